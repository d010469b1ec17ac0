"""The library checks its public arguments as the command line checks its flags: a wrong type is a ``TypeError``, a
wrong value an ``ArgumentError`` (a ``PincalError``) or the calibration options' ``DataError``; each names the
argument and the value given, never a bare error from deep inside, never a silently wrong result."""

from __future__ import annotations

import math
from collections.abc import Callable
from pathlib import Path
from typing import Any

import numpy as np
import pytest

import pincal
from pincal import validation


@pytest.fixture(scope="module")
def five_bar() -> pincal.Robot:
    return pincal.load_robot("five_bar")


@pytest.fixture(scope="module")
def simulation(five_bar: pincal.Robot) -> pincal.Simulation:
    return pincal.simulate(five_bar, ["position"], 12, seed=1)


SIMULATE_VALUES: list[tuple[dict[str, Any], str]] = [
    ({"noise": math.nan}, "noise=nan: must be a finite number ≥ 0 [m, rad]"),
    ({"noise": math.inf}, "noise=inf: must be a finite number ≥ 0 [m, rad]"),
    ({"noise": -1e-5}, "noise=-1e-05: must be a finite number ≥ 0 [m, rad]"),
    ({"joint_noise": math.nan}, "joint_noise=nan: must be a finite number ≥ 0 [rad or m]"),
    ({"perturb": -1.0}, "perturb=-1.0: must be a finite number ≥ 0 [m, rad]"),
    ({"seed": -1}, "seed=-1: must be a whole number ≥ 0"),
    ({"n_train": 0}, "n_train=0: must be a whole number ≥ 1"),
    ({"n_test": -1}, "n_test=-1: must be a whole number ≥ 0"),
]


@pytest.mark.parametrize(("change", "message"), SIMULATE_VALUES)
def test_simulate_refuses_values_the_cli_refuses(five_bar: pincal.Robot, change: dict[str, Any],
                                                 message: str) -> None:
    """``noise=nan`` once returned all-NaN measurements; ``perturb=-1`` a bare ValueError from NumPy."""
    arguments = {"n_train": 5, **change}
    with pytest.raises(pincal.ArgumentError) as caught:
        pincal.simulate(five_bar, ["position"], **arguments)
    assert str(caught.value) == message
    assert caught.value.option == next(iter(change))  # the argument at fault, as a field


SIMULATE_TYPES: list[tuple[dict[str, Any], str]] = [
    ({"robot": "five_bar"}, "robot='five_bar': expected a Robot (pincal.load_robot), not str"),
    ({"kinds": "position"}, "kinds='position': expected a list of strings (e.g. ['position']), not str"),
    ({"n_train": "5"}, "n_train='5': expected a whole number (int), not str"),
    ({"n_train": 5.5}, "n_train=5.5: expected a whole number (int), not float"),
    ({"n_train": True}, "n_train=True: expected a whole number (int), not bool"),
    ({"seed": 1.5}, "seed=1.5: expected a whole number (int), not float"),
    ({"perturb": "a"}, "perturb='a': expected a number, not str"),
    ({"parameter_spec": "default"}, "parameter_spec='default': expected a list of strings (e.g. ['default']), not str"),
    ({"payload": 5}, "payload=5: expected a Payload or None, not int"),
]


@pytest.mark.parametrize(("change", "message"), SIMULATE_TYPES)
def test_simulate_names_an_argument_of_the_wrong_type(five_bar: pincal.Robot, change: dict[str, Any],
                                                      message: str) -> None:
    arguments = {"robot": five_bar, "kinds": ["position"], "n_train": 5, **change}
    with pytest.raises(TypeError) as caught:
        pincal.simulate(**arguments)
    assert str(caught.value) == message


@pytest.mark.parametrize("sigma", [-1e-5, 0.0, math.nan, "1e-5"])
def test_calibrate_refuses_a_sigma_the_cli_refuses(five_bar: pincal.Robot, simulation: pincal.Simulation,
                                                   sigma: Any) -> None:
    """-1e-5 once acted as +1e-5, and 0.0 as the default."""
    with pytest.raises(pincal.DataError, match=r"^sigma=.*: a σ is a finite number > 0"):
        pincal.calibrate(five_bar, simulation.dataset, sigma=sigma)


