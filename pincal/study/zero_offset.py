"""Iterative zero-offset identification with TSVD and the mechanism-error update (study 003, §4-5).

Study 003 identifies the zero offsets Δθ_i of the actuated joints, together with the errors Δr_M of
the measuring mechanism, from increments of a distance that is reset after each reading:

- the identification model is linear, ``Δλ = G Δp`` with ``Δp = (Δq, Δr_M)`` (Eq. 28), and is
  solved by truncated SVD, ``Δp = Σ_{i≤t} (u_iᵀ Δλ / σ_i) v_i`` (Eq. 29);
- after each identification the controller compensates the offsets found, the robot measures again,
  and the next identification uses a model updated with the mechanism errors found so far
  (``f^(j) = f^(j−1) + Δr_M^(j−1)``, Eq. 30);
- it stops when the compensation accuracy ``μ = √(Σ_i (Δθ_i^(j+1) − Δθ_i^(j))² / n)`` falls within
  ``μ_0`` (Eq. 32); the compensation value is ``Σ_j Δθ^(j)`` (Eq. 33).

pincal's version linearises the exact model (closed-loop FK, analytic Jacobian through the loops) at
the current compensation and mechanism estimate instead of at the nominal robot, which is the same
procedure with a more accurate ``G``. The world is reached through ``measure(compensation)``: a real
robot (drive to the measurement positions with the compensation applied, read the scale) or a
simulation. With a ``measure`` that ignores the compensation, the procedure is Gauss-Newton with
TSVD steps on one dataset.
"""

from __future__ import annotations

import math
import time
from collections.abc import Callable, Sequence
from dataclasses import field

import numpy as np
import numpy.typing as npt

from pincal import linalg
from pincal.errors import DataError
from pincal.identification.measurements import Measurement
from pincal.identification.parameters import ParameterSet, ReadingOffset
from pincal.identification.problem import CalibrationProblem, Observations
from pincal.model.robot import Robot
from pincal.records import record

Array = npt.NDArray[np.float64]

#: Study 003's threshold on the compensation accuracy μ (§6.2: μ_0 = 0.1°) [rad].
MU0 = math.radians(0.1)


@record(frozen=True)
class ZeroOffsetStep:
    """One identification j.

    Attributes:
        offsets: Δθ^(j), the offsets identified at this step [rad or m] (increments to compensate).
        others: The step's increments of the other parameters (Δr_M^(j), geometric errors) [m, rad].
        condition_number: κ of the scaled identification matrix G at this step (all its columns).
        kept: Singular values kept by the truncation (t of Eq. 29).
        mu: Compensation accuracy of Eq. 32 against the previous step [rad] (NaN at j = 1).
        rms_residual: RMS of the unweighted increment residual before this step [m].
    """

    offsets: Array
    others: Array
    condition_number: float
    kept: int
    mu: float
    rms_residual: float


@record
class ZeroOffsetResult:
    """The compensation found and how it was reached.

    Attributes:
        names: Names of the identified quantities (offsets first, as in ``offsets``).
        offsets: Indices of the zero offsets among ``names``.
        compensation: Σ_j Δθ^(j), the compensation value of each zero offset (Eq. 33) [rad or m].
        estimate: Every identified quantity after the last step (compensation and accumulated
            mechanism and geometric errors) [m, rad].
        steps: One record per identification.
        converged: μ fell within μ_0.
        seconds: Wall time, measurements included [s].
    """

    names: list[str]
    offsets: list[int]
    compensation: Array
    estimate: Array
    steps: list[ZeroOffsetStep] = field(default_factory=list)
    converged: bool = False
    seconds: float = 0.0

    @property
    def kappa_first(self) -> float:
        """κ_1 of study 003 Eq. 31: condition number of the first identification."""
        return self.steps[0].condition_number if self.steps else math.nan

    @property
    def kappa_rest(self) -> float:
        """κ_m of study 003 Eq. 31: mean condition number of the remaining identifications."""
        rest = [s.condition_number for s in self.steps[1:]]
        return float(np.mean(rest)) if rest else math.nan


def compensation_accuracy(previous: Array, current: Array) -> float:
    """Study 003 Eq. 32: ``μ = √(Σ_i (Δθ_i^(j+1) − Δθ_i^(j))² / n)`` [rad]."""
    d = np.asarray(current, dtype=float) - np.asarray(previous, dtype=float)
    return float(np.sqrt(np.mean(d**2)))


