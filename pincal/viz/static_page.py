"""The 3D scene as one self-contained HTML file: a recording meshcat window and the page around it.

:class:`StaticScene` is a meshcat window that records the drawing commands instead of sending them to
a server; :func:`scene_page` writes them with the viewer JavaScript shipped in the meshcat package (so
the file needs no network), a legend, and a slider that steps through the samples. The page also
writes what the browser built into ``#pincal-scene-status`` (JSON), for people and for tests.
"""

from __future__ import annotations

import base64
import gzip
import html
import json
from pathlib import Path
from typing import Any

import numpy as np
import numpy.typing as npt

from pincal.errors import PincalError
from pincal.records import record
from pincal.viz import colormaps
from pincal.viz.visuals import CALIBRATED_COLOR, ERROR_COLORMAP, NOMINAL_COLOR, POINT_COLOR, lean_meshcat

Array = npt.NDArray[np.float64]


@record
class SceneSummary:
    """What :func:`pincal.viz.scene.draw_calibration` drew: what the legend shows and the browser test checks.

    Attributes:
        frames: Robot frames carrying shapes (node names under ``robot_nominal``/``robot_calibrated``).
        n_visuals: Shapes per robot.
        n_samples: Samples (markers, error segments and animation frames).
        magnification: Factor applied to the error segments.
        error_scale: Error [m] mapped to the top of the colour map.
        sample_before, sample_after: Per-sample error sizes [m] (for the step-through label).
        notes: What could not be drawn.
        has_points: Whether 3D points are measured (else the markers are the calibrated end effector).
        has_lengths: Whether the sample errors are lengths (else there are none to show).
        robot_difference: Largest distance [m] between a frame of the nominal robot and the same frame of the
            calibrated one, both drawn in the measurement frame, over the samples (NaN when no frame is drawn).
        workspace_postures: Postures drawn within the joint limits shown as points coloured by their predicted
            95 % bound (0 when the report holds no workspace prediction).
        workspace_low, workspace_high: The smallest and largest of those bounds [m]: the ends of their colour scale.
    """

    frames: list[str]
    n_visuals: int
    n_samples: int
    magnification: float
    error_scale: float
    sample_before: Array
    sample_after: Array
    notes: list[str]
    has_points: bool
    has_lengths: bool
    robot_difference: float = float("nan")
    workspace_postures: int = 0
    workspace_low: float = float("nan")
    workspace_high: float = float("nan")


class StaticScene:
    """A meshcat window that records drawing commands instead of sending them to a server.

    :meth:`visualizer` draws into it as ``meshcat.Visualizer(window=StaticScene())`` does; :meth:`replay` sends the
    recording to a live visualizer and :func:`scene_page` writes it as a self-contained page.
    """

    def __init__(self) -> None:
        self.commands: list[Any] = []

    def send(self, command: Any) -> None:
        """Record one meshcat command instead of sending it to a server."""
        self.commands.append(command)

    def visualizer(self) -> Recorder:
        """A visualizer drawing into this recording (:class:`Recorder`)."""
        lean_meshcat()
        from meshcat.path import Path as NodePath

        return Recorder(self, NodePath(("meshcat",)))

    def packed(self) -> list[bytes]:
        """The commands as the msgpack buffers meshcat's JavaScript decodes.

        meshcat names geometries and materials by time-based ``uuid1`` values; they are renamed here
        ``pincal-1``, ``pincal-2``, ... in order of appearance, so the same scene gives the same bytes. Numbers are
        packed in single precision, as three.js holds them anyway: half the bytes of the placements and the
        animation, and a placement still to well under a micrometre [m].
        """
        from pincal.viz.msgpack_pack import packb_renamed

        names: dict[str, str] = {}
        packed = []
        for command in self.commands:
            lowered = command.lower()
            _collect_ids(lowered, names)
            packed.append(packb_renamed(lowered, names))
        return packed

    def replay(self, vis: Any) -> None:
        """Send every recorded command to ``vis`` (e.g. ``meshcat.Visualizer()``)."""
        for command in self.commands:
            vis.window.send(command)


