"""Levenberg–Marquardt machinery behind :func:`pincal.identification.solver.identify`: the steps one QR-reduced
SVD of the scaled Jacobian gives, Transtrum & Sethna's geodesic acceleration, and when a fit is done.

Weakly identifiable directions are strongly nonlinear: moving 0.1 mm along one changes the predictions more
at second order than at first (measured on a hexapod with pose data, κ 5e7), so plain LM crawls, each
smaller λ being rejected. :func:`accelerated` corrects the step for that curvature; :func:`settled` ends
the crawl once it cannot matter (an exact fit, or a cost at the noise level).
"""

from __future__ import annotations

import math

import numpy as np
import numpy.typing as npt
import scipy.linalg
import scipy.linalg.lapack

from pincal import linalg
from pincal.errors import ConvergenceError, DataError
from pincal.identification.problem import Prediction, Problem
from pincal.model.robot import SOLVE_TOLERANCE

Array = npt.NDArray[np.float64]

#: An error below this fraction of its measurement's stated σ counts as an exact fit when no step
#: decreases the cost: no measurement of that instrument could tell it from zero.
FLOOR_SIGMA_FRACTION = 0.1
#: FK closes the loops to ``SOLVE_TOLERANCE`` (1e-11 m, rad); the predictions carry that error amplified
#: through the passive joints and the arm (C_p⁺, lever arms). Errors up to this multiple of the FK
#: tolerance (1e-8 m, rad) are numerical, whatever the stated σ.
FK_AMPLIFICATION = 1e3
#: A fit LM is still crawling on stops once every error is within this multiple of the FK tolerance (1e-9 m,
#: rad): tighter than the floor above, so that what a user takes home reproduces the data to ~1 nm.
EXACT_FIT_AMPLIFICATION = 1e2
#: Geodesic acceleration (Transtrum & Sethna 2012): finite-difference step ``h`` of the directional second
#: derivative (their recommended 0.1), and the largest ``2‖a‖/‖v‖`` kept (their α; see :func:`accelerated`).
GEODESIC_H = 0.1
GEODESIC_ALPHA = 0.1
#: Once the cost is at the noise level, a remaining Gauss–Newton improvement of χ² below this is
#: statistically nil: the optimum lies inside the estimate's 1σ confidence region.
NOISE_LEVEL_DECREMENT = 1.0
#: Smallest residual level (½χ²·2/dof, in units of the stated σ²) taken for noise under a σ stated too large: a
#: residual below 0.1 % of the stated σ (RMS) is an exact fit's, which goes on to the numerical floor (noise-free
#: data leave about (1e-10 m / σ)², 1e-10 at σ = 10 µm).
CAUTIOUS_SIGMA = 1e-6
#: ... over the directions the data identify in practice: singular value of the weighted, scaled Jacobian at
#: least 1, i.e. an a-priori standard deviation at most the parameters' typical size. Along the others a
#: fit at the noise level only chases noise.
PRACTICAL_INFORMATION = 1.0


