"""Job files: one TOML file that holds everything a calibration run needs (docs/job_file.md).

A job names the robot, the data files as the measuring system wrote them, which of their columns are which
quantity and in which units, which samples are held out, the parameters and the options of ``pincal calibrate``.
:func:`read_job` reads and checks the file; :func:`pincal.calibration.job_data.job_dataset` reads its data into a
:class:`~pincal.io.dataset.Dataset` in SI units (m, rad). Paths in a job are relative to the job file's directory.

Every error names the file and the place in it (``job.toml: [measure 1] columns: ...``). An unknown key is an error
that lists the valid keys at its level: a misspelt option is never ignored.
"""

from __future__ import annotations

import re
from pathlib import Path
from typing import Any

from pincal.calibration.job_reader import JOB_KEYS, Column, HeldOut, Job, JobReader, MeasureColumns
from pincal.calibration.samples import ANGLE_UNIT_SIZES, LENGTH_UNIT_SIZES
from pincal.errors import DataError, NotFoundError, listing
from pincal.identification.measurements import KIND_CLASSES, parse_key
from pincal.io.dataset import MEASUREMENT_COMPONENTS, parse_measurement_key
from pincal.io.files import input_problem
from pincal.model.robot import Robot, load_robot

#: The names of a job file; its record (``Job``, ``MeasureColumns``, ``HeldOut``) is defined in
#: :mod:`pincal.calibration.job_reader`, which the ``[bag]`` grammar (:mod:`pincal.calibration.job_bag`) reads too.
__all__ = ["DATA_KEYS", "EVERY", "HEADERS", "JOB_KEYS", "JOINT_KEYS", "MEASURE_KEYS", "UNIT_KEYS", "Column", "HeldOut",
           "Job", "MeasureColumns", "load_job_robot", "measure_keys", "read_job"]

#: Keys of each level of a job file under the top one (:data:`~pincal.calibration.job_reader.JOB_KEYS`).
DATA_KEYS = ("file", "files", "units", "held_out", "sample", "ignore", "header")
UNIT_KEYS = ("length", "angle")
#: The keys every ``[[measure]]`` may have; a kind reads its own besides (:func:`measure_keys`).
MEASURE_KEYS = ("kind", "frame", "frames", "columns", "units", "sigma", "sigma_angle")
#: Keys of a joint given as a table under ``[joints]``: ``torso_lift_joint = { column = "T", units = "m" }``.
JOINT_KEYS = ("column", "units")
#: What the first line of a data file is: the column ``names`` (the default), a header to ``skip`` (names defective or
#: misplaced: every column is named by its position), or ``none`` (the first line is data).
HEADERS = ("names", "skip", "none")
#: ``held_out = "every 5th from 4"``: every K-th row of the data, counted from 0 over the files in order.
EVERY = re.compile(r"every\s+(\d+)(?:st|nd|rd|th)?(?:\s+from\s+(\d+))?", re.IGNORECASE)


def measure_keys() -> tuple[str, ...]:
    """The keys a ``[[measure]]`` may have: :data:`MEASURE_KEYS`, then each registered kind's own
    (:attr:`~pincal.identification.measurements.Measurement.job_keys`: a plane's ``support``)."""
    return MEASURE_KEYS + tuple(dict.fromkeys(key for kind in KIND_CLASSES.values() for key in kind.job_keys))


def read_job(path: str | Path) -> Job:
    """Read and check a job file (docs/job_file.md): its keys, their types and values, and that the files it names
    exist. The data and the robot are not read here (:func:`~pincal.calibration.job_data.job_dataset`,
    :func:`load_job_robot`).

    Raises:
        DataError: naming the file, the place in it and the fault; NotFoundError for an unknown key, listing the valid
            keys at its level.
    """
    source = Path(path)
    try:
        raw = source.read_bytes()
    except OSError as exc:
        raise DataError(f"cannot read job file '{source}': {exc.strerror or exc}", file=str(source)) from None
    try:
        text = raw.decode("utf-8-sig")  # a byte-order mark, as some editors write, is no content
    except UnicodeDecodeError as exc:
        raise DataError(f"{source}: not UTF-8 text (byte {exc.start}): a TOML job file's encoding is UTF-8; save "
                        "it as UTF-8", file=str(source)) from None
    import tomllib  # here: a calibration of a CSV file reads no TOML

    try:
        doc = tomllib.loads(text)
    except tomllib.TOMLDecodeError as exc:
        line = re.search(r"\(at line (\d+)", str(exc))  # tomllib writes where: "(at line 3, column 7)"
        raise DataError(f"{source}: not a valid TOML file: {exc}", file=str(source),
                        line=int(line.group(1)) if line else None) from None
    except RecursionError:
        raise DataError(f"{source}: arrays or tables nested too deeply to read; a job file nests a few "
                        "levels", file=str(source)) from None
    if "bag" in doc:  # the data is a ROS bag (docs/bags.md)
        from pincal.calibration.job_bag import read_bag_job

        return read_bag_job(_DataReader(source), doc)
    return _DataReader(source).job(doc)


