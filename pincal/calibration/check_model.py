"""The model ``pincal check`` evaluates: a calibrated URDF (with its corrections file beside it), a robot by name, or
a calibration's report JSON rebuilt on its nominal robot, with what the calibration recorded of its inputs
(:mod:`pincal.calibration.provenance`).

A model holds the calibrated robot, the joint corrections its readings take (harmonics, compliance) and the zeros of
its instrumented passive joints' sensors (docs/calibrated_urdf.md). SI units: m, rad.
"""

from __future__ import annotations

import json
from dataclasses import field
from pathlib import Path

import numpy as np
import numpy.typing as npt

from pincal.calibration.carried import read_carried
from pincal.calibration.provenance import Recorded, read_provenance, sha256
from pincal.calibration.report import CalibrationReport
from pincal.errors import Culprit, DataError, RobotFileError
from pincal.identification.choices import MarkerFit
from pincal.identification.measurements import Measurement, parse_key
from pincal.identification.parameters import choose_parameters, read_joints
from pincal.io.adapters import declared_marker_offsets
from pincal.io.calibrated_urdf import calibrated_robot_text, declared_markers, joint_sensor_zeros, source_text
from pincal.io.corrections_file import (
    Corrections,
    corrected_readings,
    corrections_of,
    corrections_path,
    read_corrections,
)
from pincal.io.dataset import Dataset
from pincal.model.robot import Robot, load_robot, robot_from_urdf_text
from pincal.records import record

Array = npt.NDArray[np.float64]

@record(frozen=True)
class CheckedModel:
    """The model ``check`` predicts with.

    Attributes:
        robot: The calibrated robot (raw actuated readings in, predictions in its root frame: the measurement frame
            when the calibration estimated it).
        source: What it was read from (a path or a name), for messages and the report.
        corrections: The joint corrections its actuated readings take (None: none).
        sensor_zeros: Instrumented passive joint -> the reading when the joint is at zero in the model [m or rad].
        provenance: What the calibration recorded of its inputs.
        calibration: The calibration's report, when MODEL is one, or the calibration a calibrated URDF carries
            (:mod:`pincal.calibration.carried`): its estimates, their covariance and the bound's growth give each
            posture's predicted error; None for a name, or a URDF that carries none.
    """

    robot: Robot
    source: str
    corrections: Corrections | None = None
    sensor_zeros: dict[str, float] = field(default_factory=dict)
    provenance: Recorded = field(default_factory=Recorded)
    calibration: CalibrationReport | None = None

    def readings(self, dataset: Dataset, nominal: Robot) -> Dataset:
        """``dataset`` with its joint readings as this model takes them: the actuated ones corrected (harmonics,
        compliance with ``nominal``'s gravity torques), each read passive joint less its sensor's zero."""
        joints = dataset.joints.copy()
        names = dataset.joint_names
        if self.corrections is not None:
            reference = nominal.actuated_values(nominal.q_reference)
            actuated = np.column_stack([joints[:, names.index(j)] if j in names else np.full(len(joints), reference[k])
                                        for k, j in enumerate(nominal.actuated_joints)])
            corrected = corrected_readings(self.corrections, nominal, actuated)
            for k, joint in enumerate(nominal.actuated_joints):
                if joint in names:
                    joints[:, names.index(joint)] = corrected[:, k]
        for joint, zero in self.sensor_zeros.items():
            if joint in names:
                joints[:, names.index(joint)] -= zero
        return Dataset(names, joints, dataset.measurements, dataset.sample_ids, dataset.sets, dataset.metadata)


#: What ``pincal check`` reads, said in every refusal of its arguments.
MODEL_AND_DATA = ("MODEL is a calibrated URDF, a known robot name or a report JSON (pincal calibrate --out, --report), "
                  "DATA a measurement CSV or a job file JOB.toml")
#: How much of a file its kind is told from [bytes]: a URDF's ``<robot>`` element comes after its XML declaration
#: and a comment or two.
HEAD_BYTES = 65536


def file_kind(path: Path) -> str:
    """What the regular file at ``path`` holds, by its suffix and its first :data:`HEAD_BYTES` bytes: ``job``
    (``.toml``), ``json`` (``.json``, or text starting with ``{``), ``urdf`` (XML with a ``<robot`` element), ``xml``,
    ``csv`` (``.csv``, or a first line that is not a comment starting with ``sample,``), ``binary`` (a NUL byte) or
    ``text`` (also a file that cannot be read: its reader says why)."""
    suffix = path.suffix.lower()
    if suffix in (".toml", ".json", ".csv"):
        return {".toml": "job", ".json": "json", ".csv": "csv"}[suffix]
    try:
        with path.open("rb") as stream:
            head = stream.read(HEAD_BYTES)
    except OSError:
        return "text"
    if b"\x00" in head:
        return "binary"
    text = head.decode("utf-8", errors="replace").lstrip("\ufeff \t\r\n")
    if text.startswith("<"):
        return "urdf" if "<robot" in text else "xml"
    if text.startswith("{"):
        return "json"
    first = next((line for line in text.splitlines() if line.strip() and not line.startswith("#")), "")
    return "csv" if first.startswith("sample,") else "text"


