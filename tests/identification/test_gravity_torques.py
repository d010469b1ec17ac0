"""The gravity torques behind joint compliance, with a payload: checked against the gradient of the potential energy
by finite differences and against Pinocchio with the mass added to the model; the payload's bad inputs."""

from __future__ import annotations

import re

import numpy as np
import pinocchio as pin
import pytest

import pincal
from pincal.errors import DataError, NotFoundError
from pincal.identification.corrections import (
    GRAVITY,
    Payload,
    correction_regressors,
    gravity_torques,
    payload_from_dict,
)
from pincal.model.robot import Robot, robot_from_urdf_text
from pincal.study.simulation import random_actuated


@pytest.fixture(scope="module")
def ur10() -> Robot:
    return pincal.load_robot("ur10")


def payload_height(robot: Robot, payload: Payload, qa: np.ndarray) -> float:
    """z [m] of the payload's point in the root frame at actuated readings ``qa``."""
    placement = robot.placement(robot.solve_fk(qa), payload.frame)
    return float((placement.act(np.asarray(payload.offset)))[2])


def potential_gradient(robot: Robot, payload: Payload, qa: np.ndarray, eps: float = 1e-6) -> np.ndarray:
    """∂(m g z_p)/∂q_a by central differences: the generalized gravity force of the payload, found without
    Jacobians."""
    out = np.empty(robot.n_actuated)
    for k in range(robot.n_actuated):
        step = np.zeros(robot.n_actuated)
        step[k] = eps
        rise = payload_height(robot, payload, qa + step) - payload_height(robot, payload, qa - step)
        out[k] = payload.mass * GRAVITY * rise / (2 * eps)
    return out


@pytest.mark.parametrize(("name", "payload"), [
    ("ur10", Payload(7.5, "tool0", (0.03, -0.02, 0.15))),
    ("ur10", Payload(2.0, "forearm_link", (0.2, 0.05, 0.1))),  # mid-arm: the wrist joints carry none of it
    ("tiago_no_hand", Payload(1.5, "wrist_ft_tool_link", (0.0, 0.0, 0.12))),  # a prismatic torso: a force [N]
])
def test_payload_torque_is_the_gradient_of_its_potential_energy(name: str, payload: Payload) -> None:
    robot = pincal.load_robot(name)
    qa, _ = random_actuated(robot, 4, np.random.default_rng(2))
    links = gravity_torques(robot, qa)
    loaded = gravity_torques(robot, qa, payload)
    for k in range(qa.shape[0]):
        expected = potential_gradient(robot, payload, qa[k])
        assert np.abs(expected).max() > 1.0  # [N m or N]: a load the joints feel
        np.testing.assert_allclose(loaded[k] - links[k], expected, atol=1e-6 * np.abs(expected).max())
    if payload.frame == "forearm_link":
        assert np.abs(loaded[:, 3:] - links[:, 3:]).max() < 1e-9


def test_payload_torque_is_pinocchios_with_the_mass_added_to_the_model(ur10: Robot) -> None:
    """The same load as a point inertia on the frame's joint: Pinocchio's computeGeneralizedGravity agrees."""
    payload = Payload(4.0, "tool0", (0.01, 0.02, 0.1))
    model = ur10.model.copy()
    frame = model.frames[model.getFrameId("tool0")]
    point = pin.Inertia(payload.mass, frame.placement.act(np.asarray(payload.offset)), np.zeros((3, 3)))
    model.inertias[frame.parentJoint] = model.inertias[frame.parentJoint] + point
    data = model.createData()
    qa, _ = random_actuated(ur10, 3, np.random.default_rng(5))
    ours = gravity_torques(ur10, qa, payload)
    for k in range(qa.shape[0]):
        np.testing.assert_allclose(ours[k], pin.computeGeneralizedGravity(model, data, ur10.solve_fk(qa[k])),
                                   atol=1e-9)


def test_the_compliance_regressor_carries_the_payload(ur10: Robot) -> None:
    qa, _ = random_actuated(ur10, 3, np.random.default_rng(1))
    payload = Payload(3.0, "tool0")
    kinds = [("elbow_joint", "compliance"), ("elbow_joint", "sin1")]
    with_load = correction_regressors(ur10, kinds, qa, payload)
    plain = correction_regressors(ur10, kinds, qa)
    np.testing.assert_allclose(with_load[0], gravity_torques(ur10, qa, payload)[:, 2])
    assert np.abs(with_load[0] - plain[0]).min() > 1.0  # [N m]
    np.testing.assert_array_equal(with_load[1], plain[1])  # a harmonic does not see the load


