"""The evidence: each group's prior factor chosen by the marginal likelihood of the linearised fit."""

from __future__ import annotations

import math

import numpy as np
import pytest

import pincal
from pincal.calibration.campaign import simulate
from pincal.calibration.pipeline import calibrate
from pincal.identification import evidence
from pincal.identification.evidence import FACTOR_RANGE, _fixed_point, _linear, _terms, choose_prior


def _problem(seed: int, factors: dict[str, float], m: int = 4000, noise: float = 0.5):
    """A linear model of two groups of ten parameters (base σ 1) and two setup columns (flat prior): the true
    deviations of each group drawn with its factor, the data ``z = J δ + ε``."""
    rng = np.random.default_rng(seed)
    groups: list[str | None] = ["translations"] * 10 + ["rotations"] * 10 + [None, None]
    J = rng.normal(size=(m, len(groups)))
    delta = np.concatenate([factors["translations"] * rng.normal(size=10), factors["rotations"] * rng.normal(size=10),
                            [3.0, -2.0]])
    z = J @ delta + noise * rng.normal(size=m)
    return J, -z, groups, np.array([1.0] * 20 + [math.inf] * 2)


def test_the_gradient_is_the_derivative_of_the_log_evidence() -> None:
    J, y0, groups, base = _problem(0, {"translations": 0.3, "rotations": 2.0}, m=200)
    linear = _linear(J, y0, groups, ["translations", "rotations"], base, np.ones(len(groups)))
    theta = np.array([0.4, -1.1, 0.2])
    value, grad, _ = _terms(linear, theta[:2], float(theta[2]))
    step = 1e-6
    for k in range(3):
        up, down = theta.copy(), theta.copy()
        up[k] += step
        down[k] -= step
        numeric = (_terms(linear, up[:2], float(up[2]))[0] - _terms(linear, down[:2], float(down[2]))[0]) / (2 * step)
        assert grad[k] == pytest.approx(numeric, rel=1e-5, abs=1e-6)
    assert math.isfinite(value)


def test_each_group_s_factor_and_the_noise_come_back() -> None:
    """With many rows, the evidence finds the scale each group's deviations were drawn with (ten draws each: within a
    factor of 1.6) and the noise variance; a group drawn at zero is left out."""
    J, y0, groups, base = _problem(1, {"translations": 0.2, "rotations": 3.0})
    choice = choose_prior(J, y0, groups, base, np.ones(len(groups)), ["translations", "rotations"])
    assert 0.2 / 1.6 < choice.factors["translations"] < 0.2 * 1.6
    assert 3.0 / 1.6 < choice.factors["rotations"] < 3.0 * 1.6
    assert choice.noise == pytest.approx(0.25, rel=0.1)
    assert choice.left_out == () and np.all(np.isinf(choice.sigma[-2:]))  # the setup: no prior
    J, y0, groups, base = _problem(2, {"translations": 0.0, "rotations": 1.0})
    none = choose_prior(J, y0, groups, base, np.ones(len(groups)), ["translations", "rotations"])
    assert none.left_out == ("translations",) and none.factors["translations"] == 0.0
    assert none.factors["rotations"] > 10 * FACTOR_RANGE[0]


def test_a_robot_whose_geometry_is_close_to_nominal_is_held_firmly_near_it() -> None:
    """UR10 with true errors a tenth of the prior's σ (0.5 mm, 0.9 mrad): the evidence holds the placements about ten
    times firmer than the kinds' prior, and the fit predicts the held-out postures as well as least squares."""
    robot = pincal.load_robot("ur10")
    sim = simulate(robot, ["position"], 40, 60, perturb=5e-4, noise=5e-5, seed=4)
    cal = calibrate(robot, sim.dataset)
    selection = cal.report.selection
    assert selection is not None and selection.prior_factors is not None
    factors = selection.prior_factors
    assert selection.policy == "evidence"
    assert 0.02 < factors["translations"] < 0.5 and 0.02 < factors["rotations"] < 0.5
    plain = calibrate(robot, sim.dataset, select="none", prior="off")
    assert cal.report.test_rms_after <= 1.05 * plain.report.test_rms_after



def _plain_rounds(linear, n_groups: int) -> tuple[np.ndarray, int]:
    """MacKay's fixed point without acceleration from every factor 1, the bounds of ``_optimise`` applied, until no
    log-parameter moves by ``SETTLED``: where it ends, and after how many rounds."""
    low, high = (2.0 * math.log(v) for v in FACTOR_RANGE)
    theta = np.zeros(n_groups + 1)
    theta[-1] = math.log(linear.zz / linear.rows)
    for rounds in range(1, 10_000):
        updated = _fixed_point(linear, theta)
        updated[:-1] = np.clip(updated[:-1], low, high)
        settled = np.max(np.abs(updated - theta)) < evidence.SETTLED
        theta = updated
        if settled:
            return theta, rounds
    raise AssertionError("the plain rounds did not settle")


def test_the_accelerated_fixed_point_ends_where_the_plain_rounds_do_in_fewer_rounds(monkeypatch) -> None:
    """A group drawn at zero, on 100 rows, creeps toward a small factor a little each plain round (thousands of rounds,
    more than ``ROUNDS``); the accelerated rounds reach the same maximum of the evidence, its gradient zero, with a
    twentieth of the factorisations."""
    J, y0, groups, base = _problem(1, {"translations": 0.0, "rotations": 1.0}, m=100)
    linear = _linear(J, y0, groups, ["translations", "rotations"], base, np.ones(len(groups)))
    plain, plain_rounds = _plain_rounds(linear, 2)
    calls: list[int] = []
    monkeypatch.setattr(evidence, "_fixed_point", lambda lin, t: calls.append(1) or _fixed_point(lin, t))
    log_evidence, theta = evidence._optimise(linear, 2, accelerated=True)
    assert theta == pytest.approx(plain, abs=1e-3)
    assert log_evidence == pytest.approx(-0.5 * _terms(linear, plain[:2], float(plain[2]))[0], abs=1e-6)
    assert np.all(np.abs(_terms(linear, theta[:2], float(theta[2]))[1]) < 1e-4)  # the evidence's maximum
    assert plain_rounds > evidence.ROUNDS and len(calls) < plain_rounds / 20
