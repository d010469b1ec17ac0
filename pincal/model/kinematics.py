"""Closed-loop kinematics: forward and inverse solvers and derivatives through the loops.

FK holds the actuated joints at their commanded values and drives the loop residual ``c(q)`` to
zero over the passive joints by damped Gauss–Newton on the configuration manifold (Pinocchio's
``integrate``). Its answer is always the **reference assembly**: the configuration that continuation
from the reference configuration reaches (the actuated values moved from the reference's to the target
in steps of at most :data:`CONTINUATION_STEP`, each closed in turn). A warm start is only a shortcut to
that answer: Newton from the guess is kept when it converges without moving any passive coordinate by
more than one continuation step; a larger move is a jump (onto another assembly mode, or another branch
of a joint) and the solve falls back on continuation from the reference. A guess that is itself a
reference-assembly answer (at nearby inputs, or at slightly different parameters) therefore gives the
same answer as a cold solve, and the answer does not depend on the order in which samples are solved.

Derivatives through the loops follow the implicit-function theorem: with
``C = dc/dv = [C_a C_p]``, the passive velocities are ``v_p = -C_p⁺ C_a v_a``.
"""

from __future__ import annotations

import functools
import math

import numpy as np
import numpy.typing as npt
import pinocchio as pin

from pincal import linalg
from pincal.model.closure import LoopClosure
from pincal.model.jacobians import frame_jacobian as pin_frame_jacobian
from pincal.model.per_thread import per_thread
from pincal.records import record

Array = npt.NDArray[np.float64]

#: Largest change of any actuated value in one continuation step [rad or m]; also the largest jump a
#: warm start tries by direct Newton, and the largest move of a passive coordinate a warm start may make
#: before it counts as a jump to another assembly. The cold-start tests (2000 samples per reference robot,
#: checked against closed forms for the assembly branch) pass at this size.
CONTINUATION_STEP = 0.5
#: Most continuation steps a solve may take (a larger span is refused at once: far outside any workspace).
MAX_CONTINUATION_STEPS = 400


def damped_pseudo_inverse(jac: Array, damping: float = 1e-12) -> Array | None:
    """``(JᵀJ + μI)⁻¹ Jᵀ`` with ``μ = damping · (1 + tr(JᵀJ)/n)``; None if singular.

    A square, well-conditioned ``J`` (most parallel robots' passive closure Jacobian) is inverted
    directly by LU, which is several times cheaper for these small sizes.
    """
    rows, cols = jac.shape
    if rows == cols:
        inverse: Array
        _, _, inverse, info = linalg.lapack().dgesv(jac, _identity(rows))
        if info == 0 and float(abs(inverse).max()) < 1e8:
            return inverse
    h = jac.T @ jac
    n = h.shape[0]
    h.flat[:: n + 1] += damping * (1.0 + float(np.trace(h)) / n)
    gain: Array
    _, _, gain, info = linalg.lapack().dgesv(h, jac.T, overwrite_a=1)
    return None if info != 0 else gain


@functools.cache
def _identity(n: int) -> Array:
    eye = np.eye(n)
    eye.flags.writeable = False
    return eye


def damped_gauss_newton_step(jac: Array, residual: Array, damping: float = 1e-12) -> Array | None:
    """Step ``-(JᵀJ + μI)⁻¹ Jᵀ r`` with ``μ = damping · (1 + tr(JᵀJ)/n)``; None if singular.

    LAPACK's ``dgesv`` directly: for the small systems of closed-loop kinematics (n ≈ 10-30),
    ``numpy.linalg.solve``'s overhead would be most of the cost. With fewer rows than columns (a task a redundant robot
    reaches in many ways: a point aimed by a six-axis arm) the same step is ``-Jᵀ(JJᵀ + μI)⁻¹ r``: ``JᵀJ`` then has
    zero eigenvalues that only μ lifts, and solving with it would make the step's null-space part round-off amplified
    by 1/μ (1e-8 rad that differed between BLAS builds, and sent the next solves elsewhere), where ``JJᵀ`` is as well
    conditioned as the task.
    """
    rows, cols = jac.shape
    step: Array
    if rows < cols:
        g = jac @ jac.T
        g.flat[:: rows + 1] += damping * (1.0 + float(np.trace(g)) / cols)  # μ as below: tr(JJᵀ) = tr(JᵀJ)
        _, _, dual, info = linalg.lapack().dgesv(g, np.array(residual, dtype=float), overwrite_a=1, overwrite_b=1)
        return None if info != 0 else -(jac.T @ dual)
    h = jac.T @ jac
    h.flat[:: cols + 1] += damping * (1.0 + float(np.trace(h)) / cols)
    _, _, step, info = linalg.lapack().dgesv(h, jac.T @ residual, overwrite_a=1, overwrite_b=1)
    if info != 0:
        return None
    return -step


