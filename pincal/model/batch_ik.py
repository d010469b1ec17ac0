"""Inverse kinematics of one frame towards many targets at once, every target from its own start.

The solvers of :class:`~pincal.model.kinematics.ClosedLoopKinematics` and of ``pincal compensate``, for rows of
targets: their steps, bounds, tolerances and iteration counts, on a
:class:`~pincal.model.frame_kinematics.FrameKinematics` (every row at once where the batched arrays take the robot, else
row by row). A row's arithmetic reads that row alone, so its answer depends on its target and start, never on the
other rows or their order (fewer than :data:`~pincal.model.frame_kinematics.SMALL_BATCH` rows: :func:`newton` is the
per-sample solver itself, row after row, the same steps without the stacked arrays' fixed cost).

- :func:`newton`: damped Gauss–Newton over all the joints on the loops' residual stacked with the frame's error
  (``p − p_t`` [m], and ``log3(R_tᵀ R)`` [rad] for a pose), the step of
  :func:`~pincal.model.kinematics.damped_gauss_newton_step` (:func:`damped_steps`);
- :func:`solve_ik`: :func:`newton` from the start, then, for the rows it does not bring there, continuation in space:
  waypoints on the screw motion from the frame's placement at the start to the target, ``⌈span / 0.05⌉`` of them (at
  least 2; span the larger of the distance [m] and the angle [rad]), each solved from the last, then four times as
  many (:meth:`~pincal.model.kinematics.ClosedLoopKinematics.solve_ik`);
- :func:`actuated_newton`: Gauss–Newton over the actuated values alone, the loops closed by forward kinematics (the
  reference assembly, as the robot runs), the values held within their limits.
"""

from __future__ import annotations

import math

import numpy as np
import pinocchio as pin

from pincal.model.batch_frames import Array, BoolArray, IntArray
from pincal.model.frame_kinematics import SMALL_BATCH, FrameKinematics, FrameState
from pincal.model.rotations import jlog3, log3
from pincal.records import record

#: Damping of the inverse kinematics' Gauss–Newton steps (relative, as the per-sample solver's).
IK_DAMPING = 1e-10
#: Largest residual component [m, rad] past which a solve gives up (as the per-sample one).
DIVERGED = 1e3
#: Largest waypoint spacing [m or rad] of continuation in space.
WAYPOINT_STEP = 0.05
#: Relative cut of the actuated Gauss–Newton's least-squares steps (singular values below it times the largest).
ACTUATED_RCOND = 1e-10


@record(frozen=True)
class Goals:
    """Targets of a frame, one per row, in the world frame.

    Attributes:
        positions: (N, 3) [m].
        rotations: (N, 3, 3) orientations, or None: position targets (the orientation free).
    """

    positions: Array
    rotations: Array | None

    def __len__(self) -> int:
        return len(self.positions)

    def take(self, rows: IntArray | BoolArray) -> Goals:
        """The targets ``rows`` (indices or a mask)."""
        return Goals(self.positions[rows], None if self.rotations is None else self.rotations[rows])

    def target(self, k: int) -> pin.SE3 | Array:
        """Target ``k`` as the per-sample solvers take it: a placement, or a position (3,) [m]."""
        if self.rotations is None:
            return np.array(self.positions[k], dtype=float)
        return pin.SE3(self.rotations[k], self.positions[k])

    def error(self, state: FrameState, jacobian: Array) -> tuple[Array, Array]:
        """The frame's error to each target (N, 3 or 6) [m, rad] and its rows of ``jacobian`` (N, 6, k), the frame's
        twist per unit of k motions (``LOCAL_WORLD_ALIGNED``): ``p − p_t``, then ``log3(R_tᵀ R)`` with the rows
        ``Jlog3 · Rᵀ · J_ω``."""
        error = state.origin - self.positions
        rows = jacobian[:, :3]
        if self.rotations is not None:
            relative = np.swapaxes(self.rotations, 1, 2) @ state.rotation
            if len(relative) < SMALL_BATCH:  # a few rows: Pinocchio's, without the stacked functions' fixed cost
                angle = np.array([pin.log3(r) for r in relative]).reshape(-1, 3)
                derivative = np.array([pin.Jlog3(r) for r in relative]).reshape(-1, 3, 3)
            else:
                angle = log3(relative)
                derivative = jlog3(angle)
            error = np.hstack([error, angle])
            turned = derivative @ np.swapaxes(state.rotation, 1, 2) @ jacobian[:, 3:]
            rows = np.concatenate([rows, turned], axis=1)
        return error, rows

    def gaps(self, state: FrameState) -> Array:
        """(N, 2) the distance [m] from the frame to each target and, for poses, the angle [rad] (NaN for positions)."""
        out = np.full((len(self), 2), np.nan)
        out[:, 0] = np.linalg.norm(state.origin - self.positions, axis=1)
        if self.rotations is not None:
            out[:, 1] = np.linalg.norm(log3(np.swapaxes(self.rotations, 1, 2) @ state.rotation), axis=1)
        return out


