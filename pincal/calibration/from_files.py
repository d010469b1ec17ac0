"""A calibration from files: the outputs checked before any work (never over an input), then written whole or not
at all, each recording its provenance (:mod:`pincal.calibration.provenance`) — from a robot and a data file
(:func:`calibrate_files`) or from a job file (:func:`calibrate_job`)."""

from __future__ import annotations

import hashlib
from dataclasses import replace
from pathlib import Path
from typing import TYPE_CHECKING

from pincal import validation
from pincal.calibration.options import CalibrationOptions, GivenOptions
from pincal.calibration.pipeline import Calibration, calibrate
from pincal.calibration.provenance import Provenance, file_source, options_dict, robot_source, with_provenance
from pincal.calibration.report import CalibrationReport
from pincal.calibration.samples import read_robot_dataset
from pincal.errors import NotFoundError, PincalError
from pincal.io.calibrated_urdf import source_text
from pincal.io.corrections_file import corrections_dict, corrections_path, robot_files
from pincal.io.dataset import Dataset
from pincal.io.files import check_outputs, json_text, write_texts
from pincal.io.mesh_files import MeshMode, MeshPlan, plan_meshes
from pincal.model.robot import Robot, load_robot
from pincal.records import record

if TYPE_CHECKING:
    from pincal.calibration.job import Job


def _mesh_plan(robot: Robot, out: str | Path | None, meshes: MeshMode) -> MeshPlan:
    """The calibrated URDF's meshes at ``out`` (:mod:`pincal.io.mesh_files`), worked out before the fit."""
    if out is None:
        return MeshPlan({})
    return plan_meshes(source_text(robot), robot.source.parent if robot.source is not None else None, out, meshes)


def _checked_outputs(robot: Robot, out: str | Path | None, report: str | Path | None, meshes: MeshMode,
                     inputs: list[str | Path], names: tuple[str, str], keywords: bool) -> tuple[MeshPlan, Path | None]:
    """The mesh plan and the corrections file of a calibration's outputs, every output checked before the fit (none
    over an input, parents created); ``names`` name the URDF and report outputs in messages: the library's keywords
    (with ``keywords``: the error's ``option`` field names them) or a job file's keys."""
    beside = corrections_path(out) if out else None
    plan = _mesh_plan(robot, out, meshes)
    outputs: list[tuple[str, str | Path]] = [
        (what, path) for what, path in ((names[0], out), (names[1], report),
                                        (f"{names[0]} (its corrections file)", beside)) if path]
    outputs += [("meshes='copy'" if keywords else "--meshes copy", dest) for _, dest in plan.copies]
    check_outputs(outputs, [*robot_files(robot), *inputs, *(f for f, _ in plan.copies)], keywords=keywords)
    return plan, beside


def writes_urdf(report: CalibrationReport, force: bool) -> bool:
    """Whether a calibration with ``report`` gets its calibrated URDF (and the corrections file and meshes beside it)
    written: not for a fit that explains nothing (residuals beyond 1000 × σ), unless ``force``."""
    return force or not report.explains_nothing


def _written(cal: Calibration, robot: Robot, provenance: Provenance, out: str | Path | None,
             report: str | Path | None, beside: Path | None, plan: MeshPlan, force: bool) -> Calibration:
    """``cal`` with its provenance, its outputs written, all or none: the calibrated URDF (its mesh names for where it
    lands), the report, the corrections file beside the URDF when the URDF cannot hold every estimate, and the mesh
    copies; of a fit that explains nothing, the report alone (unless ``force``: :func:`writes_urdf`)."""
    texts: list[tuple[str | Path, str | bytes]] = []
    named = None
    if not writes_urdf(cal.report, force):
        out = beside = None
    if cal.corrections is not None and beside is not None:  # what the URDF cannot hold goes beside it
        text = json_text({**corrections_dict(cal.corrections, robot, beside.parent),
                          "provenance": provenance.as_dict(beside.parent)})
        texts.append((beside, text))
        named = (beside.name, hashlib.sha256(text.encode("utf-8")).hexdigest())
    if out:
        provenance = replace(provenance, fitted_range=cal.report.fitted_range)
        cal.urdf_text = with_provenance(cal.urdf_text, provenance, Path(out).parent, named)
        texts += [(out, plan.text(cal.urdf_text)), *plan.files()]
    if report:
        cal.report = replace(cal.report, provenance=provenance.record(Path(report).parent))
        texts.append((report, cal.report.to_json()))
    write_texts(texts)
    return cal


def write_recorded(cal: Calibration, robot_given: str, options: CalibrationOptions, data_path: Path, out: Path,
                   report: Path) -> None:
    """Write ``cal`` (a calibration of the robot ``robot_given``, a name or a URDF path, on the data file ``data_path``,
    with ``options``) as the calibrated URDF ``out`` and the report ``report``, with the provenance
    :func:`calibrate_files` records (``cal`` takes the report's): what ``pincal demo`` writes, so that ``check`` and
    ``compensate`` find its robot and data."""
    provenance = Provenance(robot_source(robot_given, cal.problem.robot), [file_source(data_path)],
                            options_dict(options), fitted_range=cal.report.fitted_range)
    cal.report = replace(cal.report, provenance=provenance.record(report.parent))
    write_texts([(out, with_provenance(cal.urdf_text, provenance, out.parent)), (report, cal.report.to_json())])