class Recorder:
    """What ``meshcat.Visualizer`` does to draw, into a :class:`StaticScene`: the same commands (meshcat's own
    ``commands`` module) at the same paths, without meshcat's visualizer module and the server stack it imports.

    Args:
        window: The recording.
        path: The node drawn at (a ``meshcat.path.Path``).
    """

    __slots__ = ("path", "window")

    def __init__(self, window: StaticScene, path: Any) -> None:
        self.window, self.path = window, path

    def __getitem__(self, path: str) -> Recorder:
        return Recorder(self.window, self.path.append(path))

    def set_object(self, geometry: Any, material: Any = None) -> None:
        """Place ``geometry`` (with ``material``) at this node."""
        from meshcat.commands import SetObject

        self.window.send(SetObject(geometry, material, self.path))

    def set_transform(self, matrix: Array | None = None) -> None:
        """Place this node at the (4, 4) pose ``matrix`` [m] (default the identity)."""
        from meshcat.commands import SetTransform

        self.window.send(SetTransform(np.eye(4) if matrix is None else matrix, self.path))

    def set_property(self, key: str, value: Any) -> None:
        """Set a property of this node (``visible``, ``position``, ...)."""
        from meshcat.commands import SetProperty

        self.window.send(SetProperty(key, value, self.path))

    def set_animation(self, animation: Any, play: bool = True, repetitions: int = 1) -> None:
        """Record ``animation`` (a ``meshcat.animation.Animation``)."""
        from meshcat.commands import SetAnimation

        self.window.send(SetAnimation(animation, play=play, repetitions=repetitions))

    def delete(self) -> None:
        """Delete this node."""
        from meshcat.commands import Delete

        self.window.send(Delete(self.path))


def _collect_ids(value: Any, names: dict[str, str]) -> None:
    """Name every ``uuid`` value in ``value`` (a lowered meshcat command) not yet in ``names``."""
    if isinstance(value, dict):
        uid = value.get("uuid")
        if isinstance(uid, str) and uid not in names:
            names[uid] = f"pincal-{len(names) + 1}"
        items: Any = value.values()
    elif isinstance(value, list | tuple):
        items = value
    else:
        return
    for item in items:
        if isinstance(item, dict | list | tuple):  # not the numbers: nine tenths of a scene's values
            _collect_ids(item, names)


def meshcat_javascript() -> str:
    """The meshcat viewer bundle shipped in the meshcat package (three.js included; no network)."""
    lean_meshcat()
    import meshcat

    path = Path(meshcat.__file__).parent / "viewer" / "dist" / "main.min.js"
    try:
        return path.read_text(encoding="utf-8")
    except OSError as exc:
        raise PincalError(f"the meshcat viewer JavaScript is missing ({path}): reinstall meshcat") from exc


def packed_javascript() -> str:
    """The meshcat viewer bundle gzipped and in base64 (290 kB against 850 kB: most of a page), which
    :data:`LOADER` unpacks in the browser with its own ``DecompressionStream``; ``mtime=0`` keeps the bytes the same
    from run to run."""
    return base64.b64encode(gzip.compress(meshcat_javascript().encode("utf-8"), 9, mtime=0)).decode("ascii")


#: Unpacks :func:`packed_javascript`, runs it in the page's global scope (the bundle defines ``MeshCat``), then the
#: scene's script.
LOADER = """
(async function () {
  var packed = document.getElementById("pincal-viewer").textContent;
  var bytes = Uint8Array.from(atob(packed), function (ch) { return ch.charCodeAt(0); });
  var stream = new Blob([bytes]).stream().pipeThrough(new DecompressionStream("gzip"));
  (0, eval)(await new Response(stream).text());
  pincalScene();
})();
"""


PAGE_STYLE = """
body { margin: 0; font: 13px/1.35 system-ui, sans-serif; background: linear-gradient(#fbfcfd, #c9d3df); }
#meshcat-pane { width: 100vw; height: 100vh; overflow: hidden; }
#pincal-panel { position: absolute; left: 10px; top: 10px; max-width: 390px; padding: 8px 10px;
  background: rgba(255,255,255,.88); border-radius: 6px; box-shadow: 0 1px 4px rgba(0,0,0,.25); }
#pincal-panel h1 { font-size: 14px; margin: 0 0 4px; }
#pincal-panel .key { display: inline-block; width: 11px; height: 11px; border-radius: 2px; vertical-align: -1px; }
#pincal-panel .bar { height: 9px; border-radius: 2px; margin: 2px 0 0; }
#pincal-panel .ticks { display: flex; justify-content: space-between; font-size: 11px; color: #444; }
#pincal-panel input[type=range] { width: 190px; vertical-align: middle; }
#pincal-panel button { padding: 0 6px; }
#pincal-sample-label { font-variant-numeric: tabular-nums; }
"""

