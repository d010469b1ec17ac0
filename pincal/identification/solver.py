"""Identification: one front, :func:`identify`, over the methods and losses chosen by name.

One fit (:func:`pincal.identification.fitting.fit`) iterates a method of
:data:`~pincal.identification.fitting.METHODS` from a start: ``lm`` (:mod:`~pincal.identification.lm`,
Levenberg–Marquardt with geodesic acceleration), ``tsvd`` (:mod:`~pincal.identification.tsvd`, study 003) or
``ridge`` (:mod:`~pincal.identification.ridge`), along the directions the data can see. Losses
(:data:`pincal.identification.losses.IMPLEMENTED_LOSSES`) re-weight whole samples (IRLS); ``auto`` is this module's
plan on top of them. This module also refits while samples prove off the reference assembly, and once with the prior
weighed against the noise the data show. The names alone are in :mod:`pincal.identification.choices`.
"""

from __future__ import annotations

import contextlib
import functools
import math
import os
import threading
from collections.abc import Iterator, Sequence
from dataclasses import replace
from typing import TYPE_CHECKING, Any

import numpy as np
import numpy.typing as npt

from pincal import linalg, validation
from pincal.errors import ArgumentError, ConvergenceError
from pincal.identification import fitting
from pincal.identification.choices import Loss, Solver
from pincal.identification.fit_options import FitOptions
from pincal.identification.ikm import ChainProblem, ImplicitProblem, chain_blocks
from pincal.identification.losses import TRIM_KEEP, TRIMMED, outlier_samples, sample_squares
from pincal.identification.problem import Problem
from pincal.identification.readings import find_bad_readings
from pincal.identification.result import CalibrationResult, chained
from pincal.identification.steps import EXACT_FIT_AMPLIFICATION, at_floor, evaluated, exact_fit_floors

Array = npt.NDArray[np.float64]


if TYPE_CHECKING:
    from threadpoolctl import ThreadpoolController

    from pincal.identification.fit_options import FitPrior

#: The variables that, all "1" from the process's start (as the ``pincal`` command sets them), give every BLAS
#: library one thread: identification then has no thread count to limit.
ONE_THREAD = ("OMP_NUM_THREADS", "OPENBLAS_NUM_THREADS", "MKL_NUM_THREADS", "BLIS_NUM_THREADS")


@functools.cache
def _threadpools() -> ThreadpoolController:
    """The BLAS and OpenMP libraries loaded, found once per process: finding them reads every loaded library's
    description (~3 ms with Pinocchio and SciPy loaded, a tenth of a 60-sample Delta calibration). SciPy's LAPACK
    bindings are loaded first: they bring a BLAS of their own (``libscipy_openblas``), which a controller made before
    they load would leave on all its threads (a TALOS table-contact calibration: 2.4 s of CPU instead of 0.45 s on this
    2-core machine)."""
    from threadpoolctl import ThreadpoolController  # here: not imported by a process started on one thread

    linalg.lapack()
    return ThreadpoolController()


def one_blas_thread() -> contextlib.AbstractContextManager[Any]:
    """BLAS on one thread while identifying (and, from :func:`~pincal.calibration.pipeline.calibrate`, for the whole
    calibration): nothing to do where the environment gave it one from the start
    (:data:`ONE_THREAD`, as the command line does), else threadpoolctl's limit, held once for the process however many
    threads are inside (:func:`_held_limit`)."""
    if all(os.environ.get(name) == "1" for name in ONE_THREAD):
        return contextlib.nullcontext()
    return _held_limit()


#: The process's one limit: the lock, and [how many callers are inside, threadpoolctl's limiter or None].
_LIMIT_LOCK = threading.Lock()
_LIMIT: list[Any] = [0, None]


@contextlib.contextmanager
def _held_limit() -> Iterator[None]:
    """BLAS on one thread from the first caller's entry to the last one's exit. threadpoolctl's limits are the
    process's, and each limiter restores what it saw on entry: two calibrations overlapping in threads (a fleet on a
    thread pool) would otherwise leave the caller's BLAS on one thread for good."""
    with _LIMIT_LOCK:
        if _LIMIT[0] == 0:
            _LIMIT[1] = _threadpools().limit(limits=1, user_api="blas")
        _LIMIT[0] += 1
    try:
        yield
    finally:
        with _LIMIT_LOCK:
            _LIMIT[0] -= 1
            if _LIMIT[0] == 0:
                _LIMIT[1].restore_original_limits()
                _LIMIT[1] = None


