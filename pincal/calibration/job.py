"""Job files: one TOML file that holds everything a calibration run needs (docs/job_file.md).

A job names the robot, the data files as the measuring system wrote them, which of their columns are which
quantity and in which units, which samples are held out, the parameters and the options of ``pincal calibrate``.
:func:`read_job` reads and checks the file; :func:`pincal.calibration.job_data.job_dataset` reads its data into a
:class:`~pincal.io.dataset.Dataset` in SI units (m, rad). Paths in a job are relative to the job file's directory.

Every error names the file and the place in it (``job.toml: [measure 1] columns: ...``). An unknown key is an error
that lists the valid keys at its level: a misspelt option is never ignored.
"""

from __future__ import annotations

import math
import re
import tomllib
from collections.abc import Sequence
from dataclasses import dataclass, field, replace
from pathlib import Path
from typing import TYPE_CHECKING, Any

from pincal.calibration.options import JOB_OPTIONS, OPTIONS
from pincal.calibration.samples import ANGLE_UNIT_SIZES, LENGTH_UNIT_SIZES
from pincal.errors import DataError, NotFoundError, listing, not_found
from pincal.identification.corrections import Payload, payload_from_dict
from pincal.identification.measurements import KIND_CLASSES
from pincal.io.dataset import MEASUREMENT_COMPONENTS, parse_measurement_key
from pincal.io.files import input_problem
from pincal.model.robot import Robot, load_robot

if TYPE_CHECKING:
    from pincal.io.bag_dataset import BagSource

#: Keys of each level of a job file.
JOB_KEYS = ("robot", "data", "joints", "measure", "out", "report", *JOB_OPTIONS)
DATA_KEYS = ("file", "files", "units", "held_out", "sample", "ignore", "header")
UNIT_KEYS = ("length", "angle")
MEASURE_KEYS = ("kind", "frame", "frames", "columns", "units", "sigma", "sigma_angle", "support")
#: Keys of a joint given as a table under ``[joints]``: ``torso_lift_joint = { column = "T", units = "m" }``.
JOINT_KEYS = ("column", "units")
PAYLOAD_KEYS = ("mass", "frame", "offset")
#: What the first line of a data file is: the column ``names`` (the default), a header to ``skip`` (names defective or
#: misplaced: every column is named by its position), or ``none`` (the first line is data).
HEADERS = ("names", "skip", "none")
#: A data file's column as a job names it: its header name, or its position (1 for the first column).
Column = str | int
#: ``held_out = "every 5th from 4"``: every K-th row of the data, counted from 0 over the files in order.
EVERY = re.compile(r"every\s+(\d+)(?:st|nd|rd|th)?(?:\s+from\s+(\d+))?", re.IGNORECASE)


@dataclass(frozen=True)
class MeasureColumns:
    """One ``[[measure]]`` entry: a measurement and the data columns of its components.

    Attributes:
        key: The measurement key (``position:wrist_ft_tool_link``, ``distance:a-b``).
        columns: The data file's column of each component (a name, or a position from 1), in the model's order (x, y,
            z; x, y, z, qx, qy, qz, qw; d); empty for a contact written in no column (every value 0).
        sigma: σ of its values [m, rad]: one, or one per residual row; None: not stated.
        sigma_angle: σ of a pose's orientation [rad], or None.
        where: Its place in the job, ``[measure 1]``.
        length_unit: The length unit its columns are written in (a key of :data:`LENGTH_UNIT_SIZES`), or None: the
            job's ``[data] units``.
    """

    key: str
    columns: tuple[Column, ...]
    sigma: float | tuple[float, ...] | None
    sigma_angle: float | None
    where: str
    length_unit: str | None = None


@dataclass(frozen=True)
class HeldOut:
    """Which rows are held out: every ``every``-th from ``start``, the rows ``rows``, or those a ``column`` marks."""

    text: str
    every: int = 0
    start: int = 0
    rows: tuple[int, ...] = ()
    column: str | None = None


