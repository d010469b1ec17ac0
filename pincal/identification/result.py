"""What identification found, and how well: :class:`CalibrationResult`, the record
:func:`~pincal.identification.solver.identify` returns."""

from __future__ import annotations

from dataclasses import field

import numpy as np
import numpy.typing as npt

from pincal.identification.identifiability import Identifiability
from pincal.identification.problem import Prediction
from pincal.records import record

Array = npt.NDArray[np.float64]


@record
class CalibrationResult:
    """What identification found, and how well.

    Attributes:
        names: Parameter names; ``x`` their estimates (deviations from nominal) [m or rad].
        std: Standard deviations [m or rad] (NaN for parameters not identified).
        identified: Indices of the parameters that were estimated (the identifiable set by default).
        identifiability: Rank, condition number, base parameters and unidentifiable combinations.
        correlation: Correlations among the identified parameters.
        iterations, converged, message: The solver's account.
        cost_history: ``½‖r‖²`` (weighted) after each accepted iteration.
        errors_before, errors_after: Per measurement key, per-sample errors (predicted − measured).
        sample_weights: Robust-loss weights per sample (1 = fully trusted).
        sigma2: A-posteriori variance factor (≈ 1 when the stated σ are right).
        seconds: Wall time of identification.
        extra: Further records; the solver's counters ``rejected_steps``, ``evaluations`` (of the model: trial
            points, geodesic look-aheads, and the Jacobian at the start and at each accepted step),
            ``accelerated_steps`` (trials with geodesic acceleration) and ``rank_changes`` (iterations at
            which the number of directions moved along changed).
        final: The problem evaluated at ``x`` by the fit (weighted residual [σ units] and its Jacobian on the data's
            rows, errors and predictions [m, rad]): :func:`identify` and model selection read it instead of evaluating
            again; None when the samples' configurations were reset after the fit.
    """

    names: list[str]
    x0: Array
    x: Array
    std: Array
    identified: list[int]
    identifiability: Identifiability
    correlation: Array
    iterations: int
    converged: bool
    message: str
    cost_history: list[float]
    errors_before: dict[str, Array]
    errors_after: dict[str, Array]
    sample_weights: Array
    sigma2: float
    seconds: float
    solver: str = "lm"
    loss: str = "linear"
    extra: dict[str, object] = field(default_factory=dict)
    std_apriori: Array | None = None  # from the stated σ alone: sqrt(diag((JᵀJ)⁻¹)) [m or rad]
    final: Prediction | None = field(default=None, init=False, repr=False, compare=False)

    @property
    def unidentified(self) -> list[str]:
        """Names of the parameters that were not estimated (not in ``identified``)."""
        return [n for k, n in enumerate(self.names) if k not in set(self.identified)]

    def down_weighted(self, threshold: float = 0.5) -> list[int]:
        """Samples whose robust weight fell below ``threshold``."""
        return [int(k) for k in np.flatnonzero(self.sample_weights < threshold)]


#: The solver's counters, summed when one fit continues another.
COUNTERS = ("rejected_steps", "evaluations", "accelerated_steps", "rank_changes")


def chained(first: CalibrationResult, then: CalibrationResult) -> CalibrationResult:
    """``then``, a fit that followed ``first``, accounted as one: ``first``'s start and errors before, both
    fits' iterations, cost history, time and counters."""
    then.x0, then.errors_before = first.x0, first.errors_before
    then.iterations += first.iterations
    then.cost_history = first.cost_history + then.cost_history
    then.seconds += first.seconds
    for key in COUNTERS:
        then.extra[key] = int(first.extra.get(key, 0)) + int(then.extra.get(key, 0))  # type: ignore[call-overload]
    return then
