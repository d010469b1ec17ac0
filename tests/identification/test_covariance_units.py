"""The covariance's refusal words a dependent pair in the units the parameters' kinds give, not in units guessed
from their names (a plugin kind's parameter names no axis)."""

from __future__ import annotations

import numpy as np
import pytest

from pincal.errors import DataError, IdentifiabilityError
from pincal.identification.identifiability import covariance
from pincal.identification.parameters import ParameterSet, offset_parameter


def _dependent() -> np.ndarray:
    """Two columns, the second twice the first: the first acts as 0.5 × the second."""
    column = np.random.default_rng(0).normal(size=(10, 1))
    return np.hstack([column, 2.0 * column])


def test_the_units_given_word_the_dependent_pair() -> None:
    names = ["gauge.zero", "lever.zero"]
    with pytest.raises(IdentifiabilityError, match=r"gauge\.zero \(column 0\) acts as 0\.5 × lever"):
        covariance(_dependent(), 1.0, names=names)  # no unit can be read from these names
    with pytest.raises(IdentifiabilityError, match=r"gauge\.zero \(column 0\) acts as 0\.5 rad/m × lever"):
        covariance(_dependent(), 1.0, names=names, units=["m", "rad"])
    with pytest.raises(DataError, match="1 units for 2 parameters"):
        covariance(_dependent(), 1.0, names=names, units=["m"])


def test_a_parameter_set_gives_its_kinds_lengths_and_angles() -> None:
    pset = ParameterSet([offset_parameter("slide", "m"), offset_parameter("elbow", "rad")])
    assert pset.lengths_and_angles == ["m", "rad"]
