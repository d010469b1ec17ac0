"""A dataset's errors name the culprit as fields (file, line, column, sample), beside the message a user reads: a
program reading many files can point at the cell without parsing the wording."""

from __future__ import annotations

from pathlib import Path

import pytest

from pincal.errors import DataError
from pincal.io.dataset_reader import read_dataset

HEADER = "sample,j1,j2,position:tool:x,position:tool:y,position:tool:z"


def _error(tmp_path: Path, *rows: str) -> DataError:
    path = tmp_path / "data.csv"
    path.write_text("\n".join([HEADER, *rows]) + "\n", encoding="utf-8")
    with pytest.raises(DataError) as caught:
        read_dataset(path)
    assert caught.value.file == str(path)
    return caught.value


def test_a_cell_that_is_no_number_is_named_by_column_and_line(tmp_path: Path) -> None:
    error = _error(tmp_path, "a,0.1,0.2,0.3,0.4,0.5", "b,0.1,zero,0.3,0.4,0.5")
    assert (error.column, error.line, error.sample) == ("j2", 3, None)


def test_an_empty_measurement_cell_is_named_by_its_column(tmp_path: Path) -> None:
    error = _error(tmp_path, "a,0.1,0.2,0.3,,0.5")
    assert (error.column, error.line) == ("position:tool:y", 2)


def test_a_row_of_the_wrong_width_is_named_by_its_line(tmp_path: Path) -> None:
    error = _error(tmp_path, "a,0.1,0.2,0.3,0.4,0.5", "b,0.1,0.2,0.3,0.4")
    assert (error.column, error.line) == (None, 3)


def test_a_sample_id_used_twice_is_named_with_its_second_line(tmp_path: Path) -> None:
    error = _error(tmp_path, "a,0.1,0.2,0.3,0.4,0.5", "a,0.2,0.3,0.3,0.4,0.5")
    assert (error.column, error.sample, error.line) == ("sample", "a", 3)


def test_an_unknown_set_is_named_with_its_sample(tmp_path: Path) -> None:
    path = tmp_path / "data.csv"
    path.write_text(HEADER + ",set\na,0.1,0.2,0.3,0.4,0.5,validation\n", encoding="utf-8")
    with pytest.raises(DataError) as caught:
        read_dataset(path)
    assert (caught.value.column, caught.value.sample, caught.value.line) == ("set", "a", 2)
