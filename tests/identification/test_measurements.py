"""Measurement models own their maths: a new sensor is one subclass, and the problem stacks it unasked."""

from __future__ import annotations

from dataclasses import dataclass
from typing import ClassVar

import numpy as np
import pinocchio as pin
import pytest
from conftest import finite_difference_jacobian

import pincal
from pincal.errors import DataError
from pincal.identification import measurements as ms
from pincal.identification.parameters import candidate_parameters
from pincal.identification.problem import CalibrationProblem, Observations
from pincal.io.dataset import MEASUREMENT_COMPONENTS
from pincal.study.simulation import random_actuated


@dataclass(frozen=True)
class Height(ms.Measurement):
    """Height [m] of a frame's origin above the measurement frame's xy plane (a dial gauge, an altimeter)."""

    components: ClassVar[tuple[str, ...]] = ("z",)

    frame: str = ""

    @property
    def frames(self) -> tuple[str, ...]:
        return (self.frame,)

    def predict(self, ctx: ms.SampleContext, out: np.ndarray, jac: np.ndarray | None) -> None:
        placement = ctx.placement(self.frame)
        out[0] = ctx.base.act(placement.translation)[2]
        if jac is not None:
            motion = ms.point_derivative(placement, ctx.twists[self.frame], np.zeros(3))
            jac[0] = (ctx.base.rotation @ motion)[2]
            if ctx.base_columns:
                base_motion = np.hstack([np.eye(3), -pin.skew(placement.translation)]) @ ctx.base_jacobian
                jac[0, ctx.base_columns] = (ctx.base.rotation @ base_motion)[2]


@pytest.mark.parametrize(("name", "frame"), [("delta", "end_effector"), ("ur10", "tool0")])
def test_a_new_sensor_is_one_class(name: str, frame: str) -> None:
    robot = pincal.load_robot(name)
    height = Height(f"height:{frame}", 1, 1e-6, frame)
    models = [ms.position(frame), height]
    pset = candidate_parameters(robot, frames=[frame], offsets=list(robot.actuated_joints), base=True)
    rng = np.random.default_rng(5)
    qa, _ = random_actuated(robot, 4, rng)
    values = {models[0].key: np.zeros((4, 3)), height.key: np.full((4, 1), 0.1)}
    problem = CalibrationProblem(robot, pset, models, Observations(qa, values))
    x = rng.normal(scale=1e-3, size=len(pset))
    pred = problem.evaluate(x)
    # the height is the z row of the position, whatever the parameters
    assert np.allclose(pred.predicted[height.key][:, 0], pred.predicted[models[0].key][:, 2], atol=1e-14)
    assert np.allclose(pred.errors[height.key][:, 0], pred.predicted[height.key][:, 0] - 0.1, atol=1e-14)
    assert pred.jacobian is not None
    assert pred.jacobian.shape == (4 * 4, len(pset))
    assert np.array_equal(problem.row_samples(), np.concatenate([np.repeat(np.arange(4), 3), np.arange(4)]))
    fd = finite_difference_jacobian(problem, x)
    assert np.max(np.abs(pred.jacobian - fd)) < 1e-5 * np.max(np.abs(fd))


def test_a_new_sensor_s_data_width_comes_from_its_columns() -> None:
    robot = pincal.load_robot("ur10")
    height = Height("height:tool0", 1, 1e-6, "tool0")
    qa, _ = random_actuated(robot, 3, np.random.default_rng(1))
    pset = candidate_parameters(robot, frames=["tool0"])
    with pytest.raises(DataError, match=r"'height:tool0' has shape \(3, 3\); expected \(3, 1\) for height:tool0:z"):
        CalibrationProblem(robot, pset, [height], Observations(qa, {height.key: np.zeros((3, 3))}))


@pytest.mark.parametrize("key", ["position:tool0", "pose:tool0", "distance:tool0-base_link",
                                 "distance_increment:tool0-base_link", "joint:elbow_joint"])
def test_keys_parse_to_their_model_and_name_the_dataset_columns(key: str) -> None:
    model = ms.parse_key(key)
    assert model.key == key
    kind = key.split(":", 1)[0]
    expected = (model.joint,) if isinstance(model, ms.JointReading) else \
        tuple(f"{key}:{c}" for c in MEASUREMENT_COMPONENTS[kind])
    assert model.columns == expected
    assert len(model.row_units()) == model.size == model.row_sigmas().size


