"""Scale-out: a fleet of Delta calibrations serially, in a process pool, and on a local Dask cluster.

Run: ``python benchmarks/bench_scaleout.py [--robots 8]``. Prints wall time per mode and the speed-up
against serial, measured side by side in one run (2 workers on a 2-core machine).
"""

from __future__ import annotations

import argparse
import concurrent.futures
import tempfile
import time
from pathlib import Path

import pincal
from pincal.calibration.campaign import simulate
from pincal.fleet import calibrate_fleet, jobs_from_directory
from pincal.io.dataset import write_dataset


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--robots", type=int, default=8)
    parser.add_argument("--samples", type=int, default=60)
    parser.add_argument("--workers", type=int, default=2)
    args = parser.parse_args()
    robot = pincal.load_robot("delta")
    with tempfile.TemporaryDirectory() as tmp:
        data = Path(tmp) / "data"
        data.mkdir()
        for k in range(args.robots):
            sim = simulate(robot, ["position"], args.samples, 20, perturb=1e-3, noise=1e-5, seed=k,
                           parameter_spec=["model24i"])
            write_dataset(sim.dataset, data / f"delta_{k:02d}.csv")
        jobs = jobs_from_directory("delta", data, Path(tmp) / "out")  # all candidate parameters (105)
        times = {}
        start = time.perf_counter()
        calibrate_fleet(jobs, workers=1)
        times["serial"] = time.perf_counter() - start
        start = time.perf_counter()
        with concurrent.futures.ProcessPoolExecutor(max_workers=args.workers) as pool:
            calibrate_fleet(jobs, executor=pool)
        times[f"process pool ({args.workers})"] = time.perf_counter() - start
        from dask.distributed import Client, LocalCluster

        with LocalCluster(n_workers=args.workers, threads_per_worker=1, dashboard_address=None) as cluster, \
                Client(cluster) as client:
            client.run(lambda: __import__("pincal"))  # warm the workers' imports, as a long-lived cluster would
            start = time.perf_counter()
            calibrate_fleet(jobs, executor=client.get_executor())
            times[f"Dask LocalCluster ({args.workers})"] = time.perf_counter() - start
    print(f"fleet of {args.robots} Delta robots, {args.samples} postures each, all candidate parameters\n")
    print("| mode | wall time [s] | speed-up |\n|---|---|---|")
    for mode, t in times.items():
        print(f"| {mode} | {t:.2f} | {times['serial'] / t:.2f}× |")


if __name__ == "__main__":
    main()
