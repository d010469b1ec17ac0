"""Predicted accuracy: how far a calibrated model's prediction of a posture may be off, from the fit's covariance.

A sample's length-type error (its position, pose-position and distance rows together, as
:func:`~pincal.identification.metrics.sample_length_errors` measures it) is predicted to have the covariance

    S = J C Jᵀ + σ̂² diag(σ_row²)                                                         [m²]

with ``J`` the rows' derivatives w.r.t. the identified parameters at the estimate (unweighted: the problem's rows
are divided by their σ, so they are multiplied back), ``C`` the estimates' covariance as the fit gives it
(:func:`~pincal.calibration.report.parameter_covariance`: a posteriori, scaled by the fit's variance factor ``σ̂²``),
and the noise the measurement's stated σ per row scaled by the same ``σ̂²`` (the a-posteriori noise). The 95 % bound
of the error's norm ``‖e‖`` is the quantile of ``eᵀe``, a weighted sum of χ² variables, by the
Welch–Satterthwaite approximation ``eᵀe ≈ a χ²_ν`` with ``a = tr(S²)/tr(S)``, ``ν = tr(S)²/tr(S²)`` (exact for an
isotropic S).

Outside the joint ranges the fit saw, the linear propagation already grows with the lever arms, but it assumes the
model is right; what the fit absorbed of unmodelled effects inside its range can grow outside it. The bound is then
widened by the factor ``1 + Σ_j d_j / w_j`` (``d_j`` [rad or m]: how far joint j's reading lies beyond the fitted
range and its margin of 10 % of the width on each side, as the held-out warning counts it; ``w_j``: the range's
width, at least :data:`MIN_WIDTH`): one range width beyond doubles the bound.
docs/predicted_accuracy.md explains the choice. Every length in m, every angle in rad.
"""

from __future__ import annotations

from collections.abc import Sequence
from dataclasses import dataclass
from typing import Any

import numpy as np
import numpy.typing as npt

from pincal.calibration.report import parameter_covariance
from pincal.calibration.samples import RANGE_MARGIN
from pincal.errors import ConvergenceError
from pincal.identification.chi2 import chi2_upper
from pincal.identification.metrics import length_columns
from pincal.identification.predictions import remember
from pincal.identification.problem import CalibrationProblem, Observations, Prediction
from pincal.identification.result import CalibrationResult
from pincal.model.assemblable import assemble
from pincal.model.robot import Robot
from pincal.study.simulation import random_actuated

Array = npt.NDArray[np.float64]

#: The probability of the predicted bound.
LEVEL = 0.95
#: Postures the report samples within the joint limits to draw the predicted uncertainty over the workspace.
WORKSPACE_POSTURES = 100
#: Smallest fitted range width [rad or m] the widening divides by (a joint the fit saw still gets a finite factor).
MIN_WIDTH = 0.05


@dataclass(frozen=True)
class PredictedErrors:
    """The predicted length-type error of each sample of a problem.

    Attributes:
        sigma: (N, k) σ [m] of each length row of a sample (k: the length rows of every measurement, in the
            measurements' order; NaN for a reading not taken), noise included.
        bound: (N,) 95 % bound [m] of the sample's length error norm, widened outside the fitted range (NaN where
            the covariance is not known or the sample has no length reading).
        widening: (N,) the factor the bound was widened by (1 inside the fitted range).
    """

    sigma: Array
    bound: Array
    widening: Array

    def inside(self, errors: Array) -> npt.NDArray[np.bool_]:
        """Which of the samples' error norms ``errors`` (N,) [m] lie within their bound (False where either is NaN)."""
        return np.isfinite(errors) & np.isfinite(self.bound) & (errors <= self.bound)


