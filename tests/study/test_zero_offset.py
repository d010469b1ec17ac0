"""Iterative zero-offset identification with TSVD and the mechanism-error update (study 003, Eq. 28-33)."""

from __future__ import annotations

import math

import numpy as np
import pytest

import pincal
from pincal.errors import DataError
from pincal.identification import measurements as ms
from pincal.identification.parameters import candidate_parameters
from pincal.identification.problem import Observations
from pincal.study.simulation import simulate_observations
from pincal.study.zero_offset import compensation_accuracy, identify_zero_offsets, tsvd_step

DEG = math.pi / 180.0
SCALE = [ms.distance("scale_body", "scale_slider", sigma=1e-6, increment=True)]
MODEL = ["theta_1_joint.offset", "theta_2_joint.offset", "scale_pivot_joint.tx", "scale_pivot_joint.ty"]


def test_compensation_accuracy_is_eq_32() -> None:
    assert compensation_accuracy(np.array([0.1, 0.2]), np.array([0.4, -0.2])) == pytest.approx(
        math.sqrt((0.3**2 + 0.4**2) / 2))


def test_tsvd_step_is_least_squares_at_full_rank_and_truncates() -> None:
    rng = np.random.default_rng(0)
    jac = rng.normal(size=(10, 4))
    jac[:, 3] = jac[:, 2] + 1e-9 * rng.normal(size=10)  # a nearly dependent column
    r = rng.normal(size=10)
    scales = np.array([1.0, 2.0, 1.0, 1.0])
    full, kappa, kept = tsvd_step(jac, r, scales, rcond=1e-12)
    assert kept == 4 and kappa > 1e8
    np.testing.assert_allclose(jac @ full, jac @ -np.linalg.lstsq(jac, r, rcond=None)[0], atol=1e-6)
    cut, _, kept = tsvd_step(jac, r, scales)  # default rcond drops the near-null direction
    assert kept == 3 and np.linalg.norm(cut) < 1e3 < np.linalg.norm(full)
    _, _, kept = tsvd_step(jac, r, scales, rank=1)
    assert kept == 1


@pytest.fixture(scope="module")
def five_bar() -> pincal.Robot:
    return pincal.load_robot("five_bar")


def _campaign(robot: pincal.Robot, offsets_deg: tuple[float, float], r_m: tuple[float, float]):
    pool = candidate_parameters(robot)
    truth = pool.select(MODEL)
    x_true = truth.vector({"theta_1_joint.offset": offsets_deg[0] * DEG, "theta_2_joint.offset": offsets_deg[1] * DEG,
                           "scale_pivot_joint.tx": r_m[0], "scale_pivot_joint.ty": r_m[1]})
    # six positions on the workspace boundary (study 003, Fig. 7), commanded by the nominal controller
    points = [(x, y) for y in (-0.632, -0.782) for x in (-0.24, 0.0, 0.24)]
    commands = np.array([robot.actuated_values(robot.solve_ik(np.array([x, y, 0.0]), frame="end_effector"))
                         for x, y in points])
    received: list[np.ndarray] = []

    def measure(compensation: np.ndarray) -> Observations:
        received.append(compensation)
        return simulate_observations(robot, truth, x_true, SCALE, commands - compensation, np.random.default_rng(0))
    return truth, x_true, measure, received


def test_offsets_and_mechanism_errors_come_back(five_bar: pincal.Robot) -> None:
    truth, x_true, measure, received = _campaign(five_bar, (2.0, -1.0), (1e-3, 0.5e-3))
    result = identify_zero_offsets(five_bar, truth, SCALE, measure, mu0=1e-10)
    assert result.converged and len(result.steps) >= 2
    assert result.names == truth.names and [result.names[k] for k in result.offsets] == MODEL[:2]
    np.testing.assert_allclose(result.compensation, x_true[result.offsets], atol=1e-10)  # Eq. 33
    np.testing.assert_allclose(result.estimate, x_true, atol=1e-10)  # Δr_M accumulated by Eq. 30
    # the controller was asked to compensate what had been identified so far
    np.testing.assert_array_equal(received[0], np.zeros(2))
    np.testing.assert_allclose(received[1], result.steps[0].offsets)
    assert result.steps[0].kept == 4 and np.isnan(result.steps[0].mu)
    assert 1.0 < result.kappa_first < 1e4 and math.isfinite(result.kappa_rest)
    assert result.steps[-1].rms_residual < 1e-9 < result.steps[0].rms_residual


def test_the_papers_threshold_stops_early(five_bar: pincal.Robot) -> None:
    truth, x_true, measure, _ = _campaign(five_bar, (0.5, 0.25), (1e-3, 0.5e-3))
    result = identify_zero_offsets(five_bar, truth, SCALE, measure)  # μ0 = 0.1°
    assert result.converged and result.steps[-1].mu <= 0.1 * DEG
    assert np.max(np.abs(result.compensation - x_true[result.offsets])) < 0.01 * DEG


def test_inconsistent_arguments_raise_data_errors(five_bar: pincal.Robot) -> None:
    truth, _, measure, _ = _campaign(five_bar, (1.0, 1.0), (0.0, 0.0))
    with pytest.raises(DataError, match="mapping must have 4 rows"):
        identify_zero_offsets(five_bar, truth, SCALE, measure, mapping=np.eye(3), offsets=["a"], names=list("abc"))
    with pytest.raises(DataError, match="not among the identified quantities"):
        identify_zero_offsets(five_bar, truth, SCALE, measure, offsets=["theta_3_joint.offset"])
    with pytest.raises(DataError, match="name the zero offsets explicitly"):
        identify_zero_offsets(five_bar, truth, SCALE, measure, mapping=np.eye(4))
