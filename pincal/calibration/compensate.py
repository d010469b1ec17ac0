"""Compensation: the raw joint commands that bring a calibrated robot's frame to given targets, and the targets to send
to a controller that keeps its nominal model (``pincal compensate``, docs/compensate.md). SI units: m, rad.

Per target, in file order: inverse kinematics of the calibrated model (closed loops included) from the previous
target's answer, then the reference configuration, then :data:`RANDOM_STARTS` random postures within the joint limits;
a start whose inverse kinematics does not converge, or ends outside the joint limits, goes on by Gauss–Newton over
the actuated joints alone, the loops closed by forward kinematics and the joints held within their limits (a redundant
robot reaches with its other joints); the actuated values are brought into their URDF limits (a revolute joint by whole
turns); the corrections file is
inverted (:func:`~pincal.io.corrections_file.raw_commands`); and the answer is checked the way the robot will run it:
forward kinematics of the calibrated model at the corrected commands, on its reference assembly, must put the frame on
the target to :data:`TOLERANCE`, at a posture that is not singular. A target no start passes is unreachable, with the
reason of the start that came closest.
"""

from __future__ import annotations

import math
import time
from collections.abc import Iterator
from dataclasses import dataclass
from pathlib import Path

import numpy as np
import numpy.typing as npt
import pinocchio as pin

from pincal.calibration.provenance import read_provenance
from pincal.errors import DataError, listing
from pincal.identification.parameters import influencing_joints
from pincal.io.calibrated_urdf import MEASUREMENT_FRAME, attached_link, marker_link
from pincal.io.corrections_file import Corrections, corrected_readings, corrections_path, raw_commands, read_corrections
from pincal.io.targets import OK, UNREACHABLE, Targets
from pincal.model.robot import SOLVE_TOLERANCE, Robot, joint_unit, load_robot

Array = npt.NDArray[np.float64]

#: Largest residual [m, rad] of the calibrated model at the commands for a target to count as reached.
TOLERANCE = 1e-9
#: Random postures tried as starts after the previous answer and the reference configuration.
RANDOM_STARTS = 6
#: Smallest ratio of the task Jacobian's extreme singular values at an accepted posture.
SINGULAR_RATIO = 1e-6
#: Below this ratio, a target the inverse kinematics does not reach is said to lie near a singular posture.
NEAR_SINGULAR = 1e-2
#: How far [rad or m] an actuated value may pass its URDF limit and still count as within it.
LIMIT_SLACK = 1e-9
#: The choices of ``targets_in``.
TARGET_FRAMES = ("measurement", "base")


@dataclass(frozen=True)
class Model:
    """The model commands are computed on: the robot, and the corrections its raw commands go through.

    Attributes:
        robot: The calibrated (or nominal) robot.
        corrections: The corrections file's content, None when there is none.
        corrections_file: Where it was read from.
        torque_robot: The robot the corrections' gravity torques come from (the nominal one for compliance terms).
        fitted_range: The actuated joints' ranges [min, max] [rad or m] the calibration fitted, as the URDF's
            provenance records them (None: not recorded).
    """

    robot: Robot
    corrections: Corrections | None = None
    corrections_file: Path | None = None
    torque_robot: Robot | None = None
    fitted_range: dict[str, list[float]] | None = None

    def corrected(self, raw: Array) -> Array:
        """The joint values [rad or m] the robot takes at raw commands (N, na) or (na,)."""
        if self.corrections is None:
            return np.asarray(raw, dtype=float)
        return corrected_readings(self.corrections, self.torque_robot or self.robot, raw)

    def raw(self, wanted: Array) -> tuple[Array, float]:
        """Raw commands (na,) whose corrected values are ``wanted``, and the largest gap left [rad or m]."""
        if self.corrections is None:
            return np.asarray(wanted, dtype=float).copy(), 0.0
        raw, gap = raw_commands(self.corrections, self.torque_robot or self.robot, wanted)
        return raw, float(gap.max(initial=0.0))


def load_model(model: str | Path, nominal: Robot | None = None) -> Model:
    """A robot name or URDF path, with the corrections file beside a URDF path when there is one
    (``cal.urdf`` → ``cal.corrections.json``). Compliance terms take their gravity torques from ``nominal``, else from
    the nominal URDF the corrections file names.

    Raises:
        RobotFileError, NotFoundError: the model cannot be loaded; DataError: a bad corrections file, or compliance
            terms whose nominal robot is not found.
    """
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
                            "--nominal ROBOT")
        torque_robot = load_robot(corrections.nominal_urdf)
    if torque_robot is not None and torque_robot.actuated_joints != robot.actuated_joints:
        raise DataError(f"the nominal robot '{torque_robot.name}' actuates {listing(torque_robot.actuated_joints)}, "
                        f"the model {listing(robot.actuated_joints)}: they are not the same robot")
    return Model(robot, corrections, path, torque_robot, ranges)


