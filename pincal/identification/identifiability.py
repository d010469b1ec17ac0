"""Identifiability of calibration parameters: what the data can see, how well, and what it cannot.

Everything here works on an identification Jacobian ``J`` (m × p): rows are residuals already weighted
by 1/σ (so dimensionless), columns are parameters in SI units (m for lengths, rad for angles). Before
any rank decision the columns are scaled by each parameter's typical size ``s`` (``J_s = J diag(s)``),
so that a column in metres and one in radians compare; a parameter vector in physical units is then
``x = diag(s) u`` with ``u`` dimensionless and ``J x = J_s u`` (Hollerbach & Wampler 1996, "The
calibration index and taxonomy for robot kinematic calibration methods", §"scaling").

- The numerical rank is the number of singular values of ``J_s`` above ``tol · σ_max``
  (:data:`RANK_TOLERANCE` by default).
- QR with column pivoting of ``J_s`` picks the base (identifiable) parameters: the first ``rank`` pivots
  (Gautier 1991, "Numerical calculation of the base inertial parameters of robots").
- What the data cannot see is the null space of ``J_s``: the right singular vectors past the rank, made
  sparse and said in words by :mod:`pincal.identification.combinations` (each :class:`Combination` names a few
  parameters and what the data sees of them).
- The observability indices O1..O5 are those compared by Sun & Hollerbach 2008, "Observability index
  selection for robot calibration" (ICRA), computed on the singular values of the identifiable columns.
"""

from __future__ import annotations

from collections.abc import Sequence
from dataclasses import field
from functools import cached_property

import numpy as np
import numpy.typing as npt

from pincal import linalg, validation
from pincal.errors import ConvergenceError, DataError, IdentifiabilityError, listing
from pincal.identification.combinations import (
    MORE_INDENT,
    UNITS,
    Combination,
    combination_lines,
    sparse_combinations,
    unit_from_name,
    wrapped,
)
from pincal.records import record

Array = npt.NDArray[np.float64]

RANK_TOLERANCE = 1e-8
"""Default relative rank tolerance: a singular value of the scaled Jacobian counts when above
``RANK_TOLERANCE · σ_max``. The LAPACK-style ``max(m, p) · eps · σ_max`` would count the round-off of
iterative FK solves and loop closures (converged to ~1e-10..1e-12) as information and report phantom
rank; 1e-8 sits well above that noise and well below any direction a calibration could actually use
(a scaled condition number of 1e8 already means useless estimates). Pass ``tol`` to change it, e.g.
1e-4 to call only practically identifiable parameters identifiable."""


@record(frozen=True)
class Identifiability:
    """What an identification Jacobian can identify.

    Attributes:
        rank: numerical rank of the scaled Jacobian.
        n_parameters: number of columns p.
        singular_values: singular values of the scaled (dimensionless) Jacobian, descending, min(m, p).
        condition_number: ``σ_max / σ_min`` of the scaled Jacobian restricted to the base columns;
            ``inf`` at rank 0.
        observability: ``O1``..``O5`` of Sun & Hollerbach on the base columns' singular values σ_1..σ_r,
            with m residuals: ``O1 = (σ_1⋯σ_r)^(1/r)/√m``, ``O2 = σ_min/σ_max``, ``O3 = σ_min``,
            ``O4 = σ_min²/σ_max``, ``O5 = 1/Σ(1/σ_i)``. All 0 at rank 0. Larger is better.
        base_indices: columns kept (identifiable), ascending.
        base_names: their names.
        unidentifiable: ``p − rank`` :class:`Combination` s, a sparse basis of the null space, fewest
            parameters first, then by name (worked out when first read: a fit's first analysis needs only the base
            columns).
    """

    rank: int
    n_parameters: int
    singular_values: Array
    condition_number: float
    observability: dict[str, float]
    base_indices: list[int]
    base_names: list[str]
    #: what :attr:`unidentifiable` is worked out from: the null space's right singular vectors (p − rank, p), the
    #: names, scales [m or rad] and units of the parameters
    null_space: tuple[Array, list[str], Array, list[str]] = field(repr=False, compare=False)

    @cached_property
    def unidentifiable(self) -> list[Combination]:
        """``p − rank`` :class:`Combination` s, a sparse basis of the null space (see the class docstring)."""
        return sparse_combinations(*self.null_space)

    def summary(self, limit: int = 10) -> str:
        """A short account for a report: lines of at most :data:`~pincal.identification.combinations.LINE_WIDTH`
        characters, with at most ``limit`` unidentifiable combinations (:attr:`unidentifiable` has them all)."""
        obs = ", ".join(f"{key} {value:.3g}" for key, value in self.observability.items())
        lines = [
            f"identifiable: rank {self.rank} of {self.n_parameters} parameters",
            f"condition number (scaled, identifiable set): {self.condition_number:.3g}",
            f"observability: {obs}",
            *wrapped(f"base parameters ({len(self.base_names)}): ", self.base_names or ["-"]),
        ]
        if self.unidentifiable:
            lines.append(f"not identifiable ({len(self.unidentifiable)} directions the data cannot see):")
            listed, left_out = combination_lines(self.unidentifiable, limit)
            lines += listed
            if left_out:
                lines.append(f"{MORE_INDENT}… and {left_out} more (Identifiability.unidentifiable has them all)")
        else:
            lines.append("every parameter is identifiable")
        return "\n".join(lines)


