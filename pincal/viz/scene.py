"""A calibration in 3D with meshcat: the nominal robot ghosted, the calibrated robot solid, the measured
points, and each sample's error before and after calibration as a short segment coloured by its size.

The same drawing goes to a running meshcat server (``meshcat.Visualizer()``) or into one
self-contained HTML file (:mod:`pincal.viz.static_page`); the shapes come from the robot's URDF visuals
(:mod:`pincal.viz.visuals`). One animation frame per sample steps through the samples: in meshcat's
controls, ``Animations › default › time`` is the sample index; the static page adds a slider.

Errors are millimetres on a robot of decimetres, so the segments are magnified by a round factor
(stated in the legend). Everything is drawn in the measurement frame: the nominal robot at the
identity base, the calibrated one at its calibrated base.
"""

from __future__ import annotations

import math
from typing import Any

import numpy as np
import numpy.typing as npt
import pinocchio as pin

from pincal.calibration.heldout import HeldOut, evaluate_held_out
from pincal.calibration.options import CalibrationOptions
from pincal.calibration.pipeline import Calibration
from pincal.calibration.report import CalibrationReport
from pincal.calibration.report_sections import WorkspacePrediction
from pincal.calibration.setup import prepare
from pincal.errors import ConvergenceError, DataError, PincalError, listing
from pincal.identification.metrics import error_norms, length_columns, rms, sample_length_errors
from pincal.identification.problem import CalibrationProblem
from pincal.io.dataset import Dataset
from pincal.model.robot import Robot
from pincal.progress import Progress
from pincal.records import record
from pincal.viz.camera_scene import camera_placements, draw_cameras
from pincal.viz.static_page import SceneSummary, StaticScene, scene_page
from pincal.viz.visuals import (
    CALIBRATED_COLOR,
    CURRENT_COLOR,
    GHOST_OPACITY,
    MAX_MESH_BYTES,
    NOMINAL_COLOR,
    POINT_COLOR,
    bound_colors,
    error_colors,
    lean_meshcat,
    robot_visuals,
    segment_pose,
    translation_pose,
)

Array = npt.NDArray[np.float64]

#: Fraction of a sample's animation second during which its pose is held (the rest is the move).
HOLD = 0.9
#: Longest magnified error segment, as a fraction of the scene's size.
SEGMENT_FRACTION = 0.08


