"""A targets file's errors (``pincal compensate``) name their culprit as fields beside the message: the file, and
where known the line, the column and the sample; the command still says it in one line."""

from __future__ import annotations

from pathlib import Path

import pytest
from conftest import run_pincal

from pincal.errors import DataError
from pincal.io.targets import read_targets

POSITION = "sample,position:end_effector:x,position:end_effector:y,position:end_effector:z"
POSE = POSITION.replace("position", "pose") + ",pose:end_effector:qx,pose:end_effector:qy,pose:end_effector:qz," \
    "pose:end_effector:qw"


def _error(tmp_path: Path, *lines: str) -> DataError:
    path = tmp_path / "targets.csv"
    path.write_text("\n".join(lines) + "\n", encoding="utf-8")
    with pytest.raises(DataError) as caught:
        read_targets(path)
    assert caught.value.file == str(path)
    return caught.value


def test_a_column_that_is_no_target_is_named_in_the_header(tmp_path: Path) -> None:
    error = _error(tmp_path, "# units: SI", POSITION + ",force:end_effector:x", "a,0,0,-0.4,1")
    assert (error.column, error.line, error.sample) == ("force:end_effector:x", 2, None)


def test_a_missing_component_is_named_by_its_column(tmp_path: Path) -> None:
    error = _error(tmp_path, POSITION.rpartition(",")[0], "a,0,0")
    assert (error.column, error.line) == ("position:end_effector:z", 1)


def test_an_empty_cell_is_named_by_column_and_line(tmp_path: Path) -> None:
    error = _error(tmp_path, POSITION, "a,0,0,-0.4", "b,0,,-0.4")
    assert (error.column, error.line) == ("position:end_effector:y", 3)


def test_a_quaternion_not_of_unit_norm_is_named_by_its_sample(tmp_path: Path) -> None:
    error = _error(tmp_path, POSE, "a,0,0,-0.4,0,0,0,1", "b,0,0,-0.4,0,0,0,2")
    assert (error.sample, error.line, error.column) == ("b", 3, None)


def test_a_sample_used_twice_is_named_with_its_second_line(tmp_path: Path) -> None:
    error = _error(tmp_path, POSITION, "a,0,0,-0.4", "a,0,0,-0.5")
    assert (error.column, error.sample, error.line) == ("sample", "a", 3)


def test_a_row_whose_status_is_not_ok_is_named_by_its_sample(tmp_path: Path) -> None:
    error = _error(tmp_path, POSITION + ",status", "a,0,0,-0.4,ok", "b,,,,unreachable: too far")
    assert (error.column, error.sample, error.line) == ("status", "b", 3)


def test_the_command_names_the_target_in_millimetres(tmp_path: Path) -> None:
    targets = tmp_path / "targets.csv"
    targets.write_text(f"{POSITION}\na,0,0,-0.4\nb,100,0,-400\n", encoding="utf-8")
    done = run_pincal("compensate", "delta", str(targets), "--out", str(tmp_path / "commands.csv"))
    assert done.returncode == 2 and done.stdout == "", done.stdout + done.stderr
    assert done.stderr.splitlines() == ["pincal: error: targets.csv: line 3: the target [100.0, 0.0, -400.0] lies "
                                        "beyond 20 m: it looks like millimetres; pincal expects metres"]
    assert not (tmp_path / "commands.csv").exists()
