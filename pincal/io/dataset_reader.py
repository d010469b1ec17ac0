"""Reading a dataset CSV (docs/dataset.md, :mod:`pincal.io.dataset`): the header's layout, every cell checked and
named when wrong (its column and line), the readings checked for plausible units, and the plain tables job files
read (:func:`read_table`). SI units: m, rad.
"""

from __future__ import annotations

import csv
import math
import re
from collections.abc import Mapping, Sequence
from pathlib import Path

import numpy as np
import numpy.typing as npt

from pincal import linalg, validation
from pincal.errors import DataError, listing
from pincal.identification.measurements import KIND_CLASSES, QUATERNION
from pincal.io.dataset import (
    FOREIGN_UNITS,
    MAX_FILE_BYTES,
    MAX_PLAUSIBLE_ANGLE,
    MAX_PLAUSIBLE_LENGTH,
    MAX_SAMPLES,
    MEASUREMENT_COMPONENTS,
    OCCLUDABLE_KINDS,
    QUATERNION_NORM_TOLERANCE,
    SAMPLE_COLUMN,
    SET_COLUMN,
    SET_NAMES,
    Dataset,
    is_increment,
    parse_measurement_key,
)
from pincal.io.files import input_problem
from pincal.records import record

#: The csv module's longest cell [characters]: a line shorter cannot hold a cell it refuses.
FIELD_LIMIT = csv.field_size_limit()

Array = npt.NDArray[np.float64]


# --- reading ------------------------------------------------------------------------------------
@record
class _Layout:
    """Where each quantity sits among the file's columns."""

    joints: dict[str, int]
    groups: dict[str, dict[str, int]]  # measurement key -> component -> column index
    sample: int | None
    set: int | None


def _layout(header: list[str], line: int, required: Sequence[str], known: Sequence[str] | None,
            joint_like: Sequence[str] = ()) -> _Layout:
    where = f"header (line {line})"
    seen: dict[str, int] = {}
    for i, name in enumerate(header):
        if not name:
            raise DataError(f"{where}: column {i + 1} has no name")
        if name in seen:
            raise DataError(f"{where}: column '{name}' appears twice (columns {seen[name] + 1} and {i + 1})")
        seen[name] = i
    joints: dict[str, int] = {}
    groups: dict[str, dict[str, int]] = {}
    for i, name in enumerate(header):
        if name in (SAMPLE_COLUMN, SET_COLUMN):
            continue
        joint_name = name in required or name in joint_like or (known is not None and name in known)
        if ":" not in name or joint_name:  # joint names may hold ':'
            joints[name] = i
            continue
        key, _, component = name.rpartition(":")
        kind = key.partition(":")[0]
        if ":" not in key:
            raise DataError(f"{where}: column '{name}' is not a joint name nor '<kind>:<frame>:<component>'; "
                            "kinds are: " + listing(MEASUREMENT_COMPONENTS))
        if kind not in MEASUREMENT_COMPONENTS:
            raise DataError(f"{where}: column '{name}' has unknown kind '{kind}'; measurement columns are "
                            "'<kind>:<frame>:<component>' with kinds: " + listing(MEASUREMENT_COMPONENTS))
        try:
            parse_measurement_key(key)
        except DataError as exc:
            raise DataError(f"{where}: column '{name}': {exc}") from None
        valid = MEASUREMENT_COMPONENTS[kind]
        if component not in valid:
            raise DataError(f"{where}: column '{name}' has component '{component}'; a {kind} has "
                            f"components: {listing(valid)}")
        groups.setdefault(key, {})[component] = i
    for key, columns in groups.items():
        valid = MEASUREMENT_COMPONENTS[key.partition(":")[0]]
        missing = [c for c in valid if c not in columns]
        if missing:
            raise DataError(f"{where}: measurement '{key}' has columns {listing(c for c in valid if c in columns)} "
                            f"but not {listing(missing)}; a {key.partition(':')[0]} needs {listing(valid)}")
    if not joints:
        raise DataError(f"{where}: no joint columns; every sample needs the readings of the joints that move what is "
                        f"measured (columns named after the joints); columns are: {listing(header)}")
    absent = [j for j in required if j not in joints]
    if absent:
        raise DataError(f"{where}: missing joint columns {listing(absent)}; joint columns present: "
                        f"{listing(joints) or 'none'}")
    if known is not None:
        unknown = [j for j in joints if j not in known]
        if unknown:
            raise DataError(f"{where}: columns {listing(unknown)} are neither joints of the robot nor "
                            f"'<kind>:<frame>:<component>' measurements; joints are: {listing(known)}")
    return _Layout(joints, groups, seen.get(SAMPLE_COLUMN), seen.get(SET_COLUMN))


