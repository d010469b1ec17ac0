"""Model selection: keep only the kinds of parameters the data support.

With few postures a model with more parameters fits better and predicts worse: on the TIAGo arm data
(34 postures, one marker) the 33 identifiable parameters fit 2.46 mm and predict 4.7 mm in 5-fold
cross-validation; the same model without the joint axes' tilts and the reading offsets fits 2.83 mm and
predicts 4.0 mm.

The choice is among *groups* of parameters, not single parameters: the joint and anchor translations, their
rotations, the reading offsets, and the joint harmonics and compliances when they are chosen (:func:`group_of`);
the measurement frame, the markers and device constants always stay. Every combination of groups is scored by the
Bayesian information criterion of the fit linearized at the estimate (Schwarz 1978, "Estimating the dimension of a
model"): for the weighted linear model ``r(x) = y₀ + J x`` over the combination's independent columns (p of them)
and m residual rows, ``BIC = m ln(RSS/m) + p ln m``, with the noise level estimated from the residuals, so a wrong
stated σ does not bias the choice. The combination with the smallest BIC is refitted. Every combination is scored on
the triangle of one QR of the weighted Jacobian and residual (as many rows as parameters, whatever the samples), and
combinations whose columns span the same directions (a group that adds none) share one score; between them, the
round-off of the criterion computed on every row decides, as it did when every combination was scored on the rows.

Measured on the TIAGo data, in 5-fold × 4 cross-validation with the selection redone in every fold: BIC
4.09 mm, AICc 4.19, linearized 5-fold error 4.27, leave-one-out error (PRESS) 4.52, choosing parameter by
parameter by the leave-one-out error 5.4, no selection 4.7. Rows are weighted (1/σ and the robust loss' sample
weights), so down-weighted samples do not steer the choice.
"""

from __future__ import annotations

import itertools
import math
from collections.abc import Callable
from dataclasses import dataclass
from typing import Any

import numpy as np
import numpy.typing as npt
import scipy.linalg

from pincal import linalg
from pincal.errors import DataError, PincalError, listing
from pincal.identification.evidence import EvidenceChoice, base_sigma, choose_prior
from pincal.identification.identifiability import RANK_TOLERANCE
from pincal.identification.parameters import Parameter
from pincal.identification.predictions import carry_over
from pincal.identification.problem import CalibrationProblem, Observations
from pincal.identification.result import CalibrationResult
from pincal.identification.solver import identify

Array = npt.NDArray[np.float64]

#: The groups selection may leave out, in the order they are named.
GROUPS = ("translations", "rotations", "offsets", "harmonics", "compliance")


def group_of(parameter: Parameter) -> str | None:
    """The selection group of a parameter: ``translations`` or ``rotations`` of joint and anchor placements,
    ``offsets`` of joint readings, joint ``harmonics``, joint ``compliance``, or None for what always stays (base,
    markers, device constants): as its kind says
    (:meth:`~pincal.identification.parameters.ParameterKind.selection_group`)."""
    return parameter.kind_class.selection_group(parameter)


#: Relative floor on the residual mean square in the criterion: below it, fits differ by round-off only.
RSS_FLOOR = 1e-24


def information_criterion(jacobian: Array, y0: Array) -> float:
    """``m ln(RSS/m) + p ln m`` of the least-squares fit of ``y0 + J x`` (m rows, p columns, full column rank).

    Args:
        jacobian: (m, p) weighted Jacobian [1/unit of each parameter] (p may be 0).
        y0: (m,) weighted residual of the linear model at the nominal parameters (x = 0).

    Returns:
        The Bayesian information criterion (dimensionless; smaller is better).
    """
    m, p = jacobian.shape
    triangle = _reduced_rows(jacobian, y0)
    return _criterion(triangle[:, :p], triangle[:, p], m)


def _reduced_rows(jacobian: Array, y0: Array) -> Array:
    """``R`` (k × (p + 1), k = min(m, p + 1)) of the QR ``[J | y0] = Q R``: every least-squares fit of ``y0`` on
    columns of ``J`` has the residual norm of the same fit on the columns of ``R`` (``Q`` has orthonormal columns
    and ``y0`` lies in their span), and every set of ``J``'s columns the singular values of the same set of ``R``'s.
    The criteria of all the combinations of groups are then computed on k rows instead of m."""
    m, p = jacobian.shape
    if not m:
        return np.zeros((0, p + 1))
    augmented = np.empty((m, p + 1), order="F")  # the one copy, in the order LAPACK factors in place
    augmented[:, :p], augmented[:, p] = jacobian, y0
    factored, _ = linalg.householder(augmented, "the weighted identification Jacobian and the residual")
    return np.triu(factored[:min(m, p + 1)])


