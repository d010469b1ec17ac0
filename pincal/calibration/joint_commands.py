"""The raw joint commands that bring one frame of a model to many targets, every target by the same rule, all at once
(the work of :func:`~pincal.calibration.compensate.compensate`; docs/compensate.md, "How each target is solved").
SI units: m, rad.

Each target is solved from the reference configuration, then from each of :data:`RANDOM_STARTS` random postures within
the joint limits (drawn once from the seed), the first start that passes giving the answer: inverse kinematics of the
model (closed loops included, :func:`~pincal.model.batch_ik.solve_ik`); a start whose inverse kinematics does not
converge, or ends outside the joint limits, goes on by Gauss–Newton over the actuated joints alone
(:func:`~pincal.model.batch_ik.actuated_newton`); the actuated values are brought into their URDF limits (a revolute
joint by whole turns), the joints that cannot move the frame held at their reference; the corrections inverted
(:func:`~pincal.io.corrections_file.raw_commands`); and the answer checked the way the robot will run it: forward
kinematics of the model at the corrected commands, on its reference assembly, must put the frame on the target to the
tolerance, at a posture that is not singular. A target no start passes is unreachable, with the reason of the start
that came closest. The answer is a function of the target, the model and the seed alone: every target starts afresh,
and each row's arithmetic reads that row alone (:mod:`pincal.model.batch_ik`), so neither the other targets nor their
order change it.
"""

from __future__ import annotations

from collections.abc import Callable
from pathlib import Path

import numpy as np
import numpy.typing as npt

from pincal.identification.parameters import influencing_joints
from pincal.io.corrections_file import Corrections, corrected_readings, raw_commands
from pincal.io.targets import OK, UNREACHABLE
from pincal.model.batch_ik import Goals, actuated_newton, solve_ik
from pincal.model.frame_kinematics import FrameState, frame_kinematics
from pincal.model.robot import SOLVE_TOLERANCE, Robot, joint_unit
from pincal.records import record

Array = npt.NDArray[np.float64]

#: Random postures tried as starts after the reference configuration.
RANDOM_STARTS = 6
#: Smallest ratio of the task Jacobian's extreme singular values at an accepted posture.
SINGULAR_RATIO = 1e-6
#: Below this ratio, a target the inverse kinematics does not reach is said to lie near a singular posture.
NEAR_SINGULAR = 1e-2
#: How far [rad or m] an actuated value may pass its URDF limit and still count as within it.
LIMIT_SLACK = 1e-9


@record(frozen=True)
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

    def raw(self, wanted: Array) -> tuple[Array, Array]:
        """Raw commands (N, na) whose corrected values are ``wanted`` (N, na) [rad or m], and per row the largest gap
        left (0 without corrections)."""
        wanted = np.asarray(wanted, dtype=float)
        if self.corrections is None:
            return wanted.copy(), np.zeros(len(wanted))
        return raw_commands(self.corrections, self.torque_robot or self.robot, wanted)


@record(frozen=True)
class Commands:
    """The answers for N targets, in their order.

    Attributes:
        statuses: ``ok``, or ``unreachable: <reason>``.
        raw: (N, na) raw actuated commands [rad or m], NaN on a row not reached.
        configurations: (N, nq) the model's configuration at the commands, NaN on a row not reached.
        residuals: (N, 2) distance [m] and angle [rad] (NaN for positions) from the frame to the target at the
            commands, NaN on a row not reached.
        inversion: (N,) largest gap [rad or m] left by inverting the corrections (0 without them), NaN on a row not
            reached.
    """

    statuses: list[str]
    raw: Array
    configurations: Array
    residuals: Array
    inversion: Array


