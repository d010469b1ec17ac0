"""pincal.io.export's arguments checked as the command line checks its own: the wrong type a TypeError, text that
is not a URDF a PincalError naming the argument (not the XML parser's ParseError), each naming the value."""

from __future__ import annotations

import pytest
from conftest import ROBOTS

import pincal
from pincal.errors import ArgumentError, RobotFileError
from pincal.io.export import dh_export, joint_origins_yaml


@pytest.fixture(scope="module")
def arm() -> tuple[pincal.Robot, str]:
    path = ROBOTS / "five_bar.urdf"
    return pincal.load_robot(path), path.read_text(encoding="utf-8")


@pytest.mark.parametrize(("text", "message"), [
    ("not xml at all", r"urdf_text='not xml at all': not a URDF: XML syntax error: line 1, column 0"),
    ("<robot name='r'><link></robot>", r"urdf_text=.*: not a URDF: XML mismatched tag: line 1, column 24"),
    ("<html><body/></html>", r"urdf_text: the root element is <html>, not <robot>: not a URDF"),
], ids=["not-xml", "broken-xml", "not-a-robot"])
def test_text_that_is_not_a_urdf_is_named(arm: tuple[pincal.Robot, str], text: str, message: str) -> None:
    with pytest.raises(RobotFileError, match=message):
        joint_origins_yaml(text, "given")
    with pytest.raises(RobotFileError, match=message):
        dh_export(arm[0], text, "given", "dh")


def test_arguments_of_the_wrong_type_or_value_are_named(arm: tuple[pincal.Robot, str]) -> None:
    robot, text = arm
    with pytest.raises(TypeError, match=r"urdf_text=None: expected the text of a URDF \(str\), not NoneType"):
        joint_origins_yaml(None, "given")  # type: ignore[arg-type]
    with pytest.raises(TypeError, match=r"source=3: expected a description \(str\), not int"):
        joint_origins_yaml(text, 3)  # type: ignore[arg-type]
    with pytest.raises(TypeError, match=r"robot=None: expected a Robot \(pincal.load_robot\), not NoneType"):
        dh_export(None, text, "given", "dh")  # type: ignore[arg-type]
    with pytest.raises(ArgumentError, match=r"tolerance=nan: must be a finite number > 0 \[m, rad\]"):
        dh_export(robot, text, "given", "dh", tolerance=float("nan"))
    with pytest.raises(ArgumentError, match=r"postures=0: must be a whole number ≥ 1"):
        dh_export(robot, text, "given", "dh", postures=0)
    with pytest.raises(TypeError, match=r"seed='x': expected a whole number \(int\), not str"):
        dh_export(robot, text, "given", "dh", seed="x")  # type: ignore[arg-type]