def _criterion(columns: Array, rhs: Array, m: int) -> float:
    """:func:`information_criterion` from the rows :func:`_reduced_rows` leaves: ``columns`` (k, p) the chosen
    columns of ``R``, ``rhs`` (k,) its last column, ``m`` the rows of the Jacobian they reduce."""
    p = columns.shape[1]
    if p:
        Q, _ = scipy.linalg.qr(columns, mode="economic", check_finite=False)
        residual = rhs - Q @ (Q.T @ rhs)
    else:
        residual = rhs
    mean_square = max(float(residual @ residual) / m, RSS_FLOOR * max(float(rhs @ rhs) / m, 1.0))
    return float(m * math.log(mean_square) + p * math.log(m))


def _independent(triangle: Array, columns: list[int], scale: float) -> list[int]:
    """The columns among ``columns`` that pivoted QR keeps as independent (pivot above :data:`RANK_TOLERANCE`
    × ``scale``, the largest singular value of the whole Jacobian), in their order; ``triangle``: the Jacobian's
    columns reduced by :func:`_reduced_rows` (the same pivots as the Jacobian's own)."""
    if not columns or scale == 0.0:
        return []
    _, R, pivots = scipy.linalg.qr(triangle[:, columns], mode="economic", pivoting=True, check_finite=False)
    rank = int(np.count_nonzero(np.abs(np.diag(R)) > RANK_TOLERANCE * scale))
    return sorted(columns[k] for k in pivots[:rank])


@dataclass(frozen=True)
class Selection:
    """The outcome of :func:`select_groups`.

    Attributes:
        kept: Column indices kept, ascending.
        removed_groups: The groups left out (in :data:`GROUPS` order).
        scores: The criterion of every combination scored, keyed by the groups it leaves out.
    """

    kept: list[int]
    removed_groups: tuple[str, ...]
    scores: dict[tuple[str, ...], float]


def select_groups(jacobian: Array, y0: Array, groups: list[str | None]) -> Selection:
    """The combination of parameter groups with the smallest :func:`information_criterion`.

    Args:
        jacobian: (m, p) weighted, scaled Jacobian of the parameters [dimensionless]; each combination is scored
            on its independent columns (pivoted QR).
        y0: (m,) weighted residual of the linear model at the nominal parameters: ``r(x̂) − J x̂``.
        groups: (p,) each column's group (:func:`group_of`; None: always kept).

    Returns:
        The :class:`Selection`; on equal scores the combination with fewer independent parameters wins. A
        combination whose columns span what a combination of fewer left-out groups spans (the same rank) takes that
        one's score (their fits are the same), and the one of fewer left-out groups stays: a group is left out only
        where that lowers the criterion, never on round-off (which decided between such equals once, and could
        decide otherwise on another machine).
    """
    present = [g for g in GROUPS if g in groups]
    m, p = jacobian.shape
    triangle = _reduced_rows(jacobian, y0)  # one QR of the m rows; every combination is scored on its k rows
    columns, rhs = triangle[:, :p], triangle[:, p]
    scale = float(np.linalg.norm(columns, 2)) if columns.size else 0.0
    scores: dict[tuple[str, ...], float] = {}
    ranks: dict[tuple[str, ...], int] = {}
    spans: dict[tuple[str, ...], tuple[str, ...]] = {}  # each combination -> the first one of its span
    best: tuple[float, int, tuple[str, ...]] | None = None
    for n in range(len(present) + 1):
        for drop in itertools.combinations(present, n):
            cols = _independent(columns, [k for k, g in enumerate(groups) if g not in drop], scale)
            ranks[drop] = len(cols)
            same = _same_span(drop, len(cols), ranks)
            spans[drop] = drop if same is None else spans[same]
            scores[drop] = scores[same] if same is not None else _criterion(columns[:, cols], rhs, m)
            if best is None or (scores[drop], len(cols)) < best[:2]:
                best = (scores[drop], len(cols), drop)
    assert best is not None
    chosen = spans[best[2]]
    return Selection([k for k, g in enumerate(groups) if g not in chosen], chosen, scores)


