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