def _checked(jacobian: npt.ArrayLike, names: Sequence[str], scales: npt.ArrayLike) -> tuple[Array, Array]:
    """``jacobian`` and ``scales`` as float arrays, or :class:`DataError` naming what is wrong."""
    J = _checked_jacobian(jacobian)
    p = J.shape[1]
    names = list(validation.texts("names", names))
    if len(names) != p:
        raise DataError(f"{len(names)} parameter names for a Jacobian with {p} columns; names: {listing(names)}")
    repeated = sorted({name for name in names if names.count(name) > 1})
    if repeated:
        raise DataError(f"parameter names must be unique; repeated: {listing(repeated)}")
    s = np.asarray(scales, dtype=float)
    if s.shape != (p,):
        raise DataError(f"scales has shape {s.shape}; expected ({p},), one per Jacobian column")
    bad = [f"{names[j]} ({s[j]})" for j in range(p) if not (np.isfinite(s[j]) and s[j] > 0.0)]
    if bad:
        raise DataError(f"scales must be finite and positive [m or rad]; bad: {listing(bad)}")
    return J, s


def _checked_units(units: Sequence[str] | None, names: Sequence[str]) -> list[str]:
    """One unit per parameter: ``units`` checked, or inferred from the names when None."""
    if units is None:
        return [unit_from_name(name) for name in names]
    units = list(units)
    if len(units) != len(names):
        raise DataError(f"{len(units)} units for {len(names)} parameters; give one per Jacobian column")
    bad = [f"{name} ({unit!r})" for name, unit in zip(names, units, strict=True) if unit not in UNITS]
    if bad:
        raise DataError(f"units must be 'm', 'rad' or '' (unknown); bad: {listing(bad)}")
    return units


def _checked_jacobian(jacobian: npt.ArrayLike) -> Array:
    try:
        J = np.asarray(jacobian, dtype=float)
    except (TypeError, ValueError):
        raise TypeError(f"jacobian={validation.shown(jacobian)}: expected an m × p matrix of numbers") from None
    if J.ndim != 2 or J.shape[0] == 0 or J.shape[1] == 0:
        raise DataError(f"the Jacobian must be a non-empty m × p matrix; got shape {J.shape}")
    if not np.all(np.isfinite(J)):
        rows, cols = np.nonzero(~np.isfinite(J))
        raise DataError(f"the Jacobian has {rows.size} NaN/inf entries, first at row {rows[0]}, column {cols[0]}")
    return J


def _checked_tolerance(tol: float | None) -> float:
    tol = RANK_TOLERANCE if tol is None else float(tol)
    if not 0.0 < tol < 1.0:
        raise DataError(f"rank tolerance must lie in (0, 1), relative to the largest singular value; got {tol}")
    return tol


def _svd(matrix: Array) -> tuple[Array, Array]:
    """Singular values (descending, min(m, p)) and all p right singular vectors (rows of ``Vᵀ``)."""
    return linalg.right_svd(matrix, "the scaled identification Jacobian")


