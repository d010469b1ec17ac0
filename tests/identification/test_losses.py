"""Robust losses: per-sample weights by name, judged per reading taken."""

from __future__ import annotations

import numpy as np

import pincal
from pincal.identification import measurements as ms
from pincal.identification.chi2 import chi2_upper
from pincal.identification.losses import IMPLEMENTED_LOSSES, TRIM_KEEP, TRIMMED, sample_weights
from pincal.identification.parameters import default_parameters
from pincal.identification.problem import CalibrationProblem
from pincal.study.simulation import random_actuated, simulate_observations

MARKERS = {"m1": (0.06, 0.0, 0.03), "m2": (-0.04, 0.05, 0.01), "m3": (0.0, -0.05, 0.07)}


def test_the_robust_loss_judges_a_sample_by_its_readings_taken() -> None:
    """A sample that saw one marker of three is neither favoured nor penalised by the Cauchy weights for having
    fewer rows: with every sample off by the same error per reading, every weight is the same."""
    robot = pincal.load_robot("ur10")
    models = [ms.position("tool0", marker=m, nominal=n) for m, n in MARKERS.items()]
    pset = default_parameters(robot, models)
    rng = np.random.default_rng(2)
    qa, _ = random_actuated(robot, 12, rng)
    obs = simulate_observations(robot, pset, np.zeros(len(pset)), models, qa, rng)
    for m in models:
        obs.values[m.key] += 1e-4  # the same error on every reading
    obs.values[models[1].key][[2, 5]] = np.nan
    obs.values[models[2].key][[2, 7]] = np.nan
    problem = CalibrationProblem(robot, pset, models, obs)
    weights = sample_weights(problem, problem.evaluate(np.zeros(len(pset)), jacobian=False),
                             IMPLEMENTED_LOSSES["cauchy"])
    np.testing.assert_allclose(weights, weights[0], rtol=1e-12)


def test_each_weighting_on_known_norms() -> None:
    """Least squares weighs every sample 1; Cauchy down-weights the far sample; the trimmed start keeps the
    best-fitting half of the samples with rows and leaves a sample with no rows at 1."""
    assert IMPLEMENTED_LOSSES["linear"] is None
    norms = np.array([1.0, 1.2, 0.8, 50.0, 0.9, 0.0])
    used = np.array([True, True, True, True, True, False])
    cauchy = IMPLEMENTED_LOSSES["cauchy"]
    trimmed = IMPLEMENTED_LOSSES[TRIMMED]
    assert cauchy is not None and trimmed is not None
    weights = cauchy(norms, used)
    assert weights[3] < 0.01 and np.all(weights[[0, 1, 2, 4]] > 0.5)
    kept = trimmed(norms, used)
    assert kept.tolist() == [1.0, 0.0, 1.0, 0.0, 1.0, 1.0]
    assert int(kept[used].sum()) == int(np.ceil(TRIM_KEEP * used.sum()))


def test_the_chi2_quantiles_are_scipy_stats_ones() -> None:
    """The outlier test's and the predicted bound's χ² quantiles, taken without ``scipy.stats`` or ``scipy.special``,
    are its ``ppf``: the median, a 95 % level at a fractional ν (Welch–Satterthwaite), Bonferroni tails down to
    1e-3 / 10⁶ and beyond, degrees of freedom from 0.3 to 10⁴; and ``scipy.special.chdtri``'s to 1e-12 on random
    draws of both."""
    from scipy.special import chdtri
    from scipy.stats import chi2

    dof = np.array([0.3, 1, 2, 3, 6, 7.3, 12, 40, 1e4])
    assert np.allclose(chi2_upper(0.5, dof), chi2.median(dof), rtol=1e-12)
    assert np.allclose(chi2_upper(0.05, dof), chi2.ppf(0.95, dof), rtol=1e-12)
    for tail in (0.999, 1e-3, 1e-3 / 60, 1e-9, 1e-15):
        assert np.allclose(chi2_upper(tail, dof), chi2.isf(tail, dof), rtol=1e-10)
    rng = np.random.default_rng(0)
    tails, dofs = np.exp(rng.uniform(np.log(1e-15), np.log(0.9999), 300)), np.exp(rng.uniform(np.log(0.2), 8.5, 300))
    assert np.allclose(chi2_upper(tails, dofs), chdtri(dofs, tails), rtol=1e-12, atol=0.0)
    assert np.all(np.isnan(chi2_upper(np.array([0.0, 1.0, 0.5]), np.array([3.0, 3.0, 0.0]))))
    # beyond the range it is checked over: right where the terms suffice, NaN where the doubles run out
    assert np.allclose(chi2_upper(0.5, np.array([1e5, 1e6])), chdtri(np.array([1e5, 1e6]), 0.5), rtol=1e-11)
    assert np.all(np.isnan(chi2_upper(0.5, np.array([1e-6, np.inf, np.nan]))))


def test_the_chi2_start_takes_the_normal_quantile_of_statistics_to_the_bit() -> None:
    """Wilson–Hilferty's start reads the normal quantile from the function ``statistics.NormalDist.inv_cdf`` calls:
    the same value to the bit over tails from 1e-15 to 0.9999."""
    from statistics import NormalDist

    from pincal.identification import chi2

    tails = [*np.exp(np.random.default_rng(1).uniform(np.log(1e-15), np.log(0.9999), 200)).tolist(), 0.05, 0.5]
    assert [chi2._normal_dist_inv_cdf(t, 0.0, 1.0) for t in tails] == [NormalDist().inv_cdf(t) for t in tails]


def test_many_degrees_of_freedom_started_from_their_neighbours_are_scipy_s() -> None:
    """The predicted bounds' call, one tail at many close fractional ν (each solve started from its neighbours' and
    often ended after one Halley step), gives ``scipy.special.chdtri``'s quantiles as the solve from Wilson–Hilferty
    does, between invalid entries and across ranges where the neighbours are far apart."""
    from scipy.special import chdtri

    rng = np.random.default_rng(3)
    for tail in (0.05, 0.5, 0.9999, 1e-3 / 60, 1e-15):
        for dofs in (rng.uniform(1.0, 3.0, 100), rng.uniform(0.2, 1.0, 100), np.arange(1.0, 400.0),
                     np.exp(rng.uniform(np.log(0.2), 8.5, 300))):
            assert np.allclose(chi2_upper(tail, dofs), chdtri(dofs, tail), rtol=1e-12, atol=0.0)
    mixed = np.array([1.2, np.nan, 1.3, 0.0, 1.4, 1e6, 2.9])
    expected = np.array([chdtri(d, 0.05) if 0 < d < 1e5 else np.nan for d in mixed])
    expected[5] = chdtri(1e6, 0.05)
    assert np.allclose(chi2_upper(0.05, mixed), expected, rtol=1e-11, atol=0.0, equal_nan=True)
