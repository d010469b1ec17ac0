"""The range guard: a prior the evidence chose is held firmer when, on the fit's own samples, it predicts the postures
beyond a joint's range worse than the nominal robot does.

The evidence (:mod:`pincal.identification.evidence`) weighs how well the parameters explain the data *inside* the
postures measured; what the robot lacks in its model (joint deflections, gear errors, a link's growth) the parameters
absorb there, and may carry beyond, worse than leaving them at nominal. The guard measures it on the data themselves,
with the hold-outs of :mod:`pincal.identification.holdouts` (one linearised solve each, no new evaluation):

- *beyond*: for each actuated joint that moves what is measured, the samples in the lower half of its readings refitted
  from the upper half and predicted, then the other way round (:func:`~pincal.identification.holdouts.range_halves`);
- *inside*: five folds of one seeded shuffle (:func:`~pincal.identification.holdouts.shuffled_folds`).

Each score is the mean square of the held-out rows' weighted residuals [σ²]. The nominal robot's is that of the same
refits with the robot held at nominal (its setup alone refitted). When the chosen prior's *beyond* score exceeds the
nominal robot's, every robot parameter's prior σ is divided by the smallest of :data:`FIRMER` whose beyond score does
not (the sum of both scores decides among them), or by the last when none does; the fit is then made again with it.
"""

from __future__ import annotations

from dataclasses import dataclass
from typing import Any

import numpy as np
import numpy.typing as npt

from pincal.identification.criterion import group_of
from pincal.identification.holdouts import Linearised, range_halves, shuffled_folds
from pincal.identification.parameters import influencing_joints, read_joints
from pincal.identification.problem import CalibrationProblem
from pincal.identification.result import CalibrationResult

Array = npt.NDArray[np.float64]

#: Fewest samples the guard judges (fewer: the prior is kept).
MIN_SAMPLES = 4
#: The divisors of the robot parameters' prior σ tried, in order (the last: the robot practically held at nominal).
FIRMER = (3.0, 10.0, 30.0, 100.0, 1000.0)


@dataclass(frozen=True)
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

    def scores(divisor: float) -> tuple[float, float]:
        precision = linear.precision.copy()
        precision[robot] *= divisor**2
        held = Linearised(linear.jacobian, linear.residual, linear.weights, precision, linear.x, linear.rows)
        return float(np.mean(_squares(held, inside))), float(np.mean(_squares(held, beyond)))

    # the nominal robot: the robot's parameters back at nominal (0), the setup alone refitted
    at_nominal = linear.residual - linear.jacobian[:, robot] @ linear.x[robot]
    nominal = Linearised(linear.jacobian[:, ~robot], at_nominal, linear.weights, linear.precision[~robot],
                         linear.x[~robot], linear.rows)
    nominal_beyond = float(np.mean(_squares(nominal, beyond)))
    tried = [(1.0, *scores(1.0))]
    if tried[0][2] <= nominal_beyond:
        return Guard(1.0, tried[0][2], tried[0][1], nominal_beyond, tuple(tried))
    tried += [(d, *scores(d)) for d in FIRMER]
    safe = [t for t in tried if t[2] <= nominal_beyond] or [tried[-1]]
    divisor, score_in, score_out = min(safe, key=lambda t: (t[1] + t[2], t[0]))
    return Guard(divisor, score_out, score_in, nominal_beyond, tuple(tried))


def _squares(linear: Linearised, folds: list[npt.NDArray[np.intp]]) -> Array:
    """The squares of the held-out rows' weighted residuals [σ²] over ``folds``, fold after fold."""
    parts = [linear.refit(held)[0] ** 2 for held in folds]
    return np.concatenate(parts) if parts else np.zeros(0)
