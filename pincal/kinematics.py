"""Closed-loop kinematics: forward and inverse solvers and derivatives through the loops.

FK holds the actuated joints at their commanded values and drives the loop residual ``c(q)`` to
zero over the passive joints by damped Gauss–Newton on the configuration manifold (Pinocchio's
``integrate``). Cold starts, and warm starts that fail, fall back on continuation: the actuated
values are moved from the start's own values to the target in small steps, each closed in turn, so
the solution stays on the assembly branch of the start.

Derivatives through the loops follow the implicit-function theorem: with
``C = dc/dv = [C_a C_p]``, the passive velocities are ``v_p = -C_p⁺ C_a v_a``.
"""

from __future__ import annotations

import functools
import math
from dataclasses import dataclass

import numpy as np
import numpy.typing as npt
import pinocchio as pin
from scipy.linalg import lapack

from pincal.closure import LoopClosure

Array = npt.NDArray[np.float64]

#: Largest change of any actuated value in one continuation step [rad or m]; also the largest jump a
#: warm start tries by direct Newton. The cold-start tests (2000 samples per reference robot, checked
#: against closed forms for the assembly branch) pass at this size.
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
        _, _, inverse, info = lapack.dgesv(jac, _identity(rows))
        if info == 0 and float(abs(inverse).max()) < 1e8:
            return inverse
    h = jac.T @ jac
    n = h.shape[0]
    h.flat[:: n + 1] += damping * (1.0 + float(np.trace(h)) / n)
    _, _, gain, info = lapack.dgesv(h, jac.T, overwrite_a=1)
    return None if info != 0 else gain


@functools.cache
def _identity(n: int) -> Array:
    eye = np.eye(n)
    eye.flags.writeable = False
    return eye


def damped_gauss_newton_step(jac: Array, residual: Array, damping: float = 1e-12) -> Array | None:
    """Step ``-(JᵀJ + μI)⁻¹ Jᵀ r`` with ``μ = damping · (1 + tr(JᵀJ)/n)``; None if singular.

    LAPACK's ``dgesv`` directly: for the small systems of closed-loop kinematics (n ≈ 10-30),
    ``numpy.linalg.solve``'s overhead would be most of the cost.
    """
    h = jac.T @ jac
    n = h.shape[0]
    h.flat[:: n + 1] += damping * (1.0 + float(np.trace(h)) / n)
    _, _, step, info = lapack.dgesv(h, jac.T @ residual, overwrite_a=1, overwrite_b=1)
    if info != 0:
        return None
    return -step


@dataclass(frozen=True)
class SolveReport:
    """Outcome of one Newton solve: the configuration, the residual reached and the iterations."""

    q: Array
    residual: float
    iterations: int
    converged: bool


@dataclass(frozen=True)
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
    """

    def __init__(self, model: pin.Model, closure: LoopClosure, actuated: list[ActuatedJoint]) -> None:
        self.model = model
        self.data = model.createData()
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

    # --- actuated coordinates -------------------------------------------------------------------
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
        """``target - current`` [rad or m], wrapped into (-π, π] for unbounded (continuous) joints."""
        delta = np.asarray(target, dtype=float) - current
        if not self._all_scalar:
            wrap = self._continuous
            delta[wrap] = np.remainder(delta[wrap] + np.pi, 2.0 * np.pi) - np.pi
        return delta

    def actuated_values(self, q: Array) -> Array:
        """Actuated values [rad or m] read from ``q``."""
        if self._all_scalar:
            return q[self._scalar_q].copy()
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
    def close_loops(self, q: Array, tol: float, max_iter: int = 30, max_step: float = 0.5) -> SolveReport:
        """Newton over the passive joints from ``q`` (actuated values held), with chord steps.

        The closure Jacobian is rebuilt only when the residual stops falling fast (by 10× per
        step); otherwise the last damped pseudo-inverse is reused and each iteration costs one
        forward-kinematics pass. Warm starts typically take one Jacobian and two cheap steps.
        """
        model, data, passive, closure = self.model, self.data, self.passive_v, self.closure
        if closure.rows == 0:
            return SolveReport(q, 0.0, 0, True)
        dv = np.zeros(model.nv)
        pin.computeJointJacobians(model, data, q)
        r, jac = closure.residual_and_jacobian(data)
        norm = float(abs(r).max())
        gain = damped_pseudo_inverse(jac[:, passive])
        for it in range(max_iter + 1):
            if norm <= tol:
                return SolveReport(q, norm, it, True)
            if it == max_iter or gain is None or not math.isfinite(norm) or norm > 1e3:
                break
            step = -(gain @ r)
            size = math.sqrt(float(step @ step))
            if size > max_step:
                step *= max_step / size
            dv[passive] = step
            q = pin.integrate(model, q, dv)
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

    def solve_fk(self, q_actuated: Array, start: Array, warm: bool, tol: float) -> SolveReport:
        """Full configuration with the loops closed for ``q_actuated``, from ``start``.

        A warm start within one continuation step tries Newton directly; otherwise (a cold start, a far
        guess, or a failed Newton) continuation runs from ``start`` with 1, 4 and 16 times
        ``max|Δq_a| / CONTINUATION_STEP`` steps.
        """
        if self.closure.rows == 0:  # a tree: nothing to close
            q = start.copy()
            self.set_actuated(q, q_actuated)
            return SolveReport(q, 0.0, 0, True)
        span = float(abs(self.actuated_delta(q_actuated, self.actuated_values(start))).max()) \
            if len(self.actuated) else 0.0
        if warm and span <= CONTINUATION_STEP:  # a far guess goes straight to continuation from it
            q = start.copy()
            self.set_actuated(q, q_actuated)
            report = self.close_loops(q, tol)
            if report.converged:
                return report
        if not math.isfinite(span) or span > MAX_CONTINUATION_STEPS * CONTINUATION_STEP:
            return SolveReport(start, math.inf, 0, False)
        base = max(1, math.ceil(span / CONTINUATION_STEP))
        report = SolveReport(start, math.inf, 0, False)
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
            tangent[self.passive_v] = -np.linalg.lstsq(cp, ca, rcond=None)[0]
        return tangent

    def frame_jacobian(self, q: Array, frame_id: int, reference: pin.ReferenceFrame) -> Array:
        """Frame Jacobian (6 × nv) at ``q`` in ``reference``; the closure Jacobian is left in data."""
        pin.computeJointJacobians(self.model, self.data, q)
        pin.updateFramePlacement(self.model, self.data, frame_id)
        return pin.getFrameJacobian(self.model, self.data, frame_id, reference)

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