def tsvd_step(jacobian: Array, residual: Array, scales: Array, rank: int | None = None,
              rcond: float = 1e-6) -> tuple[Array, float, int]:
    """The TSVD solution of ``J Δp = −r`` (study 003 Eq. 29) in scaled columns.

    Returns:
        Δp [parameter units], κ of the scaled J (all columns; ``inf`` when rank-deficient), and the
        number of singular values kept: ``rank`` if given, else those above ``rcond · σ_1``.
    """
    js = jacobian * scales
    u, s, vt = linalg.svd(js, "the scaled identification matrix G")
    if not s.size or s[0] == 0.0:
        raise DataError("the identification matrix is zero: the measurements do not see the parameters")
    keep = int(np.count_nonzero(s > rcond * s[0])) if rank is None else min(int(rank), s.size)
    kappa = float(s[0] / s[-1]) if s.size == js.shape[1] and s[-1] > 0 else math.inf
    dz = -(vt[:keep].T @ ((u[:, :keep].T @ residual) / s[:keep]))
    return np.asarray(dz * scales), kappa, keep


def identify_zero_offsets(robot: Robot, parameters: ParameterSet, measurements: Sequence[Measurement],
                          measure: Callable[[Array], Observations], offsets: Sequence[str] | None = None,
                          mapping: Array | None = None, names: Sequence[str] | None = None,
                          scales: npt.ArrayLike | None = None, rank: int | None = None, rcond: float = 1e-6,
                          mu0: float = MU0, max_steps: int = 10) -> ZeroOffsetResult:
    """Study 003's iterative zero-offset identification (Eq. 28-33).

    Args:
        robot: The nominal robot (the controller's model).
        parameters: pincal parameters of the identification model: the actuated joints' offsets and
            the measuring mechanism's errors (e.g. ``scale_pivot_joint.tx/ty`` for Δr_M).
        measurements: The measurement models (e.g. an incremental distance).
        measure: ``measure(compensation) -> Observations``: readings and measured values taken with the
            controller compensating ``compensation`` (one value per zero offset, ``offsets`` order):
            to reach a position the controller commands ``θ_nominal − compensation``.
        offsets: Names (among ``names``) of the zero offsets to compensate; default: the parameters of
            kind ``offset`` on actuated joints.
        mapping: Optional (len(parameters), n) matrix from identified quantities to pincal parameters,
            ``x = mapping @ p`` (e.g. a link length that moves two placements); identity by default.
        names: n names of the identified quantities (default: the parameter names).
        scales: n typical sizes [m or rad] scaling G's columns (default: the parameters' scales).
        rank: TSVD truncation t (Eq. 29); default: singular values above ``rcond · σ_1``.
        rcond: Relative truncation threshold when ``rank`` is None.
        mu0: Threshold on μ (Eq. 32) [rad]; the paper's 0.1° by default.
        max_steps: Identifications at most.

    Raises:
        DataError: inconsistent names, mapping or scales.
    """
    start = time.perf_counter()
    n_model = len(parameters)
    t = np.eye(n_model) if mapping is None else np.asarray(mapping, dtype=float)
    if t.ndim != 2 or t.shape[0] != n_model:
        raise DataError(f"mapping must have {n_model} rows (one per pincal parameter); got shape {t.shape}")
    labels = list(parameters.names) if names is None else list(names)
    if len(labels) != t.shape[1]:
        raise DataError(f"{len(labels)} names for {t.shape[1]} identified quantities")
    if offsets is None:
        actuated = set(robot.actuated_joints)
        offsets = [p.name for p in parameters if p.is_a(ReadingOffset) and p.owner in actuated]
        if mapping is not None:
            raise DataError("with a mapping, name the zero offsets explicitly (offsets=...)")
    missing = [o for o in offsets if o not in labels]
    if missing or not offsets:
        raise DataError(f"zero offsets {missing or 'none'} are not among the identified quantities: {labels}")
    idx = [labels.index(o) for o in offsets]
    s = (t.T @ parameters.scales if mapping is not None else parameters.scales) if scales is None \
        else np.asarray(scales, dtype=float)
    if s.shape != (t.shape[1],) or not np.all(s > 0):
        raise DataError(f"scales must be {t.shape[1]} positive values [m or rad]")
    p = np.zeros(t.shape[1])
    result = ZeroOffsetResult(labels, idx, np.zeros(len(idx)), p)
    previous: Array | None = None
    for _ in range(max_steps):
        obs = measure(p[idx].copy())
        pred = CalibrationProblem(robot, parameters, measurements, obs).evaluate(t @ p)
        assert pred.jacobian is not None
        jac = pred.jacobian @ t
        errors = np.concatenate([e[1:] if m.incremental else e for m, e in
                                 zip(measurements, pred.errors.values(), strict=True)], axis=None)
        dp, kappa, kept = tsvd_step(jac, pred.residual, s, rank, rcond)
        p = p + dp
        mu = math.nan if previous is None else compensation_accuracy(previous, dp[idx])
        others = np.delete(dp, idx)
        result.steps.append(ZeroOffsetStep(dp[idx].copy(), others, kappa, kept, mu,
                                           float(np.sqrt(np.mean(errors**2)))))
        previous = dp[idx].copy()
        if mu <= mu0:
            result.converged = True
            break
    result.compensation = p[idx].copy()
    result.estimate = p
    result.seconds = time.perf_counter() - start
    return result