def _number(cell: str, column: str, line: int, first_increment: bool = False, may_be_empty: bool = False) -> float:
    """The number in one cell; empty or NaN only on the first row of a distance_increment column, and in a
    position's cells (``may_be_empty``: the caller checks that the position's cells are all empty or none)."""
    try:
        if "_" in cell:  # Python's float() reads "0.1_0" as 0.1; a measuring system never writes it
            raise ValueError(cell)
        value = float(cell) if cell else math.nan
    except ValueError:
        raise DataError(f"column '{column}', line {line}: '{cell}' is not a number", column=column, line=line) from None
    if first_increment:
        if not math.isnan(value):
            raise DataError(f"column '{column}', line {line}: {cell} on the first row; a distance increment "
                            "has no previous sample there, so the cell must be empty or NaN", column=column, line=line)
        return value
    if math.isnan(value) and may_be_empty:
        return value
    if math.isnan(value):
        what = "is empty" if not cell else f"is '{cell}'"
        raise DataError(f"column '{column}', line {line}: the cell {what}; every reading and measurement "
                        "needs a number (only the first row of a distance_increment column may be empty, and all "
                        "three cells of a position whose marker was not seen)", column=column, line=line)
    if not math.isfinite(value):
        raise DataError(f"column '{column}', line {line}: '{cell}' is not finite", column=column, line=line)
    return value


def _split(text: str) -> tuple[dict[str, str], int, list[str], list[tuple[int, list[str]]]]:
    """Metadata, header line number, header cells and (line number, cells) of each data row."""
    metadata: dict[str, str] = {}
    metadata_lines: dict[str, int] = {}
    header: list[str] | None = None
    header_line = 0
    rows: list[tuple[int, list[str]]] = []
    for number, raw in enumerate(text.splitlines(), start=1):
        stripped = raw.strip()
        if not stripped:
            continue
        if stripped.startswith("#"):
            key, sep, value = stripped[1:].partition(":")
            if header is None and sep and key.strip():
                key = key.strip()
                if key in metadata:
                    raise DataError(f"line {number}: metadata '{key}' is given twice (lines "
                                    f"{metadata_lines[key]} and {number})")
                metadata[key], metadata_lines[key] = value.strip(), number
            continue
        try:
            # without quotes or NUL the csv module's cells are the text between commas: split at once
            simple = '"' not in raw and "\x00" not in raw and len(raw) < FIELD_LIMIT
            cells = [c.strip() for c in (raw.split(",") if simple else next(csv.reader([raw])))]
        except csv.Error as exc:  # e.g. a cell over the csv module's 131072-character field limit
            raise DataError(f"line {number}: {exc} (a cell of {max(map(len, raw.split(',')))} characters)") from None
        if header is None:
            header, header_line = cells, number
        else:
            rows.append((number, cells))
    if header is None:
        raise DataError("no header line: the first line that is not a '#' comment must name the columns")
    return metadata, header_line, header, rows


def _file_text(source: Path, max_rows: int = MAX_SAMPLES, too_many: str = "") -> str:
    """The text of a CSV file, refused at once when it is larger than a calibration takes (bytes, or more rows than
    ``max_rows``: with ``too_many``, the refusal is the row count followed by that text)."""
    problem = input_problem(source)
    if problem:
        raise DataError(f"dataset '{source}' {problem}")
    try:
        size = source.stat().st_size
        if size > MAX_FILE_BYTES:
            raise DataError(f"dataset '{source}' is {size / 2**20:.0f} MiB; pincal reads at most "
                            f"{MAX_FILE_BYTES // 2**20} MiB and calibrates at most {MAX_SAMPLES} samples in one run: "
                            "split or thin the file")
        raw = source.read_bytes()
        lines = raw.count(b"\n") + 1
        if lines > max_rows + 1:  # rows, less the header, comments and blank lines
            rows = lines - 1 - len(re.findall(rb"^[ \t\r]*(?:#|$)", raw, re.M))
            if rows > max_rows and too_many:
                raise DataError(f"{rows} {too_many}")
            if rows > max_rows:
                raise DataError(f"dataset '{source}' has {rows} rows; pincal calibrates at most {MAX_SAMPLES} "
                                "samples in one run (time grows with the samples): split or thin the file")
        return _utf8_text(raw, source)
    except OSError as exc:
        raise DataError(f"cannot read dataset '{source}': {exc.strerror or exc}") from None