# --- what a calibration shows ----------------------------------------------------------------------
@record
class CalibrationView:
    """One calibration as the scene and the report show it.

    Attributes:
        problem: The calibration samples (the usable ``train`` samples) and models.
        x: Estimated deviations [m, rad], in ``problem.parameters`` order.
        x0: "Before" [m, rad]: the nominal robot with its measurement setup registered on the fitted samples, as the
            report's "before" figures are (``report.before_parameters``; the fit's start where nothing was
            registered).
        report: The typed report (:class:`~pincal.calibration.report.CalibrationReport`).
        errors_before, errors_after: Per measurement key, (N, rows) errors [m, rad] at ``x0`` and at ``x``.
        held_out: The held-out samples' evaluation (:func:`~pincal.calibration.heldout.evaluate_held_out`), or None.
    """

    problem: CalibrationProblem
    x: Array
    report: CalibrationReport
    errors_before: dict[str, Array]
    errors_after: dict[str, Array]
    x0: Array
    held_out: HeldOut | None = None

    @classmethod
    def from_calibration(cls, calibration: Calibration) -> CalibrationView:
        """From a :class:`~pincal.calibration.pipeline.Calibration`."""
        result, before = calibration.result, calibration.before
        if before is None:  # a calibration that registered nothing: "before" is its start
            return cls(calibration.problem, result.x, calibration.report, result.errors_before, result.errors_after,
                       result.x0, calibration.held_out)
        return cls(calibration.problem, result.x, calibration.report, before.errors, result.errors_after, before.x,
                   calibration.held_out)

    @classmethod
    def from_result(cls, robot: Robot, dataset: Dataset, report: CalibrationReport,
                    options: CalibrationOptions) -> CalibrationView:
        """From a report written earlier (``pincal calibrate --report``) and its dataset, prepared as the calibration
        was (:func:`~pincal.calibration.setup.prepare`, less the parameters model selection left out); the payload of
        the compliances is the one the report records. "Before" is the nominal robot with the setup the report
        records for it (``before_parameters``), else the calibration's start.

        Raises:
            DataError: the report's parameters are not those chosen by ``options`` (pass the same ``--parameters``
                and ``--markers`` as for the calibration).
        """
        removed = report.selection.removed if report.selection is not None else []
        options = options.replace(payload=report.payload)
        part = "train" if "train" in dataset.sets else None
        fit = prepare(robot, dataset, options, part, leave_out=set(removed))
        pset = fit.parameters
        if set(pset.names) != set(report.parameters):
            missing = sorted(set(report.parameters) - set(pset.names))
            extra = sorted(set(pset.names) - set(report.parameters))
            raise DataError(f"the result's parameters differ from those chosen here (in the result only: "
                            f"{listing(missing) or '-'}; here only: {listing(extra) or '-'}): pass the same "
                            "--parameters and --markers as for the calibration")
        x = np.array([float(report.parameters[name].value) for name in pset.names])
        x0 = fit.problem.initial_guess()
        registered = report.before_parameters
        x0 = np.array([float(registered.get(name, v)) for name, v in zip(pset.names, x0, strict=True)])
        before = fit.problem.evaluate(x0, jacobian=False).errors
        after = fit.problem.evaluate(x, jacobian=False).errors
        held = evaluate_held_out(fit, dataset, pset, x0, x) if part is not None else None
        return cls(fit.problem, x, report, before, after, x0, held)

    def base_placement(self, x: Array | None = None) -> pin.SE3:
        """The robot's base in the measurement frame at ``x`` [m, rad] (default: the estimate; ``x0`` gives the
        nominal robot's as "before" places it); the identity without a base parameter."""
        problem = self.problem
        if not problem.base:
            return pin.SE3.Identity()
        return pin.exp6(problem.parameters.placement_delta(self.x if x is None else x, problem.base))

    def point_errors(self) -> tuple[Array | None, Array | None, Array | None]:
        """Measured points (N, 3) [m] and the error vectors before and after (N, 3) [m]: of each sample, its
        first position or pose reading taken (an occluded marker gives way to the next one; NaN rows for a
        sample with none); three Nones when no 3D point is measured. A camera on the robot reads its target in its
        own moving frame, not a point of the scene: it locates nothing."""
        located = [m for m in self.problem.measurements
                   if m.locates_point]
        if not located:
            return None, None, None
        n = self.problem.observations.n_samples
        points, before, after = (np.full((n, 3), np.nan) for _ in range(3))
        for m in reversed(located):  # the first measurement's reading, where taken, is written last
            taken = self.problem.seen(m.key)
            points[taken] = self.problem.observations.values[m.key][taken, :3]
            before[taken] = self.errors_before[m.key][taken, :3]
            after[taken] = self.errors_after[m.key][taken, :3]
        return points, before, after

    @property
    def has_lengths(self) -> bool:
        """True when some measurement is a length (position, pose, distance): sample errors in metres."""
        return any(length_columns(key) for key in self.errors_before)

    def sample_errors(self) -> tuple[Array, Array]:
        """Per-sample error size before and after [m]: the length-type errors (positions, pose positions,
        distances) of each sample together, as in the report (NaN for a sample that took no such reading); zeros
        when nothing length-like is measured."""
        n = self.problem.observations.n_samples
        before, after = sample_length_errors(self.errors_before, n), sample_length_errors(self.errors_after, n)
        return (before, after) if before is not None and after is not None else (np.zeros(n), np.zeros(n))