class CommandSolver:
    """The commands that bring ``frame`` of ``model`` to targets (this module's docstring).

    Args:
        model: The model.
        frame: The frame that goes to the targets.
        tolerance: Largest residual [m, rad] of a reached target.
        seed: Seed of the random starts.
    """

    def __init__(self, model: Model, frame: str, tolerance: float, seed: int) -> None:
        robot = model.robot
        self.model, self.robot, self.tolerance, self.seed = model, robot, tolerance, seed
        self.frame = frame_kinematics(robot.batch, robot.frame_id(frame), SOLVE_TOLERANCE)
        actuated = robot.kinematics.actuated
        self.lower = np.array([robot.model.lowerPositionLimit[a.idx_q] if a.nq == 1 else -np.inf for a in actuated])
        self.upper = np.array([robot.model.upperPositionLimit[a.idx_q] if a.nq == 1 else np.inf for a in actuated])
        self.turns = np.array([a.nq == 1 and joint_unit(robot, a.name) == "rad" for a in actuated])
        moving = set(influencing_joints(robot, [frame]))
        #: Actuated joints that cannot move the frame (a TIAGo's head and wheels for its hand): held at the reference.
        self.idle = np.array([name not in moving for name in robot.actuated_joints], dtype=bool)
        self.reference = robot.actuated_values(robot.q_reference)
        self._starts: list[Array] | None = None

    def starts(self) -> list[Array]:
        """The configurations every target starts from, in order: the reference, then :data:`RANDOM_STARTS` closed
        random postures within the limits (drawn once, from the seed)."""
        if self._starts is None:
            from pincal.study.simulation import random_actuated

            _, q = random_actuated(self.robot, RANDOM_STARTS, np.random.default_rng(self.seed))
            self._starts = [self.robot.q_reference, *q]
        return self._starts

    def solve(self, goals: Goals, advance: Callable[[int], object] | None = None) -> Commands:
        """The commands for every target of ``goals`` (world frame), by the rule of this module's docstring;
        ``advance(k)`` is told of k more targets done as they are (a progress bar's)."""
        n, na, nq = len(goals), self.robot.n_actuated, self.robot.model.nq
        statuses = [OK] * n
        raw, configurations = np.full((n, na), np.nan), np.full((n, nq), np.nan)
        residuals, inversion = np.full((n, 2), np.nan), np.full(n, np.nan)
        reasons: list[list[tuple[float, str]]] = [[] for _ in range(n)]  # (how close the start came [m, rad], why)
        pending = np.arange(n)
        tried = 0
        for start in self.starts():
            if not pending.size:
                break
            tried += 1
            done, answers, why = self._attempt(goals.take(pending), start)
            rows = pending[done]
            raw[rows], configurations[rows], residuals[rows], inversion[rows] = answers
            for k, reason in why.items():
                reasons[int(pending[k])].append(reason)
            pending = pending[~done]
            if advance is not None:
                advance(len(rows))
        if advance is not None and pending.size:
            advance(int(pending.size))  # the targets no start reached: done too
        for k in pending.tolist():
            # the reason of a start that reached the target in joint space comes first, else the nearest miss
            _, nearest = min(reasons[k], key=lambda item: item[0])
            statuses[k] = f"{UNREACHABLE}: {nearest} ({tried} starts)"
        return Commands(statuses, raw, configurations, residuals, inversion)

    def solve_from(self, goals: Goals, starts: Array) -> Commands:
        """The commands for every target of ``goals`` (world frame) from its own start alone (``starts``: (N, nq)
        configurations), checked as :meth:`solve` checks them: where a program fixes the branch (``pincal filter``
        starts each target from the nominal controller's answer). A target not passed from its start is unreachable,
        with the reason."""
        n, na, nq = len(goals), self.robot.n_actuated, self.robot.model.nq
        raw, configurations = np.full((n, na), np.nan), np.full((n, nq), np.nan)
        residuals, inversion = np.full((n, 2), np.nan), np.full(n, np.nan)
        done, answers, why = self._attempt(goals, np.asarray(starts, dtype=float))
        rows = np.flatnonzero(done)
        raw[rows], configurations[rows], residuals[rows], inversion[rows] = answers
        statuses = [OK if done[k] else f"{UNREACHABLE}: {why[k][1]}" for k in range(n)]
        return Commands(statuses, raw, configurations, residuals, inversion)

    def _attempt(self, goals: Goals, start: Array) -> tuple[npt.NDArray[np.bool_], tuple[Array, Array, Array, Array],
                                                            dict[int, tuple[float, str]]]:
        """Every target of ``goals`` from ``start`` (nq,), or each from its own row of ``start`` (N, nq): which passed,
        their (raw commands, configurations, residuals, inversion gaps), and why each other one failed (row ->
        (closeness, reason))."""
        frame, n = self.frame, len(goals)
        pose = goals.rotations is not None
        why: dict[int, tuple[float, str]] = {}
        starts = np.array(np.broadcast_to(start, (n, start.shape[-1])), dtype=float)
        start_values = frame.actuated_values(starts)
        ik = solve_ik(frame, goals, starts, SOLVE_TOLERANCE)
        q, ok = ik.q.copy(), ik.converged.copy()
        failed = np.flatnonzero(~ok)
        if failed.size:  # Gauss–Newton over the actuated joints alone, within their limits
            rescue = actuated_newton(frame, goals.take(failed), start_values[failed], self.lower,
                                     self.upper, SOLVE_TOLERANCE)
            q[failed[rescue.converged]], ok[failed[rescue.converged]] = rescue.q[rescue.converged], True
            lost = failed[~rescue.converged]
            if lost.size:
                state = frame.state(ik.q[lost])
                misses = goals.take(lost).gaps(state)[:, 0]
                for k, miss, ratio, closeness in zip(lost.tolist(), misses.tolist(), self.ratios(state, pose).tolist(),
                                                     ik.residual[lost].tolist(), strict=True):
                    edge = (f", near a singular posture (singular values in the ratio {ratio:.2g}: the edge of the "
                            "workspace)" if ratio < NEAR_SINGULAR else "")
                    why[k] = (closeness, f"inverse kinematics did not converge: the nearest posture found leaves the "
                                         f"frame {miss:.3g} m from the target{edge}")
        rows = np.flatnonzero(ok)
        wanted = self.settled(frame.actuated_values(q[rows]), start_values[rows])
        outside = np.flatnonzero(self.outside_rows(wanted))
        if outside.size:  # the same targets with the joints held within their limits
            inside = actuated_newton(frame, goals.take(rows[outside]), wanted[outside], self.lower, self.upper,
                                     SOLVE_TOLERANCE)
            moved = outside[inside.converged]
            q[rows[moved]] = inside.q[inside.converged]
            wanted[moved] = self.settled(frame.actuated_values(q[rows[moved]]), wanted[moved])
        raw, gaps = self.model.raw(wanted)
        for k, (model_why, raw_why) in enumerate(zip(self.outside(wanted, "the model's"),
                                                     self.outside(raw, "the raw command of"), strict=True)):
            if model_why or raw_why:
                why[int(rows[k])] = (0.0, model_why or raw_why)
        keep = np.array([int(r) not in why for r in rows], dtype=bool)
        rows, raw, gaps = rows[keep], raw[keep], gaps[keep]
        closed_q, closed = frame.forward(self.model.corrected(raw), None)  # as the robot runs: the reference assembly
        for k in rows[~closed].tolist():
            why[k] = (0.0, "the loops do not close at the commands")
        rows, raw, gaps, closed_q = rows[closed], raw[closed], gaps[closed], closed_q[closed]
        state = frame.state(closed_q)
        residuals = goals.take(rows).gaps(state)
        ratios = self.ratios(state, pose)
        passed = np.zeros(len(rows), dtype=bool)
        for k, (row, residual, ratio) in enumerate(zip(rows.tolist(), residuals, ratios.tolist(), strict=True)):
            worst = float(np.nanmax(residual))
            if not worst <= self.tolerance:
                why[row] = (worst, f"at the commands the model assembles otherwise (its reference assembly): the frame "
                                   f"lands {residual[0]:.3g} m from the target")
            elif ratio < SINGULAR_RATIO:
                why[row] = (0.0, f"singular posture: the frame's Jacobian has singular values in the ratio {ratio:.3g}")
            else:
                passed[k] = True
        done = np.zeros(n, dtype=bool)
        done[rows[passed]] = True
        return done, (raw[passed], closed_q[passed], residuals[passed], gaps[passed]), why  # rows ascending

    def settled(self, values: Array, near: Array) -> Array:
        """Actuated values (N, na) as commanded: revolute values moved by whole turns into their limits (nearest to
        ``near`` when several fit), the joints that cannot move the frame at their reference."""
        out = np.array(values, dtype=float)
        near = np.broadcast_to(near, out.shape)
        for k in np.flatnonzero(self.turns):
            candidates = out[:, k, None] + 2 * np.pi * np.arange(-3, 4)
            fits = (candidates >= self.lower[k] - LIMIT_SLACK) & (candidates <= self.upper[k] + LIMIT_SLACK)
            distance = np.where(fits, np.abs(candidates - near[:, k, None]), np.inf)
            best = np.argmin(distance, axis=1)
            rows = np.flatnonzero(fits.any(axis=1))
            out[rows, k] = candidates[rows, best[rows]]
        out[:, self.idle] = self.reference[self.idle]
        return out

    def outside_rows(self, values: Array) -> npt.NDArray[np.bool_]:
        """(N,) which rows of actuated values (N, na) pass a limit."""
        with np.errstate(invalid="ignore"):
            beyond = (values < self.lower - LIMIT_SLACK) | (values > self.upper + LIMIT_SLACK)
        return np.asarray(beyond.any(axis=1), dtype=bool)

    def outside(self, values: Array, what: str) -> list[str]:
        """Per row of actuated values (N, na), the first joint beyond its limits in words, or ``""``."""
        out = [""] * len(values)
        for row in np.flatnonzero(self.outside_rows(values)).tolist():
            value = values[row]
            k = int(np.flatnonzero((value < self.lower - LIMIT_SLACK) | (value > self.upper + LIMIT_SLACK))[0])
            name = self.robot.actuated_joints[k]
            out[row] = (f"outside the joint limits: {what} {name} = {value[k]:.6g} {joint_unit(self.robot, name)}, "
                        f"limits [{self.lower[k]:.6g}, {self.upper[k]:.6g}]")
        return out

    def ratios(self, state: FrameState, pose: bool) -> Array:
        """(N,) smallest over largest singular value of the frame's Jacobian over the actuated joints (its position
        rows, or all six for a pose); 0 where it cannot be computed."""
        jacobian = state.actuated_jacobian(self.robot.kinematics)[:, : 6 if pose else 3]
        out = np.zeros(len(jacobian))
        finite = np.flatnonzero(np.all(np.isfinite(jacobian), axis=(1, 2)))
        if finite.size:
            s = np.linalg.svd(jacobian[finite], compute_uv=False)
            with np.errstate(invalid="ignore", divide="ignore"):
                out[finite] = np.where(s[:, 0] > 0, s[:, -1] / s[:, 0], 0.0)
        return np.nan_to_num(out, nan=0.0)

