"""Checks shared by the identifiability tests: random Jacobians, and that a named combination is invisible."""

from __future__ import annotations

import numpy as np

from pincal.identification.combinations import Combination


def random_matrix(m: int, p: int, seed: int) -> np.ndarray:
    """An (m, p) matrix of standard normal entries drawn from ``seed``."""
    return np.random.default_rng(seed).normal(size=(m, p))


def assert_null(J: np.ndarray, names: list[str], combination: Combination) -> None:
    """The combination's direction, in physical units, is invisible to J (to 1e-8 of the size of its terms)."""
    columns = [names.index(name) for name in combination.names]
    direction = combination.null_direction
    seen = J[:, columns] @ direction
    size = np.sum(np.linalg.norm(J[:, columns], axis=0) * np.abs(direction))
    assert np.linalg.norm(seen) <= 1e-8 * size + 1e-300
    assert len(combination.coefficients) == len(combination.names) == len(combination.units)
