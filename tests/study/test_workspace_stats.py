"""Statistical sensitivity (study 004, Eq. 20-21) and the pose-error Jacobians it integrates."""

from __future__ import annotations

import numpy as np
import pinocchio as pin
import pytest

import pincal
from pincal.errors import DataError
from pincal.identification import measurements as ms
from pincal.identification.parameters import choose_parameters
from pincal.identification.problem import CalibrationProblem
from pincal.study.simulation import random_actuated, simulate_observations
from pincal.study.workspace_stats import pose_error_jacobians, quaternion_rows, statistical_sensitivity


def test_percentages_follow_eq_20_and_21() -> None:
    rng = np.random.default_rng(0)
    t = rng.normal(size=(40, 6, 5))
    t[:, :, 3] = t[:, :, 1]  # two parameters acting identically
    t[:, :, 4] = 0.0  # one that acts nowhere
    sens = statistical_sensitivity(t, list("abcde"))
    tau = np.mean(np.sum(t**2, axis=1), axis=0)  # Eq. 20 per unit volume: mean over samples of Σ_j T_ji²
    np.testing.assert_allclose(sens.tau, tau)
    np.testing.assert_allclose(sens.percentages, 100 * tau / tau.sum())  # Eq. 21
    assert sens.percentages.sum() == pytest.approx(100.0)
    assert sens.percentages[1] == pytest.approx(sens.percentages[3]) and sens.percentages[4] == 0.0
    assert sens.ranked()[-1] == ("e", 0.0)
    # units: a common factor cancels; a row scale changes the mix of position and orientation rows
    scaled = statistical_sensitivity(t * 7.0, list("abcde"), column_scales=np.full(5, 1 / 7.0))
    np.testing.assert_allclose(scaled.percentages, sens.percentages)
    weighted = statistical_sensitivity(t, list("abcde"), row_scales=[1.0] * 3 + [0.0] * 3)
    np.testing.assert_allclose(weighted.tau, np.mean(np.sum(t[:, :3] ** 2, axis=1), axis=0))
    # volume weights: a sample with twice the weight counts twice
    doubled = statistical_sensitivity(np.concatenate([t, t[:1]]), list("abcde"))
    w = np.ones(40)
    w[0] = 2.0
    np.testing.assert_allclose(statistical_sensitivity(t, list("abcde"), weights=w).tau, doubled.tau)


def test_bad_inputs_raise_data_errors() -> None:
    with pytest.raises(DataError, match=r"\(N, rows, p\)"):
        statistical_sensitivity(np.zeros((6, 5)), list("abcde"))
    with pytest.raises(DataError, match="2 names for 5"):
        statistical_sensitivity(np.ones((3, 6, 5)), ["a", "b"])
    with pytest.raises(DataError, match="no parameter changes the pose"):
        statistical_sensitivity(np.zeros((3, 6, 2)), ["a", "b"])
    with pytest.raises(DataError, match="row_scales"):
        statistical_sensitivity(np.ones((3, 6, 2)), ["a", "b"], row_scales=[1.0, 2.0])


def test_quaternion_rows_match_finite_differences() -> None:
    rng = np.random.default_rng(1)
    rot = pin.exp3(rng.normal(size=3))
    omega = rng.normal(size=3)
    eps = 1e-7
    quat = pin.Quaternion(rot).coeffs()
    plus = pin.Quaternion(rot @ pin.exp3(eps * omega)).coeffs()
    minus = pin.Quaternion(rot @ pin.exp3(-eps * omega)).coeffs()
    numeric = (plus[:3] - minus[:3]) / (2 * eps)
    np.testing.assert_allclose(quaternion_rows(quat, omega[:, None])[:, 0], numeric, atol=1e-7)


def test_pose_error_jacobians_match_finite_differences() -> None:
    """T_R of the 3-UCR: position and quaternion change of E per parameter change, legs held."""
    robot = pincal.load_robot("ucr3")
    models = [ms.pose("end_effector")]
    pset = choose_parameters(robot, models, ["limb_1_base_revolute.t?", "limb_2_platform.successor.tz",
                                             "end_effector_joint.tz", "limb_3_prismatic.offset"])
    rng = np.random.default_rng(2)
    qa, _ = random_actuated(robot, 3, rng)

    def poses(x: np.ndarray) -> np.ndarray:
        return simulate_observations(robot, pset, x, models, qa, rng).values["pose:end_effector"]

    problem = CalibrationProblem(robot, pset, models, simulate_observations(robot, pset, np.zeros(len(pset)), models,
                                                                            qa, rng))
    blocks = pose_error_jacobians(problem, orientation="quaternion")
    assert blocks.shape == (3, 6, len(pset))
    eps = 1e-7
    for j in range(len(pset)):
        step = np.zeros(len(pset))
        step[j] = eps
        plus, minus = poses(step), poses(-step)
        sign = np.sign(np.sum(plus[:, 3:] * minus[:, 3:], axis=1))[:, None]
        numeric_p = (plus[:, :3] - minus[:, :3]) / (2 * eps)
        numeric_q = (plus[:, 3:6] - sign * minus[:, 3:6]) / (2 * eps)
        np.testing.assert_allclose(blocks[:, :3, j], numeric_p, atol=1e-6)
        np.testing.assert_allclose(blocks[:, 3:, j], numeric_q, atol=1e-6)
    rotation = pose_error_jacobians(problem)
    np.testing.assert_allclose(rotation[:, :3], blocks[:, :3])
    with pytest.raises(DataError, match="orientation must be"):
        pose_error_jacobians(problem, orientation="euler")
