"""What every identification method shares: the scaled Jacobian of an iterate reduced once and the steps it gives
(:class:`Steps`), the interface a method implements (:class:`Method`), evaluating a trial point, and when the errors
are at the numerical floor.

A method (:mod:`~pincal.identification.lm`, :mod:`~pincal.identification.tsvd`,
:mod:`~pincal.identification.ridge`) decides which singular values of the scaled Jacobian its steps move along and
how it damps them; :func:`pincal.identification.solver.identify` picks it by name from
:data:`pincal.identification.fitting.METHODS` and drives the iterations without asking which it is.
"""

from __future__ import annotations

from abc import ABC, abstractmethod
from typing import ClassVar, Self

import numpy as np
import numpy.typing as npt

from pincal import linalg
from pincal.errors import ConvergenceError, DataError
from pincal.identification.fit_options import StepOptions as StepOptions  # the methods read it here
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


class Method(ABC):
    """How one identification method steps from an iterate's reduced Jacobian (:class:`Steps`): which singular
    values it keeps, how it damps them, what it does after a rejected trial, and whether it may end the fit before
    a trial. The step along the kept singular triplets ``(s_i, u_i, v_i)`` of the scaled Jacobian is
    ``δz = -Σ_i v_i s_i/(s_i² + μ) u_iᵀ r``.

    One subclass per module, registered under its :attr:`name` in :data:`pincal.identification.fitting.METHODS`; one
    instance per fit, made by :meth:`configured`.
    """

    #: The name :func:`~pincal.identification.solver.identify` takes (``solver=``).
    name: ClassVar[str]

    @classmethod
    @abstractmethod
    def configured(cls, options: StepOptions) -> Self:
        """The method with the options it reads."""

    @abstractmethod
    def threshold(self, largest: float) -> float:
        """The steps move along the singular values of the scaled Jacobian above this (``largest``: s₁)."""

    @abstractmethod
    def damping(self, lam: float, largest: float) -> float:
        """``μ`` of the step at the damping parameter ``lam`` (``largest``: s₁)."""

    def rejected(self, lam: float, shrink: float) -> tuple[float, float, bool]:
        """After a rejected trial: the next trial's ``lam`` and step factor, and whether the steps are geodesically
        accelerated (:meth:`accelerated`) from then on. By default the same ``lam``, half the step, no acceleration."""
        return lam, shrink * 0.5, False

    def accelerated(self, problem: Problem, x: Array, d: Array, rw: Array, v: Array, steps: Steps,
                    lam: float) -> Array | None:
        """The scaled step ``v`` corrected for the model's curvature, once :meth:`rejected` has turned acceleration
        on; None if the model cannot be evaluated along ``v``. By default ``v`` itself."""
        return v

    def settled(self, steps: Steps, lam: float, cost: float, errors: dict[str, Array], numerical: dict[str, Array],
                rejected: bool, tol: float, cautious: bool) -> str:
        """Before an iteration's trials: why the fit needs no more steps, or ``""``. By default never (the tests after
        an accepted step decide)."""
        return ""


class Steps:
    """The scaled, weighted Jacobian ``J_s = diag(w) J diag(d)`` and residual ``r = diag(w) e`` at one iterate,
    reduced once, and the steps they give.

    One Householder QR of the augmented matrix, ``[J_s | r] = Q [R | Q_tᵀ r]`` (LAPACK ``geqrt``,
    :func:`pincal.linalg.householder`, in place of the only copy made), then the SVD of the small triangle
    ``R = U_R S Vᵀ`` (t × n, t = min(m, n)): the SVD of ``J_s`` is ``(Q_t U_R) S Vᵀ``, so its m × n left factor is
    never formed. Every trial of an iteration (each damping λ) reuses it, and the geodesic acceleration projects its
    second right-hand side with the Householder reflectors (:meth:`project`). The singular values kept are those above
    the method's :meth:`Method.threshold`.

    Args:
        jacobian: (m, n) Jacobian of the weighted residual w.r.t. the parameters [1/m, 1/rad].
        column_scales: (n,) typical sizes ``d`` [m, rad]: the step is in scaled variables ``z = x / d``.
        row_weights: (m,) robust-loss row weights ``w`` (square roots of the sample weights).
        residual: (m,) weighted residual ``e`` (dimensionless).
        method: The step rule: which singular values are kept, and their damping.
    """

    def __init__(self, jacobian: Array, column_scales: Array, row_weights: Array, residual: Array,
                 method: Method) -> None:
        m, n = jacobian.shape
        augmented = np.empty((m, n + 1), order="F")  # the one m × n copy of J an iteration holds
        np.multiply(jacobian, column_scales, out=augmented[:, :n])
        if not np.all(row_weights == 1.0):  # least squares weighs every row 1: the pass would change nothing
            augmented[:, :n] *= row_weights[:, None]
        np.multiply(row_weights, residual, out=augmented[:, n])
        t = min(m, n)
        self.rows = m
        self._householder: tuple[Array, Array] | None = None
        if m and n:
            reflectors, factors = linalg.householder(augmented, "the scaled identification Jacobian")
            self._householder = (reflectors[:, :t], factors[:t, :t])  # Q_t: the first t reflectors (not r's own)
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
        keep = s > method.threshold(self.largest)
        self.u, self.s, self.vt = u[:, keep], s[keep], vt[keep]
        self.method = method

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
        :meth:`solve` takes (LAPACK ``gemqrt`` with the stored reflectors)."""
        if self._householder is None:
            raise RuntimeError("the Householder reflectors were released; build the steps again to project")
        reflectors, factors = self._householder
        if not factors.size:
            return np.zeros(0)
        projected = linalg.apply_householder(reflectors, factors, np.reshape(vector, (-1, 1)),
                                             "the scaled identification Jacobian")
        return np.asarray(projected[:factors.shape[1], 0], dtype=np.float64)

    def along(self, v: Array) -> Array:
        """``Q_tᵀ J_s v = R v``: the scaled step ``v``'s first-order change of the residual, projected."""
        return np.asarray(self.triangle @ v, dtype=np.float64)

    def solve(self, lam: float, projected: Array | None = None) -> Array:
        """The scaled step for the residual (or for the right-hand side whose :meth:`project` is ``projected``):
        ``-Σ_i v_i s_i/(s_i² + μ) u_iᵀ r`` with the method's damping ``μ`` at ``lam`` (:meth:`Method.damping`)."""
        if not self.s.size:
            return np.zeros(self.vt.shape[1])
        rhs = self.projected_residual if projected is None else projected
        damping = self.method.damping(lam, self.largest)
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