def beyond_fitted_range(compensation: Compensation) -> list[int]:
    """The targets whose commands [rad or m] lie beyond the actuated joints' ranges the calibration fitted (and
    their margin, :func:`~pincal.calibration.predicted.widening`): the model extrapolates there."""
    ranges = compensation.model.fitted_range
    if not ranges:
        return []
    from pincal.calibration.predicted import widening

    reached = compensation.reached
    commands = np.where(reached[:, None], compensation.commands, 0.0)
    return [int(k) for k in np.flatnonzero(reached & (widening(compensation.model.robot, commands, ranges) > 1.0))]


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
        NotFoundError: a frame the robot does not have (the frames are listed).
    """
    if frame:
        robot.frame_id(frame, "--frame: ")
        return frame
    robot.frame_id(targets.frame, f"targets '{targets.key}': ")
    named = targets.key.partition(":")[2]
    if targets.kind == "position":
        link = marker_link(named)
    else:
        link = attached_link("target", named) if targets.attachment else targets.frame
    if targets.attachment or robot.model.existFrame(link):
        robot.frame_id(link, f"targets '{targets.key}' (a calibrated URDF of data with that "
                             f"{'marker' if targets.kind == 'position' else 'target'} has it; or give --frame): ")
        return link
    return targets.frame


def goals(targets: Targets, world_from_targets: pin.SE3) -> list[pin.SE3 | Array]:
    """The targets in the robot's world (root) frame: positions (3,) [m], or placements."""
    out: list[pin.SE3 | Array] = []
    for row in targets.values:
        if targets.kind == "position":
            out.append(world_from_targets.act(np.asarray(row, dtype=float)))
        else:
            quaternion = pin.Quaternion(float(row[6]), float(row[3]), float(row[4]), float(row[5])).normalized()
            out.append(world_from_targets * pin.SE3(quaternion.matrix(), np.asarray(row[:3], dtype=float)))
    return out


def gap(placement: pin.SE3, goal: pin.SE3 | Array) -> tuple[float, float]:
    """Distance [m] and, for a placement goal, angle [rad] from ``placement`` to ``goal``."""
    if isinstance(goal, pin.SE3):
        return (float(np.linalg.norm(placement.translation - goal.translation)),
                float(np.linalg.norm(pin.log3(goal.rotation.T @ placement.rotation))))
    return float(np.linalg.norm(placement.translation - goal)), math.nan


@dataclass(frozen=True)
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
    if compensation.targets_in == "base" or root != MEASUREMENT_FRAME:
        return f"the robot's base frame, link '{compensation.base}'" + (
            " (the model's root: it has no measurement frame)" if root != MEASUREMENT_FRAME else "")
    return f"the measurement frame, the model's root link '{MEASUREMENT_FRAME}'"


