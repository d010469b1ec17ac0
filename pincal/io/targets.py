"""Target files and command files: what ``pincal compensate`` reads and writes (docs/compensate.md).

A **targets** file is a dataset CSV (docs/dataset.md) without joint columns: an optional ``sample`` column (ids) and
one measurement group, the place each row asks a frame to reach, in metres:

- ``position:<frame>:x,y,z`` (or ``position:<frame>@<marker>:…``): a point;
- ``pose:<frame>:x,y,z,qx,qy,qz,qw`` (or ``pose:<frame>@<target>:…``): a placement, unit quaternion.

A ``set`` column is allowed and ignored, so a dataset's measurement columns can be cut out as they are; a
``status`` column (a nominal targets file) must say ``ok`` on every row. The
**commands** file holds per target the raw actuated commands [rad or m], the residual of the calibrated model at
those commands and a status; a **nominal targets** file the targets' columns again, in the nominal model's base frame.
"""

from __future__ import annotations

import csv
import io
import math
from collections.abc import Mapping, Sequence
from dataclasses import field
from pathlib import Path

import numpy as np
import numpy.typing as npt

from pincal.errors import DataError, listing
from pincal.identification.measurements.context import split_target
from pincal.io.dataset import MAX_PLAUSIBLE_LENGTH, QUATERNION_NORM_TOLERANCE, SAMPLE_COLUMN, SET_COLUMN
from pincal.io.dataset_reader import cell_number, check_si_units, read_table
from pincal.records import record

Array = npt.NDArray[np.float64]

#: The components of each target kind, in column order.
TARGET_COMPONENTS = {"position": ("x", "y", "z"), "pose": ("x", "y", "z", "qx", "qy", "qz", "qw")}
#: The status of a target reached.
OK = "ok"
#: A target's count of numbers, in words.
NUMBERS = {3: "three", 7: "seven"}
#: The start of the status of a target not reached; the reason follows.
UNREACHABLE = "unreachable"
#: Most targets in one file (or one call of compensate): each costs up to seven inverse kinematics solves when it is
#: unreachable (docs/compensate.md gives the worst wait).
MAX_TARGETS = 5_000
RESIDUAL_POSITION = "residual_position"
RESIDUAL_ORIENTATION = "residual_orientation"
STATUS = "status"
#: The commands file's columns of each target's predicted 95 % bound and the nominal robot's own [m].
BOUND = "bound"
NOMINAL_BOUND = "nominal_bound"


@record(frozen=True)
class Targets:
    """Targets read from a file.

    Attributes:
        key: The measurement key of the columns (``position:end_effector``, ``pose:tool0@tag``).
        ids: The rows' sample ids.
        values: (N, 3) positions [m], or (N, 7) poses: x, y, z [m], then a unit quaternion qx, qy, qz, qw.
        metadata: The file's ``# key: value`` lines.
    """

    key: str
    ids: list[str]
    values: Array
    metadata: dict[str, str] = field(default_factory=dict)

    @property
    def kind(self) -> str:
        """``position`` or ``pose``."""
        return self.key.partition(":")[0]

    @property
    def frame(self) -> str:
        """The frame named in the key, without its marker or target: ``tool0`` of ``position:tool0@m1``."""
        return split_target(self.key.partition(":")[2])[0]

    @property
    def attachment(self) -> str:
        """The marker or pose target named after ``@`` in the key, or ``""``."""
        return split_target(self.key.partition(":")[2])[1]


def read_targets(path: str | Path) -> Targets:
    """Read a targets file (this module's docstring, docs/compensate.md).

    Raises:
        DataError: naming the file, and the column and line at fault: no target columns or two groups of them, a
            group with a component missing, another column, a cell that is no finite number, a quaternion not of
            unit norm, a length that looks like millimetres, a duplicated or empty sample id, no rows. Its fields
            say the same: ``file`` (``path``), and where known ``line``, ``column`` and ``sample``.
    """
    source = Path(path)
    try:
        return _parse(source)
    except DataError as exc:
        raise DataError(f"{source.name}: {exc}", column=exc.column, sample=exc.sample, file=str(path),
                        line=exc.line) from None


