"""Hold-outs of a fit, refitted without the samples they hold out, linearised at the fit's estimate.

Each refit is one Gauss–Newton solve from the estimate without the held-out rows, with the fit's robust weights and
its prior (one σ per parameter; inf: none): no iteration, no new evaluation of the model, so that a hundred hold-outs
cost less than one fit. Two kinds of hold-out:

- :func:`shuffled_folds`: K folds of one seeded shuffle, every sample held out once (how the fit predicts postures
  like its own);
- :func:`range_halves`: for each of the given actuated joints (those that move what is measured), the samples in the
  lower half of its readings predicted from the upper half, then the other way round (how the fit predicts beyond the
  range it saw).

The predicted bound (:mod:`pincal.calibration.growth`) is estimated from them. Rows are the problem's weighted residual
rows [σ units].
"""

from __future__ import annotations

import functools
from collections.abc import Sequence

import numpy as np
import numpy.typing as npt

from pincal.identification.problem import Problem
from pincal.identification.result import CalibrationResult
from pincal.records import record

Array = npt.NDArray[np.float64]
IntArray = npt.NDArray[np.intp]

#: Folds of the shuffled hold-out, and its seed.
FOLDS = 5
SEED = 0
#: Relative eigenvalue below which a refit's direction is not estimated (no prior and no data: pseudo-inverse).
RCOND = 1e-10


def shuffled_folds(n: int, folds: int = FOLDS, seed: int = SEED) -> list[IntArray]:
    """``folds`` folds of one shuffle of ``n`` samples (seeded ``seed``), each as sorted sample indices."""
    order = np.random.default_rng(seed).permutation(n)
    return [np.sort(order[f::folds]).astype(np.intp) for f in range(min(folds, n))]


def range_halves(actuated: Array, columns: Sequence[int]) -> list[IntArray]:
    """For each actuated column of ``actuated`` (N, na) [rad or m] in ``columns``: the samples in the lower half of its
    readings, then those in the upper half (ties broken by sample order), each as sorted sample indices."""
    n = actuated.shape[0]
    out: list[IntArray] = []
    for column in columns:
        ranked = np.argsort(actuated[:, column], kind="stable")
        out += [np.sort(ranked[:n // 2]).astype(np.intp), np.sort(ranked[n // 2:]).astype(np.intp)]
    return out


@record(frozen=True)
class Linearised:
    """A fit linearised at a point, in scaled parameters (``x / scale``).

    Attributes:
        jacobian: (rows, q) the weighted Jacobian of the parameters kept, scaled.
        residual: (rows,) the weighted residual at the point [σ units].
        weights: (rows,) each row's robust weight.
        precision: (q,) the prior's precision, scaled (0: none).
        x: (q,) the point, scaled.
        rows: (rows,) each row's sample.
    """

    jacobian: Array
    residual: Array
    weights: Array
    precision: Array
    x: Array
    rows: IntArray

    @classmethod
    def of_fit(cls, problem: Problem, result: CalibrationResult, residual: Array, jacobian: Array, prior: Array,
               columns: Sequence[int] | None = None, x: Array | None = None) -> Linearised:
        """``problem``'s fit linearised at a point: its weighted ``residual`` and ``jacobian`` there (over the
        parameters ``columns``, default all), ``result``'s robust weights, the prior σ ``prior`` over those parameters
        [their units; inf: none], the point ``x`` over them (default: ``result``'s estimate)."""
        chosen = list(range(len(problem.parameters))) if columns is None else list(columns)
        scales = problem.parameters.scales[chosen]
        rows = problem.row_samples().astype(np.intp)
        precision = np.where(np.isfinite(prior), (scales / np.where(np.isfinite(prior), prior, 1.0)) ** 2, 0.0)
        point = (result.x[chosen] if x is None else x) / scales
        return cls(jacobian * scales, residual, result.sample_weights[rows], precision, point, rows)

    @functools.cached_property
    def weighted(self) -> Array:
        """(rows, q) ``W J``: the Jacobian's rows times their robust weights, the same for every hold-out."""
        return np.asarray(self.jacobian * self.weights[:, None], dtype=float)

    def held_rows(self, held: IntArray) -> npt.NDArray[np.bool_]:
        """(rows,) which rows belong to the samples ``held`` (``np.isin(rows, held)``, by a look-up table)."""
        if not self.rows.size or not np.size(held):
            return np.zeros(self.rows.size, dtype=bool)
        member = np.zeros(max(int(self.rows.max()), int(np.max(held))) + 1, dtype=bool)
        member[held] = True
        return np.asarray(member[self.rows], dtype=bool)

    def refit(self, held: IntArray, precision: Array | None = None) -> tuple[Array, Array, npt.NDArray[np.bool_]]:
        """The held-out samples' rows after one Gauss–Newton solve without them, toward the prior (its precision
        ``precision``, scaled; default :attr:`precision`): their weighted residual, the refit's scaled covariance factor
        ``(JᵀWJ + P)⁺``, and which rows are held out."""
        out, normal, gradient = self._terms(held)
        prior = self.precision if precision is None else precision
        inverse = pseudo_inverse(normal + np.diag(prior))
        step = -inverse @ (gradient + prior * self.x)
        return self.residual[out] + self.jacobian[out] @ step, inverse, out

    def held_samples(self, held: IntArray) -> tuple[IntArray, IntArray]:
        """The samples ``held`` whose rows are held out, sorted, and each held-out row's position among them
        (``np.unique``'s values and inverse), computed once per hold-out."""
        cache: dict[bytes, tuple[IntArray, IntArray]] = self.__dict__.setdefault("_samples_of", {})
        key = np.asarray(held, dtype=np.intp).tobytes()
        if key not in cache:
            out = self._terms(held)[0]
            ids, inverse = np.unique(self.rows[out], return_inverse=True)
            cache[key] = (np.asarray(ids, dtype=np.intp), np.asarray(inverse, dtype=np.intp))
        return cache[key]

    def _terms(self, held: IntArray) -> tuple[npt.NDArray[np.bool_], Array, Array]:
        """The rows of the samples ``held``, and the rest's ``JᵀWJ`` and ``JᵀWr``: computed once per hold-out, for
        every prior it is refitted with."""
        cache: dict[bytes, tuple[npt.NDArray[np.bool_], Array, Array]] = self.__dict__.setdefault("_terms_of", {})
        key = np.asarray(held, dtype=np.intp).tobytes()
        if key not in cache:
            out = self.held_rows(held)
            kept = ~out
            weighted = self.weighted[kept]
            cache[key] = (out, self.jacobian[kept].T @ weighted, weighted.T @ self.residual[kept])
        return cache[key]


def pseudo_inverse(matrix: Array) -> Array:
    """The pseudo-inverse of a symmetric positive semi-definite ``matrix``, its rows and columns first scaled to a unit
    diagonal (so that a firm prior on some parameters does not push the others' directions below the cut): directions
    below :data:`RCOND` of the largest eigenvalue of the scaled matrix are not estimated."""
    diagonal = np.diag(matrix)
    scale = np.where(diagonal > 0.0, 1.0 / np.sqrt(np.where(diagonal > 0.0, diagonal, 1.0)), 1.0)
    values, vectors = np.linalg.eigh(matrix * scale[:, None] * scale[None, :])
    top = float(np.max(values, initial=0.0))
    keep = values > RCOND * top if top > 0.0 else np.zeros(values.size, dtype=bool)
    scaled = vectors[:, keep] * scale[:, None]
    return np.asarray((scaled / values[keep]) @ scaled.T, dtype=float)