def _check_arguments(problem: Any, x0: Any, options: FitOptions) -> None:
    """Refuse arguments of :func:`identify` of the wrong type or value, naming each (TypeError, ArgumentError)."""
    if not hasattr(problem, "parameters") or not hasattr(problem, "observations"):
        raise TypeError(f"problem={validation.shown(problem)}: expected a calibration problem (CalibrationProblem, "
                        "ImplicitProblem)")
    if x0 is not None:
        start = np.asarray(x0, dtype=float)
        if start.shape != (len(problem.parameters),) or not np.all(np.isfinite(start)):
            raise ArgumentError(f"x0 has shape {start.shape}{'' if np.all(np.isfinite(start)) else ' and NaN/inf'}: "
                                f"give {len(problem.parameters)} finite values [m, rad], one per parameter",
                                option="x0")
    validation.whole("max_iter", options.max_iter, 1)
    validation.real("tol", options.tol)  # 0: iterate until no step decreases the cost
    prior = options.fixed_prior()
    if prior is not None and np.ndim(prior):
        sigma = np.asarray(prior, dtype=float)
        if sigma.shape != (len(problem.parameters),) or np.any(np.isnan(sigma)) or np.any(sigma <= 0.0):
            raise ArgumentError(f"prior has shape {sigma.shape}: give {len(problem.parameters)} prior σ > 0 [parameter "
                                "units] (inf: none), one per parameter, or one factor", option="prior")
    else:
        validation.optional_real("prior", prior, strict=True)


#: Every option at its default: the keywords of :func:`identify` default to its fields.
_DEFAULT = FitOptions()


def identify(problem: Problem, x0: Array | None = None, solver: Solver = _DEFAULT.solver, loss: Loss = _DEFAULT.loss,
             *, identifiable_only: bool = _DEFAULT.identifiable_only, max_iter: int = _DEFAULT.max_iter,
             tol: float = _DEFAULT.tol, rank_tol: float = _DEFAULT.rank_tol,
             min_information: float = _DEFAULT.min_information, tsvd_rcond: float = _DEFAULT.tsvd_rcond,
             ridge: float = _DEFAULT.ridge, strict: bool = _DEFAULT.strict, prior: FitPrior = _DEFAULT.prior
             ) -> CalibrationResult:
    """Estimate the parameters from the data: :func:`identify_with` of the :class:`FitOptions` these keywords make
    (each described there and at :func:`~pincal.identification.fitting.fit`).

    ``loss="auto"`` (the default) fits by least squares, tests every sample against the noise level the
    fit shows (:func:`outlier_samples`) and, if any sample is implausible, refits with the Cauchy loss
    from the least-squares fit and from the starting point, and keeps the refit whose median sample
    residual is the smaller (clustered outliers pull the least-squares fit towards them); then a sample
    whose error one wrong joint reading explains is left out (weight 0) and the Cauchy fit redone
    (:func:`_without_bad_readings`); the result lists the samples it down-weighted.
    """
    return identify_with(problem, FitOptions(solver=solver, loss=loss, identifiable_only=identifiable_only,
                                             max_iter=max_iter, tol=tol, rank_tol=rank_tol,
                                             min_information=min_information, tsvd_rcond=tsvd_rcond, ridge=ridge,
                                             strict=strict, prior=prior), x0)


def identify_with(problem: Problem, options: FitOptions, x0: Array | None = None) -> CalibrationResult:
    """:func:`identify` with its options as one :class:`FitOptions` (the automatic prior as factor 1), from ``x0``
    [m, rad] (default: the problem's initial guess).

    Raises:
        TypeError: ``problem`` or ``options`` of the wrong type.
        ArgumentError: an option or ``x0`` out of range, naming it.
    """
    validation.instance("options", options, FitOptions, "FitOptions")
    options = options.single()
    _check_arguments(problem, x0, options)
    # the dense algebra here is small (hundreds × tens): multi-threaded BLAS only adds overhead, and
    # on a loaded 2-core machine it made identification ten times slower
    with one_blas_thread():
        return _identify_auto(problem, x0, options)


