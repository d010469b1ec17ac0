"""``pincal compensate``'s work on 2000 targets, today's code beside an earlier revision's, in one run (issue 36: "2000
targets on the Delta: 12.5 CPU-s, no progress, no cap").

Run: ``python benchmarks/bench_compensate.py`` (``--before REV``, default ``10551e0``: main when issue 36 was filed;
``--repeats K``, default 5; ``--targets N``, default 2000; ``--unreachable N``, default 100: the worst case, targets out
of reach, which try every start to the end). ``pincal/`` as of REV is exported (``git archive``) to a temporary folder;
two worker processes, one importing each copy, compensate the same targets files in turns (one run each, then the
other), each timing its own process CPU time with single-threaded BLAS: ``compensate(load_model(ROBOT),
read_targets(FILE))``, the model and the targets read once, outside the timing.

The targets: where each nominal robot puts its measured frame at random postures within its joint limits (seed 5),
written once by today's code: the Delta's ``end_effector`` and the UR10's ``tool0`` by a point, the UR10's by a pose;
the unreachable ones are the Delta's moved 2 m aside. Printed: medians and bests per case, the ratio of the medians,
the targets each reached, and today's CPU time per target.
"""

from __future__ import annotations

import argparse
import csv
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
ISSUE_36_FILED = "10551e0"  # main when issue 36 was filed
WORKER = r"""
import sys, time
import pincal
from pincal.calibration.compensate import compensate, load_model
from pincal.io.targets import read_targets

models = {}
print(pincal.__file__, flush=True)
for line in sys.stdin:
    robot, path = line.split()
    model = models.setdefault(robot, load_model(robot))
    targets = read_targets(path)
    start = time.process_time()
    result = compensate(model, targets)
    seconds = time.process_time() - start
    print(seconds, sum(status == "ok" for status in result.statuses), flush=True)
"""


def export(revision: str, into: Path) -> None:
    """``pincal/`` as of ``revision`` into the folder ``into``."""
    archive = subprocess.run(["git", "-C", str(ROOT), "archive", revision, "pincal"], check=True,
                             capture_output=True).stdout
    subprocess.run(["tar", "-x", "-C", str(into)], input=archive, check=True)


def worker(source: Path, folder: Path) -> subprocess.Popen[str]:
    """A process running compensate with the ``pincal`` under ``source``, one run per line it reads."""
    return start_worker(WORKER, source, folder)


def one_run(process: subprocess.Popen[str], robot: str, path: Path) -> tuple[float, int]:
    """(CPU seconds, targets reached) of one compensate in ``process``."""
    assert process.stdin is not None and process.stdout is not None
    process.stdin.write(f"{robot} {path}\n")
    process.stdin.flush()
    seconds, reached = process.stdout.readline().split()
    return float(seconds), int(reached)


def write_targets(folder: Path, robot_name: str, frame: str, kind: str, n: int, offset: float = 0.0) -> Path:
    """A targets file of ``n`` targets of ``frame`` (``kind``: position or pose) at random postures of the nominal
    robot, moved by ``offset`` [m] along x."""
    import pinocchio as pin

    import pincal
    from pincal.study.simulation import random_actuated

    robot = pincal.load_robot(robot_name)
    _, q = random_actuated(robot, n, np.random.default_rng(5))
    components = ["x", "y", "z"] + (["qx", "qy", "qz", "qw"] if kind == "pose" else [])
    path = folder / f"{robot_name}_{kind}_{n}{'_far' if offset else ''}.csv"
    with path.open("w", newline="", encoding="utf-8") as stream:
        writer = csv.writer(stream)
        writer.writerow(["sample", *(f"{kind}:{frame}:{c}" for c in components)])
        for k, config in enumerate(q):
            m = robot.placement(config, frame)
            moved = m.translation + np.array([offset, 0.0, 0.0])
            row = np.concatenate([moved, pin.Quaternion(m.rotation).coeffs()])
            writer.writerow([f"t{k}", *map(repr, row[: len(components)].tolist())])
    return path


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--before", default=ISSUE_36_FILED, help=f"the earlier revision (default: {ISSUE_36_FILED})")
    parser.add_argument("--repeats", type=int, default=5, help="runs per revision and case (default: 5)")
    parser.add_argument("--targets", type=int, default=2000, help="targets per case (default: 2000)")
    parser.add_argument("--unreachable", type=int, default=100,
                        help="unreachable Delta targets (default: 100; 0: none)")
    args = parser.parse_args()

    sys.path.insert(0, str(ROOT))
    import pincal

    with tempfile.TemporaryDirectory() as scratch:
        folder = Path(scratch)
        cases = [(f"Delta, {args.targets} positions", "delta", args.targets,
                  write_targets(folder, "delta", "end_effector", "position", args.targets)),
                 (f"UR10, {args.targets} positions", "ur10", args.targets,
                  write_targets(folder, "ur10", "tool0", "position", args.targets)),
                 (f"UR10, {args.targets} poses", "ur10", args.targets,
                  write_targets(folder, "ur10", "tool0", "pose", args.targets))]
        if args.unreachable:
            cases.append((f"Delta, {args.unreachable} positions 2 m out of reach", "delta", args.unreachable,
                          write_targets(folder, "delta", "end_effector", "position", args.unreachable, offset=2.0)))
        old = folder / "before"
        old.mkdir()
        export(args.before, old)
        revision = subprocess.run(["git", "-C", str(ROOT), "rev-parse", "--short", "HEAD"], check=True,
                                  capture_output=True, text=True).stdout.strip()
        dirty = subprocess.run(["git", "-C", str(ROOT), "status", "--porcelain", "pincal"], check=True,
                               capture_output=True, text=True).stdout.strip()
        names = {"before": args.before, "today": revision + (" + uncommitted changes" if dirty else "")}
        workers = {"before": worker(old, folder), "today": worker(ROOT, folder)}
        for process in workers.values():  # warm: imports, caches
            one_run(process, "delta", cases[0][3])
        times: dict[tuple[str, str], list[float]] = {}
        reached: dict[tuple[str, str], int] = {}
        for label, robot, _, path in cases:
            for _ in range(args.repeats):
                for name, process in workers.items():
                    seconds, reached[label, name] = one_run(process, robot, path)
                    times.setdefault((label, name), []).append(seconds)
        stop_workers(workers.values())

    print(f"pincal today {pincal.__version__}, numpy {np.__version__}, Python {platform.python_version()}, "
          f"{platform.machine()}; before = {names['before']}, today = {names['today']}; {args.repeats} runs each, in "
          "turns; process CPU time, one BLAS thread\n")
    print("| targets | before: median (best) [s] | today: median (best) [s] | before / today | reached before, today "
          "| today per target [ms] |")
    print("|---|---|---|---|---|---|")
    for label, _, n, _ in cases:
        before, today = times[label, "before"], times[label, "today"]
        print(f"| {label} | {statistics.median(before):.2f} ({min(before):.2f}) | {statistics.median(today):.2f} "
              f"({min(today):.2f}) | {statistics.median(before) / statistics.median(today):.1f}× | "
              f"{reached[label, 'before']}, {reached[label, 'today']} | {1e3 * statistics.median(today) / n:.2f} |")


if __name__ == "__main__":
    main()
