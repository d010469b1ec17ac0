"""A robot file's errors name the file (and, for XML that does not parse, the line) as fields beside the message: a
program loading many robots can point at the file without parsing the wording; the command still says it in words."""

from __future__ import annotations

from pathlib import Path

import pytest
from conftest import ROBOTS, run_pincal

import pincal
from pincal.errors import LoopError, RobotFileError
from pincal.model.robot import robot_from_urdf_text


def _line_of(text: str, start: str) -> int:
    """The line (from 1) of ``text`` on which ``start`` is written."""
    return text[:text.index(start)].count("\n") + 1


def test_a_loop_naming_a_missing_link_names_the_file_and_the_line_it_starts_on(tmp_path: Path) -> None:
    path = tmp_path / "delta.urdf"
    text = (ROBOTS / "delta.urdf").read_text().replace('predecessor link="rod_2"', 'predecessor link="rodd_2"', 1)
    path.write_text(text)
    with pytest.raises(LoopError, match="names link 'rodd_2'") as caught:
        pincal.load_robot(path)
    assert (caught.value.file, caught.value.line) == (str(path), _line_of(text, '<loop name="leg_2_platform"'))


def test_a_joint_origin_at_fault_names_the_line_the_joint_starts_on(tmp_path: Path) -> None:
    path = tmp_path / "delta.urdf"
    text = (ROBOTS / "delta.urdf").read_text()
    joint = text.index('<joint name="rod_1_pitch"')
    origin = text.index('rpy="0.0 1.08292', joint)
    path.write_text(text[:origin] + 'rpy="nan 1.08292' + text[origin + len('rpy="0.0 1.08292'):])
    with pytest.raises(RobotFileError, match="joint 'rod_1_pitch' origin rpy") as caught:
        pincal.load_robot(path)
    assert (caught.value.file, caught.value.line) == (str(path), _line_of(text, '<joint name="rod_1_pitch"'))


def test_text_without_a_file_names_the_line_alone() -> None:
    with pytest.raises(RobotFileError, match="duplicate link name 'a'") as caught:
        robot_from_urdf_text("<robot name='r'>\n  <link name='a'/>\n  <link name='a'/>\n</robot>")
    assert (caught.value.file, caught.value.line) == (None, 3)  # the second <link name='a'>


def test_a_mimic_of_no_joint_names_the_line_of_its_element() -> None:
    text = ("<robot name='r'>\n  <link name='a'/>\n  <link name='b'/>\n  <joint name='j' type='revolute'>\n"
            "    <parent link='a'/><child link='b'/>\n    <limit lower='-1' upper='1' effort='1' velocity='1'/>\n"
            "    <mimic joint='nothing'/>\n  </joint>\n</robot>\n")
    with pytest.raises(RobotFileError, match="follows 'nothing'") as caught:
        robot_from_urdf_text(text)
    assert caught.value.line == 7


def test_a_file_too_large_is_named_before_it_is_read(tmp_path: Path) -> None:
    path = tmp_path / "big.urdf"
    path.write_text("<robot name='r'>" + " " * (10 * 2**20) + "</robot>")
    with pytest.raises(RobotFileError) as caught:
        pincal.load_robot(path)
    assert caught.value.file == str(path)


def test_the_command_names_the_file_and_the_line_in_one_line(tmp_path: Path) -> None:
    path = tmp_path / "broken.urdf"
    path.write_text("<robot name='r'>\n  <link name='a'>\n</robot>\n")
    done = run_pincal("info", str(path))
    assert done.returncode == 2, done.stderr
    assert done.stderr.splitlines() == [f"pincal: error: {path} is not well-formed XML: mismatched tag: line 3, "
                                        "column 2"]
