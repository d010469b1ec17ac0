"""Compensation: the raw joint commands that bring a calibrated robot's frame to given targets, and the targets to send
to a controller that keeps its nominal model (``pincal compensate``, docs/compensate.md). SI units: m, rad.

The model and its corrections file are read here (:func:`load_model`), the frame that goes to the targets chosen
(:func:`reached_frame`: it must be one the actuated joints move), the targets placed in the model's world, and every
target solved by the rule of :mod:`pincal.calibration.joint_commands` (from the reference configuration, then seeded
random postures; each answer checked by forward kinematics as the robot runs it), in blocks of :data:`BLOCK` targets
solved together, a progress bar advancing as targets are done.
"""

from __future__ import annotations

import time
from pathlib import Path
from typing import Any

import numpy as np
import numpy.typing as npt
import pinocchio as pin

from pincal import validation
from pincal.calibration.joint_commands import CommandSolver, Model
from pincal.calibration.provenance import read_provenance
from pincal.errors import ArgumentError, Culprit, DataError, listing
from pincal.io.calibrated_urdf import MEASUREMENT_FRAME, attached_link, marker_link
from pincal.io.corrections_file import corrections_path, read_corrections
from pincal.io.dataset import QUATERNION_NORM_TOLERANCE
from pincal.io.targets import MAX_TARGETS, OK, TARGET_COMPONENTS, UNREACHABLE, Targets
from pincal.model.batch_ik import Goals
from pincal.model.frame_kinematics import frame_kinematics
from pincal.model.robot import SOLVE_TOLERANCE, Robot, load_robot
from pincal.model.rotations import quaternion_matrices
from pincal.progress import Progress
from pincal.records import record

Array = npt.NDArray[np.float64]

#: Largest residual [m, rad] of the calibrated model at the commands for a target to count as reached.
TOLERANCE = 1e-9
#: The choices of ``targets_in``.
TARGET_FRAMES = ("measurement", "base", "board")
#: The link of the board an eye-in-hand camera sees, fixed in the robot's world (``--targets-in board``).
BOARD_LINK = "camera_target"
#: Targets solved together: enough that the stacked solves' fixed cost is spread thin (2000 UR10 poses took 40 % longer
#: in blocks of 500, 90 % in blocks of 250).
BLOCK = 1000

__all__ = ["BLOCK", "TARGET_FRAMES", "TOLERANCE", "Compensation", "Model", "base_link", "beyond_fitted_range",
           "compensate", "goals", "load_model", "nominal_targets", "reached_frame", "target_bounds", "targets_frame"]


def load_model(model: str | Path, nominal: Robot | None = None) -> Model:
    """A robot name or URDF path, with the corrections file beside a URDF path when there is one
    (``cal.urdf`` → ``cal.corrections.json``). Compliance terms take their gravity torques from ``nominal``, else from
    the nominal URDF the corrections file names.

    Raises:
        RobotFileError, NotFoundError: the model cannot be loaded; DataError: a bad corrections file, or compliance
            terms whose nominal robot is not found. TypeError: ``model`` is no path or name, ``nominal`` no Robot.
    """
    model = validation.path("model", model)
    if nominal is not None:
        validation.instance("nominal", nominal, Robot, "a Robot (pincal.load_robot) or None")
    if Path(model).suffix.lower() == ".json":
        raise DataError(f"MODEL '{model}' is a JSON file: compensate takes the calibrated URDF ('pincal calibrate "
                        "--out') or a robot, not a report")
    robot = load_robot(model)
    path = corrections_path(model)
    ranges = None
    if Path(model).is_file():
        recorded = read_provenance(model)
        recorded.check_corrections(model)
        ranges = recorded.fitted_range
    if not Path(model).is_file() or not path.is_file():
        return Model(robot, fitted_range=ranges)
    corrections = read_corrections(path)
    torque_robot = nominal
    needs_masses = any("compliance" in terms for terms in corrections.joints.values())
    if torque_robot is None and needs_masses:
        if not corrections.nominal_urdf:
            raise DataError(f"{path} has compliance terms but names no nominal URDF for their gravity torques; give "
                            "nominal=ROBOT", option="nominal")
        torque_robot = load_robot(corrections.nominal_urdf)
    if torque_robot is not None and torque_robot.actuated_joints != robot.actuated_joints:
        raise DataError(f"the nominal robot '{torque_robot.name}' actuates {listing(torque_robot.actuated_joints)}, "
                        f"the model {listing(robot.actuated_joints)}: they are not the same robot")
    return Model(robot, corrections, path, torque_robot, ranges)


