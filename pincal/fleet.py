"""Calibrating a fleet: many robots, one dataset each, through any ``concurrent.futures.Executor``.

The default is a process pool (one worker per core). For a cluster, pass Dask's executor::

    from dask.distributed import Client
    with Client("scheduler-address") as client:
        results = calibrate_fleet(jobs, executor=client.get_executor())

Each job is a robot (URDF path or name) and a measurement CSV, or a job file (docs/job_file.md), with the options of
:class:`~pincal.calibration.options.CalibrationOptions`; outputs go to the job's own paths.
Results come back in the jobs' order; a job that fails is reported, not dropped, and does not stop
the others.
"""

from __future__ import annotations

import concurrent.futures
import os
from collections.abc import Iterable, Sequence
from dataclasses import field
from pathlib import Path

from pincal.calibration.options import GivenOptions
from pincal.calibration.report import CalibrationReport
from pincal.errors import PincalError
from pincal.io.files import check_directory
from pincal.progress import Progress
from pincal.records import record

#: A file named so is a job file (docs/job_file.md).
JOB_SUFFIX = ".toml"


@record(frozen=True)
class FleetJob:
    """One robot of the fleet.

    Attributes:
        name: A label for reports (e.g. the robot's serial number).
        robot: URDF path or known robot name (the nominal model); ignored for a job file.
        data: Measurement CSV, or a job file (``.toml``) naming its own robot and data.
        out_urdf: Where to write the calibrated URDF (optional).
        report: Where to write the report JSON (optional).
        options: Options of :func:`pincal.calibration.calibrate` given for this robot, each at its source
            (:class:`~pincal.calibration.options.GivenOptions`); over a job file's own.
    """

    name: str
    robot: str
    data: str
    out_urdf: str | None = None
    report: str | None = None
    options: GivenOptions = field(default_factory=GivenOptions)


@record(frozen=True)
class FleetResult:
    """The outcome of one job: the report, or the error that stopped it."""

    name: str
    report: CalibrationReport | None
    error: str | None

    @property
    def ok(self) -> bool:
        """True when no error stopped the job (it has a report)."""
        return self.error is None


def run_job(job: FleetJob) -> FleetResult:
    """Calibrate one robot (runs in a worker process; a top-level function so it pickles)."""
    from pincal.calibration.from_files import calibrate_files, calibrate_job
    from pincal.calibration.job import read_job
    from pincal.calibration.on_demand import pending_fields
    try:
        if job.data.endswith(JOB_SUFFIX):
            cal = calibrate_job(read_job(job.data).overridden(job.out_urdf, job.report, job.options))
        else:
            cal = calibrate_files(job.robot, job.data, job.out_urdf, job.report, options=job.options.calibration)
        for name in pending_fields(cal.report):  # computed here: the result kept holds no fit alive
            getattr(cal.report, name)
    except PincalError as exc:
        return FleetResult(job.name, None, f"{type(exc).__name__}: {exc}")
    return FleetResult(job.name, cal.report, None)


def calibrate_fleet(jobs: Sequence[FleetJob], executor: concurrent.futures.Executor | None = None,
                    workers: int | None = None, progress: bool = False) -> list[FleetResult]:
    """Calibrate every job; results in the jobs' order.

    Args:
        jobs: The robots and their data.
        executor: Any ``concurrent.futures.Executor`` (a Dask client's ``get_executor()`` included);
            by default a process pool of ``workers`` processes.
        workers: Processes of the default pool (default: the machine's cores); 1 runs serially in-process.
        progress: A bar on stderr (when it is a terminal), one tick per robot calibrated.
    """
    with Progress("robots calibrated", len(jobs), quiet=not progress) as bar:
        if executor is not None:
            return _gathered(executor.map(run_job, jobs), bar)
        count = workers or os.cpu_count() or 1
        if count == 1 or len(jobs) <= 1:
            return _gathered(map(run_job, jobs), bar)
        with concurrent.futures.ProcessPoolExecutor(max_workers=count) as pool:
            return _gathered(pool.map(run_job, jobs), bar)


def _gathered(results: Iterable[FleetResult], bar: Progress) -> list[FleetResult]:
    """``results`` in order, the bar advanced as each arrives."""
    out = []
    for result in results:
        out.append(result)
        bar.advance()
    return out


def jobs_from_directory(robot: str, directory: str | Path, out: str | Path,
                        options: GivenOptions | None = None) -> list[FleetJob]:
    """One job per ``*.csv`` in ``directory`` on the nominal ``robot``, and one per job file ``*.toml`` (its own robot
    and data), sorted by name; outputs named after each file in ``out``; ``options`` (those given, each at its
    source: :class:`~pincal.calibration.options.GivenOptions`) for every job."""
    options = GivenOptions() if options is None else options
    out_dir = check_directory(out, "out", option="out")
    files = sorted([*Path(directory).glob("*.csv"), *Path(directory).glob(f"*{JOB_SUFFIX}")])
    return [FleetJob(p.stem, robot, str(p), str(out_dir / f"{p.stem}.urdf"), str(out_dir / f"{p.stem}.json"), options)
            for p in files]
