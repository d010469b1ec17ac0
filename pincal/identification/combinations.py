"""What the data cannot see, in words: sparse combinations of parameters and how a listing says them.

The null space of the scaled identification Jacobian ``J_s`` (:mod:`pincal.identification.identifiability`) has any
number of bases; the SVD's mixes every parameter. Its reduced row echelon form (pivot: the largest remaining entry) is
sparse instead: when the null space splits into small groups of parameters (``base.tz`` with ``arm_1_joint.tz``, …),
each of its rows involves one group only, so each :class:`Combination` names a few parameters. Row ``u`` led by ``a``
reads, in physical units, ``J[:, a] = Σ_b k_b J[:, b]`` with ``k_b = −(u_b / u_a)(s_b / s_a)``: the data only sees
``x_b + k_b x_a``. Each combination is described in one line, the most explicit wording that fits.
"""

from __future__ import annotations

import textwrap
from collections.abc import Sequence
from dataclasses import field

import numpy as np
import numpy.typing as npt

from pincal.errors import DataError
from pincal.records import record

Array = npt.NDArray[np.float64]

COEFFICIENT_TOLERANCE = 1e-6
"""A parameter is named in a combination when its scaled entry in the null-space row exceeds this
fraction of the row's largest: smaller entries are the round-off of the SVD."""

UNITS = ("m", "rad", "")
"""The units a parameter can have: metres, radians, or unknown ("")."""

#: The units a direction's steps are said in (the same numbers: only the ratios matter).
SMALL_UNITS = {"m": "mm", "rad": "mrad"}

LINE_WIDTH = 120
"""Longest line of :meth:`~pincal.identification.identifiability.Identifiability.summary` and
:func:`describe_unidentifiable` [characters]."""

BULLET = "  - "
"""What starts a combination's line in a listing; descriptions are short enough to fit after it."""

MORE_INDENT = "  "
"""What starts the ``… and N more`` line of a listing."""

SHOWN_TERMS = 6
"""A combination of up to this many parameters is written out whole; a longer one shows its
``SHOWN_TERMS − 1`` largest (scaled) terms and counts the others."""

SAME_EFFECT = 1e-6
"""Two parameters move the measurements the same way (or opposite ways) when ``|k| = 1`` within this."""


@record(frozen=True)
class Combination:
    """One direction the data cannot see, on the few parameters it involves.

    Attributes:
        names: the leading parameter first: the one that moves most along the direction, in scaled
            units (the pivot of the null-space row; the first in column order among equals), then the
            others, largest scaled entry first (equal ones in column order).
        coefficients: ``[1, k_1, k_2, ...]`` in physical units, such that
            ``J[:, names[0]] = Σ_i k_i J[:, names[i]]``: moving the leading parameter by δ changes the
            data exactly as moving each other parameter by ``k_i δ`` does. ``k_i`` has units
            [unit of names[i] / unit of names[0]], e.g. [m/rad]. Only ``[1]`` for an invisible parameter.
        description: the same in plain words, one line of at most ``LINE_WIDTH − len(BULLET)`` characters
            (unless names are so long that even the shortest wording is longer).
        units: the unit of each parameter of :attr:`names`: ``m``, ``rad`` or ``""`` (unknown).
    """

    names: list[str]
    coefficients: Array
    description: str
    units: list[str] = field(default_factory=list)

    @property
    def dependent(self) -> str:
        """The leading parameter: not identifiable on its own (neither are the others named)."""
        return self.names[0]

    @property
    def null_direction(self) -> Array:
        """The parameter change the data cannot see, in physical units, over :attr:`names`:
        ``[1, -k_1, -k_2, ...]`` (``J δx = 0`` up to the rank tolerance)."""
        return np.concatenate([[1.0], -self.coefficients[1:]])


#: Entries within this relative distance of the largest are tied for the pivot (symmetric mechanisms make exact ties,
#: which round-off would otherwise break one way or the other).
PIVOT_TIE = 1e-6


