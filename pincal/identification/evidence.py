"""How firmly to hold each group of parameters near nominal, decided from the data: the evidence.

The prior (:mod:`pincal.identification.prior`) holds each parameter near its nominal value with its kind's σ (5 mm and
0.5° for a placement, 1° for a reading's zero) times one factor. No fixed factor serves every robot and campaign: a
robot whose geometry is off by a tenth of the prior's σ is better predicted with a prior ten times firmer, where one
off by millimetres needs the prior as it is. This module lets the data decide, group by group: the translations and
the rotations of the joint placements, the reading offsets, the harmonics and the compliances each get a factor
``f_g`` on their kinds' σ, chosen to maximise the *evidence* (the marginal likelihood, MacKay 1992, "Bayesian
interpolation"; type-II maximum likelihood) of the fit linearised at its estimate:

    z = J δ + ε,   δ_i ~ N(0, (f_g σ_i)²) for a parameter i of group g,   ε ~ N(0, s² I),

with ``J`` the weighted Jacobian [1/unit] (rows whitened by their σ and the robust loss's weights), ``z = J x̂ − r(x̂)``
the data the linear model sees at the nominal robot (δ = 0), and ``s²`` the rows' variance factor, estimated with the
factors. The setup (measurement frame, markers, cameras, targets, planes, device constants) has a flat prior: a tracker
may stand anywhere; it is integrated out (the restricted likelihood). With ``Λ`` the prior covariance of the parameters
of a prior, ``K = Λ⁻¹ + JᵀJ / s²`` (the setup's rows of ``Λ⁻¹`` zero), ``b = Jᵀz / s²`` and ``μ = K⁻¹ b`` (the maximum a
posteriori estimate of the linear model), over the m rows:

    −2 ln L = m ln s² + ln|Λ| + ln|K| + zᵀz / s² − bᵀ μ                                   (up to a constant)
    ∂(−2 ln L)/∂ ln f_g² = n_g − Σ_{i∈g} (K⁻¹_ii + μ_i²) / Λ_ii
    ∂(−2 ln L)/∂ ln s²   = m − (‖z − J μ‖² + tr(J K⁻¹ Jᵀ)) / s²

(the analytic gradient; ``tests/identification/test_evidence.py`` checks it against finite differences; the maximum is
found by MacKay's fixed point, :func:`_optimise`, where the gradient vanishes). A group whose
factor falls to the smallest searched is left out, as model selection leaves out a group, and named so. Compliance
has no prior of its kind: its σ here is the compliance that deflects the joint by :data:`COMPLIANCE_DEFLECTION` RMS
over the samples' gravity torques.
"""

from __future__ import annotations

import functools
import math
from collections.abc import Sequence

import numpy as np
import numpy.typing as npt

from pincal.errors import DataError
from pincal.identification.corrections import gravity_torques
from pincal.identification.parameters import ParameterSet
from pincal.identification.problem import CalibrationProblem
from pincal.linalg import lapack
from pincal.records import record

Array = npt.NDArray[np.float64]

#: The RMS deflection [rad, m] over the samples that a compliance's evidence scale stands for (the offset prior's 1°).
COMPLIANCE_DEFLECTION = {"rad": math.radians(1.0), "m": 0.005}
#: Smallest and largest factor on a group's σ the evidence is searched over.
FACTOR_RANGE = (1e-3, 10.0)
#: A group whose factor ends within this ratio of the smallest is left out (held at nominal).
LEFT_OUT = 1.5
#: Relative singular value below which a direction of the setup's columns is none (projected out of the rows).
SETUP_RANK = 1e-10