@record(frozen=True)
class SolveReport:
    """Outcome of one Newton solve: the configuration, the residual reached and the iterations."""

    q: Array
    residual: float
    iterations: int
    converged: bool


@record(frozen=True)
class ActuatedJoint:
    """Where one actuated joint sits in ``q`` and ``v``; ``nq`` is 2 for unbounded revolutes."""

    name: str
    joint_id: int
    idx_q: int
    idx_v: int
    nq: int


class ClosedLoopKinematics:
    """Newton solvers for a tree plus loop closures, with a fixed set of actuated joints.

    Args:
        model: Pinocchio model of the cut tree.
        closure: Its loop closures.
        actuated: The actuated joints, in the order of ``q_actuated`` vectors.
        reference: The reference configuration (nq,), where the loops close and every FK answer's
            continuation starts; Pinocchio's neutral configuration by default.
    """

    def __init__(self, model: pin.Model, closure: LoopClosure, actuated: list[ActuatedJoint],
                 reference: Array | None = None) -> None:
        self.model = model
        self.reference = pin.neutral(model) if reference is None else np.asarray(reference, dtype=float)
        self.closure = closure
        self.actuated = actuated
        self.actuated_v = np.array([a.idx_v for a in actuated], dtype=int)
        mask = np.ones(model.nv, dtype=bool)
        mask[self.actuated_v] = False
        self.passive_v = np.flatnonzero(mask)
        # fast path when every actuated joint has nq == 1 (no unbounded revolutes)
        self._scalar_q = np.array([a.idx_q for a in actuated], dtype=int)
        self._all_scalar = all(a.nq == 1 for a in actuated)
        self._continuous = np.array([a.nq == 2 for a in actuated], dtype=bool)

    @per_thread
    def data(self) -> pin.Data:
        """Pinocchio's working data of the model, one per thread (:mod:`pincal.model.per_thread`: every method writes
        them), made on first use: they hold nv³ numbers (second-derivative tensors, 250 MB for 198 velocities), which a
        robot described or checked part by part (:mod:`pincal.model.parts`) never needs. ``pinocchio.Data(model)``, not
        ``model.createData()``, which holds a second copy while it returns."""
        return pin.Data(self.model)

    # --- actuated coordinates -------------------------------------------------------------------
    @property
    def continuous(self) -> npt.NDArray[np.bool_]:
        """(na,) which actuated joints are unbounded revolutes (continuous: values compared modulo 2π)."""
        return self._continuous.copy()

    def set_actuated(self, q: Array, q_actuated: Array) -> None:
        """Write actuated values [rad or m] into ``q`` in place."""
        if self._all_scalar:
            q[self._scalar_q] = q_actuated
            return
        for joint, value in zip(self.actuated, q_actuated, strict=True):
            if joint.nq == 1:
                q[joint.idx_q] = value
            else:
                q[joint.idx_q] = math.cos(value)
                q[joint.idx_q + 1] = math.sin(value)

    def actuated_delta(self, target: Array, current: Array) -> Array:
        """``target - current`` [rad or m], wrapped into [-π, π) for unbounded (continuous) joints; rows of
        samples (N, na) as well as one sample (na,)."""
        delta = np.asarray(target, dtype=float) - current
        if not self._all_scalar:
            wrap = self._continuous
            delta[..., wrap] = linalg.wrap_angle(delta[..., wrap])
        return delta

    def actuated_values(self, q: Array) -> Array:
        """Actuated values [rad or m] read from ``q``."""
        if self._all_scalar:
            values: Array = q[self._scalar_q].copy()
            return values
        out = np.empty(len(self.actuated))
        for k, joint in enumerate(self.actuated):
            if joint.nq == 1:
                out[k] = q[joint.idx_q]
            else:
                out[k] = math.atan2(q[joint.idx_q + 1], q[joint.idx_q])
        return out

    # --- residuals ------------------------------------------------------------------------------
    def closure_residual(self, q: Array) -> Array:
        """Stacked loop residual at ``q`` [m, rad]."""
        pin.forwardKinematics(self.model, self.data, q)
        return self.closure.residual(self.data)

    def closure_jacobian(self, q: Array) -> tuple[Array, Array]:
        """Residual and its Jacobian ``dc/dv`` at ``q``."""
        pin.computeJointJacobians(self.model, self.data, q)
        return self.closure.residual_and_jacobian(self.data)

    # --- forward kinematics ---------------------------------------------------------------------
    def close_loops(self, q: Array, tol: float, max_iter: int = 30, max_step: float = 0.5,
                    max_move: float = math.inf) -> SolveReport:
        """Newton over the passive joints from ``q`` (actuated values held), with chord steps.

        The closure Jacobian is rebuilt only when the residual stops falling fast (by 10× per
        step); otherwise the last damped pseudo-inverse is reused and each iteration costs one
        forward-kinematics pass. Warm starts typically take one Jacobian and two cheap steps.

        Args:
            q: Start configuration (nq,), actuated values already set.
            tol: Largest accepted closure residual component [m, rad].
            max_iter: Most Newton iterations.
            max_step: Largest norm of one step over the passive velocities [rad or m].
            max_move: Largest change of any passive coordinate from ``q`` [rad or m] (in the tangent
                space, ``difference(q, ·)``); a solve that goes farther stops unconverged at once (a jump).
        """
        model, data, passive, closure = self.model, self.data, self.passive_v, self.closure
        if closure.rows == 0:
            return SolveReport(q, 0.0, 0, True)
        dv = np.zeros(model.nv)
        pin.computeJointJacobians(model, data, q)
        r, jac = closure.residual_and_jacobian(data)
        norm = float(abs(r).max())
        gain = damped_pseudo_inverse(jac[:, passive])
        start, path = q, 0.0  # path: the steps' summed norms, a bound on any coordinate's change
        for it in range(max_iter + 1):
            if norm <= tol:
                return SolveReport(q, norm, it, True)
            if it == max_iter or gain is None or not math.isfinite(norm) or norm > 1e3:
                break
            step = -(gain @ r)
            size = math.sqrt(float(step @ step))
            if size > max_step:
                step *= max_step / size
            path += min(size, max_step)
            dv[passive] = step
            q = pin.integrate(model, q, dv)
            if path > max_move and float(abs(pin.difference(model, start, q)[passive]).max()) > max_move:
                return SolveReport(q, norm, it + 1, False)
            previous = norm
            pin.forwardKinematics(model, data, q)
            r = closure.residual(data)
            norm = float(abs(r).max())
            if tol < norm > 0.1 * previous:  # slow progress: rebuild the Jacobian (a true Newton step)
                pin.computeJointJacobians(model, data, q)
                r, jac = closure.residual_and_jacobian(data)
                gain = damped_pseudo_inverse(jac[:, passive])
        return SolveReport(q, norm, max_iter, False)

    def continuation(self, start: Array, q_actuated: Array, tol: float, steps: int) -> SolveReport:
        """Close the loops along a straight path of actuated values from ``start``'s to ``q_actuated``."""
        q = start.copy()
        origin = self.actuated_values(start)
        path = self.actuated_delta(q_actuated, origin)  # the short way round for continuous joints
        report = SolveReport(q, math.inf, 0, False)
        total = 0
        for k in range(1, steps + 1):
            self.set_actuated(q, origin + path * (k / steps))
            report = self.close_loops(q, tol if k == steps else max(tol, 1e-8), max_iter=20)
            total += report.iterations
            if not report.converged:
                return SolveReport(report.q, report.residual, total, False)
            q = report.q
        return SolveReport(report.q, report.residual, total, True)

    def solve_fk(self, q_actuated: Array, guess: Array | None, tol: float) -> SolveReport:
        """Full configuration on the reference assembly with the loops closed for ``q_actuated``.

        Args:
            q_actuated: Actuated values [rad or m].
            guess: A configuration (nq,) to warm-start from, or None (cold start).
            tol: Largest accepted closure residual component [m, rad].

        A guess within one continuation step of actuated values tries Newton directly
        (:meth:`warm_solve`); the result is kept if it did not jump. Otherwise (a cold start, a far
        guess, a failed or jumped Newton) :meth:`reference_continuation` gives the answer. A guess
        is only a shortcut to the reference assembly when it lies on it (a previous answer, at nearby
        inputs or parameters): a guess on another assembly that Newton can close without a jump
        stays there.
        """
        if self.closure.rows == 0:  # a tree: nothing to close
            q = (self.reference if guess is None else guess).copy()
            self.set_actuated(q, q_actuated)
            return SolveReport(q, 0.0, 0, True)
        if guess is not None:
            report = self.warm_solve(q_actuated, guess, tol)
            if report is not None:
                return report
        return self.reference_continuation(q_actuated, tol)

    def warm_solve(self, q_actuated: Array, guess: Array, tol: float) -> SolveReport | None:
        """Newton from ``guess`` with the actuated values set; None if it is not a safe shortcut.

        None when the guess is more than :data:`CONTINUATION_STEP` away in actuated values, when
        Newton fails, or when it moves a passive coordinate by more than :data:`CONTINUATION_STEP`
        [rad or m] from the guess (stopped as soon as it does): such a move is a jump, which can land
        on another assembly mode or another branch of a joint, so only continuation from the
        reference can say which is right.
        """
        span = self.actuated_span(q_actuated, guess)
        if not span <= CONTINUATION_STEP:  # NaN compares False: refused too
            return None
        start = guess.copy()
        self.set_actuated(start, q_actuated)
        report = self.close_loops(start, tol, max_move=CONTINUATION_STEP)
        return report if report.converged else None

    def actuated_span(self, q_actuated: Array, q: Array) -> float:
        """Largest change of an actuated value from ``q``'s to ``q_actuated`` [rad or m]."""
        if not self.actuated:
            return 0.0
        return float(abs(self.actuated_delta(q_actuated, self.actuated_values(q))).max())

    def reference_continuation(self, q_actuated: Array, tol: float) -> SolveReport:
        """The reference assembly: continuation from the reference configuration to ``q_actuated``.

        Runs with 1, 4 and 16 times ``max|Δq_a| / CONTINUATION_STEP`` steps (Δq_a from the reference's
        actuated values), the first that closes the loops giving the answer.
        """
        start = self.reference
        span = self.actuated_span(q_actuated, start)
        if not math.isfinite(span) or span > MAX_CONTINUATION_STEPS * CONTINUATION_STEP:
            return SolveReport(start.copy(), math.inf, 0, False)
        base = max(1, math.ceil(span / CONTINUATION_STEP))
        report = SolveReport(start.copy(), math.inf, 0, False)
        for factor in (1, 4, 16):
            if base * factor > 16 * MAX_CONTINUATION_STEPS:
                break
            report = self.continuation(start, q_actuated, tol, base * factor)
            if report.converged:
                return report
        return report

    # --- derivatives through the loops -----------------------------------------------------------
    def configuration_jacobian(self, q: Array) -> Array:
        """``dv/dq_a`` (nv × na) on the closed-loop manifold at ``q`` (implicit-function theorem)."""
        _, jac = self.closure_jacobian(q)
        return self.tangent_from_jacobian(jac)

    def tangent_from_jacobian(self, jac: Array) -> Array:
        """``dv/dq_a`` from a closure Jacobian ``jac`` (rows × nv): ``v_p = -C_p⁺ C_a v_a``."""
        na = len(self.actuated)
        tangent = np.zeros((self.model.nv, na))
        tangent[self.actuated_v, np.arange(na)] = 1.0
        if self.closure.rows:
            cp = jac[:, self.passive_v]
            ca = jac[:, self.actuated_v]
            tangent[self.passive_v] = -linalg.pseudo_inverse(cp, "the passive closure Jacobian") @ ca
        return tangent

    def frame_jacobian(self, q: Array, frame_id: int, reference: pin.ReferenceFrame) -> Array:
        """Frame Jacobian (6 × nv) at ``q`` in ``reference``; the closure Jacobian is left in data."""
        pin.computeJointJacobians(self.model, self.data, q)
        pin.updateFramePlacement(self.model, self.data, frame_id)
        jac: Array = pin_frame_jacobian(self.model, self.data, frame_id, reference)
        return jac

    def frame_jacobian_actuated(self, q: Array, frame_id: int,
                                reference: pin.ReferenceFrame = pin.LOCAL_WORLD_ALIGNED) -> Array:
        """Twist of a frame per unit actuated velocity (6 × na), through the loops."""
        jf = self.frame_jacobian(q, frame_id, reference)
        if self.closure.rows == 0:
            return jf[:, self.actuated_v]
        _, jac = self.closure.residual_and_jacobian(self.data)
        return jf @ self.tangent_from_jacobian(jac)

    # --- inverse kinematics ---------------------------------------------------------------------
    def task_error(self, q: Array, frame_id: int, target: pin.SE3 | Array) -> tuple[Array, Array, Array]:
        """Closure and frame-target residual stacked, with the Jacobian over all of ``v``.

        For an SE3 target the frame rows are ``p - p_t`` [m] and ``log3(R_tᵀ R)`` [rad]; for a
        position target only ``p - p_t``.
        """
        jf = self.frame_jacobian(q, frame_id, pin.LOCAL_WORLD_ALIGNED)
        placement = self.data.oMf[frame_id]
        r, jac = self.closure.residual_and_jacobian(self.data)
        if isinstance(target, pin.SE3):
            rel = target.rotation.T @ placement.rotation
            err = np.concatenate([placement.translation - target.translation, pin.log3(rel)])
            jt = np.vstack([jf[:3], pin.Jlog3(rel) @ placement.rotation.T @ jf[3:]])
        else:
            err = placement.translation - target
            jt = jf[:3]
        return np.concatenate([r, err]), np.vstack([jac, jt]), err

    def solve_ik_newton(self, q: Array, frame_id: int, target: pin.SE3 | Array, tol: float,
                        max_iter: int = 40, max_step: float = 0.5) -> SolveReport:
        """Damped Gauss–Newton over all joints towards a frame target with the loops closed."""
        norm = math.inf
        for it in range(max_iter + 1):
            e, jac, _ = self.task_error(q, frame_id, target)
            norm = float(np.max(np.abs(e)))
            if norm <= tol:
                return SolveReport(q, norm, it, True)
            if it == max_iter or not math.isfinite(norm) or norm > 1e3:
                break
            step = damped_gauss_newton_step(jac, e, damping=1e-10)
            if step is None:
                break
            size = float(np.linalg.norm(step))
            if size > max_step:
                step *= max_step / size
            q = pin.integrate(self.model, q, step)
        return SolveReport(q, norm, max_iter, False)

    def solve_ik(self, target: pin.SE3 | Array, frame_id: int, start: Array, tol: float) -> SolveReport:
        """Configuration placing the frame at ``target``: direct Newton, then continuation in space."""
        report = attempt = self.solve_ik_newton(start.copy(), frame_id, target, tol)
        if report.converged:
            return report
        pin.forwardKinematics(self.model, self.data, start)
        here = pin.updateFramePlacement(self.model, self.data, frame_id).copy()
        goal = target if isinstance(target, pin.SE3) else pin.SE3(here.rotation, np.asarray(target))
        delta = pin.log6(here.actInv(goal)).vector
        span = max(float(np.linalg.norm(delta[:3])), float(np.linalg.norm(delta[3:])))
        base = max(2, math.ceil(span / 0.05))
        for factor in (1, 4):
            steps = base * factor
            q = start.copy()
            for k in range(1, steps + 1):
                waypoint = here * pin.exp6(delta * (k / steps))
                sub = waypoint if isinstance(target, pin.SE3) else waypoint.translation
                report = self.solve_ik_newton(q, frame_id, sub, tol if k == steps else max(tol, 1e-8))
                if not report.converged:
                    break
                q = report.q
            if report.converged:
                return report
        # report the distance to the requested target, not to the waypoint where continuation stopped
        gaps = [(float(abs(self.task_error(rep.q, frame_id, target)[0]).max()), rep) for rep in (attempt, report)]
        gap, best = min(gaps, key=lambda item: item[0])
        return SolveReport(best.q, gap, best.iterations, False)
