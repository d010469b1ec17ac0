"""Assembling a closed-loop URDF: the passive joints' new zero against the four-bar's closed form."""

from __future__ import annotations

import math

import numpy as np
import pytest
from conftest import readme_four_bar

from pincal.errors import LoopError
from pincal.model.assembly import assemble_urdf
from pincal.model.robot import robot_from_urdf_text


def four_bar_angles(crank: float, coupler: float, rocker: float, ground: float) -> tuple[float, float]:
    """The coupler's and the rocker's directions [rad] with the crank along +y, by intersecting two circles (the
    solution above the ground line)."""
    b, d = np.array([0.0, crank]), np.array([ground, 0.0])
    distance = float(np.linalg.norm(d - b))
    along = (coupler ** 2 - rocker ** 2 + distance ** 2) / (2 * distance)
    unit = (d - b) / distance
    c = b + along * unit + math.sqrt(coupler ** 2 - along ** 2) * np.array([-unit[1], unit[0]])
    return math.atan2(*(c - b)[::-1]), math.atan2(*(c - d)[::-1])


def test_the_four_bar_closes_at_the_closed_form_angles() -> None:
    assembly = assemble_urdf(readme_four_bar())
    coupler, rocker = four_bar_angles(0.1, 0.25, 0.2, 0.3)
    shifts = {s.joint: s for s in assembly.shifts}
    assert shifts["coupler_joint"].value == pytest.approx(coupler - 0.35, abs=1e-12)
    assert shifts["rocker_joint"].value == pytest.approx(rocker - 1.9, abs=1e-12)
    assert all(s.translation < 1e-15 for s in assembly.shifts)
    robot = robot_from_urdf_text(assembly.text)
    assert np.max(np.abs(robot.closure_residual(robot.q_reference))) < 1e-13
    assert assembly.residual_before > 1e-3 and assembly.residual_after < 1e-13


def test_an_assembled_file_is_left_as_it_is() -> None:
    text = assemble_urdf(readme_four_bar()).text
    again = assemble_urdf(text)
    assert again.text == text and again.shifts == [] and again.steps == 0


def test_a_loop_no_angles_close_is_named() -> None:
    text = readme_four_bar().replace('<origin xyz="0.2 0 0" rpy="0 0 0"/></successor>',
                                     '<origin xyz="0.02 0 0" rpy="0 0 0"/></successor>')
    with pytest.raises(LoopError, match="no values of the passive joints close loop 'coupler_rocker'"):
        assemble_urdf(text)