@record(frozen=True)
class EvidenceChoice:
    """The prior the evidence chooses.

    Attributes:
        factors: Per group present, its factor on the kinds' prior σ (0 for a group left out).
        sigma: (p,) each parameter's prior σ [its unit]: the factor times its base σ; inf for the setup (no prior);
            0 for a parameter of a group left out; inf for a group not among those chosen for.
        left_out: The groups left out, in the order given.
        noise: The rows' variance factor s² the evidence estimates (the a-posteriori variance factor of the linear
            model).
        log_evidence: ln L at the choice (up to a constant).
    """

    factors: dict[str, float]
    sigma: Array
    left_out: tuple[str, ...]
    noise: float
    log_evidence: float


def base_sigma(problem: CalibrationProblem) -> Array:
    """Each parameter's σ at factor 1 [its unit]: its kind's prior (:mod:`pincal.identification.prior`); for a
    compliance, the one that deflects its joint by :data:`COMPLIANCE_DEFLECTION` RMS over the samples' gravity torques;
    inf for the setup and kinds without one."""
    sigma = np.full(len(problem.parameters), math.inf)
    torques: Array | None = None
    for k, parameter in enumerate(problem.parameters):
        value = parameter.kind_class.prior.get(parameter.unit)
        if value is not None:
            sigma[k] = value
        elif parameter.kind_class.name == "compliance":
            if torques is None:
                torques = gravity_torques(problem.robot, problem.observations.actuated, problem.payload)
            column = problem.robot.actuated_joints.index(parameter.name.rsplit(".", 1)[0])
            rms = float(np.sqrt(np.mean(torques[:, column] ** 2)))
            unit = "m" if parameter.unit == "m/N" else "rad"
            sigma[k] = COMPLIANCE_DEFLECTION[unit] / rms if rms > 0.0 else math.inf
    return sigma


@record(frozen=True)
class _Linear:
    """The linear model the evidence is computed on, in scaled parameters (``δ / scale``), with the setup's flat
    directions projected out of the rows (the restricted likelihood: with one noise variance, the projection is
    orthogonal): only the products of the m rows are kept.

    Attributes:
        gram: (q, q) ``JᵀP J`` of the columns of a prior (P: the projection off the setup's columns).
        jz: (q,) ``JᵀP z``.
        zz: ``zᵀP z``.
        rows: The rows left, m less the setup's rank.
        base: (q,) those columns' σ at factor 1, scaled.
        members: Per group, its columns among them.
    """

    gram: Array
    jz: Array
    zz: float
    rows: int
    base: Array
    members: list[npt.NDArray[np.intp]]

    @functools.cached_property
    def base2(self) -> Array:
        """(q,) ``base²``, each round's variances at factor 1."""
        return np.asarray(self.base**2, dtype=float)

    @functools.cached_property
    def group(self) -> npt.NDArray[np.intp]:
        """(q,) each column's group, its index in ``members``."""
        group = np.zeros(self.base.size, dtype=np.intp)
        for g, columns in enumerate(self.members):
            group[columns] = g
        return group

    @functools.cached_property
    def identity(self) -> Array:
        """(q, q) the identity each round solves for ``K⁻¹`` (never written to)."""
        return np.eye(self.base.size)

    def variance(self, log_factor2: Array) -> Array:
        """(q,) the prior's variance of each column [scaled units²] at the groups' log-factors ``ln f_g²``:
        ``base² · f_g²`` (one ``exp`` per group)."""
        factor2 = np.array([math.exp(t) for t in log_factor2[:len(self.members)]])
        return np.asarray(self.base2 * factor2[self.group], dtype=float)