class Steps:
    """The scaled, weighted Jacobian ``J_s = diag(w) J diag(d)`` and residual ``r = diag(w) e`` at one iterate,
    reduced once, and the steps they give.

    One Householder QR of the augmented matrix, ``[J_s | r] = Q [R | Q_tᵀ r]`` (LAPACK ``geqrf``, in place of
    the only copy made), then the SVD of the small triangle ``R = U_R S Vᵀ`` (t × n, t = min(m, n)): the SVD
    of ``J_s`` is ``(Q_t U_R) S Vᵀ``, so its m × n left factor is never formed. Every trial of an iteration
    (each damping λ) reuses it, and the geodesic acceleration projects its second right-hand side with the
    Householder reflectors (:meth:`project`). ``lm`` and ``tsvd`` keep the singular values above
    ``rcond · s₁`` and above ``floor`` (absolute); ``ridge`` keeps them all.

    Args:
        jacobian: (m, n) Jacobian of the weighted residual w.r.t. the parameters [1/m, 1/rad].
        column_scales: (n,) typical sizes ``d`` [m, rad]: the step is in scaled variables ``z = x / d``.
        row_weights: (m,) robust-loss row weights ``w`` (square roots of the sample weights).
        residual: (m,) weighted residual ``e`` (dimensionless).
        solver, rcond, ridge, floor: The step rule and its truncation (see :mod:`pincal.identification.solver`).
    """

    def __init__(self, jacobian: Array, column_scales: Array, row_weights: Array, residual: Array, solver: str,
                 rcond: float, ridge: float, floor: float = 0.0) -> None:
        m, n = jacobian.shape
        augmented = np.empty((m, n + 1), order="F")  # the one m × n copy of J an iteration holds
        np.multiply(jacobian, column_scales, out=augmented[:, :n])
        augmented[:, :n] *= row_weights[:, None]
        np.multiply(row_weights, residual, out=augmented[:, n])
        t = min(m, n)
        self.rows = m
        self._householder: tuple[Array, Array] | None = None
        if m and n:
            (reflectors, tau), _ = scipy.linalg.qr(augmented, overwrite_a=True, mode="raw", check_finite=False)
            self._householder = (reflectors[:, :t], tau[:t])  # Q_t: the first t reflectors (r's own one is not needed)
            self.triangle = np.triu(reflectors[:t, :n])
            self.projected_residual = np.array(reflectors[:t, n])
            if not (np.all(np.isfinite(self.triangle)) and np.all(np.isfinite(self.projected_residual))):
                linalg.require_finite(jacobian, "the identification Jacobian")
                linalg.require_finite(residual, "the weighted residual")
                raise DataError("the QR reduction of the scaled identification Jacobian overflowed: check the "
                                "parameters' typical sizes and the data for values out of range")
        else:
            self.triangle, self.projected_residual = np.zeros((t, n)), np.zeros(t)
        u, s, vt = linalg.svd(self.triangle, "the scaled identification Jacobian (its QR triangle)")
        self.largest = float(s[0]) if s.size else 0.0
        keep = s > (0.0 if solver == "ridge" else max(rcond * self.largest, floor))
        self.u, self.s, self.vt = u[:, keep], s[keep], vt[keep]
        self.solver = solver
        self.ridge = ridge

    @property
    def smallest_damping(self) -> float:
        """The λ at which LM damping halves the step along the weakest kept direction: ``(s_k / s₁)²``."""
        return float((self.s[-1] / self.largest) ** 2) if self.s.size else 0.0

    @property
    def kept(self) -> int:
        """Number of directions the steps move along."""
        return int(self.s.size)

    def release(self) -> None:
        """Drop the Householder reflectors (the m × n part): :meth:`solve`, :meth:`decrement`, :meth:`along` and
        :meth:`gradient_norm` still work, :meth:`project` no longer does."""
        self._householder = None

    def project(self, vector: Array) -> Array:
        """``Q_tᵀ y`` for an (m,) vector ``y``: its coordinates in the basis of ``J_s``'s column space that
        :meth:`solve` takes (LAPACK ``ormqr`` with the stored reflectors)."""
        if self._householder is None:
            raise RuntimeError("the Householder reflectors were released; build the steps again to project")
        reflectors, tau = self._householder
        if not tau.size:
            return np.zeros(0)
        column = np.asfortranarray(vector, dtype=np.float64).reshape(-1, 1)
        projected, _, info = scipy.linalg.lapack.dormqr("L", "T", reflectors, tau, column, max(64, column.shape[1]))
        if info != 0:
            raise ConvergenceError(f"applying the QR reflectors of the scaled identification Jacobian failed "
                                   f"(LAPACK dormqr info {info})")
        return np.asarray(projected[:tau.size, 0], dtype=np.float64)

    def along(self, v: Array) -> Array:
        """``Q_tᵀ J_s v = R v``: the scaled step ``v``'s first-order change of the residual, projected."""
        return np.asarray(self.triangle @ v, dtype=np.float64)

    def solve(self, lam: float, projected: Array | None = None) -> Array:
        """The scaled step for the residual (or for the right-hand side whose :meth:`project` is ``projected``):
        ``-Σ_i v_i s_i/(s_i² + μ) u_iᵀ r`` with ``μ = λ s₁²`` (``lm``), 0 (``tsvd``) or the ridge parameter
        (``ridge``: ``(J_sᵀJ_s + μI) δz = -J_sᵀ r``)."""
        if not self.s.size:
            return np.zeros(self.vt.shape[1])
        rhs = self.projected_residual if projected is None else projected
        damping = {"lm": lam * self.largest**2, "tsvd": 0.0}.get(self.solver, self.ridge)
        gain = self.s / (self.s**2 + damping)
        return np.asarray(-(self.vt.T @ ((self.u.T @ rhs) * gain)), dtype=np.float64)

    def decrement(self, information: float = 0.0) -> float:
        """``‖U_kᵀ r‖²``: twice the cost decrease a full Gauss–Newton step would predict, and the squared
        length of that step in the metric of the parameters' covariance (in σ units when the rows are
        weighted by 1/σ) — the Newton decrement [dimensionless]. Only over the directions whose singular
        value is at least ``information`` (a-priori standard deviation at most 1/information typical sizes)."""
        chosen = self.s >= information
        return float(np.sum((self.u[:, chosen].T @ self.projected_residual) ** 2))

    def gradient_norm(self) -> float:
        """``‖J_sᵀ r‖ = ‖Rᵀ Q_tᵀ r‖``: the cost's gradient in scaled variables."""
        return float(np.linalg.norm(self.triangle.T @ self.projected_residual))


