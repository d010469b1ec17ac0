"""One fit: a method's iterations from a start until they converge, then the estimate's identifiability and
uncertainty.

The problem is solved in scaled variables ``z = x / s`` (s: typical sizes, metres and radians differ by orders of
magnitude). By default the steps move only along the directions the data can see: the SVD of the scaled (and
robust-weighted) Jacobian at the current iterate, truncated at ``rank_tol`` relative to its largest singular value
(and at ``min_information`` absolute, if set). Parameters caught in unidentifiable combinations then take
minimum-norm values, and the report names the combinations. (Pinning the dependent parameters at their start instead
would leave a second-order misfit: the symmetry orbits are curved, so that linear section misses the truth.)

The method is chosen by name from :data:`METHODS` (one module each, :mod:`pincal.identification.steps` for what they
share) and the loss from :data:`~pincal.identification.losses.IMPLEMENTED_LOSSES`; the loop never asks which it has.
Each iteration reduces ``[J_s | r]`` by one QR and takes the SVD of its small triangle
(:class:`pincal.identification.steps.Steps`), reused for every trial; a trial point is evaluated without the Jacobian,
which is computed once a step is accepted, but for the first trial of an iteration while no first trial has been
rejected (then it is evaluated with its Jacobian: a closed-loop robot's residual costs most of a full evaluation).
Before each iteration's trials the method may end the fit (:meth:`~pincal.identification.steps.Method.settled`).
Every SVD goes through :mod:`pincal.linalg` (no ``LinAlgError``). :func:`pincal.identification.solver.identify` is
the front that runs these fits (the robust ``auto`` plan, the refits).
"""

from __future__ import annotations

import math
import time
from collections.abc import Sequence

import numpy as np
import numpy.typing as npt

from pincal import linalg
from pincal.errors import DataError, IdentifiabilityError
from pincal.identification.choices import LOSSES
from pincal.identification.fit_options import FitOptions
from pincal.identification.identifiability import Identifiability, analyse, correlations, covariance
from pincal.identification.lm import LevenbergMarquardt
from pincal.identification.losses import IMPLEMENTED_LOSSES, Weighting, row_weights, sample_weights
from pincal.identification.parameters import ParameterSet
from pincal.identification.prior import WithPrior, prior_sigma
from pincal.identification.problem import Prediction, Problem
from pincal.identification.result import CalibrationResult
from pincal.identification.ridge import Ridge
from pincal.identification.steps import (
    EXACT_FIT_AMPLIFICATION,
    FLOOR_SIGMA_FRACTION,
    Method,
    Steps,
    at_floor,
    evaluated,
    exact_fit_floors,
)
from pincal.identification.tsvd import TruncatedSVD

Array = npt.NDArray[np.float64]

#: Every option at its default (:func:`fit`'s).
_DEFAULT = FitOptions()
#: The identification methods, by the name :func:`~pincal.identification.solver.identify` takes (``solver=``);
#: ``choices.SOLVERS`` lists the same names (:mod:`pincal.identification.choices`).
METHODS: dict[str, type[Method]] = {method.name: method for method in (LevenbergMarquardt, TruncatedSVD, Ridge)}
#: Relative cost change per step below which three steps in a row count as a stationary cost.
STATIONARY = 1e-6


def _practical_tol(jacobian: Array, scales: Array, rank_tol: float, min_information: float) -> float:
    """Relative rank tolerance with an absolute floor ``min_information`` on the singular values."""
    if min_information <= 0.0:  # no floor: no need for the Jacobian's norm (an SVD)
        return rank_tol
    largest = linalg.largest_singular_value(jacobian, scales, "the identification Jacobian")  # no copy
    if largest <= 0.0:
        return rank_tol
    return min(max(rank_tol, min_information / largest), 0.5)



def _chosen(solver: str, loss: str) -> tuple[type[Method], Weighting | None]:
    """The method and the loss's weighting of these names (:data:`METHODS`,
    :data:`~pincal.identification.losses.IMPLEMENTED_LOSSES`), or DataError listing the valid names."""
    if solver not in METHODS:
        raise DataError(f"unknown solver '{solver}'; solvers are: {', '.join(METHODS)}")
    if loss not in IMPLEMENTED_LOSSES:
        raise DataError(f"unknown loss '{loss}'; losses are: {', '.join(LOSSES)}")
    return METHODS[solver], IMPLEMENTED_LOSSES[loss]


