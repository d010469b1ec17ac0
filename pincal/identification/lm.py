"""Levenberg–Marquardt (``solver="lm"``, the default of :func:`pincal.identification.solver.identify`): Levenberg's
damping of the truncated Gauss–Newton step, ``δz = -Σ_i v_i s_i/(s_i² + λ s_1²) u_iᵀ r``, over the directions the data
can see (the singular values of the scaled Jacobian above ``rank_tol · s₁`` and ``min_information``); λ ×10 after a
rejected trial, ÷10 after an accepted step.

Weakly identifiable directions are strongly nonlinear: moving 0.1 mm along one changes the predictions more
at second order than at first (measured on a hexapod with pose data, κ 5e7), so plain LM crawls, each
smaller λ being rejected. From the first rejected step on, :func:`accelerated` corrects the step for that curvature
(Transtrum & Sethna's geodesic acceleration, one residual evaluation per trial). Before each iteration's trials,
:func:`settled` may end the fit: an exact fit (every error within 100 × the FK tolerance, 1 nm); for noisy data, a
remaining Gauss–Newton improvement along the practically identified directions below one unit of χ² at the noise
level the residual shows, or at the stated one if that is smaller (these two end a crawl once it cannot matter);
and, for any fit, a Gauss–Newton model that predicts a decrease of at most ``tol`` times the cost (the decrease test,
asked before a trial is spent on it).
"""

from __future__ import annotations

import math
from typing import ClassVar, Self

import numpy as np
import numpy.typing as npt

from pincal.identification.problem import Problem
from pincal.identification.steps import Method, StepOptions, Steps, at_floor, evaluated
from pincal.records import record

Array = npt.NDArray[np.float64]

#: Geodesic acceleration (Transtrum & Sethna 2012): finite-difference step ``h`` of the directional second
#: derivative (their recommended 0.1), and the largest ``2‖a‖/‖v‖`` kept (their α; see :func:`accelerated`).
GEODESIC_H = 0.1
GEODESIC_ALPHA = 0.1
#: Once the cost is at the noise level, a remaining Gauss–Newton improvement of χ² below this is
#: statistically nil: the optimum lies inside the estimate's 1σ confidence region.
NOISE_LEVEL_DECREMENT = 1.0
#: Smallest residual level (½χ²·2/dof, in units of the stated σ²) taken for noise: a residual below 0.1 % of the
#: stated σ (RMS) is an exact fit's, which goes on to the numerical floor (noise-free
#: data leave about (1e-10 m / σ)², 1e-10 at σ = 10 µm).
CAUTIOUS_SIGMA = 1e-6
#: ... over the directions the data identify in practice: singular value of the weighted, scaled Jacobian at
#: least 1, i.e. an a-priori standard deviation at most the parameters' typical size. Along the others a
#: fit at the noise level only chases noise.
PRACTICAL_INFORMATION = 1.0


@record(frozen=True)
class LevenbergMarquardt(Method):
    """Levenberg–Marquardt on the directions the data can see: damping ``μ = λ s₁²``; after a rejected trial λ ×10
    and geodesic acceleration from then on (:func:`accelerated`); :func:`settled` may end the fit before a trial.

    Attributes:
        rcond: The steps move along the singular values above ``rcond · s₁`` (``rank_tol``; 1e-15 with
            ``identifiable_only`` off, where the damping alone keeps the unidentifiable directions in check) ...
        floor: ... and above this absolute floor (``min_information``; 0 with ``identifiable_only`` off).
    """

    name: ClassVar[str] = "lm"
    rcond: float = 1e-8
    floor: float = 0.0

    @classmethod
    def configured(cls, options: StepOptions) -> Self:
        """``rank_tol`` and ``min_information`` with ``identifiable_only`` (the default), else round-off only."""
        if not options.identifiable_only:
            return cls(1e-15, 0.0)
        return cls(options.rank_tol, options.min_information)

    def threshold(self, largest: float) -> float:
        """``max(rcond · s₁, floor)``."""
        return max(self.rcond * largest, self.floor)

    def damping(self, lam: float, largest: float) -> float:
        """``λ s₁²``: damping relative to the largest singular value, whatever the parameters' scale."""
        return lam * largest**2

    def rejected(self, lam: float, shrink: float) -> tuple[float, float, bool]:
        """λ ×10, the step not shrunk, and geodesic acceleration from then on."""
        return lam * 10.0, shrink, True

    def accelerated(self, problem: Problem, x: Array, d: Array, rw: Array, v: Array, steps: Steps,
                    lam: float) -> Array | None:
        """:func:`accelerated`."""
        return accelerated(problem, x, d, rw, v, steps, lam)

    def settled(self, steps: Steps, lam: float, cost: float, errors: dict[str, Array], numerical: dict[str, Array],
                rejected: bool, tol: float, cautious: bool) -> str:
        """:func:`settled`."""
        return settled(steps, lam, cost, errors, numerical, rejected, tol, cautious)


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


