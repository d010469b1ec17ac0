"""A job's data files read into one :class:`~pincal.io.dataset.Dataset`: the user's columns mapped onto pincal's
quantities as the job says (:mod:`pincal.calibration.job`), converted to SI units (m, rad), concatenated, rows held
out."""

from __future__ import annotations

from collections.abc import Sequence
from typing import Any

import numpy as np
import numpy.typing as npt

from pincal.calibration.job_reader import Column, HeldOut, Job
from pincal.calibration.samples import ANGLE_UNIT_SIZES, LENGTH_UNIT_SIZES
from pincal.errors import DataError, listing, not_found
from pincal.identification.measurements import KIND_CLASSES, parse_key
from pincal.io.dataset import MAX_SAMPLES, OCCLUDABLE_KINDS, Dataset
from pincal.io.dataset_reader import Table, cell_number, check_dataset, read_table
from pincal.model.robot import Robot, joint_unit
from pincal.records import record

#: Cells of a held-out column that hold a row out, and those that keep it for the fit.
HELD_WORDS = {"test": True, "true": True, "yes": True, "1": True, "train": False, "false": False, "no": False,
              "0": False}


@record
class _Columns:
    """Where a data file holds each quantity of the job: column indices."""

    joints: dict[str, int]
    measures: dict[str, list[int]]
    sample: int | None
    held_out: int | None


def job_dataset(job: Job, robot: Robot) -> Dataset:
    """The job's data files read into one :class:`Dataset` for ``robot``, in SI units (m, rad).

    Each file's columns are mapped as the job says: ``[[measure]]`` columns to measurements, ``[joints]`` columns (and,
    by default, columns named like a joint of the robot) to joint readings; every other column must be listed under
    ``[data] ignore``. Lengths (positions, distances, prismatic readings) are multiplied by the size of the job's
    length unit in metres, angles (revolute and continuous readings) by the size of its angle unit in radians. Files
    are concatenated in order; with several, a sample id is the file as the job writes it, ``:`` and the file's id.
    Each file gets :func:`~pincal.io.dataset_reader.read_dataset`'s checks (numbers, duplicates, quaternions,
    millimetres and degrees), after the conversion.

    Raises:
        DataError: naming the job file, the place in it or the data file, the column and the line at fault.
        NotFoundError: a joint or frame the robot does not have.
    """
    if job.bag is not None:  # a ROS bag's static postures (docs/bags.md)
        from pincal.calibration.job_bag import bag_job_dataset  # ROS bag reading, only for a [bag] job

        return bag_job_dataset(job, job.bag, robot)
    for joint in {**job.joints, **job.joint_units}:
        robot.joint_id(joint, f"{job.path}: [joints] {joint}: ")
    _check_joint_units(job, robot)
    for measure in job.measures:
        for frame in parse_key(measure.key).frames:
            robot.frame_id(frame, f"{job.path}: {measure.where} frame: ")
    parts = [_file_dataset(job, robot, k) for k in range(len(job.files))]
    headers = list(dict.fromkeys(column for _, _, header in parts for column in header))
    absent = [column for column in job.ignore if isinstance(column, str) and column not in headers]
    if absent:
        raise DataError(f"{job.path}: [data] ignore: {listing(absent)} {'is' if len(absent) == 1 else 'are'} a "
                        f"column of no data file; columns are: {listing(headers)}")
    names = [p[0].joint_names for p in parts]
    for k in range(1, len(parts)):
        if set(names[k]) != set(names[0]):
            raise DataError(f"{job.path}: [data] files: '{job.file_names[k]}' has readings of "
                            f"{listing(names[k]) or 'no joint'}, '{job.file_names[0]}' of {listing(names[0])}; the "
                            "files must hold the same joints")
    n = sum(p[0].n_samples for p in parts)
    if n > MAX_SAMPLES:
        raise DataError(f"{job.path}: [data] files: {n} rows in all; pincal calibrates at most {MAX_SAMPLES} samples "
                        "in one run")
    if n < 2:
        raise DataError(f"{job.path}: [data]: {n} samples; at least 2 are needed")
    order = names[0]
    joints = np.vstack([p[0].joints[:, [p[0].joint_names.index(j) for j in order]] for p in parts])
    measurements = {m.key: np.vstack([p[0].measurements[m.key] for p in parts]) for m in job.measures}
    several = len(parts) > 1
    ids = [f"{job.file_names[k]}:{s}" if several else s for k, p in enumerate(parts) for s in p[0].sample_ids]
    held = np.concatenate([p[1] for p in parts])  # marked by a column
    if job.held_out is not None and job.held_out.column is None:
        held = _held_rows(job.held_out, job, n)
    sets = ["test" if h else "train" for h in held]
    return Dataset(order, joints, measurements, ids, sets, _metadata(job, robot, parts[0][0].joint_names))