def _terms(linear: _Linear, log_factor2: Array, log_noise: float) -> tuple[float, Array, Array]:
    """−2 ln L and its gradient with respect to (ln f_g², ln s²); and μ (the linear model's estimate, scaled)."""
    s2 = math.exp(log_noise)
    variance = linear.variance(log_factor2)
    precision = 1.0 / variance
    factor = _cholesky(linear.gram / s2 + np.diag(precision))
    b = linear.jz / s2
    mu = _cho_solve(factor, b)
    log_det_k = 2.0 * float(np.sum(np.log(np.diag(factor[0]))))
    value = linear.rows * log_noise + float(np.sum(np.log(variance))) + log_det_k + linear.zz / s2 - float(b @ mu)
    k_inv = _cho_solve(factor, linear.identity)
    grad = np.zeros(len(linear.members) + 1)
    for g, columns in enumerate(linear.members):
        grad[g] = columns.size - float(np.sum((np.diag(k_inv)[columns] + mu[columns] ** 2) * precision[columns]))
    residual2 = linear.zz - 2.0 * float(mu @ linear.jz) + float(mu @ linear.gram @ mu)  # ‖P(z − J μ)‖²
    grad[-1] = linear.rows - (residual2 + float(np.sum(k_inv * linear.gram))) / s2
    return value, grad, mu


#: Jitter, relative to the largest diagonal term, added to a matrix round-off left short of positive definite (a prior
#: far weaker than the data on directions they cannot see), tried from the first until one factors.
JITTER = (1e-14, 1e-12, 1e-10, 1e-8)


def _cholesky(matrix: Array) -> tuple[Array, bool]:
    """The Cholesky factor of the symmetric positive definite ``matrix`` as ``scipy.linalg.cho_factor`` gives it (upper,
    the lower triangle left as it was), with the smallest :data:`JITTER` on its diagonal that lets it factor where
    round-off leaves it short. LAPACK's ``potrf`` called directly: the same factor without SciPy's checks and array
    wrappers, a fifth of a cross-validation's evidence (thousands of small factorisations)."""
    if not matrix.size:
        return np.zeros(matrix.shape), False
    top = max(float(matrix.diagonal().max()), 0.0)  # NaN stays NaN, as with np.max(..., initial=0.0)
    potrf = lapack().dpotrf
    # no jitter first: the matrix plus a zero of the sign of 0 · top, as the jittered sums below are made
    factor, info = potrf(matrix + 0.0 * top, lower=0, clean=0, overwrite_a=1)
    if info == 0:
        return np.asarray(factor, dtype=float), False
    for jitter in JITTER:
        factor, info = potrf(matrix + jitter * top * np.eye(len(matrix)), lower=0, clean=0, overwrite_a=1)
        if info == 0:
            return np.asarray(factor, dtype=float), False
    raise DataError("the evidence's matrix is not positive definite: the data and the prior leave a direction free")


def _cho_solve(factor: tuple[Array, bool], rhs: Array) -> Array:
    """``K⁻¹ rhs`` from :func:`_cholesky`'s factor of ``K`` (LAPACK ``potrs``, as ``scipy.linalg.cho_solve`` calls
    it)."""
    if not factor[0].size:
        return np.zeros(rhs.shape)
    out, info = lapack().dpotrs(factor[0], rhs, lower=int(factor[1]))
    if info != 0:
        raise DataError(f"the evidence's solve failed (LAPACK potrs info {info})")
    return np.asarray(out, dtype=float)


def _linear(jacobian: Array, y0: Array, groups: Sequence[str | None], present: Sequence[str], base: Array,
            scales: Array) -> _Linear:
    """The linear model over the columns of the groups ``present`` (the other groups held at nominal), the setup's
    (group None, or no finite base σ) projected out."""
    flat = np.array([g is None for g in groups]) | ~np.isfinite(base)
    prior = ~flat & np.array([g in present for g in groups])
    z = -y0
    J = jacobian[:, prior] * scales[prior]
    setup = jacobian[:, flat] * scales[flat]
    rank = 0
    if setup.shape[1]:
        u, values, _ = np.linalg.svd(setup, full_matrices=False)
        rank = int(np.count_nonzero(values > SETUP_RANK * values[0])) if values.size and values[0] > 0 else 0
        u = u[:, :rank]
        J = J - u @ (u.T @ J)  # the rows projected off the setup's directions: J'ᵀJ' stays positive semi-definite
        z = z - u @ (u.T @ z)
    kept_groups = [g for g, k in zip(groups, prior, strict=True) if k]
    members = [np.flatnonzero([g == name for g in kept_groups]) for name in present]
    return _Linear(J.T @ J, J.T @ z, float(z @ z), z.size - rank, base[prior] / scales[prior], members)