#: How each kind of file is named when it is given where another was expected.
KIND_WORDS = {"job": "a job file (TOML)", "json": "a JSON file (a report?)", "urdf": "a URDF", "xml": "an XML file",
              "csv": "a measurement CSV", "binary": "binary data, not text",
              "text": "text that is neither XML nor a measurement CSV"}


def check_nominal(model: str, given: str | None, nominal: Robot, recorded: Recorded) -> None:
    """Refuse a nominal robot ``given`` (``--nominal``, loaded as ``nominal``) that is not the one MODEL records it was
    calibrated from (``recorded``): a UR5 given for a calibrated UR10 would blame DATA for MODEL's robot. The same
    URDF (its SHA-256 the recorded one) moved elsewhere, or a robot of the recorded name or file name (its URDF edited
    since), is accepted.

    Raises:
        DataError: naming both robots and MODEL.
    """
    if given is None or recorded.robot is None:
        return
    source = Path(nominal.source) if nominal.source is not None else None
    if recorded.robot_sha256 and source is not None and source.is_file() and sha256(source) == recorded.robot_sha256:
        return
    names = {given, Path(given).stem, nominal.name} | ({source.stem} if source is not None else set())
    if recorded.robot in names or Path(recorded.robot).stem in names:
        return
    raise DataError(f"nominal_path='{given}' is not the robot MODEL was calibrated from ('{recorded.robot}', as "
                    f"'{model}' records): leave it out, or give that robot", option="nominal_path")


def load_nominal(model: str, given: str | None, name: str, recorded: Recorded) -> Robot:
    """The nominal robot ``name``: ``given`` (``--nominal``), else the one MODEL records (``recorded``), checked by
    :func:`check_nominal`.

    Raises:
        DataError: the URDF MODEL records (relative to MODEL's folder) is not there: MODEL moved without it; or as
            :func:`check_nominal`.
        RobotFileError, NotFoundError: the robot cannot be loaded.
    """
    if given is None and (Path(name).suffix or "/" in name) and not Path(name).is_file():
        raise DataError(f"MODEL '{model}' records its nominal robot as '{name}' (its URDF, relative to MODEL's "
                        "folder), which is not there: give the robot it was calibrated from with nominal_path=ROBOT",
                        option="nominal_path")
    nominal = load_robot(name)
    check_nominal(model, given, nominal, recorded)
    return nominal


def check_arguments(model: str, data: str) -> None:
    """Refuse a MODEL or DATA argument that is not what ``pincal check`` reads, before anything is read: MODEL a
    directory, a device or pipe, data (a CSV or a job file), a text or binary file that is no URDF, a file that does
    not exist and no known robot's name; DATA a directory, a device or pipe, a URDF or other XML, a JSON file, a file
    that does not exist.

    Raises:
        DataError: one line naming the argument, what it is, and what MODEL and DATA should be.
    """
    from pincal.io.files import input_problem
    from pincal.model.catalog import known_robot_names

    problem = input_problem(Path(model))
    bare = not (Path(model).suffix or "/" in model)  # a name, not a path (load_robot's rule)
    if problem in ("does not exist", "is a directory") and bare and model in known_robot_names():
        problem = None  # a known robot, by its name
    elif problem == "does not exist" and bare:
        raise DataError(f"MODEL '{model}' does not exist (no such file, and no known robot of that name): "
                        f"{MODEL_AND_DATA}")
    elif problem is not None:
        raise DataError(f"MODEL '{model}' {problem}, where a model was expected: {MODEL_AND_DATA}")
    elif (kind := file_kind(Path(model))) in ("job", "csv", "binary", "text"):
        raise DataError(f"MODEL '{model}' is {KIND_WORDS[kind]}, where a model was expected: {MODEL_AND_DATA}")
    elif kind == "json" and Path(model).suffix.lower() != ".json":
        raise DataError(f"MODEL '{model}' is JSON text not named *.json (a report JSON is told by its suffix): "
                        f"{MODEL_AND_DATA}")
    elif kind == "json":
        _check_report_format(model)
    problem = input_problem(Path(data))
    if problem is not None:
        raise DataError(f"DATA '{data}' {problem}, where data were expected: {MODEL_AND_DATA}")
    if (kind := file_kind(Path(data))) in ("urdf", "xml", "json"):
        raise DataError(f"DATA '{data}' is {KIND_WORDS[kind]}, where data were expected: {MODEL_AND_DATA}")


#: The JSON files of pincal that are not a calibration's report, by their ``format``: what each is.
OTHER_JSON = {"pincal joint corrections 1": "a pincal corrections file",
              "pincal check 1": "the report of a pincal check"}