def check_same_data(view: CalibrationView, dataset: Dataset) -> None:
    """Refuse a view read from a result JSON (:meth:`CalibrationView.from_result`) over other data than the result
    was fitted on (DataError): the counts of samples it records (in the file, fitted) and its RMS error after
    calibration [m] must be those the view recomputes from ``dataset``."""
    report, n_fitted, rms_after = view.report, view.problem.observations.n_samples, rms(error_norms(view.errors_after))

    def mm(value: float) -> str:
        return f"{value * 1e3:.4f} mm"

    recorded = report.rms_after
    in_file = report.n_samples_in_file if "n_samples_in_file" in report.present else dataset.n_samples
    fitted = report.n_samples if "n_samples" in report.present else n_fitted
    same_rms = not isinstance(recorded, int | float) or not (math.isfinite(recorded) and math.isfinite(rms_after)) \
        or abs(recorded - rms_after) <= 1e-9 + 1e-6 * abs(recorded)  # [m]: the loops close to 1e-10 m
    def same(recorded: Any, count: int) -> bool:  # a count the JSON does not hold as a number is not compared
        return not isinstance(recorded, int) or isinstance(recorded, bool) or recorded == count

    if same(in_file, dataset.n_samples) and same(fitted, n_fitted) and same_rms:
        return
    shown = f", RMS error after {mm(recorded)}" if isinstance(recorded, int | float) and math.isfinite(recorded) \
        else ""
    raise DataError(f"the result JSON was not fitted on these data: it records {fitted} fitted samples of {in_file} "
                    f"in the file{shown}; these data give {n_fitted} of {dataset.n_samples}"
                    + (f", {mm(rms_after)}" if shown else "")
                    + ": give the data file the result was calibrated from")


def configurations(view: CalibrationView, quiet: bool = True) -> tuple[Robot, Array, Robot, Array]:
    """The nominal and calibrated robots and their closed configurations (N, nq) at every sample."""
    problem = view.problem
    nominal = problem.robot
    calibrated = problem.robot_at(view.x)
    qa_nominal = problem.actuated_values(view.x0)
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
def _nice_factor(value: float) -> float:
    """The largest 1-2-5 number not above ``value`` (at least 1)."""
    if not math.isfinite(value) or value <= 1:
        return 1.0
    exponent = math.floor(math.log10(value))
    return max(f * 10.0 ** exponent for f in (1, 2, 5) if f * 10.0 ** exponent <= value)


def _frame_poses(robot: Robot, qs: Array, frame_ids: list[int], base: Array) -> dict[int, Array]:
    model = robot.model
    data = model.createData()
    poses = {fid: np.empty((len(qs), 4, 4)) for fid in frame_ids}
    for k, q in enumerate(qs):
        pin.forwardKinematics(model, data, q)
        for fid in frame_ids:
            poses[fid][k] = base @ pin.updateFramePlacement(model, data, fid).homogeneous
    return poses


def _drawn_frame(view: CalibrationView, robot: Robot) -> str:
    """The frame a sample is drawn at when it has no measured point: the first frame a measurement looks at (a
    contact frame, a camera's target), else the robot's end effector."""
    for measurement in view.problem.measurements:
        for frame in measurement.frames:
            if robot.model.existFrame(frame):
                return frame
    return robot.end_effector


