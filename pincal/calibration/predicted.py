"""Predicted accuracy: how far a calibrated model's prediction of a posture may be off, from the fit and the data.

A sample's length-type error is predicted to have the covariance ``S = J C Jᵀ + σ̂² diag(σ_row²)`` [m²] of the fit's
estimates propagated (:mod:`pincal.calibration.propagation`, with ``C`` the fit's covariance,
:func:`~pincal.calibration.report.parameter_covariance`: a posteriori, scaled by the fit's variance factor ``σ̂²``);
its 95 % bound with no growth ``B`` is the quantile of ``‖e‖`` under ``S``. That bound trusts the model. How far the
data show it off, and how what the model lacks grows beyond the fitted range, are estimated from the data themselves
(:mod:`pincal.calibration.growth`): the bound at a posture of extrapolation distance ``u`` (how far beyond the fitted
joint ranges, in range widths) is ``√ρ₀ B + E₁ u``. It is never taken above the nominal
robot's own predicted error there plus the noise's bound: the nominal robot with its setup registered ("before",
:func:`~pincal.calibration.heldout.register_setup`) has its own 95 % error bound, estimated from the same hold-outs
(:meth:`~pincal.calibration.growth.ErrorGrowth.nominal`); a calibration is never less sure of a posture than that.
docs/predicted_accuracy.md explains the choice. Every length in m, every angle in rad.
"""

from __future__ import annotations

from collections.abc import Sequence
from typing import Any

import numpy as np
import numpy.typing as npt

from pincal import linalg
from pincal.calibration.covariance import parameter_covariance
from pincal.calibration.growth import MIN_WIDTH, ErrorGrowth, extrapolation_distance
from pincal.calibration.propagation import LEVEL, length_covariances, length_layout, norm_quantile, norm_quantiles
from pincal.calibration.report_sections import (
    Covariance,
    Coverage,
    HeldOutPredictions,
    PredictedSample,
    WorkspacePrediction,
)
from pincal.errors import ConvergenceError, PincalError
from pincal.identification.choices import MarkerFit
from pincal.identification.metrics import length_columns
from pincal.identification.parameters import joint_unit
from pincal.identification.predictions import remember
from pincal.identification.problem import CalibrationProblem, Observations, Prediction
from pincal.identification.result import CalibrationResult
from pincal.model.assemblable import assemble
from pincal.model.robot import Robot
from pincal.records import record
from pincal.study.simulation import random_actuated

Array = npt.NDArray[np.float64]

__all__ = ["LEVEL", "MIN_WIDTH", "WORKSPACE_POSTURES", "FitCovariance", "PredictedErrors", "coverage", "distance",
           "fitted_ranges", "held_out_predictions", "norm_quantile", "norm_quantiles", "outside_range",
           "predicted_errors", "workspace_prediction"]

#: Postures the report samples within the joint limits to draw the predicted uncertainty over the workspace.
WORKSPACE_POSTURES = 100


@record(frozen=True)
class PredictedErrors:
    """The predicted length-type error of each sample of a problem.

    Attributes:
        sigma: (N, k) σ [m] of each length row of a sample (k: the length rows of every measurement, in the
            measurements' order; NaN for a reading not taken), noise included, no growth.
        linear: (N,) the 95 % bound [m] of the sample's length error norm with no growth (the covariance and the
            noise alone; NaN where the covariance is not known or the sample has no length reading).
        distance: (N,) its extrapolation distance beyond the fitted ranges (0 inside them).
        bound: (N,) its 95 % bound [m]: ``linear`` grown at ``distance`` (:meth:`~pincal.calibration.growth.
            ErrorGrowth.bounds`), at most ``cap``.
        cap: (N,) the nominal robot's predicted error plus the noise's bound [m] (inf where not known).
    """

    sigma: Array
    linear: Array
    distance: Array
    bound: Array
    cap: Array

    @property
    def capped(self) -> npt.NDArray[np.bool_]:
        """Which bounds are the cap."""
        return np.isfinite(self.bound) & (self.bound >= self.cap)

    def inside(self, errors: Array) -> npt.NDArray[np.bool_]:
        """Which of the samples' error norms ``errors`` (N,) [m] lie within their bound (False where either is NaN)."""
        return np.isfinite(errors) & np.isfinite(self.bound) & (errors <= self.bound)


