"""A calibration from files: the outputs checked before any work (never over an input), then written whole or not
at all — from a robot and a data file (:func:`calibrate_files`) or from a job file (:func:`calibrate_job`)."""

from __future__ import annotations

from dataclasses import replace
from pathlib import Path
from typing import Any

from pincal.calibration.job import Job, load_job_robot
from pincal.calibration.job_data import job_dataset
from pincal.calibration.options import OPTIONS, OptionSource, check_cv_seed
from pincal.calibration.pipeline import Calibration, calibrate, options_of
from pincal.calibration.provenance import Provenance, file_source, options_dict, robot_source, with_provenance
from pincal.calibration.samples import read_robot_dataset
from pincal.errors import NotFoundError
from pincal.io.corrections_file import corrections_dict, corrections_path
from pincal.io.files import check_outputs, json_text, write_texts
from pincal.model.robot import Robot, load_robot


def calibrate_files(robot_path: str, data_path: str, out_urdf: str | None, report_path: str | None,
                    **options: Any) -> Calibration:
    """:func:`calibrate` from files: the outputs are checked before the fit (never over an input, parents
    created) and each is written whole or not at all."""
    robot = load_robot(robot_path)
    beside = str(corrections_path(out_urdf)) if out_urdf else None
    outputs = [(what, path) for what, path in (("--out", out_urdf), ("--report", report_path),
                                               ("--out (its corrections file)", beside)) if path]
    check_outputs(outputs, [p for p in (robot.source, data_path) if p is not None])
    dataset = read_robot_dataset(data_path, robot)
    cal = calibrate(robot, dataset, **options)
    provenance = Provenance(robot_source(robot_path, robot), [file_source(data_path)],
                            options_dict(options_of(None, {k: v for k, v in options.items() if k in OPTIONS})))
    return _written(cal, robot, provenance, out_urdf, report_path, beside)


def _written(cal: Calibration, robot: Robot, provenance: Provenance, out_urdf: str | Path | None,
             report_path: str | Path | None, beside: str | Path | None) -> Calibration:
    """``cal`` with its provenance, its outputs written (all or none): the calibrated URDF, the report, and the
    corrections file beside the URDF when the URDF cannot hold every estimate."""
    texts: list[tuple[str | Path | None, str]] = []
    if out_urdf:
        cal.urdf_text = with_provenance(cal.urdf_text, provenance, Path(out_urdf).parent)
        texts.append((out_urdf, cal.urdf_text))
    if report_path:
        cal.report = replace(cal.report, provenance=provenance.as_dict(Path(report_path).parent))
        texts.append((report_path, cal.report.to_json()))
    if cal.corrections is not None and beside:  # what the URDF cannot hold goes beside it
        texts.append((beside, json_text(corrections_dict(cal.corrections, robot, Path(beside).parent))))
    write_texts([(path, text) for path, text in texts if path])
    return cal


def calibrate_job(job: Job) -> Calibration:
    """:func:`calibrate` as a job file says (:mod:`pincal.calibration.job`): its robot, its data read into SI units, its
    options; the outputs are checked before the fit (never over an input, the job file included) and each is written
    whole or not at all."""
    def source(option: str) -> OptionSource:  # the command line's value in place of the job's, or the job's own
        return "command line" if option in job.overrides else job.path

    check_cv_seed(job.options.get("cv"), job.options.get("cv_seed", 0), source("cv"), source("cv_seed"))
    robot = load_job_robot(job)
    payload = job.options.get("payload")
    if payload is not None and "payload" not in job.overrides:  # the job's own: name the file
        try:
            payload.check(robot)
        except NotFoundError as exc:  # the same culprit, the job file named
            raise NotFoundError(f"{job.path}: {exc}", exc.kind, exc.name, exc.choices) from None
    beside = corrections_path(job.out) if job.out else None
    outputs = [(what, path) for what, path in (("out", job.out), ("report", job.report),
                                               ("out (its corrections file)", beside)) if path]
    check_outputs(outputs, [p for p in (robot.source, job.path, *job.files) if p is not None])
    cal = calibrate(robot, job_dataset(job, robot), **job.options)
    provenance = Provenance(robot_source(str(job.robot), robot), [file_source(p) for p in (job.path, *job.files)],
                            options_dict(options_of(None, {k: v for k, v in job.options.items() if k in OPTIONS})))
    return _written(cal, robot, provenance, job.out, job.report, beside)
