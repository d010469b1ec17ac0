"""The range guard: how firmly a prior the evidence chose holds the robot near nominal, judged by how well it predicts
postures beyond a joint's range and inside it, on the fit's own samples.

The evidence (:mod:`pincal.identification.evidence`) weighs how well the parameters explain the data *inside* the
postures measured; what the robot lacks in its model (joint deflections, gear errors, a link's growth) the parameters
absorb there, and may carry beyond, worse than leaving them at nominal. The guard measures it on the data themselves,
with the hold-outs of :mod:`pincal.identification.holdouts` (one linearised solve each, no new evaluation):

- *beyond*: for each actuated joint that moves what is measured, the samples in the lower half of its readings refitted
  from the upper half and predicted, then the other way round (:func:`~pincal.identification.holdouts.range_halves`);
- *inside*: five folds of one seeded shuffle (:func:`~pincal.identification.holdouts.shuffled_folds`).

Each score is the mean square of the held-out rows' weighted residuals [σ²], each times its sample's robust weight. The
nominal robot's is that of the same refits with the robot held at nominal (its setup alone refitted). When the chosen
prior's beyond score is not above the nominal robot's, it stays. Otherwise every robot parameter's prior σ is divided by
one of 1 (the evidence's prior kept) and :data:`FIRMER`, each scored both ways:

- when the chosen prior's *beyond* squares exceed the nominal robot's beyond chance (their mean difference, held-out
  sample by held-out sample, above :data:`SIGNIFICANT` standard errors), by the divisor of the least sum of both scores
  among those whose beyond score is not above the nominal robot's, or, when none is (the linear picture of the refits
  does not reach the nominal robot's), by the one of the least beyond score;
- otherwise by the divisor of the least sum of both scores, when it lowers that sum beyond chance and materially
  (:func:`_better`: each sample's part of the change one difference, their mean above :data:`BETTER` standard errors,
  the change above :data:`MATERIAL` of the evidence's prior's sum); else the prior stays as the evidence chose it.

The fit is then made again with it.
"""

from __future__ import annotations

import math
from typing import Any

import numpy as np
import numpy.typing as npt

from pincal.identification.criterion import group_of
from pincal.identification.holdouts import Linearised, range_halves, shuffled_folds
from pincal.identification.parameters import influencing_joints, read_joints
from pincal.identification.problem import CalibrationProblem
from pincal.identification.result import CalibrationResult
from pincal.records import record

Array = npt.NDArray[np.float64]
IntArray = npt.NDArray[np.intp]

#: Fewest samples the guard judges (fewer: the prior is kept).
MIN_SAMPLES = 4
#: The divisors of the robot parameters' prior σ tried, in order (the last: the robot practically held at nominal).
FIRMER = (3.0, 10.0, 30.0, 100.0, 1000.0)
#: Scores within this share of the nominal robot's are a tie of rounding, not worse (the chosen prior kept).
TIE = 1e-6
#: The chosen prior's held-out squares are worse than the nominal robot's when their mean difference, sample by sample,
#: is above this many standard errors of it.
SIGNIFICANT = 2.0
#: A firmer prior predicts the hold-outs better than the evidence's when the mean of each sample's part of the change in
#: the sum of both scores is above this many standard errors of it (the six divisors are tried on the same samples: a
#: stricter test than :data:`SIGNIFICANT`'s, so that a prior the data support is not moved by the noise of the choice).
BETTER = 3.0
#: ... and when the change is more than this share of the evidence's prior's sum of both scores: a firmer prior that
#: shrinks every prediction a little is consistently, but not materially, better.
MATERIAL = 0.1


@record(frozen=True)
class Guard:
    """What the range guard found.

    Attributes:
        firmer: The divisor applied to the robot parameters' prior σ (1: the chosen prior kept).
        beyond: The chosen prior's beyond score [σ²] (mean square of the held-out rows' weighted residuals).
        inside: Its inside score [σ²].
        nominal_beyond: The nominal robot's beyond score [σ²].
        scores: Each divisor tried: (divisor, inside, beyond) [σ²].
    """

    firmer: float
    beyond: float
    inside: float
    nominal_beyond: float
    scores: tuple[tuple[float, float, float], ...]

    def as_dict(self) -> dict[str, Any]:
        """As the report JSON holds it."""
        return {"firmer": self.firmer, "beyond": self.beyond, "inside": self.inside,
                "nominal_beyond": self.nominal_beyond, "scores": [list(s) for s in self.scores]}


def moving_columns(problem: CalibrationProblem) -> list[int]:
    """The columns of ``problem``'s actuated readings whose joints move what it measures."""
    frames = sorted({f for m in problem.measurements for f in m.frames})
    moving = set(influencing_joints(problem.robot, frames, read_joints(problem.measurements)))
    return [k for k, joint in enumerate(problem.robot.actuated_joints) if joint in moving]