def _rank(singular_values: Array, tol: float) -> int:
    if singular_values.size == 0 or singular_values[0] == 0.0:
        return 0
    return int(np.count_nonzero(singular_values > tol * singular_values[0]))


def _pivoted_triangle(J_scaled: Array) -> tuple[Array, npt.NDArray[np.intp]]:
    """``R`` (min(m, p) × p) and the pivots ``P`` of a column-pivoted QR ``J_scaled[:, P] = Q R``, computed in place
    of ``J_scaled`` (Fortran order: no copy), ``Q`` never formed."""
    m, p = J_scaled.shape
    factored, jpvt, _, _, info = linalg.lapack().dgeqp3(J_scaled, overwrite_a=True)
    if info != 0:
        raise ConvergenceError(f"the pivoted QR of the scaled identification Jacobian failed (LAPACK dgeqp3 info "
                               f"{info})")
    return np.triu(factored[:min(m, p)]), np.asarray(jpvt, dtype=np.intp) - 1  # LAPACK's pivots count from 1


def _base_columns(R: Array, pivots: npt.NDArray[np.intp], names: list[str], rank: int) -> list[int]:
    """The first ``rank`` pivots of the column-pivoted QR of the scaled Jacobian (``R``, ``pivots``:
    :func:`_pivoted_triangle`), ascending."""
    base = pivots[:rank]
    pivot = np.abs(np.diag(R[:rank, :rank]))
    if not np.all(pivot > 0.0):  # the SVD's rank and the pivoted QR disagree: an exactly dependent column
        raise IdentifiabilityError(f"the QR pivot of {names[base[int(np.argmin(pivot))]]} is zero although the "
                                   f"singular values give rank {rank}; pass a larger tol")
    return sorted(int(j) for j in base)


def base_parameters(
    jacobian: npt.ArrayLike,
    names: Sequence[str],
    scales: npt.ArrayLike,
    tol: float | None = None,
    *,
    units: Sequence[str] | None = None,
) -> tuple[list[int], list[Combination]]:
    """The identifiable columns and a sparse basis of what the data cannot see.

    Args:
        jacobian: (m, p) identification Jacobian, rows weighted by 1/σ, columns per unit of each
            parameter [1/m or 1/rad].
        names: p parameter names.
        scales: (p,) typical size of each parameter [m or rad]; columns are multiplied by them.
        tol: relative rank tolerance on the scaled singular values (default :data:`RANK_TOLERANCE`).
        units: p units, each ``m``, ``rad`` or ``""`` (unknown), for the descriptions; inferred from
            the names when None (see :func:`unit_from_name`).

    Returns:
        The base column indices (ascending) and the ``p − rank`` :class:`Combination` s, fewest
        parameters first, then by name.

    Raises:
        DataError: malformed input.
    """
    J, s = _checked(jacobian, names, scales)
    tol = _checked_tolerance(tol)
    names = list(names)
    units = _checked_units(units, names)
    R, pivots = _pivoted_triangle(np.multiply(J, s, out=np.empty(J.shape, order="F")))
    singular_values, Vt_pivoted = _svd(R)
    Vt = np.empty_like(Vt_pivoted)
    Vt[:, pivots] = Vt_pivoted
    rank = _rank(singular_values, tol)
    return _base_columns(R, pivots, names, rank), sparse_combinations(Vt[rank:], names, s, units)


def observability_indices(singular_values: Array, n_residuals: int) -> dict[str, float]:
    """Sun & Hollerbach's O1..O5 of the given (positive) singular values, m = ``n_residuals``.

    ``O1 = (σ_1⋯σ_r)^(1/r)/√m`` (Borm & Menq), ``O2 = σ_min/σ_max`` (inverse condition number, Driels &
    Pathre), ``O3 = σ_min`` (Nahvi et al.), ``O4 = σ_min²/σ_max`` (noise amplification index, Nahvi &
    Hollerbach), ``O5 = 1/Σ(1/σ_i)``. All 0 when there is none.
    """
    sv = np.sort(np.asarray(singular_values, dtype=float))[::-1]
    if sv.size == 0 or sv[-1] <= 0.0:
        return {"O1": 0.0, "O2": 0.0, "O3": 0.0, "O4": 0.0, "O5": 0.0}
    high, low = float(sv[0]), float(sv[-1])
    return {
        "O1": float(np.exp(np.mean(np.log(sv))) / np.sqrt(n_residuals)),  # log-mean: no overflow at large r
        "O2": low / high,
        "O3": low,
        "O4": low * (low / high),  # not low**2: Python floats raise OverflowError where numpy gives inf
        "O5": float(1.0 / np.sum(1.0 / sv)),
    }


