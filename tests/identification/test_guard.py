"""The range guard (pincal/identification/guard.py): a prior that predicts each joint's range halves from each other
worse than the nominal robot is held firmer; one that predicts them better is kept."""

from __future__ import annotations

from dataclasses import replace

import numpy as np
import numpy.typing as npt
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

Array = npt.NDArray[np.float64]


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
    robot, and the guard keeps the prior without trying a firmer one."""
    problem = _problem(1e-3)
    sigma = prior_sigma(problem.parameters, 1.0)
    guard = range_guard(problem, identify(problem, prior=sigma), sigma)
    assert guard is not None and guard.firmer == 1.0 and len(guard.scores) == 1  # no firmer prior tried
    assert guard.beyond < 0.1 * guard.nominal_beyond


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
    sum of scores, kept only when each sample's part of the change in that sum is positive beyond chance (BETTER
    standard errors, a sample counted once however many hold-outs hold it) and the change material (MATERIAL)."""
    rng = np.random.default_rng(0)
    n = 40
    ids = np.arange(n)
    inside, beyond = rng.chisquare(3, n) + 1.0, rng.chisquare(3, n) + 1.0
    ones = np.ones(n)
    prior = ((inside, ones), (beyond, ones))

    def scaled(factor_in: Array, factor_out: Array) -> tuple[tuple[Array, Array], tuple[Array, Array]]:
        return (inside * factor_in, ones), (beyond * factor_out, ones)

    assert _better(scaled(0.5, 0.5), prior, (ids, ids))  # every sample half: far beyond chance, material
    assert not _better(prior, prior, (ids, ids))
    assert not _better(scaled(0.97, 0.97), prior, (ids, ids))  # every sample 3 % better: real, not material
    steady = scaled(0.8, 0.8)  # 20 % better on every sample: taken ...
    assert _better(steady, prior, (ids, ids))
    noise = rng.normal(0.0, 10.0, n)
    noise -= noise.mean()  # ... the same 20 % on the mean, spread by noise far wider than it: chance
    noisy = ((steady[0][0] + noise, ones), steady[1])
    assert np.sum(noisy[0][0]) + np.sum(noisy[1][0]) == pytest.approx(np.sum(steady[0][0]) + np.sum(steady[1][0]))
    assert not _better(noisy, prior, (ids, ids))
    # ten samples, each held out in fifteen range halves with the same difference: ten differences, not 150
    few = np.repeat(np.arange(10), 15)
    spread = np.repeat(rng.normal(1.0, 2.0, 10), 15)
    base = np.full(150, 10.0)
    halves = ((np.ones(10), np.ones(10)), (base - spread, np.ones(150)))
    assert not _better(halves, ((np.ones(10), np.ones(10)), (base, np.ones(150))), (np.arange(10), few))
    assert _better(((np.ones(10), np.ones(10)), (base - np.abs(spread) - 1.0, np.ones(150))),
                   ((np.ones(10), np.ones(10)), (base, np.ones(150))), (np.arange(10), few))
