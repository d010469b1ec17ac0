"""An ISO 9283 runs file's errors (``pincal iso9283 evaluate``) name their culprit as fields beside the message: the
file, and where known the line and the column; the command still says it in one line."""

from __future__ import annotations

from pathlib import Path

import pytest
from conftest import run_pincal

from pincal.errors import DataError
from pincal.io.iso_runs import read_runs

HEADER = "pose,cycle,direction,cmd_x,cmd_y,cmd_z,x,y,z"


def _error(tmp_path: Path, *lines: str) -> DataError:
    path = tmp_path / "runs.csv"
    path.write_text("\n".join(["# robot: ur10", *lines]) + "\n", encoding="utf-8")
    with pytest.raises(DataError) as caught:
        read_runs(path)
    assert caught.value.file == str(path)
    return caught.value


def test_a_missing_column_is_named_in_the_header(tmp_path: Path) -> None:
    error = _error(tmp_path, "pose,cycle,x,y,z", "P1,0,0,0,0")
    assert (error.column, error.line) == ("cmd_x", 2)


def test_a_column_read_twice_is_named(tmp_path: Path) -> None:
    error = _error(tmp_path, HEADER + ",x", "P1,0,,0,0,0,0,0,0,0")
    assert (error.column, error.line) == ("x", 2)


def test_half_the_orientation_columns_name_the_first_missing(tmp_path: Path) -> None:
    error = _error(tmp_path, HEADER + ",qw,qx,qy,qz", "P1,0,,0,0,0,0,0,0,1,0,0,0")
    assert (error.column, error.line) == ("cmd_qw", 2)


def test_a_cycle_that_is_no_number_is_named_by_column_and_line(tmp_path: Path) -> None:
    error = _error(tmp_path, HEADER, "P1,0,,0,0,0,0,0,0", "P1,one,,0,0,0,0,0,0")
    assert (error.column, error.line) == ("cycle", 4)


def test_a_cell_that_is_no_number_is_named_by_column_and_line(tmp_path: Path) -> None:
    error = _error(tmp_path, HEADER, "P1,0,,0,0,0,0,zero,0")
    assert (error.column, error.line) == ("y", 3)


def test_a_pose_measured_twice_is_named_on_its_second_line(tmp_path: Path) -> None:
    error = _error(tmp_path, HEADER, "P1,0,,0,0,0,0,0,0", "P2,0,,0,0,0,0,0,0", "P1,0,,0,0,0,0,0,0")
    assert (error.column, error.line) == (None, 5)


def test_a_position_in_millimetres_is_named_by_its_line(tmp_path: Path) -> None:
    error = _error(tmp_path, HEADER, "P1,0,,0.5,0,0,0.5,0,0", "P1,1,,0.5,0,0,500,0,0")
    assert error.line == 4


def test_the_command_names_the_pose_measured_twice(tmp_path: Path) -> None:
    (tmp_path / "runs.csv").write_text(f"{HEADER}\nP1,0,,0.6,0,0.4,0.6,0,0.4\nP1,0,,0.6,0,0.4,0.6,0,0.4\n",
                                       encoding="utf-8")
    done = run_pincal("iso9283", "evaluate", "ur10", "runs.csv", cwd=tmp_path)
    assert done.returncode == 2 and done.stdout == "", done.stdout + done.stderr
    assert done.stderr.splitlines() == ["pincal: error: runs.csv: line 3: pose P1 in cycle 0 was measured already on "
                                        "line 2"]
