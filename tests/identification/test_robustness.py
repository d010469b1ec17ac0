"""Shop-floor data: gross outliers handled with no hand-set threshold, unusable samples listed."""

from __future__ import annotations

import numpy as np

import pincal
from pincal.calibration.campaign import simulate
from pincal.calibration.pipeline import calibrate
from pincal.calibration.report_sections import DroppedSample
from pincal.identification import measurements as ms
from pincal.identification.metrics import error_norms, rms
from pincal.identification.parameters import choose_parameters
from pincal.identification.problem import CalibrationProblem, Observations
from pincal.identification.solver import identify
from pincal.io.dataset import Dataset
from pincal.study.simulation import perturbation, random_actuated, simulate_observations


def test_five_percent_gross_outliers_are_down_weighted_by_default() -> None:
    robot = pincal.load_robot("ur10")
    models = [ms.position("tool0", sigma=1e-5)]
    rng = np.random.default_rng(1)
    pset = choose_parameters(robot, models)
    x_true = perturbation(pset, 1e-3, rng)
    qa, _ = random_actuated(robot, 100, rng)
    obs = simulate_observations(robot, pset, x_true, models, qa, rng, noise=1e-5)
    train, test = obs.subset(np.arange(60)), obs.subset(np.arange(60, 100))
    clean = identify(CalibrationProblem(robot, pset, models, train))
    assert clean.extra["outlier_test"] == []  # nothing flagged in clean data
    values = train.values["position:tool0"].copy()
    corrupted = sorted(rng.choice(60, 3, replace=False).tolist())  # 5 %
    direction = rng.normal(size=(3, 3))
    values[corrupted] += direction / np.linalg.norm(direction, axis=1)[:, None] * rng.uniform(0.02, 0.04, (3, 1))
    dirty = identify(CalibrationProblem(robot, pset, models, Observations(train.actuated, {"position:tool0": values})))
    held_out = CalibrationProblem(robot, pset, models, test)
    rms_clean = rms(error_norms(held_out.evaluate(clean.x, jacobian=False).errors))
    rms_dirty = rms(error_norms(held_out.evaluate(dirty.x, jacobian=False).errors))
    assert rms_dirty <= 1.5 * rms_clean
    assert dirty.down_weighted() == corrupted and dirty.loss == "auto (cauchy)"
    # plain least squares is ruined by the same data
    plain = identify(CalibrationProblem(robot, pset, models, Observations(train.actuated, {"position:tool0": values})),
                     loss="linear")
    assert rms(error_norms(held_out.evaluate(plain.x, jacobian=False).errors)) > 10 * rms_clean


def test_unreachable_samples_are_dropped_and_listed() -> None:
    robot = pincal.load_robot("hexapod")
    sim = simulate(robot, ["pose"], 30, 0, perturb=1e-4, noise=1e-6, seed=2, parameter_spec=["*.offset"])
    ds = sim.dataset
    joints = ds.joints.copy()
    joints[4, :6] = [0.79, 0.0, 0.0, 0.0, 0.0, 0.0]  # one leg 0.79 m longer, within its limits: no pose fits
    bad = Dataset(ds.joint_names, joints, ds.measurements, ds.sample_ids, ds.sets, ds.metadata)
    cal = calibrate(robot, bad, parameter_spec=["*.offset"])
    assert [d.sample for d in cal.report.dropped_samples] == ["4"]
    assert "forward kinematics did not converge" in cal.report.dropped_samples[0].reason
    assert cal.report.n_samples == 29 and cal.result.converged


def test_singular_samples_are_named() -> None:
    """A four-bar at the end of its crank's range (coupler and rocker aligned): the passive joints are no
    longer determined by the crank, so the sample is refused as singular, with the reason."""
    import math

    from mechanisms import FOUR_BAR, FOUR_BAR_CRANK_HOME, four_bar_urdf

    from pincal.model.assemblable import unusable_samples
    from pincal.model.robot import robot_from_urdf_text

    robot = robot_from_urdf_text(four_bar_urdf())
    a, b, c, d = (FOUR_BAR[k] for k in "abcd")
    limit = math.acos((a * a + d * d - (b + c) ** 2) / (2 * a * d)) - FOUR_BAR_CRANK_HOME  # crank reading
    bad = unusable_samples(robot, np.array([[0.1], [limit], [0.3], [limit + 0.2]]))
    assert [k for k, _ in bad] == [1, 3]
    assert bad[0][1].startswith("singular configuration")
    assert "did not converge" in bad[1][1]  # beyond the range: no assembly at all