PAGE_SCRIPT = """
function pincalScene() {
  var viewer = new MeshCat.Viewer(document.getElementById("meshcat-pane"));
  var commands = %(commands)s, samples = %(samples)s;
  commands.forEach(function (c) {
    var bytes = Uint8Array.from(atob(c), function (ch) { return ch.charCodeAt(0); });
    viewer.handle_command_bytearray(bytes);
  });
  var animator = viewer.animator;
  animator.play(); animator.pause();  // activate the per-sample animation, stopped at sample 0
  var slider = document.getElementById("pincal-sample"), label = document.getElementById("pincal-sample-label");
  function show(k) {
    k = Math.max(0, Math.min(samples.count - 1, k));
    slider.value = k; animator.seek(k); animator.display_progress(k);
    var errors = samples.before ? ": " + samples.before[k] + " \\u2192 " + samples.after[k] + " mm" : "";
    label.textContent = "sample " + k + errors;
  }
  slider.addEventListener("input", function () { show(+slider.value); });
  document.getElementById("pincal-prev").onclick = function () { show(+slider.value - 1); };
  document.getElementById("pincal-next").onclick = function () { show(+slider.value + 1); };
  document.addEventListener("keydown", function (e) {
    if (e.key === "ArrowLeft") show(+slider.value - 1);
    if (e.key === "ArrowRight") show(+slider.value + 1);
  });
  var start = /sample=(\\d+)/.exec(window.location.hash);
  show(start ? +start[1] : 0);
  // what the browser built, for people and for tests
  function node(path) { return viewer.scene_tree.find(["meshcat", "pincal"].concat(path)); }
  function meshes(path) { var n = 0; node(path).object.traverse(function (o) { if (o.isMesh) n++; }); return n; }
  function where(path) { return node(path).object.position.toArray(); }
  function workspacePoints() {  // the points of the workspace cloud, 0 without one
    var n = 0, root = node([]);
    if (!root.children.workspace) return 0;
    root.children.workspace.object.traverse(function (o) {
      if (o.isPoints) n += o.geometry.attributes.position.count;
    });
    return n;
  }
  var frames = Object.keys(node(["robot_calibrated"]).children), placed = {};
  frames.forEach(function (f) { placed[f] = where(["robot_calibrated", f]); });
  var status = {
    robot_nominal: meshes(["robot_nominal"]), robot_calibrated: meshes(["robot_calibrated"]), frames: frames,
    points: meshes(["samples", "points"]), error_before: meshes(["samples", "error_before"]),
    error_after: meshes(["samples", "error_after"]), animation_seconds: animator.duration,
    sample: +slider.value, current_point: where(["samples", "current"]), calibrated_frames: placed,
    webgl: !!(viewer.renderer && viewer.renderer.getContext()), workspace: workspacePoints()
  };
  var out = document.getElementById("pincal-scene-status");
  out.textContent = JSON.stringify(status);
  if (window.parent !== window) window.parent.postMessage({pincalScene: status}, "*");
}
"""


def _colour_bar(colormap: str, low_mm: float, high_mm: float) -> str:
    """A colour bar of ``colormap`` with five ticks from ``low_mm`` to ``high_mm`` [mm]."""
    stops = ", ".join("#{:02x}{:02x}{:02x}".format(*(int(255 * c) for c in rgba[:3]))
                      for rgba in colormaps.colormap(colormap, np.linspace(0, 1, 6)))
    ticks = "".join(f"<span>{v:.3g}</span>" for v in np.linspace(low_mm, high_mm, 5))
    return (f"<div class='bar' style='background: linear-gradient(to right, {stops})'></div>"
            f"<div class='ticks'>{ticks}</div>")


def workspace_text(summary: SceneSummary) -> str:
    """What the scene's workspace points show, in words (empty without them)."""
    if not summary.workspace_postures:
        return ""
    return (f"coloured dots: the predicted positions at {summary.workspace_postures} postures drawn within the joint "
            f"limits, coloured by their predicted 95 % bound, {summary.workspace_low * 1e3:.3g} to "
            f"{summary.workspace_high * 1e3:.3g}")