@record(frozen=True)
class FitCovariance:
    """The covariance a fit gives its estimates, and how its bound grows, as the predictions use them.

    Attributes:
        matrix: (q, q) covariance [m², m·rad, rad²] of the estimated parameters (NaN where not known).
        columns: Their indices in the problem's parameter order.
        sigma2: The fit's a-posteriori variance factor (scales the stated measurement σ² into the noise part).
        growth: How the bound grows beyond the fitted range (:mod:`pincal.calibration.growth`); None: no growth
            (not estimated).
    """

    matrix: Array
    columns: list[int]
    sigma2: float
    growth: ErrorGrowth | None = None

    @classmethod
    def of_result(cls, result: CalibrationResult, growth: ErrorGrowth | None = None) -> FitCovariance:
        """As the fit ``result`` gives it (:func:`~pincal.calibration.report.parameter_covariance`)."""
        return cls(parameter_covariance(result), list(result.identified), float(result.sigma2), growth)

    @classmethod
    def of_report(cls, covariance: Covariance | None, sigma2: float | None, names: Sequence[str],
                  growth: ErrorGrowth | None = None) -> FitCovariance:
        """As a report holds it (its ``covariance``, its ``sigma2`` and ``error_growth``), over the parameters
        ``names`` in a problem's order; NaN when the report holds none."""
        held = list(covariance.parameters) if covariance is not None else []
        matrix = np.array([[np.nan if v is None else float(v) for v in row]
                           for row in (covariance.matrix if covariance is not None else [])])
        columns = [list(names).index(n) for n in held if n in names]
        if len(columns) != len(held) or matrix.shape != (len(held), len(held)) or sigma2 is None:
            return cls(np.full((1, 1), np.nan), [0], float("nan"), growth)
        return cls(matrix, columns, float(sigma2), growth)


def fitted_ranges(robot: Robot, actuated: Array, joints: Sequence[str] | None = None) -> dict[str, list[float]]:
    """The range [min, max] [rad or m] of each actuated joint's readings ``actuated`` (N, na) in the fit, for the
    ``joints`` given (default: every actuated joint)."""
    chosen = robot.actuated_joints if joints is None else [j for j in robot.actuated_joints if j in joints]
    columns = {name: k for k, name in enumerate(robot.actuated_joints)}
    return {j: [float(np.min(actuated[:, columns[j]])), float(np.max(actuated[:, columns[j]]))] for j in chosen}


def distance(robot: Robot, actuated: Array, ranges: dict[str, list[float]]) -> Array:
    """Each posture's extrapolation distance beyond the fitted ``ranges`` (:func:`~pincal.calibration.growth.
    extrapolation_distance`) for its readings ``actuated`` (N, na) [rad or m]; 0 inside them."""
    known = [j for j in ranges if j in robot.actuated_joints]
    return extrapolation_distance(actuated, [robot.actuated_joints.index(j) for j in known],
                                  [(ranges[j][0], ranges[j][1]) for j in known],
                                  [joint_unit(robot, j) == "rad" for j in known])


def outside_range(robot: Robot, actuated: Array, ranges: dict[str, list[float]]) -> npt.NDArray[np.bool_]:
    """Which postures (readings ``actuated`` (N, na) [rad or m]) lie outside a fitted range by more than its margin
    (``RANGE_MARGIN`` of its width on each side, as the held-out warning counts it)."""
    return distance(robot, actuated, ranges) > 0.0


def predicted_errors(problem: CalibrationProblem, fit: CalibrationResult | FitCovariance, x: Array,
                     distances: Array | None = None, prediction: Prediction | None = None) -> PredictedErrors:
    """The predicted length-type errors of ``problem``'s samples for the model at ``x`` [m, rad] (in ``problem``'s
    parameter order, the one ``fit`` was fitted in), with the covariance the fit gives (its result, or
    :class:`FitCovariance` with its growth), at extrapolation distances ``distances`` (N,) (default 0: inside the
    fitted range); ``prediction``: ``problem``'s evaluation at ``x`` with its Jacobian, if made already. Each bound is
    capped by the nominal robot's own (:meth:`~pincal.calibration.growth.ErrorGrowth.nominal`) plus the noise's."""
    fit = fit if isinstance(fit, FitCovariance) else FitCovariance.of_result(fit)
    n = problem.observations.n_samples
    distances = np.zeros(n) if distances is None else np.asarray(distances, dtype=float)
    prediction = problem.evaluate(x, jacobian=True) if prediction is None else prediction
    assert prediction.jacobian is not None
    width = int(sum(length_columns(m.key) for m in problem.measurements))
    nothing = np.full(n, np.nan)
    if not np.all(np.isfinite(fit.matrix)) or not np.isfinite(fit.sigma2):
        return PredictedErrors(np.full((n, width), np.nan), nothing, distances, nothing, np.full(n, np.inf))
    layout = length_layout(problem)
    s, taken = length_covariances(problem, prediction.jacobian[:, fit.columns], fit.matrix, fit.sigma2, None, layout)
    sigma = np.full((n, width), np.nan)
    diagonal = np.arange(s.shape[1])
    sigma[layout.samples, layout.columns] = np.sqrt(s[:, diagonal, diagonal][taken])
    measured = taken.any(axis=1)
    linear = np.full(n, np.nan)
    linear[measured] = norm_quantiles(s[measured])
    grown = fit.growth.bounds(linear, distances) if fit.growth is not None else linear
    cap = _cap(problem, fit, distances, layout)
    return PredictedErrors(sigma, linear, distances, np.minimum(grown, cap), cap)