class _Solver:
    """Inverse kinematics of one model towards one frame, with the checks of this module's docstring."""

    def __init__(self, model: Model, frame: str, tolerance: float, seed: int) -> None:
        self.model, self.robot, self.tolerance = model, model.robot, tolerance
        self.fid, self.name = self.robot.frame_id(frame), frame
        robot = self.robot
        self.lower = np.array([robot.model.lowerPositionLimit[a.idx_q] if a.nq == 1 else -np.inf
                               for a in robot.kinematics.actuated])
        self.upper = np.array([robot.model.upperPositionLimit[a.idx_q] if a.nq == 1 else np.inf
                               for a in robot.kinematics.actuated])
        self.turns = np.array([a.nq == 1 and joint_unit(robot, a.name) == "rad" for a in robot.kinematics.actuated])
        self.seed = seed
        self._random: list[Array] | None = None
        moving = set(influencing_joints(robot, [frame]))
        #: Actuated joints that cannot move the frame (a TIAGo's head and wheels for its hand): held at the reference.
        self.idle = np.array([name not in moving for name in robot.actuated_joints])
        self.reference = robot.actuated_values(robot.q_reference)

    def random_starts(self) -> list[Array]:
        """:data:`RANDOM_STARTS` closed random postures within the limits, drawn once (seeded)."""
        if self._random is None:
            from pincal.study.simulation import random_actuated

            _, q = random_actuated(self.robot, RANDOM_STARTS, np.random.default_rng(self.seed))
            self._random = list(q)
        return self._random

    def starts(self, previous: Array | None) -> Iterator[Array]:
        if previous is not None:
            yield previous
        yield self.robot.q_reference
        yield from self.random_starts()

    def into_limits(self, values: Array, near: Array) -> Array:
        """Revolute values moved by whole turns into their limits, nearest to ``near`` when several fit."""
        out = values.copy()
        for k in np.flatnonzero(self.turns):
            candidates = values[k] + 2 * np.pi * np.arange(-3, 4)
            fits = (candidates >= self.lower[k] - LIMIT_SLACK) & (candidates <= self.upper[k] + LIMIT_SLACK)
            inside = candidates[fits]
            if inside.size:
                out[k] = inside[np.argmin(np.abs(inside - near[k]))]
        return out

    def outside(self, values: Array, what: str) -> str | None:
        bad = np.flatnonzero((values < self.lower - LIMIT_SLACK) | (values > self.upper + LIMIT_SLACK))
        if not bad.size:
            return None
        k = int(bad[0])
        name = self.robot.actuated_joints[k]
        unit = joint_unit(self.robot, name)
        return (f"outside the joint limits: {what} {name} = {values[k]:.6g} {unit}, limits [{self.lower[k]:.6g}, "
                f"{self.upper[k]:.6g}]")

    def ratio(self, q: Array, pose: bool) -> float:
        """Smallest over largest singular value of the frame's Jacobian over the actuated joints at ``q``."""
        try:
            jac = self.robot.kinematics.frame_jacobian_actuated(q, self.fid)[: 6 if pose else 3]
            s = np.linalg.svd(jac, compute_uv=False)
        except (np.linalg.LinAlgError, ValueError, RuntimeError):
            return 0.0
        return float(s[-1] / s[0]) if s.size and s[0] > 0 and np.all(np.isfinite(s)) else 0.0

    def singular(self, q: Array, pose: bool) -> str | None:
        ratio = self.ratio(q, pose)
        if ratio < SINGULAR_RATIO:
            return f"singular posture: the frame's Jacobian has singular values in the ratio {ratio:.3g}"
        return None

    def actuated_newton(self, start: Array, goal: pin.SE3 | Array, max_iter: int = 40) -> Array | None:
        """Gauss–Newton over the actuated values alone from ``start`` [rad or m], the loops closed by forward kinematics
        (the reference assembly, as the robot runs), kept within the joint limits (a joint at a limit that the step
        would pass is held there, the others solve without it): the configuration reaching ``goal``, or None."""
        robot, guess = self.robot, None
        qa = np.clip(np.array(start, dtype=float), self.lower, self.upper)
        for _ in range(max_iter):
            fk = robot.solve_fk_report(qa, guess)
            if not fk.converged:
                return None
            guess = fk.q
            placement = robot.placement(fk.q, self.name)
            jac = robot.kinematics.frame_jacobian_actuated(fk.q, self.fid)
            if isinstance(goal, pin.SE3):
                rel = goal.rotation.T @ placement.rotation
                error = np.concatenate([placement.translation - goal.translation, pin.log3(rel)])
                jac = np.vstack([jac[:3], pin.Jlog3(rel) @ placement.rotation.T @ jac[3:]])
            else:
                error, jac = placement.translation - goal, jac[:3]
            if float(np.abs(error).max()) <= SOLVE_TOLERANCE:
                return fk.q
            step = np.linalg.lstsq(jac, -error, rcond=1e-10)[0]
            held = ((qa <= self.lower) & (step < 0)) | ((qa >= self.upper) & (step > 0))
            if held.any():
                step = np.zeros_like(step)
                step[~held] = np.linalg.lstsq(jac[:, ~held], -error, rcond=1e-10)[0]
            size = float(np.linalg.norm(step))
            qa = np.clip(qa + (step * (0.2 / size) if size > 0.2 else step), self.lower, self.upper)
        return None

    def solve(self, goal: pin.SE3 | Array, previous: Array | None) -> tuple[str, Array | None, Array | None, tuple[
            float, float], float]:
        """(status, raw commands, configuration, residuals, inversion gap) for one target."""
        robot, pose = self.robot, isinstance(goal, pin.SE3)
        reasons: list[tuple[float, str]] = []  # (how close the start came [m, rad], why it failed)
        tried = 0
        for start in self.starts(previous):
            tried += 1
            report = robot.kinematics.solve_ik(goal, self.fid, start.copy(), SOLVE_TOLERANCE)
            q = report.q if report.converged else self.actuated_newton(robot.actuated_values(start), goal)
            if q is None:
                miss = gap(robot.placement(report.q, self.name), goal)[0]
                ratio = self.ratio(report.q, pose)
                edge = (f", near a singular posture (singular values in the ratio {ratio:.2g}: the edge of the "
                        "workspace)" if ratio < NEAR_SINGULAR else "")
                reasons.append((report.residual, f"inverse kinematics did not converge: the nearest posture found "
                                                  f"leaves the frame {miss:.3g} m from the target{edge}"))
                continue
            wanted = self.into_limits(robot.actuated_values(q), robot.actuated_values(start))
            wanted[self.idle] = self.reference[self.idle]
            if self.outside(wanted, "") and (inside := self.actuated_newton(wanted, goal)) is not None:
                q = inside  # the same target with the joints held within their limits
                wanted = self.into_limits(robot.actuated_values(q), wanted)
                wanted[self.idle] = self.reference[self.idle]
            why = self.outside(wanted, "the model's")
            raw, inversion = self.model.raw(wanted)
            why = why or self.outside(raw, "the raw command of")
            if why:
                reasons.append((0.0, why))
                continue
            fk = robot.solve_fk_report(self.model.corrected(raw))
            if not fk.converged:
                reasons.append((0.0, "the loops do not close at the commands"))
                continue
            placement = robot.placement(fk.q, self.name)
            residual = gap(placement, goal)
            worst = max(r for r in residual if not math.isnan(r))
            if not worst <= self.tolerance:
                reasons.append((worst, f"at the commands the model assembles otherwise (its reference assembly): the "
                                       f"frame lands {residual[0]:.3g} m from the target"))
                continue
            why = self.singular(fk.q, pose)
            if why:
                reasons.append((0.0, why))
                continue
            return OK, raw, fk.q, residual, inversion
        # the reason of a start that reached the target in joint space comes first, else the nearest miss
        _, reason = min(reasons, key=lambda item: item[0])
        return f"{UNREACHABLE}: {reason} ({tried} starts)", None, None, (math.nan, math.nan), math.nan