def _utf8_text(raw: bytes, source: Path) -> str:
    """The text of a CSV file's bytes, which must be UTF-8 (a BOM allowed, as spreadsheets write one); a UTF-16 file,
    with or without its BOM, is named as such."""
    utf16 = raw[:2] in (b"\xff\xfe", b"\xfe\xff") or b"\x00" in raw
    if utf16:
        raise DataError(f"dataset '{source}' is not UTF-8 text: its bytes hold NUL characters, as UTF-16 does; "
                        "pincal reads CSV files in the UTF-8 encoding: save it as UTF-8 (e.g. 'CSV UTF-8')")
    try:
        return raw.decode("utf-8-sig")  # -sig: spreadsheets start UTF-8 files with a BOM
    except UnicodeDecodeError as exc:
        raise DataError(f"dataset '{source}' is not UTF-8 text (byte {exc.start}: {raw[exc.start:exc.start + 1]!r}); "
                        "pincal reads CSV files in the UTF-8 encoding: save it as UTF-8 (e.g. 'CSV UTF-8')") from None


def read_dataset(path: str | Path, joint_names_required: Sequence[str] | None = None, min_samples: int = 1,
                 *, joint_kinds: dict[str, str] | None = None,
                 known_joints: Sequence[str] | None = None, joint_like: Sequence[str] = ()) -> Dataset:
    """Read and check a measurement CSV file (format in this module's docstring).

    Args:
        path: CSV file.
        joint_names_required: Joint columns that must be present (the actuated joints).
        min_samples: Fewest rows accepted.
        joint_kinds: URDF joint type by joint name; ``revolute`` and ``prismatic`` readings are
            checked for degrees and millimetres.
        known_joints: If given, every joint column must be one of these.
        joint_like: Names read as joint columns although they hold ``:`` (the robot's joints), not required.

    Raises:
        DataError: naming the column, the line and the value at fault, for missing or unknown columns,
            incomplete measurements, non-numbers, empty/NaN cells, duplicated columns or rows, too few
            rows, non-unit quaternions, and values that look like millimetres or degrees.
        TypeError, ArgumentError: an argument of the wrong type or value (named, with the value).
    """
    source = Path(validation.path("path", path))
    joint_names_required = validation.optional_texts("joint_names_required", joint_names_required)
    validation.whole("min_samples", min_samples, 0)
    text = _file_text(source)
    try:
        return _parse(text, joint_names_required or [], min_samples, joint_kinds or {}, known_joints, joint_like)
    except DataError as exc:
        raise DataError(f"{source.name}: {exc}", column=exc.column, sample=exc.sample, file=str(path),
                        line=exc.line) from None


def check_si_units(metadata: Mapping[str, str]) -> None:
    """Refuse a file whose ``# units:`` line names a unit other than metres and radians (a ``# units: mm`` line is
    never read as metres).

    Raises:
        DataError: naming the line.
    """
    units = re.findall(r"[a-zµ°]+", metadata.get("units", "").lower())
    foreign = sorted({u for u in units if u in FOREIGN_UNITS})
    if foreign:
        raise DataError(f"metadata 'units: {metadata['units']}' names {', '.join(foreign)}; pincal reads metres and "
                        "radians: convert the file to SI, and state '# units: SI (m, rad)'")


