"""Statistical sensitivity of the pose to each geometric parameter over the workspace (study 004, §1.4).

At one pose the error model is ``δE_S = T_R δE_R`` (study 004 Eq. 14): the pose error of the end
effector per parameter error, at fixed actuated inputs, i.e. the forward identification Jacobian of a
pose measurement. With independent, zero-mean parameter errors of one common standard deviation, the
variance of the pose error is ``Σ_i Σ_j T_Rji² σ²`` (Eq. 16-19), so parameter i contributes through

    τ_Ri = ∫_V Σ_j T_Rji² dv                      (Eq. 20)

and its share, the *sensitivity percentage*, is

    τ̄_Ri = τ_Ri / Σ_i τ_Ri                         (Eq. 21, reported × 100 %).

The integral over the workspace volume V is estimated by the mean over poses sampled uniformly in the
workspace (V cancels in Eq. 21). Units matter: study 004 mixes millimetres for positions and
dimensionless quaternion components for orientations, with every parameter error in millimetres;
``row_scales`` and ``column_scales`` convert pincal's SI Jacobians to such units.
"""

from __future__ import annotations

from collections.abc import Sequence

import numpy as np
import numpy.typing as npt
import pinocchio as pin

from pincal.errors import DataError
from pincal.identification.problem import CalibrationProblem
from pincal.records import record
from pincal.study.pose_selection import jacobian_blocks

Array = npt.NDArray[np.float64]


@record
class StatisticalSensitivity:
    """Sensitivity of the pose to each parameter over the workspace.

    Attributes:
        names: Parameter names.
        tau: (p,) workspace mean of ``Σ_j T_ji²`` (Eq. 20 divided by V), in the squared units of the
            rows per squared unit of the columns.
        percentages: (p,) ``100 τ_i / Σ τ`` [%] (Eq. 21); they sum to 100.
        n_samples: Workspace poses averaged.
    """

    names: list[str]
    tau: Array
    percentages: Array
    n_samples: int

    def ranked(self) -> list[tuple[str, float]]:
        """(name, percentage) from the most to the least influential parameter."""
        order = np.argsort(-self.percentages, kind="stable")
        return [(self.names[k], float(self.percentages[k])) for k in order]


def statistical_sensitivity(jacobians: npt.ArrayLike, names: Sequence[str], row_scales: npt.ArrayLike | None = None,
                            column_scales: npt.ArrayLike | None = None,
                            weights: npt.ArrayLike | None = None) -> StatisticalSensitivity:
    """Study 004 Eq. 20-21 from the pose-error Jacobians of workspace samples.

    Args:
        jacobians: (N, rows, p) ``T_R`` of N workspace poses (pose error per parameter error).
        names: p parameter names.
        row_scales: (rows,) factors applied to the rows (e.g. 1000 to report positions in mm).
        column_scales: (p,) factors applied to the columns (e.g. 1e-3 for parameter errors in mm).
        weights: (N,) volume weights of the samples (uniform by default).

    Raises:
        DataError: malformed shapes, non-finite values, or a zero total (no parameter acts).
    """
    t = np.asarray(jacobians, dtype=float)
    if t.ndim != 3 or t.shape[0] == 0:
        raise DataError(f"jacobians must be (N, rows, p) with N > 0; got shape {t.shape}")
    n, rows, p = t.shape
    if len(names) != p:
        raise DataError(f"{len(names)} names for {p} parameter columns")
    if not np.all(np.isfinite(t)):
        raise DataError("the pose-error Jacobians contain NaN or infinity")
    if row_scales is not None:
        t = t * _vector(row_scales, rows, "row_scales")[None, :, None]
    if column_scales is not None:
        t = t * _vector(column_scales, p, "column_scales")[None, None, :]
    w = np.full(n, 1.0 / n) if weights is None else _vector(weights, n, "weights")
    if weights is not None:
        if np.any(w < 0) or w.sum() <= 0:
            raise DataError("weights must be non-negative with a positive sum")
        w = w / w.sum()
    tau = np.einsum("n,nrp->p", w, t**2)
    total = float(tau.sum())
    if total <= 0.0:
        raise DataError("no parameter changes the pose anywhere in the samples (all sensitivities are zero)")
    return StatisticalSensitivity(list(names), tau, 100.0 * tau / total, n)


def _vector(values: npt.ArrayLike, size: int, what: str) -> Array:
    v = np.asarray(values, dtype=float)
    if v.shape != (size,) or not np.all(np.isfinite(v)):
        raise DataError(f"{what} must be {size} finite values; got shape {v.shape}")
    return v


def quaternion_rows(quaternion: npt.ArrayLike, angular: Array) -> Array:
    """Derivative of the quaternion's vector part (q1, q2, q3) from local angular rows.

    ``q̇ = ½ q ⊗ (0, ω)`` for a local angular velocity ω, so ``d(q1, q2, q3) = ½ (q0 I + [v]×) ω``.

    Args:
        quaternion: (x, y, z, w) of the frame's orientation (Pinocchio's coefficient order).
        angular: (3, p) local angular change per parameter [rad per parameter unit].
    """
    x, y, z, w = np.asarray(quaternion, dtype=float)
    return np.asarray(0.5 * (w * np.eye(3) + pin.skew(np.array([x, y, z]))) @ angular)


#: The residual rows of a placement measured whole: its position [m], then its local rotation vector [rad]
#: (:meth:`~pincal.identification.measurements.Measurement.row_names`).
POSE_ROWS = ("x", "y", "z", "rx", "ry", "rz")


def pose_error_jacobians(problem: CalibrationProblem, x: Array | None = None,
                         orientation: str = "rotation") -> Array:
    """``T_R`` per sample, (N, 6, p): position rows [m] and orientation rows of the first pose measurement.

    The problem's pose observations must be the poses at ``x`` (simulated without noise, for
    instance), so that the orientation rows are local angular rates [rad] (the residual's ``Jlog3``
    is the identity at zero error).

    Args:
        problem: Problem over workspace samples with a measurement of a whole placement (rows :data:`POSE_ROWS`:
            a :class:`~pincal.identification.measurements.Pose`).
        x: Parameters to linearise at (nominal by default).
        orientation: ``rotation`` (local rotation vector [rad]) or ``quaternion`` (study 004's
            q1, q2, q3, dimensionless).
    """
    if orientation not in ("rotation", "quaternion"):
        raise DataError(f"orientation must be 'rotation' or 'quaternion'; got '{orientation}'")
    poses = [m for m in problem.measurements if m.row_names() == POSE_ROWS]
    if not poses:
        raise DataError(f"no pose measurement among {', '.join(m.key for m in problem.measurements)}")
    start = 0
    for m in problem.measurements:
        if m is poses[0]:
            break
        start += m.size
    blocks = jacobian_blocks(problem, x, weighted=False)[:, start:start + 6, :]
    if orientation == "quaternion":
        quats = problem.observations.values[poses[0].key][:, 3:]
        for k in range(blocks.shape[0]):
            blocks[k, 3:] = quaternion_rows(quats[k], blocks[k, 3:])
    return np.asarray(blocks)
