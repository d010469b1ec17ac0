"""Rows of plain numbers are read at once, the others cell by cell: the same numbers either way, and every error
still names its row and column, whichever rows come before it."""

from __future__ import annotations

import re
from pathlib import Path

import numpy as np
import pytest

from pincal.errors import DataError
from pincal.io.dataset_reader import read_dataset

HEADER = "sample,j1,j2,position:tool:x,position:tool:y,position:tool:z"


def _write(path: Path, rows: list[str]) -> Path:
    path.write_text("\n".join([HEADER, *rows]) + "\n", encoding="utf-8")
    return path


def test_every_way_of_writing_a_number_reads_as_python_reads_it(tmp_path: Path) -> None:
    cells = ["1", "-0.25", "+3e-2", " 7.5 ", "1E-3", ".5", "5.", "0.1000000000000000055511151231257827", "-0",
             "1.2345678901234567890", "2.2250738585072014e-308", "1e-320"]
    rows = [f"s{k},{a},{b},{c},0.5,\"{d}\"" if k % 3 == 0 else f"s{k},{a},{b},{c},0.5,{d}"
            for k, (a, b, c, d) in enumerate(zip(cells, cells[1:] + cells[:1], cells[2:] + cells[:2],
                                                cells[3:] + cells[:3], strict=True))]
    data = read_dataset(_write(tmp_path / "m.csv", rows))
    expected = np.array([[float(c.strip()) for c in row.replace('"', "").split(",")[1:]] for row in rows])
    read = np.hstack([data.joints, data.measurements["position:tool"]])
    assert read.tobytes() == expected.tobytes()  # bit for bit, the sign of -0 included


@pytest.mark.parametrize(("bad", "column"), [("0.1_0", "j2"), ("nan", "position:tool:y"), ("inf", "j1"),
                                             ("", "position:tool:z"), ("x1", "j1")])
def test_a_bad_cell_after_plain_rows_is_named_by_line_and_column(tmp_path: Path, bad: str, column: str) -> None:
    rows = [f"s{k},0.1,0.2,0.3,0.4,0.5" for k in range(6)]
    cells = rows[4].split(",")
    cells[HEADER.split(",").index(column)] = bad
    rows[4] = ",".join(cells)
    rows.append("s9,0.1,0.2")  # a later row of too few cells: the bad cell comes first
    with pytest.raises(DataError, match=rf"column '{re.escape(column)}', line 6: "):
        read_dataset(_write(tmp_path / "m.csv", rows))


def test_a_short_row_before_a_bad_cell_is_named_first(tmp_path: Path) -> None:
    rows = ["s0,0.1,0.2,0.3,0.4,0.5", "s1,0.1,0.2", "s2,0.1,x,0.3,0.4,0.5"]
    with pytest.raises(DataError, match=r"m.csv: line 3 has 3 cells; the header \(line 1\) has 6$"):
        read_dataset(_write(tmp_path / "m.csv", rows))
