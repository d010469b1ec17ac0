"""A calibration from files: the outputs checked before any work (never over an input), then written whole or not
at all — from a robot and a data file (:func:`calibrate_files`) or from a job file (:func:`calibrate_job`)."""

from __future__ import annotations

from pathlib import Path
from typing import Any

from pincal.calibration.job import Job, load_job_robot
from pincal.calibration.job_data import job_dataset
from pincal.calibration.options import OptionSource, check_cv_seed
from pincal.calibration.pipeline import Calibration, calibrate
from pincal.calibration.samples import read_robot_dataset
from pincal.errors import NotFoundError
from pincal.io.calibrated_urdf import source_text
from pincal.io.corrections_file import corrections_dict, corrections_path
from pincal.io.files import check_outputs, write_texts
from pincal.io.mesh_files import MeshMode, MeshPlan, plan_meshes
from pincal.io.report_data import json_text
from pincal.model.robot import Robot, load_robot


def _mesh_plan(robot: Robot, out: str | Path | None, meshes: MeshMode) -> MeshPlan:
    """The calibrated URDF's meshes at ``out`` (:mod:`pincal.io.mesh_files`), worked out before the fit."""
    if out is None:
        return MeshPlan({})
    return plan_meshes(source_text(robot), robot.source.parent if robot.source is not None else None, out, meshes)


def _outputs(cal: Calibration, out: str | Path | None, report: str | Path | None, beside: str | Path | None,
             plan: MeshPlan, robot: Robot) -> list[tuple[str | Path, str | bytes]]:
    """Every file of a calibration: the URDF (its mesh names for where it lands), the report, the corrections file
    and the mesh copies."""
    texts: list[tuple[str | Path | None, str | bytes]] = [
        (out, plan.text(cal.urdf_text)), (report, cal.report.to_json() if report else "")]
    if cal.corrections is not None:  # what the URDF cannot hold goes beside it
        texts.append((beside, json_text(corrections_dict(cal.corrections, robot))))
    if out:
        texts += plan.files()
    return [(path, text) for path, text in texts if path]


def calibrate_files(robot_path: str, data_path: str, out_urdf: str | None, report_path: str | None,
                    meshes: MeshMode = "keep", **options: Any) -> Calibration:
    """:func:`calibrate` from files: the outputs are checked before the fit (never over an input, parents
    created) and each is written whole or not at all; ``meshes`` says what the calibrated URDF's meshes become
    (:mod:`pincal.io.mesh_files`)."""
    robot = load_robot(robot_path)
    beside = str(corrections_path(out_urdf)) if out_urdf else None
    plan = _mesh_plan(robot, out_urdf, meshes)
    outputs: list[tuple[str, str | Path]] = [
        (what, path) for what, path in (("--out", out_urdf), ("--report", report_path),
                                        ("--out (its corrections file)", beside)) if path]
    outputs += [("--meshes copy", dest) for _, dest in plan.copies]
    check_outputs(outputs, [p for p in (robot.source, data_path, *(f for f, _ in plan.copies)) if p is not None])
    dataset = read_robot_dataset(data_path, robot)
    cal = calibrate(robot, dataset, **options)
    write_texts(_outputs(cal, out_urdf, report_path, beside, plan, robot))  # all or none
    return cal


def calibrate_job(job: Job, meshes: MeshMode = "keep") -> Calibration:
    """:func:`calibrate` as a job file says (:mod:`pincal.calibration.job`): its robot, its data read into SI units, its
    options; the outputs are checked before the fit (never over an input, the job file included) and each is written
    whole or not at all; ``meshes`` as for :func:`calibrate_files`."""
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
    plan = _mesh_plan(robot, job.out, meshes)
    outputs = [(what, path) for what, path in (("out", job.out), ("report", job.report),
                                               ("out (its corrections file)", beside)) if path]
    outputs += [("--meshes copy", dest) for _, dest in plan.copies]
    check_outputs(outputs, [p for p in (robot.source, job.path, *job.files, *(f for f, _ in plan.copies))
                            if p is not None])
    cal = calibrate(robot, job_dataset(job, robot), **job.options)
    write_texts(_outputs(cal, job.out, job.report, beside, plan, robot))  # all or none
    return cal