@dataclass(frozen=True)
class FitCovariance:
    """The covariance a fit gives its estimates, as the predictions use it.

    Attributes:
        matrix: (q, q) covariance [m², m·rad, rad²] of the estimated parameters (NaN where not known).
        columns: Their indices in the problem's parameter order.
        sigma2: The fit's a-posteriori variance factor (scales the stated measurement σ² into the noise part).
    """

    matrix: Array
    columns: list[int]
    sigma2: float

    @classmethod
    def of_result(cls, result: CalibrationResult) -> FitCovariance:
        """As the fit ``result`` gives it (:func:`~pincal.calibration.report.parameter_covariance`)."""
        return cls(parameter_covariance(result), list(result.identified), float(result.sigma2))

    @classmethod
    def of_report(cls, covariance: dict[str, Any], sigma2: float | None, names: Sequence[str]) -> FitCovariance:
        """As a report JSON holds it (its ``covariance``: ``parameters`` and ``matrix``, and its ``sigma2``), over the
        parameters ``names`` in a problem's order; NaN when the report holds none."""
        held = list(covariance.get("parameters") or [])
        matrix = np.array([[np.nan if v is None else float(v) for v in row] for row in covariance.get("matrix") or []])
        columns = [list(names).index(n) for n in held if n in names]
        if len(columns) != len(held) or matrix.shape != (len(held), len(held)) or sigma2 is None:
            return cls(np.full((1, 1), np.nan), [0], float("nan"))
        return cls(matrix, columns, float(sigma2))


def fitted_ranges(robot: Robot, actuated: Array, joints: Sequence[str] | None = None) -> dict[str, list[float]]:
    """The range [min, max] [rad or m] of each actuated joint's readings ``actuated`` (N, na) in the fit, for the
    ``joints`` given (default: every actuated joint)."""
    chosen = robot.actuated_joints if joints is None else [j for j in robot.actuated_joints if j in joints]
    columns = {name: k for k, name in enumerate(robot.actuated_joints)}
    return {j: [float(np.min(actuated[:, columns[j]])), float(np.max(actuated[:, columns[j]]))] for j in chosen}


def widening(robot: Robot, actuated: Array, ranges: dict[str, list[float]]) -> Array:
    """Each sample's bound factor ``1 + Σ_j d_j / max(w_j, MIN_WIDTH)`` for its readings ``actuated`` (N, na)
    [rad or m]: ``d_j`` how far beyond the fitted range of joint j (``ranges``), widened by ``RANGE_MARGIN`` × its
    width on each side as the held-out warning counts it, it lies; ``w_j`` that range's width."""
    columns = {name: k for k, name in enumerate(robot.actuated_joints)}
    factor = np.ones(actuated.shape[0])
    for joint, (low, high) in ranges.items():
        if joint not in columns:
            continue
        values = actuated[:, columns[joint]]
        low, high = low - RANGE_MARGIN * (high - low), high + RANGE_MARGIN * (high - low)
        beyond = np.maximum(low - values, 0.0) + np.maximum(values - high, 0.0)
        factor += beyond / max((high - low) / (1 + 2 * RANGE_MARGIN), MIN_WIDTH)
    return factor


def predicted_errors(problem: CalibrationProblem, fit: CalibrationResult | FitCovariance, x: Array,
                     factor: Array | None = None, prediction: Prediction | None = None) -> PredictedErrors:
    """The predicted length-type errors of ``problem``'s samples for the model at ``x`` [m, rad] (in ``problem``'s
    parameter order, the one ``fit`` was fitted in), with the covariance the fit gives (its result, or
    :class:`FitCovariance`), each bound multiplied by ``factor`` (N,) (default 1: :func:`widening` gives it outside
    the fitted range); ``prediction``: ``problem``'s evaluation at ``x`` with its Jacobian, if made already."""
    fit = fit if isinstance(fit, FitCovariance) else FitCovariance.of_result(fit)
    n = problem.observations.n_samples
    factor = np.ones(n) if factor is None else factor
    prediction = problem.evaluate(x, jacobian=True) if prediction is None else prediction
    assert prediction.jacobian is not None
    width = int(sum(length_columns(m.key) for m in problem.measurements))
    sigma, bound = np.full((n, width), np.nan), np.full(n, np.nan)
    if not np.all(np.isfinite(fit.matrix)) or not np.isfinite(fit.sigma2):
        return PredictedErrors(sigma, bound, factor)
    layout = _length_layout(problem)
    row_sigma = np.where(layout.taken, _row_sigmas(problem)[layout.rows], 0.0)  # (N, w) [m]; 0 where none
    jacobian = prediction.jacobian[:, fit.columns][layout.rows] * row_sigma[..., None]  # [m] per parameter unit
    s = jacobian @ fit.matrix @ jacobian.transpose(0, 2, 1)  # (N, w, w) [m²]
    diagonal = np.arange(s.shape[1])
    s[:, diagonal, diagonal] += fit.sigma2 * row_sigma**2
    sigma[layout.samples, layout.columns] = np.sqrt(s[:, diagonal, diagonal][layout.taken])
    measured = layout.taken.any(axis=1)
    bound[measured] = norm_quantiles(s[measured]) * factor[measured]
    return PredictedErrors(sigma, bound, factor)