def _file_dataset(job: Job, robot: Robot, k: int) -> tuple[Dataset, npt.NDArray[np.bool_], list[str]]:
    """Data file ``k`` of the job as a Dataset in SI units, which of its rows its held-out column marks, and its
    columns."""
    where = f"{job.path}: [data] file '{job.file_names[k]}'"
    try:
        table = _positional(read_table(job.files[k]), job.header)
    except DataError as exc:
        raise DataError(f"{where}: {exc}") from None
    recorded = table.metadata.get("robot")
    names = {robot.name} | ({robot.source.stem} if robot.source is not None else set())
    if recorded is not None and recorded not in names:
        raise DataError(f"{where}: its '# robot: {recorded}' line says the data are of robot '{recorded}', not of "
                        f"'{robot.name}'")
    columns = _columns(job, robot, table, k)
    rows = table.rows
    try:
        joints = np.array([[cell_number(cells[i], table.header[i], line) for i in columns.joints.values()]
                           for line, cells in rows]).reshape(len(rows), len(columns.joints))
        joints *= np.array([_unit_size(joint_units(job, robot, j)) for j in columns.joints])
        measurements = {}
        for measure in job.measures:
            kind = measure.key.partition(":")[0]
            incremental = parse_key(measure.key).incremental
            if not measure.columns:  # a contact the file does not write: every value 0
                measurements[measure.key] = parse_key(measure.key).neutral(len(rows))
                continue
            values = np.array([[cell_number(cells[i], table.header[i], line,
                                            first_increment=r == 0 and incremental,
                                            may_be_empty=kind in OCCLUDABLE_KINDS)
                                for i in columns.measures[measure.key]] for r, (line, cells) in enumerate(rows)])
            values = values.reshape(len(rows), len(columns.measures[measure.key]))
            _check_not_seen(values, [table.header[i] for i in columns.measures[measure.key]], rows)
            length = LENGTH_UNIT_SIZES[measure.length_unit or job.length_unit]
            measurements[measure.key] = values * np.array([length if unit == "m" else 1.0  # a quaternion has none
                                                           for unit in KIND_CLASSES[kind].component_units()])
        ids = [cells[columns.sample] if columns.sample is not None else str(r) for r, (_, cells) in enumerate(rows)]
        empty = [line for (line, _), sample in zip(rows, ids, strict=True) if not sample]
        if empty:
            raise DataError(f"column '{table.header[columns.sample or 0]}', line {empty[0]}: the sample id is empty")
        held = np.array([_held(cells[columns.held_out], table.header[columns.held_out], line)
                         if columns.held_out is not None else False for line, cells in rows], dtype=bool)
        dataset = Dataset(list(columns.joints), joints, measurements, ids, ["train"] * len(rows))
        check_dataset(dataset, [line for line, _ in rows], _joint_kinds(robot, list(columns.joints)))
    except DataError as exc:
        hint = ""
        if "looks like" in str(exc):
            hint = (f" (the job reads lengths in {job.length_unit} and angles in {job.angle_unit}: state the file's "
                    "units under [data] units, or a column's own as [[measure]] units or [joints] NAME = { units "
                    "= ... })")
        raise DataError(f"{where}: {exc}{hint}") from None
    return dataset, held, table.header


