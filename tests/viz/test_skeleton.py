"""A robot without visuals drawn as a skeleton: its joints, links, loops and frames, where the robot has them."""

from __future__ import annotations

from pathlib import Path

import numpy as np
import pinocchio as pin
from conftest import readme_four_bar

import pincal
from pincal.model.assembly import assemble_urdf
from pincal.model.robot import load_robot
from pincal.viz.visuals import Visual, robot_visuals


def rod_ends(robot_model: pin.Model, data: pin.Data, visual: Visual) -> tuple[np.ndarray, np.ndarray]:
    """A rod's two ends in the world [m] (a meshcat cylinder runs along its y axis, centred)."""
    half = visual.geometry.height / 2
    pose = data.oMf[visual.frame_id].homogeneous @ visual.placement
    return (pose @ [0.0, -half, 0.0, 1.0])[:3], (pose @ [0.0, half, 0.0, 1.0])[:3]


def test_the_four_bar_without_visuals_shows_its_loop_coupler_and_measured_frame(tmp_path: Path) -> None:
    path = tmp_path / "four_bar.urdf"
    path.write_text(assemble_urdf(readme_four_bar()).text, encoding="utf-8")
    robot = load_robot(path)
    visuals, notes = robot_visuals(robot)
    assert notes == ["no drawable visuals: the robot is drawn as a skeleton of its joints, loops and frames"]
    model, data = robot.model, robot.model.createData()
    pin.forwardKinematics(model, data, robot.q_reference)
    pin.updateFramePlacements(model, data)
    by_name = {v.name: v for v in visuals}
    assert {"loop_coupler_rocker_predecessor", "loop_coupler_rocker_successor", "loop_coupler_rocker",
            "to_end_effector", "rod_to_coupler_joint", "rod_to_rocker_joint"} <= set(by_name)
    # the coupler's bar and the rocker's end where the loop closes, 0.25 m and 0.2 m from their joints
    coupler = rod_ends(model, data, by_name["loop_coupler_rocker_predecessor"])
    rocker = rod_ends(model, data, by_name["loop_coupler_rocker_successor"])
    np.testing.assert_allclose(coupler[1], rocker[1], atol=1e-12)
    assert np.isclose(np.linalg.norm(coupler[1] - coupler[0]), 0.25, atol=1e-12)
    assert np.isclose(np.linalg.norm(rocker[1] - rocker[0]), 0.2, atol=1e-12)
    np.testing.assert_allclose(coupler[0], data.oMi[model.getJointId("coupler_joint")].translation, atol=1e-12)
    # the measured frame on the coupler, at the end of its own bar
    tool = rod_ends(model, data, by_name["to_end_effector"])
    np.testing.assert_allclose(tool[1], data.oMf[model.getFrameId("end_effector")].translation, atol=1e-12)
    loop_marker = by_name["loop_coupler_rocker"]
    np.testing.assert_allclose((data.oMf[loop_marker.frame_id].homogeneous @ loop_marker.placement)[:3, 3],
                               coupler[1], atol=1e-12)


def test_a_robot_with_visuals_gets_no_skeleton(delta: pincal.Robot) -> None:
    visuals, _ = robot_visuals(delta)
    assert not any(v.name.startswith(("loop_", "to_", "rod_to_")) for v in visuals)