def _named_columns(job: Job) -> list[tuple[Column, str]]:
    """Every column the job names (by header name or position), with where it names it."""
    named = [(c, f"{m.where} columns") for m in job.measures for c in m.columns]
    named += [(column, f"[joints] {joint}") for joint, column in job.joints.items()]
    named += [(job.sample, "[data] sample")] if job.sample is not None else []
    named += [(job.held_out.column, "[data] held_out")] if job.held_out and job.held_out.column else []
    named += [(column, "[data] ignore") for column in job.ignore]
    return named


class _DataReader(JobReader):
    """The grammar of a job with a ``[data]`` table and its ``[[measure]]`` tables."""

    def job(self, doc: dict[str, Any]) -> Job:
        self.keys(doc, JOB_KEYS, "at the top level")
        for key in ("robot", "data"):
            if key not in doc:
                raise self.error(f"'{key}' is missing", "a job names its robot, and its data in a [data] table "
                                                        "(see docs/job_file.md)")
        robot = self.text(doc["robot"], "robot")
        if input_problem(self.base / robot) is None or Path(robot).suffix or "/" in robot:  # a path, else a name
            robot = str(self.file(robot, "robot")[0])
        data = self.table(doc["data"], "[data]")
        self.keys(data, DATA_KEYS, "in [data]")
        if ("file" in data) == ("files" in data):
            raise self.error("[data]", "give the data as file = \"data.csv\" or files = [\"a.csv\", \"b.csv\"] "
                                       "(one of the two)")
        key = "file" if "file" in data else "files"
        found = [self.file(name, f"[data] {key}") for name in self.texts(data[key], f"[data] {key}")]
        paths = [path.resolve() for path, _ in found]
        twice = [written for k, (_, written) in enumerate(found) if paths[k] in paths[:k]]
        if twice:
            raise self.error(f"[data] {key}", f"'{twice[0]}' is named twice")
        length, angle = self.units(data.get("units", {}))
        outputs = {name: self.file(doc[name], name, must_exist=False)[0] if name in doc else None
                   for name in ("out", "report")}
        measures = tuple(self.measure(entry, k + 1) for k, entry in enumerate(self.measure_list(doc)))
        joints, joint_units = self.joints(self.table(doc.get("joints", {}), "[joints]"))
        job = Job(self.path, robot, tuple(path for path, _ in found), tuple(written for _, written in found),
                  outputs["out"], outputs["report"], self.options(doc), length, angle,
                  self.held_out(data["held_out"]) if "held_out" in data else None,
                  self.column(data["sample"], "[data] sample") if "sample" in data else None,
                  tuple(self.columns(data["ignore"], "[data] ignore")) if "ignore" in data else (), joints, measures,
                  header=self.choice(data.get("header", "names"), HEADERS, "[data] header"), joint_units=joint_units)
        self.claims(job)
        self.positions(job)
        chained = [m.key.partition(":")[0] for m in measures if parse_key(m.key).incremental]
        if len(job.files) > 1 and chained:
            raise self.error(f"[data] {key}", f"a {chained[0]} measurement needs a single data file (each "
                                              "increment is the change since the previous row of its file)")
        return job

    def units(self, value: Any) -> tuple[str, str]:
        units = self.table(value, "[data] units")
        self.keys(units, UNIT_KEYS, "in [data] units")
        return (self.choice(units.get("length", "m"), list(LENGTH_UNIT_SIZES), "[data] units: length"),
                self.choice(units.get("angle", "rad"), list(ANGLE_UNIT_SIZES), "[data] units: angle"))

    def joints(self, table: dict[str, Any]) -> tuple[dict[str, Column], dict[str, str]]:
        """``[joints]``: joint -> its column, and joint -> its unit where one is given. An entry is a column (its name,
        or its position from 1), or a table ``{ column = "T", units = "m" }`` (the column defaults to the joint's
        name)."""
        columns: dict[str, Column] = {}
        units: dict[str, str] = {}
        for joint, value in table.items():
            name, where = self.text(joint, "[joints]"), f"[joints] {joint}"
            if not isinstance(value, dict):
                columns[name] = self.column(value, where)
                continue
            self.keys(value, JOINT_KEYS, f"in {where}")
            if "column" in value:
                columns[name] = self.column(value["column"], f"{where} column")
            if "units" in value:
                units[name] = self.choice(value["units"], [*LENGTH_UNIT_SIZES, *ANGLE_UNIT_SIZES], f"{where} units")
        return columns, units

    def held_out(self, value: Any) -> HeldOut:
        where = "[data] held_out"
        if isinstance(value, list):
            rows = [self.whole(row, f"{where} (item {k + 1})", 0) for k, row in enumerate(value)]
            if len(set(rows)) != len(rows):
                raise self.error(where, "a row is listed twice")
            return HeldOut(f"rows {listing(str(r) for r in rows)}", rows=tuple(rows))
        text = self.text(value, where)
        every = EVERY.fullmatch(text)
        if every:
            k, start = int(every[1]), int(every[2] or 0)
            if k < 2:
                raise self.error(where, f"'{text}' holds out every row; give every K-th row with K ≥ 2")
            return HeldOut(text, every=k, start=start)
        if text.lower().startswith("every"):
            raise self.error(where, f"'{text}' is not of the form 'every K[th] [from S]' (e.g. 'every 5th from 4')")
        return HeldOut(text, column=text)

    def measure_list(self, doc: dict[str, Any]) -> list[dict[str, Any]]:
        entries = doc.get("measure", [])
        if not isinstance(entries, list) or not entries or not all(isinstance(e, dict) for e in entries):
            raise self.error("measure", "declare each measurement as a [[measure]] table with kind, frame (or "
                                        "frames) and columns (see docs/job_file.md)")
        return entries

    def measure(self, entry: dict[str, Any], number: int) -> MeasureColumns:
        where = f"[measure {number}]"
        keys = measure_keys()
        self.keys(entry, keys, f"in {where}")
        if "kind" not in entry:
            raise self.error(where, f"'kind' is missing (keys are: {listing(keys)})")
        kind = self.choice(entry["kind"], list(MEASUREMENT_COMPONENTS), f"{where} kind")
        model = KIND_CLASSES[kind]
        if "columns" not in entry and not model.zero_when_unwritten:
            raise self.error(where, f"'columns' is missing (keys are: {listing(keys)})")
        for own in keys[len(MEASURE_KEYS):]:
            if own in entry and own not in model.job_keys:
                only = next(k.job_keys[own] for k in KIND_CLASSES.values() if own in k.job_keys)
                raise self.error(f"{where} {own}", f"only {only}; a {kind} is not")
        two = model.job_frames == 2
        name, other = ("frames", "frame") if two else ("frame", "frames")
        if name not in entry or other in entry:
            shape = 'frames = ["A", "B"]' if two else 'frame = "NAME"'
            raise self.error(where, f"a {kind} measurement names its frame{'s' if two else ''} as {shape}")
        frames = self.texts(entry[name], f"{where} {name}")
        if len(frames) != model.job_frames:
            raise self.error(f"{where} {name}", f"{len(frames)} frames; a {kind} measurement joins two")
        key = model.job_key(kind, frames, {own: self.text(entry[own], f"{where} {own}") for own in model.job_keys
                                           if own in entry})
        try:
            parse_measurement_key(key)
        except DataError as exc:
            raise self.error(f"{where} {name}", str(exc)) from None
        components = MEASUREMENT_COMPONENTS[kind]
        columns = self.columns(entry["columns"], f"{where} columns") if "columns" in entry else []
        if len(columns) != len(components) and columns:
            raise self.error(f"{where} columns", f"{len(columns)} columns; a {kind} needs {len(components)}, one per "
                                                 f"component in this order: {listing(components)}")
        if "sigma_angle" in entry and not KIND_CLASSES[kind].angle_rows:
            raise self.error(f"{where} sigma_angle", f"only a pose or a camera's pose target has an orientation; a "
                                                     f"{kind} has sigma alone")
        return MeasureColumns(key, tuple(columns),
                              self.sigmas(entry["sigma"], f"{where} sigma") if "sigma" in entry else None,
                              self.sigma(entry["sigma_angle"], f"{where} sigma_angle") if "sigma_angle" in entry
                              else None, where,
                              self.choice(entry["units"], list(LENGTH_UNIT_SIZES), f"{where} units") if "units" in entry
                              else None)

    def positions(self, job: Job) -> None:
        """Refuse a column named by its header name when the job does not read the header."""
        if job.header == "names":
            return
        for column, where in _named_columns(job):
            if isinstance(column, str):
                raise self.error(where, f"'{column}' names a column by its header, and [data] header = "
                                        f"\"{job.header}\" reads none: name it by its position (1 for the first)")

    def claims(self, job: Job) -> None:
        """Refuse a column that the job gives two meanings."""
        claimed: dict[Column, str] = {}
        for column, where in _named_columns(job):
            if column in claimed:
                raise self.error(where, f"column '{column}' is also named by {claimed[column]}; a column has one "
                                        "meaning")
            claimed[column] = where
        keys = [m.key for m in job.measures]
        for k, measure in enumerate(job.measures):
            if measure.key in keys[:k]:
                raise self.error(measure.where, f"measurement '{measure.key}' is declared twice")
        angles = {m.sigma_angle for m in job.measures if m.sigma_angle is not None}
        if len(angles) > 1:
            raise self.error("[[measure]] sigma_angle", f"the poses give different values "
                                                        f"({listing(map(str, sorted(angles)))}); pincal takes one σ "
                                                        "for every pose's orientation")


def load_job_robot(job: Job) -> Robot:
    """The job's robot (:func:`~pincal.model.robot.load_robot`); an error says that the job named it."""
    try:
        return load_robot(job.robot)
    except NotFoundError as exc:
        raise NotFoundError(f"{job.path}: robot: {exc}", exc.kind, exc.name, exc.choices, file=str(job.path)) from None