def _parse(text: str, required: Sequence[str], min_samples: int, kinds: dict[str, str],
           known: Sequence[str] | None, joint_like: Sequence[str] = ()) -> Dataset:
    metadata, header_line, header, rows = _split(text)
    check_si_units(metadata)
    layout = _layout(header, header_line, required, known, joint_like)
    if len(rows) < min_samples:
        raise DataError(f"{len(rows)} samples; at least {min_samples} are needed")
    n = len(rows)
    joints = np.empty((n, len(layout.joints)))
    measurements = {key: np.empty((n, len(cols))) for key, cols in layout.groups.items()}
    ids: list[str] = []
    sets: list[str] = []
    lines = [line for line, _ in rows]
    incremental = {key for key in layout.groups if is_increment(key)}
    sizes = [len(layout.joints), *(len(MEASUREMENT_COMPONENTS[key.partition(":")[0]]) for key in layout.groups)]
    columns = [*layout.joints.values(), *(cols[component] for key, cols in layout.groups.items()
                                          for component in MEASUREMENT_COMPONENTS[key.partition(":")[0]])]
    numbers = np.empty((n, len(columns)))
    plain = np.zeros(n, dtype=bool)  # rows read at once: every cell a finite number, written plainly
    for r, (_, cells) in enumerate(rows):
        if r and len(cells) == len(header):  # the first row: where a distance increment is empty
            try:
                read = [float(cells[i]) for i in columns]
            except ValueError:
                continue
            if all(math.isfinite(v) for v in read) and not any("_" in cells[i] for i in columns):
                numbers[r], plain[r] = read, True
    blocks = np.split(numbers, np.cumsum(sizes)[:-1], axis=1)
    joints[plain] = blocks[0][plain]
    for key, block in zip(layout.groups, blocks[1:], strict=True):
        measurements[key][plain] = block[plain]
    for r, (line, cells) in enumerate(rows):  # the other rows cell by cell, each error where it is
        if len(cells) != len(header):
            raise DataError(f"line {line} has {len(cells)} cells; the header (line {header_line}) has {len(header)}",
                            line=line)
        if not plain[r]:
            for c, (name, i) in enumerate(layout.joints.items()):
                joints[r, c] = _number(cells[i], name, line)
            for key, cols in layout.groups.items():
                kind = key.partition(":")[0]
                components = MEASUREMENT_COMPONENTS[kind]
                for c, component in enumerate(components):
                    measurements[key][r, c] = _number(cells[cols[component]], f"{key}:{component}", line,
                                                      first_increment=r == 0 and key in incremental,
                                                      may_be_empty=kind in OCCLUDABLE_KINDS)
                empty = np.isnan(measurements[key][r])
                if empty.any() and not empty.all():  # an occluded marker leaves every cell empty, not some
                    first = components[int(np.argmax(empty))]
                    what = "is empty" if not cells[cols[first]] else f"is '{cells[cols[first]]}'"
                    full = listing(f"{key}:{c}" for c, e in zip(components, empty, strict=True) if not e)
                    raise DataError(f"column '{key}:{first}', line {line}: the cell {what} but {full} hold "
                                    f"numbers; a {KIND_CLASSES[kind].sighted} that was not seen leaves all the "
                                    f"cells of '{key}' empty, one seen fills them all", column=f"{key}:{first}",
                                    line=line)
        ids.append(cells[layout.sample] if layout.sample is not None else str(r))
        if layout.sample is not None and not ids[-1]:
            raise DataError(f"column '{SAMPLE_COLUMN}', line {line}: the sample id is empty", column=SAMPLE_COLUMN,
                            line=line)
        sets.append(cells[layout.set] if layout.set is not None else "train")
        if sets[-1] not in SET_NAMES:
            raise DataError(f"column '{SET_COLUMN}', line {line}: '{sets[-1]}' is not a set; sets are: "
                            f"{listing(SET_NAMES)}", column=SET_COLUMN, line=line, sample=ids[-1])
    dataset = Dataset(list(layout.joints), joints, measurements, ids, sets, metadata)
    _check_rows(dataset, lines)
    _check_units(dataset, lines, kinds)
    return dataset


def _check_rows(data: Dataset, lines: list[int]) -> None:
    first_line: dict[str, int] = {}
    for r, sample in enumerate(data.sample_ids):
        if sample in first_line:
            raise DataError(f"column '{SAMPLE_COLUMN}': sample id '{sample}' is used twice (lines "
                            f"{first_line[sample]} and {lines[r]})", column=SAMPLE_COLUMN, sample=sample,
                            line=lines[r])
        first_line[sample] = lines[r]
    table = np.hstack([data.joints, *data.measurements.values()]) if data.measurements else data.joints
    table = np.where(np.isnan(table), 0.0, table) + 0.0  # NaN and -0.0 compare as equal rows
    seen: dict[bytes, int] = {}
    duplicates: list[str] = []
    for r in range(data.n_samples):
        row_key = table[r].tobytes()
        if row_key in seen:
            duplicates.append(f"line {lines[r]} repeats line {seen[row_key]}")
        else:
            seen[row_key] = lines[r]
    if duplicates:
        raise DataError("duplicated samples (identical joint readings and measurements): " + listing(duplicates, 10))
    for key, values in data.measurements.items():
        quaternion = [c for c, unit in enumerate(KIND_CLASSES[key.partition(":")[0]].component_units())
                      if unit == QUATERNION]
        if quaternion:  # a pose's, a camera's
            norms = np.linalg.norm(values[:, quaternion], axis=1)
            bad = np.flatnonzero(np.abs(norms - 1.0) > QUATERNION_NORM_TOLERANCE)
            if bad.size:
                r = int(bad[0])
                raise DataError(f"measurement '{key}', line {lines[r]}: quaternion (qx, qy, qz, qw) = "
                                f"{tuple(float(v) for v in values[r, quaternion])} has norm {norms[r]:.6g}; a unit "
                                f"quaternion is needed (|norm - 1| <= {QUATERNION_NORM_TOLERANCE:g}; "
                                f"{bad.size} rows in all)")


