"""Closed-loop kinematics of many samples at once: the loops closed by stacked Newton steps.

Built on :class:`~pincal.model.batch_loops.BatchLoops` (forward kinematics, the loops' residuals and Jacobians of N
samples): the Newton step solves N small systems ``C_p δv_p = −c`` at once (stacked LAPACK solves), warm starts and
continuation move every sample together.

The answers are those of the per-sample solvers, on the same assembly: a warm start is kept only when its Newton
iterates move no passive coordinate by more than :data:`~pincal.model.kinematics.CONTINUATION_STEP` (as
:meth:`~pincal.model.kinematics.ClosedLoopKinematics.warm_solve`), a cold start is continuation from the reference
configuration in the same steps as :meth:`~pincal.model.kinematics.ClosedLoopKinematics.continuation`. A sample
these do not close is reported, never dropped: the caller solves it alone (continuation with finer steps).
"""

from __future__ import annotations

import math

import numpy as np
import pinocchio as pin

from pincal.model.batch_frames import (
    Array,
    BoolArray,
    Geometry,
    JointPlacements,
    LoopFrames,
    LoopState,
    LoopSystem,
    passive_gains,
    take_frames,
)
from pincal.model.batch_loops import BatchLoops
from pincal.model.closure import LoopClosure
from pincal.model.kinematics import CONTINUATION_STEP, MAX_CONTINUATION_STEPS
from pincal.model.per_thread import per_thread

__all__ = ["BatchKinematics", "BatchLoops", "Geometry", "JointPlacements", "LoopFrames", "LoopState", "LoopSystem",
           "passive_gains"]

#: Largest closure residual component [m, rad] past which a Newton solve gives up (as the per-sample one).
DIVERGED = 1e3
#: Largest closure residual component [m, rad] of the answers of :meth:`BatchKinematics.continuation` (a batched first
#: solve): closer than the solvers' tolerance, as these answers are the origin of every later warm start and of
#: simulated data (a noise-free 3-UCR pose study recovers its parameters to 7e-12 from them, 3.7e-9 at 1e-11);
#: Newton's quadratic convergence makes it one more pass at most, and a sample that cannot reach it is solved alone
#: (to the solvers' tolerance). Batched solves only: a set of fewer than ``SMALL_BATCH`` samples, a sample solved
#: alone and :meth:`~pincal.model.kinematics.ClosedLoopKinematics.solve_fk` close to the solvers' tolerance.
FIRST_SOLVE_TOLERANCE = 1e-13


class _KeptPasses:
    """The kinematics of a thread's last Newton pass, when it closed every sample (``last_pass``: the placements and
    loop frames), and of its last warm solve that did so (``closed``: its model and loops, held so that they stay the
    same objects, the answers, the placements and frames), for :meth:`BatchKinematics.linearised` to reuse."""

    def __init__(self) -> None:
        self.last_pass: tuple[JointPlacements, list[LoopFrames]] | None = None
        self.closed: tuple[pin.Model, LoopClosure, Array, JointPlacements, list[LoopFrames]] | None = None