def beyond_fitted_range(compensation: Compensation) -> list[int]:
    """The targets whose commands [rad or m] lie beyond the actuated joints' ranges the calibration fitted (and
    their margin, :func:`~pincal.calibration.predicted.outside_range`): the model extrapolates there."""
    ranges = compensation.model.fitted_range
    if not ranges:
        return []
    from pincal.calibration.predicted import outside_range

    reached = compensation.reached
    commands = np.where(reached[:, None], compensation.commands, 0.0)
    return [int(k) for k in np.flatnonzero(reached & outside_range(compensation.model.robot, commands, ranges))]


def target_bounds(compensation: Compensation, model_path: str | Path, nominal: Robot | None
                  ) -> tuple[Array, Array] | None:
    """Each reached target's predicted 95 % bound [m] at its commands, and the nominal robot's own bound there [m]
    (:func:`~pincal.calibration.predicted.bounds_at`), from the calibration the URDF at ``model_path`` carries
    (:mod:`pincal.calibration.carried`) on its nominal robot (``nominal``, else the one it records); NaN for a target
    not reached. None when the URDF carries no calibration or its nominal robot cannot be loaded."""
    from pincal.calibration.carried import read_carried
    from pincal.calibration.predicted import bounds_at
    from pincal.errors import PincalError

    calibration = read_carried(model_path) if Path(model_path).is_file() else None
    if calibration is None:
        return None
    if nominal is None:
        recorded = read_provenance(model_path).robot
        try:
            nominal = load_robot(recorded) if recorded else None
        except PincalError:
            nominal = None
    if nominal is None or nominal.actuated_joints != compensation.model.robot.actuated_joints:
        return None
    reached = compensation.reached
    bound, own = np.full(len(reached), np.nan), np.full(len(reached), np.nan)
    if reached.any():
        found = bounds_at(nominal, calibration, compensation.commands[reached])
        if found is None:
            return None
        bound[reached], own[reached] = found
    return bound, own


def base_link(robot: Robot) -> str:
    """The robot's own root link: the child of ``measurement_frame_joint`` in a calibrated URDF whose calibration
    estimated the measurement frame, else the root link."""
    model = robot.model
    joint = f"{MEASUREMENT_FRAME}_joint"
    if model.existFrame(joint):
        fid = model.getFrameId(joint)
        for frame in model.frames:
            if frame.parentFrame == fid and frame.type == pin.FrameType.BODY:
                return str(frame.name)
    return str(next(f.name for f in model.frames if f.type == pin.FrameType.BODY))


def reached_frame(robot: Robot, targets: Targets, frame: str | None = None) -> str:
    """The frame of ``robot`` that goes to the targets: ``frame`` when given; else what the targets' key reads in a
    calibrated URDF (docs/calibrated_urdf.md): for ``position:<frame>``, its calibrated marker ``<frame>_marker`` when
    the file has one, else ``<frame>``; ``position:<frame>@<marker>``: ``<frame>_marker_<marker>``;
    ``pose:<frame>``: ``<frame>``; ``pose:<frame>@<target>``: ``<frame>_target_<target>``.

    Raises:
        NotFoundError: a frame the robot does not have (the frames are listed). DataError: a frame no actuated joint
            moves (no command can bring it anywhere; the frames that would do are named).
    """
    if frame:
        with Culprit(option="frame"):
            robot.frame_id(frame)
            return _moving(robot, frame, f"frame={frame}")
    robot.frame_id(targets.frame, f"targets '{targets.key}': ")
    named = targets.key.partition(":")[2]
    if targets.kind == "position":
        link = marker_link(named)
    else:
        link = attached_link("target", named) if targets.attachment else targets.frame
    if targets.attachment or robot.model.existFrame(link):
        robot.frame_id(link, f"targets '{targets.key}' (a calibrated URDF of data with that "
                             f"{'marker' if targets.kind == 'position' else 'target'} has it; or give frame=NAME): ")
        return _moving(robot, link, f"targets '{targets.key}'")
    return _moving(robot, targets.frame, f"targets '{targets.key}'")


