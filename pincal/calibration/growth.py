"""How far a calibration's predictions may be off, inside the postures it was fitted on and beyond them, estimated from
the data.

The estimates' covariance (:mod:`pincal.calibration.propagation`) says how far a prediction may be off when the model
is right. A real robot carries what the model lacks (joint deflections, encoder non-linearity, a link's growth), which
the fit absorbs inside its range and which no longer cancels beyond it. How much, is measured on the data themselves,
by refitting without some samples and predicting them (each refit linearised at the estimate, with the fit's prior,
robust weights and parameters: one solve):

- *inside*: :data:`FOLDS` folds of one seeded shuffle, every sample held out once. Each held-out sample i has its
  error ``e_i`` [m] (its length rows, as the held-out figures count them) and its 95 % bound ``B_i`` from the refit's
  covariance and the noise. ``ρ₀`` is the conformal 95 % quantile of ``t_i = (e_i / B_i)²`` (the
  ``⌈0.95 (n + 1)⌉``-th smallest of n, the largest when that exceeds n: a new posture like them then lies within its
  bound with probability 0.95 whatever the errors' distribution; split-conformal prediction, Vovk, Gammerman and
  Shafer 2005, "Algorithmic learning in a random world"; from cross-validation, Barber, Candès, Ramdas and Tibshirani
  2021, "Predictive inference with the jackknife+"), and never below 1: the data may widen the covariance's bound,
  not narrow it. With :func:`~pincal.identification.selection.fold_prior` (the evidence's prior), each fold's refit
  is held by the prior the evidence chooses on its own training samples, so that ``ρ₀`` sees how the choice varies.
- *beyond*: for each actuated joint that moves what is measured, the samples whose reading lies in the lower half of
  the fitted readings are refitted from the upper half and predicted, then the other way round; each held-out sample
  lies at the extrapolation distance ``u_i = Σ_j d_j / w_j`` beyond its refit's range (:func:`extrapolation_distance`).
  These refits see half the samples: their covariance grows as fast as their error, so they show how the *nominal*
  robot's error grows, not the calibration's. The nominal robot (robot at nominal, setup refitted the same way) has
  the conformal 95 % bound ``E₀`` [m] of its inside errors and grows by the smallest ``E₁ ≥ 0`` [m per range width]
  that holds the same share of its errors beyond within ``E₀ + E₁ u``.

A posture at distance ``u`` then has the bound ``√ρ₀ B + E₁ u``: what the calibration lacks grows beyond the range as
the robot's deviation from its model does; and never more than ``E₀ + E₁ u`` plus the noise's bound, the nominal
robot's own (:mod:`pincal.calibration.predicted`). The hold-outs show the growth up to the largest ``u`` they reach
(:attr:`ErrorGrowth.reach`); past that it is extrapolated. docs/predicted_accuracy.md explains the choice and
``docs/results/extrapolation.md`` measures it. Every length in m.
"""

from __future__ import annotations

import math
from collections.abc import Callable, Sequence
from dataclasses import asdict
from typing import Any

import numpy as np
import numpy.typing as npt

from pincal import linalg
from pincal.calibration.propagation import LengthLayout, length_layout, row_sigmas, sample_bounds
from pincal.calibration.samples import RANGE_MARGIN
from pincal.identification.holdouts import FOLDS, SEED, Linearised, range_halves, shuffled_folds
from pincal.identification.parameters import joint_unit
from pincal.identification.problem import CalibrationProblem
from pincal.identification.result import CalibrationResult
from pincal.records import record

Array = npt.NDArray[np.float64]
IntArray = npt.NDArray[np.intp]

#: The probability the bounds hold.
LEVEL = 0.95
#: Smallest range width [rad or m] a distance beyond it is counted in (a joint the fit saw still gets a finite one).
MIN_WIDTH = 0.05
#: Fewest samples the bounds are estimated from (fewer: none is, and the bound is the covariance's alone).
MIN_SAMPLES = 8


