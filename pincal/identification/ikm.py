"""The inverse (IKM) formulation of study 000: implicit loop residuals with the measured pose held fixed.

For each sample the end-effector frame is held at its measured pose (or position) and the actuated
joints at their readings; the passive joints are chosen to close the loops as well as they can:

    q* = argmin ‖c(q)‖²  subject to  t(q) = 0  (t: predicted − measured pose rows),

solved by equality-constrained Gauss–Newton (``dv = -T_p⁺ t + N z``, N spanning the null space of
the task Jacobian T_p). The residual is the closure mismatch ``c(q*)`` [m, rad] left over: for a
Delta, one rod-length mismatch per leg (study 000, Eq. 3.8–3.9). Each loop's rows depend only on
its own chain's parameters, so chains decouple (:func:`chain_blocks`) and can be identified one by one.

The parameter Jacobian is ``P (∂c/∂θ + C_p dv_t)``, ``dv_t = -T_p⁺ ∂t/∂θ``, ``P = I - A A⁺``,
``A = C_p N``: exact when the loops can be closed (zero residual), Gauss–Newton otherwise (the
curvature of c times the residual is neglected, as in every Gauss–Newton method).
"""

from __future__ import annotations

from collections.abc import Sequence
from dataclasses import replace

import numpy as np
import numpy.typing as npt
import pinocchio as pin

from pincal import linalg
from pincal.errors import ConvergenceError, DataError
from pincal.identification.derivatives import KinematicSensitivity, frame_probe
from pincal.identification.measurements import MarkerPoint, Measurement, SampleContext
from pincal.identification.parameters import ParameterSet
from pincal.identification.problem import CalibrationProblem, Observations, Prediction
from pincal.model.jacobians import frame_jacobian
from pincal.model.robot import Robot

Array = npt.NDArray[np.float64]
IntArray = npt.NDArray[np.int64]

#: Key under which the closure mismatches are reported in ``Prediction.errors``.
CLOSURE_KEY = "ikm:closure"


def _split(jac: Array, tol: float = 1e-10) -> tuple[Array, Array]:
    """Pseudo-inverse of ``jac`` and an orthonormal basis of its null space."""
    u, s, vt = linalg.svd(jac, "the task Jacobian over the passive joints (IKM)", full_matrices=True)
    rank = int(np.sum(s > tol * (s[0] if s.size else 1.0)))
    pinv = vt[:rank].T @ np.diag(1.0 / s[:rank]) @ u[:, :rank].T
    return pinv, vt[rank:].T


