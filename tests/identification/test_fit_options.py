"""The identification layer's options as one object (``FitOptions``): what ``identify``'s keywords make, what the
calibration layer makes of ``CalibrationOptions``, and the prior's forms."""

from __future__ import annotations

import inspect
from dataclasses import fields, replace

import numpy as np
import pytest

import pincal
from pincal.calibration.options import CalibrationOptions
from pincal.errors import ArgumentError, DataError
from pincal.identification import measurements as ms
from pincal.identification.fit_options import AUTO_PRIOR, FitOptions, StepOptions
from pincal.identification.parameters import choose_parameters
from pincal.identification.problem import CalibrationProblem
from pincal.identification.selection import select_and_fit
from pincal.identification.solver import identify, identify_with
from pincal.study.simulation import perturbation, random_actuated, simulate_observations


@pytest.fixture(scope="module")
def problem() -> CalibrationProblem:
    robot = pincal.load_robot("ur10")
    models = [ms.position("tool0")]
    rng = np.random.default_rng(5)
    pset = choose_parameters(robot, models, ["*.offset"])
    qa, _ = random_actuated(robot, 20, rng)
    obs = simulate_observations(robot, pset, perturbation(pset, 1e-3, rng), models, qa, rng)
    return CalibrationProblem(robot, pset, models, obs)


def test_identify_takes_its_keywords_defaults_from_the_options_object() -> None:
    """Every keyword of ``identify`` is a field of ``FitOptions`` with its default: each default written once."""
    signature = inspect.signature(identify).parameters
    defaults = FitOptions()
    for f in fields(FitOptions):
        assert signature[f.name].default is getattr(defaults, f.name), f.name
    assert {f.name for f in fields(StepOptions)} < {f.name for f in fields(FitOptions)}


def test_the_calibration_options_make_the_fit_options() -> None:
    """``CalibrationOptions.fitting``: the solver, loss, iterations and prior carried over; ``off`` is no prior."""
    assert CalibrationOptions().fitting == FitOptions(prior=AUTO_PRIOR)
    made = CalibrationOptions(solver="tsvd", loss="cauchy", max_iter=7, prior=2).fitting
    assert (made.solver, made.loss, made.max_iter, made.prior) == ("tsvd", "cauchy", 7, 2.0)
    assert CalibrationOptions(prior="off").fitting.prior is None
    assert CalibrationOptions.max_iter == FitOptions.max_iter and CalibrationOptions.solver == FitOptions.solver


def test_the_automatic_prior_is_factor_one_in_a_single_fit() -> None:
    assert FitOptions(prior=AUTO_PRIOR).automatic_prior
    assert FitOptions(prior=AUTO_PRIOR).single() == FitOptions(prior=1.0)
    assert FitOptions(prior=0.5).single() == FitOptions(prior=0.5)
    assert FitOptions(prior=AUTO_PRIOR).fixed_prior() == 1.0


def test_identify_with_the_object_is_identify_with_its_keywords(problem: CalibrationProblem) -> None:
    keywords = identify(problem, loss="linear", max_iter=30, prior=3.0)
    carried = identify_with(problem, FitOptions(loss="linear", max_iter=30, prior=3.0))
    assert np.array_equal(keywords.x, carried.x)
    assert keywords.iterations == carried.iterations
    automatic = identify_with(problem, FitOptions(loss="linear", prior=AUTO_PRIOR))
    factor_one = identify(problem, loss="linear", prior=1.0)
    assert np.array_equal(automatic.x, factor_one.x)


def test_a_prior_of_no_form_is_refused_naming_the_option(problem: CalibrationProblem) -> None:
    with pytest.raises(ArgumentError) as caught:
        identify_with(problem, FitOptions(prior="strong"))  # type: ignore[arg-type]
    assert caught.value.option == "prior"
    assert "prior='strong'" in str(caught.value)
    with pytest.raises(TypeError, match="options="):
        identify_with(problem, {"loss": "linear"})  # type: ignore[arg-type]
    with pytest.raises(ArgumentError) as caught:
        identify_with(problem, replace(FitOptions(), max_iter=0))
    assert caught.value.option == "max_iter"


def test_selection_by_the_evidence_names_the_prior_it_needs(problem: CalibrationProblem) -> None:
    with pytest.raises(DataError) as caught:
        select_and_fit(problem, "evidence", FitOptions(prior=2.0))
    assert caught.value.option == "prior"
    assert "--" not in str(caught.value)  # library words, not a command-line flag
