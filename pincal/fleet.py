"""Calibrating a fleet: many robots, one dataset each, through any ``concurrent.futures.Executor``.

The default is a process pool (one worker per core). For a cluster, pass Dask's executor::

    from dask.distributed import Client
    with Client("scheduler-address") as client:
        results = calibrate_fleet(jobs, executor=client.get_executor())

Each job is a robot (URDF path or name) and a measurement CSV; outputs go to the job's own paths.
Results come back in the jobs' order; a job that fails is reported, not dropped, and does not stop
the others.
"""

from __future__ import annotations

import concurrent.futures
import os
from collections.abc import Sequence
from dataclasses import dataclass, field
from pathlib import Path
from typing import Any

from pincal.errors import PincalError
from pincal.io.files import make_directory


@dataclass(frozen=True)
class FleetJob:
    """One robot of the fleet.

    Attributes:
        name: A label for reports (e.g. the robot's serial number).
        robot: URDF path or known robot name (the nominal model).
        data: Measurement CSV.
        out_urdf: Where to write the calibrated URDF (optional).
        report: Where to write the report JSON (optional).
        options: Keyword options of :func:`pincal.workflow.calibrate` (parameter_spec, solver, loss, ...).
    """

    name: str
    robot: str
    data: str
    out_urdf: str | None = None
    report: str | None = None
    options: dict[str, Any] = field(default_factory=dict)


@dataclass(frozen=True)
class FleetResult:
    """The outcome of one job: the report dict, or the error that stopped it."""

    name: str
    report: dict[str, Any] | None
    error: str | None

    @property
    def ok(self) -> bool:
        """True when no error stopped the job (it has a report)."""
        return self.error is None


def run_job(job: FleetJob) -> FleetResult:
    """Calibrate one robot (runs in a worker process; a top-level function so it pickles)."""
    from pincal.workflow import calibrate_files

    try:
        cal = calibrate_files(job.robot, job.data, job.out_urdf, job.report, **job.options)
    except PincalError as exc:
        return FleetResult(job.name, None, f"{type(exc).__name__}: {exc}")
    return FleetResult(job.name, cal.report, None)


def calibrate_fleet(jobs: Sequence[FleetJob], executor: concurrent.futures.Executor | None = None,
                    workers: int | None = None) -> list[FleetResult]:
    """Calibrate every job; results in the jobs' order.

    Args:
        jobs: The robots and their data.
        executor: Any ``concurrent.futures.Executor`` (a Dask client's ``get_executor()`` included);
            by default a process pool of ``workers`` processes.
        workers: Processes of the default pool (default: the machine's cores); 1 runs serially in-process.
    """
    if executor is not None:
        return list(executor.map(run_job, jobs))
    count = workers or os.cpu_count() or 1
    if count == 1 or len(jobs) <= 1:
        return [run_job(job) for job in jobs]
    with concurrent.futures.ProcessPoolExecutor(max_workers=count) as pool:
        return list(pool.map(run_job, jobs))


def jobs_from_directory(robot: str, directory: str | Path, out: str | Path, **options: Any) -> list[FleetJob]:
    """One job per ``*.csv`` in ``directory`` (sorted), all on the same nominal robot; outputs named
    after each CSV in ``out``."""
    out_dir = make_directory(out, "--out")
    return [FleetJob(p.stem, robot, str(p), str(out_dir / f"{p.stem}.urdf"), str(out_dir / f"{p.stem}.json"), options)
            for p in sorted(Path(directory).glob("*.csv"))]