def choose_prior(jacobian: Array, y0: Array, groups: Sequence[str | None], base: Array, scales: Array,
                 present: Sequence[str], accelerated: bool = False) -> EvidenceChoice:
    """The factors of the groups ``present`` that maximise the evidence; a group whose factor reaches the smallest of
    :data:`FACTOR_RANGE` is left out (held at nominal: the data see nothing of it worth a correction).

    Args:
        jacobian: (m, p) weighted Jacobian [1/unit of each parameter] at the estimate (rows whitened by their σ and the
            robust weights).
        y0: (m,) weighted residual of the linear model at the nominal parameters: ``r(x̂) − J x̂``.
        groups: (p,) each column's group (None: the setup, flat prior).
        base: (p,) each parameter's σ at factor 1 [its unit] (:func:`base_sigma`; inf: flat).
        scales: (p,) the parameters' typical sizes [their unit] (the problem's scaling).
        present: The groups to choose factors for (the others are held at nominal).
        accelerated: Reach the maximum by the accelerated fixed point (:func:`_optimise`): the same maximum in a
            fraction of the rounds, where the plain rounds settle (they stop after :data:`ROUNDS` where they creep).

    Raises:
        DataError: no row of data.
    """
    if not y0.size:
        raise DataError("the evidence needs rows of data; there are none")
    members = [g for g in present if any(x == g and math.isfinite(b) for x, b in zip(groups, base, strict=True))]
    log_evidence, theta = _optimise(_linear(jacobian, y0, groups, members, base, scales), len(members), accelerated)
    chosen = dict(zip(members, np.exp(0.5 * theta[:-1]).tolist(), strict=True))
    left = tuple(g for g in members if chosen[g] <= LEFT_OUT * FACTOR_RANGE[0])
    factors = {g: 0.0 if g in left else f for g, f in chosen.items()}
    sigma = np.array([base[k] * factors[g] if g in factors and math.isfinite(base[k]) else math.inf
                      for k, g in enumerate(groups)])
    return EvidenceChoice(factors, sigma, left, math.exp(theta[-1]), log_evidence)


#: Most rounds of the fixed-point iteration, and the change of every log-parameter below which it has converged.
ROUNDS = 500
SETTLED = 1e-7
#: Longest extrapolation of the accelerated fixed point (:func:`_optimise`), in rounds' lengths.
LONGEST_STEP = 64.0