def _cap(problem: CalibrationProblem, fit: FitCovariance, distances: Array, layout: Any) -> Array:
    """Each sample's cap [m]: the nominal robot's own 95 % error bound at its distance (the fit's growth holds it)
    plus the 95 % bound of the noise alone (the stated σ scaled by the fit's variance factor); inf where not known."""
    n = problem.observations.n_samples
    nominal = fit.growth.nominal(distances) if fit.growth is not None else np.full(n, np.nan)
    s, taken = length_covariances(problem, np.zeros((problem.row_samples().size, 0)), np.zeros((0, 0)), fit.sigma2,
                                  None, layout)
    noise = np.full(n, np.nan)
    measured = taken.any(axis=1)
    noise[measured] = norm_quantiles(s[measured])
    return np.where(np.isfinite(nominal) & np.isfinite(noise), nominal + noise, np.inf)


def workspace_postures(problem: CalibrationProblem, actuated: Array) -> CalibrationProblem:
    """``problem``'s robot, parameters and measurements at the postures ``actuated`` (N, na) [rad or m], with
    neutral readings: its predictions are absolute positions, its Jacobian that of the predictions."""
    observations = Observations.neutral(problem.measurements, actuated)
    return CalibrationProblem(problem.robot, problem.parameters, problem.measurements, observations,
                              payload=problem.payload)


def coverage(predicted: PredictedErrors, errors: Array) -> dict[str, Any]:
    """How many of the samples' error norms ``errors`` (N,) [m] lie within their predicted 95 % bound, as the check
    report holds it: all of them (``inside``/``samples``/``fraction``), and those within and beyond the fitted range
    apart (``in_range``, ``beyond_range``: the same each)."""
    every, in_range, beyond_range = coverages(predicted, errors)
    return {**every.as_dict(), "in_range": in_range.as_dict(), "beyond_range": beyond_range.as_dict()}


def coverages(predicted: PredictedErrors, errors: Array) -> tuple[Coverage, Coverage, Coverage]:
    """How many of the samples' error norms ``errors`` (N,) [m] lie within their predicted 95 % bound: all of them,
    and those within and beyond the fitted range apart."""
    known = np.isfinite(errors) & np.isfinite(predicted.bound)
    within = predicted.inside(errors)
    inside, beyond = predicted.distance <= 0.0, predicted.distance > 0.0
    return (_share(within, known), _share(within & inside, known & inside), _share(within & beyond, known & beyond))


def _share(within: npt.NDArray[np.bool_], known: npt.NDArray[np.bool_]) -> Coverage:
    inside, total = int(np.count_nonzero(within)), int(np.count_nonzero(known))
    return Coverage(inside=inside, samples=total, fraction=inside / total if total else None)


def workspace_prediction(problem: CalibrationProblem, fit: FitCovariance, x: Array,
                         ranges: dict[str, list[float]], n: int = WORKSPACE_POSTURES,
                         seed: int = 0) -> WorkspacePrediction | None:
    """The predicted error over the workspace: ``n`` postures drawn within the joint limits (as ``pincal simulate``
    draws them, seeded; those the calibrated robot cannot close left out), each with the predicted position of the
    first measured point [m] and its 95 % bound [m] (grown beyond the fitted ``ranges``, capped by the nominal robot's
    own), and the bounds' median and maximum [m]; None when the model measures no length or no posture can be
    drawn."""
    if not any(length_columns(m.key) == 3 for m in problem.measurements):
        return None
    try:
        actuated, q = random_actuated(problem.robot, n, np.random.default_rng(seed))
        closed, predicted, prediction = predicted_at(problem, fit, x, actuated, ranges, q)
        actuated, distances = actuated[closed], predicted.distance
        key = next(m.key for m in problem.measurements if length_columns(m.key) == 3)
        positions = prediction.predicted[key][:, :3]
    except ConvergenceError:
        return None
    bounds = predicted.bound
    finite = bounds[np.isfinite(bounds)]
    return WorkspacePrediction(postures=len(actuated), measurement=key, positions=positions.tolist(),
                               bounds=bounds.tolist(), distance=distances.tolist(),
                               outside_fitted_range=int(np.count_nonzero(distances > 0.0)),
                               capped=int(np.count_nonzero(predicted.capped)),
                               median_bound=float(linalg.median(finite)) if finite.size else None,
                               max_bound=float(np.max(finite)) if finite.size else None)


