"""A calibration in 3D with meshcat: the nominal robot ghosted, the calibrated robot solid, the measured
points, and each sample's error before and after calibration as a short segment coloured by its size.

The same drawing goes to a running meshcat server (``meshcat.Visualizer()``) or into one
self-contained HTML file: :class:`StaticScene` is a meshcat window that records the commands, and
:func:`scene_page` writes them with the viewer JavaScript shipped in the meshcat package, so the file
needs no network. One animation frame per sample steps through the samples: in meshcat's controls,
``Animations › default › time`` is the sample index; the static page adds a slider.

Errors are millimetres on a robot of decimetres, so the segments are magnified by a round factor
(stated in the legend). Everything is drawn in the measurement frame: the nominal robot at the
identity base, the calibrated one at its calibrated base.
"""

from __future__ import annotations

import argparse
import base64
import html
import json
import math
import sys
import xml.etree.ElementTree as ET
from dataclasses import dataclass
from pathlib import Path
from typing import Any, TextIO

import numpy as np
import numpy.typing as npt
import pinocchio as pin

from pincal.calibration import choose_parameters, measurements_for, observations_from
from pincal.dataset import Dataset, read_dataset
from pincal.errors import ConvergenceError, DataError, PincalError, RobotFileError, listing
from pincal.measurements import Pose, Position
from pincal.problem import CalibrationProblem
from pincal.robot import Robot, load_robot
from pincal.urdf import origin_to_se3

Array = npt.NDArray[np.float64]

NOMINAL_COLOR = 0x4f86c6
CALIBRATED_COLOR = 0xe8833a
POINT_COLOR = 0x1e1e1e
CURRENT_COLOR = 0xffd21f
GHOST_OPACITY = 0.3
#: Colour map of the error segments, from 0 to the largest error before calibration.
ERROR_COLORMAP = "RdYlGn_r"
#: Mesh files larger than this are not embedded (the link's collision mesh is tried instead).
MAX_MESH_BYTES = 400_000
#: Fraction of a sample's animation second during which its pose is held (the rest is the move).
HOLD = 0.9
#: Longest magnified error segment, as a fraction of the scene's size.
SEGMENT_FRACTION = 0.08


# --- progress --------------------------------------------------------------------------------------
class Progress:
    """A one-line progress bar for long loops, on stderr when it is a terminal (or on ``stream``).

    Use as a context manager; ``quiet=True`` silences it.
    """

    def __init__(self, label: str, total: int, quiet: bool = False, stream: TextIO | None = None) -> None:
        self.label, self.total, self.done = label, total, 0
        self.stream = sys.stderr if stream is None else stream
        self.active = not quiet and total > 0 and (stream is not None or self.stream.isatty())
        self._shown = -1

    def __enter__(self) -> Progress:
        self._draw()
        return self

    def advance(self, n: int = 1) -> None:
        self.done = min(self.total, self.done + n)
        self._draw()

    def _draw(self) -> None:
        if not self.active:
            return
        filled = 30 * self.done // self.total
        if filled == self._shown and self.done != self.total:
            return
        self._shown = filled
        self.stream.write(f"\r{self.label} [{'#' * filled}{'.' * (30 - filled)}] {self.done}/{self.total}")
        self.stream.flush()

    def __exit__(self, *exc: object) -> None:
        if self.active:
            self.stream.write("\n")
            self.stream.flush()


# --- robot shapes ----------------------------------------------------------------------------------
@dataclass(frozen=True)
class Visual:
    """One shape fixed to a Pinocchio frame.

    Attributes:
        frame_id: The frame (a URDF link, or a joint for the skeleton fallback).
        name: Node name, unique within the frame.
        geometry: A ``meshcat.geometry`` geometry.
        placement: (4, 4) pose of the shape in the frame [m] (mesh scale included).
    """

    frame_id: int
    name: str
    geometry: Any
    placement: Array


def _cylinder_along_z(origin: pin.SE3) -> Array:
    # meshcat cylinders run along y, URDF ones along z
    return origin.homogeneous @ pin.SE3(pin.utils.rotate("x", math.pi / 2), np.zeros(3)).homogeneous