def _parse(source: Path) -> Targets:
    too_many = f"targets: pincal compensate takes at most {MAX_TARGETS} in one run; split the file"
    table = read_table(source, MAX_TARGETS, too_many)  # refused by its rows' count, before any row is parsed
    check_si_units(table.metadata)
    where, header = f"header (line {table.header_line})", table.header_line
    groups: dict[str, dict[str, int]] = {}
    sample = status = None
    for i, name in enumerate(table.header):
        if name == SAMPLE_COLUMN:
            sample = i
            continue
        if name == STATUS:
            status = i
            continue
        if name == SET_COLUMN:
            continue
        key, _, component = name.rpartition(":")
        kind = key.partition(":")[0]
        if kind not in TARGET_COMPONENTS or not key.partition(":")[2]:
            raise DataError(f"{where}: column '{name}' is not a target; a targets file has '{SAMPLE_COLUMN}' and the "
                            "columns of one position:<frame>:x,y,z or pose:<frame>:x,y,z,qx,qy,qz,qw "
                            "(docs/compensate.md)", column=name, line=header)
        if component not in TARGET_COMPONENTS[kind]:
            raise DataError(f"{where}: column '{name}' has component '{component}'; a {kind} has components: "
                            f"{listing(TARGET_COMPONENTS[kind])}", column=name, line=header)
        if component in groups.get(key, {}):
            raise DataError(f"{where}: column '{name}' appears twice", column=name, line=header)
        groups.setdefault(key, {})[component] = i
    if len(groups) != 1:
        what = "none" if not groups else listing(groups)
        raise DataError(f"{where}: a targets file holds the columns of exactly one position or pose; found {what}",
                        line=header)
    ((key, columns),) = groups.items()
    components = TARGET_COMPONENTS[key.partition(":")[0]]
    missing = [c for c in components if c not in columns]
    if missing:
        raise DataError(f"{where}: target '{key}' lacks the columns {listing(f'{key}:{c}' for c in missing)}",
                        column=f"{key}:{missing[0]}", line=header)
    if not table.rows:
        raise DataError("no targets: the file has a header and no rows")
    if len(table.rows) > MAX_TARGETS:  # before any cell is read, and before the model is loaded
        raise DataError(f"{len(table.rows)} {too_many}")
    if status is not None:
        for line, cells in table.rows:
            if cells[status] != OK:
                raise DataError(f"line {line}: status '{cells[status]}': this row holds no target; remove it",
                                column=STATUS, sample=cells[sample] if sample is not None else None, line=line)
    values = np.array([[_target_number(cells[columns[c]], key, c, line) for c in components]
                       for line, cells in table.rows])
    ids = _sample_ids(table.rows, sample)
    lines = [line for line, _ in table.rows]
    far = np.flatnonzero(np.abs(values[:, :3]).max(axis=1) > MAX_PLAUSIBLE_LENGTH)
    if far.size:
        r = int(far[0])
        raise DataError(f"line {lines[r]}: the target {values[r, :3].tolist()} lies beyond {MAX_PLAUSIBLE_LENGTH:g} m: "
                        "it looks like millimetres; pincal expects metres", sample=ids[r], line=lines[r])
    if values.shape[1] == 7:
        norms = np.linalg.norm(values[:, 3:], axis=1)
        bad = np.flatnonzero(np.abs(norms - 1.0) > QUATERNION_NORM_TOLERANCE)
        if bad.size:
            r = int(bad[0])
            raise DataError(f"line {lines[r]}: quaternion (qx, qy, qz, qw) of norm {norms[r]:.6g}; a unit quaternion "
                            f"is needed (|‖q‖ − 1| ≤ {QUATERNION_NORM_TOLERANCE:g})", sample=ids[r], line=lines[r])
        values[:, 3:] /= norms[:, None]
    return Targets(key, ids, values, dict(table.metadata))


def _target_number(cell: str, key: str, component: str, line: int) -> float:
    """The number in one cell of a target (column ``key:component``) [m, or a quaternion component]: an empty or NaN
    cell is named as a target lacking one of its numbers (a dataset's rule on cells a marker left empty does not
    apply)."""
    column, kind = f"{key}:{component}", key.partition(":")[0]
    try:
        empty = not cell or math.isnan(float(cell))
    except ValueError:  # not a number: cell_number names it
        empty = False
    if empty:
        what = "is empty" if not cell else f"is '{cell}'"
        numbers = TARGET_COMPONENTS[kind]
        raise DataError(f"column '{column}', line {line}: the cell {what}; a {kind} target needs all "
                        f"{NUMBERS[len(numbers)]} numbers ({', '.join(numbers)}): every row is a place to reach",
                        column=column, line=line)
    return cell_number(cell, column, line)