def compensate(model: Model, targets: Targets, frame: str | None = None, targets_in: str = "measurement",
               tolerance: float = TOLERANCE, seed: int = 0) -> Compensation:
    """Raw commands [rad or m] that bring ``model``'s frame to each target (this module's docstring).

    Args:
        model: The calibrated model (:func:`load_model`).
        targets: Positions or poses [m, unit quaternion].
        frame: The frame that goes to the targets (:func:`reached_frame` by default).
        targets_in: ``measurement``: the targets are in the model's root frame (the measurement frame of a calibrated
            URDF that estimated it); ``base``: in the robot's own root link (:func:`base_link`).
        tolerance: Largest residual [m, rad] of a reached target.
        seed: Seed of the random starts.

    Raises:
        DataError: pose targets for a robot of fewer than 6 degrees of freedom, an unknown ``targets_in``.
        NotFoundError: an unknown frame.
    """
    start = time.perf_counter()
    robot = model.robot
    if targets_in not in TARGET_FRAMES:
        raise DataError(f"targets in '{targets_in}': choose {' or '.join(TARGET_FRAMES)}")
    if targets.kind == "pose" and robot.mobility() < 6:
        raise DataError(f"pose targets ask 6 coordinates of '{robot.name}', which has {robot.mobility()} degrees of "
                        "freedom: give position targets (position:<frame>:x,y,z)")
    name = reached_frame(robot, targets, frame)
    base = base_link(robot)
    world_from_targets = robot.placement(robot.q_reference, base) if targets_in == "base" else pin.SE3.Identity()
    solver = _Solver(model, name, tolerance, seed)
    n, na = len(targets.ids), robot.n_actuated
    commands, configurations = np.full((n, na), np.nan), np.full((n, robot.model.nq), np.nan)
    residuals, inversion = np.full((n, 2), np.nan), np.full(n, np.nan)
    statuses: list[str] = []
    previous = None
    for k, goal in enumerate(goals(targets, world_from_targets)):
        status, raw, q, residual, gap_left = solver.solve(goal, previous)
        statuses.append(status)
        if raw is not None and q is not None:
            commands[k], configurations[k], residuals[k], inversion[k] = raw, q, residual, gap_left
            previous = q
    return Compensation(model, targets, name, targets_in, base, commands, residuals, statuses, configurations,
                        inversion, tolerance, time.perf_counter() - start)


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
    robot = compensation.model.robot
    if nominal.actuated_joints != robot.actuated_joints:
        raise DataError(f"--nominal '{nominal.name}' actuates {listing(nominal.actuated_joints)}, the model "
                        f"{listing(robot.actuated_joints)}: they are not the same robot")
    frame = compensation.frame if nominal.model.existFrame(compensation.frame) else compensation.targets.frame
    nominal.frame_id(frame, "--nominal: ")
    width = 7 if compensation.targets.kind == "pose" else 3
    out = np.full((len(compensation.statuses), width), np.nan)
    statuses = list(compensation.statuses)
    for k in np.flatnonzero(compensation.reached).tolist():
        fk = nominal.solve_fk_report(compensation.commands[k])
        if not fk.converged:
            statuses[k] = f"{UNREACHABLE}: the nominal model's loops do not close at the commands"
            continue
        placement = nominal.placement(fk.q, frame)
        out[k, :3] = placement.translation
        if width == 7:
            out[k, 3:] = pin.Quaternion(placement.rotation).coeffs()  # x, y, z, w
    return out, statuses, frame
