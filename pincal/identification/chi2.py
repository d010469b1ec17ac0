"""Quantiles of the χ² distribution, without SciPy's special-function package (a tenth of a second of every
command's start).

:func:`chi2_upper` solves ``Q(ν/2, x/2) = tail`` for ``x``, ``Q`` the regularised upper incomplete gamma function,
by Halley's method on ``log Q`` from the Wilson–Hilferty approximation (for many degrees of freedom and one tail,
corrected by the neighbour's solution), within a bracket that halves where a step would leave it. ``Q`` comes from
its power series below ``a + 1`` and from its continued fraction (modified Lentz) above, the two classical expansions
(Numerical Recipes, 3rd ed., §6.2), with as many terms as ``a`` needs (about √a); both converge to the double
precision. The quantile agrees with ``scipy.special.chdtri`` to about 1e-13 relative for degrees of freedom from 0.2
to 10⁴ (fractional ones included; pincal's are 1 to a few hundred) and tails from 1e-15 to 0.9999 (checked in the
tests); where it cannot answer (a quantile that underflows, no convergence) it gives NaN, never a wrong number.
Dimensionless throughout.
"""

from __future__ import annotations

import math

import numpy as np
import numpy.typing as npt

Array = npt.NDArray[np.float64]

try:  # the C function ``statistics.NormalDist.inv_cdf`` calls, without importing ``statistics`` (and its ``fractions``
    from _statistics import _normal_dist_inv_cdf  # and ``decimal``: 2 ms of a calibration's start)
except ImportError:  # an interpreter without that private accelerator: the public API, the same values
    from statistics import NormalDist

    def _normal_dist_inv_cdf(p: float, mu: float, sigma: float) -> float:
        return NormalDist(mu, sigma).inv_cdf(p)

#: Most Halley steps, and the terms of a series or a continued fraction beyond the ``TERMS_PER_ROOT · √a`` it needs.
MAX_TERMS = 1000
TERMS_PER_ROOT = 20
#: Relative precision of the expansions and of the quantile.
EPS = float(np.finfo(float).eps)


def chi2_upper(tail: float | Array, dof: float | npt.ArrayLike) -> Array:
    """The value a χ² variable with ``dof`` degrees of freedom exceeds with probability ``tail``:
    ``chi2.ppf(1 − tail, dof)`` without the cancellation of ``1 − tail`` for a small tail; broadcast over both."""
    tails, dofs = np.broadcast_arrays(np.asarray(tail, dtype=float), np.asarray(dof, dtype=float))
    if tails.size > 1 and bool(np.all(tails == tails.flat[0])):  # one tail (the usual call): each dof solved once
        values, inverse = np.unique(dofs, return_inverse=True)
        solved = _quantiles(float(tails.flat[0]), values.tolist())
        return np.asarray(solved[inverse.reshape(-1)].reshape(tails.shape), dtype=np.float64)
    out = np.empty(tails.shape)
    pairs: dict[tuple[float, float], float] = {}
    for index, (t, d) in enumerate(zip(tails.ravel().tolist(), dofs.ravel().tolist(), strict=True)):
        if (t, d) not in pairs:
            pairs[(t, d)] = _quantile(t, d)
        out.flat[index] = pairs[(t, d)]
    return out


def _quantiles(tail: float, dofs: list[float]) -> Array:
    """:func:`_quantile` of one tail at each of ``dofs`` (ascending, distinct): each solve starts from the
    Wilson–Hilferty value times the ratio of root to that value extrapolated from the last two solved, which the
    ratio's smoothness in the degrees of freedom makes close enough for a single Halley step where they are close
    (the workspace's bounds: a hundred degrees of freedom between 1 and 3, started within 1e-5 or so)."""
    out = []  # Python floats: their arithmetic is several times numpy scalars'
    known: list[tuple[float, float]] = []  # (dof, its root over its Wilson–Hilferty start), the last two solved
    for dof in dofs:
        guess = _wilson_hilferty(tail, dof) if 0.0 < tail < 1.0 and 0.0 < dof < math.inf else math.nan
        ratio = 1.0
        if len(known) == 2:  # the ratio extrapolated linearly in the degrees of freedom
            (d0, r0), (d1, r1) = known
            ratio = r1 + (r1 - r0) * (dof - d1) / (d1 - d0)
        elif known:
            ratio = known[-1][1]
        out.append(_quantile(tail, dof, guess * ratio if 0.5 <= ratio <= 2.0 else guess))
        solved = out[-1] / (2.0 * guess)
        known = [*known, (dof, solved)][-2:] if 0.5 <= solved <= 2.0 else []  # NaN: none
    return np.array(out)