def _check_start(jacobian: Array, parameters: ParameterSet, tol: float, strict: bool) -> None:
    """:func:`_check_identifiable` at the start (data rows' ``jacobian``, rank tolerance ``tol``): the rank alone (the
    singular values of ``J diag(s)``) unless it refuses, when the full analysis names what the data cannot see."""
    n, rows = len(parameters), jacobian.shape[0]
    scaled = linalg.triangle(jacobian, column_scales=parameters.scales) if rows >= n else jacobian * parameters.scales
    values = linalg.singular_values(scaled, "the scaled identification Jacobian")
    rank = int(np.count_nonzero(values > tol * values[0])) if values.size and values[0] > 0.0 else 0
    if (strict and rank < n) or rank == 0 or (rows < n and rank >= rows):
        ident = analyse(jacobian, parameters.names, parameters.scales, units=parameters.lengths_and_angles, tol=tol)
        _check_identifiable(ident, n, rows, strict)


def _check_identifiable(ident: Identifiability, n_parameters: int, n_residuals: int, strict: bool) -> None:
    """Refuse a start the data cannot fit from: with ``strict``, any unidentifiable parameter
    (IdentifiabilityError naming up to five combinations); always, no identifiable direction
    (IdentifiabilityError) or fewer residual rows than parameters when the rows themselves cap the rank (DataError:
    every row spent, more data would identify more; a rank below the row count is the model's own redundancy,
    which the analysis names, as with a default set of 52 candidates and 33 identifiable directions)."""
    if strict and ident.rank < n_parameters:
        words = "; ".join(c.description for c in ident.unidentifiable[:5])
        more = f" (and {len(ident.unidentifiable) - 5} more)" if len(ident.unidentifiable) > 5 else ""
        raise IdentifiabilityError(f"{ident.rank} of {n_parameters} parameters are identifiable from these data; not "
                                   f"identifiable: {words}{more}. Add postures or measurements, or choose fewer "
                                   "parameters.")
    if not ident.base_indices:
        raise IdentifiabilityError("the data identifies none of the parameters (rank 0)")
    if n_residuals < n_parameters and ident.rank >= n_residuals:
        raise DataError(f"{n_residuals} residuals cannot identify {n_parameters} parameters (study 000: the "
                        "number of measured values must be at least the number of parameters); add samples")


