"""Identifiability of calibration parameters: what the data can see, how well, and what it cannot.

Everything here works on an identification Jacobian ``J`` (m × p): rows are residuals already weighted
by 1/σ (so dimensionless), columns are parameters in SI units (m for lengths, rad for angles). Before
any rank decision the columns are scaled by each parameter's typical size ``s`` (``J_s = J diag(s)``),
so that a column in metres and one in radians compare; a parameter vector in physical units is then
``x = diag(s) u`` with ``u`` dimensionless and ``J x = J_s u`` (Hollerbach & Wampler 1996, "The
calibration index and taxonomy for robot kinematic calibration methods", §"scaling").

- The numerical rank is the number of singular values of ``J_s`` above ``tol · σ_max``
  (:data:`RANK_TOLERANCE` by default).
- QR with column pivoting of ``J_s`` picks the base (identifiable) parameters: the first ``rank`` pivots.
  Each remaining column ``d`` is a combination of the base columns, ``J_s[:, d] = J_s[:, B] C`` with
  ``C = R11⁻¹ R12`` (Gautier 1991, "Numerical calculation of the base inertial parameters of robots").
  In physical units ``J[:, d] = Σ_b k_b J[:, b]`` with ``k_b = C_b s_b / s_d``, and the data only sees
  the combinations ``x_b + k_b x_d``.
- The observability indices O1..O5 are those compared by Sun & Hollerbach 2008, "Observability index
  selection for robot calibration" (ICRA), computed on the singular values of the identifiable columns.
"""

from __future__ import annotations

from collections.abc import Sequence
from dataclasses import dataclass

import numpy as np
import numpy.typing as npt
import scipy.linalg

from pincal import linalg
from pincal.errors import DataError, IdentifiabilityError, listing

Array = npt.NDArray[np.float64]

RANK_TOLERANCE = 1e-8
"""Default relative rank tolerance: a singular value of the scaled Jacobian counts when above
``RANK_TOLERANCE · σ_max``. The LAPACK-style ``max(m, p) · eps · σ_max`` would count the round-off of
iterative FK solves and loop closures (converged to ~1e-10..1e-12) as information and report phantom
rank; 1e-8 sits well above that noise and well below any direction a calibration could actually use
(a scaled condition number of 1e8 already means useless estimates). Pass ``tol`` to change it, e.g.
1e-4 to call only practically identifiable parameters identifiable."""

COEFFICIENT_TOLERANCE = 1e-6
"""A base parameter is named in a combination when its scaled coefficient exceeds this fraction of the
largest scaled coefficient of that combination."""


@dataclass(frozen=True)
class Combination:
    """One direction the data cannot see, tied to the parameter that carries it.

    Attributes:
        names: the dependent (unidentifiable) parameter first, then the base parameters it is tied to.
        coefficients: ``[1, k_1, k_2, ...]`` in physical units, such that
            ``J[:, dependent] = Σ_i k_i J[:, names[i]]``: moving the dependent parameter by δ changes the
            data exactly as moving each base parameter by ``k_i δ`` does. ``k_i`` has units
            [unit of names[i] / unit of names[0]], e.g. [m/rad]. Only ``[1]`` for an invisible parameter.
        description: the same in plain words.
    """

    names: list[str]
    coefficients: Array
    description: str

    @property
    def dependent(self) -> str:
        """The parameter that is not identifiable on its own."""
        return self.names[0]

    @property
    def null_direction(self) -> Array:
        """The parameter change the data cannot see, in physical units, over :attr:`names`:
        ``[1, -k_1, -k_2, ...]`` (``J δx = 0`` up to the rank tolerance)."""
        return np.concatenate([[1.0], -self.coefficients[1:]])