@record(frozen=True)
class Solved:
    """Rows solved: (N, nq) configurations, (N,) the largest residual component reached [m, rad], (N,) which
    converged."""

    q: Array
    residual: Array
    converged: BoolArray


def newton(frame: FrameKinematics, goals: Goals, start: Array, tol: Array | float, max_iter: int = 40,
           max_step: float = 0.5) -> Solved:
    """Damped Gauss–Newton over all the joints from ``start`` (N, nq) towards each target, the loops closed on the
    way (:meth:`~pincal.model.kinematics.ClosedLoopKinematics.solve_ik_newton` for every row).

    Args:
        frame: The frame.
        goals: Its targets.
        start: (N, nq) the start of each row.
        tol: Largest accepted residual component (loops and target) [m, rad], one or one per row.
        max_iter: Most iterations.
        max_step: Largest norm of one step over the joint velocities [rad or m].
    """
    q = np.array(start, dtype=float)
    n = len(q)
    tols = np.broadcast_to(np.asarray(tol, dtype=float), (n,))
    norms = np.full(n, np.inf)
    converged = np.zeros(n, dtype=bool)
    if n < SMALL_BATCH:  # a few rows: the per-sample solver itself, without the stacked arrays' fixed cost
        for k in range(n):
            report = frame.kinematics.solve_ik_newton(q[k].copy(), frame.frame_id, goals.target(k), float(tols[k]),
                                                      max_iter, max_step)
            q[k], norms[k], converged[k] = report.q, report.residual, report.converged
        return Solved(q, norms, converged)
    active = np.arange(n)
    for it in range(max_iter + 1):
        if not active.size:
            break
        state = frame.state(q[active])
        task, rows = goals.take(active).error(state, state.jacobian)
        error = np.hstack([state.residual, task])
        with np.errstate(invalid="ignore"):
            norm = np.abs(error).max(axis=1)
        norms[active] = norm
        done = norm <= tols[active]
        converged[active[done]] = True
        going = ~done & np.isfinite(norm) & (norm <= DIVERGED) & (it < max_iter)
        if not np.any(going):
            break
        jacobian = np.concatenate([state.closure_jacobian, rows], axis=1)[going]
        active = active[going]
        step = damped_steps(jacobian, error[going], IK_DAMPING)
        size = np.sqrt(np.einsum("ni,ni->n", step, step))
        step *= np.minimum(1.0, max_step / np.where(size > 0.0, size, 1.0))[:, None]
        finite = np.all(np.isfinite(step), axis=1)  # a singular system: stops there, unconverged
        active, step = active[finite], step[finite]
        if active.size:
            q[active] = frame.integrate(q[active], step)
    return Solved(q, norms, converged)