def fit(problem: Problem, x0: Array | None = None, options: FitOptions = _DEFAULT, loss: str = "linear",
        left_out: Sequence[int] = ()) -> CalibrationResult:
    """Estimate the parameters from the data.

    Args:
        problem: Robot, parameters, measurements and data.
        x0: Starting deviations [m, rad]; by default the problem's initial guess (the nominal robot,
            with an unknown measurement frame registered in closed form).
        options: The fit's options (:class:`~pincal.identification.fit_options.FitOptions`): its solver (``lm``,
            ``tsvd`` or ``ridge``: :data:`METHODS`), its steps, iteration limit and tolerance, ``strict`` and prior;
            its ``loss`` is :func:`~pincal.identification.solver.identify`'s plan, not this fit's. When no step
            decreases the cost, the fit counts as converged at a first-order optimum or when every error is within
            ``max(FLOOR_SIGMA_FRACTION · σ, FK_AMPLIFICATION · SOLVE_TOLERANCE)`` [m, rad]
            (:mod:`pincal.identification.steps`), σ the measurement's stated standard deviation.
        loss: This fit's loss: ``linear`` (least squares) or ``cauchy`` (robust to gross outliers)
            (:data:`~pincal.identification.losses.IMPLEMENTED_LOSSES`).
        left_out: Samples (indices) that weigh 0 whatever the loss (bad joint readings).

    Raises:
        DataError: unknown solver or loss, or fewer residuals than identifiable parameters.
        ConvergenceError: the model cannot be evaluated at the starting point, or an SVD fails with both
            LAPACK drivers (:mod:`pincal.linalg`).
    """
    chosen, weighting = _chosen(options.solver, loss)
    rank_tol, min_information, max_iter, tol = options.rank_tol, options.min_information, options.max_iter, options.tol
    start = time.perf_counter()
    pset = problem.parameters
    scales = pset.scales
    # its residual: the data's rows, then the prior's
    model = WithPrior(problem, prior_sigma(pset, options.fixed_prior()))
    x = problem.initial_guess() if x0 is None else np.array(x0, dtype=float)
    start_x = x.copy()
    pred = model.evaluate(x)
    data = model.data(pred)
    assert pred.jacobian is not None and data.jacobian is not None
    if not (np.all(np.isfinite(pred.residual)) and np.all(np.isfinite(pred.jacobian))):
        raise DataError("the residuals or their Jacobian are not finite at the starting point: check the data "
                        "for values out of range")
    errors_before = pred.errors
    _check_start(data.jacobian, pset, _practical_tol(data.jacobian, scales, rank_tol, min_information),
                 options.strict)
    d = scales
    weights = sample_weights(problem, data, weighting, left_out)
    rw = np.sqrt(model.row_weights(row_weights(problem, weights)))
    cost = 0.5 * float(np.sum((rw * pred.residual) ** 2))
    history = [cost]
    floors = exact_fit_floors(problem, FLOOR_SIGMA_FRACTION)
    numerical = exact_fit_floors(problem, 0.0, EXACT_FIT_AMPLIFICATION)
    method = chosen.configured(options)
    least_squares = weighting is None  # never re-weighted
    lam, converged, message, iterations, slow = 1e-3, False, "iteration limit reached", 0, 0
    accelerate = False  # geodesic acceleration: on once the method turns it on after a rejected step (LM)
    counts = {"rejected": 0, "evaluations": 1, "accelerated": 0}
    kept: list[int] = []
    eager_first = True  # evaluate the next first trial with its Jacobian (no first trial rejected yet)
    steps: Steps | None = None
    reduced: Array | None = None
    for it in range(1, max_iter + 1):
        assert pred.jacobian is not None
        steps = None  # the previous iteration's m × n reflectors go before this one's are built
        steps = Steps(pred.jacobian, d, rw, pred.residual, method)
        kept.append(steps.kept)
        if it > 1:
            settled = method.settled(steps, lam, cost, pred.errors, numerical, accelerate, tol, least_squares)
            if settled:
                converged, message = True, settled
                reduced = steps.triangle / d  # R of diag(w)·J at the estimate: the covariance's, on n rows
                break
        iterations = it
        accepted = False
        shrink = 1.0
        dz: Array | None = None
        new: Prediction | None = None
        for attempt in range(12):
            dz = steps.solve(lam) * shrink
            if accelerate:
                counts["evaluations"] += 1
                dz = method.accelerated(model, x, d, rw, dz, steps, lam)
                counts["accelerated"] += int(dz is not None)
            # a trial needs only the residual, and the Jacobian is computed once a step is accepted; but while the
            # first trials are accepted (the previous iteration's was) the first is evaluated with its Jacobian at
            # once: a closed-loop robot's residual alone costs most of a full evaluation
            eager = eager_first and attempt == 0
            if eager:
                steps.release()  # the m × n reflectors go before the trial's Jacobian is built
            trial = evaluated(model, x + d * dz, jacobian=eager) if dz is not None else None
            counts["evaluations"] += int(dz is not None)
            if trial is not None:
                new_cost = 0.5 * float(np.sum((rw * trial.residual) ** 2))
                if new_cost <= cost and eager:
                    new, accepted = trial, True
                    break
                if new_cost <= cost:
                    assert dz is not None
                    steps.release()  # the m × n reflectors go before the new Jacobian is built
                    new = evaluated(model, x + d * dz)  # None: a sample turned singular, rejected as before
                    counts["evaluations"] += 1
                    if new is not None:
                        accepted = True
                        break
                    steps = Steps(pred.jacobian, d, rw, pred.residual, method)
            if eager:  # a rejected eager trial: the next ones may need the reflectors (geodesic acceleration)
                trial = None  # its Jacobian goes first
                steps = Steps(pred.jacobian, d, rw, pred.residual, method)
            eager_first = False
            counts["rejected"] += 1
            lam, shrink, accelerating = method.rejected(lam, shrink)
            accelerate = accelerate or accelerating
        if not accepted or new is None or dz is None:
            message = "no step decreases the cost (a local minimum, or the model cannot be evaluated nearby)"
            # at a first-order optimum (gradient negligible against ‖J‖‖r‖), or with every error below what
            # the measurements resolve and FK reproduces, this is convergence, not a failure
            grad = steps.gradient_norm()
            if at_floor(pred.errors, floors):
                converged, message = True, "converged (no further decrease at the numerical floor)"
            elif grad <= 1e-4 * steps.largest * math.sqrt(2 * cost):
                converged, message = True, "converged (at the least-squares optimum: no step decreases the cost)"
            break
        decrease = cost - new_cost
        step_size = float(np.linalg.norm(dz))
        x, pred, cost = x + d * dz, new, new_cost
        assert pred.jacobian is not None
        if not least_squares:
            weights = sample_weights(problem, model.data(pred), weighting, left_out)
            rw = np.sqrt(model.row_weights(row_weights(problem, weights)))
            cost = 0.5 * float(np.sum((rw * pred.residual) ** 2))
        history.append(cost)
        lam = max(lam / 10.0, 1e-20)
        if decrease <= tol * max(cost, 1e-300) or step_size <= tol or cost <= 1e-30:
            converged, message = True, "converged"
            break
        # weakly identifiable directions can keep LM creeping for many iterations with no effect on the
        # predictions: three steps in a row that change the cost by < 1e-6 relative, or — once the residual
        # is at the noise level (½χ² comparable to the number of rows) — by < 0.01 in ½χ², which no test
        # could tell from noise, make a stationary cost
        noise_level = cost > 0.05 * pred.residual.size
        slow = slow + 1 if decrease <= STATIONARY * max(cost, 1e-300) or (noise_level and decrease < 1e-2) else 0
        if slow >= 3:
            converged, message = True, "converged (cost stationary)"
            break
    # identifiability at the estimate: a special nominal geometry (parallel axes) can hide directions
    # that the generic true robot shows
    steps = None  # its m × n reflectors are not needed any more
    data = model.data(pred)
    assert pred.jacobian is not None and data.jacobian is not None
    ident = analyse(data.jacobian, pset.names, scales, units=pset.lengths_and_angles,
                    tol=_practical_tol(data.jacobian, scales, rank_tol, min_information))
    active = ident.base_indices
    sigma2, std, apriori, corr = _uncertainty(pred, rw, list(active), pset, model.rows, reduced)
    result = CalibrationResult(pset.names, start_x, x, std, list(active), ident, corr, iterations, converged, message,
                               history, errors_before, pred.errors,
                               weights, sigma2, time.perf_counter() - start, options.solver, loss, std_apriori=apriori,
                               extra={"rejected_steps": counts["rejected"], "evaluations": counts["evaluations"],
                                      "accelerated_steps": counts["accelerated"],
                                      "rank_changes": int(np.count_nonzero(np.diff(kept)))})
    result.final = Prediction(data.residual, data.jacobian, data.errors, data.predicted)
    return result