def draw_calibration(vis: Any, view: CalibrationView, quiet: bool = True,
                     max_mesh_bytes: int = MAX_MESH_BYTES) -> SceneSummary:
    """Draw ``view`` into a meshcat ``Visualizer`` (live, or over a :class:`StaticScene`).

    Nodes under ``pincal/``: ``robot_nominal/<frame>/<shape>`` (ghost), ``robot_calibrated/...``
    (solid), ``samples/points/<k>`` (measured points; the calibrated end effector when nothing 3D is
    measured), ``samples/error_before/<k>`` and ``samples/error_after/<k>`` (magnified segments from
    the measured point towards each model's prediction), ``samples/current`` (the animated
    highlight), ``workspace`` (the report's workspace postures, a point cloud coloured by their predicted 95 %
    bound, when the report holds them). The animation has one frame per sample (time = sample index, in seconds).
    """
    lean_meshcat()
    import meshcat.geometry as mg
    from meshcat.animation import Animation

    nominal, q_nominal, calibrated, q_calibrated = configurations(view, quiet)
    visuals, notes = robot_visuals(nominal, max_mesh_bytes)
    frame_ids = sorted({v.frame_id for v in visuals})
    names = {fid: str(nominal.model.frames[fid].name).replace("/", "_") for fid in frame_ids}
    base = view.base_placement().homogeneous
    # both robots in the measurement frame: the nominal one where "before" places it (its setup registered)
    poses = {"robot_nominal": _frame_poses(nominal, q_nominal, frame_ids, view.base_placement(view.x0).homogeneous),
             "robot_calibrated": _frame_poses(calibrated, q_calibrated, frame_ids, base)}
    apart = [np.linalg.norm(poses["robot_nominal"][f][:, :3, 3] - poses["robot_calibrated"][f][:, :3, 3], axis=1)
             for f in frame_ids]
    difference = float(np.max(np.concatenate(apart))) if apart else math.nan
    points, before, after = view.point_errors()
    has_points = points is not None
    if points is None or np.isnan(points).any():  # nothing 3D measured, or a sample whose markers were all unseen
        ee = [int(calibrated.frame_id(_drawn_frame(view, calibrated)))]
        effector = _frame_poses(calibrated, q_calibrated, ee, base)[ee[0]][:, :3, 3]
        if points is None:
            points = effector
        else:  # drawn at the calibrated end effector, with no error segment
            unseen = np.isnan(points).any(axis=1)
            points[unseen] = effector[unseen]
            for errors in (before, after):
                if errors is not None:
                    errors[unseen] = 0.0
    n = len(points)
    cloud = np.vstack([points, *(p[:, :3, 3] for p in poses["robot_nominal"].values())])
    radius = max(float(np.linalg.norm(cloud.max(axis=0) - cloud.min(axis=0))) / 2, 1e-3)
    sample_before, sample_after = view.sample_errors()
    sizes = np.concatenate([sample_before, sample_after])
    scale = float(sizes[np.isfinite(sizes)].max(initial=0.0))
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
            root["samples/points"][tag].set_transform(translation_pose(points[k]))
            for group, errors in (("error_before", before), ("error_after", after)):
                if errors is None:
                    continue
                end = points[k] + magnification * errors[k]
                length = float(np.linalg.norm(end - points[k]))
                color = error_colors(np.array([np.linalg.norm(errors[k])]), scale)[0]
                root["samples"][group][tag].set_object(mg.Cylinder(max(length, 1e-9), thickness),
                                                       mg.MeshLambertMaterial(color=color))
                root["samples"][group][tag].set_transform(segment_pose(points[k], end))
            progress.advance()
    cameras = draw_cameras(root["cameras"], camera_placements(view, calibrated, q_calibrated, base))
    workspace = workspace_points(view.report)
    if workspace is not None:
        _draw_workspace(root["workspace"], *workspace, size=0.02 * radius)
        cloud = np.vstack([cloud, workspace[0]])
    current = root["samples/current"]
    current.set_object(mg.Sphere(5 * thickness), mg.MeshLambertMaterial(color=CURRENT_COLOR, opacity=0.45))
    current.set_transform(translation_pose(points[0]))

    animation = Animation(default_framerate=1)
    moving = {group: [fid for fid in frame_ids if np.ptp(poses[group][fid], axis=0).max() > 1e-12]
              for group in poses}
    for k in range(n):
        for t in (k, k + HOLD):
            with animation.at_frame(root, t) as frame:
                for group, fids in moving.items():
                    for fid in fids:
                        frame[group][names[fid]].set_transform(poses[group][fid][k])
                frame["samples/current"].set_transform(translation_pose(points[k]))
                for name, placements in cameras.items():
                    frame["cameras"][name].set_transform(placements[k])
    vis.set_animation(animation, play=False, repetitions=1)

    _set_camera(vis, cloud)
    return SceneSummary([names[f] for f in frame_ids], len(visuals), n, magnification, scale, sample_before,
                        sample_after, notes, has_points, view.has_lengths, difference,
                        *(_bound_range(workspace[1]) if workspace is not None else (0, math.nan, math.nan)))