def solve_ik(frame: FrameKinematics, goals: Goals, start: Array, tol: float) -> Solved:
    """Configurations placing the frame on each target: :func:`newton` from ``start`` (N, nq), then continuation in
    space for the rows it leaves (this module's docstring). A row no attempt brings there keeps the attempt that came
    nearer, its residual measured to the target itself."""
    first = newton(frame, goals, start, tol)
    q, residual, converged = first.q.copy(), first.residual.copy(), first.converged.copy()
    failed = np.flatnonzero(~converged)
    if not failed.size:
        return Solved(q, residual, converged)
    here = frame.state(start[failed])
    waypoints = _Waypoints(here, goals.take(failed))
    last = first.q[failed].copy()  # each row's configuration where the last continuation stopped
    last_residual = first.residual[failed].copy()
    pending = np.arange(failed.size)
    for factor in (1, 4):
        steps = waypoints.base[pending] * factor
        current = start[failed[pending]].copy()
        alive = np.ones(pending.size, dtype=bool)
        for k in range(1, int(steps.max(initial=0)) + 1):
            rows = np.flatnonzero(alive & (steps >= k))
            if not rows.size:
                break
            final = steps[rows] == k
            sub = waypoints.at(pending[rows], k / steps[rows])
            solved = newton(frame, sub, current[rows], np.where(final, tol, max(tol, 1e-8)))
            last[pending[rows]], last_residual[pending[rows]] = solved.q, solved.residual
            current[rows] = np.where(solved.converged[:, None], solved.q, current[rows])
            alive[rows[~solved.converged]] = False
        reached = alive  # every row alive at its last step converged there
        q[failed[pending[reached]]] = current[reached]
        converged[failed[pending[reached]]] = True
        residual[failed[pending[reached]]] = last_residual[pending[reached]]
        pending = pending[~reached]
        if not pending.size:
            break
    if pending.size:  # the attempt nearer to the target itself: Newton's from the start, or the continuation's
        rows = failed[pending]
        candidates = [first.q[rows], last[pending]]
        gaps = [_task_norm(frame, goals.take(rows), c) for c in candidates]
        nearer = gaps[1] < gaps[0]
        q[rows] = np.where(nearer[:, None], candidates[1], candidates[0])
        residual[rows] = np.where(nearer, gaps[1], gaps[0])
    return Solved(q, residual, converged)


def actuated_newton(frame: FrameKinematics, goals: Goals, start: Array, lower: Array, upper: Array, tol: float,
                    max_iter: int = 40, max_step: float = 0.2) -> Solved:
    """Gauss–Newton over the actuated values alone from ``start`` (N, na) [rad or m], the loops closed by forward
    kinematics (the reference assembly, warm from the last iterate), kept within ``[lower, upper]`` (na,): a value at
    a limit that the step would pass is held there, and the others solve without it; a step is at most ``max_step``
    long. Converged: the frame within ``tol`` [m, rad] of the target (every component)."""
    kin = frame.kinematics
    n = len(start)
    actuated = np.clip(np.array(start, dtype=float), lower, upper)
    q = np.tile(kin.reference, (n, 1))
    guesses: Array | None = None
    residual = np.full(n, np.inf)
    converged = np.zeros(n, dtype=bool)
    active = np.arange(n)
    for _ in range(max_iter):
        if not active.size:
            break
        closed, ok = frame.forward(actuated[active], None if guesses is None else guesses[active])
        if guesses is None:
            guesses = np.tile(kin.reference, (n, 1))
        guesses[active] = closed
        q[active] = closed
        active, closed = active[ok], closed[ok]
        if not active.size:
            break
        state = frame.state(closed)
        error, jacobian = goals.take(active).error(state, state.actuated_jacobian(kin))
        with np.errstate(invalid="ignore"):
            norm = np.abs(error).max(axis=1)
        residual[active] = norm
        done = norm <= tol
        converged[active[done]] = True
        going = ~done & np.all(np.isfinite(jacobian), axis=(1, 2)) & np.isfinite(norm)
        active, error, jacobian = active[going], error[going], jacobian[going]
        if not active.size:
            break
        values = actuated[active]
        step = _least_squares(jacobian, -error)
        held = ((values <= lower) & (step < 0)) | ((values >= upper) & (step > 0))
        again = np.flatnonzero(held.any(axis=1))
        if again.size:  # the joints at a limit held there, the others solving without them
            masked = np.where(held[again, None, :], 0.0, jacobian[again])
            step[again] = _least_squares(masked, -error[again])
            step[again] = np.where(held[again], 0.0, step[again])
        size = np.linalg.norm(step, axis=1)
        step *= np.where(size > max_step, max_step / np.where(size > 0.0, size, 1.0), 1.0)[:, None]
        actuated[active] = np.clip(values + step, lower, upper)
    return Solved(q, residual, converged)