def test_links_without_mass_take_the_payload_alone(ur10: Robot) -> None:
    """A massless URDF with a payload: the compliance runs on the payload's torque alone; without one (or with a
    payload of no mass) it is refused, and the message says how to give one."""
    assert ur10.source is not None
    massless = robot_from_urdf_text(re.sub(r"<inertial>.*?</inertial>", "", ur10.source.read_text(), flags=re.S))
    qa, _ = random_actuated(ur10, 3, np.random.default_rng(4))
    payload = Payload(5.0, "tool0", (0.0, 0.0, 0.1))
    alone = gravity_torques(massless, qa, payload)
    np.testing.assert_allclose(alone, gravity_torques(ur10, qa, payload) - gravity_torques(ur10, qa), atol=1e-9)
    with pytest.raises(DataError, match=r"carry no <inertial> mass in the URDF; when the load is a payload alone, "
                                        r"give it \(--payload MASS@FRAME\)"):
        gravity_torques(massless, qa)
    with pytest.raises(DataError, match=r"the payload, 0 kg on tool0, has none either"):
        gravity_torques(massless, qa, Payload(0.0, "tool0"))


@pytest.mark.parametrize(("mass", "frame", "offset", "message"), [
    (-1.0, "tool0", (0, 0, 0), "payload mass -1 kg: a mass is a finite number ≥ 0 [kg]"),
    (float("nan"), "tool0", (0, 0, 0), "payload mass nan kg"),
    (float("inf"), "tool0", (0, 0, 0), "payload mass inf kg"),
    ("heavy", "tool0", (0, 0, 0), "payload mass 'heavy' is not a number [kg]"),
    (1.0, " ", (0, 0, 0), "payload frame ' ': name the frame the mass is on"),
    (1.0, "tool0", (0, 0), "payload offset 0, 0: give three finite numbers x, y, z [m] in frame 'tool0'"),
    (1.0, "tool0", (0, 0, float("nan")), "payload offset 0, 0, nan"),
    (1.0, "tool0", ("a", 0, 0), "payload offset ('a', 0, 0) is not three numbers"),
])
def test_a_bad_payload_is_refused_by_name(mass: object, frame: str, offset: tuple[object, ...], message: str) -> None:
    with pytest.raises(DataError) as caught:
        Payload(mass, frame, offset)  # type: ignore[arg-type]
    assert message in str(caught.value)


def test_a_payload_on_a_frame_the_robot_lacks_lists_the_frames(ur10: Robot) -> None:
    with pytest.raises(NotFoundError) as caught:
        gravity_torques(ur10, np.zeros((1, 6)), Payload(1.0, "tool1"))
    assert str(caught.value).startswith("payload: frame 'tool1' does not exist in robot 'ur10'; frames are: ")
    assert "tool0" in caught.value.choices


def test_a_payload_reads_back_from_its_dict() -> None:
    payload = Payload(1.5, "tool0", (0.0, 0.0, 0.1))
    assert payload_from_dict(payload.as_dict()) == payload and payload_from_dict(None) is None
    assert payload_from_dict({"mass": 2, "frame": "tool0"}) == Payload(2.0, "tool0")
    assert str(payload) == "1.5 kg on tool0 at (0, 0, 0.1) m" and str(Payload(2, "ee_link")) == "2 kg on ee_link"
    for bad, message in [({"mass": 1.0}, "is not {mass = KG"), ({"mass": True, "frame": "a"}, "mass is a number"),
                         ({"mass": 1.0, "frame": "a", "offset": "0 0 1"}, "offset a list of three numbers"),
                         ({"mass": 1.0, "frame": "a", "colour": "red"}, "is not {mass = KG"),
                         ({"mass": -2.0, "frame": "a"}, "f.json: payload mass -2 kg")]:
        with pytest.raises(DataError, match=re.escape(message)):
            payload_from_dict(bad, "f.json: ")
