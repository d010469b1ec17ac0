"""A job file's record and the checks of its values (docs/job_file.md).

:class:`Job` is a job file read and checked; :class:`JobReader` checks one job file's values (a table, a text, a σ,
a column, a file, the calibration options), each error starting with the file and the place in it. The grammar of a
job with a ``[data]`` table (:mod:`pincal.calibration.job`) and of one with a ``[bag]`` table
(:mod:`pincal.calibration.job_bag`) are both read with it.
"""

from __future__ import annotations

import math
import re
from collections.abc import Sequence
from dataclasses import field, replace
from pathlib import Path
from typing import TYPE_CHECKING, Any

from pincal.calibration.options import JOB_OPTIONS, OPTIONS, GivenOptions
from pincal.errors import DataError, NotFoundError, PincalError, listing, not_found
from pincal.identification.corrections import Payload, payload_from_dict
from pincal.io.files import input_problem
from pincal.records import record

if TYPE_CHECKING:
    from pincal.io.bag_dataset import BagSource

#: Keys of the top level of a job file with a ``[data]`` table.
JOB_KEYS = ("robot", "data", "joints", "measure", "out", "report", *JOB_OPTIONS)
PAYLOAD_KEYS = ("mass", "frame", "offset")
#: A data file's column as a job names it: its header name, or its position (1 for the first column).
Column = str | int


@record(frozen=True)
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


@record(frozen=True)
class HeldOut:
    """Which rows are held out: every ``every``-th from ``start``, the rows ``rows``, or those a ``column`` marks."""

    text: str
    every: int = 0
    start: int = 0
    rows: tuple[int, ...] = ()
    column: str | None = None


@record(frozen=True)
class Job:
    """A job file, read and checked (docs/job_file.md); paths resolved against its directory.

    Attributes:
        path: The job file.
        robot: A known robot name, or the path of a URDF file.
        files: The data files, in order.
        file_names: Each data file as the job writes it (messages, sample ids).
        out: The calibrated URDF to write, or None.
        report: The report JSON to write, or None.
        options: The options of :func:`pincal.calibration.calibrate` the job gives (``parameters``, ``select``,
            ``loss``, ``solver``, ``sigma`` [m], ``max_iter``, ``formulation``, ``cv``, ``cv_seed``, ``payload``), each
            with where it was given (the job file, or the command line in place of the job's):
            :class:`~pincal.calibration.options.GivenOptions`.
        length_unit: The data files' length unit (a key of :data:`LENGTH_UNIT_SIZES`).
        angle_unit: The data files' angle unit (a key of :data:`ANGLE_UNIT_SIZES`).
        held_out: Which rows are held out, or None.
        sample: The column of the sample ids, or None (ids: the row numbers).
        ignore: Columns of the data files that are not read.
        joints: Joint name -> the column of its readings, those the job maps.
        header: What each data file's first line is (:data:`~pincal.calibration.job.HEADERS`); a column is named by its
            header name, or by its position from 1 (the only way when the header is skipped or absent).
        joint_units: Joint name -> the unit its readings are written in (a key of :data:`LENGTH_UNIT_SIZES` or
            :data:`ANGLE_UNIT_SIZES`), those the job states; the others are in ``length_unit`` or ``angle_unit``.
        measures: The measurements and their columns.
        bag: The ROS bag the data come from (a ``[bag]`` table, :mod:`pincal.calibration.job_bag`), or None.
    """

    path: Path
    robot: str
    files: tuple[Path, ...]
    file_names: tuple[str, ...]
    out: Path | None = None
    report: Path | None = None
    options: GivenOptions = field(default_factory=GivenOptions)
    length_unit: str = "m"
    angle_unit: str = "rad"
    held_out: HeldOut | None = None
    sample: Column | None = None
    ignore: tuple[Column, ...] = ()
    joints: dict[str, Column] = field(default_factory=dict)
    measures: tuple[MeasureColumns, ...] = ()
    bag: BagSource | None = None
    header: str = "names"
    joint_units: dict[str, str] = field(default_factory=dict)

    def overridden(self, out: str | Path | None = None, report: str | Path | None = None,
                   options: GivenOptions | None = None) -> Job:
        """This job with outputs and :func:`~pincal.calibration.calibrate` options given elsewhere (the command line:
        :class:`~pincal.calibration.options.GivenOptions`, each at its source) in place of its own; None keeps the
        job's."""
        return replace(self, out=Path(out) if out is not None else self.out,
                       report=Path(report) if report is not None else self.report,
                       options=self.options if options is None else self.options.over(options))