def damped_steps(jacobian: Array, residual: Array, damping: float) -> Array:
    """(N, n) the steps of :func:`~pincal.model.kinematics.damped_gauss_newton_step` for stacked Jacobians (N, m, n)
    and residuals (N, m): ``−Jᵀ(JJᵀ + μI)⁻¹ r`` when ``m < n`` (the null space left untouched rather than round-off
    amplified by 1/μ), else ``−(JᵀJ + μI)⁻¹ Jᵀ r``; ``μ = damping · (1 + tr(JᵀJ)/n)``; NaN for a singular one."""
    n, rows, cols = jacobian.shape
    transposed = np.swapaxes(jacobian, 1, 2)
    if rows < cols:
        system, rhs = jacobian @ transposed, np.array(residual, dtype=float)
    else:
        system, rhs = transposed @ jacobian, np.einsum("nij,nj->ni", transposed, residual)
    size = system.shape[1]
    diagonal = np.arange(size)
    system[:, diagonal, diagonal] += (damping * (1.0 + np.trace(system, axis1=1, axis2=2) / cols))[:, None]
    solved = np.full((n, size), np.nan)
    with np.errstate(all="ignore"):
        try:
            solved[:] = np.linalg.solve(system, rhs[:, :, None])[:, :, 0]
        except np.linalg.LinAlgError:  # one singular: each alone
            for k in range(n):
                try:
                    solved[k] = np.linalg.solve(system[k], rhs[k])
                except np.linalg.LinAlgError:
                    continue
    if rows < cols:
        out: Array = -np.einsum("nij,nj->ni", transposed, solved)
        return out
    return -solved


def _least_squares(jacobian: Array, rhs: Array) -> Array:
    """(N, n) the minimum-norm least-squares solutions of stacked systems (N, m, n) (``numpy.linalg.lstsq`` with
    ``rcond`` :data:`ACTUATED_RCOND`, for every row)."""
    with np.errstate(all="ignore"):
        solution: Array = (np.linalg.pinv(jacobian, rcond=ACTUATED_RCOND) @ rhs[:, :, None])[:, :, 0]
    return solution


def _task_norm(frame: FrameKinematics, goals: Goals, q: Array) -> Array:
    """(N,) the largest residual component (loops and target) [m, rad] at configurations ``q``."""
    state = frame.state(q)
    error, _ = goals.error(state, state.jacobian)
    with np.errstate(invalid="ignore"):
        norm: Array = np.abs(np.hstack([state.residual, error])).max(axis=1)
    return norm


class _Waypoints:
    """The screw motion of each row from the frame's placement ``here`` to its target: ``here · exp6(s δ)``,
    ``δ = log6(here⁻¹ · goal)`` (for a position, the goal keeps ``here``'s orientation: a straight line)."""

    def __init__(self, here: FrameState, goals: Goals) -> None:
        self.here, self.goals = here, goals
        if goals.rotations is None:
            self.motions: list[pin.Motion] = []
            span = np.linalg.norm(goals.positions - here.origin, axis=1)
        else:
            self.motions = [pin.log6(pin.SE3(r, p).actInv(pin.SE3(rt, pt)))
                            for r, p, rt, pt in zip(here.rotation, here.origin, goals.rotations, goals.positions,
                                                    strict=True)]
            span = np.array([max(float(np.linalg.norm(m.linear)), float(np.linalg.norm(m.angular)))
                             for m in self.motions]).reshape(len(goals))
        self.base = np.array([max(2, math.ceil(s / WAYPOINT_STEP)) if math.isfinite(s) else 2 for s in span.tolist()],
                             dtype=int)

    def at(self, rows: IntArray, fraction: Array) -> Goals:
        """The waypoints of ``rows`` at ``fraction`` (one per row) of the way."""
        origin = self.here.origin[rows]
        if self.goals.rotations is None:
            return Goals(origin + (self.goals.positions[rows] - origin) * fraction[:, None], None)
        points = [pin.SE3(self.here.rotation[k], self.here.origin[k]) * pin.exp6(self.motions[k] * float(s))
                  for k, s in zip(rows.tolist(), fraction.tolist(), strict=True)]
        return Goals(np.array([m.translation for m in points]), np.array([m.rotation for m in points]))
