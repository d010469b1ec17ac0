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

import numpy as np
import numpy.typing as npt
import pinocchio as pin

from pincal import linalg
from pincal.errors import ConvergenceError, DataError
from pincal.identify.derivatives import KinematicSensitivity, frame_probe, right_jacobian
from pincal.identify.measurements import Measurement, Pose, Position
from pincal.identify.parameters import ParameterSet
from pincal.identify.problem import CalibrationProblem, Observations, Prediction
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
        targets = [m for m in measurements if isinstance(m, (Position, Pose))]
        if len(targets) != 1 or len(measurements) != 1:
            raise DataError("the implicit (IKM) formulation takes exactly one position or pose measurement of the "
                            f"end effector; got {', '.join(m.key for m in measurements) or 'none'}")
        super().__init__(robot, parameters, measurements, observations)
        self.target = targets[0]

    def row_samples(self) -> IntArray:
        return np.repeat(np.arange(self.observations.n_samples, dtype=np.int64), self.robot.closure.rows)

    def _task(self, k: int, robot: Robot, data: pin.Data, base: pin.SE3, markers: dict[str, Array],
              jac_v: bool) -> tuple[Array, Array | None]:
        """Task residual (predicted − measured) of sample k and, optionally, its Jacobian over v."""
        m = self.target
        measured = self.observations.values[m.key][k]
        placement = data.oMf[self.frame_ids[m.frame]]
        marker = markers.get(m.frame, np.zeros(3)) if isinstance(m, Position) else np.zeros(3)
        point = placement.act(marker)
        rows = [base.act(point) - measured[:3]]
        rel = None
        if isinstance(m, Pose):
            meas_rot = pin.Quaternion(*measured[[6, 3, 4, 5]]).normalized().matrix()
            rel = meas_rot.T @ base.rotation @ placement.rotation
            rows.append(pin.log3(rel))
        t = np.concatenate(rows)
        if not jac_v:
            return t, None
        local = pin.getFrameJacobian(robot.model, data, self.frame_ids[m.frame], pin.LOCAL)
        lin = base.rotation @ placement.rotation @ (local[:3] - pin.skew(marker) @ local[3:])
        if rel is None:
            return t, lin
        return t, np.vstack([lin, pin.Jlog3(rel) @ local[3:]])

    def _close(self, k: int, robot: Robot, qa: Array, base: pin.SE3, markers: dict[str, Array],
               tol: float = 1e-12, max_iter: int = 50) -> Array:
        kin, model, data = robot.kinematics, robot.model, robot.kinematics.data
        cached = self._q_cache[k]
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
            t, tjac = self._task(k, robot, data, base, markers, jac_v=True)
            assert tjac is not None
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
                self._q_cache[k] = q
                return q
            size = float(np.linalg.norm(step))
            if size > 0.5:
                step *= 0.5 / size
            dv[passive] = step
            q = pin.integrate(model, q, dv)
        raise ConvergenceError(f"sample {k}: the implicit (IKM) solve did not converge: the measured pose may be "
                               "unreachable with these readings, or the parameters far off")

    def evaluate(self, x: Array, jacobian: bool = True) -> Prediction:
        robot = self.robot_at(x)
        model, data, kin = robot.model, robot.kinematics.data, robot.kinematics
        n, p, rows = self.observations.n_samples, len(self.parameters), robot.closure.rows
        sens = KinematicSensitivity(robot, self.parameters, x) if jacobian else None
        base_delta = self.parameters.placement_delta(x, self.base) if self.base else np.zeros(6)
        base = pin.exp6(base_delta)
        base_jac = right_jacobian(base_delta, [self.parameters.parameters[k].component for k in self.base])
        markers = {f: x[idx] for f, idx in self.markers.items()}
        qa_all = self.actuated_values(x)
        residual = np.empty((n, rows))
        jac_out = np.zeros((n, rows, p)) if jacobian else None
        passive, act_v = kin.passive_v, kin.actuated_v
        probe = frame_probe(robot, self.frame_ids[self.target.frame])
        preds = {self.target.key: np.empty((n, self.target.size))}  # buffers reused by every sample
        dpreds = {self.target.key: np.zeros((n, self.target.size, p))}
        for k in range(n):
            q = self._close(k, robot, qa_all[k], base, markers)
            pin.computeJointJacobians(model, data, q)
            pin.updateFramePlacements(model, data)
            c, cjac = robot.closure.residual_and_jacobian(data)
            residual[k] = c
            if jac_out is None or sens is None:
                continue
            _, tjac = self._task(k, robot, data, base, markers, jac_v=True)
            assert tjac is not None
            # direct parameter sensitivities of the closure and of the task (passive joints held)
            dc = sens.closure_derivative(data)
            dv = np.zeros((model.nv, p))
            for joint, col in self.actuated_offsets:
                dv[act_v[joint], col] = 1.0
                dc[:, col] += cjac[:, act_v[joint]]
            local = pin.getFrameJacobian(model, data, self.frame_ids[self.target.frame], pin.LOCAL)
            twist = sens.probe_twist(data, probe) + local @ dv
            dpreds[self.target.key][k] = 0.0
            self._predict(self.target, x, k, q, robot, data, base, base_jac, markers, {self.target.frame: twist},
                          dv, preds, dpreds)
            dt = dpreds[self.target.key][k]
            cp, tp = cjac[:, passive], tjac[:, passive]
            tp_pinv, null = _split(tp)
            a = cp @ null
            closure_pinv = linalg.pseudo_inverse(a, "the closure Jacobian on the task null space (IKM)", 1e-15)
            projector = np.eye(rows) - a @ closure_pinv if a.size else np.eye(rows)
            jac_out[k] = projector @ (dc - cp @ (tp_pinv @ dt))
        sigma = self.target.sigma
        out_res = (residual / sigma).reshape(-1)
        out_jac = None if jac_out is None else (jac_out / sigma).reshape(-1, p)
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
        rows = problem.robot.closure.rows
        n = problem.observations.n_samples
        self.rows = (np.arange(n)[:, None] * rows + per_sample[None, :]).reshape(-1)
        self._samples = np.repeat(np.arange(n, dtype=np.int64), per_sample.size)

    def row_samples(self) -> IntArray:
        return self._samples

    def initial_guess(self) -> Array:
        return self.x_fixed[self.columns].copy()

    def evaluate(self, x: Array, jacobian: bool = True) -> Prediction:
        full = self.x_fixed.copy()
        full[self.columns] = x
        pred = self.full.evaluate(full, jacobian)
        jac = None if pred.jacobian is None else pred.jacobian[np.ix_(self.rows, self.columns)]
        return Prediction(pred.residual[self.rows], jac, pred.errors, pred.predicted)
