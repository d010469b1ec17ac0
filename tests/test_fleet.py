"""Fleet calibration through executors: serial, a process pool and a local Dask cluster agree."""

from __future__ import annotations

import concurrent.futures
from pathlib import Path

import pytest
from conftest import run_pincal
from dask.distributed import Client, LocalCluster

import pincal
from pincal.calibration.campaign import simulate
from pincal.calibration.options import GivenOptions
from pincal.fleet import FleetJob, calibrate_fleet, jobs_from_directory
from pincal.io.dataset import write_dataset


@pytest.fixture(scope="module")
def fleet(tmp_path_factory: pytest.TempPathFactory) -> tuple[Path, list[FleetJob]]:
    root = tmp_path_factory.mktemp("fleet")
    robot = pincal.load_robot("delta")
    data = root / "data"
    data.mkdir()
    for k in range(4):  # four Delta robots, each with its own errors
        sim = simulate(robot, ["position"], 25, 5, perturb=1e-3, noise=1e-5, seed=100 + k, parameter_spec=["model24i"])
        write_dataset(sim.dataset, data / f"delta_{k:02d}.csv")
    (data / "delta_99.csv").write_text("arm_1_joint,arm_2_joint\n0,0\n0.1,0\n")  # a broken file in the lot
    return root, jobs_from_directory("delta", data, root / "out",
                                     GivenOptions.of({"parameter_spec": ["model24i"]}))


def _reports(results: list) -> list:
    return [(r.name, r.error, None if r.report is None else r.report.to_json()) for r in results]


def test_fleet_serial_pool_and_dask_agree(fleet: tuple[Path, list[FleetJob]]) -> None:
    root, jobs = fleet
    serial = calibrate_fleet(jobs, workers=1)
    assert [r.name for r in serial] == ["delta_00", "delta_01", "delta_02", "delta_03", "delta_99"]
    assert all(r.ok for r in serial[:4]) and not serial[4].ok and "no measurement columns" in (serial[4].error or "")
    assert all(r.report is not None and r.report.test_rms_after < 0.1 * r.report.test_rms_before
               for r in serial[:4])
    assert (root / "out" / "delta_00.urdf").is_file() and (root / "out" / "delta_00.json").is_file()
    with concurrent.futures.ProcessPoolExecutor(max_workers=2) as pool:
        pooled = calibrate_fleet(jobs, executor=pool)
    assert _reports(pooled) == _reports(serial)
    with LocalCluster(n_workers=2, threads_per_worker=1, processes=True, dashboard_address=None) as cluster, \
            Client(cluster) as client:
        distributed = calibrate_fleet(jobs, executor=client.get_executor())
    assert _reports(distributed) == _reports(serial)


def test_the_fleet_command_accounts_for_each_robot(fleet: tuple[Path, list[FleetJob]], tmp_path: Path) -> None:
    """Held-out errors, the samples fitted, dropped and down-weighted, and the verdict, per robot; a broken
    file is named and makes the run exit 1."""
    root, _ = fleet
    done = run_pincal("fleet", "delta", str(root / "data"), "--out", str(tmp_path / "out"), "--parameters",
                      "model24i", "--workers", "2")
    assert done.returncode == 1, done.stderr  # delta_99.csv is broken
    lines = done.stdout.splitlines()
    assert lines[0].split() == ["robot", "held", "out", "before", "held", "out", "after", "fitted", "dropped",
                                "down-weighted", "status"]
    rows = {line.split()[0]: line for line in lines[1:] if line.startswith("delta_")}
    for k in range(4):
        cells = rows[f"delta_{k:02d}"].split()
        assert cells[2] == "mm" and cells[4] == "mm" and float(cells[3]) < 0.1 * float(cells[1])
        assert cells[5:8] == ["25", "0", "0"] and cells[8] == "converged"
    assert "failed: DataError" in rows["delta_99"]