def _quantile(tail: float, dof: float, start: float | None = None) -> float:
    """``x`` with ``Q(dof/2, x/2) = tail`` (from ``start`` in ``x/2``, default Wilson–Hilferty's); NaN outside
    ``0 < tail < 1``, ``0 < dof < ∞``, and where the iteration fails (an underflow, no convergence)."""
    if not (0.0 < tail < 1.0 and 0.0 < dof < math.inf):
        return math.nan
    try:
        return _halley(tail, dof, _wilson_hilferty(tail, dof) if start is None or not start > 0.0 else start)
    except (OverflowError, ValueError, ZeroDivisionError):  # x under- or overflowed: no answer in doubles
        return math.nan


def _wilson_hilferty(tail: float, dof: float) -> float:
    """Wilson and Hilferty's approximation of the quantile, in ``x/2`` (at least 1e-300)."""
    z: float = -_normal_dist_inv_cdf(tail, 0.0, 1.0)  # the normal upper quantile, NormalDist().inv_cdf(tail): exact
    # for a small tail
    h = 2.0 / (9.0 * dof)
    return max(dof * (1.0 - h + z * math.sqrt(h)) ** 3, 1e-300) / 2.0


#: A Halley step at most this fraction of ``x`` (divided by ∛a for ``a = ν/2`` above 1) leaves an error of the order
#: of its cube (1e-15 of ``x``): the quantile is taken without evaluating ``Q`` once more.
CUBIC_STEP = 1e-5


def _halley(tail: float, dof: float, x: float) -> float:
    """:func:`_quantile`'s iteration from ``x`` (in ``x/2``; it may raise where the doubles run out): Halley's method
    on ``f = log Q − log tail``, whose derivatives follow from ``Q``'s, ``f′ = −xᵃ⁻¹e⁻ˣ/(Γ(a) Q)`` and
    ``f″ = f′ ((a − 1)/x − 1 − f′)``."""
    a, target = dof / 2.0, math.log(tail)
    log_gamma = math.lgamma(a)
    cubic = CUBIC_STEP / max(a, 1.0) ** (1.0 / 3.0)  # the cube's factor grows as a (Q's width in x goes as √a)
    low, high = 0.0, math.inf
    for _ in range(MAX_TERMS):
        log_q = _log_upper_gamma(a, x, log_gamma)
        if log_q > target:
            low = x  # Q decreases with x: the root lies above
        else:
            high = x
        slope = -math.exp((a - 1.0) * math.log(x) - x - log_gamma - log_q)  # f′
        newton = (log_q - target) / slope if slope != 0.0 else math.inf
        correction = 1.0 - 0.5 * newton * ((a - 1.0) / x - 1.0 - slope)  # 1 − f f″ / (2 f′²)
        step = newton / correction if correction > 0.5 else newton  # Halley's step; Newton's far from the root
        nxt = x - step
        if not low < nxt < high:  # out of the bracket: halve it (double the low end while unbounded)
            nxt = (low + high) / 2.0 if math.isfinite(high) else max(2.0 * x, 1.0)
        elif abs(step) <= cubic * x and correction > 0.5:
            return 2.0 * nxt
        if abs(nxt - x) <= 4 * EPS * x:
            return 2.0 * nxt
        x = nxt
    return math.nan  # no convergence


def _log_upper_gamma(a: float, x: float, log_gamma: float) -> float:
    """``log Q(a, x)``, the regularised upper incomplete gamma function (``a > 0``, ``x > 0``; ``log_gamma``:
    ``log Γ(a)``)."""
    prefix = a * math.log(x) - x - log_gamma
    terms = MAX_TERMS + int(TERMS_PER_ROOT * math.sqrt(a))
    if x < a + 1.0:  # P(a, x) by its series; Q = 1 − P
        term = total = 1.0 / a
        for n in range(1, terms):
            term *= x / (a + n)
            total += term
            if abs(term) < abs(total) * EPS:
                break
        return math.log1p(-math.exp(prefix) * total)
    # Q(a, x) by its continued fraction (modified Lentz)
    tiny = 1e-300
    b = x + 1.0 - a
    c, d = 1.0 / tiny, 1.0 / b
    h = d
    for n in range(1, terms):
        an = -n * (n - a)
        b += 2.0
        d = an * d + b
        d = tiny if abs(d) < tiny else d
        c = b + an / c
        c = tiny if abs(c) < tiny else c
        d = 1.0 / d
        delta = d * c
        h *= delta
        if abs(delta - 1.0) < EPS:
            break
    return prefix + math.log(h)