def resolve_mesh(uri: str, urdf_dir: Path) -> Path | None:
    """Local file of a URDF mesh reference (``package://``, ``file://`` or relative); None if absent.

    ``package://pkg/rest`` is looked for as ``pkg/rest`` beside the URDF file and in each of its parent
    directories (the layout of example-robot-data); nothing is ever downloaded.
    """
    if uri.startswith("file://"):
        path = Path(uri[len("file://"):])
        return path if path.is_file() else None
    if uri.startswith("package://"):
        package, _, rest = uri[len("package://"):].partition("/")
        for folder in (urdf_dir, *urdf_dir.parents):
            for candidate in (folder / package / rest, folder / rest if folder.name == package else None):
                if candidate is not None and candidate.is_file():
                    return candidate
        return None
    path = urdf_dir / uri
    return path if path.is_file() else None


def _mesh_geometry(path: Path) -> Any:
    import meshcat.geometry as mg

    loaders = {".stl": mg.StlMeshGeometry, ".obj": mg.ObjMeshGeometry, ".dae": mg.DaeMeshGeometry}
    return loaders[path.suffix.lower()].from_file(str(path))


def _mesh_visual(link: ET.Element, visual: ET.Element, urdf_dir: Path, budget: int) -> tuple[Any, Array] | None:
    """The visual's mesh, or the link's collision mesh, that meshcat can load within ``budget`` bytes.

    STL and OBJ come first: three.js's Collada loader re-orients Z-up files.
    """
    candidates = [visual, *link.findall("collision")]
    found = []
    for element in candidates:
        mesh = element.find("geometry/mesh")
        if mesh is None:
            continue
        path = resolve_mesh(mesh.get("filename", ""), urdf_dir)
        if path is None or path.suffix.lower() not in (".stl", ".obj", ".dae") or path.stat().st_size > budget:
            continue
        scale = [float(v) for v in mesh.get("scale", "1 1 1").split()]
        placement = origin_to_se3(element.find("origin"), f"link '{link.get('name')}' mesh").homogeneous
        found.append((path.suffix.lower() == ".dae", path, placement @ np.diag([*scale, 1.0])))
    if not found:
        return None
    _, path, placement = min(found, key=lambda item: item[0])
    return _mesh_geometry(path), placement


def robot_visuals(robot: Robot, max_mesh_bytes: int = MAX_MESH_BYTES) -> tuple[list[Visual], list[str]]:
    """The robot's URDF visuals as meshcat shapes, and notes on what could not be drawn.

    Boxes, cylinders and spheres are drawn as such; meshes are embedded when their file is found
    locally and is small enough, else the link's collision mesh, else they are skipped (noted). A robot
    with nothing drawable gets a skeleton: a sphere per joint and a rod to each child joint.
    """
    import meshcat.geometry as mg

    model = robot.model
    visuals: list[Visual] = []
    notes: list[str] = []
    root = None
    if robot.source is not None:
        try:
            root = ET.fromstring(Path(robot.source).read_text(encoding="utf-8"))
        except (OSError, ET.ParseError) as exc:
            raise RobotFileError(f"cannot read the visuals of '{robot.source}': {exc}") from None
    for link in root.findall("link") if root is not None else []:
        name = link.get("name", "")
        if not model.existFrame(name, pin.FrameType.BODY):
            continue
        fid = int(model.getFrameId(name, pin.FrameType.BODY))
        for k, visual in enumerate(link.findall("visual")):
            origin = origin_to_se3(visual.find("origin"), f"link '{name}' visual")
            shape = visual.find("geometry/*")
            tag = shape.tag if shape is not None else "none"
            values = [float(v) for v in (shape.get("size") or "").split()] if shape is not None else []
            if shape is not None and tag == "box" and len(values) == 3:
                visuals.append(Visual(fid, f"visual_{k}", mg.Box(values), origin.homogeneous))
            elif shape is not None and tag == "cylinder":
                cylinder = mg.Cylinder(float(shape.get("length", 0)), float(shape.get("radius", 0)))
                visuals.append(Visual(fid, f"visual_{k}", cylinder, _cylinder_along_z(origin)))
            elif shape is not None and tag == "sphere":
                visuals.append(Visual(fid, f"visual_{k}", mg.Sphere(float(shape.get("radius", 0))),
                                      origin.homogeneous))
            elif tag == "mesh" and robot.source is not None:
                mesh = _mesh_visual(link, visual, Path(robot.source).parent, max_mesh_bytes)
                if mesh is None:
                    notes.append(f"link '{name}': mesh '{shape.get('filename') if shape is not None else ''}' "
                                 f"not drawn (not found locally, or over {max_mesh_bytes // 1000} kB)")
                else:
                    visuals.append(Visual(fid, f"visual_{k}", *mesh))
            else:
                notes.append(f"link '{name}': visual {k} ({tag}) not drawn")
    if not visuals:
        visuals = _skeleton(robot)
        notes.append("no drawable visuals: the robot is drawn as a skeleton of its joints")
    return visuals, notes