def calibrate_files(robot_path: str, data_path: str, out_urdf: str | None, report_path: str | None,
                    meshes: MeshMode = "keep", options: CalibrationOptions | None = None,
                    progress: bool = False) -> Calibration:
    """:func:`calibrate` from files with ``options`` (default: every default): the outputs are checked before the fit
    (never over an input, parents created) and each is written whole or not at all; ``meshes`` says what the
    calibrated URDF's meshes become (:mod:`pincal.io.mesh_files`); ``progress`` as for :func:`calibrate`."""
    options = CalibrationOptions() if options is None else options
    validation.instance("options", options, CalibrationOptions, "CalibrationOptions or None")
    robot = load_robot(robot_path)
    plan, beside = _checked_outputs(robot, out_urdf, report_path, meshes, [data_path], ("out_urdf", "report_path"),
                                    keywords=True)
    cal = calibrate(robot, read_robot_dataset(data_path, robot), options, progress=progress)
    provenance = Provenance(robot_source(robot_path, robot), [file_source(data_path)], options_dict(options))
    return _written(cal, robot, provenance, out_urdf, report_path, beside, plan, options.force)


def calibrate_job(job: Job, meshes: MeshMode = "keep", progress: bool = False) -> Calibration:
    """:func:`calibrate` as a job file says (:mod:`pincal.calibration.job`): its robot, its data read into SI units, its
    options; the outputs are checked before the fit (never over an input, the job file included) and each is written
    whole or not at all; ``meshes`` as for :func:`calibrate_files`; ``progress`` as for :func:`calibrate`."""
    from pincal.calibration.job import Job, load_job_robot  # here: a calibration from a robot and a CSV reads no job
    from pincal.calibration.job_data import job_dataset

    validation.instance("job", job, Job, "a Job (pincal.calibration.job.read_job)")

    options = job.options.calibration  # errors worded as each option was given: the command line or the job file
    robot = load_job_robot(job)
    payload = options.payload
    if payload is not None and job.options.source("payload") == job.path:  # the job's own: name the file
        try:
            payload.check(robot)
        except NotFoundError as exc:  # the same culprit, the job file named
            raise NotFoundError(f"{job.path}: {exc}", exc.kind, exc.name, exc.choices) from None
    plan, beside = _checked_outputs(robot, job.out, job.report, meshes, [job.path, *job.files], ("out", "report"),
                                    keywords=False)
    cal = calibrate(robot, job_dataset(job, robot), options, progress=progress)
    provenance = Provenance(robot_source(str(job.robot), robot), [file_source(p) for p in (job.path, *job.files)],
                            options_dict(options))
    return _written(cal, robot, provenance, job.out, job.report, beside, plan, options.force)


#: A file named so is a job file (docs/job_file.md): ``pincal calibrate JOB.toml``.
JOB_SUFFIX = ".toml"


@record(frozen=True)
class Inputs:
    """What a command calibrates: the robot, the dataset (in SI units), the options, the files read, and the robot
    as the command or the job file named it."""

    robot: Robot
    dataset: Dataset
    options: CalibrationOptions
    files: list[Path]
    robot_given: str = ""


def read_inputs(command: str, robot_or_job: str, data: str | None, options: GivenOptions | None = None) -> Inputs:
    """The robot and dataset of ``pincal COMMAND ROBOT DATA`` or ``pincal COMMAND JOB.toml`` (its robot, its data
    read into SI units, its options with ``options``, those given and where, over them), the options checked.

    Raises:
        PincalError: a job file with DATA, or a robot without; an option the job file or the command line cannot
            take (naming which).
    """
    options = GivenOptions() if options is None else options
    if robot_or_job.endswith(JOB_SUFFIX):
        from pincal.calibration.job import load_job_robot, read_job  # here: a robot and a CSV read no job
        from pincal.calibration.job_data import job_dataset

        if data is not None:
            raise PincalError(f"{command}: '{robot_or_job}' is a job file, which names its own data; give no DATA "
                              f"(got '{data}'), or a robot: pincal {command} ROBOT DATA")
        if options.value("markers", "each") != "each":
            raise PincalError(f"{command}: markers='cluster' applies to a dataset named on the command line, not "
                              "yet to a job file", option="markers")
        job = read_job(robot_or_job).overridden(options=options.without("markers"))
        given = job.options.calibration
        robot = load_job_robot(job)
        return Inputs(robot, job_dataset(job, robot), given, [job.path, *job.files], str(job.robot))
    if data is None:
        raise PincalError(f"{command}: DATA is missing: give pincal {command} ROBOT DATA.csv, or a job file "
                          f"JOB{JOB_SUFFIX} (docs/job_file.md); got only '{robot_or_job}'")
    given = options.calibration
    robot = load_robot(robot_or_job)
    return Inputs(robot, read_robot_dataset(data, robot), given, [Path(data)], robot_or_job)
