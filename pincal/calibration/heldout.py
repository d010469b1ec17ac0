"""The one held-out evaluation: a fit's "before" and "after" on the samples it did not see.

"Before" is always the fit's start (``x0``: the nominal robot, with the measurement frame registered, or cameras
placed, in closed form from the *training* data where they are estimated), for the fit and the held-out samples alike;
"after" is the estimate. The report's held-out figures, the HTML page's figures and tables, ``view`` and the Monte
Carlo trial all come from :func:`evaluate_held_out`. Errors in m (lengths) and rad (orientations).
"""

from __future__ import annotations

from dataclasses import dataclass
from typing import Any

import numpy as np
import numpy.typing as npt

from pincal.calibration.predicted import PredictedErrors, coverage, fitted_ranges, predicted_errors, widening
from pincal.calibration.samples import held_out_outside_range
from pincal.calibration.setup import Prepared
from pincal.identification.losses import outlier_samples
from pincal.identification.metrics import angle_error_norms, error_norms, rms, sample_length_errors
from pincal.identification.parameters import ParameterSet, influencing_joints, read_joints
from pincal.identification.result import CalibrationResult
from pincal.io.dataset import Dataset

Array = npt.NDArray[np.float64]

#: Relative difference of two RMS errors below which they are the same (a fit of the base alone reproduces the
#: closed-form registration of the "before" model up to round-off).
SAME_ERROR = 1e-6


#: σ² factor beyond which a fit does not reach the stated noise (residuals over 3 × σ).
NOISE_CONTRADICTED = 9.0


def worse_than_nominal(before: dict[str, Array], after: dict[str, Array], n: int, strange: list[int]) -> bool:
    """Whether the calibrated model predicts the held-out samples worse than the nominal one (RMS length error),
    leaving out the ``strange`` held-out samples (those a fit at the noise level cannot explain: a wrong reading
    in the held-out set must not condemn a good fit); on all samples when that would leave none."""
    per_before, per_after = sample_length_errors(before, n), sample_length_errors(after, n)
    if per_before is None or per_after is None:
        return bool(rms(error_norms(after)) > (1 + SAME_ERROR) * rms(error_norms(before)))
    keep = np.setdiff1d(np.arange(n), strange) if len(strange) < n else np.arange(n)
    keep = keep[np.isfinite(per_after[keep]) & np.isfinite(per_before[keep])]  # samples with a length reading
    return bool(rms(per_after[keep]) > (1 + SAME_ERROR) * rms(per_before[keep]))


@dataclass(frozen=True)
class HeldOut:
    """A fit evaluated on held-out samples.

    Attributes:
        prepared: The held-out samples' problem (with the fit's models and parameters); its ``dropped`` lists the
            held-out samples that could not be used.
        errors_before, errors_after: Per measurement key, (N, rows) errors [m, rad] at the fit's start and at the
            estimate.
        outliers: Ids of the held-out samples the calibrated model cannot explain at the noise level the held-out
            set itself shows (they inflate the held-out figures).
        outside_range: Held-out readings of actuated joints outside the fitted range
            (:func:`~pincal.calibration.samples.held_out_outside_range`).
        worse_than_nominal: Whether the estimate predicts the held-out samples worse than the start.
        predicted: Each held-out sample's predicted error after calibration (σ per length row and the 95 % bound,
            widened outside the fitted range: :mod:`~pincal.calibration.predicted`); None without the fit's result.
        fitted_range: The fitted samples' range [min, max] [rad or m] of each actuated joint that moves what is
            measured.
    """

    prepared: Prepared
    errors_before: dict[str, Array]
    errors_after: dict[str, Array]
    outliers: list[str]
    outside_range: list[dict[str, Any]]
    worse_than_nominal: bool
    predicted: PredictedErrors | None = None
    fitted_range: dict[str, list[float]] | None = None

    @property
    def n_samples(self) -> int:
        """The held-out samples evaluated (the usable ones)."""
        return self.prepared.samples.n_samples

    def sample_errors(self) -> tuple[Array, Array]:
        """Per-sample length-type error [m] before and after (NaN for a sample with no such reading; zeros when
        nothing length-like is measured)."""
        n = self.n_samples
        before, after = sample_length_errors(self.errors_before, n), sample_length_errors(self.errors_after, n)
        return (before, after) if before is not None and after is not None else (np.zeros(n), np.zeros(n))

    def figures(self) -> dict[str, Any]:
        """RMS and max errors before and after [m; rad for orientations], as the report holds them."""
        before, after = error_norms(self.errors_before), error_norms(self.errors_after)
        out: dict[str, Any] = {"n_test_samples": self.n_samples, "test_rms_before": rms(before),
                               "test_rms_after": rms(after),
                               "test_max_before": float(before.max()) if before.size else None,
                               "test_max_after": float(after.max()) if after.size else None}
        angles_before, angles_after = angle_error_norms(self.errors_before), angle_error_norms(self.errors_after)
        if angles_before.size:
            out.update({"test_rms_angle_before": rms(angles_before), "test_rms_angle_after": rms(angles_after),
                        "test_max_angle_before": float(angles_before.max()),
                        "test_max_angle_after": float(angles_after.max())})
        return out

    def coverage(self) -> dict[str, Any] | None:
        """How many held-out length errors after calibration lie within their predicted 95 % bound (``inside``,
        ``samples``, ``fraction``); None without a prediction."""
        return coverage(self.predicted, self.sample_errors()[1]) if self.predicted is not None else None


def evaluate_held_out(fit: Prepared, dataset: Dataset, parameters: ParameterSet, x0: Array, x: Array,
                      trusted: bool = True, result: CalibrationResult | None = None) -> HeldOut | None:
    """The ``test`` samples of ``dataset`` (None when it has none) predicted at the fit's start ``x0`` and at its
    estimate ``x`` [m, rad], both in ``parameters``' order; ``fit`` is the training part (its samples set the fitted
    range). ``trusted``: the fit reached the noise level, so held-out outliers are left out of the comparison with the
    start (a wrong held-out reading must not condemn a good fit)."""
    if "test" not in dataset.sets:
        return None
    test = fit.on(dataset.of_set("test"), parameters, "held-out ")
    problem = test.problem
    before = problem.evaluate(x0, jacobian=False).errors
    held = problem.evaluate(x, jacobian=False)
    strange = outlier_samples(problem, held)
    moving = influencing_joints(fit.robot, sorted({f for m in fit.models for f in m.frames}),
                                read_joints(fit.models))
    outside = held_out_outside_range(fit.robot, fit.samples, test.samples, joints=moving)
    worse = worse_than_nominal(before, held.errors, test.samples.n_samples, strange if trusted else [])
    ranges = fitted_ranges(fit.robot, fit.problem.observations.actuated, moving)
    predicted = None
    if result is not None and problem.observations.n_samples:
        factor = widening(fit.robot, problem.observations.actuated, ranges)
        predicted = predicted_errors(problem, result, x, factor)
    return HeldOut(test, before, held.errors, [test.samples.sample_ids[k] for k in strange], outside, worse,
                   predicted, ranges)