def norm_quantile(s: Array, level: float = LEVEL) -> float:
    """The ``level`` quantile [m] of ``‖e‖`` for ``e ~ N(0, s)`` (``s`` [m²]), by Welch–Satterthwaite's
    ``eᵀe ≈ a χ²_ν`` (exact when ``s`` is isotropic)."""
    return float(norm_quantiles(np.asarray(s, dtype=float)[None], level)[0])


def norm_quantiles(s: Array, level: float = LEVEL) -> Array:
    """:func:`norm_quantile` of each of the covariances ``s`` (K, w, w) [m²]: (K,) quantiles [m]."""
    trace = np.trace(s, axis1=1, axis2=2)
    trace2 = np.sum(s * s, axis=(1, 2))
    out = np.zeros(len(s))
    positive = trace > 0.0
    a, nu = trace2[positive] / trace[positive], trace[positive] ** 2 / trace2[positive]
    out[positive] = np.sqrt(a * chi2_upper(1.0 - level, nu))
    return out


def _row_sigmas(problem: CalibrationProblem) -> Array:
    """Each residual row's stated σ [m, rad], in :meth:`evaluate`'s order."""
    return np.concatenate([np.tile(m.row_sigmas(), int(np.count_nonzero(problem.seen(m.key))))
                           for m in problem.measurements])


@dataclass(frozen=True)
class _LengthLayout:
    """Each sample's length rows in :meth:`evaluate`'s order (measurements in order, then their components), padded
    to the most a sample has (w).

    Attributes:
        rows: (N, w) their residual rows (0 where ``taken`` is False).
        taken: (N, w) which entries are rows.
        samples, columns: The taken entries' sample and :attr:`PredictedErrors.sigma` column, in row-major order.
    """

    rows: npt.NDArray[np.intp]
    taken: npt.NDArray[np.bool_]
    samples: npt.NDArray[np.intp]
    columns: npt.NDArray[np.intp]


def _length_layout(problem: CalibrationProblem) -> _LengthLayout:
    """The :class:`_LengthLayout` of ``problem``'s residual rows."""
    rows, samples, columns = [], [], []
    start_row = start_column = 0
    for m in problem.measurements:
        taken = np.flatnonzero(problem.seen(m.key))
        width = length_columns(m.key)
        rows.append((start_row + m.size * np.arange(taken.size)[:, None] + np.arange(width)).ravel())
        samples.append(np.repeat(taken, width))
        columns.append(np.tile(start_column + np.arange(width), taken.size))
        start_row += m.size * taken.size
        start_column += width
    order = np.argsort(np.concatenate(samples), kind="stable")  # by sample, each in row order
    row, sample, column = (np.concatenate(a).astype(np.intp)[order] for a in (rows, samples, columns))
    counts = np.bincount(sample, minlength=problem.observations.n_samples)
    position = np.arange(row.size) - np.repeat(np.cumsum(counts) - counts, counts)
    index = np.zeros((counts.size, int(counts.max(initial=0))), dtype=np.intp)
    taken_at = np.zeros(index.shape, dtype=bool)
    index[sample, position], taken_at[sample, position] = row, True
    return _LengthLayout(index, taken_at, sample, column)


