"""The estimates' covariance propagated to each sample's length error, and its 95 % bound.

A sample's length-type error (its position, pose-position and distance rows together, as
:func:`~pincal.identification.metrics.sample_length_errors` measures it) is predicted to have the covariance

    S = J C Jᵀ + σ̂² diag(σ_row²)                                                         [m²]

with ``J`` the rows' derivatives w.r.t. the identified parameters at the estimate (unweighted: the problem's rows are
divided by their σ, so they are multiplied back), ``C`` a covariance of the estimates (the fit's, or a refit's) and
the noise the measurement's stated σ per row scaled by the fit's variance factor ``σ̂²``. The 95 % bound of the
error's norm ``‖e‖`` is the quantile of ``eᵀe``, a weighted sum of χ² variables, by the Welch–Satterthwaite
approximation ``eᵀe ≈ a χ²_ν`` with ``a = tr(S²)/tr(S)``, ``ν = tr(S)²/tr(S²)`` (exact for an isotropic S).
:mod:`pincal.calibration.predicted` and :mod:`pincal.calibration.growth` both read it here. Lengths in m.
"""

from __future__ import annotations

import numpy as np
import numpy.typing as npt

from pincal.identification.chi2 import chi2_upper
from pincal.identification.metrics import length_columns
from pincal.identification.problem import CalibrationProblem
from pincal.records import record

Array = npt.NDArray[np.float64]

#: The probability of the predicted bound.
LEVEL = 0.95


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


def row_sigmas(problem: CalibrationProblem) -> Array:
    """Each residual row's stated σ [m, rad], in :meth:`evaluate`'s order."""
    return np.concatenate([np.tile(m.row_sigmas(), int(np.count_nonzero(problem.seen(m.key))))
                           for m in problem.measurements])


@record(frozen=True)
class LengthLayout:
    """Each sample's length rows in :meth:`evaluate`'s order (measurements in order, then their components), padded
    to the most a sample has (w).

    Attributes:
        rows: (N, w) their residual rows (0 where ``taken`` is False).
        taken: (N, w) which entries are rows.
        samples, columns: The taken entries' sample and column (of all the measurements' length columns side by side),
            in row-major order.
        width: The measurements' length columns side by side.
    """

    rows: npt.NDArray[np.intp]
    taken: npt.NDArray[np.bool_]
    samples: npt.NDArray[np.intp]
    columns: npt.NDArray[np.intp]
    width: int


def length_layout(problem: CalibrationProblem) -> LengthLayout:
    """The :class:`LengthLayout` of ``problem``'s residual rows."""
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
    return LengthLayout(index, taken_at, sample, column, start_column)


def length_covariances(problem: CalibrationProblem, jacobian: Array, covariance: Array, sigma2: float,
                       samples: npt.NDArray[np.intp] | None = None,
                       layout: LengthLayout | None = None) -> tuple[Array, npt.NDArray[np.bool_]]:
    """``S`` (K, w, w) [m²] of the length error of each of ``samples`` (default: all N) of ``problem``, and which of
    its w entries are rows (K, w): ``jacobian`` (rows, q) the problem's weighted Jacobian over the q parameters of
    ``covariance`` (q, q) [their units squared], ``sigma2`` the noise's variance factor."""
    layout = length_layout(problem) if layout is None else layout
    chosen = np.arange(layout.rows.shape[0]) if samples is None else samples
    taken = layout.taken[chosen]
    row_sigma = np.where(taken, row_sigmas(problem)[layout.rows[chosen]], 0.0)  # (K, w) [m]; 0 where none
    rows = jacobian[layout.rows[chosen]] * row_sigma[..., None]  # (K, w, q) [m] per parameter unit
    s = rows @ covariance @ rows.transpose(0, 2, 1)
    diagonal = np.arange(s.shape[1])
    s[:, diagonal, diagonal] += sigma2 * row_sigma**2
    return s, taken


def sample_bounds(problem: CalibrationProblem, jacobian: Array, covariance: Array, sigma2: float,
                  samples: npt.NDArray[np.intp] | None = None, layout: LengthLayout | None = None) -> Array:
    """The 95 % bound [m] of the length error of each of ``samples`` (default: all) with no growth (NaN for a sample
    with no length row): :func:`norm_quantiles` of :func:`length_covariances`."""
    s, taken = length_covariances(problem, jacobian, covariance, sigma2, samples, layout)
    measured = taken.any(axis=1)
    out = np.full(len(s), np.nan)
    out[measured] = norm_quantiles(s[measured])
    return out