def _reduced_row_echelon(rows: Array) -> Array:
    """The reduced row echelon form of the space spanned by the orthonormal ``rows`` (k × p), the same whichever basis
    of the space they are: Gauss–Jordan elimination of the space's projector ``rowsᵀ rows`` (p × p, rank k), each
    pivot the largest remaining entry (complete pivoting, for stability; among entries equal within
    :data:`PIVOT_TIE`, the first column, then the first row). Returns the k pivot rows, each 1 at its pivot, 0 at the
    others' pivots; entries below :data:`COEFFICIENT_TOLERANCE` times the row's largest are round-off and set to
    zero."""
    k = rows.shape[0]
    reduced = rows.T @ rows
    pivots: list[int] = []
    for i in range(k):
        size = np.abs(reduced[i:])
        tied = np.argwhere(size >= (1.0 - PIVOT_TIE) * size.max())
        r, c = min(((int(row), int(column)) for row, column in tied), key=lambda rc: (rc[1], rc[0]))
        reduced[[i, i + r]] = reduced[[i + r, i]]
        reduced[i] /= reduced[i, c]
        others = np.arange(reduced.shape[0]) != i
        reduced[others] -= np.outer(reduced[others, c], reduced[i])
        reduced[others, c] = 0.0
        pivots.append(c)
    reduced = reduced[:k]
    for row, c in zip(reduced, pivots, strict=True):
        small = np.abs(row) < COEFFICIENT_TOLERANCE * np.max(np.abs(row))
        small[c] = False
        row[small] = 0.0
    return reduced


def sparse_combinations(null_rows: Array, names: list[str], scales: Array, units: list[str]) -> list[Combination]:
    """One :class:`Combination` per row of a basis of the scaled null space (k × p), made sparse; ``names``,
    ``scales`` [m or rad] and ``units`` are the p parameters'. Fewest parameters first, then by name."""
    if null_rows.shape[0] == 0:
        return []
    combinations = []
    for u in _reduced_row_echelon(null_rows):
        # largest first, equal ones in column order (rounded: round-off does not decide which leads)
        involved = sorted((int(j) for j in np.flatnonzero(u)), key=lambda j: (-float(f"{abs(u[j]):.6g}"), j))
        lead, others = involved[0], involved[1:]
        coefficients = np.array([1.0, *(-u[j] / u[lead] * scales[j] / scales[lead] for j in others)])
        tied = [names[j] for j in involved]
        their_units = [units[j] for j in involved]
        combinations.append(Combination(tied, coefficients, _describe(tied, coefficients, their_units), their_units))
    combinations.sort(key=lambda combination: (len(combination.names), combination.names))
    return combinations


def describe_unidentifiable(combinations: Sequence[Combination], limit: int = 10) -> list[str]:
    """The lines a listing prints for unidentifiable combinations, each at most :data:`LINE_WIDTH`
    characters: ``BULLET + description`` per combination, except that parameters with no effect at all
    share one line when there are several; at most ``limit`` such lines, then ``  … and N more`` when
    N combinations were left out.

    Args:
        combinations: :attr:`Identifiability.unidentifiable`, in its order.
        limit: most lines before the ``… and N more`` one (>= 0).

    Raises:
        DataError: negative ``limit``.
    """
    lines, left_out = combination_lines(combinations, limit)
    return lines + ([f"{MORE_INDENT}… and {left_out} more"] if left_out else [])


def digest(combinations: Sequence[Combination], n_candidates: int) -> str:
    """One sentence on what a candidate set's unseen directions are: how many of ``n_candidates``, how many are pairs
    seen only together, larger combinations and parameters with no effect, with one example; "" when none."""
    if not combinations:
        return ""
    sizes = [len(c.names) for c in combinations]
    kinds = [(sizes.count(2), "pair", "pairs", "seen only together"),
             (sum(size > 2 for size in sizes), "combination", "combinations", "of 3+"),
             (sizes.count(1), "parameter", "parameters", "with no effect")]
    parts = [f"{count} {one if count == 1 else many} {what}" for count, one, many, what in kinds if count]
    example = next((c for c in combinations if len(c.names) > 1), combinations[0])
    shown = ", ".join(example.names[:3]) + (f" (+{len(example.names) - 3} more)" if len(example.names) > 3 else "")
    return (f"{len(combinations)} of {n_candidates} candidate directions, as expected of overlapping candidates: "
            f"{', '.join(parts)} (e.g. {shown}), left at minimum norm")


def combination_lines(combinations: Sequence[Combination], limit: int) -> tuple[list[str], int]:
    """At most ``limit`` lines for :func:`describe_unidentifiable`, and how many combinations they leave out."""
    if limit < 0:
        raise DataError(f"limit must be >= 0 lines; got {limit}")
    invisible = [c.dependent for c in combinations if len(c.names) == 1]
    entries = [(BULLET + c.description, 1) for c in combinations if len(c.names) > 1 or len(invisible) == 1]
    if len(invisible) > 1:
        head = f"{BULLET}no effect on the measurements ({len(invisible)} parameters): "
        entries.insert(0, (wrapped(head, invisible, max_lines=1)[0], len(invisible)))
    shown = entries[:limit]
    return [text for text, _ in shown], len(combinations) - sum(count for _, count in shown)