def test_an_unknown_kind_lists_the_known_ones() -> None:
    with pytest.raises(DataError,
                       match="kinds are position, pose, camera, camera_point, distance, distance_increment, joint"):
        ms.parse_key("height:tool0")


#: Every built-in kind, with a frame of the UR10 (a camera and a pose target on the tool, a declared marker).
BUILT_IN = ["position:tool0", "position:tool0@m1", "pose:tool0", "pose:tool0@t1", "camera:tool0",
            "camera_point:tool0", "distance:tool0-base_link", "distance_increment:tool0-base_link",
            "joint:elbow_joint"]


@pytest.mark.parametrize("key", BUILT_IN)
def test_a_model_says_the_width_units_and_neutral_reading_of_its_data(key: str) -> None:
    model = ms.parse_key(key)
    quaternion = isinstance(model, ms.Pose)  # a pose's (and a camera's) reading ends in a unit quaternion
    assert model.width == len(model.columns) == (7 if quaternion else model.size)
    assert len(model.column_units) == model.width
    assert model.column_units == (("m",) * 3 + (ms.QUATERNION,) * 4 if quaternion else
                                  ("rad or m",) if isinstance(model, ms.JointReading) else ("m",) * model.width)
    expected = np.zeros((4, model.width))  # what simulation and pose design built by hand
    if quaternion:
        expected[:, 6] = 1.0
    assert np.array_equal(model.neutral(4), expected)


@pytest.mark.parametrize("key", BUILT_IN)
def test_a_model_simulates_its_readings_as_the_simulation_did(key: str) -> None:
    model = ms.parse_key(key)
    rng = np.random.default_rng(3)
    predicted = rng.normal(size=(5, model.size))
    got = model.simulate(predicted, 1e-3, np.random.default_rng(7))
    rng = np.random.default_rng(7)  # the simulation's former branches, drawing in the same order
    if isinstance(model, ms.Pose):
        want = np.empty((5, 7))
        want[:, :3] = predicted[:, :3] + rng.normal(scale=1e-3, size=(5, 3))
        for k in range(5):
            quat = pin.Quaternion(pin.exp3(predicted[k, 3:]) @ pin.exp3(rng.normal(scale=1e-3, size=3)))
            want[k, 3:] = [quat.x, quat.y, quat.z, quat.w]
    elif model.incremental:
        want = np.full((5, 1), np.nan)
        want[1:, 0] = np.diff(predicted[:, 0]) + rng.normal(scale=1e-3, size=4)
    else:
        want = predicted + rng.normal(scale=1e-3, size=predicted.shape)
    np.testing.assert_array_equal(got, want)


def test_models_say_which_markers_cameras_targets_and_joints_they_read() -> None:
    marker = ms.position("tool0", marker="m1").with_markers({"tool0@m1": (0.0, 0.0, 0.05), "other@m2": (1, 2, 3)})
    assert dict(marker.markers) == {"tool0@m1": (0.0, 0.0, 0.05)} and marker.reads_markers
    assert dict(ms.position("tool0").markers) == {"tool0": None}
    assert ms.position("tool0").with_markers({}) == ms.position("tool0")
    assert ms.pose("tool0", target="t1").attachments == (ms.Attachment("target", "tool0@t1"),)
    assert ms.pose("tool0").attachments == () and not ms.pose("tool0").reads_markers
    assert ms.camera_pose("tool0").attachments == (ms.Attachment("camera", "tool0"), ms.Attachment("target", ""))
    assert ms.camera_point("tool0").attachments[1] == ms.Attachment("target", "", ("tx", "ty", "tz"))
    assert ms.joint_reading("device_lvdt").read_joints == ("device_lvdt",)
    assert ms.distance("a", "b").reads_markers and ms.distance("a", "b").read_joints == ()
    increment = ms.distance("a", "b", 2e-6, increment=True)
    assert increment.absolute() == ms.distance("a", "b", 2e-6) and ms.position("a").absolute() == ms.position("a")
    assert ms.pose("tool0").with_angle_sigma(3e-4).row_sigmas()[3:].tolist() == [3e-4] * 3
    assert ms.position("tool0").with_angle_sigma(3e-4) == ms.position("tool0")
    with pytest.raises(DataError, match="'position:tool0' has no closed-form start"):
        ms.position("tool0").closed_form([], np.zeros((0, 3)))