def range_guard(problem: CalibrationProblem, result: CalibrationResult, prior: Array) -> Guard | None:
    """The :class:`Guard` of the fit ``result`` of ``problem`` with the prior σ ``prior`` (p,) [parameter units; inf:
    none]. None when the fit has no Jacobian, its rows are not its samples' (an implicit fit), no joint moves what is
    measured, no robot parameter is estimated or there are fewer than :data:`MIN_SAMPLES` samples."""
    final = result.final
    columns = moving_columns(problem)
    robot = np.array([group_of(p) is not None for p in problem.parameters])
    if final is None or final.jacobian is None or final.residual.size != problem.row_samples().size \
            or not columns or not robot.any():
        return None
    n = problem.observations.n_samples
    if n < MIN_SAMPLES:
        return None
    linear = Linearised.of_fit(problem, result, final.residual, final.jacobian, prior)
    inside, beyond = shuffled_folds(n), range_halves(problem.observations.actuated, columns)

    def held(divisor: float) -> tuple[tuple[Array, Array], tuple[Array, Array]]:
        precision = linear.precision.copy()
        precision[robot] *= divisor**2
        return _squares(linear, inside, precision), _squares(linear, beyond, precision)

    # the nominal robot: the robot's parameters back at nominal (0), the setup alone refitted
    at_nominal = linear.residual - linear.jacobian[:, robot] @ linear.x[robot]
    nominal = Linearised(linear.jacobian[:, ~robot], at_nominal, linear.weights, linear.precision[~robot],
                         linear.x[~robot], linear.rows)
    nominal_squares = _squares(nominal, beyond)
    nominal_beyond = _score(nominal_squares)
    squares = {1.0: (_squares(linear, inside), _squares(linear, beyond))}
    if _score(squares[1.0][1]) <= nominal_beyond * (1.0 + TIE):  # better than the nominal robot beyond: kept
        tried = [(1.0, _score(squares[1.0][0]), _score(squares[1.0][1]))]
        return Guard(1.0, tried[0][2], tried[0][1], nominal_beyond, tuple(tried))
    squares |= {d: held(d) for d in FIRMER}
    tried = [(d, _score(both[0]), _score(both[1])) for d, both in squares.items()]
    if _worse(squares[1.0][1], nominal_squares):
        limit = nominal_beyond * (1.0 + TIE)
        safe = [t for t in tried if t[2] <= limit] or [min(tried, key=lambda t: (t[2], t[0]))]
        divisor, score_in, score_out = min(safe, key=lambda t: (t[1] + t[2], t[0]))
    else:
        divisor, score_in, score_out = min(tried, key=lambda t: (t[1] + t[2], t[0]))
        if divisor != 1.0 and not _better(squares[divisor], squares[1.0], (_samples(linear, inside),
                                                                           _samples(linear, beyond))):
            divisor, score_in, score_out = tried[0]
    return Guard(divisor, score_out, score_in, nominal_beyond, tuple(tried))


def _worse(squares: tuple[Array, Array], nominal: tuple[Array, Array]) -> bool:
    """Whether the held-out squares ``squares`` are worse than the nominal robot's ``nominal`` beyond chance: the mean
    of their differences, held-out sample by held-out sample, above :data:`SIGNIFICANT` standard errors of it (and
    beyond a tie of rounding, :data:`TIE`)."""
    differences = squares[0] - nominal[0]
    if differences.size < 2 or _score(squares) <= _score(nominal) * (1.0 + TIE):
        return False
    error = float(np.std(differences, ddof=1)) / math.sqrt(differences.size)
    return float(np.mean(differences)) > SIGNIFICANT * error


def _better(squares: tuple[tuple[Array, Array], tuple[Array, Array]],
            than: tuple[tuple[Array, Array], tuple[Array, Array]], samples: tuple[IntArray, IntArray]) -> bool:
    """Whether the held-out squares ``squares`` (inside, beyond; the entries' samples ``samples``) lower the sum of the
    two scores below ``than``'s beyond chance and materially. Each sample's part of that sum's change (its entries in
    both, over each score's rows) is one difference: their mean above :data:`BETTER` standard errors of it (a sample
    held out in several range halves is one sample, not several), and the change above :data:`MATERIAL` of ``than``'s
    sum."""
    rows_in, rows_out = max(float(np.sum(than[0][1])), 1.0), max(float(np.sum(than[1][1])), 1.0)
    parts = np.concatenate([(than[0][0] - squares[0][0]) / rows_in, (than[1][0] - squares[1][0]) / rows_out])
    _, which = np.unique(np.concatenate(samples), return_inverse=True)
    differences = np.bincount(which, weights=parts)
    if differences.size < 2:
        return False
    error = float(np.std(differences, ddof=1)) / math.sqrt(differences.size)
    gain = float(np.sum(differences))
    return float(np.mean(differences)) > BETTER * error and gain > MATERIAL * (_score(than[0]) + _score(than[1]))


def _score(squares: tuple[Array, Array]) -> float:
    """The mean square of the held-out rows' weighted residuals [σ²] from :func:`_squares`' sums and row counts."""
    return float(np.sum(squares[0]) / max(int(np.sum(squares[1])), 1))


def _squares(linear: Linearised, folds: list[npt.NDArray[np.intp]], precision: Array | None = None
             ) -> tuple[Array, Array]:
    """Per held-out sample of each of ``folds``, fold after fold, refitted with the prior's scaled ``precision``
    (default: ``linear``'s): the sum of the squares of its rows' weighted residuals [σ²], each times its robust weight
    (a sample the robust loss set aside weighs on no score), and its number of rows."""
    sums, counts = [], []
    for held in folds:
        residual, _, out = linear.refit(held, precision)
        _, sample = linear.held_samples(held)
        sums.append(np.bincount(sample, weights=linear.weights[out] * residual**2))
        counts.append(np.bincount(sample).astype(float))
    if not sums:
        return np.zeros(0), np.zeros(0)
    return np.concatenate(sums), np.concatenate(counts)


def _samples(linear: Linearised, folds: list[npt.NDArray[np.intp]]) -> IntArray:
    """The sample of each entry of :func:`_squares`' arrays for ``folds``."""
    ids = [linear.held_samples(held)[0] for held in folds]
    return np.concatenate(ids) if ids else np.zeros(0, dtype=np.intp)