def _moving(robot: Robot, frame: str, where: str) -> str:
    """``frame``, which the actuated joints must move; DataError naming it and the frames that would do otherwise."""
    from pincal.model.measured_frame import default_measured_frame, frame_moves, moving_ends

    if frame_moves(robot, frame):
        return frame
    choice = default_measured_frame(robot)
    others = [name for name in moving_ends(robot) if name != choice.frame]
    default = [f"'{choice.frame}' (the default measured frame)"] if choice.frame else []
    would = default + [f"'{name}'" for name in others[:8]] + (["…"] if len(others) > 8 else [])
    raise DataError(f"{where}: no actuated joint of '{robot.name}' moves frame '{frame}', so no command brings it to a "
                    f"target; give a frame they move{': ' + ', '.join(would) if would else ''}")


def goals(targets: Targets, world_from_targets: pin.SE3) -> Goals:
    """The targets in the robot's world (root) frame: positions [m] and, for poses, orientations."""
    values = np.asarray(targets.values, dtype=float)
    rotation, translation = world_from_targets.rotation, world_from_targets.translation
    positions = values[:, :3] @ rotation.T + translation
    if targets.kind == "position":
        return Goals(positions, None)
    quaternions = values[:, 3:] / np.linalg.norm(values[:, 3:], axis=1)[:, None]  # qx, qy, qz, qw
    return Goals(positions, rotation @ quaternion_matrices(quaternions))


@record(frozen=True)
class Compensation:
    """Commands for targets, one row per target in file order.

    Attributes:
        model: The model the commands were computed on.
        targets: The targets as read.
        frame: The frame of the model that goes to the targets.
        targets_in: ``measurement`` (the model's root frame) or ``base`` (the robot's own root link, :attr:`base`).
        base: The robot's own root link.
        commands: (N, na) raw actuated commands [rad or m], NaN on a row not reached.
        residuals: (N, 2) distance [m] and angle [rad] (NaN for positions) from the frame, as the model places it at
            the commands, to the target; NaN on a row not reached.
        statuses: ``ok``, or ``unreachable: <reason>``.
        configurations: (N, nq) the model's configuration at the commands, NaN on a row not reached.
        inversion: (N,) largest gap [rad or m] left by inverting the corrections (0 without them).
        tolerance: Largest residual [m, rad] of a reached target.
        seconds: Time taken.
    """

    model: Model
    targets: Targets
    frame: str
    targets_in: str
    base: str
    commands: Array
    residuals: Array
    statuses: list[str]
    configurations: Array
    inversion: Array
    tolerance: float
    seconds: float

    @property
    def reached(self) -> npt.NDArray[np.bool_]:
        """(N,) which targets were reached."""
        return np.array([s == OK for s in self.statuses], dtype=bool)


def targets_frame(compensation: Compensation) -> str:
    """In words, the frame the targets are in."""
    root = str(compensation.model.robot.model.frames[1].name)
    if compensation.targets_in == "board":
        return f"the board's frame, link '{BOARD_LINK}' (the calibrated board an eye-in-hand camera sees)"
    if compensation.targets_in == "base" or root != MEASUREMENT_FRAME:
        return f"the robot's base frame, link '{compensation.base}'" + (
            " (the model's root: it has no measurement frame)" if root != MEASUREMENT_FRAME else "")
    return f"the measurement frame, the model's root link '{MEASUREMENT_FRAME}'"


