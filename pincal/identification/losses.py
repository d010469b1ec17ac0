"""Robust losses: how much each sample counts in a fit, by name, and the outlier test of ``auto``.

A loss re-weights whole samples (IRLS): after each accepted step, each sample's weight follows from its weighted
residual norm ``e`` through the loss's weighting (:data:`IMPLEMENTED_LOSSES`, a name → function table as SciPy's
``least_squares`` keeps), with a scale estimated from the median sample, so no threshold is set by hand in data units.
``auto``, :func:`~pincal.identification.solver.identify`'s default, is a plan on top of these: least squares, then
Cauchy refits if :func:`outlier_samples` finds a sample implausible, and a last refit without the samples whose joint
reading is wrong (:mod:`pincal.identification.readings`: weight 0, whatever the loss).
"""

from __future__ import annotations

import math
from collections.abc import Callable, Sequence

import numpy as np
import numpy.typing as npt

from pincal import linalg
from pincal.identification.chi2 import chi2_upper
from pincal.identification.problem import Prediction, Problem

Array = npt.NDArray[np.float64]
IntArray = npt.NDArray[np.int64]
BoolArray = npt.NDArray[np.bool_]

#: A loss's weighting: per-sample weights from the samples' weighted residual norms (comparable across samples, see
#: :func:`sample_weights`) and which samples have rows at all.
Weighting = Callable[[Array, BoolArray], Array]

#: Outlier test of ``loss="auto"``: the probability that clean data (Gaussian noise) raise a false
#: alarm anywhere in the dataset (Bonferroni: each sample is tested at this level over N).
OUTLIER_FALSE_ALARM = 1e-3
CAUCHY_C = 2.3849  # 95 % efficiency under Gaussian noise
#: Internal loss of ``auto``'s robust start: least trimmed squares over the best-fitting :data:`TRIM_KEEP` of the
#: samples, chosen afresh at each step (concentration steps, Rousseeuw & Van Driessen 2006).
TRIMMED = "trimmed"
TRIM_KEEP = 0.5


def cauchy(norms: Array, used: BoolArray) -> Array:
    """Cauchy weights ``w = 1 / (1 + (e / (c·s))²)``, ``s`` the median norm over the samples with rows / 0.6745
    (a robust standard deviation) and ``c`` = :data:`CAUCHY_C`."""
    scale = float(linalg.median(norms[used] if used.any() else norms)) / 0.6745
    scale = max(scale, 1e-300)
    return np.asarray(1.0 / (1.0 + (norms / (CAUCHY_C * scale)) ** 2), dtype=np.float64)


def trimmed(norms: Array, used: BoolArray) -> Array:
    """Least trimmed squares: 1 for the :data:`TRIM_KEEP` share of the samples with rows that fit best, 0 for the
    others; a sample with no row keeps 1."""
    ranked = [k for k in np.argsort(norms, kind="stable") if used[k]]
    weights = np.where(used, 0.0, 1.0)
    weights[ranked[:math.ceil(TRIM_KEEP * int(used.sum()))]] = 1.0
    return weights


#: The losses a fit runs with, by name: each one's weighting (None: least squares, every sample weighs 1 and is never
#: re-weighted). :data:`TRIMMED` is ``auto``'s internal robust start, not a choice of its own.
IMPLEMENTED_LOSSES: dict[str, Weighting | None] = {"linear": None, "cauchy": cauchy, TRIMMED: trimmed}


def sample_squares(problem: Problem, residual: Array) -> tuple[Array, IntArray]:
    """Each sample's squared weighted residual norm and its number of rows (0: the sample has no rows)."""
    samples = problem.row_samples()
    n = problem.observations.n_samples
    squares = np.asarray(np.bincount(samples, weights=residual**2, minlength=n), dtype=np.float64)
    return squares, np.bincount(samples, minlength=n).astype(np.int64)


def sample_weights(problem: Problem, pred: Prediction, weighting: Weighting | None,
                   left_out: Sequence[int] = ()) -> Array:
    """Per-sample robust weights (IRLS) of ``weighting`` (one of :data:`IMPLEMENTED_LOSSES`) at ``pred``; 0 for the
    samples ``left_out`` (indices: bad joint readings, :mod:`pincal.identification.readings`).

    A sample with fewer rows than most (some markers not seen) has its norm scaled to the most common row count,
    ``e · sqrt(d_typical / d_k)``, so that it is judged per reading; a sample with no row keeps weight 1 and
    counts in neither the scale nor the trimmed share."""
    n = problem.observations.n_samples
    if weighting is None:
        weights = np.ones(n)
    else:
        squares, dims = sample_squares(problem, pred.residual)
        used = dims > 0
        typical = float(linalg.median(dims[used])) if used.any() else 1.0
        norms = np.sqrt(squares * typical / np.maximum(dims, 1))
        weights = weighting(norms, used)
    weights[list(left_out)] = 0.0
    return weights


def row_weights(problem: Problem, weights: Array) -> Array:
    """Per-sample weights expanded to the residual rows."""
    return np.asarray(weights[problem.row_samples()], dtype=np.float64)


def noise_scale(problem: Problem, residual: Array, n_fitted: int = 0) -> float:
    """The noise scale the data show [σ² units of the weighted residual]: ``s² = median(e_k² / m_k)`` over the
    samples with rows (``e_k`` a sample's weighted residual norm over ``d_k`` rows, ``m_k`` the median of χ²_{d_k}),
    corrected by ``rows / (rows − n_fitted)`` for the degrees of freedom the fit used; 0 with fewer than three
    samples."""
    sq, dims = sample_squares(problem, residual)
    used = dims > 0
    if used.sum() < 3:
        return 0.0
    scale2 = float(linalg.median(sq[used] / chi2_upper(0.5, dims[used])))
    rows = int(dims.sum())
    if rows > n_fitted:  # fitted residuals are smaller than the noise by the fitted degrees of freedom
        scale2 *= rows / (rows - n_fitted)
    return scale2


def outlier_samples(problem: Problem, pred: Prediction, n_fitted: int = 0) -> list[int]:
    """Samples whose residual is implausible given the noise level the data themselves show.

    With ``e_k`` a sample's weighted residual norm over ``d_k`` rows and ``s²`` the noise scale
    (:func:`noise_scale`), a sample is flagged when ``e_k² > s² · χ²_{d_k}(1 − α/N)``, α = ``OUTLIER_FALSE_ALARM``:
    clean data raise a false alarm in about one dataset in a thousand. Nothing here is set by hand in data units.
    """
    scale2 = noise_scale(problem, pred.residual, n_fitted)
    if scale2 <= 0.0:
        return []
    sq, dims = sample_squares(problem, pred.residual)
    used = dims > 0
    limit = scale2 * chi2_upper(OUTLIER_FALSE_ALARM / int(used.sum()), np.maximum(dims, 1))
    return [int(k) for k in np.flatnonzero(used & (sq > limit))]