def evaluated(problem: Problem, x: Array, jacobian: bool = True) -> Prediction | None:
    """The problem at ``x``, or None where it cannot be evaluated (FK fails, a sample turns singular)."""
    if not np.all(np.isfinite(x)):
        return None
    try:
        return problem.evaluate(x, jacobian=jacobian)
    except (ConvergenceError, DataError):  # an unusable step: rejected like one that raises the cost
        return None


def accelerated(problem: Problem, x: Array, d: Array, rw: Array, v: Array, steps: Steps, lam: float) -> Array | None:
    """The LM step ``v`` (scaled) with Transtrum & Sethna's geodesic acceleration, ``v + a/2``; None if the
    model cannot be evaluated along ``v``.

    Transtrum & Sethna, "Geodesic acceleration and the small-curvature approximation for nonlinear least
    squares" (2012): ``a = -(J_sᵀJ_s + μ)⁻¹ J_sᵀ r_vv`` with the directional second derivative
    ``r_vv ≈ (2/h)((r(z + h v) − r(z))/h − J_s v)`` (one residual evaluation, no Jacobian), here only its
    projection ``Q_tᵀ r_vv`` (all the step needs, see :class:`Steps`). They accept the
    step only if ``2‖a‖/‖v‖ ≤ α``. Here the curvature that moving along a weakly identifiable direction
    creates is mostly undone by the well identified ones, while the weak components of ``a`` (``r_vv``
    amplified by ``1/s``) are not to be trusted: instead of rejecting the step, ``a`` is damped (μ raised
    from ``λ s₁²`` by tens) until it is a small correction, ``2‖a‖ ≤ α‖v‖``; the cost test then decides.
    """
    norm_v = float(np.linalg.norm(v))
    ahead = evaluated(problem, x + GEODESIC_H * d * v, jacobian=False)
    if ahead is None:
        return None
    r_vv = (2.0 / GEODESIC_H) * ((steps.project(rw * ahead.residual) - steps.projected_residual) / GEODESIC_H
                                 - steps.along(v))
    damping = lam
    while damping < 1.0:
        a = steps.solve(damping, r_vv)
        if 2.0 * float(np.linalg.norm(a)) <= GEODESIC_ALPHA * norm_v:
            return np.asarray(v + 0.5 * a, dtype=np.float64)
        damping *= 10.0
    return v


def exact_fit_floors(problem: Problem, sigma_fraction: float,
                     amplification: float = FK_AMPLIFICATION) -> dict[str, Array]:
    """Per measurement key, per error column: the error [m, rad] up to which a fit counts as exact,
    ``max(sigma_fraction · σ, amplification · SOLVE_TOLERANCE)`` with σ the measurement's stated
    standard deviation (``sigma_fraction`` 0: the numerical floor alone). Keys the problem names no
    measurement for (IKM closure rows) take the smallest floor, under the key ``""``."""
    numerical = amplification * SOLVE_TOLERANCE
    floors: dict[str, Array] = {}
    for m in getattr(problem, "measurements", []):
        floors[m.key] = np.maximum(sigma_fraction * m.row_sigmas(), numerical)
    floors[""] = np.array([min((float(np.min(f)) for f in floors.values()), default=numerical)])
    return floors


