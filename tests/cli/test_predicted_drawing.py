"""The predicted uncertainty drawn as a user runs it (docs/predicted_accuracy.md): ``pincal report`` shows the
report's workspace postures in a figure (two projections coloured by their predicted 95 % bound, and the held-out
postures' bound against their actual error) and as a point cloud in the 3D scene; a report JSON of an older pincal,
without a workspace prediction, still renders, without them.

A Delta is simulated (30 fit + 10 held-out postures) and calibrated (``--report r.json``); ``pincal report`` calibrates
the same file again (the same figures: a calibration is deterministic) and renders ``r.json`` with its
``predicted_workspace`` and ``predicted_held_out`` removed.
"""

from __future__ import annotations

import base64
import html
import json
import re
from pathlib import Path
from typing import Any

import numpy as np
import pytest
import umsgpack
from browser import render, served
from conftest import run_pincal
from matplotlib import colormaps

FIGURE = re.compile(r'<div id="predicted-uncertainty"><figure>(<svg .*?</svg>)</figure><p class="caption">([^<]*)</p>'
                    r'</div>', re.S)


def _ok(done: Any) -> None:
    assert done.returncode == 0, done.stdout + done.stderr


@pytest.fixture(scope="module")
def pages(tmp_path_factory: pytest.TempPathFactory) -> dict[str, Any]:
    """The report JSON (``r.json``), the page of ``pincal report`` on the data (``page``) and the page of the JSON
    without its predictions (``old``)."""
    root = tmp_path_factory.mktemp("drawing")
    data = root / "sim" / "measurements.csv"
    _ok(run_pincal("simulate", "delta", "--samples", "30", "--test-samples", "10", "--seed", "4", "--quiet",
                   "--out", str(root / "sim")))
    _ok(run_pincal("calibrate", "delta", str(data), "--report", str(root / "r.json")))
    _ok(run_pincal("report", "delta", str(data), "--out", str(root / "page.html"), "--quiet"))
    report = json.loads((root / "r.json").read_text(encoding="utf-8"))
    older = {k: v for k, v in report.items() if k not in ("predicted_workspace", "predicted_held_out")}
    (root / "old.json").write_text(json.dumps(older), encoding="utf-8")
    _ok(run_pincal("report", "delta", str(data), "--result", str(root / "old.json"), "--out", str(root / "old.html"),
                   "--quiet"))
    return {"root": root, "report": report, "page": (root / "page.html").read_text(encoding="utf-8"),
            "old": (root / "old.html").read_text(encoding="utf-8")}


def _scene(page: str) -> str:
    match = re.search(r'<iframe id="scene"[^>]*srcdoc="([^"]*)"', page)
    assert match, "the report holds no 3D scene"
    return html.unescape(match.group(1))


def _commands(scene: str) -> list[dict[str, Any]]:
    """The meshcat commands of a scene page, decoded as the viewer's JavaScript does."""
    match = re.search(r"var commands = (\[.*?\]), samples =", scene)
    assert match
    return [umsgpack.unpackb(base64.b64decode(c)) for c in json.loads(match.group(1))]


def _attribute(geometry: dict[str, Any], name: str) -> np.ndarray:
    """A point cloud's attribute (N, 3), from meshcat's column-major float32 buffer."""
    return np.frombuffer(geometry["data"]["attributes"][name]["array"].data, dtype=np.float32).reshape(-1, 3)


def test_the_page_draws_the_workspace_bounds_and_the_held_out_bounds_against_their_errors(pages: dict[str, Any]
                                                                                          ) -> None:
    space, held = pages["report"]["predicted_workspace"], pages["report"]["predicted_held_out"]
    match = FIGURE.search(pages["page"])
    assert match, "no predicted-uncertainty figure in the page"
    drawing = match.group(1)
    assert len(drawing) < 50_000  # a few tens of kB of vector graphics
    width = float(re.search(r'width="([0-9.]+)"', drawing).group(1))  # type: ignore[union-attr]
    assert width >= 900  # three panels: two projections and the held-out postures
    caption = match.group(2)
    assert f"at {space['postures']} postures drawn within the joint limits" in caption
    assert f"median {space['median_bound'] * 1e3:.3f} mm, largest {space['max_bound'] * 1e3:.3f} mm" in caption
    errors = {e["sample"]: e["after"] for e in pages["report"]["sample_errors"] if e["set"] == "test"}
    inside = sum(errors[s["sample"]] <= s["bound"] for s in held["samples_predicted"])
    assert f"held out: {inside} of 10 errors within their bound" in caption
    # each posture of a bound a dot in both projections, coloured on viridis: the smallest bound at one end, the
    # largest at the other; each held-out posture a dot against its bound
    bounds = np.array([np.nan if b is None else b for b in space["bounds"]], dtype=float)
    dots = re.findall(r'<circle cx="[^"]+" cy="[^"]+" r="[^"]+" fill="(#[0-9a-f]{6})"', drawing)
    judged = [s for s in held["samples_predicted"] if s["bound"] is not None]
    assert len(dots) == 2 * int(np.isfinite(bounds).sum()) + len(judged) + 2  # and the legend's two dots
    for end in (0.0, 1.0):
        colour = "#{:02x}{:02x}{:02x}".format(*(round(255 * c) for c in colormaps["viridis"](end)[:3]))
        assert dots.count(colour) >= 2


def test_the_scene_holds_the_workspace_points_coloured_by_their_bound(pages: dict[str, Any], tmp_path: Path
                                                                      ) -> None:
    space = pages["report"]["predicted_workspace"]
    scene = _scene(pages["page"])
    (cloud,) = [c for c in _commands(scene) if c["type"] == "set_object" and c["path"] == "/meshcat/pincal/workspace"]
    positions = _attribute(cloud["object"]["geometries"][0], "position")
    colours = _attribute(cloud["object"]["geometries"][0], "color")
    np.testing.assert_allclose(positions, space["positions"], atol=1e-6)  # [m], the measurement frame
    bounds = np.array(space["bounds"])
    for k, end in ((int(np.argmin(bounds)), 0.0), (int(np.argmax(bounds)), 1.0)):
        np.testing.assert_allclose(colours[k], colormaps["viridis"](end)[:3], atol=1e-6)
    legend = (f"coloured by their predicted 95 % bound, {bounds.min() * 1e3:.3g} to {bounds.max() * 1e3:.3g} mm")
    assert legend in scene and legend in pages["page"]  # the scene's legend and the report's caption
    (tmp_path / "scene.html").write_text(scene, encoding="utf-8")
    with served(tmp_path) as base:
        shown = render(f"{base}scene.html", tmp_path / "scene.png")
    status = re.search(r'<pre id="pincal-scene-status"[^>]*>(.*?)</pre>', shown.dom, re.S)
    assert status and json.loads(html.unescape(status.group(1)))["workspace"] == space["postures"]


def test_a_report_without_a_workspace_prediction_renders_without_the_drawing(pages: dict[str, Any]) -> None:
    old = pages["old"]
    assert "predicted-uncertainty" not in old and "coloured dots" not in old
    assert not any(c["path"] == "/meshcat/pincal/workspace" for c in _commands(_scene(old)))
    assert "<h2>Parameters</h2>" in old and "3D scene" in old  # the rest of the page is there
    assert 0 < len(pages["page"]) - len(old) < 60_000  # what the drawing adds to the page [bytes]