def _check_report_format(path: str) -> None:
    """Refuse a MODEL JSON that pincal wrote as something else than a calibration's report (its ``format``): a
    corrections file (its calibrated URDF, ``<stem>.urdf`` beside it, pointed to), a check's report. A file that
    cannot be read as JSON is left to the report's reader, which names it.

    Raises:
        DataError: naming the file and what it is.
    """
    try:
        content = json.loads(Path(path).read_text(encoding="utf-8"))
    except (OSError, UnicodeDecodeError, json.JSONDecodeError):
        return
    written = content.get("format") if isinstance(content, dict) else None
    if not isinstance(written, str) or written not in OTHER_JSON:
        return
    hint = ""
    if written == "pincal joint corrections 1":
        stem = Path(path).name.removesuffix(".json").removesuffix(".corrections")
        hint = f": give the calibrated URDF it sits beside ('{Path(path).with_name(stem + '.urdf')}')"
    raise DataError(f"MODEL '{path}' is {OTHER_JSON[written]} (format '{written}'), not a calibration's report{hint}; "
                    f"{MODEL_AND_DATA}")


def is_report(path: str | Path) -> bool:
    """Whether ``path`` names a report JSON (by its suffix)."""
    return Path(path).suffix.lower() == ".json"


def load_model(path: str, nominal: Robot, dataset: Dataset) -> CheckedModel:
    """The model at ``path``: a calibrated URDF or a robot name (with ``<name>.corrections.json`` beside a URDF when
    there is one), or a report JSON rebuilt on ``nominal`` (its parameters' values applied as ``calibrate --out``
    writes them; ``dataset`` gives the nominal offsets of declared markers).

    Raises:
        RobotFileError, NotFoundError: the URDF cannot be read, or the name is not known.
        DataError: a report that is not one, or whose parameters ``nominal`` does not have; a model whose actuated
            joints are not ``nominal``'s; a calibrated URDF whose corrections file is missing or changed. Its
            ``file`` is ``path`` (a file) unless another file read for it (the corrections file) is at fault.
    """
    with Culprit(file=path if Path(path).is_file() else None):  # a report rebuilt, MODEL's joints: MODEL's fault
        if is_report(path):
            model = _rebuilt(path, nominal, dataset)
        else:
            robot = load_robot(path)
            if Path(path).is_file():
                read_provenance(path).check_corrections(path)
            beside = corrections_path(path)
            corrections = read_corrections(beside) if robot.source is not None and beside.is_file() else None
            zeros = joint_sensor_zeros(source_text(robot)) if robot.source is not None else {}
            carried = read_carried(path) if Path(path).is_file() else None  # the calibration a calibrated URDF has
            model = CheckedModel(robot, path, corrections, zeros, read_provenance(path), carried)
        if list(model.robot.actuated_joints) != list(nominal.actuated_joints):
            raise DataError(f"MODEL '{path}' actuates {', '.join(model.robot.actuated_joints)}, the nominal robot "
                            f"'{nominal.name}' {', '.join(nominal.actuated_joints)}: give the nominal robot MODEL was "
                            "calibrated from (--nominal)")
        return model


def _rebuilt(path: str, nominal: Robot, dataset: Dataset) -> CheckedModel:
    """A report JSON's calibrated robot: its parameters' values applied to ``nominal``."""
    report = CalibrationReport.read(path)
    declared = _declared(report, dataset)
    models: list[Measurement] = [parse_key(key).with_markers(declared) for key in report.measurements]
    names = list(report.parameters)
    try:
        parameters = choose_parameters(nominal, models, names, _marker_fit(report))
    except (DataError, KeyError) as exc:
        raise DataError(f"MODEL '{path}': its parameters are not those of robot '{nominal.name}' measured by "
                        f"{', '.join(report.measurements) or 'nothing'}: {exc}") from None
    if len(parameters) != len(names):
        raise DataError(f"MODEL '{path}': {len(names)} parameters, of which robot '{nominal.name}' has "
                        f"{len(parameters)}: is '{nominal.name}' the robot it was calibrated from?",
                        option="nominal_path")
    x = np.array([float(report.parameters[name].value) for name in parameters.names])
    text, _ = calibrated_robot_text(nominal, source_text(nominal), parameters, x, read_joints=read_joints(models),
                                    markers=declared_markers(models))
    try:
        robot = robot_from_urdf_text(text)
    except RobotFileError as exc:
        raise DataError(f"MODEL '{path}': its calibrated robot cannot be built: {exc}") from None
    payload = report.payload
    return CheckedModel(robot, path, corrections_of(nominal, parameters, x, payload), joint_sensor_zeros(text),
                        read_provenance(path), report)


def _declared(report: CalibrationReport, dataset: Dataset) -> dict[str, tuple[float, float, float]]:
    """The nominal marker offsets [m, in their frames] the report's calibrated robot is built on: those its calibration
    read, as the report records them (a report written before it recorded them: those ``dataset`` declares)."""
    if "declared_markers" not in report.present:
        return declared_marker_offsets(dataset.metadata)
    return {target: (float(x), float(y), float(z)) for target, (x, y, z) in report.declared_markers.items()}


def _marker_fit(report: CalibrationReport) -> MarkerFit:
    """How the report's calibration fitted declared markers."""
    return "cluster" if report.markers == "cluster" else "each"

