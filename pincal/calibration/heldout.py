"""The one held-out evaluation: a fit's "before" and "after" on the samples it did not see.

"Before" is the nominal robot with its setup registered (:func:`register_setup`): the measurement frame, markers,
cameras, targets and planes fitted to the *training* data with the robot's own geometry at nominal, by the same fit
(loss and all) as the calibration: the gain a user sees is then the robot's calibration, not the registration of a
marker. The fit's start (the frame registered in closed form, markers at their nominal offsets) stays as a second
figure, named for what it is. Both are evaluated on the fit and the held-out samples alike; "after" is the estimate.
The report's held-out figures, the HTML page's figures and tables, ``view`` and the Monte Carlo trial all come from
:func:`evaluate_held_out`. Errors in m (lengths) and rad (orientations).
"""

from __future__ import annotations

import math
from dataclasses import replace
from typing import Any

import numpy as np
import numpy.typing as npt

from pincal import linalg
from pincal.calibration.growth import ErrorGrowth
from pincal.calibration.predicted import (
    FitCovariance,
    PredictedErrors,
    coverage,
    distance,
    fitted_ranges,
    predicted_errors,
)
from pincal.calibration.report_sections import PixelErrors
from pincal.calibration.samples import held_out_outside_range
from pincal.calibration.setup import Prepared
from pincal.calibration.setup_parameters import setup_columns
from pincal.errors import PincalError
from pincal.identification.fit_options import FitOptions
from pincal.identification.losses import outlier_samples
from pincal.identification.metrics import angle_error_norms, error_norms, pixel_error_norms, rms, sample_length_errors
from pincal.identification.parameters import ParameterSet, influencing_joints, read_joints
from pincal.identification.predictions import carry_over
from pincal.identification.problem import CalibrationProblem
from pincal.identification.result import CalibrationResult
from pincal.identification.solver import identify_with
from pincal.io.dataset import Dataset
from pincal.model.assemblable import assemble
from pincal.records import record

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
    keep = linalg.complement(n, strange) if len(strange) < n else np.arange(n)
    keep = keep[np.isfinite(per_after[keep]) & np.isfinite(per_before[keep])]  # samples with a length reading
    return bool(rms(per_after[keep]) > (1 + SAME_ERROR) * rms(per_before[keep]))


@record(frozen=True)
class Registration:
    """The nominal robot with its setup registered on the training samples: the calibration's "before".

    Attributes:
        x: (p,) deviations [m, rad] in the problem's parameter order: the setup's (parameters of no selection group:
            measurement frame, markers, cameras, targets, planes, device constants) fitted, the robot's 0.
        errors: Per measurement key, (N, rows) errors [m, rad] of the training samples at ``x``.
        start_errors: The same at the fit's start (frame in closed form, markers at their nominal offsets).
        registered: Whether the fit of the setup lowered the error below the start's (else ``x`` is the start, and
            ``note`` says why).
        note: Why the start stands, when it does.
    """

    x: Array
    errors: dict[str, Array]
    start_errors: dict[str, Array]
    registered: bool
    note: str = ""


def register_setup(problem: CalibrationProblem, x0: Array, options: FitOptions) -> Registration:
    """The nominal robot with the setup of ``problem`` fitted to its samples from the start ``x0`` [m, rad] (in its
    parameter order) by :func:`~pincal.identification.solver.identify_with` with ``options`` (the calibration's loss,
    solver and iterations; the setup has no prior). The start is kept, and said so, when the fit does not lower the
    RMS error (a robust fit may end above it) or fails."""
    start = problem.evaluate(x0, jacobian=False).errors
    columns = setup_columns(problem.parameters)
    if not columns:
        return Registration(x0.copy(), start, start, False)  # nothing to register: the start is the nominal robot
    joint_sigma = None if problem.joint_sigma is None else list(problem.joint_sigma)
    reduced = CalibrationProblem(problem.robot, problem.parameters.subset(columns), problem.measurements,
                                 problem.observations, joint_sigma, problem.payload)
    carry_over(problem, reduced)
    try:
        fitted = identify_with(reduced, replace(options, prior=None), x0[columns])
    except PincalError as exc:
        return Registration(x0.copy(), start, start, False, f"the setup's fit failed ({exc}); the start stands")
    x = np.zeros_like(x0)
    x[columns] = fitted.x
    errors = problem.evaluate(x, jacobian=False).errors
    norms, scale, unit = (error_norms, 1e3, "mm") if error_norms(start).size else (pixel_error_norms, 1.0, "px")
    fitted_rms, start_rms = rms(norms(errors)), rms(norms(start))
    if not fitted_rms < start_rms:
        return Registration(x0.copy(), start, start, False, f"the setup's fit ended at an RMS above the start's "
                            f"({fitted_rms * scale:.4f} against {start_rms * scale:.4f} {unit}); the start stands")
    return Registration(x, errors, start, True)