def _skeleton(robot: Robot) -> list[Visual]:
    import meshcat.geometry as mg

    model = robot.model
    data = model.createData()
    pin.forwardKinematics(model, data, robot.q_reference)
    size = max((float(np.linalg.norm(data.oMi[j].translation)) for j in range(model.njoints)), default=0.0) or 1.0
    radius = 0.012 * size
    out = []
    for j in range(1, model.njoints):
        fid = int(model.getFrameId(model.names[j], pin.FrameType.JOINT))
        out.append(Visual(fid, "joint", mg.Sphere(2 * radius), np.eye(4)))
        offset = model.jointPlacements[j].translation
        if np.linalg.norm(offset) > 1e-9:
            parent = model.parents[j]
            parent_frame = 0 if parent == 0 else int(model.getFrameId(model.names[parent], pin.FrameType.JOINT))
            rod = mg.Cylinder(float(np.linalg.norm(offset)), radius)
            out.append(Visual(parent_frame, f"rod_to_{model.names[j]}", rod, _segment_pose(np.zeros(3), offset)))
    return out


def _segment_pose(start: Array, end: Array) -> Array:
    """Pose of a meshcat cylinder (axis y, centred) spanning ``start`` → ``end``."""
    axis = end - start
    length = float(np.linalg.norm(axis))
    y = axis / length if length > 0 else np.array([0.0, 0.0, 1.0])
    helper = np.array([1.0, 0.0, 0.0]) if abs(y[0]) < 0.9 else np.array([0.0, 1.0, 0.0])
    x = np.cross(helper, y)
    x /= np.linalg.norm(x)
    pose = np.eye(4)
    pose[:3, :3] = np.column_stack([x, y, np.cross(x, y)])
    pose[:3, 3] = (start + end) / 2
    return pose


def _translation(p: Array) -> Array:
    pose = np.eye(4)
    pose[:3, 3] = p
    return pose


