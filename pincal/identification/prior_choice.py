"""The default model: which groups of parameters to estimate, and how firmly to hold each near nominal, chosen by how
well the model predicts postures it did not see, inside the fitted range and beyond it.

Three candidates, each a set of parameters kept and one prior σ per parameter:

- ``evidence``: every group, each held by the factor its evidence chooses (:mod:`pincal.identification.evidence`);
- ``bic``: the groups the information criterion keeps (:func:`~pincal.identification.criterion.select_groups`), each
  held by the factor the evidence chooses for it;
- ``nominal``: no group: the nominal robot, its setup registered.

Each is scored on the hold-outs of :mod:`pincal.identification.holdouts`, refitted linearised at the fit of every
parameter, each candidate chosen again on each hold-out's training rows alone (the information criterion's groups and
the evidence's factors: a choice made on the held-out rows too would flatter it): the mean square of the held-out
rows' weighted residuals over the shuffled folds (postures like the fitted ones) plus the same over the range halves
(each actuated joint's half of the range predicted from the other: beyond the range). The smallest wins; on equal
scores the earlier in the list above. The evidence is smooth and holds weakly
seen directions near nominal, which serves where the robot lacks what the model holds least (a narrow band of postures,
effects the geometry absorbs); the information criterion leaves whole groups out, which serves where the data see a
group's effect but not its parameters; and where neither predicts better than the nominal robot, the nominal robot is
the model. Measured on docs/results/extrapolation.md.
"""

from __future__ import annotations

import math
from collections.abc import Sequence
from dataclasses import dataclass

import numpy as np
import numpy.typing as npt

from pincal.identification.criterion import select_groups
from pincal.identification.evidence import EvidenceChoice, base_sigma, choose_prior
from pincal.identification.holdouts import Linearised, range_halves, shuffled_folds
from pincal.identification.parameters import influencing_joints, read_joints
from pincal.identification.problem import CalibrationProblem
from pincal.identification.result import CalibrationResult

Array = npt.NDArray[np.float64]

#: The candidates, in the order that decides equal scores.
CANDIDATES = ("evidence", "bic", "nominal")


@dataclass(frozen=True)
class Candidate:
    """One candidate model.

    Attributes:
        name: ``evidence``, ``bic`` or ``nominal``.
        kept: The indices of the parameters it estimates (the others held at nominal).
        sigma: (p,) the prior σ of every parameter [its unit; inf: none].
        left_out: The groups it holds at nominal.
        evidence: The evidence's choice of factors it holds its groups by (None for ``nominal``).
    """

    name: str
    kept: list[int]
    sigma: Array
    left_out: tuple[str, ...]
    evidence: EvidenceChoice | None


@dataclass(frozen=True)
class PriorChoice:
    """The candidate chosen, and every candidate's score (the hold-outs' mean square [σ²]: inside + beyond)."""

    chosen: Candidate
    scores: dict[str, float]


def moving_columns(problem: CalibrationProblem) -> list[int]:
    """The actuated columns of ``problem``'s readings whose joints move what it measures."""
    models = problem.measurements
    moving = influencing_joints(problem.robot, sorted({f for m in models for f in m.frames}), read_joints(models))
    return [k for k, joint in enumerate(problem.robot.actuated_joints) if joint in moving]


def choose(problem: CalibrationProblem, first: CalibrationResult, jacobian: Array, y0: Array,
           groups: Sequence[str | None], present: Sequence[str], bic_left_out: tuple[str, ...]) -> PriorChoice:
    """The candidate of :data:`CANDIDATES` whose hold-outs predict best.

    Args:
        problem: The problem of every candidate parameter.
        first: Its fit with every parameter (the hold-outs are linearised at it).
        jacobian: (m, p) its weighted Jacobian at the estimate [1/unit], rows whitened and robust-weighted.
        y0: (m,) the linear model's residual at the nominal parameters, ``r(x̂) − J x̂``.
        groups: (p,) each parameter's selection group (None: the setup).
        present: The groups present, in the order they are named.
        bic_left_out: The groups the information criterion leaves out.
    """
    base, scales = base_sigma(problem), problem.parameters.scales
    every = np.ones(y0.size, dtype=bool)
    candidates = {name: _candidate(name, jacobian, y0, groups, present, base, scales, every, bic_left_out)
                  for name in CANDIDATES}
    final = first.final
    assert final is not None and final.jacobian is not None
    linear = Linearised.of_fit(problem, first, final.residual, final.jacobian, np.full(len(groups), math.inf))
    n = problem.observations.n_samples
    scores = dict.fromkeys(CANDIDATES, 0.0)
    for folds in (shuffled_folds(n), range_halves(problem.observations.actuated, moving_columns(problem))):
        if not folds:
            continue
        totals = {name: [0.0, 0.0] for name in CANDIDATES}
        for held in folds:
            training = ~np.isin(linear.rows, held)
            for name in CANDIDATES:
                candidate = _candidate(name, jacobian, y0, groups, present, base, scales, training)
                residual, _, out = linear.refit(held, candidate.kept, _precision(candidate.sigma, scales))
                totals[name][0] += float(np.sum(linear.weights[out] * residual**2))
                totals[name][1] += float(np.sum(linear.weights[out]))
        for name, (total, count) in totals.items():
            scores[name] += total / count if count > 0.0 else math.inf
    best = min(CANDIDATES, key=lambda name: (scores[name], CANDIDATES.index(name)))
    return PriorChoice(candidates[best], scores)


def _candidate(name: str, jacobian: Array, y0: Array, groups: Sequence[str | None], present: Sequence[str],
               base: Array, scales: Array, rows: npt.NDArray[np.bool_],
               bic_left_out: tuple[str, ...] | None = None) -> Candidate:
    """Candidate ``name`` chosen on the linear model's ``rows``: the information criterion's groups (``bic_left_out``
    when given, else chosen on those rows) and the evidence's factors for them, or the nominal robot."""
    if name == "nominal":
        setup = [k for k, g in enumerate(groups) if g is None]
        return Candidate(name, setup, np.full(len(groups), math.inf), tuple(present), None)
    J, y = jacobian[rows], y0[rows]
    chosen = list(present)
    if name == "bic":
        left_out = bic_left_out if bic_left_out is not None \
            else select_groups(J * scales, y, list(groups)).removed_groups
        chosen = [g for g in present if g not in left_out]
    found = choose_prior(J, y, groups, base, scales, chosen)
    left = tuple(g for g in present if g not in chosen) + found.left_out
    return Candidate(name, [k for k, g in enumerate(groups) if g not in left], found.sigma, left, found)


def _precision(sigma: Array, scales: Array) -> Array:
    """The prior's precision in scaled parameters (0 where σ is inf: no prior)."""
    finite = np.isfinite(sigma) & (sigma > 0.0)
    return np.where(finite, (scales / np.where(finite, sigma, 1.0)) ** 2, 0.0)