@dataclass(frozen=True)
class Job:
    """A job file, read and checked (docs/job_file.md); paths resolved against its directory.

    Attributes:
        path: The job file.
        robot: A known robot name, or the path of a URDF file.
        files: The data files, in order.
        file_names: Each data file as the job writes it (messages, sample ids).
        out: The calibrated URDF to write, or None.
        report: The report JSON to write, or None.
        options: Keyword arguments of :func:`pincal.calibration.calibrate` (``parameter_spec``, ``select``, ``loss``,
            ``solver``, ``sigma`` [m], ``max_iter``, ``formulation``, ``cv``, ``cv_seed``, ``payload``), those the
            job gives.
        length_unit: The data files' length unit (a key of :data:`LENGTH_UNIT_SIZES`).
        angle_unit: The data files' angle unit (a key of :data:`ANGLE_UNIT_SIZES`).
        held_out: Which rows are held out, or None.
        sample: The column of the sample ids, or None (ids: the row numbers).
        ignore: Columns of the data files that are not read.
        joints: Joint name -> the column of its readings, those the job maps.
        header: What each data file's first line is (:data:`HEADERS`); a column is named by its header name, or by
            its position from 1 (the only way when the header is skipped or absent).
        joint_units: Joint name -> the unit its readings are written in (a key of :data:`LENGTH_UNIT_SIZES` or
            :data:`ANGLE_UNIT_SIZES`), those the job states; the others are in ``length_unit`` or ``angle_unit``.
        measures: The measurements and their columns.
        overrides: The options given elsewhere (the command line) in place of the job's, by name.
        bag: The ROS bag the data come from (a ``[bag]`` table, :mod:`pincal.calibration.job_bag`), or None.
    """

    path: Path
    robot: str
    files: tuple[Path, ...]
    file_names: tuple[str, ...]
    out: Path | None = None
    report: Path | None = None
    options: dict[str, Any] = field(default_factory=dict)
    length_unit: str = "m"
    angle_unit: str = "rad"
    held_out: HeldOut | None = None
    sample: Column | None = None
    ignore: tuple[Column, ...] = ()
    joints: dict[str, Column] = field(default_factory=dict)
    measures: tuple[MeasureColumns, ...] = ()
    overrides: tuple[str, ...] = ()
    bag: BagSource | None = None
    header: str = "names"
    joint_units: dict[str, str] = field(default_factory=dict)

    def overridden(self, out: str | Path | None = None, report: str | Path | None = None,
                   **options: Any) -> Job:
        """This job with outputs and :func:`~pincal.calibration.calibrate` options given elsewhere (the command line) in
        place of its own; None keeps the job's.

        Raises:
            NotFoundError: an option that :func:`~pincal.calibration.calibrate` does not have.
        """
        for name in options:
            if name not in OPTIONS:
                raise not_found("option", name, OPTIONS, " of calibrate()")
        given = {k: v for k, v in options.items() if v is not None}
        return replace(self, out=Path(out) if out is not None else self.out,
                       report=Path(report) if report is not None else self.report,
                       options={**self.options, **given}, overrides=tuple(sorted({*self.overrides, *given})))


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
        raise DataError(f"cannot read job file '{source}': {exc.strerror or exc}") from None
    try:
        text = raw.decode("utf-8-sig")  # a byte-order mark, as some editors write, is no content
    except UnicodeDecodeError as exc:
        raise DataError(f"{source}: not UTF-8 text (byte {exc.start}): a TOML job file's encoding is UTF-8; save "
                        "it as UTF-8") from None
    try:
        doc = tomllib.loads(text)
    except tomllib.TOMLDecodeError as exc:
        raise DataError(f"{source}: not a valid TOML file: {exc}") from None
    except RecursionError:
        raise DataError(f"{source}: arrays or tables nested too deeply to read; a job file nests a few "
                        "levels") from None
    if "bag" in doc:  # the data is a ROS bag (docs/bags.md)
        from pincal.calibration.job_bag import read_bag_job

        return read_bag_job(_Reader(source), doc)
    return _Reader(source).job(doc)


def _named_columns(job: Job) -> list[tuple[Column, str]]:
    """Every column the job names (by header name or position), with where it names it."""
    named = [(c, f"{m.where} columns") for m in job.measures for c in m.columns]
    named += [(column, f"[joints] {joint}") for joint, column in job.joints.items()]
    named += [(job.sample, "[data] sample")] if job.sample is not None else []
    named += [(job.held_out.column, "[data] held_out")] if job.held_out and job.held_out.column else []
    named += [(column, "[data] ignore") for column in job.ignore]
    return named


