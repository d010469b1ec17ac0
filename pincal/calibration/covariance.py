"""The estimates' covariance as the fit gives it: every use of it (the report's, the predicted errors') reads it
here."""

from __future__ import annotations

import numpy as np
import numpy.typing as npt

from pincal.identification.result import CalibrationResult

Array = npt.NDArray[np.float64]


def parameter_covariance(result: CalibrationResult) -> Array:
    """The estimates' covariance over the identified parameters (``result.identified``'s order) as the fit gives it,
    ``C_ij = ρ_ij σ_i σ_j`` [products of the parameters' units: m², m·rad, rad²]; NaN where it could not. Every use
    of the covariance (the report's, the predicted errors') reads it here."""
    std = result.std[result.identified]
    return np.asarray(result.correlation * np.outer(std, std), dtype=float)