def _check_units(data: Dataset, lines: list[int], kinds: dict[str, str]) -> None:
    mm = "looks like millimetres; pincal expects metres"
    for key, values in data.measurements.items():
        kind = key.partition(":")[0]
        units = KIND_CLASSES[kind].component_units()
        for c, component in enumerate(MEASUREMENT_COMPONENTS[kind]):
            if units[c] != "m":
                continue
            column = values[:, c]
            big = np.flatnonzero(np.abs(np.nan_to_num(column)) > MAX_PLAUSIBLE_LENGTH)
            if big.size:
                r = int(big[0])
                raise DataError(f"column '{key}:{component}', line {lines[r]}: {float(column[r])!r} {mm} "
                                f"(|value| > {MAX_PLAUSIBLE_LENGTH:g} m on {big.size} of {data.n_samples} rows)")
    if data.n_samples == 0:
        return
    for c, name in enumerate(data.joint_names):
        column = np.abs(data.joints[:, c])
        joint_kind = kinds.get(name)
        if joint_kind == "prismatic" and float(linalg.median(column)) > MAX_PLAUSIBLE_LENGTH:
            raise DataError(f"column '{name}' (prismatic joint): median |reading| {float(linalg.median(column)):g} "
                            f"{mm} (median > {MAX_PLAUSIBLE_LENGTH:g} m)")
        if joint_kind == "revolute":
            big = np.flatnonzero(column > MAX_PLAUSIBLE_ANGLE)
            if big.size * 2 > data.n_samples:
                r = int(big[0])
                raise DataError(f"column '{name}' (revolute joint), line {lines[r]}: "
                                f"{float(data.joints[r, c])!r} looks like degrees; pincal expects radians "
                                f"(|reading| > 4 pi on {big.size} of {data.n_samples} rows)")


# --- other column layouts (a job file's, pincal.calibration.job) -------------------------------------------
@record
class Table:
    """A CSV file's cells before any column is given a meaning.

    Attributes:
        metadata: The ``# key: value`` lines before the header.
        header: The column names, as written.
        header_line: The header's line number (1-based).
        rows: (line number, cells) of each data row; cells as written, stripped.
    """

    metadata: dict[str, str]
    header: list[str]
    header_line: int
    rows: list[tuple[int, list[str]]]


def read_table(path: str | Path, max_rows: int = MAX_SAMPLES, too_many: str = "") -> Table:
    """Read a CSV file as :func:`read_dataset` does (size limits, byte-order mark, ``#`` comments, blank lines),
    without interpreting its columns.

    Args:
        path: The CSV file.
        max_rows: Most data rows taken; a larger file is refused before it is parsed.
        too_many: The refusal of a file of more rows, after their count (``targets: pincal compensate takes at most
            5000 …``); empty: a calibration's (at most :data:`~pincal.io.dataset.MAX_SAMPLES` samples).

    Raises:
        DataError: an unreadable or oversized file, a file with no header, or a row with more or fewer cells than
            the header (the message names the line; the caller names the file).
    """
    metadata, header_line, header, rows = _split(_file_text(Path(path), max_rows, too_many))
    for line, cells in rows:
        if len(cells) != len(header):
            raise DataError(f"line {line} has {len(cells)} cells; the header (line {header_line}) has {len(header)}",
                            line=line)
    return Table(metadata, header, header_line, rows)


def cell_number(cell: str, column: str, line: int, first_increment: bool = False, may_be_empty: bool = False) -> float:
    """The number in one cell, as :func:`read_dataset` reads it: decimal or exponent notation, finite; with
    ``first_increment`` (the first row of a distance increment) the cell must be empty or NaN, read as NaN; with
    ``may_be_empty`` (a position whose marker may not have been seen) an empty cell is NaN, and the caller checks
    that the measurement's cells are all empty or none.

    Raises:
        DataError: naming ``column`` and ``line``: an empty cell, NaN, infinity or not a number.
    """
    return _number(cell, column, line, first_increment, may_be_empty)


def check_dataset(dataset: Dataset, lines: Sequence[int], joint_kinds: dict[str, str] | None = None) -> None:
    """The checks :func:`read_dataset` makes of the rows it read: no duplicated sample ids or samples, unit
    quaternions, and no length or reading that looks like millimetres or degrees.

    Args:
        dataset: The samples, read from one file.
        lines: The file's line number of each sample, for the messages.
        joint_kinds: URDF joint type by joint name (``revolute``, ``prismatic``), as for :func:`read_dataset`.

    Raises:
        DataError: naming the column, the line and the value at fault.
    """
    _check_rows(dataset, list(lines))
    _check_units(dataset, list(lines), joint_kinds or {})