class _Reader:
    """The checks of one job file's values; every message starts with the file and the place in it."""

    def __init__(self, path: Path) -> None:
        self.path = path
        self.base = path.parent

    def error(self, where: str, message: str) -> DataError:
        return DataError(f"{self.path}: {where}: {message}")

    def keys(self, table: dict[str, Any], valid: Sequence[str], level: str) -> None:
        for key in table:
            if key not in valid:
                error = not_found("key", key, valid, f" {level}", f"{self.path}: ")
                if valid is not JOB_KEYS and key in JOB_KEYS:  # TOML puts keys after a [table] header inside it
                    raise NotFoundError(f"{error} ('{key}' is a top-level key: write it above the first [table])",
                                        error.kind, error.name, error.choices)
                raise error

    def table(self, value: Any, where: str) -> dict[str, Any]:
        if not isinstance(value, dict):
            raise self.error(where, f"{_shown(value)} is not a table; write it as [{where.strip('[]')}] or {{ ... }}")
        return value

    def text(self, value: Any, where: str) -> str:
        if not isinstance(value, str) or not value.strip():
            raise self.error(where, f"{_shown(value)} is not a non-empty string")
        return value.strip()

    def texts(self, value: Any, where: str) -> list[str]:
        """A string or a list of strings."""
        if isinstance(value, str):
            return [self.text(value, where)]
        if not isinstance(value, list) or not value:
            raise self.error(where, f"{_shown(value)} is not a string nor a non-empty list of strings")
        return [self.text(item, f"{where} (item {k + 1})") for k, item in enumerate(value)]

    def choice(self, value: Any, choices: Sequence[str], where: str) -> str:
        word = self.text(value, where)
        if word not in choices:
            raise self.error(where, f"'{word}' is not one of: {listing(choices)}")
        return word

    def sigma(self, value: Any, where: str) -> float:
        if isinstance(value, bool) or not isinstance(value, int | float) or not 0.0 < value < math.inf:
            raise self.error(where, f"{_shown(value)} is not a number > 0 (a standard deviation in SI units: m, rad)")
        return float(value)

    def sigmas(self, value: Any, where: str) -> float | tuple[float, ...]:
        """One σ [m, rad], or a non-empty list of them: one per residual row (``[1e-3, 1e-3, 3e-3]``)."""
        if not isinstance(value, list):
            return self.sigma(value, where)
        if not value:
            raise self.error(where, "[] gives no σ: write one number, or one per residual row ([1e-3, 1e-3, 3e-3])")
        return tuple(self.sigma(item, f"{where} (item {k + 1})") for k, item in enumerate(value))

    def column(self, value: Any, where: str) -> Column:
        """A column: its header name (a non-empty string) or its position (a whole number from 1)."""
        if isinstance(value, int) and not isinstance(value, bool):
            return self.whole(value, where, 1)
        if not isinstance(value, str) or not value.strip():
            raise self.error(where, f"{_shown(value)} is neither a column's name nor its position (1 for the first "
                                    "column)")
        return value.strip()

    def columns(self, value: Any, where: str) -> list[Column]:
        """A column, or a non-empty list of them."""
        if not isinstance(value, list):
            return [self.column(value, where)]
        if not value:
            raise self.error(where, "[] names no column")
        return [self.column(item, f"{where} (item {k + 1})") for k, item in enumerate(value)]

    def whole(self, value: Any, where: str, minimum: int) -> int:
        if isinstance(value, bool) or not isinstance(value, int) or value < minimum:
            raise self.error(where, f"{_shown(value)} is not a whole number ≥ {minimum}")
        return value

    def file(self, value: Any, where: str, must_exist: bool = True) -> tuple[Path, str]:
        """A path as written and resolved against the job's directory; an input must be a file."""
        written = self.text(value, where)
        path = self.base / Path(written).expanduser()
        what = input_problem(path) if must_exist else None
        if what:
            raise self.error(where, f"'{written}' {what} (looked for '{path.absolute()}': paths in a job file are "
                                    "relative to its directory)")
        return path, written

    def job(self, doc: dict[str, Any]) -> Job:
        self.keys(doc, JOB_KEYS, "at the top level")
        for key in ("robot", "data"):
            if key not in doc:
                raise DataError(f"{self.path}: '{key}' is missing: a job names its robot, and its data in a [data] "
                                "table (see docs/job_file.md)")
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
        if len(job.files) > 1 and any(m.key.startswith("distance_increment:") for m in measures):
            raise self.error(f"[data] {key}", "a distance_increment measurement needs a single data file (each "
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
        self.keys(entry, MEASURE_KEYS, f"in {where}")
        if "kind" not in entry:
            raise self.error(where, f"'kind' is missing (keys are: {listing(MEASURE_KEYS)})")
        kind = self.choice(entry["kind"], list(MEASUREMENT_COMPONENTS), f"{where} kind")
        unwritten = KIND_CLASSES[kind].zero_when_unwritten
        if "columns" not in entry and not unwritten:
            raise self.error(where, f"'columns' is missing (keys are: {listing(MEASURE_KEYS)})")
        if "support" in entry and not unwritten:
            raise self.error(f"{where} support", f"only a contact with a plane is held by a support; a {kind} is not")
        two = kind.startswith("distance")
        name, other = ("frames", "frame") if two else ("frame", "frames")
        if name not in entry or other in entry:
            shape = 'frames = ["A", "B"]' if two else 'frame = "NAME"'
            raise self.error(where, f"a {kind} measurement names its frame{'s' if two else ''} as {shape}")
        frames = self.texts(entry[name], f"{where} {name}")
        if len(frames) != (2 if two else 1):
            raise self.error(f"{where} {name}", f"{len(frames)} frames; a {kind} measurement joins two")
        key = f"{kind}:{'-'.join(frames)}"
        if "support" in entry:
            key += f"@{self.text(entry['support'], f'{where} support')}"
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

    def options(self, doc: dict[str, Any]) -> dict[str, Any]:
        """The calibration options the job gives, each read as its :class:`~pincal.calibration.options.Option`
        says (its key, kind and choices), by keyword."""
        options: dict[str, Any] = {}
        for name, option in OPTIONS.items():
            if option.key is None or option.key not in doc:
                continue
            key, value = option.key, doc[option.key]
            if option.choices is not None:
                options[name] = self.choice(value, option.choices, key)
            else:
                options[name] = getattr(self, f"option_{option.kind}")(value, key)
        return options

    def option_texts(self, value: Any, key: str) -> list[str]:
        return self.texts(value, key)

    def option_sigma(self, value: Any, key: str) -> float:
        return self.sigma(value, key)

    def option_sigmas(self, value: Any, key: str) -> float | tuple[float, ...]:
        return self.sigmas(value, key)

    def option_int(self, value: Any, key: str) -> int:
        return self.whole(value, key, 1)

    def option_seed(self, value: Any, key: str) -> int:
        return self.whole(value, key, 0)

    def option_plan(self, value: Any, key: str) -> str:
        plan = str(self.whole(value, key, 2)) if isinstance(value, int) else self.text(value, key)
        if not re.fullmatch(r"\d+(x\d+)?|loo", plan, re.IGNORECASE):
            raise self.error(key, f"'{plan}' is not K (folds), KxR (K folds, R shuffles, e.g. \"5x4\") or \"loo\"")
        return plan

    def option_factor(self, value: Any, key: str, auto: bool = False) -> float | str:
        if isinstance(value, str) and value.strip().lower() in (("off", "auto") if auto else ("off",)):
            return value.strip().lower()
        if isinstance(value, bool) or not isinstance(value, int | float) or not 0.0 < value < math.inf:
            choices = 'a factor > 0, "auto" or "off"' if auto else 'a factor > 0 or "off"'
            raise self.error(key, f"{_shown(value)} is not {choices}")
        return float(value)

    def option_prior(self, value: Any, key: str) -> float | str:
        return self.option_factor(value, key, auto=True)

    def option_payload(self, value: Any, key: str) -> Payload | None:
        payload = self.table(value, key)
        self.keys(payload, PAYLOAD_KEYS, f"in {key}")
        try:
            return payload_from_dict(payload)
        except DataError as exc:
            raise DataError(f"{self.path}: {exc}") from None

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


def _shown(value: Any) -> str:
    return repr(value) if isinstance(value, str) else f"{value!r} ({type(value).__name__})"


def load_job_robot(job: Job) -> Robot:
    """The job's robot (:func:`~pincal.model.robot.load_robot`); an error says that the job named it."""
    try:
        return load_robot(job.robot)
    except NotFoundError as exc:
        raise NotFoundError(f"{job.path}: robot: {exc}", exc.kind, exc.name, exc.choices) from None