def _check_not_seen(values: npt.NDArray[np.float64], names: Sequence[str], rows: Sequence[tuple[int, Any]]) -> None:
    """A marker not seen leaves all its cells empty (a row of NaN); some empty and some not is an error naming the
    cell and the line."""
    empty = np.isnan(values)
    for r in map(int, np.flatnonzero(empty.any(axis=1) & ~empty.all(axis=1))):
        first = names[int(np.argmax(empty[r]))]
        full = listing(n for n, e in zip(names, empty[r], strict=True) if not e)
        raise DataError(f"column '{first}', line {rows[r][0]}: the cell is empty but {full} hold numbers; a marker "
                        "or a target that was not seen leaves all its cells empty, one seen fills them all")


def _positional(table: Table, header: str) -> Table:
    """The table as the job reads it: a header to ``skip`` or ``none`` (the first line is data) gives each column the
    name ``column <position>`` (from 1), by which messages name it."""
    if header == "names":
        return table
    rows = ([(table.header_line, table.header)] if header == "none" else []) + table.rows
    return Table(table.metadata, [f"column {i + 1}" for i in range(len(table.header))], table.header_line, rows)


def _columns(job: Job, robot: Robot, table: Table, k: int) -> _Columns:
    """Where data file ``k`` holds each quantity; every column accounted for."""
    header = {name: i for i, name in enumerate(table.header)}
    file = f" in data file '{job.file_names[k]}'"

    def find(column: Column, where: str) -> int:
        if isinstance(column, int):
            if column > len(table.header):
                raise DataError(f"{job.path}: {where}: column {column} is beyond the {len(table.header)} columns "
                                f"of data file '{job.file_names[k]}'")
            return column - 1
        if column not in header:
            raise not_found("column", column, table.header, file, f"{job.path}: {where}: ")
        return header[column]

    measures = {m.key: [find(c, f"{m.where} columns") for c in m.columns] for m in job.measures}
    joints = {joint: find(column, f"[joints] {joint}") for joint, column in job.joints.items()}
    sample = find(job.sample, "[data] sample") if job.sample is not None else None
    ignored = {find(c, "[data] ignore") for c in job.ignore if isinstance(c, int)}
    ignored |= {i for i, name in enumerate(table.header) if name in job.ignore}
    held = find(job.held_out.column, "[data] held_out") if job.held_out and job.held_out.column else None
    for joint in job.joint_units:  # a unit without a column: the column named like the joint
        if joint not in joints:
            joints[joint] = find(joint, f"[joints] {joint}")
    claims = [i for indices in measures.values() for i in indices] + list(joints.values())
    claims += [i for i in (sample, held) if i is not None]
    twice = sorted({i for i in claims if claims.count(i) > 1} | (set(claims) & ignored))
    if twice:
        raise DataError(f"{job.path}: [data] file '{job.file_names[k]}': column '{table.header[twice[0]]}' is named "
                        "twice (by its name and by its position, or also under [data] ignore); a column has one "
                        "meaning")
    used = set(claims)
    robot_joints = [str(name) for name in robot.model.names[1:]]
    for i, name in enumerate(table.header):  # by default, a column named like one of the robot's joints
        if i not in used and i not in ignored and name in robot_joints and name not in joints:
            joints[name] = i
            used.add(i)
    unknown = [name for i, name in enumerate(table.header) if i not in used and i not in ignored]
    if unknown:
        raise DataError(f"{job.path}: [data] file '{job.file_names[k]}': columns {listing(unknown)} are not joints of "
                        f"robot '{robot.name}' and the job does not name them: list them under [data] ignore, or map "
                        f"them under [joints] or [[measure]]; joints are: {listing(robot_joints)}")
    return _Columns(joints, measures, sample, held)


def _held(cell: str, column: str, line: int) -> bool:
    """Whether a held-out column's cell holds its row out."""
    word = cell.strip().lower()
    if word not in HELD_WORDS:
        raise DataError(f"column '{column}', line {line}: '{cell}' does not say whether the row is held out; cells "
                        f"are: {listing(HELD_WORDS)}")
    return HELD_WORDS[word]


