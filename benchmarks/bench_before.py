"""Today's Delta calibration beside an earlier revision's, in one run (issue 14: "≤ 30 ms, today 77–93 ms").

Run: ``python benchmarks/bench_before.py`` (``--before REV``, default ``b8a351c``: main when issue 14 was filed;
``--repeats K``). The VM's speed varies by 2× from day to day, so a time measured on another day says little; this
script measures the ratio instead. ``pincal/`` as of REV is exported (``git archive``) to a temporary folder, and two
worker processes, one importing each copy, fit the same data in turns (one fit each, then the other), each timing
its own process CPU time with single-threaded BLAS.

The data: the Delta of ``bench_loops.py`` (Model 24 errors of 1 mm / 1 mrad, 60 laser-tracker positions with 10 µm
noise), simulated once by today's code and handed to both workers as arrays; each builds its problem with its own
code (``measurements_for``, ``observations_from``, ``choose_parameters``, ``CalibrationProblem``) and runs
``identify`` with default settings, the problem built anew each time. Printed: medians and bests, the ratio of the
medians, the largest gap between the two estimates, and what the ratio makes of the issue's own figure for REV.
"""

from __future__ import annotations

import argparse
import platform
import statistics
import subprocess
import sys
import tempfile
from pathlib import Path

import numpy as np

sys.path.insert(0, str(Path(__file__).resolve().parent))
from workers import start_worker, stop_workers

ROOT = Path(__file__).resolve().parent.parent
ISSUE_14_FILED = "b8a351c"  # main when issue 14 was filed
WORKER = r"""
import sys, time
import numpy as np
import pincal
from pincal.identification.parameters import choose_parameters
from pincal.identification.problem import CalibrationProblem
from pincal.identification.solver import identify
from pincal.io.adapters import measurements_for, observations_from

saved = np.load(sys.argv[1])
names, keys = [str(s) for s in saved["joint_names"]], [str(s) for s in saved["keys"]]
readings = {key: saved[f"m{i}"] for i, key in enumerate(keys)}
robot = pincal.load_robot("delta")
models = measurements_for(robot, keys, names, None)
pset = choose_parameters(robot, models, ["model24"])
print(pincal.__file__, flush=True)
for line in sys.stdin:
    start = time.process_time()
    problem = CalibrationProblem(robot, pset, models,
                                 observations_from(robot, names, saved["joints"], readings, models))
    result = identify(problem)
    seconds = time.process_time() - start
    print(seconds, result.iterations, " ".join(repr(float(v)) for v in result.x), flush=True)
"""


def export(revision: str, into: Path) -> None:
    """``pincal/`` as of ``revision`` into the folder ``into``."""
    archive = subprocess.run(["git", "-C", str(ROOT), "archive", revision, "pincal"], check=True,
                             capture_output=True).stdout
    subprocess.run(["tar", "-x", "-C", str(into)], input=archive, check=True)


def worker(source: Path, data: Path) -> subprocess.Popen[str]:
    """A process fitting ``data`` with the ``pincal`` under ``source``, one fit per line it reads."""
    return start_worker(WORKER, source, data.parent, str(data))


def one_fit(process: subprocess.Popen[str]) -> tuple[float, int, np.ndarray]:
    """(CPU seconds, LM iterations, estimate) of one fit in ``process``."""
    assert process.stdin is not None and process.stdout is not None
    process.stdin.write("fit\n")
    process.stdin.flush()
    seconds, iterations, *x = process.stdout.readline().split()
    return float(seconds), int(iterations), np.array([float(v) for v in x])


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--before", default=ISSUE_14_FILED, help=f"the earlier revision (default: {ISSUE_14_FILED})")
    parser.add_argument("--repeats", type=int, default=15, help="fits per revision (default: 15)")
    args = parser.parse_args()

    sys.path.insert(0, str(ROOT))
    import pincal
    from pincal.calibration.campaign import simulate

    robot = pincal.load_robot("delta")
    sim = simulate(robot, ["position"], 60, 0, perturb=1e-3, noise=1e-5, seed=1, parameter_spec=["model24"])
    ds = sim.dataset
    keys = list(ds.measurements)
    with tempfile.TemporaryDirectory() as folder:
        data = Path(folder) / "delta.npz"
        np.savez(data, joint_names=np.array(ds.joint_names), keys=np.array(keys), joints=ds.joints,
                 **{f"m{i}": ds.measurements[key] for i, key in enumerate(keys)})
        old = Path(folder) / "before"
        old.mkdir()
        export(args.before, old)
        revision = subprocess.run(["git", "-C", str(ROOT), "rev-parse", "--short", "HEAD"], check=True,
                                  capture_output=True, text=True).stdout.strip()
        dirty = subprocess.run(["git", "-C", str(ROOT), "status", "--porcelain", "pincal"], check=True,
                               capture_output=True, text=True).stdout.strip()
        names = {"before": args.before, "today": revision + (" + uncommitted changes" if dirty else "")}
        workers = {"before": worker(old, data), "today": worker(ROOT, data)}
        for process in workers.values():  # warm: imports, caches
            one_fit(process)
        times: dict[str, list[float]] = {name: [] for name in workers}
        last: dict[str, tuple[float, int, np.ndarray]] = {}
        for _ in range(args.repeats):
            for name, process in workers.items():
                last[name] = one_fit(process)
                times[name].append(last[name][0])
        stop_workers(workers.values())

    print(f"pincal today {pincal.__version__}, numpy {np.__version__}, Python {platform.python_version()}, "
          f"{platform.machine()}\n")
    print(f"### Delta, Model 24, 60 positions: calibration, {args.repeats} fits each, in turns\n")
    print("| code | median | best | LM iterations |")
    print("|---|---|---|---|")
    for name, code in names.items():
        print(f"| {name} ({code}) | {statistics.median(times[name]) * 1e3:.1f} ms | {min(times[name]) * 1e3:.1f} ms | "
              f"{last[name][1]} |")
    ratio = statistics.median(times["before"]) / statistics.median(times["today"])
    best = min(times["before"]) / min(times["today"])
    gap = float(np.abs(last["before"][2] - last["today"][2]).max()) if len(last["before"][2]) == len(
        last["today"][2]) else float("nan")
    print(f"\nbefore / today: {ratio:.2f}× (medians), {best:.2f}× (bests); largest gap between the estimates: "
          f"{gap:.1e} (m, rad)")
    if args.before == ISSUE_14_FILED:
        print(f"At this ratio, the issue's 77–93 ms for {args.before} would be {77 / ratio:.1f}–{93 / ratio:.1f} ms "
              "today (target: ≤ 30 ms, i.e. a ratio of at least 3.1×).")


if __name__ == "__main__":
    main()