@record(frozen=True)
class ErrorGrowth:
    """What the hold-outs show: the factor on the covariance's bound inside the fitted range, and the nominal robot's
    own 95 % error bound ``E₀ + E₁ u`` [m], by which the bound grows beyond it.

    Attributes:
        rho0: The factor on the covariance's variance inside the fitted range (dimensionless, ≥ 1).
        nominal0: The nominal robot's 95 % error bound inside the fitted range, ``E₀`` [m] (NaN: not known).
        nominal1: Its growth per range width beyond it, ``E₁`` [m] (≥ 0).
        reach: The largest extrapolation distance held out (past it, the growth is extrapolated).
        inside: Samples held out inside (the shuffled folds).
        beyond: Samples held out beyond their refit's range (the range halves).
    """

    rho0: float
    nominal0: float
    nominal1: float
    reach: float
    inside: int
    beyond: int

    def bounds(self, covariance_bound: Array, distance: Array) -> Array:
        """The 95 % bounds [m] ``√ρ₀ B + E₁ u`` of postures whose covariance gives ``covariance_bound`` (N,) [m], at
        extrapolation distances ``distance`` (N,)."""
        u = np.maximum(np.asarray(distance, dtype=float), 0.0)
        grown: Array = math.sqrt(self.rho0) * np.asarray(covariance_bound, dtype=float) + self.nominal1 * u
        return grown

    def nominal(self, distance: Array) -> Array:
        """The nominal robot's own 95 % error bound ``E₀ + E₁ u`` [m] at extrapolation distances ``distance`` (N,)
        (NaN: not known)."""
        grown: Array = self.nominal0 + self.nominal1 * np.maximum(np.asarray(distance, dtype=float), 0.0)
        return grown

    def as_dict(self) -> dict[str, Any]:
        """As the report JSON and the calibrated URDF hold it (NaN as None)."""
        return {k: (None if isinstance(v, float) and not math.isfinite(v) else v) for k, v in asdict(self).items()}

    @classmethod
    def from_dict(cls, held: dict[str, Any] | None) -> ErrorGrowth | None:
        """From :meth:`as_dict`'s mapping; None when there is none or it is incomplete."""
        if not held:
            return None
        try:
            nominal0 = held.get("nominal0")
            return cls(float(held["rho0"]), math.nan if nominal0 is None else float(nominal0),
                       float(held["nominal1"]), float(held["reach"]), int(held["inside"]), int(held["beyond"]))
        except (KeyError, TypeError, ValueError):
            return None


def extrapolation_distance(actuated: Array, columns: Sequence[int], ranges: Sequence[tuple[float, float]],
                           angular: Sequence[bool] | None = None) -> Array:
    """Each posture's distance beyond a fitted range, ``u = Σ_j d_j / max(w_j, MIN_WIDTH)`` (dimensionless): ``d_j``
    [rad or m] how far the reading of actuated column ``columns[j]`` of ``actuated`` (N, na) lies beyond
    ``ranges[j]`` = (min, max) and its margin of ``RANGE_MARGIN`` of the width on each side (as the warnings on
    postures outside the fitted range count it), ``w_j`` that range's width. 0 inside every range and its margin.
    ``angular[j]``: column j reads a revolute joint [rad], which moves the robot alike at q and q ± 2π: its readings
    are compared on the circle, as the warnings compare them (the nearer end; a range that spans the circle, margins
    included, leaves none beyond). Default: none is."""
    distance = np.zeros(actuated.shape[0])
    circular = [False] * len(columns) if angular is None else list(angular)
    for column, (low, high), around in zip(columns, ranges, circular, strict=True):
        values = actuated[:, column]
        margin = RANGE_MARGIN * (high - low)
        span = high - low + 2.0 * margin
        if not around:
            beyond = np.maximum(low - margin - values, 0.0) + np.maximum(values - high - margin, 0.0)
        elif span >= 2.0 * math.pi:
            beyond = np.zeros(values.size)
        else:
            past = np.remainder(values - (low - margin), 2.0 * math.pi)  # round from the margin's start, in [0, 2π)
            beyond = np.where(past > span, np.minimum(past - span, 2.0 * math.pi - past), 0.0)
        distance += beyond / max(high - low, MIN_WIDTH)
    return distance


def conformal_quantile(values: Array, level: float = LEVEL) -> float:
    """The ``⌈level (n + 1)⌉``-th smallest of the n ``values`` (the largest when that exceeds n); NaN when empty."""
    if not values.size:
        return math.nan
    k = min(math.ceil(level * (values.size + 1)), values.size)
    return float(np.sort(values)[k - 1])


def growth_slope(values: Array, distance: Array, start: float, level: float = LEVEL) -> float:
    """The smallest ``s ≥ 0`` with the conformal share ``level`` of ``values`` (N,) within ``start + s u`` at their
    ``distance`` (N,, all > 0); 0 without values."""
    if not values.size:
        return 0.0
    return max(conformal_quantile(np.maximum(values - start, 0.0) / distance, level), 0.0)