class ImplicitProblem(CalibrationProblem):
    """IKM residuals and Jacobians; same arguments as :class:`CalibrationProblem`, with exactly one
    position or pose measurement of the end effector (the pose held fixed)."""

    def __init__(self, robot: Robot, parameters: ParameterSet, measurements: Sequence[Measurement],
                 observations: Observations) -> None:
        if not robot.loops:
            raise DataError(f"the implicit (IKM) formulation needs closed loops; '{robot.name}' has none: use FKM")
        located = [m for m in measurements if m.locates_point]
        if len(located) != 1 or len(measurements) != 1:
            raise DataError("the implicit (IKM) formulation takes exactly one position or pose measurement of the "
                            f"end effector; got {', '.join(m.key for m in measurements) or 'none'}")
        if located[0].attachments:
            raise DataError(f"the implicit (IKM) formulation holds a frame at its measured pose; '{located[0].key}' "
                            "is a target on the frame whose placement is estimated: use FKM")
        super().__init__(robot, parameters, measurements, observations)
        self.measurement = located[0]
        missing = np.flatnonzero(~self.seen(self.measurement.key))
        if missing.size:
            raise DataError(f"the implicit (IKM) formulation holds each sample's measured position fixed, and "
                            f"'{self.measurement.key}' was not seen in {missing.size} samples (the first: sample "
                            f"{int(missing[0])}): leave those samples out, or use FKM")

    def row_samples(self) -> IntArray:
        """The sample index of each residual row: one block of ``closure.rows`` loop rows per sample."""
        return np.repeat(np.arange(self.observations.n_samples, dtype=np.int64), self.robot.closure.rows)

    def _task(self, over_v: SampleContext) -> tuple[Array, Array]:
        """Task residual (predicted − measured) of the context's sample and its Jacobian over v: the target's
        own model, given each frame's local Jacobian as its twist and no parameter columns (``over_v``)."""
        m, model = self.measurement, over_v.model
        over_v.twists = {f: frame_jacobian(model, over_v.data, over_v.frame_ids[f], pin.LOCAL) for f in m.frames}
        predicted, jac = np.empty(m.size), np.zeros((m.size, model.nv))
        m.predict(over_v, predicted, jac)
        return m.error(predicted[None], over_v.measured(m.key)[None], model)[0], jac

    def _close(self, k: int, robot: Robot, qa: Array, over_v: SampleContext, tol: float = 1e-12,
               max_iter: int = 50) -> Array:
        kin, model, data = robot.kinematics, robot.model, robot.kinematics.data
        cached = self.solves.configurations[k]
        q = (robot.q_reference if cached is None else cached).copy()
        if cached is None:
            q = robot.solve_fk(qa)  # a closed start near the right assembly
        kin.set_actuated(q, qa)
        passive = kin.passive_v
        dv = np.zeros(model.nv)
        for _ in range(max_iter):
            pin.computeJointJacobians(model, data, q)
            pin.updateFramePlacements(model, data)
            c, cjac = robot.closure.residual_and_jacobian(data)
            over_v.q = q
            t, tjac = self._task(over_v)
            cp, tp = cjac[:, passive], tjac[:, passive]
            tp_pinv, null = _split(tp)
            step_t = -tp_pinv @ t
            a = cp @ null
            z = -linalg.pseudo_inverse(a, "the closure Jacobian on the task null space (IKM)") @ (c + cp @ step_t) \
                if a.size else np.zeros(0)
            step = step_t + null @ z
            # converged when the step vanishes and the part of the task the passive joints can act on is met
            # (a Delta cannot turn its platform: a measured orientation's rows lie outside T_p's range)
            reachable = tp @ (tp_pinv @ t)
            if float(np.max(np.abs(reachable))) <= tol and float(np.max(np.abs(step))) <= 1e-12:
                self.solves.configurations[k] = q
                return q
            size = float(np.linalg.norm(step))
            if size > 0.5:
                step *= 0.5 / size
            dv[passive] = step
            q = pin.integrate(model, q, dv)
        raise ConvergenceError(f"sample {k}: the implicit (IKM) solve did not converge: the measured pose may be "
                               "unreachable with these readings, or the parameters far off")

    def settle_assembly(self, x: Array) -> list[int]:
        """Nothing to settle: an IKM configuration holds the measured pose, not forward kinematics (each
        starts from the reference assembly's FK answer when first closed)."""
        return []

    def evaluate(self, x: Array, jacobian: bool = True, spare_rows: int = 0) -> Prediction:
        """Weighted IKM residual (each sample's loop closure [m, rad] at the measured pose, over the target's σ)
        and its Jacobian w.r.t. ``x``, the passive joints' response projected out (with ``spare_rows`` rows of zeros
        after the residual's, as :meth:`CalibrationProblem.evaluate` gives them)."""
        robot = self.placed_robot(x)
        model, data, kin = robot.model, robot.kinematics.data, robot.kinematics
        n, p, rows = self.observations.n_samples, len(self.parameters), robot.closure.rows
        sens = KinematicSensitivity(robot, self.parameters, x) if jacobian else None
        base_delta = self.parameters.placement_delta(x, self.base) if self.base else np.zeros(6)
        ctx = self._context(model, data, x, base_delta)
        over_v = replace(ctx, base_columns=[], reading_offsets={},  # task rows over v: no parameter columns
                         markers={t: MarkerPoint(m.point) for t, m in ctx.markers.items()})
        qa_all = self.actuated_values(x)
        residual = np.empty((n, rows))
        jac_out = np.zeros((n, rows, p)) if jacobian else None
        passive, act_v = kin.passive_v, kin.actuated_v
        probes = {f: frame_probe(robot, self.frame_ids[f]) for f in self.measurement.frames}
        for k in range(n):
            over_v.sample = ctx.sample = k
            q = self._close(k, robot, qa_all[k], over_v)
            pin.computeJointJacobians(model, data, q)
            pin.updateFramePlacements(model, data)
            c, cjac = robot.closure.residual_and_jacobian(data)
            residual[k] = c
            if jac_out is None or sens is None:
                continue
            over_v.q = ctx.q = q
            _, tjac = self._task(over_v)
            # direct parameter sensitivities of the closure and of the task (passive joints held)
            dc = sens.closure_derivative(data)
            dv = np.zeros((model.nv, p))
            for joint, col in self.actuated_offsets:
                dv[act_v[joint], col] = 1.0
                dc[:, col] += cjac[:, act_v[joint]]
            ctx.dv = dv
            ctx.twists = {f: sens.probe_twist(data, probes[f])
                          + frame_jacobian(model, data, self.frame_ids[f], pin.LOCAL) @ dv for f in probes}
            dt = np.zeros((self.measurement.size, p))
            self.measurement.predict(ctx, np.empty(self.measurement.size), dt)
            cp, tp = cjac[:, passive], tjac[:, passive]
            tp_pinv, null = _split(tp)
            a = cp @ null
            closure_pinv = linalg.pseudo_inverse(a, "the closure Jacobian on the task null space (IKM)", 1e-15)
            projector = np.eye(rows) - a @ closure_pinv if a.size else np.eye(rows)
            jac_out[k] = projector @ (dc - cp @ (tp_pinv @ dt))
        sigma = self.measurement.sigma
        out_res = (residual / sigma).reshape(-1)
        out_jac = None if jac_out is None else (jac_out / sigma).reshape(-1, p)
        if out_jac is not None and spare_rows:
            out_jac = np.vstack([out_jac, np.zeros((spare_rows, p))])
        return Prediction(out_res, out_jac, {CLOSURE_KEY: residual}, {})


