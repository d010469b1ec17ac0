"""Which postures a robot assembles: every sample's loops closed at once, the samples it cannot close and those at a
singularity named, with the configurations found.

A closed-loop robot that :mod:`pincal.model.batch_kinematics` takes closes every sample's loops at once (stacked
Newton steps from the given warm starts, or continuation from the reference) and judges their passive closure
Jacobians as one stack; the samples it does not close, and the robots it does not take, are solved one by one by
:meth:`~pincal.model.robot.Robot.solve_fk_report`. A sample is singular when its passive closure Jacobian's
condition number exceeds a bound: the actuated readings do not determine its passive joints. Units: rad or m.
"""

from __future__ import annotations

import math

import numpy as np
import numpy.typing as npt

from pincal import linalg
from pincal.model.robot import SOLVE_TOLERANCE, Robot
from pincal.records import record

Array = npt.NDArray[np.float64]

#: Largest condition number of a usable sample's passive closure Jacobian.
MAX_CONDITION = 1e5


@record(frozen=True)
class Assembled:
    """Samples solved: their configurations (N, nq) on the reference assembly (a row of a sample that does not close:
    undefined) and why each unusable sample cannot be used (sample row -> reason)."""

    q: Array
    reasons: dict[int, str]

    @property
    def usable(self) -> npt.NDArray[np.bool_]:
        """Which samples can be used (N,)."""
        ok = np.ones(len(self.q), dtype=bool)
        ok[list(self.reasons)] = False
        return ok


def assemble(robot: Robot, actuated: Array, max_condition: float = MAX_CONDITION,
             guesses: Array | None = None, stacked: bool = True) -> Assembled:
    """Every sample of ``actuated`` (N, na) [rad or m] solved on ``robot`` (warm from ``guesses`` (N, nq) if given, as
    :meth:`~pincal.model.robot.Robot.solve_fk` takes a guess), and those that cannot be used with the reason: the
    loops do not close, or the passive closure Jacobian's condition number exceeds ``max_condition``. A robot without
    loops closes every sample and none is singular (its configurations written at once). ``stacked=False`` solves and
    judges every sample alone (what the stacked paths must agree with)."""
    actuated = np.asarray(actuated, dtype=float)
    n = len(actuated)
    if not robot.loops and stacked and _writable(robot, actuated, guesses):
        return Assembled(_tree_configurations(robot, actuated, guesses), {})
    q = np.zeros((n, robot.model.nq))
    ok = np.zeros(n, dtype=bool)
    batch = robot.batch if robot.loops and n else None
    stacked = stacked and batch is not None and batch.unsupported is None and bool(np.all(np.isfinite(actuated)))
    if stacked:
        assert batch is not None
        q[:], ok[:] = batch.solve(robot.model, robot.closure, actuated, guesses, SOLVE_TOLERANCE)
    reasons: dict[int, str] = {}
    for k in np.flatnonzero(~ok).tolist():
        report = robot.solve_fk_report(actuated[k], None if guesses is None else guesses[k])
        if report.converged:
            q[k], ok[k] = report.q, True
        else:
            what = "the loops cannot be assembled at its readings: " if robot.loops else ""
            reasons[k] = f"{what}forward kinematics did not converge (closure residual {report.residual:.3g})"
    rows = np.flatnonzero(ok)
    if robot.loops and rows.size:
        if stacked:
            assert batch is not None
            jacobian = batch.state(robot.model, robot.closure, q[rows]).jacobian
            assert jacobian is not None
        else:
            jacobian = np.array([robot.kinematics.closure_jacobian(q[k])[1] for k in rows])
        s = linalg.singular_values(jacobian[:, :, robot.kinematics.passive_v], "the passive closure Jacobians")
        for k, values in zip(rows.tolist(), s, strict=True):
            reason = singular(values, max_condition)
            if reason:
                reasons[k] = reason
    return Assembled(q, dict(sorted(reasons.items())))


def _writable(robot: Robot, actuated: Array, guesses: Array | None) -> bool:
    """Whether a tree's samples can be written at once: finite readings (N, na) and guesses (N, nq) of the right
    shapes (otherwise each sample alone says what is wrong)."""
    n = len(actuated)
    return (actuated.shape == (n, robot.n_actuated) and bool(np.all(np.isfinite(actuated)))
            and (guesses is None or np.shape(guesses) == (n, robot.model.nq)))


def _tree_configurations(robot: Robot, actuated: Array, guesses: Array | None) -> Array:
    """(N, nq) a tree's configurations: each guess (default the reference) with the readings ``actuated`` (N, na)
    [rad or m] written in, as :meth:`~pincal.model.robot.Robot.solve_fk` writes one sample's."""
    kinematics = robot.kinematics
    q = np.tile(kinematics.reference, (len(actuated), 1)) if guesses is None else np.array(guesses, dtype=float)
    for k, joint in enumerate(kinematics.actuated):
        if joint.nq == 1:
            q[:, joint.idx_q] = actuated[:, k]
        else:  # the cosine and sine, as the sample-by-sample path computes them
            q[:, joint.idx_q] = [math.cos(v) for v in actuated[:, k].tolist()]
            q[:, joint.idx_q + 1] = [math.sin(v) for v in actuated[:, k].tolist()]
    return q


def unusable_samples(robot: Robot, actuated: Array, max_condition: float = MAX_CONDITION) -> list[tuple[int, str]]:
    """Samples of ``actuated`` (N, na) [rad or m] the nominal robot cannot assemble (FK does not converge) or that sit
    at a singularity (the passive joints are not determined by the actuated readings), with the reason for each; a
    robot without loops has none (nothing is solved)."""
    if not robot.loops:
        return []
    return list(assemble(robot, actuated, max_condition).reasons.items())


def singular(s: Array, max_condition: float) -> str:
    """Why a sample whose passive closure Jacobian has singular values ``s`` (descending) is singular; empty if not."""
    if s[-1] <= 0.0 or s[0] / s[-1] > max_condition:
        return (f"singular configuration (passive closure Jacobian condition number "
                f"{(s[0] / s[-1]) if s[-1] > 0 else float('inf'):.3g})")
    return ""
