"""The predicted errors' arithmetic: the norm quantile against sampling, the propagation against finite differences
of the predictions, the widening beyond the fitted range."""

from __future__ import annotations

import numpy as np
from scipy.stats import chi2

import pincal
from pincal.calibration.campaign import simulate
from pincal.calibration.pipeline import calibrate
from pincal.calibration.predicted import FitCovariance, norm_quantile, predicted_errors, widening
from pincal.calibration.report import covariance_of


def test_the_norm_quantile_is_exact_when_isotropic_and_close_otherwise() -> None:
    assert np.isclose(norm_quantile(np.eye(3) * 4e-10), 2e-5 * np.sqrt(chi2.ppf(0.95, 3)))
    rng = np.random.default_rng(0)
    for variances in ([1.0, 1.0, 0.1], [1.0, 0.3, 0.01], [2.0, 1.0, 1.0, 0.5, 0.2, 0.1]):
        s = np.diag(variances)
        samples = rng.multivariate_normal(np.zeros(len(variances)), s, 200_000)
        sampled = np.quantile(np.linalg.norm(samples, axis=1), 0.95)
        assert abs(norm_quantile(s) / sampled - 1) < 0.03


def test_the_propagation_matches_finite_differences_of_the_predictions() -> None:
    robot = pincal.load_robot("ur10")
    sim = simulate(robot, ["position"], 30, 5, seed=2)
    cal = calibrate(robot, sim.dataset)
    held = cal.held_out
    assert held is not None and held.predicted is not None
    problem, result, x = held.prepared.problem, cal.result, cal.result.x
    key = problem.measurements[0].key
    jacobian = np.zeros((problem.observations.n_samples, 3, len(result.identified)))
    for j, column in enumerate(result.identified):
        step = np.zeros_like(x)
        step[column] = 1e-6
        up = problem.evaluate(x + step, jacobian=False).predicted[key][:, :3]
        down = problem.evaluate(x - step, jacobian=False).predicted[key][:, :3]
        jacobian[:, :, j] = (up - down) / 2e-6
    report = covariance_of(result)
    covariance = np.array(report["matrix"])
    noise = result.sigma2 * problem.measurements[0].sigma ** 2
    for k in range(problem.observations.n_samples):
        s = jacobian[k] @ covariance @ jacobian[k].T + noise * np.eye(3)
        assert np.allclose(held.predicted.sigma[k], np.sqrt(np.diag(s)), rtol=1e-4)
        assert np.isclose(held.predicted.bound[k], norm_quantile(s), rtol=1e-4)
    # the covariance read back from the report JSON's figures gives the same bounds
    again = predicted_errors(problem, FitCovariance.of_report(report, result.sigma2, problem.parameters.names), x)
    assert np.allclose(again.bound, held.predicted.bound, rtol=1e-9)


def test_the_widening_grows_with_the_distance_beyond_the_range_and_its_margin() -> None:
    robot = pincal.load_robot("five_bar")
    joint = robot.actuated_joints[0]
    ranges = {joint: [0.0, 1.0]}  # margin 0.1 on each side: [-0.1, 1.1]; width 1.0
    actuated = np.zeros((4, robot.n_actuated))
    actuated[:, 0] = [0.5, 1.05, 2.1, -1.1]
    assert np.allclose(widening(robot, actuated, ranges), [1.0, 1.0, 2.0, 2.0])
