"""``compensate`` checks its arguments as ``pincal compensate`` checks its flags and its targets file: a wrong type is
a ``TypeError``, a wrong value an ``ArgumentError``, each naming the argument and the value. Once a NaN target raised
"cannot convert float NaN to integer", ``tolerance=nan`` or ``-1`` and ``seed="x"`` or ``-1`` returned results the
command line refuses, None an AttributeError and ``frame=5`` a Boost.Python signature."""

from __future__ import annotations

import math
from typing import Any

import numpy as np
import pytest

import pincal
from pincal.calibration.compensate import Model, compensate, load_model, nominal_targets
from pincal.io.targets import MAX_TARGETS, Targets


@pytest.fixture(scope="module")
def model() -> Model:
    return load_model("delta")


@pytest.fixture(scope="module")
def targets() -> Targets:
    return Targets("position:end_effector", ["a", "b"], np.array([[0.0, 0.0, -0.4], [0.05, -0.03, -0.42]]))


VALUES: list[tuple[dict[str, Any], str]] = [
    ({"tolerance": math.nan}, "tolerance=nan: must be a finite number > 0 [m, rad]"),
    ({"tolerance": -1}, "tolerance=-1: must be a finite number > 0 [m, rad]"),
    ({"tolerance": 0.0}, "tolerance=0.0: must be a finite number > 0 [m, rad]"),
    ({"seed": -1}, "seed=-1: must be a whole number ≥ 0"),
    ({"targets_in": "world"}, "targets_in='world': choose 'measurement', 'base' or 'board'"),
]


@pytest.mark.parametrize(("change", "message"), VALUES)
def test_compensate_refuses_values_the_cli_refuses(model: Model, targets: Targets, change: dict[str, Any],
                                                   message: str) -> None:
    with pytest.raises(pincal.ArgumentError) as caught:
        compensate(model, targets, **change)
    assert str(caught.value) == message


TYPES: list[tuple[dict[str, Any], str]] = [
    ({"model": None}, "model=None: expected a Model (pincal.calibration.compensate.load_model), not NoneType"),
    ({"model": "delta"}, "model='delta': expected a Model (pincal.calibration.compensate.load_model), not str"),
    ({"targets": None}, "targets=None: expected Targets (pincal.io.targets.read_targets), not NoneType"),
    ({"frame": 5}, "frame=5: expected a frame name (str) or None, not int"),
    ({"tolerance": "1e-9"}, "tolerance='1e-9': expected a number, not str"),
    ({"seed": "x"}, "seed='x': expected a whole number (int), not str"),
    ({"seed": 1.0}, "seed=1.0: expected a whole number (int), not float"),
]


@pytest.mark.parametrize(("change", "message"), TYPES)
def test_compensate_names_an_argument_of_the_wrong_type(model: Model, targets: Targets, change: dict[str, Any],
                                                        message: str) -> None:
    arguments = {"model": model, "targets": targets, **change}
    with pytest.raises(TypeError) as caught:
        compensate(**arguments)
    assert str(caught.value) == message


@pytest.mark.parametrize(("values", "message"), [
    ([[math.nan, 0.0, -0.4], [0.05, -0.03, -0.42]],
     "targets.values[0] = [nan, 0.0, -0.4] (sample 'a'): a target must be finite numbers [m, unit quaternion]"),
    ([[0.0, 0.0, -0.4], [0.05, math.inf, -0.42]],
     "targets.values[1] = [0.05, inf, -0.42] (sample 'b'): a target must be finite numbers [m, unit quaternion]"),
    ([[0.0, 0.0], [0.05, -0.03]], "targets.values: an array of numbers of shape (N, 3) for 'position:end_effector' is "
                                  "needed, not array([[ 0.  ,  0.  ],\n       [ 0.05, -0.03]])"),
])
def test_compensate_names_a_target_it_cannot_solve_for(model: Model, values: list[list[float]], message: str) -> None:
    with pytest.raises(pincal.ArgumentError) as caught:
        compensate(model, Targets("position:end_effector", ["a", "b"], np.array(values)))
    assert str(caught.value) == message


def test_compensate_takes_as_many_targets_as_the_cli(model: Model) -> None:
    many = Targets("position:end_effector", [str(k) for k in range(MAX_TARGETS + 1)],
                   np.tile([0.0, 0.0, -0.4], (MAX_TARGETS + 1, 1)))
    with pytest.raises(pincal.ArgumentError, match=rf"^targets: {MAX_TARGETS + 1} targets; compensate takes at most "
                                                   rf"{MAX_TARGETS} in one call$"):
        compensate(model, many)


@pytest.mark.parametrize(("call", "message"), [
    (lambda: load_model(None), "model=None: expected a path (str or pathlib.Path), not NoneType"),  # type: ignore[arg-type]
    (lambda: load_model("delta", nominal="delta"),  # type: ignore[arg-type]
     "nominal='delta': expected a Robot (pincal.load_robot) or None, not str"),
    (lambda: nominal_targets(None, pincal.load_robot("delta")),  # type: ignore[arg-type]
     "compensation=None: expected a Compensation (compensate), not NoneType"),
])
def test_the_other_functions_of_compensate_name_their_argument(call: Any, message: str) -> None:
    with pytest.raises(TypeError) as caught:
        call()
    assert str(caught.value) == message