# --- what a calibration shows ----------------------------------------------------------------------
@dataclass
class CalibrationView:
    """One calibration as the scene and the report show it.

    Attributes:
        problem: The calibration samples (the ``train`` set) and models.
        x: Estimated deviations [m, rad], in ``problem.parameters`` order.
        report: The results dictionary (:func:`pincal.calibration.report_dict`).
        errors_before, errors_after: Per measurement key, (N, rows) predicted − measured [m, rad] at
            the nominal robot and at ``x``.
    """

    problem: CalibrationProblem
    x: Array
    report: dict[str, Any]
    errors_before: dict[str, Array]
    errors_after: dict[str, Array]

    @classmethod
    def from_calibration(cls, calibration: Any) -> CalibrationView:
        """From a :class:`pincal.workflow.Calibration`."""
        result = calibration.result
        return cls(calibration.problem, result.x, calibration.report, result.errors_before, result.errors_after)

    @classmethod
    def from_result(cls, robot: Robot, dataset: Dataset, report: dict[str, Any],
                    parameter_spec: list[str] | None = None, sigma: float | None = None) -> CalibrationView:
        """From a results JSON written earlier (``pincal calibrate --report``) and its dataset.

        Raises:
            DataError: the JSON is not a pincal report, or its parameters are not those chosen by
                ``parameter_spec`` (pass the same ``--parameters`` as for the calibration).
        """
        if not isinstance(report.get("parameters"), dict):
            raise DataError("the result JSON has no 'parameters': expected a report written by "
                            "'pincal calibrate --report'")
        train = dataset.of_set("train") if "train" in dataset.sets else dataset
        models = measurements_for(robot, list(dataset.measurements), dataset.joint_names, sigma)
        pset = choose_parameters(robot, models, parameter_spec)
        if set(pset.names) != set(report["parameters"]):
            missing = sorted(set(report["parameters"]) - set(pset.names))
            extra = sorted(set(pset.names) - set(report["parameters"]))
            raise DataError(f"the result's parameters differ from those chosen here (in the result only: "
                            f"{listing(missing) or '-'}; here only: {listing(extra) or '-'}): pass the same "
                            "--parameters as for the calibration")
        x = np.array([float(report["parameters"][name]["value"]) for name in pset.names])
        obs = observations_from(robot, train.joint_names, train.joints, train.measurements, models)
        problem = CalibrationProblem(robot, pset, models, obs)
        before = problem.evaluate(np.zeros(len(pset)), jacobian=False).errors
        after = problem.evaluate(x, jacobian=False).errors
        return cls(problem, x, report, before, after)

    def base_placement(self) -> pin.SE3:
        """The calibrated robot's base in the measurement frame (identity without a base parameter)."""
        problem = self.problem
        if not problem.base:
            return pin.SE3.Identity()
        return pin.exp6(problem.parameters.placement_delta(self.x, problem.base))

    def point_errors(self) -> tuple[Array | None, Array | None, Array | None]:
        """Measured points (N, 3) [m] and the error vectors before and after (N, 3) [m], from the first
        position or pose measurement; three Nones when no 3D point is measured."""
        for m in self.problem.measurements:
            if isinstance(m, (Position, Pose)):
                points = self.problem.observations.values[m.key][:, :3]
                return points, self.errors_before[m.key][:, :3], self.errors_after[m.key][:, :3]
        return None, None, None

    @property
    def has_lengths(self) -> bool:
        """True when some measurement is a length (position, pose, distance): sample errors in metres."""
        return any(key.split(":", 1)[0] in ("position", "pose") or key.startswith("distance")
                   for key in self.errors_before)

    def sample_errors(self) -> tuple[Array, Array]:
        """Per-sample error size before and after [m]: the RMS over the length-type measurements
        (positions, pose positions, distances); zeros when there are none."""
        def sizes(errors: dict[str, Array]) -> Array:
            parts = []
            for key, err in errors.items():
                kind = key.split(":", 1)[0]
                if kind in ("position", "pose"):
                    parts.append(np.linalg.norm(err[:, :3], axis=1))
                elif kind.startswith("distance"):
                    parts.append(np.abs(err[:, 0]))
            n = self.problem.observations.n_samples
            return np.sqrt(np.mean(np.square(parts), axis=0)) if parts else np.zeros(n)
        return sizes(self.errors_before), sizes(self.errors_after)


def configurations(view: CalibrationView, quiet: bool = True) -> tuple[Robot, Array, Robot, Array]:
    """The nominal and calibrated robots and their closed configurations (N, nq) at every sample."""
    problem = view.problem
    nominal = problem.robot
    calibrated = problem.robot_at(view.x)
    qa_nominal = problem.actuated_values(np.zeros(len(problem.parameters)))
    qa_calibrated = problem.actuated_values(view.x)
    n = qa_nominal.shape[0]
    q_nominal = np.empty((n, nominal.model.nq))
    q_calibrated = np.empty((n, calibrated.model.nq))
    with Progress("forward kinematics", n, quiet) as progress:
        for k in range(n):
            try:
                q_nominal[k] = nominal.solve_fk(qa_nominal[k])
                q_calibrated[k] = calibrated.solve_fk(qa_calibrated[k], q_nominal[k])
            except ConvergenceError as exc:
                raise ConvergenceError(f"sample {k}: {exc}") from None
            progress.advance()
    return nominal, q_nominal, calibrated, q_calibrated