def predicted_at(problem: CalibrationProblem, fit: FitCovariance, x: Array, actuated: Array,
                 ranges: dict[str, list[float]], guesses: Array | None = None
                 ) -> tuple[npt.NDArray[np.bool_], PredictedErrors, Prediction]:
    """The predicted errors of ``problem``'s measurements at the postures ``actuated`` (N, na) [rad or m] for the model
    at ``x`` [m, rad]: which postures the calibrated robot closes (``guesses``, configurations of the nominal robot,
    start its solves), their :class:`PredictedErrors` (grown beyond the fitted ``ranges``) and their prediction.

    Raises:
        ConvergenceError: none can be evaluated.
    """
    solved = assemble(problem.robot_at(x), actuated, np.inf, guesses=guesses)
    closed = solved.usable
    postures = workspace_postures(problem, actuated[closed])
    remember(postures, solved.q[closed])
    prediction = postures.evaluate(x, jacobian=True)
    distances = distance(problem.robot, actuated[closed], ranges)
    return closed, predicted_errors(postures, fit, x, distances, prediction), prediction


def bounds_at(nominal: Robot, calibration: Any, actuated: Array) -> tuple[Array, Array] | None:
    """Each posture's 95 % bound [m] under the calibration ``calibration`` holds (a report, or the calibration a
    calibrated URDF carries: :mod:`pincal.calibration.carried`) on ``nominal``, at the raw readings ``actuated``
    (N, na) [rad or m], and the nominal robot's own bound there (``E₀ + E₁ u``); NaN where a posture cannot be closed.
    The bound is that of the first point the calibration measured. None when the calibration's parameters are not
    ``nominal``'s or it holds no covariance."""
    from pincal.identification.measurements import parse_key
    from pincal.identification.parameters import choose_parameters

    declared = {target: (float(a), float(b), float(c)) for target, (a, b, c) in calibration.declared_markers.items()}
    models = weighed_as_fitted([parse_key(key).with_markers(declared) for key in calibration.measurements], calibration)
    if not any(length_columns(m.key) == 3 for m in models):
        return None
    names = list(calibration.parameters)
    fitted: MarkerFit = "cluster" if calibration.markers == "cluster" else "each"
    try:
        parameters = choose_parameters(nominal, models, names, fitted)
    except (PincalError, KeyError):
        return None
    x = np.array([float(calibration.parameters[name].value) for name in parameters.names])
    growth = calibration.error_growth
    fit = FitCovariance.of_report(calibration.covariance, calibration.sigma2, parameters.names, growth)
    template = CalibrationProblem(nominal, parameters, models, Observations.neutral(models, actuated[:1]))
    bound, own = np.full(len(actuated), np.nan), np.full(len(actuated), np.nan)
    try:
        closed, predicted, _ = predicted_at(template, fit, x, actuated, calibration.fitted_range or {})
    except ConvergenceError:
        return bound, own
    bound[closed] = predicted.bound
    if growth is not None:
        own[closed] = growth.nominal(predicted.distance)
    return bound, own


def weighed_as_fitted(models: list[Any], calibration: Any) -> list[Any]:
    """``models`` with the σ of each row the calibration's fit weighed the same measurement by (its ``row_sigma``):
    the noise part of a bound is the instrument's as calibrated, whatever σ the new data state."""
    fitted: dict[str, list[float]] = getattr(calibration, "row_sigma", None) or {}
    return [m.with_component_sigma(fitted[m.key]) if len(fitted.get(m.key, [])) == m.size else m for m in models]


def held_out_predictions(ids: list[str], predicted: PredictedErrors, errors: Array) -> HeldOutPredictions:
    """The report's account of the held-out predictions: per sample (``ids``) its predicted σ per length row, its 95 %
    bound [m], the bound with no growth [m], its extrapolation distance and whether the cap set it; the coverage of the
    error norms ``errors`` (N,) [m], all and within and beyond the fitted range apart."""
    finite = predicted.bound[np.isfinite(predicted.bound)]
    beyond = [ids[k] for k in np.flatnonzero(predicted.distance > 0.0)]
    every, in_range, beyond_range = coverages(predicted, errors)
    return HeldOutPredictions(
        level=LEVEL, inside=every.inside, samples=every.samples, fraction=every.fraction, in_range=in_range,
        beyond_range=beyond_range, median_bound=float(linalg.median(finite)) if finite.size else None, beyond=beyond,
        samples_predicted=[PredictedSample(sample=s, sigma=[None if not np.isfinite(v) else float(v) for v in sig],
                                           bound=float(b) if np.isfinite(b) else None,
                                           linear_bound=float(lb) if np.isfinite(lb) else None,
                                           distance=float(u), capped=bool(c))
                           for s, sig, b, lb, u, c in zip(ids, predicted.sigma, predicted.bound, predicted.linear,
                                                          predicted.distance, predicted.capped, strict=True)])