def _optimise(linear: _Linear, n_groups: int, accelerated: bool = False) -> tuple[float, Array]:
    """The maximum of ln L over (ln f_g², ln s²), the factors within :data:`FACTOR_RANGE`: (ln L, the
    log-parameters), from every factor 1 and the rows' mean square as s². MacKay's fixed point (1992, "Bayesian
    interpolation", eqs. 4.9–4.10, with one variance per group and the noise's): with ``γ_g = Σ_{i∈g} (1 − K⁻¹_ii /
    Λ_ii)`` the directions of group g the data determine, ``f_g² ← Σ_{i∈g} μ_i² / σ_i² / γ_g`` and ``s² ←
    ‖P(z − J μ)‖² / (rows − Σ_g γ_g)``; where a ``γ`` is too small to divide by, the expectation-maximisation step of
    the same fixed point, ``f_g² ← Σ_{i∈g} (μ_i² + K⁻¹_ii) / σ_i² / n_g`` and ``s² ← (‖P(z − J μ)‖² + tr(K⁻¹ JᵀPJ)) /
    rows``. Each round is one factorisation of the q × q matrix ``K``; at the fixed point the analytic gradient
    (:func:`_terms`) vanishes. With ``accelerated``, the rounds are accelerated by squared extrapolation (SQUAREM,
    Varadhan and Roland 2008, "Simple and globally convergent methods for accelerating the convergence of any EM
    algorithm"): from two rounds ``r`` (the first change) and ``v`` (the change of the change), a step
    ``−2α r + α² v`` with ``α = −‖r‖ / ‖v‖`` (between −1, two plain rounds, and −:data:`LONGEST_STEP`), then one round
    from there: the same fixed point in a few tens of rounds where a slow group (one creeping toward a small factor)
    takes hundreds or thousands. Without it, plain rounds (model selection's choice, as the published results were
    made)."""
    low, high = (2.0 * math.log(v) for v in FACTOR_RANGE)
    noise = math.log(max(linear.zz / max(linear.rows, 1), 1e-300))
    noise_low, noise_high = noise - 30.0, noise + 10.0
    lows, highs = np.array([low] * n_groups + [noise_low]), np.array([high] * n_groups + [noise_high])

    def bounded(t: Array) -> Array:  # as np.clip, NaN kept
        return np.asarray(np.minimum(np.maximum(t, lows), highs), dtype=float)

    theta = np.concatenate([np.zeros(n_groups), [noise]])
    rounds = 0
    while rounds < ROUNDS:
        first = bounded(_fixed_point(linear, theta))
        change = first - theta
        if abs(change).max() < SETTLED:
            theta = first
            break
        if not accelerated:
            theta = first
            rounds += 1
            continue
        second = bounded(_fixed_point(linear, first))
        rounds += 2
        if np.max(np.abs(second - first)) < SETTLED:
            theta = second
            break
        curve = second - first - change
        size = float(np.linalg.norm(curve))
        alpha = -float(np.linalg.norm(change)) / size if size > 0.0 else -1.0
        alpha = min(-1.0, max(alpha, -LONGEST_STEP))
        try:
            theta = bounded(_fixed_point(linear, bounded(theta - 2.0 * alpha * change + alpha**2 * curve)))
        except DataError:  # the extrapolation left the matrix short of positive definite: the plain rounds kept
            theta = second
        rounds += 1
    value = _terms(linear, theta[:-1], float(theta[-1]))[0]
    return -0.5 * value, theta


def _fixed_point(linear: _Linear, theta: Array) -> Array:
    """One round of :func:`_optimise`'s fixed point from the log-parameters ``theta`` (ln f_g², then ln s²)."""
    s2 = math.exp(theta[-1])
    variance = linear.variance(theta)
    factor = _cholesky(linear.gram / s2 + np.diag(1.0 / variance))
    mu = _cho_solve(factor, linear.jz / s2)
    k_inv = _cho_solve(factor, linear.identity)
    diag = k_inv.diagonal()
    residual2 = max(linear.zz - 2.0 * float(mu @ linear.jz) + float(mu @ linear.gram @ mu), 0.0)
    determined_terms = 1.0 - diag / variance
    signal_terms = mu**2 / linear.base2
    out = theta.copy()
    determined = 0.0
    for g, columns in enumerate(linear.members):  # sums as np.sum makes them (add.reduce), without its wrapper
        gamma = float(determined_terms[columns].sum())
        signal = float(signal_terms[columns].sum())
        if gamma > 1e-6 and signal > 0.0:
            out[g] = math.log(signal / gamma)
        else:  # the expectation-maximisation step
            out[g] = math.log(max(float(np.sum((mu[columns] ** 2 + diag[columns]) / linear.base2[columns]))
                                  / columns.size, 1e-300))
        determined += gamma
    free = linear.rows - determined
    if free > 1e-6 and residual2 > 0.0:
        out[-1] = math.log(residual2 / free)
    else:
        out[-1] = math.log(max((residual2 + float(np.sum(k_inv * linear.gram))) / max(linear.rows, 1), 1e-300))
    return out


def group_names(parameters: ParameterSet) -> list[str | None]:
    """Each parameter's selection group (None: the setup, which always stays)."""
    return [p.kind_class.selection_group(p) for p in parameters]
