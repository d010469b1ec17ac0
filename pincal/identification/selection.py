"""Model selection: keep the kinds of parameters the data support, and hold each as firmly as they say.

The policies (:data:`SELECTIONS`), each a fit of every candidate parameter first, then:

- ``evidence`` (the default with the automatic prior): every group held near nominal as firmly as its evidence says
  (:mod:`pincal.identification.evidence`), a group the data do not support left out;
- ``bic``: the groups the Bayesian information criterion keeps (:mod:`pincal.identification.criterion`), refitted;
- ``cv``: the groups whose combination predicts unseen samples best in 5-fold cross-validation (:func:`select_by_cv`);
- ``none``: every identifiable parameter.

With the automatic prior (``prior="auto"``) the groups kept by ``bic``, ``cv`` or ``none`` are held by the factors the
evidence chooses for them (:mod:`pincal.identification.evidence`), and every such prior passes the range guard
(:mod:`pincal.identification.guard`): held firmer when the fit's own range hold-outs predict worse than the nominal
robot.
"""

from __future__ import annotations

import itertools
import math
from collections.abc import Callable
from dataclasses import replace

import numpy as np
import numpy.typing as npt

from pincal.errors import DataError, PincalError, listing
from pincal.identification.chi2 import chi2_upper
from pincal.identification.criterion import (
    GROUPS,
    RSS_FLOOR,
    group_of,
    select_groups,
)
from pincal.identification.evidence import FACTOR_RANGE, EvidenceChoice, base_sigma, choose_prior
from pincal.identification.fit_options import FitOptions
from pincal.identification.guard import Guard, range_guard
from pincal.identification.predictions import carry_over
from pincal.identification.problem import CalibrationProblem, Observations
from pincal.identification.result import CalibrationResult
from pincal.identification.solver import identify_with
from pincal.records import record

Array = npt.NDArray[np.float64]

#: Model selection policies: ``evidence`` (each group held near nominal as firmly as the data's evidence says, left out
#: where they do not support it: :mod:`pincal.identification.evidence`), ``bic`` (the groups with the smallest
#: information criterion), ``cv`` (the groups with the smallest cross-validated error, :func:`select_by_cv`) or ``none``
#: (fit every identifiable parameter).
SELECTIONS = ("evidence", "bic", "cv", "none")
#: ``cv`` selection's plan: K folds of one shuffle of the samples, seeded (the same choice on every run).
CV_FOLDS = 5
CV_SEED = 0


@record
class SelectedFit:
    """A fit after model selection.

    Attributes:
        problem: The problem over the kept parameters (the one ``result`` solves).
        result: The fit over the kept parameters.
        first: The fit over every chosen parameter (its identifiability analysis names what the data cannot see).
        removed: Names of the identifiable parameters that selection held at their nominal value.
        scores: The criterion of each combination of groups scored, keyed by the groups it leaves out.
        removed_groups: The groups left out.
        evidence: The prior the evidence chose (its factor per group), or None when the prior was not automatic.
        prior_sigma: (p,) the prior σ of ``result``'s fit over ``problem``'s parameters [their units; inf: none], when
            the evidence chose it (None: the prior the options gave), the range guard's divisor applied.
        guard: What the range guard found (:mod:`pincal.identification.guard`), when the prior is automatic.
    """

    problem: CalibrationProblem
    result: CalibrationResult
    first: CalibrationResult
    removed: list[str]
    scores: dict[tuple[str, ...], float]
    removed_groups: tuple[str, ...] = ()
    evidence: EvidenceChoice | None = None
    prior_sigma: Array | None = None
    guard: Guard | None = None