class JobReader:
    """The checks of one job file's values; every message starts with the file and the place in it.

    Attributes:
        path: The job file.
        base: Its directory, which the paths it names are relative to.
    """

    def __init__(self, path: Path) -> None:
        self.path = path
        self.base = path.parent

    def error(self, where: str, message: str) -> DataError:
        """The error at ``where`` in this file: ``FILE: WHERE: MESSAGE``, the file its ``file`` field."""
        return DataError(f"{self.path}: {where}: {message}", file=str(self.path))

    def keys(self, table: dict[str, Any], valid: Sequence[str], level: str) -> None:
        """Refuse a key of ``table`` not in ``valid``, listing the valid keys at ``level``."""
        for key in table:
            if key not in valid:
                error = not_found("key", key, valid, f" {level}", f"{self.path}: ")
                if valid is not JOB_KEYS and key in JOB_KEYS:  # TOML puts keys after a [table] header inside it
                    raise NotFoundError(f"{error} ('{key}' is a top-level key: write it above the first [table])",
                                        error.kind, error.name, error.choices, file=str(self.path))
                error.file = str(self.path)
                raise error

    def table(self, value: Any, where: str) -> dict[str, Any]:
        """``value``, a TOML table at ``where``."""
        if not isinstance(value, dict):
            raise self.error(where, f"{shown(value)} is not a table; write it as [{where.strip('[]')}] or {{ ... }}")
        return value

    def text(self, value: Any, where: str) -> str:
        """``value``, a non-empty string at ``where``, stripped."""
        if not isinstance(value, str) or not value.strip():
            raise self.error(where, f"{shown(value)} is not a non-empty string")
        return value.strip()

    def texts(self, value: Any, where: str) -> list[str]:
        """A string or a list of strings."""
        if isinstance(value, str):
            return [self.text(value, where)]
        if not isinstance(value, list) or not value:
            raise self.error(where, f"{shown(value)} is not a string nor a non-empty list of strings")
        return [self.text(item, f"{where} (item {k + 1})") for k, item in enumerate(value)]

    def choice(self, value: Any, choices: Sequence[str], where: str) -> str:
        """``value``, one of ``choices`` at ``where``."""
        word = self.text(value, where)
        if word not in choices:
            raise self.error(where, f"'{word}' is not one of: {listing(choices)}")
        return word

    def sigma(self, value: Any, where: str) -> float:
        """``value``, a standard deviation > 0 at ``where`` [m or rad]."""
        if isinstance(value, bool) or not isinstance(value, int | float) or not 0.0 < value < math.inf:
            raise self.error(where, f"{shown(value)} is not a number > 0 (a standard deviation in SI units: m, rad)")
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
            raise self.error(where, f"{shown(value)} is neither a column's name nor its position (1 for the first "
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
        """``value``, a whole number ≥ ``minimum`` at ``where``."""
        if isinstance(value, bool) or not isinstance(value, int) or value < minimum:
            raise self.error(where, f"{shown(value)} is not a whole number ≥ {minimum}")
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

    def options(self, doc: dict[str, Any]) -> GivenOptions:
        """The calibration options the job gives, each read as its :class:`~pincal.calibration.options.Option`
        says (its key, kind and choices), given at the job file; an error names the option (its ``option``
        field)."""
        options: dict[str, Any] = {}
        for name, option in OPTIONS.items():
            if option.key is None or option.key not in doc:
                continue
            key, value = option.key, doc[option.key]
            try:
                if option.choices is not None:
                    options[name] = self.choice(value, option.choices, key)
                else:
                    options[name] = getattr(self, f"option_{option.kind}")(value, key)
            except PincalError as exc:
                exc.option = name
                raise
        return GivenOptions.of(options, self.path)

    def option_texts(self, value: Any, key: str) -> list[str]:
        """An option of strings (``parameters``): one string or a list of them."""
        return self.texts(value, key)

    def option_sigma(self, value: Any, key: str) -> float:
        """An option of one σ [m or rad]."""
        return self.sigma(value, key)

    def option_sigmas(self, value: Any, key: str) -> float | tuple[float, ...]:
        """An option of one σ or one per residual row [m or rad]."""
        return self.sigmas(value, key)

    def option_int(self, value: Any, key: str) -> int:
        """An option of a whole number ≥ 1 (``max_iter``)."""
        return self.whole(value, key, 1)

    def option_seed(self, value: Any, key: str) -> int:
        """An option of a seed, a whole number ≥ 0."""
        return self.whole(value, key, 0)

    def option_plan(self, value: Any, key: str) -> str:
        """A cross-validation plan: K folds, K folds × R shuffles (``"5x4"``) or ``"loo"``."""
        plan = str(self.whole(value, key, 2)) if isinstance(value, int) else self.text(value, key)
        if not re.fullmatch(r"\d+(x\d+)?|loo", plan, re.IGNORECASE):
            raise self.error(key, f"'{plan}' is not K (folds), KxR (K folds, R shuffles, e.g. \"5x4\") or \"loo\"")
        return plan

    def option_factor(self, value: Any, key: str, auto: bool = False) -> float | str:
        """A factor > 0 (dimensionless), or ``"off"`` (and ``"auto"`` where ``auto``)."""
        if isinstance(value, str) and value.strip().lower() in (("off", "auto") if auto else ("off",)):
            return value.strip().lower()
        if isinstance(value, bool) or not isinstance(value, int | float) or not 0.0 < value < math.inf:
            choices = 'a factor > 0, "auto" or "off"' if auto else 'a factor > 0 or "off"'
            raise self.error(key, f"{shown(value)} is not {choices}")
        return float(value)

    def option_prior(self, value: Any, key: str) -> float | str:
        """The prior's factor > 0 (dimensionless), ``"auto"`` or ``"off"``."""
        return self.option_factor(value, key, auto=True)

    def option_payload(self, value: Any, key: str) -> Payload | None:
        """A payload table: ``mass`` [kg], ``frame``, ``offset`` [m]."""
        payload = self.table(value, key)
        self.keys(payload, PAYLOAD_KEYS, f"in {key}")
        try:
            return payload_from_dict(payload)
        except DataError as exc:
            raise DataError(f"{self.path}: {exc}", file=str(self.path)) from None



def shown(value: Any) -> str:
    """A value as an error quotes it: a text in quotes, anything else with its type."""
    return repr(value) if isinstance(value, str) else f"{value!r} ({type(value).__name__})"