def _workspace_legend(summary: SceneSummary) -> str:
    """The legend of the workspace points: what they are and their colour scale [mm] (empty without them)."""
    from pincal.viz.svg_figures import BOUND_COLORMAP

    if not summary.workspace_postures:
        return ""
    return (f"<div id='pincal-workspace-legend'>{html.escape(workspace_text(summary))} mm:</div>"
            + _colour_bar(BOUND_COLORMAP, summary.workspace_low * 1e3, summary.workspace_high * 1e3))


def _legend(summary: SceneSummary, title: str) -> str:
    points = "measured point" if summary.has_points else "calibrated end effector (no 3D measurement)"
    segments = (f"<div>each sample's error, from the measured point towards each model's prediction, "
                f"magnified ×{summary.magnification:g} and coloured by size [mm]: long before calibration, "
                "short after</div>"
                + _colour_bar(ERROR_COLORMAP, 0.0, summary.error_scale * 1e3)) if summary.has_points else ""
    return f"""<div id="pincal-panel">
<h1>{html.escape(title)}</h1>
<div><span class="key" style="background:#{NOMINAL_COLOR:06x};opacity:.45"></span> nominal robot (ghost)
 &nbsp;<span class="key" style="background:#{CALIBRATED_COLOR:06x}"></span> calibrated robot
 &nbsp;<span class="key" style="background:#{POINT_COLOR:06x};border-radius:50%"></span> {points}</div>
{segments}
{_workspace_legend(summary)}
<div style="margin-top:4px"><button id="pincal-prev" title="previous sample (←)">&#9664;</button>
<input type="range" id="pincal-sample" min="0" max="{summary.n_samples - 1}" value="0">
<button id="pincal-next" title="next sample (→)">&#9654;</button>
<span id="pincal-sample-label"></span></div>
<div class="ticks">steps through the {summary.n_samples} samples (error before → after); drag to orbit</div>
<pre id="pincal-scene-status" hidden></pre>
</div>"""


def _mm(size: float) -> str:
    """A sample's error size [m] as the slider's label shows it [mm]; a dash for a sample with no reading."""
    return f"{size * 1e3:.4g}" if np.isfinite(size) else "–"


def provenance_html(provenance: dict[str, Any] | None) -> str:
    """A page's provenance (the pincal version, the input files with their SHA-256, the options: docs/check.md,
    docs/calibrated_urdf.md) as a folded block of its JSON; empty when there is none."""
    if not provenance:
        return ""
    text = html.escape(json.dumps(provenance, indent=1))
    version = html.escape(str(provenance.get("pincal_version")))
    return (f'<details class="provenance"><summary>Provenance: pincal {version}'
            f", the input files with their SHA-256, the options</summary><pre>{text}</pre></details>")


def scene_page(scene: StaticScene, summary: SceneSummary, title: str, provenance: dict[str, Any] | None = None) -> str:
    """A self-contained HTML page of the recorded scene, with a legend and a sample slider; ``provenance`` recorded
    in a comment."""
    commands = json.dumps([base64.b64encode(c).decode("ascii") for c in scene.packed()])
    samples = json.dumps({"count": summary.n_samples,
                          "before": [_mm(v) for v in summary.sample_before] if summary.has_lengths else None,
                          "after": [_mm(v) for v in summary.sample_after] if summary.has_lengths else None})
    script = PAGE_SCRIPT % {"commands": commands, "samples": samples}
    return (f'<!DOCTYPE html>\n<html lang="en"><head><meta charset="utf-8"><title>{html.escape(title)}</title>'
            f"<style>{PAGE_STYLE}</style></head>\n<body>\n<div id=\"meshcat-pane\"></div>\n"
            f"{_legend(summary, title)}\n<script id=\"pincal-viewer\" type=\"application/gzip\">{packed_javascript()}"
            f"</script>\n<script>{script}{LOADER}</script>\n"
            f"{_provenance_comment(provenance)}</body></html>\n")


def _provenance_comment(provenance: dict[str, Any] | None) -> str:
    """``provenance`` as an HTML comment (its JSON, ``--`` escaped), or nothing."""
    if not provenance:
        return ""
    return "<!-- pincal provenance: " + json.dumps(provenance).replace("--", "-\\u002d") + " -->\n"
