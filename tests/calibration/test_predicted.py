"""The predicted errors' arithmetic: the norm quantile against sampling, the propagation against finite differences
of the predictions, the distance beyond the fitted range."""

from __future__ import annotations

import numpy as np
import pytest
from scipy.stats import chi2

import pincal
from pincal.calibration.campaign import simulate
from pincal.calibration.pipeline import calibrate
from pincal.calibration.predicted import FitCovariance, distance, predicted_errors
from pincal.calibration.propagation import norm_quantile
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
    covariance = np.array(report.matrix)
    noise = result.sigma2 * problem.measurements[0].sigma ** 2
    for k in range(problem.observations.n_samples):
        s = jacobian[k] @ covariance @ jacobian[k].T + noise * np.eye(3)
        assert np.allclose(held.predicted.sigma[k], np.sqrt(np.diag(s)), rtol=1e-4)
        assert np.isclose(held.predicted.linear[k], norm_quantile(s), rtol=1e-4)  # the covariance's own bound
    # the covariance read back from the report JSON's figures gives the same bounds
    again = predicted_errors(problem, FitCovariance.of_report(report, result.sigma2, problem.parameters.names), x)
    assert np.allclose(again.linear, held.predicted.linear, rtol=1e-9)


def test_the_distance_counts_range_widths_beyond_the_margin_on_the_circle() -> None:
    """A revolute joint's readings are compared on the circle, as the warnings on postures outside the fitted range
    compare them: 2π past a reading is the same posture, the nearer end counts, and a range that spans the circle
    leaves none beyond."""
    robot = pincal.load_robot("ur10")
    joint = robot.actuated_joints[5]  # the wrist: a revolute joint of limits ±2π
    actuated = np.zeros((5, robot.n_actuated))
    actuated[:, 5] = [0.5, 1.05, 2.1, 0.5 + 2 * np.pi, -1.1]
    ranges = {joint: [0.0, 1.0]}  # margin 0.1 on each side: [-0.1, 1.1]; width 1.0
    assert np.allclose(distance(robot, actuated, ranges), [0.0, 0.0, 1.0, 0.0, 1.0])
    far = np.zeros((1, robot.n_actuated))
    far[0, 5] = 1.1 + np.pi + 0.5  # beyond the upper end by π + 0.5: nearer the lower one, 2π − (π + 0.5 + 1.2) away
    assert distance(robot, far, ranges) == pytest.approx([2 * np.pi - (np.pi + 0.5) - 1.2])
    assert np.allclose(distance(robot, actuated, {joint: [-3.0, 3.0]}), 0.0)  # with its margins, the whole circle