def _same_span(drop: tuple[str, ...], rank: int, ranks: dict[tuple[str, ...], int]) -> tuple[str, ...] | None:
    """A combination scored before that leaves out a subset of ``drop``'s groups with the same ``rank``: its
    columns include ``drop``'s and span the same directions (None if there is none)."""
    for n in range(len(drop)):
        for fewer in itertools.combinations(drop, n):
            if ranks.get(fewer) == rank:
                return fewer
    return None


#: Model selection policies: ``evidence`` (each group held near nominal as firmly as the data's evidence says, left out
#: where they do not support it: :mod:`pincal.identification.evidence`), ``bic`` (the groups with the smallest
#: information criterion), ``cv`` (the groups with the smallest cross-validated error, :func:`select_by_cv`) or ``none``
#: (fit every identifiable parameter).
SELECTIONS = ("evidence", "bic", "cv", "none")
#: The prior that asks the evidence for each group's factor (:func:`select_and_fit`).
AUTO_PRIOR = "auto"
#: ``cv`` selection's plan: K folds of one shuffle of the samples, seeded (the same choice on every run).
CV_FOLDS = 5
CV_SEED = 0


@dataclass
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
            the evidence chose it (None: the prior the options gave).
    """

    problem: CalibrationProblem
    result: CalibrationResult
    first: CalibrationResult
    removed: list[str]
    scores: dict[tuple[str, ...], float]
    removed_groups: tuple[str, ...] = ()
    evidence: EvidenceChoice | None = None
    prior_sigma: Array | None = None


def select_and_fit(problem: CalibrationProblem, policy: str = "evidence", **options: Any) -> SelectedFit:
    """Fit every parameter of ``problem``, then leave out the groups of identifiable parameters the data do not
    support and refit the rest from the nominal start: by their evidence (``policy="evidence"``, which also chooses
    how firmly the prior holds each group kept), by :func:`select_groups` on the fit's weighted Jacobian (``bic``), by
    cross-validation (``cv``), or none. ``options`` go to :func:`~pincal.identification.solver.identify` for every
    fit; their ``prior`` may be :data:`AUTO_PRIOR`: the first fit then has the kinds' prior σ (factor 1), and the
    groups kept get the factors the evidence chooses for them (:func:`~pincal.identification.evidence.choose_prior`).

    Raises:
        DataError: an unknown ``policy``, or ``evidence`` without the automatic prior.
    """
    if policy not in SELECTIONS:
        raise DataError(f"unknown selection '{policy}'; selections are: {listing(SELECTIONS)}")
    automatic = isinstance(options.get("prior"), str) and options["prior"] == AUTO_PRIOR
    if policy == "evidence" and not automatic:
        raise DataError("selection by the evidence chooses the prior itself: give the automatic prior ('auto'), or "
                        "another selection (bic, cv, none) for a prior of your own")
    if automatic:
        options = {**options, "prior": 1.0}
    first = identify(problem, **options)
    if len(first.identified) < 2 or not first.converged:  # no choice made on a failed fit
        return SelectedFit(problem, first, first, [], {})
    if policy == "none":
        return _with_evidence(SelectedFit(problem, first, first, [], {}), automatic, **options)
    if policy == "cv":
        return _with_evidence(select_by_cv(problem, first, **options), automatic, **options)
    jac, y0 = _weighted_linear(problem, first)
    pset = problem.parameters
    if policy == "evidence":
        return _refit_with_evidence(problem, first, jac, y0, **options)
    jac *= pset.scales  # its own copy: scaled in place
    choice = select_groups(jac, y0, [group_of(p) for p in pset])
    if not choice.removed_groups:
        return _with_evidence(SelectedFit(problem, first, first, [], choice.scores), automatic, **options)
    chosen = _refit_without(problem, first, choice.removed_groups, choice.scores, _fitted_criterion, **options)
    return _with_evidence(chosen, automatic, **options)


def _weighted_linear(problem: CalibrationProblem, fit: CalibrationResult) -> tuple[Array, Array]:
    """The weighted Jacobian (its own copy) of ``fit``'s estimate (rows whitened by their σ and the robust weights)
    and the residual of the linear model it makes at the nominal parameters, ``r(x̂) − J x̂``."""
    pred = fit.final if fit.final is not None and fit.final.jacobian is not None else problem.evaluate(fit.x)
    assert pred.jacobian is not None
    rows = np.sqrt(fit.sample_weights[problem.row_samples()])
    jac = pred.jacobian * rows[:, None]
    return jac, pred.residual * rows - jac @ fit.x


def _with_evidence(chosen: SelectedFit, automatic: bool, **options: Any) -> SelectedFit:
    """``chosen`` refitted with the prior factors the evidence chooses for the groups it kept, when the prior is
    automatic; ``chosen`` itself otherwise."""
    if not automatic or not chosen.result.converged:
        return chosen
    jac, y0 = _weighted_linear(chosen.problem, chosen.result)
    fitted = _refit_with_evidence(chosen.problem, chosen.result, jac, y0, **options)
    removed = chosen.removed + [n for n in fitted.removed if n not in chosen.removed]
    groups = chosen.removed_groups + tuple(g for g in fitted.removed_groups if g not in chosen.removed_groups)
    return SelectedFit(fitted.problem, fitted.result, chosen.first, removed, chosen.scores, groups, fitted.evidence,
                       fitted.prior_sigma)


def _refit_with_evidence(problem: CalibrationProblem, first: CalibrationResult, jac: Array, y0: Array,
                         **options: Any) -> SelectedFit:
    """The groups of ``problem``'s parameters weighed by their evidence on the linear model ``jac``, ``y0``
    (:func:`_weighted_linear` at ``first``'s estimate): each held by the prior σ it chooses, left out where that is
    none; the refit from the nominal start, or ``first`` when it fails."""
    pset = problem.parameters
    groups = [group_of(p) for p in pset]
    present = [g for g in GROUPS if g in groups]
    choice = choose_prior(jac, y0, groups, base_sigma(problem), pset.scales, present)
    kept = [k for k, g in enumerate(groups) if g not in choice.left_out]
    removed = [p.name for p in pset if group_of(p) in choice.left_out]
    if not kept:
        return SelectedFit(problem, first, first, [], {}, evidence=choice)
    reduced = _reduced(problem, kept) if removed else problem
    refit = identify(reduced, **{**options, "prior": choice.sigma[kept]})
    if not refit.converged:
        return SelectedFit(problem, first, first, [], {}, evidence=choice)
    return SelectedFit(reduced, refit, first, removed, {}, choice.left_out, choice, choice.sigma[kept])


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
                   **options: Any) -> SelectedFit:
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
    refit = identify(reduced, **options)
    # the choice was made on the fit linearized at its estimate; the refit starts from the nominal robot, where fewer
    # directions may be identifiable (a planar four-bar's anchor rotations): kept only if it scores better for real
    if not refit.converged or (criterion is not None and criterion(reduced, refit) > criterion(problem, first)):
        return SelectedFit(problem, first, first, [], scores)
    return SelectedFit(reduced, refit, first, removed, scores, removed_groups)


def select_by_cv(problem: CalibrationProblem, first: CalibrationResult, **options: Any) -> SelectedFit:
    """Leave out the groups of parameters whose combination predicts unseen samples best: every combination of the
    groups present (:data:`GROUPS`) is fitted on :data:`CV_FOLDS` − 1 folds of the samples (one shuffle seeded
    :data:`CV_SEED`) and scored by the mean square of the weighted residuals [σ²] it leaves on the fold left out,
    over every fold; the smallest wins (on equal scores, the one with fewer parameters), and is refitted on every
    sample. A combination whose fit fails on some fold scores infinity. ``first`` is the fit of every parameter.
    ``options`` go to :func:`~pincal.identification.solver.identify`."""
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
            scores[drop] = _cross_validated(problem, kept, folds, **options)
            if best is None or (scores[drop], len(kept)) < best[:2]:
                best = (scores[drop], len(kept), drop)
    if best is None or not best[2] or not math.isfinite(best[0]):
        return SelectedFit(problem, first, first, [], scores)
    return _refit_without(problem, first, best[2], scores, None, **options)


def _cross_validated(problem: CalibrationProblem, kept: list[int], folds: list[npt.NDArray[np.int64]],
                     **options: Any) -> float:
    """The mean square of the weighted residuals [σ²] that fits of the parameters ``kept`` on all folds but one leave
    on the one left out, over every fold (infinity when a fold's fit fails)."""
    n = problem.observations.n_samples
    total, rows = 0.0, 0
    for test in folds:
        train = np.setdiff1d(np.arange(n), test)
        try:
            fit = identify(_reduced(problem, kept, problem.observations.subset(train)), **options)
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