@dataclass(frozen=True)
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
        unidentifiable: one :class:`Combination` per null-space direction, sorted by dependent name.
    """

    rank: int
    n_parameters: int
    singular_values: Array
    condition_number: float
    observability: dict[str, float]
    base_indices: list[int]
    base_names: list[str]
    unidentifiable: list[Combination]

    def summary(self) -> str:
        """A readable multi-line account for a report."""
        obs = ", ".join(f"{key} {value:.3g}" for key, value in self.observability.items())
        lines = [
            f"identifiable: rank {self.rank} of {self.n_parameters} parameters",
            f"condition number (scaled, identifiable set): {self.condition_number:.3g}",
            f"observability: {obs}",
            "singular values (scaled): " + " ".join(f"{s:.3g}" for s in self.singular_values),
            f"base parameters ({len(self.base_names)}): {', '.join(self.base_names) or '-'}",
        ]
        if self.unidentifiable:
            lines.append(f"not identifiable ({len(self.unidentifiable)}):")
            lines += [f"  - {combination.description}" for combination in self.unidentifiable]
        else:
            lines.append("every parameter is identifiable")
        return "\n".join(lines)


def _checked(jacobian: npt.ArrayLike, names: Sequence[str], scales: npt.ArrayLike) -> tuple[Array, Array]:
    """``jacobian`` and ``scales`` as float arrays, or :class:`DataError` naming what is wrong."""
    J = _checked_jacobian(jacobian)
    p = J.shape[1]
    names = list(names)
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


def _checked_jacobian(jacobian: npt.ArrayLike) -> Array:
    J = np.asarray(jacobian, dtype=float)
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


def _number(value: float) -> str:
    magnitude = abs(value)
    return f"{magnitude:.3f}" if 1e-3 <= magnitude < 1e4 else f"{magnitude:.3e}"


def _signed_term(coefficient: float, name: str, first: bool = False) -> str:
    sign = "-" if coefficient < 0 else ("" if first else "+")
    return f"{sign}{' ' if sign and not first else ''}{_number(coefficient)} {name}"


def _describe(dependent: str, bases: list[str], coefficients: list[float]) -> str:
    if not bases:
        return f"{dependent} is invisible to the data (no measurement depends on it)"
    seen = [f"{base} {_signed_term(k, dependent)}" for base, k in zip(bases, coefficients, strict=True)]
    if len(bases) == 1:
        return f"{dependent} is not identifiable on its own: only {seen[0]} is seen by the data"
    effect = " ".join(
        _signed_term(k, base, first=i == 0) for i, (base, k) in enumerate(zip(bases, coefficients, strict=True))
    )
    return (
        f"{dependent} is not identifiable on its own: it acts on the data as {effect}; "
        f"only {', '.join(seen)} are seen by the data"
    )


def _singular_values(matrix: Array) -> Array:
    return linalg.singular_values(matrix, "the scaled identification Jacobian")


def _rank(singular_values: Array, tol: float) -> int:
    if singular_values.size == 0 or singular_values[0] == 0.0:
        return 0
    return int(np.count_nonzero(singular_values > tol * singular_values[0]))


def _base_from_scaled(
    J_scaled: Array, names: list[str], scales: Array, rank: int, tol: float
) -> tuple[list[int], list[Combination]]:
    """Base columns and named combinations of an already scaled Jacobian of known rank."""
    p = J_scaled.shape[1]
    _, R, pivots = scipy.linalg.qr(J_scaled, pivoting=True, mode="economic")
    base = pivots[:rank]
    dependents = pivots[rank:]
    if rank:
        pivot = np.abs(np.diag(R[:rank, :rank]))
        if not np.all(pivot > 0.0):  # the SVD's rank and the pivoted QR disagree: an exactly dependent column
            raise IdentifiabilityError(f"the QR pivot of {names[base[int(np.argmin(pivot))]]} is zero although the "
                                       f"singular values give rank {rank}; pass a larger tol")
        C = scipy.linalg.solve_triangular(R[:rank, :rank], R[:rank, rank:p])
    else:
        C = np.zeros((0, dependents.size))
    column_norms = np.linalg.norm(J_scaled, axis=0)
    largest = float(np.max(column_norms))
    combinations = []
    for i, d in enumerate(dependents):
        tied: list[str] = []
        physical: list[float] = []
        if column_norms[d] > tol * largest and C.size:
            c = C[:, i]
            keep = np.abs(c) > COEFFICIENT_TOLERANCE * np.max(np.abs(c))
            for row in np.argsort(base):  # base parameters in column order, for stable text
                if keep[row]:
                    tied.append(names[base[row]])
                    physical.append(float(c[row] * scales[base[row]] / scales[d]))
        combinations.append(
            Combination(
                names=[names[d], *tied],
                coefficients=np.array([1.0, *physical]),
                description=_describe(names[d], tied, physical),
            )
        )
    combinations.sort(key=lambda combination: combination.dependent)
    return sorted(int(j) for j in base), combinations


def base_parameters(
    jacobian: npt.ArrayLike, names: Sequence[str], scales: npt.ArrayLike, tol: float | None = None
) -> tuple[list[int], list[Combination]]:
    """The identifiable columns and, for every other column, what it is tied to.

    Args:
        jacobian: (m, p) identification Jacobian, rows weighted by 1/σ, columns per unit of each
            parameter [1/m or 1/rad].
        names: p parameter names.
        scales: (p,) typical size of each parameter [m or rad]; columns are multiplied by them.
        tol: relative rank tolerance on the scaled singular values (default :data:`RANK_TOLERANCE`).

    Returns:
        The base column indices (ascending) and one :class:`Combination` per dependent column,
        sorted by name.

    Raises:
        DataError: malformed input.
    """
    J, s = _checked(jacobian, names, scales)
    tol = _checked_tolerance(tol)
    J_scaled = J * s
    rank = _rank(_singular_values(J_scaled), tol)
    return _base_from_scaled(J_scaled, list(names), s, rank, tol)


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
    jacobian: npt.ArrayLike, names: Sequence[str], scales: npt.ArrayLike, tol: float | None = None
) -> Identifiability:
    """Rank, conditioning, observability and base parameters of an identification Jacobian.

    Args:
        jacobian: (m, p) identification Jacobian, rows weighted by 1/σ, columns per unit of each
            parameter [1/m or 1/rad].
        names: p parameter names, e.g. ``arm_1_joint.tx``, ``arm_2_joint.offset``.
        scales: (p,) typical size of each parameter [m or rad], e.g. 1e-3; the analysis is of
            ``J diag(scales)``, so the singular values are dimensionless.
        tol: relative rank tolerance on the scaled singular values (default :data:`RANK_TOLERANCE`).

    Returns:
        The :class:`Identifiability` record.

    Raises:
        DataError: malformed input (shapes, NaN/inf, name count, non-positive scales, bad ``tol``).
    """
    J, s = _checked(jacobian, names, scales)
    tol = _checked_tolerance(tol)
    names = list(names)
    J_scaled = J * s
    singular_values = _singular_values(J_scaled)
    rank = _rank(singular_values, tol)
    base, combinations = _base_from_scaled(J_scaled, names, s, rank, tol)
    base_values = _singular_values(J_scaled[:, base]) if base else np.zeros(0)
    condition = float(base_values[0] / base_values[-1]) if base_values.size and base_values[-1] > 0 else np.inf
    return Identifiability(
        rank=rank,
        n_parameters=J.shape[1],
        singular_values=singular_values,
        condition_number=condition,
        observability=observability_indices(base_values, J.shape[0]),
        base_indices=base,
        base_names=[names[j] for j in base],
        unidentifiable=combinations,
    )


def covariance(
    jacobian: npt.ArrayLike,
    sigma2: float,
    indices: Sequence[int] | None = None,
    names: Sequence[str] | None = None,
    tol: float | None = None,
) -> Array:
    """Covariance of the least-squares estimate, ``σ² (JᵀJ)⁻¹``, on the chosen columns.

    Args:
        jacobian: (m, p) identification Jacobian, rows weighted by 1/σ [1/m or 1/rad per column].
        sigma2: variance factor: 1 when the row weights are the true 1/σ, else the a-posteriori
            ``‖r‖² / (m − k)`` of the fit [dimensionless].
        indices: columns to keep (the identifiable set, e.g. ``Identifiability.base_indices``); all if None.
        names: p parameter names, only to name a culprit in errors.
        tol: relative rank tolerance (default :data:`RANK_TOLERANCE`) on the column-equilibrated
            sub-Jacobian, whose conditioning does not depend on units.

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
    sub = J[:, columns]
    norms = np.linalg.norm(sub, axis=0)
    for j, norm in zip(columns, norms, strict=True):
        if norm == 0.0:
            raise IdentifiabilityError(f"{labels[j]} is invisible to the data (zero Jacobian column); drop it")
    equilibrated = sub / norms  # unit columns: the singularity test does not depend on units
    _, sv, Vt = linalg.svd(equilibrated, "the identification Jacobian on the chosen columns")
    if sv.size < len(columns) or sv[-1] <= tol * sv[0]:
        rank = _rank(sv, tol)
        _, culprits = _base_from_scaled(equilibrated, [labels[j] for j in columns], 1.0 / norms, rank, tol)
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
