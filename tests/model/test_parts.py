"""Independent loop blocks (pincal.model.parts): a robot of many four-bars checked, ranked and assembled block by block
gives the whole model's figures, and names the culprit loop as the whole model did."""

from __future__ import annotations

import numpy as np
import pinocchio as pin
import pytest
from many_four_bars import DRAFT_ANGLES, closed_angles, many_four_bars_urdf

import pincal
from pincal.errors import LoopError
from pincal.model.assembly import assemble_urdf
from pincal.model.per_thread import made
from pincal.model.robot import robot_from_urdf_text


def test_independent_four_bars_are_one_block_each_and_the_delta_one(delta: pincal.Robot) -> None:
    robot = robot_from_urdf_text(many_four_bars_urdf(4))
    blocks = robot.parts.blocks
    assert [part.loops for part in blocks] == [(0,), (1,), (2,), (3,)]
    assert [part.robot.model.nv for part in blocks] == [3, 3, 3, 3]
    assert [part.robot.actuated_joints for part in blocks] == [[f"crank_joint_{k}"] for k in range(4)]
    assert not any(part.whole for part in blocks)
    assert [part.whole for part in delta.parts.blocks] == [True]  # every loop closes on the platform
    assert delta.parts.blocks[0].robot is delta


def test_blocks_give_the_whole_models_residual_and_rank() -> None:
    robot = robot_from_urdf_text(many_four_bars_urdf(4))
    q = pin.randomConfiguration(robot.model, -np.ones(robot.model.nq), np.ones(robot.model.nq))
    whole = robot.kinematics.closure_residual(q)  # the whole model's data, as before blocks
    assert np.max(np.abs(whole)) > 1e-2  # an open configuration: every row is exercised
    np.testing.assert_allclose(robot.closure_residual(q), whole, rtol=0.0, atol=1e-15)
    _, jacobian = robot.kinematics.closure_jacobian(q)
    assert robot.mobility(q) == robot.model.nv - np.linalg.matrix_rank(jacobian, tol=1e-8)
    assert robot.mobility() == 4


def test_a_robot_of_blocks_never_makes_the_whole_models_data() -> None:
    robot = robot_from_urdf_text(many_four_bars_urdf(5))
    assert robot.mobility() == 5 and np.max(np.abs(robot.closure_residual(robot.q_reference))) < 1e-15
    assert robot.end_effector == "end_effector"
    assert not made(robot.kinematics, "data")  # nv³ numbers: what 66 loops could not afford
    robot.kinematics.data  # noqa: B018  # made, the probe sees it
    assert made(robot.kinematics, "data")


def _moved_anchor(text: str, loop: int) -> str:
    old = f'<successor link="rocker_{loop}"><origin xyz="0.2 0 0"'
    assert old in text
    return text.replace(old, f'<successor link="rocker_{loop}"><origin xyz="0.2001 0 0"')


def test_an_open_loop_in_a_later_block_is_named() -> None:
    text = _moved_anchor(_moved_anchor(many_four_bars_urdf(5), 3), 2)
    with pytest.raises(LoopError, match=r"loop 'coupler_rocker_2' does not close at the reference configuration "
                                        r"\(all joints zero\): residual 0\.0001 m/rad"):
        robot_from_urdf_text(text)


def test_a_redundant_loop_and_a_missing_transmission_are_named_in_their_block() -> None:
    text = many_four_bars_urdf(4)
    start = text.index('<loop name="coupler_rocker_2"')
    twin = text[start:text.index("</loop>", start) + len("</loop>")].replace("coupler_rocker_2", "twin_2")
    with pytest.raises(LoopError, match=r"loops coupler_rocker_2, twin_2 add no constraint that the other "
                                        r"loops do not already impose \(closure rank 8 with or without each\)"):
        robot_from_urdf_text(text.replace("</robot>", twin + "\n</robot>"))
    start = text.index('<transmission name="crank_transmission_1"')
    lost = text[:start] + text[text.index("</transmission>", start) + len("</transmission>"):]
    with pytest.raises(LoopError, match=r"mobility is 4 \(nv 12 minus closure rank 8\) but 3 joints are actuated"):
        robot_from_urdf_text(lost)


def test_blocks_assemble_each_four_bar_at_its_closed_form_angles() -> None:
    assembly = assemble_urdf(many_four_bars_urdf(3, assembled=False))
    coupler, rocker = closed_angles()
    shifts = {s.joint: s.value for s in assembly.shifts}
    assert list(shifts) == [f"coupler_joint_{k}" for k in range(3)] + [f"rocker_joint_{k}" for k in range(3)]
    for k in range(3):
        assert shifts[f"coupler_joint_{k}"] == pytest.approx(coupler - DRAFT_ANGLES[0], abs=1e-12)
        assert shifts[f"rocker_joint_{k}"] == pytest.approx(rocker - DRAFT_ANGLES[1], abs=1e-12)
    assert assembly.residual_after < 1e-15 and assembly.steps == 3
    closed = robot_from_urdf_text(assembly.text)
    exact = robot_from_urdf_text(many_four_bars_urdf(3))
    for j in range(1, exact.model.njoints):
        assert closed.model.jointPlacements[j].isApprox(exact.model.jointPlacements[j], 1e-14)