class BatchKinematics(BatchLoops):
    """Batched closed-loop kinematics for one robot structure: :class:`~pincal.model.batch_loops.BatchLoops`, and the
    loops closed for every sample at once (Newton, warm starts, continuation from the reference).

    Args:
        kinematics: The per-sample kinematics whose structure (joints, loops, actuated joints, reference
            configuration) this batches; any model and closure with the same structure may be passed to the methods
            (a robot at other parameters).
    """

    @per_thread
    def _kept(self) -> _KeptPasses:
        """What this thread's last solves left (:class:`_KeptPasses`): one per thread, as the solves that write it."""
        return _KeptPasses()

    def linearised(self, model: pin.Model, closure: LoopClosure, q: Array) -> LoopSystem:
        """The loops at closed configurations ``q`` (N, nq), for the implicit-function theorem: placements, anchor
        frames, and ``C_p`` with the spherical loops' rows in the world frame (:meth:`solver_rows`)."""
        geometry = self.geometry(model, closure)
        kept = self._kept
        closed, kept.closed = kept.closed, None
        if closed is not None and closed[0] is model and closed[1] is closure and np.array_equal(closed[2], q):
            placements, frames = closed[3], closed[4]  # the last warm solve's final pass, at these very q
        else:
            placements = self.forward(geometry, q)
            frames = self.loop_frames(geometry, placements)
        return LoopSystem(placements, frames, self._newton_system(geometry, placements, frames))

    # --- Newton -------------------------------------------------------------------------------------
    def close_loops(self, model: pin.Model, closure: LoopClosure, q: Array, tol: Array | float,
                    max_iter: int = 30, max_step: float = 0.5, max_move: float = math.inf
                    ) -> tuple[Array, Array, BoolArray]:
        """Newton over the passive joints of every sample from ``q`` (N, nq), actuated values held.

        Each iteration rebuilds every unconverged sample's Jacobian and solves its step (a true Newton step: the
        per-sample solver's chord steps save Pinocchio calls, here the Jacobian costs about as much as the residual).
        A spherical loop's rows enter the step in the world frame (``p₂ − p₁`` and its Jacobian): the same step, as
        rotating a block of rows changes neither the solution of a square system nor a least-squares one.

        Args:
            model: The robot's model (at the parameters to solve for).
            closure: Its loops.
            q: (N, nq) start configurations, actuated values set.
            tol: Largest accepted closure residual component [m, rad], one or one per sample.
            max_iter: Most Newton iterations.
            max_step: Largest norm of one step over the passive velocities [rad or m].
            max_move: Largest change of any passive coordinate from ``q`` [rad or m]; a sample that goes farther
                stops unconverged (a jump).

        Returns:
            The configurations reached (N, nq), the residual reached (N,) (largest component [m, rad]), and which
            samples converged (N,).
        """
        return self._close_loops(self.geometry(model, closure), q, tol, max_iter, max_step, max_move)

    def _close_loops(self, geometry: Geometry, q: Array, tol: Array | float, max_iter: int = 30,
                     max_step: float = 0.5, max_move: float = math.inf, origin: Array | None = None
                     ) -> tuple[Array, Array, BoolArray]:
        q = np.array(q, dtype=float)
        n = len(q)
        tols = np.broadcast_to(np.asarray(tol, dtype=float), (n,))
        norms = np.full(n, math.inf)
        converged = np.zeros(n, dtype=bool)
        start = q.copy() if origin is None else origin  # where max_move is measured from
        active = np.arange(n)
        kept = self._kept
        kept.last_pass = None
        for it in range(max_iter + 1):
            if not active.size:
                break
            placements = self.forward(geometry, q[active])
            frames = self.loop_frames(geometry, placements)
            norm = np.abs(self._residual(frames)).max(axis=1)
            norms[active] = norm
            done = norm <= tols[active]
            converged[active[done]] = True
            going = ~done & np.isfinite(norm) & (norm <= DIVERGED) & (it < max_iter)
            if not np.any(going):
                # every sample closed in this pass: its kinematics are the answers' (kept for linearised)
                kept.last_pass = (placements, frames) if active.size == n and np.all(done) else None
                break
            if not np.all(going):
                placements = placements.take(going)
                frames = [take_frames(frame, going) for frame in frames]
            active = active[going]
            # a full Newton step: here a Jacobian costs about one forward kinematics pass, and chord steps (the
            # per-sample solver's, where it costs several) took twice the iterations in continuation
            gains = passive_gains(self._newton_system(geometry, placements, frames))
            step = -np.einsum("nij,nj->ni", gains, self._newton_residual(frames))
            size = np.sqrt(np.einsum("ni,ni->n", step, step))
            step *= np.minimum(1.0, max_step / np.where(size > 0.0, size, 1.0))[:, None]
            finite = np.all(np.isfinite(step), axis=1)
            q[active] = self.retract(q[active], np.where(finite[:, None], step, 0.0))
            if math.isfinite(max_move):
                finite &= np.abs(self.passive_difference(q[active], start[active])).max(axis=1) <= max_move
            active = active[finite]  # a singular step or a jump: stops there, unconverged
        return q, norms, converged

    def warm_solve(self, model: pin.Model, closure: LoopClosure, q_actuated: Array, guesses: Array,
                   tol: float, predicted: Array | None = None) -> tuple[Array, BoolArray]:
        """Newton from each guess with its actuated values set (:meth:`ClosedLoopKinematics.warm_solve` for every
        sample): refused (not converged) when the guess is more than one continuation step away in actuated values,
        or when Newton fails or moves a passive coordinate by more than one step from the guess.

        Args:
            model: The robot's model (at the parameters to solve for).
            closure: Its loops.
            q_actuated: (N, na) actuated values [rad or m].
            guesses: (N, nq) closed configurations, each a previous answer near the sample's.
            tol: Largest accepted closure residual component [m, rad].
            predicted: (N, n_passive) a first-order prediction of each sample's passive joints' change from its guess
                [rad or m] (the calibration's: the configuration's response to the parameters times their change), or
                None. Newton starts there; the refusals still measure from the guess.

        Returns:
            (N, nq) configurations and (N,) which are answers (the others: solve them alone).
        """
        span = np.abs(self.kinematics.actuated_delta(q_actuated, self.actuated_values(guesses))).max(axis=1,
                                                                                                    initial=0.0)
        near = span <= CONTINUATION_STEP  # NaN compares False: refused too
        q = np.array(guesses, dtype=float)
        ok = np.zeros(len(q), dtype=bool)
        rows = np.flatnonzero(near)
        if rows.size:
            start = q[rows]
            start[:, self.actuated_q] = q_actuated[rows]
            origin = start.copy()
            if predicted is not None:
                start = self.retract(start, predicted[rows])
            solved, _, converged = self._close_loops(self.geometry(model, closure), start, tol,
                                                     max_move=CONTINUATION_STEP, origin=origin)
            q[rows] = solved
            ok[rows] = converged
            kept = self._kept
            if kept.last_pass is not None:
                kept.closed = (model, closure, solved, *kept.last_pass)
        return q, ok

    def continuation(self, model: pin.Model, closure: LoopClosure, q_actuated: Array, tol: float
                     ) -> tuple[Array, BoolArray]:
        """The reference assembly for every sample: continuation from the reference configuration in
        ``max(1, ⌈max|Δq_a| / CONTINUATION_STEP⌉)`` steps, all samples stepping together
        (:meth:`ClosedLoopKinematics.reference_continuation`'s first try). Newton starts the first step from the
        reference's tangent prediction ``q_ref + (dq_p/dq_a) Δq_a``, the later ones from the secant prediction
        ``2 q_k − q_{k−1}`` of the passive joints (the per-sample solver starts from ``q_k``): the same branch's
        answer, in fewer iterations.

        Returns:
            (N, nq) configurations and (N,) which converged (the others: solve them alone, with finer steps).
        """
        n = len(q_actuated)
        origin = self.actuated_values(self.reference[None, :])[0]
        path = self.kinematics.actuated_delta(q_actuated, np.broadcast_to(origin, q_actuated.shape))
        span = np.abs(path).max(axis=1, initial=0.0)
        reachable = np.isfinite(span) & (span <= MAX_CONTINUATION_STEPS * CONTINUATION_STEP)
        steps = np.maximum(1, np.ceil(np.where(reachable, span, 0.0) / CONTINUATION_STEP)).astype(int)
        q = np.tile(self.reference, (n, 1))
        before = q.copy()  # each sample's configuration one step back
        alive = reachable.copy()
        geometry = self.geometry(model, closure)
        tangent = self._reference_tangent(model, closure)
        for k in range(1, int(steps[alive].max(initial=0)) + 1):
            rows = np.flatnonzero(alive & (steps >= k))
            if not rows.size:
                break
            start = q[rows]
            start[:, self.actuated_q] = origin + path[rows] * (k / steps[rows])[:, None]
            if k > 1:  # a secant predictor along the path (equal steps): Newton starts nearer the same branch
                start = self.retract(start, self.passive_difference(q[rows], before[rows]))
            elif tangent is not None:  # from the reference, its tangent: the same for every sample
                start = self.retract(start, (path[rows] / steps[rows, None]) @ tangent.T)
            last = steps[rows] == k
            tols = np.where(last, min(tol, FIRST_SOLVE_TOLERANCE), max(tol, 1e-8))
            solved, _, converged = self._close_loops(geometry, start, tols, max_iter=20)
            before[rows] = q[rows]
            q[rows] = solved
            alive[rows[~converged]] = False
        return q, alive

    def _reference_tangent(self, model: pin.Model, closure: LoopClosure) -> Array | None:
        """``dq_p/dq_a = −C_p⁺ C_a`` (n_passive × na) at the reference configuration, if it closes the loops (the
        first continuation step's predictor; None: no predictor)."""
        state = self.state(model, closure, self.reference[None, :])
        assert state.jacobian is not None
        if not np.abs(state.residual).max(initial=0.0) <= 1e-6:
            return None
        passive, actuated = state.jacobian[0][:, self.passive_v], state.jacobian[0][:, self.actuated_v]
        tangent, *_ = np.linalg.lstsq(passive, -actuated, rcond=None)
        return np.asarray(tangent, dtype=float) if np.all(np.isfinite(tangent)) else None

    def solve(self, model: pin.Model, closure: LoopClosure, q_actuated: Array, guesses: Array | None,
              tol: float) -> tuple[Array, BoolArray]:
        """Forward kinematics of every sample: warm from ``guesses`` (N, nq) where given (None: cold starts), by
        continuation from the reference for the samples without one or whose warm start was refused.

        Returns:
            (N, nq) configurations and (N,) which are answers (the others: solve them alone).
        """
        q_actuated = np.asarray(q_actuated, dtype=float)
        n = len(q_actuated)
        q = np.empty((n, self.nq))
        ok = np.zeros(n, dtype=bool)
        if guesses is not None:
            q[:], ok[:] = self.warm_solve(model, closure, q_actuated, guesses, tol)
        cold = np.flatnonzero(~ok)
        if cold.size:
            q[cold], ok[cold] = self.continuation(model, closure, q_actuated[cold], tol)
        return q, ok