def select_and_fit(problem: CalibrationProblem, policy: str = "bic", options: FitOptions | None = None) -> SelectedFit:
    """Fit every parameter of ``problem``, then leave out the groups of identifiable parameters the data do not
    support and refit the rest from the nominal start: by their evidence (``policy="evidence"``, which also chooses
    how firmly the prior holds each group kept), by :func:`select_groups` on the fit's weighted Jacobian (``bic``), by
    cross-validation (``cv``), or none. ``options`` (default: every default) go to
    :func:`~pincal.identification.solver.identify_with` for every fit; their ``prior`` may be
    :data:`~pincal.identification.fit_options.AUTO_PRIOR`: the
    first fit then has the kinds' prior σ (factor 1), and the groups kept get the factors the evidence chooses for them
    (:func:`~pincal.identification.evidence.choose_prior`).

    Raises:
        DataError: an unknown ``policy``, or ``evidence`` without the automatic prior.
    """
    if policy not in SELECTIONS:
        raise DataError(f"unknown selection '{policy}'; selections are: {listing(SELECTIONS)}")
    options = FitOptions() if options is None else options
    automatic = options.automatic_prior
    if policy == "evidence" and not automatic:
        raise DataError("selection by the evidence chooses the prior itself: give the automatic prior ('auto'), or "
                        "another selection (bic, cv, none) for a prior of your own", option="prior")
    options = options.single()
    first = identify_with(problem, options)
    if len(first.identified) < 2 or not first.converged:  # no choice made on a failed fit
        return SelectedFit(problem, first, first, [], {})
    if policy == "evidence":
        jac, y0 = _weighted_linear(problem, first)
        return _guarded(_refit_with_evidence(problem, first, jac, y0, options), options)
    if policy == "none":
        chosen = SelectedFit(problem, first, first, [], {})
    elif policy == "cv":
        chosen = select_by_cv(problem, first, options)
    else:
        jac, y0 = _weighted_linear(problem, first)
        pset = problem.parameters
        choice = select_groups(jac * pset.scales, y0, [group_of(p) for p in pset])
        chosen = SelectedFit(problem, first, first, [], choice.scores) if not choice.removed_groups \
            else _refit_without(problem, first, choice.removed_groups, choice.scores, _fitted_criterion, options)
    return _guarded(_with_evidence(chosen, automatic, options), options) if automatic else chosen


def _guarded(chosen: SelectedFit, options: FitOptions) -> SelectedFit:
    """``chosen`` (a fit with the evidence's prior) with its :func:`~pincal.identification.guard.range_guard`: refitted
    with the robot parameters' prior σ divided by the guard's divisor when that is not 1 (``chosen`` kept, the guard
    noted, when the refit fails)."""
    if chosen.prior_sigma is None or not chosen.result.converged:
        return chosen
    guard = range_guard(chosen.problem, chosen.result, chosen.prior_sigma)
    if guard is None or guard.firmer == 1.0:
        return replace(chosen, guard=guard)
    robot = np.array([group_of(p) is not None for p in chosen.problem.parameters])
    firmer = np.where(robot, chosen.prior_sigma / guard.firmer, chosen.prior_sigma)
    refit = identify_with(chosen.problem, replace(options, prior=firmer))
    if not refit.converged:
        return replace(chosen, guard=replace(guard, firmer=1.0))
    return replace(chosen, result=refit, prior_sigma=firmer, guard=guard)


def _weighted_linear(problem: CalibrationProblem, fit: CalibrationResult) -> tuple[Array, Array]:
    """The weighted Jacobian (its own copy) of ``fit``'s estimate (rows whitened by their σ and the robust weights)
    and the residual of the linear model it makes at the nominal parameters, ``r(x̂) − J x̂``."""
    pred = fit.final if fit.final is not None and fit.final.jacobian is not None else problem.evaluate(fit.x)
    assert pred.jacobian is not None
    rows = np.sqrt(fit.sample_weights[problem.row_samples()])
    jac = pred.jacobian * rows[:, None]
    return jac, pred.residual * rows - jac @ fit.x


def _with_evidence(chosen: SelectedFit, automatic: bool, options: FitOptions) -> SelectedFit:
    """``chosen`` refitted with the prior factors the evidence chooses for the groups it kept, when the prior is
    automatic; ``chosen`` itself otherwise."""
    if not automatic or not chosen.result.converged:
        return chosen
    jac, y0 = _weighted_linear(chosen.problem, chosen.result)
    fitted = _refit_with_evidence(chosen.problem, chosen.result, jac, y0, options, drop=False)
    removed = chosen.removed + [n for n in fitted.removed if n not in chosen.removed]
    groups = chosen.removed_groups + tuple(g for g in fitted.removed_groups if g not in chosen.removed_groups)
    return SelectedFit(fitted.problem, fitted.result, chosen.first, removed, chosen.scores, groups, fitted.evidence,
                       fitted.prior_sigma)