def _held_rows(held: HeldOut, job: Job, n: int) -> npt.NDArray[np.bool_]:
    """The rows ``held`` names by their index (from 0, over the files in order), as a mask of the n rows."""
    rows = list(range(held.start, n, held.every)) if held.every else list(held.rows)
    beyond = [r for r in rows if r >= n]
    if beyond or not rows:
        raise DataError(f"{job.path}: [data] held_out: '{held.text}' names "
                        + (f"rows {listing(map(str, beyond))}, beyond the last row ({n - 1})" if beyond else
                           f"no row of the {n}"))
    mask = np.zeros(n, dtype=bool)
    mask[rows] = True
    return mask


def _joint_kinds(robot: Robot, joints: Sequence[str]) -> dict[str, str]:
    """``revolute`` or ``prismatic`` for the one-DOF joints among ``joints`` (the readings checked for degrees and
    millimetres)."""
    model = robot.model
    return {j: "prismatic" if joint_unit(robot, j) == "m" else "revolute" for j in joints
            if model.joints[model.getJointId(j)].nq == 1}


def joint_units(job: Job, robot: Robot, joint: str) -> str:
    """The unit ``joint``'s readings are written in: the job's for that joint, else its length or angle unit."""
    if joint in job.joint_units:
        return job.joint_units[joint]
    return job.length_unit if joint_unit(robot, joint) == "m" else job.angle_unit


def _unit_size(unit: str) -> float:
    """A unit's size in metres or radians."""
    return LENGTH_UNIT_SIZES[unit] if unit in LENGTH_UNIT_SIZES else ANGLE_UNIT_SIZES[unit]


def _check_joint_units(job: Job, robot: Robot) -> None:
    """Refuse a joint's unit of the other kind (an angle for a prismatic joint, a length for a revolute one)."""
    for joint, unit in job.joint_units.items():
        lengths = joint_unit(robot, joint) == "m"
        if (unit in LENGTH_UNIT_SIZES) != lengths:
            kind, units = ("prismatic", LENGTH_UNIT_SIZES) if lengths else ("revolute", ANGLE_UNIT_SIZES)
            raise DataError(f"{job.path}: [joints] {joint} units: '{unit}' is not a unit of a {kind} joint's "
                            f"readings; units are: {listing(units)}")


def _label(column: Column) -> str:
    """A column as a message names it: its header name, or ``#7`` for the 7th column named by its position."""
    return column if isinstance(column, str) else f"#{column}"


def _metadata(job: Job, robot: Robot, joints: Sequence[str]) -> dict[str, str]:
    """The Dataset's metadata: the robot, the units, the σ of each channel the job states
    (:func:`~pincal.io.adapters.channel_sigma` reads them), and each quantity's columns and the unit they are written
    in (``column NAME``, ``unit NAME``: the length-scale checks of :mod:`pincal.calibration.samples` name them)."""
    metadata = {"robot": robot.name, "units": "SI (m, rad)", "job": str(job.path)}
    columns = {m.key: m.columns for m in job.measures}
    for joint in joints:
        metadata[f"column {joint}"] = _label(job.joints.get(joint, joint))
        metadata[f"unit {joint}"] = joint_units(job, robot, joint)
    for measure in job.measures:
        kind, _, name = measure.key.partition(":")
        metadata[f"column {kind} {name}"] = ", ".join(map(_label, columns[measure.key]))
        metadata[f"unit {kind} {name}"] = measure.length_unit or job.length_unit
        if measure.sigma is not None:
            stated = measure.sigma if isinstance(measure.sigma, tuple) else (measure.sigma,)
            metadata[f"sigma {kind} {name}"] = " ".join(repr(v) for v in stated)
        if measure.sigma_angle is not None:
            metadata[f"sigma {kind} angle"] = repr(measure.sigma_angle)
    return metadata