def chain_blocks(problem: ImplicitProblem, jacobian: Array, tol: float = 1e-12) -> list[tuple[list[int], list[int]]]:
    """Independent (parameter columns, loops) blocks of an IKM Jacobian: parameters that act on one
    loop only form that loop's chain; parameters acting on several loops join their loops in a block."""
    robot = problem.robot
    slices = list(robot.closure.loop_slices().values())
    n = problem.observations.n_samples
    rows = robot.closure.rows
    per_loop = np.zeros((len(slices), jacobian.shape[1]), dtype=bool)
    blocks = jacobian.reshape(n, rows, -1)
    scale = float(np.max(np.abs(jacobian))) or 1.0
    for i, sl in enumerate(slices):
        per_loop[i] = np.max(np.abs(blocks[:, sl, :]), axis=(0, 1)) > tol * scale
    # union-find over loops linked by shared parameters
    parent = list(range(len(slices)))

    def find(i: int) -> int:
        while parent[i] != i:
            i = parent[i]
        return i

    for col in range(jacobian.shape[1]):
        touched = np.flatnonzero(per_loop[:, col])
        for other in touched[1:]:
            parent[find(int(other))] = find(int(touched[0]))
    groups: dict[int, list[int]] = {}
    for i in range(len(slices)):
        groups.setdefault(find(i), []).append(i)
    out: list[tuple[list[int], list[int]]] = []
    for loops in groups.values():
        cols = [c for c in range(jacobian.shape[1]) if per_loop[loops, c].any()]
        out.append((cols, loops))
    return out


class ChainProblem:
    """One chain of an IKM problem: its loops' rows and its parameters, the rest held at ``x_fixed``."""

    def __init__(self, problem: ImplicitProblem, columns: list[int], loops: list[int], x_fixed: Array) -> None:
        self.full = problem
        self.columns = columns
        self.parameters = problem.parameters.subset(columns)
        self.observations = problem.observations
        self.measurements = problem.measurements
        self.robot = problem.robot
        self.x_fixed = x_fixed.copy()
        slices = list(problem.robot.closure.loop_slices().values())
        per_sample = np.concatenate([np.arange(slices[i].start, slices[i].stop) for i in loops])
        self._loop_rows = per_sample  # this chain's rows of a sample's closure
        rows = problem.robot.closure.rows
        n = problem.observations.n_samples
        self.rows = (np.arange(n)[:, None] * rows + per_sample[None, :]).reshape(-1)
        self._samples = np.repeat(np.arange(n, dtype=np.int64), per_sample.size)

    def row_samples(self) -> IntArray:
        """The sample index of each of this chain's residual rows."""
        return self._samples

    def initial_guess(self) -> Array:
        """The chain's parameters [m, rad] at ``x_fixed``: the starting point of its fit."""
        return self.x_fixed[self.columns].copy()

    def settle_assembly(self, x: Array) -> list[int]:
        """The full problem's :meth:`ImplicitProblem.settle_assembly` with this chain's parameters at ``x``."""
        full = self.x_fixed.copy()
        full[self.columns] = x
        return self.full.settle_assembly(full)

    def evaluate(self, x: Array, jacobian: bool = True) -> Prediction:
        """The full problem's residual, Jacobian and errors at ``x`` (the others at ``x_fixed``), restricted to this
        chain's loop rows and parameter columns."""
        full = self.x_fixed.copy()
        full[self.columns] = x
        pred = self.full.evaluate(full, jacobian)
        jac = None if pred.jacobian is None else pred.jacobian[np.ix_(self.rows, self.columns)]
        # the errors of this chain's loops only: the others' (held at x_fixed, fitted in turn) are not this fit's
        errors = {key: value[:, self._loop_rows] for key, value in pred.errors.items()}
        return Prediction(pred.residual[self.rows], jac, errors, pred.predicted)
