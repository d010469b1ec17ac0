"""The files of an ISO 9283 test (docs/iso9283.md): the measured runs ``pincal iso9283 evaluate`` reads.

A **runs** file is a CSV (``#`` comment lines first, as a dataset's) with one row per attained pose:

- ``pose`` (``P1`` … ``P5``, or any name), ``cycle`` (a whole number);
- ``cmd_x, cmd_y, cmd_z`` the commanded position and ``x, y, z`` the attained one [m];
- optionally ``cmd_qw, cmd_qx, cmd_qy, cmd_qz`` and ``qw, qx, qy, qz``: the commanded and attained orientation as
  unit quaternions (all eight or none);
- optionally ``direction``: empty for the pose accuracy and repeatability series, else the approach direction of
  the multi-directional series (any label, ``+x``, ``-y`` …).

Other columns (``step``, joint commands of the plan) are read past. SI units: m.
"""

from __future__ import annotations

from dataclasses import field
from pathlib import Path

import numpy as np
import numpy.typing as npt

from pincal.errors import DataError, listing
from pincal.io.dataset import MAX_PLAUSIBLE_LENGTH, QUATERNION_NORM_TOLERANCE
from pincal.io.dataset_reader import cell_number, check_si_units, read_table
from pincal.records import record

Array = npt.NDArray[np.float64]

POSITION = ("x", "y", "z")
QUATERNION = ("qw", "qx", "qy", "qz")
COMMANDED = "cmd_"
#: Most rows of a runs file (the standard's tests hold 5 × 30 + 3 × 3 × 30 rows; a study of many cycles more).
MAX_RUNS = 100_000


@record(frozen=True)
class Runs:
    """The attained poses of an ISO 9283 test, one row per measurement in file order.

    Attributes:
        poses: Each row's pose name.
        cycles: (N,) each row's cycle number.
        directions: Each row's approach direction, ``""`` in the pose series.
        commanded: (N, 3) commanded positions [m].
        attained: (N, 3) attained positions [m].
        commanded_quaternions: (N, 4) commanded orientations (w, x, y, z), or None when not measured.
        attained_quaternions: (N, 4) attained orientations (w, x, y, z), or None.
        lines: (N,) each row's line in the file.
        metadata: The file's ``# key: value`` lines.
    """

    poses: list[str]
    cycles: npt.NDArray[np.int64]
    directions: list[str]
    commanded: Array
    attained: Array
    commanded_quaternions: Array | None
    attained_quaternions: Array | None
    lines: npt.NDArray[np.int64]
    metadata: dict[str, str] = field(default_factory=dict)


def read_runs(path: str | Path) -> Runs:
    """Read a runs file (this module's docstring).

    Raises:
        DataError: naming the file and the column or line at fault: a required column missing, a cell that is no
            finite number or no whole cycle, a quaternion not of unit norm, a length that looks like millimetres, half
            of the orientation columns, a column read appearing twice, an empty pose name, a pose measured twice in
            one cycle and direction. Its fields say the same: ``file`` (``path``), and where known ``line`` and
            ``column``.
    """
    source = Path(path)
    try:
        return _parse(source)
    except DataError as exc:
        raise DataError(f"{source.name}: {exc}", column=exc.column, sample=exc.sample, file=str(path),
                        line=exc.line) from None


def _parse(source: Path) -> Runs:
    table = read_table(source, MAX_RUNS, f"rows: pincal iso9283 evaluate takes at most {MAX_RUNS}")
    check_si_units(table.metadata)
    where, header = f"header (line {table.header_line})", table.header_line
    column = {name: i for i, name in enumerate(table.header)}
    position = ["pose", "cycle", *(COMMANDED + c for c in POSITION), *POSITION]
    read = {*position, "direction", *(COMMANDED + c for c in QUATERNION), *QUATERNION}
    twice = next((name for name in table.header if name in read and table.header.count(name) > 1), None)
    if twice is not None:  # the dict above keeps the last one alone
        first = table.header.index(twice)
        raise DataError(f"{where}: column '{twice}' appears twice (columns {first + 1} and {column[twice] + 1})",
                        column=twice, line=header)
    missing = [name for name in position if name not in column]
    if missing:
        raise DataError(f"{where}: no column {listing(missing)}; a runs file has pose, cycle, cmd_x, cmd_y, cmd_z, "
                        "x, y, z [m] (and optionally cmd_qw…cmd_qz, qw…qz, direction: docs/iso9283.md)",
                        column=missing[0], line=header)
    orientation = [COMMANDED + c for c in QUATERNION] + list(QUATERNION)
    present = [name for name in orientation if name in column]
    if present and len(present) != len(orientation):
        raise DataError(f"{where}: orientation columns {listing(present)} without "
                        f"{listing([n for n in orientation if n not in column])}: give all eight or none",
                        column=next(n for n in orientation if n not in column), line=header)
    if not table.rows:
        raise DataError("no rows")
    poses, directions, cycles, lines = [], [], [], []
    numbers = {name: np.empty(len(table.rows)) for name in position[2:] + present}
    seen: dict[tuple[str, str, int], int] = {}
    for k, (line, cells) in enumerate(table.rows):
        pose = cells[column["pose"]]
        if not pose:
            raise DataError(f"line {line}: empty pose name", column="pose", line=line)
        cycle_cell = cells[column["cycle"]]
        if not cycle_cell.isdigit():
            raise DataError(f"line {line}: cycle '{cycle_cell}' is not a whole number ≥ 0", column="cycle", line=line)
        direction = cells[column["direction"]] if "direction" in column else ""
        key = (pose, direction, int(cycle_cell))
        if key in seen:
            raise DataError(f"line {line}: pose {pose} in cycle {key[2]}"
                            + (f" from direction {direction}" if direction else "")
                            + f" was measured already on line {seen[key]}", line=line)
        seen[key] = line
        poses.append(pose)
        directions.append(direction)
        cycles.append(int(cycle_cell))
        lines.append(line)
        for name in numbers:
            numbers[name][k] = cell_number(cells[column[name]], name, line)
    commanded = np.column_stack([numbers[COMMANDED + c] for c in POSITION])
    attained = np.column_stack([numbers[c] for c in POSITION])
    worst = int(np.argmax(np.abs(np.vstack([commanded, attained])).max(axis=1)))
    if np.abs(np.vstack([commanded, attained])).max() > MAX_PLAUSIBLE_LENGTH:
        raise DataError(f"line {lines[worst % len(lines)]}: a position beyond {MAX_PLAUSIBLE_LENGTH:g} m; the "
                        "columns are in metres (millimetres divided by 1000)", line=lines[worst % len(lines)])
    quaternions = None
    if present:
        quaternions = [np.column_stack([numbers[prefix + c] for c in QUATERNION]) for prefix in (COMMANDED, "")]
        for prefix, values in zip((COMMANDED, ""), quaternions, strict=True):
            off = np.flatnonzero(np.abs(np.linalg.norm(values, axis=1) - 1.0) > QUATERNION_NORM_TOLERANCE)
            if off.size:
                raise DataError(f"line {lines[off[0]]}: quaternion {prefix}qw…{prefix}qz of norm "
                                f"{np.linalg.norm(values[off[0]]):.6g}, not 1", line=lines[off[0]])
    return Runs(poses, np.array(cycles, dtype=np.int64), directions, commanded, attained,
                quaternions[0] if quaternions else None, quaternions[1] if quaternions else None,
                np.array(lines, dtype=np.int64), table.metadata)