def at_floor(errors: dict[str, Array], floors: dict[str, Array]) -> bool:
    """Every finite error within its floor (see :func:`exact_fit_floors`)."""
    for key, err in errors.items():
        e = np.abs(np.asarray(err, dtype=float)).reshape(len(err), -1)
        floor = floors.get(key, floors[""])
        if floor.size != e.shape[1]:
            floor = np.full(e.shape[1], float(np.min(floor)))
        if np.any(np.isfinite(e) & (e > floor)):
            return False
    return True


def noise_scale(cost: float, dof: int, cautious: bool = True) -> float:
    """The variance of the noise the fit has reached, in units of the stated σ²: 1 when the cost is at the stated
    noise level (½χ² at least ¼ of the ``dof`` degrees of freedom); with ``cautious``, the residual's own level
    ``2 · cost / dof`` when it lies below that but above :data:`CAUTIOUS_SIGMA` (a σ stated larger than the noise, as
    a cautious engineer states it: the residual levels off there, and what remains is judged against its own noise);
    0 otherwise, and with no degree of freedom left (an exact fit is due, not a noise level)."""
    if dof <= 0:
        return 0.0
    level = 2.0 * cost / dof
    return 1.0 if level >= 0.5 else level if cautious and level >= CAUTIOUS_SIGMA else 0.0


def settled(steps: Steps, lam: float, cost: float, errors: dict[str, Array], numerical: dict[str, Array],
            rejected: bool, tol: float = 0.0, cautious: bool = True) -> str:
    """Why the fit needs no more LM steps, or ``""`` (``cost``: ½‖r‖², r the weighted residual ``steps`` holds).

    The first two stops are for the crawl along weakly identifiable, strongly nonlinear directions, where LM goes
    on decreasing the cost by little for many iterations; the third is the fit's decrease test, asked before a trial.

    - An exact fit: LM still damps the weakest kept direction (``λ ≥ (s_k/s₁)²``) and every error is within
      the numerical floor (what is left is below what FK reproduces).
    - At the noise level: LM has had to reject a step (``rejected``: the model is nonlinear on the scale
      of its steps) or some kept direction is hidden by the noise (singular value below
      :data:`PRACTICAL_INFORMATION`), the cost is at the noise level (½χ² at least ¼ of the degrees of
      freedom, i.e. χ² at least half what noise of the stated σ gives; never with no degree of freedom left,
      where an exact fit is due), and the Gauss–Newton model's whole
      remaining improvement of χ² along the directions the data do identify in practice, the decrement
      ``‖U_kᵀ r‖²`` over them, is below :data:`NOISE_LEVEL_DECREMENT`: no test could tell the estimate from
      the optimum, and the rest would only fit noise.
    - The fit's decrease test asked of the Gauss–Newton model before a trial is evaluated (the predicted reduction
      of MINPACK's ftol test, without its actual-reduction half): no step of the linearised model gains more than
      ``½‖U_kᵀ r‖²``; when that is at most ``tol · cost``, a trial would only measure the noise of the closed loops'
      solves (and cost an evaluation).
    """
    if lam >= steps.smallest_damping and at_floor(errors, numerical):
        return "converged (exact fit: every error within the numerical floor)"
    dof = steps.rows - steps.kept  # none (as many residuals as kept directions): an exact fit is due, not noise
    scale = noise_scale(cost, dof, cautious)
    information = PRACTICAL_INFORMATION * math.sqrt(scale)
    if steps.kept and scale > 0.0 and (rejected or steps.s[-1] < information) \
            and steps.decrement(information) <= NOISE_LEVEL_DECREMENT * scale:
        return "converged (what remains to gain is below the noise)"
    if 0.5 * steps.decrement() <= tol * max(cost, 1e-300):
        return "converged (predicted decrease below tol)"
    return ""