@record(frozen=True)
class HeldOut:
    """A fit evaluated on held-out samples.

    Attributes:
        prepared: The held-out samples' problem (with the fit's models and parameters); its ``dropped`` lists the
            held-out samples that could not be used.
        errors_before, errors_after: Per measurement key, (N, rows) errors [m, rad] of the nominal robot with its setup
            registered ("before", :func:`register_setup`) and at the estimate.
        outliers: Ids of the held-out samples the calibrated model cannot explain at the noise level the held-out
            set itself shows (they inflate the held-out figures).
        outside_range: Held-out readings of actuated joints outside the fitted range
            (:func:`~pincal.calibration.samples.held_out_outside_range`).
        worse_than_nominal: Whether the estimate predicts the held-out samples worse than "before".
        predicted: Each held-out sample's predicted error after calibration (σ per length row and the 95 % bound,
            widened outside the fitted range: :mod:`~pincal.calibration.predicted`); None without the fit's result.
        fitted_range: The fitted samples' range [min, max] [rad or m] of each actuated joint that moves what is
            measured.
        errors_start: The errors at the fit's start (frame in closed form, markers at nominal), or None where it is
            "before" itself.
    """

    prepared: Prepared
    errors_before: dict[str, Array]
    errors_after: dict[str, Array]
    outliers: list[str]
    outside_range: list[dict[str, Any]]
    worse_than_nominal: bool
    predicted: PredictedErrors | None = None
    fitted_range: dict[str, list[float]] | None = None
    errors_start: dict[str, Array] | None = None

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
        pixels = pixel_error_norms(self.errors_before)
        if pixels.size:
            out["test_pixels"] = PixelErrors(rms_before=rms(pixels),
                                             rms_after=rms(pixel_error_norms(self.errors_after)))
        if self.errors_start is not None:
            out["test_rms_start"] = rms(error_norms(self.errors_start))
            angles = angle_error_norms(self.errors_start)
            out["test_rms_angle_start"] = rms(angles) if angles.size else None
        return out

    def coverage(self) -> dict[str, Any] | None:
        """How many held-out length errors after calibration lie within their predicted 95 % bound (``inside``,
        ``samples``, ``fraction``); None without a prediction."""
        return coverage(self.predicted, self.sample_errors()[1]) if self.predicted is not None else None


def _assembled_at(test: Prepared, x: Array) -> Prepared:
    """``test`` less the samples the model at ``x`` cannot assemble (a closed-loop robot whose loops do not close at
    their readings under the estimate), each listed in its ``dropped`` with the reason."""
    problem = test.problem
    if not problem.robot.loops or not problem.observations.n_samples:
        return test
    solved = assemble(problem.robot_at(x), problem.observations.actuated, math.inf)
    if solved.usable.all():
        return test
    ids = test.samples.sample_ids
    lost = [{"sample": ids[k], "reason": f"the calibrated model cannot assemble it: {solved.reasons[k]}"}
            for k in np.flatnonzero(~solved.usable).tolist()]
    kept = test.samples.subset(np.flatnonzero(solved.usable))
    again = test.on(kept, test.parameters, "held-out ") if kept.n_samples else None
    if again is None:
        return replace(test, dropped=test.dropped + lost)
    return replace(again, dropped=test.dropped + again.dropped + lost)


def evaluate_held_out(fit: Prepared, dataset: Dataset, parameters: ParameterSet, x0: Array, x: Array,
                      trusted: bool = True, result: CalibrationResult | None = None,
                      x_start: Array | None = None, growth: ErrorGrowth | None = None) -> HeldOut | None:
    """The ``test`` samples of ``dataset`` (None when it has none) predicted "before" at ``x0`` (the registered nominal
    robot, :func:`register_setup`) and at the estimate ``x`` [m, rad], both in ``parameters``' order, and at the fit's
    start ``x_start`` when it differs; ``fit`` is the training part (its samples set the fitted range). ``trusted``:
    the fit reached the noise level, so held-out outliers are left out of the comparison with the
    start (a wrong held-out reading must not condemn a good fit). ``result`` and its ``growth`` give each held-out
    sample's predicted bound."""
    if "test" not in dataset.sets:
        return None
    test = _assembled_at(fit.on(dataset.of_set("test"), parameters, "held-out "), x)
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
        distances = distance(fit.robot, problem.observations.actuated, ranges)
        predicted = predicted_errors(problem, FitCovariance.of_result(result, growth), x, distances)
    start = None if x_start is None else problem.evaluate(x_start, jacobian=False).errors
    return HeldOut(test, before, held.errors, [test.samples.sample_ids[k] for k in strange], outside, worse,
                   predicted, ranges, start)
