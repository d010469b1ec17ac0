"""The evidence's choice redone on part of the samples (pincal/identification/selection.py ``fold_prior``), with which
the predicted bound's hold-outs are refitted (pincal/calibration/growth.py): the bound sees how much the choice of the
prior varies with the samples."""

from __future__ import annotations

from dataclasses import replace

import numpy as np

import pincal
from pincal.calibration import CalibrationOptions
from pincal.calibration.campaign import simulate
from pincal.calibration.growth import estimate_growth
from pincal.calibration.setup import prepare
from pincal.identification.criterion import group_of
from pincal.identification.guard import moving_columns
from pincal.identification.holdouts import shuffled_folds
from pincal.identification.selection import SelectedFit, fold_prior, select_and_fit


def _fitted(options: CalibrationOptions) -> SelectedFit:
    """A UR10's marker on 30 postures, its geometry off by 0.5 mm and mrad (seed 4, noise 0.05 mm), fitted by
    ``options``' selection."""
    robot = pincal.load_robot("ur10")
    dataset = simulate(robot, ["position"], 30, 0, perturb=5e-4, noise=5e-5, seed=4).dataset
    problem = prepare(robot, replace(dataset, sets=["train"] * dataset.n_samples), options).problem
    return select_and_fit(problem, options.selection, options.fitting)


def test_on_every_sample_the_choice_is_the_fits_own_and_on_part_of_them_it_moves() -> None:
    fitted = _fitted(CalibrationOptions())
    prior = fold_prior(fitted)
    assert prior is not None and fitted.prior_sigma is not None
    n = fitted.problem.observations.n_samples
    assert np.array_equal(prior(np.arange(n)), fitted.prior_sigma)  # the same samples: the fit's own prior σ
    robot = np.array([group_of(p) is not None for p in fitted.problem.parameters])
    ratios = []
    for held in shuffled_folds(n):
        sigma = prior(np.setdiff1d(np.arange(n), held))
        assert np.all(np.isinf(sigma[~robot])) and np.all(np.isfinite(sigma[robot]) & (sigma[robot] > 0.0))
        ratios.append(sigma[robot] / fitted.prior_sigma[robot])
    assert np.max(np.abs(np.log(np.concatenate(ratios)))) > 0.01  # a fifth of the samples left out moves the choice


def test_a_prior_of_the_users_has_no_fold_choice() -> None:
    assert fold_prior(_fitted(CalibrationOptions(select="bic", prior=1.0))) is None


def test_a_fold_choice_that_never_moves_gives_the_growth_of_the_fixed_prior() -> None:
    """Refitting every hold-out with the fit's own prior σ is the bound without the choice redone, figure for
    figure; redoing the choice changes only the factor inside the range (ρ₀), never the nominal robot's growth."""
    fitted = _fitted(CalibrationOptions())
    problem, result, sigma = fitted.problem, fitted.result, fitted.prior_sigma
    assert sigma is not None
    columns = moving_columns(problem)
    fixed = estimate_growth(problem, result, sigma, columns, result.x0)
    same = estimate_growth(problem, result, sigma, columns, result.x0, lambda samples: sigma)
    redone = estimate_growth(problem, result, sigma, columns, result.x0, fold_prior(fitted))
    assert fixed is not None and same is not None and redone is not None
    assert same.as_dict() == fixed.as_dict()
    assert {k: v for k, v in redone.as_dict().items() if k != "rho0"} == \
        {k: v for k, v in fixed.as_dict().items() if k != "rho0"}