def estimate_growth(problem: CalibrationProblem, result: CalibrationResult, prior: Array, columns: Sequence[int],
                    x_before: Array, fold_prior: Callable[[IntArray], Array] | None = None) -> ErrorGrowth | None:
    """The :class:`ErrorGrowth` of the fit ``result`` of ``problem`` with the prior σ ``prior`` (p,) [parameter units;
    inf: none] and of the registered nominal robot ``x_before`` (in ``problem``'s order), over the actuated ``columns``
    that move what is measured. ``fold_prior``: the prior σ the fit's selection chooses on the samples it is given
    (:func:`~pincal.identification.selection.fold_prior`); each shuffled hold-out is then refitted with the prior
    chosen on its own training samples, and ``ρ₀`` sees how the choice varies with the samples (default: every
    hold-out with ``prior``). None with fewer than :data:`MIN_SAMPLES` samples, without the fit's evaluation or
    without a length reading."""
    final = result.final
    n = problem.observations.n_samples
    layout = length_layout(problem)
    if final is None or final.jacobian is None or n < MIN_SAMPLES or not layout.width \
            or final.residual.size != problem.row_samples().size:  # an implicit (ikm) fit's rows are its loops'
        return None
    shuffled = shuffled_folds(n, FOLDS, SEED)
    halves = range_halves(problem.observations.actuated, columns)
    calibrated = Linearised.of_fit(problem, result, final.residual, final.jacobian, prior)
    ratios: list[Array] = []
    for held in shuffled:
        linear = calibrated if fold_prior is None else Linearised.of_fit(
            problem, result, final.residual, final.jacobian, fold_prior(linalg.complement(n, held)))
        residual, inverse, out = linear.refit(held)
        scales = problem.parameters.scales
        covariance = result.sigma2 * inverse * np.outer(scales, scales)  # [parameter units²]: x = scale · z
        bound = sample_bounds(problem, final.jacobian, covariance, result.sigma2, held, layout)
        length = _sample_lengths(problem, layout, held, out, residual)
        known = np.isfinite(length) & np.isfinite(bound) & (bound > 0.0)
        ratios.append((length[known] / bound[known]) ** 2)
    rho0 = conformal_quantile(np.concatenate(ratios))
    if not math.isfinite(rho0):
        return None
    nominal0, nominal1, reach, beyond = _nominal_bound(problem, result, x_before, columns, shuffled, halves, layout)
    return ErrorGrowth(max(rho0, 1.0), nominal0, nominal1, reach, int(sum(r.size for r in ratios)), beyond)


def _nominal_bound(problem: CalibrationProblem, result: CalibrationResult, x_before: Array, columns: Sequence[int],
                   shuffled: Sequence[npt.NDArray[np.intp]], halves: Sequence[npt.NDArray[np.intp]],
                   layout: LengthLayout) -> tuple[float, float, float, int]:
    """The nominal robot's ``E₀``, ``E₁`` [m], the hold-outs' reach and how many samples they held out beyond: each
    hold-out refitted with the robot at nominal (its setup alone, from the registered ``x_before``)."""
    from pincal.calibration.setup_parameters import setup_columns  # the setup as "before" registers it

    at = problem.evaluate(x_before, jacobian=True)
    assert at.jacobian is not None
    setup = setup_columns(problem.parameters)
    nominal = Linearised.of_fit(problem, result, at.residual, at.jacobian[:, setup], np.full(len(setup), math.inf),
                                setup, x_before[setup])
    actuated = problem.observations.actuated
    angular = [joint_unit(problem.robot, problem.robot.actuated_joints[c]) == "rad" for c in columns]
    inside: list[Array] = []
    for held in shuffled:
        residual, _, out = nominal.refit(held)
        length = _sample_lengths(problem, layout, held, out, residual)
        inside.append(length[np.isfinite(length)])
    errors: list[Array] = []
    distances: list[Array] = []
    for held in halves:
        residual, _, out = nominal.refit(held)
        length = _sample_lengths(problem, layout, held, out, residual)
        train = linalg.complement(actuated.shape[0], held)
        ranges = [(float(np.min(actuated[train, c])), float(np.max(actuated[train, c]))) for c in columns]
        distance = extrapolation_distance(actuated[held], columns, ranges, angular)
        keep = np.isfinite(length) & (distance > 0.0)
        errors.append(length[keep])
        distances.append(distance[keep])
    nominal0 = conformal_quantile(np.concatenate(inside)) if inside else math.nan
    beyond, at_distance = (np.concatenate(errors), np.concatenate(distances)) if errors else (np.zeros(0), np.zeros(0))
    nominal1 = growth_slope(beyond, at_distance, nominal0) if math.isfinite(nominal0) else 0.0
    return nominal0, nominal1, float(np.max(at_distance, initial=0.0)), int(beyond.size)


def _sample_lengths(problem: CalibrationProblem, layout: LengthLayout, held: npt.NDArray[np.intp],
                    out: npt.NDArray[np.bool_], errors: Array) -> Array:
    """Each held-out sample's length error [m]: the norm of its length rows of ``errors`` (the weighted residual of the
    held-out rows ``out``, in :meth:`evaluate`'s order) times their σ; NaN for a sample with no length row."""
    full = np.zeros(problem.row_samples().size)
    full[out] = errors
    sigma = row_sigmas(problem)
    values = np.where(layout.taken, (full * sigma)[layout.rows], 0.0)[held]
    return np.where(layout.taken[held].any(axis=1), np.sqrt(np.sum(values**2, axis=1)), np.nan)