def _refit_with_evidence(problem: CalibrationProblem, first: CalibrationResult, jac: Array, y0: Array,
                         options: FitOptions, drop: bool = True) -> SelectedFit:
    """The groups of ``problem``'s parameters weighed by their evidence on the linear model ``jac``, ``y0``
    (:func:`_weighted_linear` at ``first``'s estimate): each held by the prior σ it chooses, left out where that is
    none (with ``drop``; else held by the smallest factor, as a named set's parameters stay); the refit from the nominal
    start, or ``first`` when it fails."""
    pset = problem.parameters
    groups = [group_of(p) for p in pset]
    present = [g for g in GROUPS if g in groups]
    base = base_sigma(problem)
    choice = choose_prior(jac, y0, groups, base, pset.scales, present)
    if not drop and choice.left_out:
        held = np.where([g in choice.left_out for g in groups], base * FACTOR_RANGE[0], choice.sigma)
        factors = {g: (FACTOR_RANGE[0] if g in choice.left_out else f) for g, f in choice.factors.items()}
        choice = replace(choice, sigma=held, left_out=(), factors=factors)
    kept = [k for k, g in enumerate(groups) if g not in choice.left_out]
    removed = [p.name for p in pset if group_of(p) in choice.left_out]
    if not kept:
        return SelectedFit(problem, first, first, [], {}, evidence=choice)
    reduced = _reduced(problem, kept) if removed else problem
    # the fit weighs the rows by their stated σ, the evidence by the noise they show (s²): its prior, in the fit's
    # units, is σ / s (the same maximum a posteriori estimate), whatever σ was stated
    weighed = choice.sigma[kept] / math.sqrt(max(choice.noise, 1e-300))
    refit = identify_with(reduced, replace(options, prior=weighed))
    if not refit.converged:
        return SelectedFit(problem, first, first, [], {}, evidence=choice)
    if removed and _worse_without(problem, first, refit, choice.noise):
        return _refit_with_evidence(problem, first, jac, y0, options, drop=False)
    return SelectedFit(reduced, refit, first, removed, {}, choice.left_out, choice, weighed)


#: The chance that fitting every parameter gains what :func:`_worse_without` finds by noise alone.
WORSE_TAIL = 1e-3


def _worse_without(problem: CalibrationProblem, first: CalibrationResult, refit: CalibrationResult,
                   noise: float) -> bool:
    """Whether ``refit`` (with groups left out) leaves the weighted squares of ``problem``'s rows above those of
    ``first`` (every parameter fitted) by more than noise explains: in the evidence's variance factor ``noise`` (s²),
    beyond the χ² of as many degrees of freedom as ``first`` estimates exceeds with probability :data:`WORSE_TAIL`.
    The linear model the evidence weighs can let another group stand for the one left out where the robot's own fit
    cannot (precise data on a small robot); the group is then kept, held by the smallest factor."""
    rows = problem.row_samples()
    if first.final is None or refit.final is None or not first.final.residual.size == refit.final.residual.size \
            == rows.size:  # an implicit fit's rows are not its samples'
        return False

    def squares(fit: CalibrationResult) -> float:
        assert fit.final is not None
        return float(np.sum(fit.sample_weights[rows] * fit.final.residual**2))

    estimated = max(len(problem.parameters), 1)
    return squares(refit) - squares(first) > float(chi2_upper(WORSE_TAIL, estimated)) * max(noise, 1e-300)


def _reduced(problem: CalibrationProblem, kept: list[int], observations: Observations | None = None
             ) -> CalibrationProblem:
    """``problem`` over the parameters ``kept`` (indices), on ``observations`` (default: its own)."""
    reduced = CalibrationProblem(problem.robot, problem.parameters.subset(kept), problem.measurements,
                                 problem.observations if observations is None else observations,
                                 None if problem.joint_sigma is None else list(problem.joint_sigma), problem.payload)
    if observations is None:  # the same samples: their last configurations start its solves
        carry_over(problem, reduced)
    return reduced


def _refit_without(problem: CalibrationProblem, first: CalibrationResult, removed_groups: tuple[str, ...],
                   scores: dict[tuple[str, ...], float],
                   criterion: Callable[[CalibrationProblem, CalibrationResult], float] | None,
                   options: FitOptions) -> SelectedFit:
    """The fit without ``removed_groups``, refitted from the nominal start; ``first`` kept instead when the refit
    fails or scores worse on ``criterion`` (None: no such check)."""
    pset = problem.parameters
    # a left-out group goes whole, its unidentifiable members too; everything else stays as chosen (the base
    # entire, so that the start registers the measurement frame as before)
    removed = [p.name for p in pset if group_of(p) in removed_groups]
    kept = [k for k, p in enumerate(pset) if group_of(p) not in removed_groups]
    if not kept:
        return SelectedFit(problem, first, first, [], scores)
    reduced = _reduced(problem, kept)
    refit = identify_with(reduced, options)
    # the choice was made on the fit linearized at its estimate; the refit starts from the nominal robot, where fewer
    # directions may be identifiable (a planar four-bar's anchor rotations): kept only if it scores better for real
    if not refit.converged or (criterion is not None and criterion(reduced, refit) > criterion(problem, first)):
        return SelectedFit(problem, first, first, [], scores)
    return SelectedFit(reduced, refit, first, removed, scores, removed_groups)