def compensate(model: Model, targets: Targets, frame: str | None = None, targets_in: str = "measurement",
               tolerance: float = TOLERANCE, seed: int = 0, progress: bool = False) -> Compensation:
    """Raw commands [rad or m] that bring ``model``'s frame to each target (:mod:`pincal.calibration.joint_commands`):
    each target from the reference configuration, then from the seeded random postures, its answer a function of the
    target, the model and the seed alone.

    Args:
        model: The calibrated model (:func:`load_model`).
        targets: Positions or poses [m, unit quaternion] (:func:`~pincal.io.targets.read_targets`), at most
            :data:`~pincal.io.targets.MAX_TARGETS`.
        frame: The frame that goes to the targets (:func:`reached_frame` by default).
        targets_in: ``measurement``: the targets are in the model's root frame (the measurement frame of a calibrated
            URDF that estimated it); ``base``: in the robot's own root link (:func:`base_link`); ``board``: in the
            frame of the board an eye-in-hand camera sees (:data:`BOARD_LINK`, where the calibration placed it: the
            pixels fix the camera's pose relative to the board, not to the robot's base).
        tolerance: Largest residual [m, rad] of a reached target, > 0.
        seed: Seed of the random starts, a whole number ≥ 0.
        progress: Show a progress bar on stderr when it is a terminal.

    Raises:
        TypeError, ArgumentError: an argument of the wrong type or value (named, with the value).
        DataError: pose targets for a robot of fewer than 6 degrees of freedom; a frame no actuated joint moves;
            ``board`` for a model without a fixed board's link (the reason named: its board moves).
        NotFoundError: an unknown frame.
    """
    _check_arguments(model, targets, frame, targets_in, tolerance, seed)
    start = time.perf_counter()
    robot = model.robot
    if targets.kind == "pose" and robot.mobility() < 6:
        raise DataError(f"pose targets ask 6 coordinates of '{robot.name}', which has {robot.mobility()} degrees of "
                        "freedom: give position targets (position:<frame>:x,y,z)")
    name = reached_frame(robot, targets, frame)
    base = base_link(robot)
    world_from_targets = robot.placement(robot.q_reference, base) if targets_in == "base" else pin.SE3.Identity()
    if targets_in == "board":
        world_from_targets = _board_placement(robot)
    solver = CommandSolver(model, name, tolerance, seed)
    every = goals(targets, world_from_targets)
    n, na = len(targets.ids), robot.n_actuated
    commands, configurations = np.full((n, na), np.nan), np.full((n, robot.model.nq), np.nan)
    residuals, inversion = np.full((n, 2), np.nan), np.full(n, np.nan)
    statuses: list[str] = []
    with Progress(f"compensate: {n} targets", n, quiet=not progress) as bar:
        for first in range(0, n, BLOCK):
            rows = slice(first, min(n, first + BLOCK))
            block = solver.solve(every.take(np.arange(n)[rows]), bar.advance)
            commands[rows], configurations[rows] = block.raw, block.configurations
            residuals[rows], inversion[rows] = block.residuals, block.inversion
            statuses += block.statuses
    return Compensation(model, targets, name, targets_in, base, commands, residuals, statuses, configurations,
                        inversion, tolerance, time.perf_counter() - start)


def _board_placement(robot: Robot) -> pin.SE3:
    """The fixed board's placement in ``robot``'s world [m] (link :data:`BOARD_LINK`), for ``--targets-in board``.

    Raises:
        DataError: no such link, naming why: the model's board (``<frame>_target_board``) moves with the robot, seen
            by a camera on another chain (``cross_pixel``: a target relative to the board fixes one chain relative to
            the other, not a place the robot goes) or by a fixed camera (eye-to-hand: its frame is ``measurement``);
            or the model has no board at all.
    """
    from pincal.model.measured_frame import frame_moves

    if robot.model.existFrame(BOARD_LINK):
        return robot.placement(robot.q_reference, BOARD_LINK)
    names = [str(f.name) for f in robot.model.frames if f.type == pin.FrameType.BODY]
    boards = [n for n in names if n.endswith("_target_board") and frame_moves(robot, n)]
    cameras = [n for n in names if n.endswith("_camera") and frame_moves(robot, n)]
    if boards and cameras:
        raise DataError(f"targets_in='board': MODEL's board (link '{boards[0]}') moves with the robot, as does its "
                        f"camera (link '{cameras[0]}'): a target relative to the board fixes where one chain stands "
                        "relative to the other, not a place the robot goes, which compensate does not solve; give the "
                        f"targets in 'base' (pose:{cameras[0]} or pose:{boards[0]}, docs/compensate.md)",
                        option="targets_in")
    if boards:
        raise DataError(f"targets_in='board': MODEL's board (link '{boards[0]}') is on the robot, seen by a fixed "
                        f"camera whose frame is the measurement frame: give targets of pose:{boards[0]} in "
                        "'measurement'", option="targets_in")
    raise DataError(f"targets_in='board': MODEL has no link '{BOARD_LINK}' (a URDF calibrated on an eye-in-hand "
                    "camera's pixels or poses holds the fixed board it saw there)", option="targets_in")