CALIBRATE_TYPES: list[tuple[Callable[[pincal.Robot, pincal.Dataset], Any], type[Exception], str]] = [
    (lambda r, d: pincal.calibrate(None, d), TypeError, "robot=None: expected a Robot"),
    (lambda r, d: pincal.calibrate(r, "data.csv"), TypeError, "dataset='data.csv': expected a Dataset"),
    (lambda r, d: pincal.calibrate(r, d, "x"), TypeError, "options='x': expected CalibrationOptions or None"),
    (lambda r, d: pincal.calibrate(r, d, cv=5), pincal.DataError, "cv=5: give K (folds)"),
    (lambda r, d: pincal.calibrate(r, d, payload="2@tool"), TypeError, "payload='2@tool': expected a Payload"),
    (lambda r, d: pincal.calibrate(r, d, parameter_spec=5), TypeError, "parameter_spec=5: expected a list of"),
    (lambda r, d: pincal.CalibrationOptions(cv_seed=-1), pincal.DataError, "cv_seed=-1: give a whole number ≥ 0"),
    (lambda r, d: pincal.CalibrationOptions(cv="x"), pincal.DataError, "cv='x': give K (folds)"),
    (lambda r, d: pincal.calibrate(r, d, x_true="a"), TypeError, "x_true='a': expected an array of numbers"),
    (lambda r, d: pincal.calibrate(r, d, x_true=[1e-3] * 2), pincal.ArgumentError, "x_true has shape (2,): give "),
    (lambda r, d: pincal.calibrate(r, d, parameter_spec=["*.offset"], x_true=[math.nan] * 2), pincal.ArgumentError,
     "x_true has shape (2,) and NaN/inf: give "),
]


@pytest.mark.parametrize(("call", "error", "start"), CALIBRATE_TYPES)
def test_calibrate_names_a_wrong_argument(five_bar: pincal.Robot, simulation: pincal.Simulation,
                                          call: Callable[[pincal.Robot, pincal.Dataset], Any], error: type[Exception],
                                          start: str) -> None:
    with pytest.raises(error) as caught:
        call(five_bar, simulation.dataset)
    assert str(caught.value).startswith(start)


def test_the_other_entry_points_name_a_wrong_argument(tmp_path: Path, simulation: pincal.Simulation) -> None:
    """load_robot, read_dataset, write_dataset, identify and analyse: the argument named, not a message from inside
    (``expected str, bytes or os.PathLike object``, ``'NoneType' object has no attribute``)."""
    cases: list[tuple[Callable[[], Any], type[Exception], str]] = [
        (lambda: pincal.load_robot(None), TypeError, "path=None: expected a path"),
        (lambda: pincal.load_robot(b"five_bar"), TypeError, "path=b'five_bar': expected a path"),
        (lambda: pincal.read_dataset(5), TypeError, "path=5: expected a path"),
        (lambda: pincal.read_dataset(tmp_path / "d.csv", min_samples="2"), TypeError, "min_samples='2'"),
        (lambda: pincal.read_dataset(tmp_path / "d.csv", joint_names_required=5), TypeError,
         "joint_names_required=5"),
        (lambda: pincal.write_dataset(None, tmp_path / "d.csv"), TypeError, "dataset=None: expected a Dataset"),
        (lambda: pincal.write_dataset(simulation.dataset, None), TypeError, "path=None: expected a path"),
        (lambda: pincal.identify(None), TypeError, "problem=None: expected a calibration problem"),
        (lambda: pincal.analyse([["a"]], ["a"], [1.0]), TypeError, "jacobian=[['a']]: expected an m × p matrix"),
        (lambda: pincal.analyse(np.eye(2), 5, [1.0, 1.0]), TypeError, "names=5: expected a list of strings"),
    ]
    for call, error, start in cases:
        with pytest.raises(error) as caught:
            call()
        assert str(caught.value).startswith(start), str(caught.value)


