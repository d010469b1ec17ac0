"""A robot file's errors name the file (and, for XML that does not parse, the line) as fields beside the message: a
program loading many robots can point at the file without parsing the wording; the command still says it in words."""

from __future__ import annotations

from pathlib import Path

import pytest
from conftest import ROBOTS, run_pincal

import pincal
from pincal.errors import LoopError, RobotFileError
from pincal.model.robot import robot_from_urdf_text


def test_a_loop_naming_a_missing_link_names_the_file_it_was_read_from(tmp_path: Path) -> None:
    path = tmp_path / "delta.urdf"
    path.write_text((ROBOTS / "delta.urdf").read_text().replace('predecessor link="rod_2"',
                                                                'predecessor link="rodd_2"', 1))
    with pytest.raises(LoopError) as caught:
        pincal.load_robot(path)
    assert (caught.value.file, caught.value.line) == (str(path), None)


def test_text_without_a_file_names_none(tmp_path: Path) -> None:
    with pytest.raises(RobotFileError) as caught:
        robot_from_urdf_text("<robot name='r'>\n  <link name='a'/>\n  <link name='a'/>\n</robot>")
    assert (caught.value.file, caught.value.line) == (None, None)


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