def workspace_postures(problem: CalibrationProblem, actuated: Array) -> CalibrationProblem:
    """``problem``'s robot, parameters and measurements at the postures ``actuated`` (N, na) [rad or m], with
    neutral readings: its predictions are absolute positions, its Jacobian that of the predictions."""
    observations = Observations.neutral(problem.measurements, actuated)
    return CalibrationProblem(problem.robot, problem.parameters, problem.measurements, observations,
                              payload=problem.payload)


def coverage(predicted: PredictedErrors, errors: Array) -> dict[str, Any]:
    """How many of the samples' error norms ``errors`` (N,) [m] lie within their predicted 95 % bound."""
    known = np.isfinite(errors) & np.isfinite(predicted.bound)
    inside = int(np.count_nonzero(predicted.inside(errors)))
    total = int(np.count_nonzero(known))
    return {"inside": inside, "samples": total, "fraction": inside / total if total else None}


def workspace_prediction(problem: CalibrationProblem, result: CalibrationResult, x: Array,
                         ranges: dict[str, list[float]], n: int = WORKSPACE_POSTURES,
                         seed: int = 0) -> dict[str, Any] | None:
    """The predicted error over the workspace: ``n`` postures drawn within the joint limits (as ``pincal simulate``
    draws them, seeded; those the calibrated robot cannot close left out), each with the predicted position of the
    first measured point [m] and its 95 % bound [m] (widened beyond the fitted ``ranges``), and the bounds' median and
    maximum [m]; None when the model measures no length or no posture can be drawn."""
    if not any(length_columns(m.key) == 3 for m in problem.measurements):
        return None
    try:
        actuated, q = random_actuated(problem.robot, n, np.random.default_rng(seed))
        # a posture the nominal robot closes the calibrated one may not; the nominal configurations start its solves
        solved = assemble(problem.robot_at(x), actuated, np.inf, guesses=q)
        closed, q = solved.usable, solved.q
        actuated = actuated[closed]
        postures = workspace_postures(problem, actuated)
        remember(postures, q[closed])
        factor = widening(problem.robot, actuated, ranges)
        prediction = postures.evaluate(x, jacobian=True)
        predicted = predicted_errors(postures, result, x, factor, prediction)
        key = next(m.key for m in problem.measurements if length_columns(m.key) == 3)
        positions = prediction.predicted[key][:, :3]
    except ConvergenceError:
        return None
    bounds = predicted.bound
    finite = bounds[np.isfinite(bounds)]
    return {"postures": len(actuated), "measurement": key, "positions": positions.tolist(), "bounds": bounds.tolist(),
            "widening": factor.tolist(), "outside_fitted_range": int(np.count_nonzero(factor > 1.0)),
            "median_bound": float(np.median(finite)) if finite.size else None,
            "max_bound": float(np.max(finite)) if finite.size else None}


def held_out_predictions(ids: list[str], predicted: PredictedErrors, errors: Array) -> dict[str, Any]:
    """The report's account of the held-out predictions: per sample (``ids``) its predicted σ per length row and its
    95 % bound [m] and widening, and the coverage of the error norms ``errors`` (N,) [m]."""
    finite = predicted.bound[np.isfinite(predicted.bound)]
    widened = [ids[k] for k in np.flatnonzero(predicted.widening > 1.0)]
    return {"level": LEVEL, **coverage(predicted, errors),
            "median_bound": float(np.median(finite)) if finite.size else None,
            "widened": widened,
            "samples_predicted": [{"sample": s, "sigma": [None if not np.isfinite(v) else float(v) for v in sig],
                                   "bound": float(b) if np.isfinite(b) else None, "widening": float(w)}
                                  for s, sig, b, w in zip(ids, predicted.sigma, predicted.bound, predicted.widening,
                                                          strict=True)]}