def _sample_ids(rows: Sequence[tuple[int, list[str]]], sample: int | None) -> list[str]:
    """The rows' sample ids (column ``sample``, else ``0, 1, …``); DataError naming an empty or repeated one."""
    ids = [cells[sample] if sample is not None else str(r) for r, (_, cells) in enumerate(rows)]
    seen: dict[str, int] = {}
    for sid, (line, _) in zip(ids, rows, strict=True):
        if not sid:
            raise DataError(f"column '{SAMPLE_COLUMN}', line {line}: the sample id is empty", column=SAMPLE_COLUMN,
                            line=line)
        if sid in seen:
            raise DataError(f"column '{SAMPLE_COLUMN}': sample id '{sid}' is used twice (lines {seen[sid]} and {line})",
                            column=SAMPLE_COLUMN, sample=sid, line=line)
        seen[sid] = line
    return ids


def _cell(value: float) -> str:
    return "" if math.isnan(value) else repr(float(value))


def _text(metadata: Mapping[str, str], header: Sequence[str], rows: Sequence[Sequence[str]]) -> str:
    buffer = io.StringIO()
    for key, value in metadata.items():
        buffer.write(f"# {key}: {value}\n")
    writer = csv.writer(buffer, lineterminator="\n")
    writer.writerow(header)
    writer.writerows(rows)
    return buffer.getvalue()


def commands_text(ids: Sequence[str], joints: Sequence[str], commands: Array, residuals: Array,
                  statuses: Sequence[str], metadata: Mapping[str, str], orientation: bool,
                  bounds: tuple[Array, Array] | None = None) -> str:
    """The commands file: ``sample``, one column per actuated joint (the raw commands [rad or m]),
    ``residual_position`` [m], ``residual_orientation`` [rad] (pose targets only) and ``status``; a row not reached
    has empty commands and residuals.

    Args:
        ids: Sample ids.
        joints: The actuated joints, the columns of ``commands``.
        commands: (N, na) raw commands, NaN on a row not reached.
        residuals: (N, 2) position [m] and orientation [rad] residual, NaN on a row not reached.
        statuses: ``ok`` or ``unreachable: <reason>`` per row.
        metadata: ``# key: value`` lines.
        orientation: Whether to write the orientation residual (pose targets).
        bounds: Per row, the predicted 95 % bound [m] at the commands and the nominal robot's own bound there [m]
            (columns ``bound``, ``nominal_bound``, empty where not known); None: no such columns.
    """
    extra = [BOUND, NOMINAL_BOUND] if bounds is not None else []
    header = [SAMPLE_COLUMN, *joints, RESIDUAL_POSITION] + ([RESIDUAL_ORIENTATION] if orientation else []) + extra
    width = 2 if orientation else 1
    pairs = np.column_stack(bounds) if bounds is not None else np.zeros((len(ids), 0))
    rows = [[sid, *(_cell(v) for v in command), *(_cell(v) for v in residual[:width]), *(_cell(v) for v in pair),
             status]
            for sid, command, residual, pair, status in zip(ids, commands, residuals, pairs, statuses, strict=True)]
    return _text(metadata, [*header, STATUS], rows)


def targets_text(key: str, ids: Sequence[str], values: Array, statuses: Sequence[str],
                 metadata: Mapping[str, str]) -> str:
    """A targets file: ``sample``, the columns of ``key`` with ``values`` (N, 3 or 7) [m, unit quaternion], empty on a
    row whose status is not ``ok``, and ``status``. :func:`read_targets` reads it back when every row is ``ok``."""
    components = TARGET_COMPONENTS[key.partition(":")[0]]
    header = [SAMPLE_COLUMN, *(f"{key}:{c}" for c in components), STATUS]
    rows = [[sid, *(_cell(v) for v in row), status] for sid, row, status in zip(ids, values, statuses, strict=True)]
    return _text(metadata, header, rows)
