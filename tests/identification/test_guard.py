"""The range guard (pincal/identification/guard.py): a prior that predicts each joint's range halves from each other
worse than the nominal robot is held firmer; one that predicts them better is kept."""

from __future__ import annotations

from dataclasses import replace

import numpy as np
import pytest

import pincal
from pincal.calibration import CalibrationOptions
from pincal.calibration.setup import prepare
from pincal.calibration.unmodelled import Effects, narrow_band
from pincal.identification.criterion import group_of
from pincal.identification.guard import FIRMER, _better, moving_columns, range_guard
from pincal.identification.prior import prior_sigma
from pincal.identification.selection import _reduced
from pincal.identification.solver import identify


def _problem(perturb: float):
    """A UR10's marker on 60 postures in a narrow band (seed 0, noise 0.1 mm), its true geometry off by ``perturb``
    [m and rad] (0: the nominal robot is the truth)."""
    robot = pincal.load_robot("ur10")
    band = narrow_band(robot, Effects(), 0, perturb=perturb, noise=1e-4)
    dataset = band.dataset
    return prepare(robot, replace(dataset, sets=["train"] * dataset.n_samples), CalibrationOptions()).problem


def test_a_prior_that_fits_the_noise_of_a_nominal_robot_is_held_firmer() -> None:
    """The truth is the nominal robot: every robot parameter estimated with the kinds' σ fits noise that carries beyond
    the range. The guard finds the halves predicted worse than by the nominal robot (its setup alone), each firmer prior
    better, and holds the prior as firmly as it tries (none reaches the nominal robot's score: a prior is never
    infinitely firm)."""
    problem = _problem(0.0)
    sigma = prior_sigma(problem.parameters, 1.0)
    guard = range_guard(problem, identify(problem, prior=sigma), sigma)
    assert guard is not None and len(guard.scores) == 1 + len(FIRMER)
    _, inside, beyond = (np.array(column) for column in zip(*guard.scores, strict=True))
    assert beyond[0] > 1.1 * guard.nominal_beyond  # the kinds' σ: worse than the nominal robot beyond the range
    assert np.all(np.diff(beyond) < 0.0) and np.all(np.diff(inside) < 0.0)  # firmer, better: the truth is nominal
    assert guard.firmer == FIRMER[-1] and (guard.inside, guard.beyond) == (inside[-1], beyond[-1])
    assert beyond[-1] == pytest.approx(guard.nominal_beyond, rel=0.01)  # 1000 × firmer: practically at nominal


def test_a_prior_that_finds_real_errors_is_kept() -> None:
    """The truth is off by 1 mm and 1 mrad per placement: the fit predicts the halves far better than the nominal
    robot, and the guard keeps the prior."""
    problem = _problem(1e-3)
    sigma = prior_sigma(problem.parameters, 1.0)
    guard = range_guard(problem, identify(problem, prior=sigma), sigma)
    assert guard is not None and guard.firmer == 1.0 and len(guard.scores) == 1 + len(FIRMER)
    assert guard.beyond < 0.1 * guard.nominal_beyond
    _, inside, beyond = (np.array(column) for column in zip(*guard.scores, strict=True))
    sums = inside + beyond  # no firmer prior predicts the hold-outs materially better, the firmest far worse
    assert sums.min() > 0.9 * sums[0] and sums[-1] > 10.0 * sums[0]


def test_the_nominal_robots_score_is_that_of_its_setup_refitted_on_each_half() -> None:
    """The nominal robot's beyond score, linearised at the fit, against the setup refitted for real (Levenberg–
    Marquardt, the robot at nominal) on each half and predicting the other: the same within a few per cent."""
    problem = _problem(3e-4)
    sigma = prior_sigma(problem.parameters, 1.0)
    guard = range_guard(problem, identify(problem, prior=sigma), sigma)
    assert guard is not None
    robot = [k for k, p in enumerate(problem.parameters) if group_of(p) is not None]
    setup = [k for k in range(len(problem.parameters)) if k not in robot]
    actuated = problem.observations.actuated
    total, rows = 0.0, 0
    for column in moving_columns(problem):
        ranked = np.argsort(actuated[:, column], kind="stable")
        half = actuated.shape[0] // 2
        for held, train in ((ranked[:half], ranked[half:]), (ranked[half:], ranked[:half])):
            on_train = _reduced(problem, setup, problem.observations.subset(np.sort(train)))
            fit = identify(on_train, prior=None)
            on_held = _reduced(problem, setup, problem.observations.subset(np.sort(held)))
            residual = on_held.evaluate(fit.x, jacobian=False).residual
            total += float(residual @ residual)
            rows += residual.size
    assert guard.nominal_beyond == pytest.approx(total / rows, rel=0.05)


def test_a_firmer_prior_is_taken_only_when_its_hold_outs_are_better_beyond_chance() -> None:
    """The choice among the divisors when the evidence's prior is no worse than the nominal robot: the one of the least
    sum of scores, kept only when its squares, sample by sample inside and beyond, are below the evidence's prior's by
    more than BETTER standard errors and MATERIAL of their mean."""
    rng = np.random.default_rng(0)
    inside, beyond = rng.chisquare(3, 40), rng.chisquare(3, 60)
    rows_in, rows_out = np.full(40, 3.0), np.full(60, 3.0)
    prior = ((inside, rows_in), (beyond, rows_out))
    halved = ((0.5 * inside, rows_in), (0.5 * beyond, rows_out))  # every sample better: far beyond chance
    assert _better(halved, prior)
    noise = rng.normal(0.0, 1.0, 100)
    noise -= noise.mean()  # better on the mean by a tenth of the differences' standard deviation: chance
    shifted = ((inside - 0.1 - noise[:40], rows_in), (beyond - 0.1 - noise[40:], rows_out))
    assert not _better(shifted, prior)
    steady = ((0.97 * inside, rows_in), (0.97 * beyond, rows_out))  # every sample 3 % better: real, but not material
    assert not _better(steady, prior)
    assert not _better(prior, prior)