def noise_scale(cost: float, dof: int) -> float:
    """The variance of the noise the fit has reached, in units of the stated σ²: the residual's own level
    ``2 · cost / dof`` up to 1, the stated noise (a σ stated larger than the noise, as a cautious engineer states it,
    is judged by the noise the residual shows: the fit stops where a σ matching it would stop, for least squares and
    robust losses alike; a residual above the stated noise is judged by the stated σ, which is then the stricter);
    0 below :data:`CAUTIOUS_SIGMA` (an exact fit, due to go on to the numerical floor) and with no degree of freedom
    left (an exact fit is due, not a noise level)."""
    if dof <= 0:
        return 0.0
    level = 2.0 * cost / dof
    return min(level, 1.0) if level >= CAUTIOUS_SIGMA else 0.0


def settled(steps: Steps, lam: float, cost: float, errors: dict[str, Array], numerical: dict[str, Array],
            rejected: bool, tol: float = 0.0, cautious: bool = True) -> str:
    """Why the fit needs no more LM steps, or ``""`` (``cost``: ½‖r‖², r the weighted residual ``steps`` holds;
    ``cautious``, the :class:`~pincal.identification.steps.Method` interface's, is not read: the noise level is the
    residual's own for least squares and robust losses alike).

    The first two stops are for the crawl along weakly identifiable, strongly nonlinear directions, where LM goes
    on decreasing the cost by little for many iterations; the third is the fit's decrease test, asked before a trial.

    - An exact fit: LM still damps the weakest kept direction (``λ ≥ (s_k/s₁)²``) and every error is within
      the numerical floor (what is left is below what FK reproduces).
    - At the noise level: LM has had to reject a step (``rejected``: the model is nonlinear on the scale
      of its steps) or some kept direction is hidden by the noise (singular value below
      :data:`PRACTICAL_INFORMATION` in units of the noise reached), and the Gauss–Newton model's whole
      remaining improvement of χ² along the directions the data do identify in practice, the decrement
      ``‖U_kᵀ r‖²`` over them, is below :data:`NOISE_LEVEL_DECREMENT` in units of the noise the residual itself
      shows, or the stated one when that is smaller (:func:`noise_scale`; never with no degree of freedom left, where
      an exact fit is due): no test could tell the estimate from the optimum, and the rest would only fit noise. A σ
      stated too large stops the fit where a σ matching the residual does.
    - The fit's decrease test asked of the Gauss–Newton model before a trial is evaluated (the predicted reduction
      of MINPACK's ftol test, without its actual-reduction half): no step of the linearised model gains more than
      ``½‖U_kᵀ r‖²``; when that is at most ``tol · cost``, a trial would only measure the noise of the closed loops'
      solves (and cost an evaluation).
    """
    if lam >= steps.smallest_damping and at_floor(errors, numerical):
        return "converged (exact fit: every error within the numerical floor)"
    dof = steps.rows - steps.kept  # none (as many residuals as kept directions): an exact fit is due, not noise
    scale = noise_scale(cost, dof)
    information = PRACTICAL_INFORMATION * math.sqrt(scale)
    if steps.kept and scale > 0.0 and (rejected or steps.s[-1] < information) \
            and steps.decrement(information) <= NOISE_LEVEL_DECREMENT * scale:
        return "converged (what remains to gain is below the noise)"
    if 0.5 * steps.decrement() <= tol * max(cost, 1e-300):
        return "converged (predicted decrease below tol)"
    return ""