def analyse(
    jacobian: npt.ArrayLike,
    names: Sequence[str],
    scales: npt.ArrayLike,
    tol: float | None = None,
    *,
    units: Sequence[str] | None = None,
) -> Identifiability:
    """Rank, conditioning, observability, base parameters and unseen combinations of an identification
    Jacobian.

    Args:
        jacobian: (m, p) identification Jacobian, rows weighted by 1/σ, columns per unit of each
            parameter [1/m or 1/rad].
        names: p parameter names, e.g. ``arm_1_joint.tx``, ``arm_2_joint.offset``.
        scales: (p,) typical size of each parameter [m or rad], e.g. 1e-3; the analysis is of
            ``J diag(scales)``, so the singular values are dimensionless.
        tol: relative rank tolerance on the scaled singular values (default :data:`RANK_TOLERANCE`).
        units: p units, each ``m``, ``rad`` or ``""`` (unknown), for the descriptions (e.g.
            ``[p.unit for p in parameter_set]``); inferred from the names when None, which leaves joint
            offsets without a unit (see :func:`unit_from_name`).

    Returns:
        The :class:`Identifiability` record.

    Raises:
        DataError: malformed input (shapes, NaN/inf, name count, non-positive scales, bad ``tol`` or units).
    """
    J, s = _checked(jacobian, names, scales)
    tol = _checked_tolerance(tol)
    names = list(names)
    units = _checked_units(units, names)
    # one working copy, in the column order LAPACK factors in place: the pivoted QR's triangle carries the singular
    # values and right vectors of J diag(s), and its first columns those of the base columns
    R, pivots = _pivoted_triangle(np.multiply(J, s, out=np.empty(J.shape, order="F")))
    singular_values, Vt_pivoted = _svd(R)
    Vt = np.empty_like(Vt_pivoted)
    Vt[:, pivots] = Vt_pivoted
    rank = _rank(singular_values, tol)
    base = _base_columns(R, pivots, names, rank)
    base_values = linalg.singular_values(R[:, :rank], "the scaled identification Jacobian on its base "
                                         "columns") if base else np.zeros(0)
    condition = float(base_values[0] / base_values[-1]) if base_values.size and base_values[-1] > 0 else np.inf
    return Identifiability(
        rank=rank,
        n_parameters=J.shape[1],
        singular_values=singular_values,
        condition_number=condition,
        observability=observability_indices(base_values, J.shape[0]),
        base_indices=base,
        base_names=[names[j] for j in base],
        null_space=(Vt[rank:].copy(), names, s.copy(), list(units)),  # the caller's scales may change later
    )