def _identify_auto(problem: Problem, x0: Array | None, options: FitOptions) -> CalibrationResult:
    if options.loss != "auto":
        return _identify(problem, x0, options, options.loss)
    first = _identify(problem, x0, options, "linear")
    first.loss = "auto (linear)"  # what was asked, and what it came to: least squares, no sample implausible
    # an exact fit has nothing to reject; judged on the numerical floor alone, not on the stated σ: a σ stated ten
    # times too large would put every real error under a tenth of it and skip the outlier test
    if at_floor(first.errors_after, exact_fit_floors(problem, 0.0)):
        first.extra["outlier_test"] = []
        return first
    # gross outliers can pull the least-squares fit where the loops no longer close: then every start is robust
    pred = first.final if first.final is not None else evaluated(problem, first.x, jacobian=False)
    suspects = outlier_samples(problem, pred, first.identifiability.rank) if pred is not None else []
    first.extra["outlier_test"] = suspects
    if pred is not None and not suspects:
        return first
    # the least-squares fit leans towards clustered outliers (samples of one region all off one way), and a
    # Cauchy refit from there can keep them; so can one from the start, where they pull as hard. A third start
    # fits only the best-fitting half of the samples (least trimmed squares from the start: a cluster that is
    # off by more than the nominal errors is left out). Each start is refit with the Cauchy loss, and the fit
    # whose median sample residual is the smallest is kept (least median of squares decides)
    # (a start from which the model cannot be evaluated, far from any assembly, is left out)
    # (the trimmed start needs twice as many rows in the kept half as parameters: fewer fit noise, not geometry)
    enough = TRIM_KEEP * problem.row_samples().size >= 2 * first.identifiability.rank
    trimmed = _attempt(problem, first.x0, options, TRIMMED) if enough else None
    starts = [first.x, first.x0] + ([trimmed.x] if trimmed is not None else [])
    fits = [fit for fit in (_attempt(problem, start, options, "cauchy") for start in starts)
            if fit is not None]
    scored = [(median, k) for k, median in enumerate(_median_sample_residual(problem, fit) for fit in fits)
              if math.isfinite(median)]
    if not scored:
        first.extra["outlier_test"] = suspects
        return first
    second = fits[min(scored)[1]]
    others = [fit for fit in fits if fit is not second] + ([trimmed] if trimmed is not None else [])
    second.extra["other_refit_iterations"] = sum(c.iterations for c in others)
    second.seconds += sum(c.seconds for c in others)
    second = chained(first, second)
    second.extra["first_pass_iterations"] = first.iterations
    second = _without_bad_readings(problem, second, options)
    second.loss = "auto (cauchy)"
    second.extra["outlier_test"] = suspects
    return second


def _without_bad_readings(problem: Problem, fit: CalibrationResult, options: FitOptions) -> CalibrationResult:
    """``fit`` (a Cauchy fit) redone from its start with weight 0 for the samples whose residual one wrong joint
    reading explains (:func:`~pincal.identification.readings.find_bad_readings`), listed in
    ``extra["bad_readings"]``; ``fit`` itself when there is none or the refit fails."""
    pred = fit.final if fit.final is not None else evaluated(problem, fit.x, jacobian=False)
    if pred is None:
        return fit
    linearised = None if pred.jacobian is None else (pred.jacobian, fit.sample_weights, fit.identified)
    bad, refit = find_bad_readings(problem, fit.x, pred.residual, fit.identifiability.rank,
                                   lambda left: _attempt(problem, fit.x0, options, "cauchy", left),
                                   linearised)
    if not bad or refit is None:
        return fit
    refit = chained(fit, refit)
    refit.extra.update({key: value for key, value in fit.extra.items() if key not in refit.extra})
    refit.extra["bad_readings"] = bad
    return refit


def _attempt(problem: Problem, x0: Array, options: FitOptions, loss: str,
             left_out: Sequence[int] = ()) -> CalibrationResult | None:
    """:func:`_identify`, or None when the model cannot be evaluated along the way (one of ``auto``'s robust
    starts may lead where the loops do not close)."""
    try:
        return _identify(problem, x0, options, loss, left_out)
    except ConvergenceError:
        return None


def _median_sample_residual(problem: Problem, fit: CalibrationResult) -> float:
    """Median over samples of the squared weighted residual norm at ``fit``'s estimate (the least-median-of-squares
    criterion: blind to up to half the samples being off), from its last evaluation where it kept one; infinite
    where the model cannot be evaluated."""
    pred = fit.final if fit.final is not None else evaluated(problem, fit.x, jacobian=False)
    if pred is None:
        return math.inf
    squares, dims = sample_squares(problem, pred.residual)
    return float(linalg.median(squares[dims > 0]))


#: Refits after samples were found off the reference assembly (each refit starts where the last ended).
MAX_RESETTLES = 3


def _identify(problem: Problem, x0: Array | None, options: FitOptions, loss: str,
              left_out: Sequence[int] = ()) -> CalibrationResult:
    """:func:`~pincal.identification.fitting.fit`, then refit while some sample's remembered configuration proves
    to be off the reference assembly at the estimate
    (:meth:`~pincal.identification.problem.CalibrationProblem.settle_assembly`): its residual was measured on the
    wrong robot posture, so the fit and its robust weights are redone. ``loss`` is this pass's (an implemented loss
    of :data:`~pincal.identification.losses.IMPLEMENTED_LOSSES`); ``left_out`` the samples that weigh 0."""
    result = _with_prior_weighed(problem, fitting.fit(problem, x0, options, loss, left_out), options, loss, left_out)
    result = _polished(problem, result, options, loss, left_out)
    moved_all: list[int] = []
    for _ in range(MAX_RESETTLES):
        moved = problem.settle_assembly(result.x)
        if not moved:
            break
        moved_all += moved
        try:
            result = chained(result, fitting.fit(problem, result.x, options, loss, left_out))
        except ConvergenceError:  # some sample does not assemble at all there: the caller decides
            result.final = None  # its configurations were reset after it: its residuals are not the problem's
            break
    if moved_all:
        result.extra["resettled_samples"] = sorted(set(moved_all))
    return result