def workspace_points(report: CalibrationReport) -> tuple[Array, Array] | None:
    """The report's workspace postures (``predicted_workspace``): their predicted positions (N, 3) [m] in the
    measurement frame and predicted 95 % bounds (N,) [m], those with a bound; None when the report holds none."""
    space = report.predicted_workspace or WorkspacePrediction()
    positions = np.array(space.positions, dtype=float).reshape(-1, 3)
    bounds = np.array([np.nan if b is None else float(b) for b in space.bounds], dtype=float)
    if len(positions) != len(bounds):
        return None
    known = np.isfinite(bounds) & np.all(np.isfinite(positions), axis=1)
    return (positions[known], bounds[known]) if np.any(known) else None


def _bound_range(bounds: Array) -> tuple[int, float, float]:
    """How many postures, and the smallest and largest bound [m]: the ends of the scene's colour scale."""
    return len(bounds), float(bounds.min()), float(bounds.max())


def _draw_workspace(node: Any, positions: Array, bounds: Array, size: float) -> None:
    """The workspace postures' predicted positions (N, 3) [m] as one point cloud at ``node``, each point of
    ``size`` [m] coloured by its bound (N,) [m] from the smallest to the largest."""
    lean_meshcat()
    import meshcat.geometry as mg

    colors = bound_colors(bounds, float(bounds.min()), float(bounds.max()))
    node.set_object(mg.PointCloud(positions.T.astype(np.float32), colors.T.astype(np.float32), size=size))


def _set_camera(vis: Any, cloud: Array) -> None:
    """Centre the scene on ``cloud`` (N, 3) [m] (meshcat's camera orbits the world origin) and place the
    camera at the front right, 20° above, just far enough for every point to fit a 4:3 view (meshcat's
    camera: 75° vertical field)."""
    center = (cloud.min(axis=0) + cloud.max(axis=0)) / 2
    vis["pincal"].set_transform(translation_pose(-center))
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


def static_scene(view: CalibrationView, title: str | None = None, quiet: bool = True) -> tuple[str, SceneSummary]:
    """The scene of ``view`` as a self-contained HTML page, and what it holds."""
    scene = StaticScene()
    summary = draw_calibration(scene.visualizer(), view, quiet)
    name = title or f"pincal · {view.problem.robot.name}: nominal vs calibrated, {summary.n_samples} samples"
    provenance = view.report.provenance
    return scene_page(scene, summary, name, provenance.as_dict() if provenance is not None else None), summary


#: Longest wait for a reply of the meshcat server [ms].
MESHCAT_REPLY_MS = 10_000


def open_in_meshcat(view: CalibrationView, zmq_url: str | None, quiet: bool = True) -> None:
    """Draw ``view`` in a meshcat server: the one at ``zmq_url``, or a new one kept until Enter."""
    import meshcat
    import zmq
    from meshcat.visualizer import ViewerWindow

    # meshcat waits for every reply without a bound: an address where no server answers would hang forever
    ViewerWindow.context.setsockopt(zmq.RCVTIMEO, MESHCAT_REPLY_MS)
    ViewerWindow.context.setsockopt(zmq.LINGER, 0)
    try:
        vis = meshcat.Visualizer(zmq_url=zmq_url)
    except Exception as exc:  # zmq and tornado raise their own types
        reason = f"no answer within {MESHCAT_REPLY_MS / 1000:g} s" if isinstance(exc, zmq.Again) else str(exc)
        raise PincalError(f"cannot reach a meshcat server{' at ' + zmq_url if zmq_url else ''}: {reason}") from None
    vis["pincal"].delete()
    draw_calibration(vis, view, quiet)
    print(f"meshcat: {vis.url()}  (Animations › default › time = sample index)")
    if zmq_url is None:
        try:
            input("press Enter to stop the meshcat server ")
        except EOFError:  # standard input closed meanwhile: stop as if Enter was pressed
            print()