def covariance(
    jacobian: npt.ArrayLike,
    sigma2: float,
    indices: Sequence[int] | None = None,
    names: Sequence[str] | None = None,
    tol: float | None = None,
    row_weights: npt.ArrayLike | None = None,
    units: Sequence[str] | None = None,
) -> Array:
    """Covariance of the least-squares estimate, ``σ² (JᵀJ)⁻¹``, on the chosen columns (of ``diag(row_weights) J``
    when given). The rows are reduced a few thousand at a time (:func:`pincal.linalg.triangle`): a tall Jacobian is
    not copied.

    Args:
        jacobian: (m, p) identification Jacobian, rows weighted by 1/σ [1/m or 1/rad per column].
        sigma2: variance factor: 1 when the row weights are the true 1/σ, else the a-posteriori
            ``‖r‖² / (m − k)`` of the fit [dimensionless].
        indices: columns to keep (the identifiable set, e.g. ``Identifiability.base_indices``); all if None.
        names: p parameter names, only to name a culprit in errors.
        tol: relative rank tolerance (default :data:`RANK_TOLERANCE`) on the column-equilibrated
            sub-Jacobian, whose conditioning does not depend on units.
        row_weights: (m,) weights of the rows (robust-loss weights' square roots), 1 if None.
        units: p units, each ``m``, ``rad`` or ``""`` (unknown), for the culprit's description (the parameters'
            kinds give them: :attr:`~pincal.identification.parameters.ParameterSet.lengths_and_angles`); inferred
            from ``names`` when None.

    Returns:
        (k, k) covariance in the parameters' units squared ([m²], [rad²], [m·rad]), k = len(indices).

    Raises:
        DataError: malformed input.
        IdentifiabilityError: the chosen columns are dependent; the message names one that is.
    """
    J = _checked_jacobian(jacobian)
    tol = _checked_tolerance(tol)
    p = J.shape[1]
    if names is not None and len(names) != p:
        raise DataError(f"{len(names)} parameter names for a Jacobian with {p} columns")
    column_units = _checked_units(units, names if names is not None else [f"column {j}" for j in range(p)])
    labels = [f"{names[j]} (column {j})" if names is not None else f"column {j}" for j in range(p)]
    if not (np.isfinite(sigma2) and sigma2 >= 0.0):
        raise DataError(f"sigma2 must be a finite variance factor >= 0; got {sigma2}")
    columns = list(range(p)) if indices is None else [int(j) for j in indices]
    if not columns:
        raise DataError("no columns chosen for the covariance")
    outside = [j for j in columns if not 0 <= j < p]
    if outside:
        raise DataError(f"column indices {outside} are outside 0..{p - 1}")
    if len(set(columns)) != len(columns):
        raise DataError(f"column indices repeat: {columns}")
    weights = None if row_weights is None else np.asarray(row_weights, dtype=float)
    if weights is not None and weights.shape != (J.shape[0],):
        raise DataError(f"row_weights has shape {weights.shape}; expected ({J.shape[0]},), one per Jacobian row")
    # the triangle of the weighted columns: the same Gram matrix, so the same norms, singular values and vectors
    sub = linalg.triangle(J, columns, weights) if J.shape[0] >= len(columns) else \
        J[:, columns] * (1.0 if weights is None else weights[:, None])
    norms = np.linalg.norm(sub, axis=0)
    for j, norm in zip(columns, norms, strict=True):
        if norm == 0.0:
            raise IdentifiabilityError(f"{labels[j]} is invisible to the data (zero Jacobian column); drop it")
    equilibrated = sub / norms  # unit columns: the singularity test does not depend on units
    sv, Vt = linalg.right_svd(equilibrated, "the identification Jacobian on the chosen columns")
    if sv.size < len(columns) or sv[-1] <= tol * sv[0]:
        rank = _rank(sv, tol)
        culprits = sparse_combinations(_svd(equilibrated)[1][rank:], [labels[j] for j in columns], 1.0 / norms,
                                       [column_units[j] for j in columns])
        raise IdentifiabilityError(
            f"JᵀJ is singular on the chosen columns (rank {rank} of {len(columns)}); keep only the "
            f"identifiable ones (see analyse()): " + "; ".join(c.description for c in culprits)
        )
    inverse = (Vt.T / sv**2) @ Vt
    return sigma2 * inverse / np.outer(norms, norms)


def correlations(cov: npt.ArrayLike) -> Array:
    """Correlation matrix ``ρ_ij = C_ij / √(C_ii C_jj)`` of a covariance matrix (dimensionless)."""
    C = np.asarray(cov, dtype=float)
    if C.ndim != 2 or C.shape[0] != C.shape[1]:
        raise DataError(f"a covariance must be a square matrix; got shape {C.shape}")
    if not np.all(np.isfinite(C)):
        raise DataError("the covariance has NaN/inf entries")
    variances = np.diag(C)
    bad = np.nonzero(variances <= 0.0)[0]
    if bad.size:
        raise DataError(f"variances must be positive; diagonal entries {bad.tolist()} are {variances[bad].tolist()}")
    std = np.sqrt(variances)
    rho: Array = C / np.outer(std, std)
    np.fill_diagonal(rho, 1.0)
    return rho
