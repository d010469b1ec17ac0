"""A prior toward the nominal geometry: maximum a posteriori instead of least squares.

A robot's geometry is off its URDF by millimetres and fractions of a degree; data that barely excite a direction can
still move the estimate along it by much more, fitting noise: the model then predicts worse than the nominal robot
outside the postures it saw. The prior says what the URDF already knows: each parameter of a kind that has one
(:attr:`~pincal.identification.parameters.kinds.ParameterKind.prior`) is normal about its nominal value, with that
standard deviation times a factor. :class:`WithPrior` adds one residual row ``x_k / σ_k`` per such parameter to a
problem's weighted residual, so that least squares on it is the maximum a posteriori estimate and ``(JᵀJ)⁻¹`` of the
augmented Jacobian its posterior covariance. Directions the data see well are not moved (their information is far
above the prior's); a weakly seen one stays near nominal. The setup (measurement frame, markers, cameras, targets)
has no prior: a tracker may stand anywhere.
"""

from __future__ import annotations

import math

import numpy as np
import numpy.typing as npt

from pincal.identification.parameters import ParameterSet
from pincal.identification.problem import CalibrationProblem, Observations, Prediction, Problem

Array = npt.NDArray[np.float64]
IntArray = npt.NDArray[np.int64]


#: A prior as the fits take it: a factor on each kind's prior σ, each parameter's own prior σ [its unit] (inf: none;
#: :mod:`pincal.identification.evidence` chooses them), or None (least squares).
Prior = float | Array | None


def prior_sigma(parameters: ParameterSet, prior: Prior) -> Array:
    """Each parameter's prior standard deviation [its unit]: its kind's (by unit) times ``prior`` when that is a
    factor (infinite, no prior, for kinds without one), the σ ``prior`` gives it when that is an array (one per
    parameter), and infinite for every parameter when ``prior`` is None."""
    sigma = np.full(len(parameters), math.inf)
    if prior is None:
        return sigma
    if np.ndim(prior):
        return np.array(prior, dtype=float)
    for k, parameter in enumerate(parameters):
        value = parameter.kind_class.prior.get(parameter.unit)
        if value is not None:
            sigma[k] = float(prior) * value
    return sigma


class WithPrior:
    """``problem`` with one more residual row ``x_k / σ_k`` per parameter of finite prior σ (``sigma`` [parameter
    units]), after the data's rows; everything else is the problem's. :meth:`data` takes a prediction back to the
    data's rows."""

    def __init__(self, problem: Problem, sigma: Array) -> None:
        self.problem = problem
        self.parameters: ParameterSet = problem.parameters
        self.observations: Observations = problem.observations
        self.bounded = np.flatnonzero(np.isfinite(sigma))
        self.inverse = 1.0 / sigma[self.bounded]
        self.rows = int(problem.row_samples().size)

    def evaluate(self, x: Array, jacobian: bool = True) -> Prediction:
        """The problem's prediction at ``x`` [m, rad] with the prior's rows appended to its residual and Jacobian."""
        if not self.bounded.size:
            return self.problem.evaluate(x, jacobian)
        problem, spare = self.problem, False
        if jacobian and isinstance(problem, CalibrationProblem):  # its Jacobian made with room for ours
            pred, spare = problem.evaluate(x, jacobian, spare_rows=self.bounded.size), True
        else:
            pred = problem.evaluate(x, jacobian)
        residual = np.concatenate([pred.residual, x[self.bounded] * self.inverse])
        full = pred.jacobian
        if full is not None:
            if not spare:
                full = np.vstack([full, np.zeros((self.bounded.size, x.size))])
            full[self.rows + np.arange(self.bounded.size), self.bounded] = self.inverse
        return Prediction(residual, full, pred.errors, pred.predicted)

    def data(self, pred: Prediction) -> Prediction:
        """``pred`` (of :meth:`evaluate`) on the data's rows only."""
        if not self.bounded.size:
            return pred
        jacobian = None if pred.jacobian is None else pred.jacobian[:self.rows]
        return Prediction(pred.residual[:self.rows], jacobian, pred.errors, pred.predicted)

    def row_weights(self, data_weights: Array) -> Array:
        """Row weights: the data rows' ``data_weights``, then 1 for each prior row (a prior is never down-weighted)."""
        if not self.bounded.size:
            return data_weights
        return np.concatenate([data_weights, np.ones(self.bounded.size)])

    def row_samples(self) -> IntArray:
        """The data rows' samples (the prior's rows belong to none)."""
        return self.problem.row_samples()

    def initial_guess(self) -> Array:
        """The problem's."""
        return self.problem.initial_guess()

    def settle_assembly(self, x: Array) -> list[int]:
        """The problem's."""
        return self.problem.settle_assembly(x)