def test_identify_refuses_values_it_would_silently_misuse(five_bar: pincal.Robot,
                                                          simulation: pincal.Simulation) -> None:
    problem = pincal.calibrate(five_bar, simulation.dataset).problem
    n = len(problem.parameters)
    for keywords, message in [
        ({"max_iter": -1}, "max_iter=-1: must be a whole number ≥ 1"),
        ({"tol": math.nan}, "tol=nan: must be a finite number ≥ 0"),
        ({"prior": -1.0}, "prior=-1.0: must be a finite number > 0"),
        ({"x0": [1.0]}, f"x0 has shape (1,): give {n} finite values [m, rad], one per parameter"),
    ]:
        with pytest.raises(pincal.ArgumentError) as caught:
            pincal.identify(problem, **keywords)
        assert str(caught.value) == message
        assert caught.value.option == next(iter(keywords))


def test_the_validators_take_what_they_should() -> None:
    """Accepted values come back as given (ints and NumPy scalars are numbers; a Path is a path)."""
    assert validation.real("x", np.float64(0.5)) == 0.5
    assert validation.real("x", 3) == 3.0
    assert validation.whole("n", np.int64(4), 1) == 4
    assert validation.texts("kinds", ["position", "pose"]) == ("position", "pose")
    assert validation.path("path", Path("a.csv")) == Path("a.csv")
    assert validation.optional_real("spread", None) is None
    assert validation.shown("x" * 100).endswith("...")


def test_the_calibration_entry_points_name_a_missing_robot_dataset_or_report(tmp_path: Path, five_bar: pincal.Robot,
                                                                              simulation: pincal.Simulation) -> None:
    """None where a robot, a dataset, a job, a simulation or a report belongs: the argument named (once
    ``'NoneType' object has no attribute 'model'``, ``... 'options'``, ``... 'error_words'``)."""
    from pincal.calibration import (
        calibrate_job,
        prepare,
        read_robot_dataset,
        summary_text,
        usable_part,
        write_simulation,
    )

    options = pincal.CalibrationOptions()
    cases: list[tuple[Callable[[], Any], str]] = [
        (lambda: read_robot_dataset(tmp_path / "d.csv", None), "robot=None: expected a Robot"),
        (lambda: usable_part(None, simulation.dataset), "robot=None: expected a Robot"),
        (lambda: usable_part(five_bar, None), "part=None: expected a Dataset"),
        (lambda: prepare(None, simulation.dataset, options), "robot=None: expected a Robot"),
        (lambda: prepare(five_bar, None, options), "dataset=None: expected a Dataset"),
        (lambda: prepare(five_bar, simulation.dataset, None), "options=None: expected CalibrationOptions"),
        (lambda: calibrate_job(None), "job=None: expected a Job"),
        (lambda: write_simulation(None, tmp_path / "sim"), "sim=None: expected a Simulation"),
        (lambda: write_simulation(simulation, None), "out=None: expected a path"),
        (lambda: summary_text(None, 1.0), "report=None: expected a CalibrationReport"),
    ]
    for call, start in cases:
        with pytest.raises(TypeError) as caught:
            call()
        assert str(caught.value).startswith(start), str(caught.value)
    with pytest.raises(pincal.ArgumentError) as refused:  # once NumPy's "need at least one array to concatenate"
        pincal.simulate(five_bar, [], 5)
    assert str(refused.value) == ("kinds=[]: give at least one measurement kind, e.g. ['position'] (the kinds of "
                                  "measurement_models: position, pose, or keys such as distance:A-B, joint:NAME)")


def test_an_unknown_bag_measurement_kind_is_named_with_the_kinds() -> None:
    """Once a KeyError from deep inside the bag reader."""
    from pincal.io.bags import MeasurementSource

    with pytest.raises(pincal.ArgumentError) as caught:
        MeasurementSource("odometry", "/odom")  # type: ignore[arg-type]
    assert str(caught.value) == "kind='odometry': must be one of pose, tf, point"