def select_by_cv(problem: CalibrationProblem, first: CalibrationResult, options: FitOptions) -> SelectedFit:
    """Leave out the groups of parameters whose combination predicts unseen samples best: every combination of the
    groups present (:data:`GROUPS`) is fitted on :data:`CV_FOLDS` − 1 folds of the samples (one shuffle seeded
    :data:`CV_SEED`) and scored by the mean square of the weighted residuals [σ²] it leaves on the fold left out,
    over every fold; the smallest wins (on equal scores, the one with fewer parameters), and is refitted on every
    sample. A combination whose fit fails on some fold scores infinity. ``first`` is the fit of every parameter.
    ``options`` go to :func:`~pincal.identification.solver.identify_with`."""
    pset = problem.parameters
    groups = [group_of(p) for p in pset]
    present = [g for g in GROUPS if g in groups]
    n = problem.observations.n_samples
    k = min(CV_FOLDS, n)
    order = np.random.default_rng(CV_SEED).permutation(n)
    folds = [np.sort(order[f::k]) for f in range(k)]
    scores: dict[tuple[str, ...], float] = {}
    best: tuple[float, int, tuple[str, ...]] | None = None
    for size in range(len(present) + 1):
        for drop in itertools.combinations(present, size):
            kept = [j for j, g in enumerate(groups) if g not in drop]
            if not kept:
                continue
            scores[drop] = _cross_validated(problem, kept, folds, options)
            if best is None or (scores[drop], len(kept)) < best[:2]:
                best = (scores[drop], len(kept), drop)
    if best is None or not best[2] or not math.isfinite(best[0]):
        return SelectedFit(problem, first, first, [], scores)
    return _refit_without(problem, first, best[2], scores, None, options)


def _cross_validated(problem: CalibrationProblem, kept: list[int], folds: list[npt.NDArray[np.int64]],
                     options: FitOptions) -> float:
    """The mean square of the weighted residuals [σ²] that fits of the parameters ``kept`` on all folds but one leave
    on the one left out, over every fold (infinity when a fold's fit fails)."""
    n = problem.observations.n_samples
    total, rows = 0.0, 0
    for test in folds:
        train = np.setdiff1d(np.arange(n), test)
        try:
            fit = identify_with(_reduced(problem, kept, problem.observations.subset(train)), options)
            residual = _reduced(problem, kept, problem.observations.subset(test)).evaluate(fit.x, jacobian=False)
        except PincalError:
            return math.inf
        total += float(residual.residual @ residual.residual)
        rows += residual.residual.size
    return total / rows if rows else math.inf


def _fitted_criterion(problem: CalibrationProblem, result: CalibrationResult) -> float:
    """:func:`information_criterion`'s value for a nonlinear fit: its weighted residual (robust weights included)
    and its number of identified parameters."""
    weights = np.sqrt(result.sample_weights[problem.row_samples()])
    final = result.final if result.final is not None else problem.evaluate(result.x, jacobian=False)
    residual = final.residual * weights
    m, p = residual.size, len(result.identified)
    return float(m * math.log(max(float(residual @ residual) / m, RSS_FLOOR)) + p * math.log(m))


def fold_prior(fitted: SelectedFit) -> Callable[[npt.NDArray[np.intp]], Array] | None:
    """For a fit whose prior the evidence chose: the prior σ [parameter units] the evidence chooses on a subset of its
    samples (the sample indices it is given), linearised at the fit (:func:`_weighted_linear`; one accelerated fixed
    point over the kept groups, no evaluation): the fit's own prior σ times the ratio of the evidence's choice on
    those samples to its choice, so linearised, on all of them (the range guard's divisor kept): what a hold-out refit
    would be held by had the selection seen only its samples. The predicted bound's hold-outs refit with it
    (:func:`~pincal.calibration.growth.estimate_growth`), so that the bound sees how much the choice varies with the
    samples. None when the prior was not the evidence's."""
    if fitted.evidence is None or fitted.prior_sigma is None or not fitted.result.converged:
        return None
    problem = fitted.problem
    jac, y0 = _weighted_linear(problem, fitted.result)
    pset = problem.parameters
    groups = [group_of(p) for p in pset]
    present = [g for g in GROUPS if g in groups]
    base = base_sigma(problem)
    rows = problem.row_samples()
    if jac.shape[0] != rows.size:  # an implicit fit's rows are not its samples'
        return None
    held = fitted.prior_sigma

    def chosen(kept: npt.NDArray[np.bool_]) -> Array:
        choice = choose_prior(jac[kept], y0[kept], groups, base, pset.scales, present, accelerated=True)
        sigma = np.where([g in choice.left_out for g in groups], base * FACTOR_RANGE[0], choice.sigma)
        return np.asarray(sigma / math.sqrt(max(choice.noise, 1e-300)), dtype=float)

    whole = chosen(np.ones(rows.size, dtype=bool))
    usable = np.isfinite(whole) & (whole > 0.0) & np.isfinite(held)

    def prior(samples: npt.NDArray[np.intp]) -> Array:
        ratio = np.where(usable, chosen(np.isin(rows, samples)) / np.where(usable, whole, 1.0), 1.0)
        return np.asarray(held * ratio, dtype=float)

    return prior