#: The a-posteriori variance factor below which the data show less noise than stated, and the prior is weighed
#: against the noise they show.
QUIETER_THAN_STATED = 0.5


def _with_prior_weighed(problem: Problem, result: CalibrationResult, options: FitOptions, loss: str,
                        left_out: Sequence[int] = ()) -> CalibrationResult:
    """``result``, refit once from its estimate with the prior weighed against the noise the data show when they
    show much less than stated (a-posteriori factor ``s²`` below :data:`QUIETER_THAN_STATED`): each prior σ divided
    by ``s``, as if the data rows were whitened by the noise they show. A σ stated ten times too large would
    otherwise make the data look a hundred times less informative, and the prior pull what they see well. A fit
    short of the stated noise (``s² > 1``: a model error, or a σ stated too small) never makes the prior stronger."""
    factor = options.fixed_prior()
    if factor is None or np.ndim(factor) or not math.isfinite(result.sigma2) or result.sigma2 >= QUIETER_THAN_STATED:
        return result  # a prior of its own σ per parameter (the evidence's) was chosen against the noise already
    if at_floor(result.errors_after, exact_fit_floors(problem, 0.0, EXACT_FIT_AMPLIFICATION)):  # exact: no noise
        return result
    weighed = replace(options, prior=factor / math.sqrt(max(result.sigma2, 1e-300)))
    try:
        return chained(result, fitting.fit(problem, result.x0, weighed, loss, left_out))
    except ConvergenceError:  # the refit could not be evaluated: the first fit stands
        return result


#: The stop :func:`_polished` takes a camera's fit on from: LM's at the noise level, which discounts weakly seen
#: directions (:func:`pincal.identification.lm.settled`).
NOISE_LEVEL_STOP = "converged (what remains to gain is below the noise)"
#: The χ² decrease that makes :func:`_polished` keep its steps: the 99.9 % quantile of χ² with one degree of freedom
#: (a decrease no test could put down to the noise). A smaller one is left: the steps would move along a weakly seen
#: direction (a principal point against the camera's rotation) by what the noise decides, at no gain in the fit.
SIGNIFICANT_GAIN = 10.83


def _polished(problem: Problem, result: CalibrationResult, options: FitOptions, loss: str,
              left_out: Sequence[int] = ()) -> CalibrationResult:
    """``result`` taken on to the least-squares minimum when the problem has a camera's intrinsics and LM stopped at
    the noise level: a board's rotation on the hand is weakly seen and trades with the wrist's parameters, and the
    χ² LM leaves along it (about 15 on a Panda eye-to-hand campaign of 40 images) moves the held-out camera
    positions by far more than the noise (twice the error of a converged fit). Truncated-SVD steps from the estimate
    (no noise-level stop: they go on while ½χ² drops by 0.01) take it there; kept only when they lower χ² by more
    than :data:`SIGNIFICANT_GAIN`. Problems without intrinsics are left as they are."""
    if options.solver != "lm" or loss != "linear" or result.message != NOISE_LEVEL_STOP \
            or not any(p.kind == "intrinsics" for p in problem.parameters):
        return result
    try:
        polished = fitting.fit(problem, result.x, replace(options, solver="tsvd"), loss, left_out)
    except ConvergenceError:  # the steps led where the model cannot be evaluated: the LM fit stands
        return result
    if not polished.cost_history or not result.cost_history \
            or 2.0 * (result.cost_history[-1] - polished.cost_history[-1]) <= SIGNIFICANT_GAIN:
        return result
    polished = chained(result, polished)
    polished.solver, polished.message = result.solver, result.message
    polished.extra["polished"] = True
    return polished


def identify_chains(problem: ImplicitProblem, x0: Array | None = None,
                    options: FitOptions = _DEFAULT) -> list[tuple[list[str], CalibrationResult]]:
    """Identify each independent chain on its own (study 000's segment-by-segment IKM calibration),
    with ``options`` (:func:`identify_with`'s).

    Returns:
        Per chain: the loop names and its :class:`~pincal.identification.result.CalibrationResult`.
    """
    x = np.zeros(len(problem.parameters)) if x0 is None else np.asarray(x0, dtype=float).copy()
    jac = problem.evaluate(x).jacobian
    assert jac is not None
    names = list(problem.robot.closure.loop_slices())
    out = []
    for columns, loops in chain_blocks(problem, jac):
        chain = ChainProblem(problem, columns, loops, x)
        result = identify_with(chain, options, x[columns])
        x[columns] = result.x
        out.append(([names[i] for i in loops], result))
    return out