def _uncertainty(pred: Prediction, rw: Array, active: list[int], pset: ParameterSet, rows: int,
                 reduced: Array | None = None) -> tuple[float, Array, Array, Array]:
    """The a-posteriori variance factor σ² of the fit (weighted residual ``rw · r`` of its first ``rows`` rows, the
    data's, ``active`` parameters), the estimates' standard deviations (a posteriori and a priori, NaN outside
    ``active``) [parameter units] and their correlations, from every row (a prior's included: the posterior
    covariance); NaN when the active columns are dependent. ``reduced``: the triangle ``R`` (n columns) of the
    weighted Jacobian ``diag(rw) J`` when the last iteration made it (``RᵀR = Jᵀ diag(rw)² J``: the same
    covariance, from n rows instead of m)."""
    assert pred.jacobian is not None
    dof = max(int(np.count_nonzero(rw[:rows])) - len(active), 1)  # a sample left out (weight 0): no degree of freedom
    sigma2 = float(np.sum((rw[:rows] * pred.residual[:rows]) ** 2)) / dof
    std, apriori = np.full(len(pset), np.nan), np.full(len(pset), np.nan)
    try:
        jacobian, weights = (pred.jacobian, rw) if reduced is None else (reduced, None)
        shape = covariance(jacobian, 1.0, active, pset.names, row_weights=weights,  # (JᵀJ)⁻¹: σ² scales it
                           units=pset.lengths_and_angles)
    except IdentifiabilityError:
        return sigma2, std, apriori, np.full((len(active), len(active)), np.nan)
    std[active] = np.sqrt(sigma2 * np.diag(shape))
    apriori[active] = np.sqrt(np.diag(shape))
    return sigma2, std, apriori, correlations(shape)