# --- the scene -------------------------------------------------------------------------------------
@dataclass
class SceneSummary:
    """What was drawn: the parts the browser test and the legends check against.

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


def _nice_factor(value: float) -> float:
    """The largest 1-2-5 number not above ``value`` (at least 1)."""
    if not math.isfinite(value) or value <= 1:
        return 1.0
    exponent = math.floor(math.log10(value))
    return max(f * 10.0 ** exponent for f in (1, 2, 5) if f * 10.0 ** exponent <= value)


def error_colors(values: Array, scale: float) -> list[int]:
    """Colours (0xRRGGBB) of errors ``values`` [m] on :data:`ERROR_COLORMAP` from 0 to ``scale``."""
    import matplotlib

    cmap = matplotlib.colormaps[ERROR_COLORMAP]
    rgba = cmap(np.clip(np.asarray(values) / (scale or 1.0), 0.0, 1.0))
    return [int(r * 255) << 16 | int(g * 255) << 8 | int(b * 255) for r, g, b, _ in np.atleast_2d(rgba)]


def _frame_poses(robot: Robot, qs: Array, frame_ids: list[int], base: Array) -> dict[int, Array]:
    model = robot.model
    data = model.createData()
    poses = {fid: np.empty((len(qs), 4, 4)) for fid in frame_ids}
    for k, q in enumerate(qs):
        pin.forwardKinematics(model, data, q)
        for fid in frame_ids:
            poses[fid][k] = base @ pin.updateFramePlacement(model, data, fid).homogeneous
    return poses


def draw_calibration(vis: Any, view: CalibrationView, quiet: bool = True,
                     max_mesh_bytes: int = MAX_MESH_BYTES) -> SceneSummary:
    """Draw ``view`` into a meshcat ``Visualizer`` (live, or over a :class:`StaticScene`).

    Nodes under ``pincal/``: ``robot_nominal/<frame>/<shape>`` (ghost), ``robot_calibrated/...``
    (solid), ``samples/points/<k>`` (measured points; the calibrated end effector when nothing 3D is
    measured), ``samples/error_before/<k>`` and ``samples/error_after/<k>`` (magnified segments from
    the measured point towards each model's prediction), ``samples/current`` (the animated
    highlight). The animation has one frame per sample (time = sample index, in seconds).
    """
    import meshcat.geometry as mg
    from meshcat.animation import Animation

    nominal, q_nominal, calibrated, q_calibrated = configurations(view, quiet)
    visuals, notes = robot_visuals(nominal, max_mesh_bytes)
    frame_ids = sorted({v.frame_id for v in visuals})
    names = {fid: str(nominal.model.frames[fid].name).replace("/", "_") for fid in frame_ids}
    base = view.base_placement().homogeneous
    poses = {"robot_nominal": _frame_poses(nominal, q_nominal, frame_ids, np.eye(4)),
             "robot_calibrated": _frame_poses(calibrated, q_calibrated, frame_ids, base)}
    points, before, after = view.point_errors()
    has_points = points is not None
    if points is None:
        ee = [int(calibrated.frame_id(calibrated.end_effector))]
        points = _frame_poses(calibrated, q_calibrated, ee, base)[ee[0]][:, :3, 3]
    n = len(points)
    cloud = np.vstack([points, *(p[:, :3, 3] for p in poses["robot_nominal"].values())])
    radius = max(float(np.linalg.norm(cloud.max(axis=0) - cloud.min(axis=0))) / 2, 1e-3)
    sample_before, sample_after = view.sample_errors()
    scale = float(max(sample_before.max(initial=0.0), sample_after.max(initial=0.0)))
    largest = float(np.linalg.norm(before, axis=1).max(initial=0.0)) if before is not None else 0.0
    magnification = _nice_factor(SEGMENT_FRACTION * 2 * radius / largest) if largest > 0 else 1.0

    root = vis["pincal"]
    for group, color, opacity in (("robot_nominal", NOMINAL_COLOR, GHOST_OPACITY),
                                  ("robot_calibrated", CALIBRATED_COLOR, 1.0)):
        for v in visuals:
            node = root[group][names[v.frame_id]][v.name]
            node.set_object(v.geometry, mg.MeshPhongMaterial(color=color, opacity=opacity, transparent=opacity < 1))
            node.set_transform(v.placement)
        for fid in frame_ids:
            root[group][names[fid]].set_transform(poses[group][fid][0])
    thickness = 0.004 * radius
    with Progress("scene samples", n, quiet) as progress:
        for k in range(n):
            tag = f"{k:03d}"
            root["samples/points"][tag].set_object(mg.Sphere(1.6 * thickness), mg.MeshPhongMaterial(color=POINT_COLOR))
            root["samples/points"][tag].set_transform(_translation(points[k]))
            for group, errors in (("error_before", before), ("error_after", after)):
                if errors is None:
                    continue
                end = points[k] + magnification * errors[k]
                length = float(np.linalg.norm(end - points[k]))
                color = error_colors(np.array([np.linalg.norm(errors[k])]), scale)[0]
                root["samples"][group][tag].set_object(mg.Cylinder(max(length, 1e-9), thickness),
                                                       mg.MeshLambertMaterial(color=color))
                root["samples"][group][tag].set_transform(_segment_pose(points[k], end))
            progress.advance()
    current = root["samples/current"]
    current.set_object(mg.Sphere(5 * thickness), mg.MeshLambertMaterial(color=CURRENT_COLOR, opacity=0.45))
    current.set_transform(_translation(points[0]))

    animation = Animation(default_framerate=1)
    moving = {group: [fid for fid in frame_ids if np.ptp(poses[group][fid], axis=0).max() > 1e-12]
              for group in poses}
    for k in range(n):
        for t in (k, k + HOLD):
            with animation.at_frame(root, t) as frame:
                for group, fids in moving.items():
                    for fid in fids:
                        frame[group][names[fid]].set_transform(poses[group][fid][k])
                frame["samples/current"].set_transform(_translation(points[k]))
    vis.set_animation(animation, play=False, repetitions=1)

    _set_camera(vis, cloud)
    return SceneSummary([names[f] for f in frame_ids], len(visuals), n, magnification, scale, sample_before,
                        sample_after, notes, has_points, view.has_lengths)


def _set_camera(vis: Any, cloud: Array) -> None:
    """Centre the scene on ``cloud`` (N, 3) [m] (meshcat's camera orbits the world origin) and place the
    camera at the front right, 20° above, just far enough for every point to fit a 4:3 view (meshcat's
    camera: 75° vertical field)."""
    center = (cloud.min(axis=0) + cloud.max(axis=0)) / 2
    vis["pincal"].set_transform(_translation(-center))
    toward = np.array([1.0, 0.7, 0.45]) / np.linalg.norm([1.0, 0.7, 0.45])  # from the centre to the camera
    right = np.cross(-toward, [0.0, 0.0, 1.0])
    right /= np.linalg.norm(right)
    up = np.cross(right, -toward)
    half = 0.85 * math.tan(math.radians(75.0 / 2))  # 15 % margin for the shapes around the points
    relative = cloud - center
    needed = relative @ toward + np.maximum(np.abs(relative @ up) / half, np.abs(relative @ right) / (half * 4 / 3))
    offset = max(float(needed.max()), 1e-3) * toward
    vis["/Cameras/default"].set_transform(np.eye(4))
    # the camera sits in a y-up frame turned +90° about x: world (x, y, z) is (x, z, -y) there
    vis["/Cameras/default/rotated/<object>"].set_property("position", [offset[0], offset[2], -offset[1]])
    vis["/Grid"].set_property("visible", False)  # a 20 m grid says nothing at the scale of a calibration
    vis["/Axes"].set_property("visible", False)
    vis["/Background"].set_property("visible", False)  # the page's own background shows through


# --- static HTML -----------------------------------------------------------------------------------
class StaticScene:
    """A meshcat window that records drawing commands instead of sending them to a server.

    ``meshcat.Visualizer(window=StaticScene())`` draws as usual; :meth:`replay` sends the recording to
    a live visualizer and :func:`scene_page` writes it as a self-contained page.
    """

    def __init__(self) -> None:
        self.commands: list[Any] = []

    def send(self, command: Any) -> None:
        self.commands.append(command)

    def visualizer(self) -> Any:
        import meshcat

        return meshcat.Visualizer(window=self)

    def packed(self) -> list[bytes]:
        """The commands as the msgpack buffers meshcat's JavaScript decodes."""
        import umsgpack

        return [umsgpack.packb(command.lower()) for command in self.commands]

    def replay(self, vis: Any) -> None:
        """Send every recorded command to ``vis`` (e.g. ``meshcat.Visualizer()``)."""
        for command in self.commands:
            vis.window.send(command)


def meshcat_javascript() -> str:
    """The meshcat viewer bundle shipped in the meshcat package (three.js included; no network)."""
    import meshcat

    path = Path(meshcat.__file__).parent / "viewer" / "dist" / "main.min.js"
    try:
        return path.read_text(encoding="utf-8")
    except OSError as exc:
        raise PincalError(f"the meshcat viewer JavaScript is missing ({path}): reinstall meshcat") from exc


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
var viewer = new MeshCat.Viewer(document.getElementById("meshcat-pane"));
(function () {
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
  var frames = Object.keys(node(["robot_calibrated"]).children), placed = {};
  frames.forEach(function (f) { placed[f] = where(["robot_calibrated", f]); });
  var status = {
    robot_nominal: meshes(["robot_nominal"]), robot_calibrated: meshes(["robot_calibrated"]), frames: frames,
    points: meshes(["samples", "points"]), error_before: meshes(["samples", "error_before"]),
    error_after: meshes(["samples", "error_after"]), animation_seconds: animator.duration,
    sample: +slider.value, current_point: where(["samples", "current"]), calibrated_frames: placed,
    webgl: !!(viewer.renderer && viewer.renderer.getContext())
  };
  var out = document.getElementById("pincal-scene-status");
  out.textContent = JSON.stringify(status);
  if (window.parent !== window) window.parent.postMessage({pincalScene: status}, "*");
})();
"""


def _legend(summary: SceneSummary, title: str) -> str:
    from matplotlib import colormaps

    cmap = colormaps[ERROR_COLORMAP]
    stops = ", ".join("#{:02x}{:02x}{:02x}".format(*(int(255 * c) for c in cmap(t)[:3])) for t in np.linspace(0, 1, 6))
    scale_mm = summary.error_scale * 1e3
    ticks = "".join(f"<span>{v:.3g}</span>" for v in np.linspace(0, scale_mm, 5))
    points = "measured point" if summary.has_points else "calibrated end effector (no 3D measurement)"
    segments = (f"<div>each sample's error, from the measured point towards each model's prediction, "
                f"magnified ×{summary.magnification:g} and coloured by size [mm]: long before calibration, "
                "short after</div>"
                f"<div class='bar' style='background: linear-gradient(to right, {stops})'></div>"
                f"<div class='ticks'>{ticks}</div>") if summary.has_points else ""
    return f"""<div id="pincal-panel">
<h1>{html.escape(title)}</h1>
<div><span class="key" style="background:#{NOMINAL_COLOR:06x};opacity:.45"></span> nominal robot (ghost)
 &nbsp;<span class="key" style="background:#{CALIBRATED_COLOR:06x}"></span> calibrated robot
 &nbsp;<span class="key" style="background:#{POINT_COLOR:06x};border-radius:50%"></span> {points}</div>
{segments}
<div style="margin-top:4px"><button id="pincal-prev" title="previous sample (←)">&#9664;</button>
<input type="range" id="pincal-sample" min="0" max="{summary.n_samples - 1}" value="0">
<button id="pincal-next" title="next sample (→)">&#9654;</button>
<span id="pincal-sample-label"></span></div>
<div class="ticks">steps through the {summary.n_samples} samples (error before → after); drag to orbit</div>
<pre id="pincal-scene-status" hidden></pre>
</div>"""


def scene_page(scene: StaticScene, summary: SceneSummary, title: str) -> str:
    """A self-contained HTML page of the recorded scene, with a legend and a sample slider."""
    commands = json.dumps([base64.b64encode(c).decode("ascii") for c in scene.packed()])
    samples = json.dumps({"count": summary.n_samples,
                          "before": [f"{v * 1e3:.4g}" for v in summary.sample_before] if summary.has_lengths else None,
                          "after": [f"{v * 1e3:.4g}" for v in summary.sample_after] if summary.has_lengths else None})
    script = PAGE_SCRIPT % {"commands": commands, "samples": samples}
    return (f'<!DOCTYPE html>\n<html lang="en"><head><meta charset="utf-8"><title>{html.escape(title)}</title>'
            f"<style>{PAGE_STYLE}</style></head>\n<body>\n<div id=\"meshcat-pane\"></div>\n"
            f"{_legend(summary, title)}\n<script>{meshcat_javascript()}</script>\n<script>{script}</script>\n"
            "</body></html>\n")


def static_scene(view: CalibrationView, title: str | None = None, quiet: bool = True) -> tuple[str, SceneSummary]:
    """The scene of ``view`` as a self-contained HTML page, and what it holds."""
    scene = StaticScene()
    summary = draw_calibration(scene.visualizer(), view, quiet)
    name = title or f"pincal · {view.problem.robot.name}: nominal vs calibrated, {summary.n_samples} samples"
    return scene_page(scene, summary, name), summary


# --- command line ----------------------------------------------------------------------------------
def load_view(args: argparse.Namespace) -> tuple[CalibrationView, Dataset, Any]:
    """Robot, data and calibration from the common options: calibrate, or read ``--result``.

    Returns the view, the dataset and the :class:`pincal.workflow.Calibration` (None with ``--result``).
    """
    from pincal.workflow import calibrate

    robot = load_robot(args.robot)
    dataset = read_dataset(args.data, robot.actuated_joints, min_samples=2)
    if args.result:
        try:
            report = json.loads(Path(args.result).read_text(encoding="utf-8"))
        except (OSError, json.JSONDecodeError) as exc:
            raise DataError(f"cannot read the result JSON '{args.result}': {exc}") from None
        return CalibrationView.from_result(robot, dataset, report, args.parameters, args.sigma), dataset, None
    if not args.quiet:
        print(f"calibrating '{robot.name}' from {dataset.n_samples} samples ...", file=sys.stderr)
    calibration = calibrate(robot, dataset, parameter_spec=args.parameters, solver=args.solver, loss=args.loss,
                            sigma=args.sigma)
    return CalibrationView.from_calibration(calibration), dataset, calibration


def add_calibration_options(parser: argparse.ArgumentParser) -> None:
    """ROBOT, DATA and the calibration options shared by ``view`` and ``report``."""
    parser.add_argument("robot", help="URDF file or known robot name")
    parser.add_argument("data", help="measurement CSV (rows with set=test are held out)")
    parser.add_argument("--parameters", nargs="+", help="a named set or name patterns, as for calibrate")
    parser.add_argument("--result", metavar="REPORT.json",
                        help="reuse the results JSON of 'pincal calibrate --report' instead of calibrating again")
    parser.add_argument("--solver", choices=["lm", "tsvd", "ridge"], default="lm")
    parser.add_argument("--loss", choices=["linear", "cauchy"], default="linear", help="cauchy: robust to outliers")
    parser.add_argument("--sigma", type=float, help="measurement σ [m] for weighting (default 1e-5)")
    parser.add_argument("--quiet", action="store_true", help="no progress output")


def cmd_view(args: argparse.Namespace) -> int:
    view, _, calibration = load_view(args)
    page, summary = static_scene(view, quiet=args.quiet)
    out = Path(args.out)
    out.parent.mkdir(parents=True, exist_ok=True)
    out.write_text(page, encoding="utf-8")
    errors = f", errors magnified ×{summary.magnification:g}" if summary.has_points else ""
    print(f"wrote {out} ({out.stat().st_size / 1e6:.1f} MB): {summary.n_visuals} shapes per robot, "
          f"{summary.n_samples} samples{errors}; open it in a browser")
    for note in summary.notes:
        print(f"  note: {note}")
    if args.open is not None:
        open_in_meshcat(view, args.open or None, args.quiet)
    return 0 if calibration is None or calibration.result.converged else 1


def open_in_meshcat(view: CalibrationView, zmq_url: str | None, quiet: bool = True) -> None:
    """Draw ``view`` in a meshcat server: the one at ``zmq_url``, or a new one kept until Enter."""
    import meshcat

    try:
        vis = meshcat.Visualizer(zmq_url=zmq_url)
    except Exception as exc:  # zmq and tornado raise their own types
        raise PincalError(f"cannot reach a meshcat server{' at ' + zmq_url if zmq_url else ''}: {exc}") from None
    vis["pincal"].delete()
    draw_calibration(vis, view, quiet)
    print(f"meshcat: {vis.url()}  (Animations › default › time = sample index)")
    if zmq_url is None:
        input("press Enter to stop the meshcat server ")


def register(sub: argparse._SubParsersAction) -> None:
    """Add the ``view`` command."""
    view = sub.add_parser(
        "view", help="3D scene: nominal vs calibrated robot, measured points, errors (HTML or meshcat)",
        description="Calibrate (or read --result), then draw the nominal robot ghosted, the calibrated robot "
                    "solid, the measured points and each sample's error before and after calibration as "
                    "magnified segments coloured by size, one animation frame per sample. Writes one "
                    "self-contained HTML file (no network needed); --open also shows it in meshcat.",
        epilog="example: pincal view delta sim/measurements.csv --parameters model24 --out scene.html")
    add_calibration_options(view)
    view.add_argument("--out", required=True, help="HTML file to write")
    view.add_argument("--open", nargs="?", const="", metavar="ZMQ_URL",
                      help="also draw in meshcat: a running server (e.g. tcp://127.0.0.1:6000) or, without a "
                           "URL, a new one kept until Enter")
    view.set_defaults(func=cmd_view)