def _check_arguments(model: Any, targets: Any, frame: Any, targets_in: Any, tolerance: Any, seed: Any) -> None:
    """:func:`compensate`'s arguments, as the command line checks its own: TypeError or ArgumentError naming the
    argument and the value."""
    validation.instance("model", model, Model, "a Model (pincal.calibration.compensate.load_model)")
    validation.instance("targets", targets, Targets, "Targets (pincal.io.targets.read_targets)")
    if frame is not None:
        validation.instance("frame", frame, str, "a frame name (str) or None")
    validation.instance("targets_in", targets_in, str, f"one of {', '.join(TARGET_FRAMES)}")
    if targets_in not in TARGET_FRAMES:
        raise ArgumentError(f"targets_in={targets_in!r}: choose "
                            f"{', '.join(repr(c) for c in TARGET_FRAMES[:-1])} or {TARGET_FRAMES[-1]!r}")
    validation.real("tolerance", tolerance, "m, rad", strict=True)
    validation.whole("seed", seed, 0)
    kind = targets.kind
    if kind not in TARGET_COMPONENTS:
        raise ArgumentError(f"targets.key={targets.key!r}: a position:<frame> or pose:<frame> key is needed")
    width = len(TARGET_COMPONENTS[kind])
    values = np.asarray(targets.values)
    if values.ndim != 2 or values.shape[1] != width or not np.issubdtype(values.dtype, np.number):
        raise ArgumentError(f"targets.values: an array of numbers of shape (N, {width}) for '{targets.key}' is needed, "
                            f"not {validation.shown(targets.values)}")
    if len(values) > MAX_TARGETS:
        raise ArgumentError(f"targets: {len(values)} targets; compensate takes at most {MAX_TARGETS} in one call")
    if len(targets.ids) != len(values):
        raise ArgumentError(f"targets.ids: {len(targets.ids)} ids for {len(values)} targets")
    values = values.astype(float)
    bad = np.flatnonzero(~np.all(np.isfinite(values), axis=1))
    if bad.size:
        k = int(bad[0])
        raise ArgumentError(f"targets.values[{k}] = {values[k].tolist()} (sample '{targets.ids[k]}'): a target must be "
                            "finite numbers [m, unit quaternion]")
    if kind == "pose":
        norms = np.linalg.norm(values[:, 3:], axis=1)
        far = np.flatnonzero(np.abs(norms - 1.0) > QUATERNION_NORM_TOLERANCE)
        if far.size:
            k = int(far[0])
            raise ArgumentError(f"targets.values[{k}] (sample '{targets.ids[k]}'): quaternion (qx, qy, qz, qw) of norm "
                                f"{norms[k]:.6g}; a unit quaternion is needed")


def nominal_targets(compensation: Compensation, nominal: Robot) -> tuple[Array, list[str], str]:
    """What to send a controller that keeps ``nominal``: the nominal model's placement of the frame at each raw command,
    in the nominal robot's root frame. Its inverse kinematics then gives back the commands, and the robot goes where the
    calibrated model says the target is (with a redundant robot, only when that inverse kinematics chooses the same
    joint values: give poses, which leave a 6-axis arm no freedom).

    The frame is the compensation's when ``nominal`` has it, else the targets' key's (``end_effector`` for the
    calibrated marker ``end_effector_marker``).

    Returns:
        (N, 3 or 7) targets [m, unit quaternion], NaN on a row not reached; the statuses; the nominal frame.

    Raises:
        DataError: ``nominal`` does not actuate the model's joints. NotFoundError: it lacks the frame.
    """
    validation.instance("compensation", compensation, Compensation, "a Compensation (compensate)")
    validation.instance("nominal", nominal, Robot, "a Robot (pincal.load_robot)")
    robot = compensation.model.robot
    if nominal.actuated_joints != robot.actuated_joints:
        raise DataError(f"nominal='{nominal.name}' actuates {listing(nominal.actuated_joints)}, the model "
                        f"{listing(robot.actuated_joints)}: they are not the same robot", option="nominal")
    frame = compensation.frame if nominal.model.existFrame(compensation.frame) else compensation.targets.frame
    frame_id = nominal.frame_id(frame, f"nominal='{nominal.name}': ")
    kinematics = frame_kinematics(nominal.batch, frame_id, SOLVE_TOLERANCE)
    width = 7 if compensation.targets.kind == "pose" else 3
    out = np.full((len(compensation.statuses), width), np.nan)
    statuses = list(compensation.statuses)
    reached = np.flatnonzero(compensation.reached)
    q, closed = kinematics.forward(compensation.commands[reached], None)  # the nominal model's reference assembly
    for k in reached[~closed].tolist():
        statuses[k] = f"{UNREACHABLE}: the nominal model's loops do not close at the commands"
    rows = reached[closed]
    if rows.size:
        state = kinematics.state(q[closed])
        out[rows, :3] = state.origin
        if width == 7:
            out[rows, 3:] = [pin.Quaternion(rotation).coeffs() for rotation in state.rotation]  # x, y, z, w
    return out, statuses, frame