def wrapped(head: str, items: Sequence[str], max_lines: int = 2) -> list[str]:
    """``head`` and the comma-separated items on at most ``max_lines`` lines of :data:`LINE_WIDTH`; the
    items that do not fit are counted at the end."""

    def wrap(shown: list[str]) -> list[str]:
        return textwrap.wrap(head + ", ".join(shown), LINE_WIDTH, subsequent_indent="  ",
                             break_long_words=False, break_on_hyphens=False)

    lines = wrap(list(items))
    shown = len(items)
    while len(lines) > max_lines and shown > 0:
        shown -= 1
        lines = wrap([*items[:shown], f"… (+{len(items) - shown} more)"])
    return lines


def unit_from_name(name: str) -> str:
    """The unit a parameter's name implies: ``m`` for ``*.tx|ty|tz`` and ``marker.*.x|y|z``, ``rad`` for
    ``*.rx|ry|rz``, ``""`` (unknown) otherwise, e.g. for a joint offset (m or rad with the joint)."""
    component = name.rsplit(".", 1)[-1]
    if component in ("tx", "ty", "tz") or (name.startswith("marker.") and component in ("x", "y", "z")):
        return "m"
    return "rad" if component in ("rx", "ry", "rz") else ""


def _quantity(value: float, unit: str, sign: str = "") -> str:
    """``value`` to 3 significant digits, then its unit if known; ``sign="+"`` writes a plus sign."""
    number = f"{value:{sign}.3g}"
    return f"{number} {unit}" if unit else number


def _ratio_unit(numerator: str, denominator: str) -> str:
    """The unit of a coefficient ``k`` in ``J[:, a] = k J[:, b]``: unit(b)/unit(a); none when they are
    equal or one is unknown."""
    return f"{numerator}/{denominator}" if numerator and denominator and numerator != denominator else ""


def _wordings(names: list[str], coefficients: Array, units: list[str]) -> list[str]:
    """Ways to say one combination (its names, ``[1, k_1, ...]`` and units), the most explicit first."""
    if len(names) == 1:
        return [f"{names[0]} has no effect on the measurements", f"{names[0]}: no effect"]
    if len(names) == 2:
        (a, b), k = names, float(coefficients[1])
        if not (units[0] and units[1] and units[0] != units[1]) and abs(abs(k) - 1.0) <= SAME_EFFECT:
            # J_a = ±J_b: the data sees J_a (x_a ± x_b)
            way, seen = ("the same way", "their sum") if k > 0 else ("in opposite ways", "their difference")
            return [f"{a} and {b} move the measurements {way}: only {seen} is seen",
                    f"{a} and {b}: only {seen} is seen"]
        ratio = _ratio_unit(units[1], units[0])
        acts = f"{a} acts as {_quantity(k, ratio)} × {b}"
        # J_a = k J_b: the data sees J_b (x_b + k x_a)
        return [f"{acts}: only {b} {'-' if k < 0 else '+'} {_quantity(abs(k), ratio)} × {a} is seen", acts]
    null_direction = np.concatenate([[1.0], -coefficients[1:]])
    # a direction, not a size: said per millimetre or milliradian of the first, the size of a geometric error
    steps = [_quantity(step, SMALL_UNITS.get(unit, unit), "+")
             for step, unit in zip(null_direction, units, strict=True)]
    return _group_wordings(names, steps)


def _group_wordings(names: list[str], steps: list[str]) -> list[str]:
    """Ways to say that moving each of three or more parameters by its step (with its unit) is not seen,
    the most explicit first; the shorter ones show fewer parameters and count the others."""
    whole = len(names) <= SHOWN_TERMS
    shown = len(names) if whole else SHOWN_TERMS - 1
    moves = [f"{name} by {step}" for name, step in zip(names[:shown], steps[:shown], strict=True)]
    listed = f"{', '.join(moves[:-1])} and {moves[-1]}" if whole else f"{', '.join(moves)} (+{len(names) - shown} more)"
    wordings = [f"moving {listed} changes no measurement"]
    for count in range(shown, 0, -1):
        more = f" (+{len(names) - count} more)" if count < len(names) else ""
        terms = ", ".join(f"{name} {step}" for name, step in zip(names[:count], steps[:count], strict=True))
        wordings.append(f"unseen change: {terms}{more}")
    return wordings


def _describe(names: list[str], coefficients: Array, units: list[str]) -> str:
    """The most explicit wording that fits after a :data:`BULLET` on a line of :data:`LINE_WIDTH`."""
    wordings = _wordings(names, coefficients, units)
    text = next((text for text in wordings if len(BULLET + text) <= LINE_WIDTH), wordings[-1])
    room = LINE_WIDTH - len(BULLET)
    return text if len(text) <= room else text[:room - 1] + "…"  # names too long for any wording: cut