def test_unreachable_held_out_samples_are_listed_not_fatal() -> None:
    robot = pincal.load_robot("hexapod")
    sim = simulate(robot, ["pose"], 20, 5, perturb=1e-4, noise=1e-6, seed=3, parameter_spec=["*.offset"])
    ds = sim.dataset
    joints = ds.joints.copy()
    joints[22, :6] = [2.0, 0.0, 0.0, 0.0, 0.0, 0.0]  # a held-out sample no platform pose fits
    cal = calibrate(robot, Dataset(ds.joint_names, joints, ds.measurements, ds.sample_ids, ds.sets, ds.metadata),
                    parameter_spec=["*.offset"])
    assert cal.report.dropped_test_samples is not None
    assert [d.sample for d in cal.report.dropped_test_samples] == ["22"]
    assert cal.report.n_test_samples == 4 and cal.result.converged


def test_coincident_frames_in_a_distance_are_named() -> None:
    import pytest

    robot = pincal.load_robot("delta")
    models = [ms.distance("platform", "end_effector")]  # the end effector sits at the platform centre
    pset = choose_parameters(robot, [ms.position("end_effector")], ["*.offset"])
    problem = CalibrationProblem(robot, pset, models, Observations(np.zeros((2, 3)), {models[0].key: np.ones((2, 1))}))
    with pytest.raises(pincal.DataError, match="frames 'platform' and 'end_effector' coincide"):
        identify(problem)


def test_a_selection_that_leaves_nothing_is_refused() -> None:
    import pytest

    robot = pincal.load_robot("delta")
    with pytest.raises(pincal.NotFoundError, match="leave no parameter to identify"):
        choose_parameters(robot, [ms.position("end_effector")], ["arm_1_joint.tx", "!arm_1_joint.tx"])


def test_readings_beyond_the_joint_limits_are_dropped_with_that_reason() -> None:
    robot = pincal.load_robot("hexapod")
    sim = simulate(robot, ["pose"], 30, 0, perturb=1e-4, noise=1e-6, seed=2, parameter_spec=["*.offset"])
    ds = sim.dataset
    joints = ds.joints.copy()
    joints[4, :6] = [2.0, 0.0, 0.0, 0.0, 0.0, 0.0]  # one leg 2 m longer: beyond its 0.8 m limit
    bad = Dataset(ds.joint_names, joints, ds.measurements, ds.sample_ids, ds.sets, ds.metadata)
    cal = calibrate(robot, bad, parameter_spec=["*.offset"])
    assert cal.report.dropped_samples == [
        DroppedSample("4", "joint 'leg_1_prismatic' reads 2 m, outside its URDF limits [-0.55, 0.8] m")]
    assert cal.report.n_samples == 29 and cal.result.converged


def test_a_reading_just_past_a_nominal_limit_is_kept_and_one_well_past_is_dropped() -> None:
    """URDF limits are nominal: the real TIAGo torso reads 0.350184 m against a 0.35 m limit."""
    from pincal.calibration.samples import out_of_limits

    robot = pincal.load_robot("delta")  # arm limits [-1.2, 1.6] rad: 1 % of the range is 0.028 rad
    joints = np.array([[0.1, 0.2, 0.3], [1.62, 0.2, 0.3], [1.7, 0.2, 0.3], [0.1, -1.25, 0.3]])
    data = Dataset(list(robot.actuated_joints), joints, {}, ["a", "b", "c", "d"], ["train"] * 4, {})
    found = out_of_limits(robot, data)
    assert [k for k, _ in found] == [2, 3]
    assert found[0][1] == "joint 'arm_1_joint' reads 1.7 rad, outside its URDF limits [-1.2, 1.6] rad"
