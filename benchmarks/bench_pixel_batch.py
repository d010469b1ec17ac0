"""The pixel models' batch predictions beside an earlier revision's, in one run: a problem's evaluation (pixels and
their Jacobian) of an eye-in-hand campaign (``pixel``: a UR10's camera on ``tool0``) and of a camera on one chain
seeing a board on another (``cross_pixel``: TIAGo's head camera, the board in its gripper).

Run: ``python benchmarks/bench_pixel_batch.py`` (``--before REV``, default ``12634f7``: main before the two models
shared one helper for the camera's view; ``--repeats K``). ``pincal/`` as of REV is exported (``git archive``) to a
temporary folder; two worker processes, one importing each copy, simulate the same campaigns (40 images of a ChArUco
board of 35 corners, seed 1) and evaluate each problem at its start, 20 times per turn, in turns, each timing its own
process CPU time with single-threaded BLAS (each evaluation at a new estimate, none recalled). Printed: per campaign,
the median CPU time of one evaluation before and after, their ratio, and whether the two copies' residuals and
Jacobians are the same bytes at every turn.
"""

from __future__ import annotations

import argparse
import os
import platform
import statistics
import subprocess
import sys
import tempfile
from pathlib import Path

sys.path.insert(0, str(Path(__file__).resolve().parent))
from workers import start_worker, stop_workers

ROOT = Path(__file__).resolve().parent.parent
BEFORE = "12634f7"  # main before Pixel.view_batch
WORKER = r"""
import hashlib, sys, time
import pincal
from pincal.calibration.cross_campaign import simulate_cross_pixels
from pincal.calibration.pixel_campaign import simulate_pixels
from pincal.identification.problem import CalibrationProblem, Observations

sims = {"pixel": simulate_pixels(pincal.load_robot("ur10"), "tool0", 40, seed=1),
        "cross_pixel": simulate_cross_pixels(pincal.load_robot("tiago_no_hand"), "head_2_link", "arm_tool_link", 40,
                                             seed=1)}
problems = {}
for name, sim in sims.items():
    ds = sim.dataset
    problems[name] = CalibrationProblem(sim.robot, sim.parameters, sim.measurements,
                                        Observations(ds.joints, ds.measurements))
print(pincal.__file__, flush=True)
calls = 0
for line in sys.stdin:
    name = line.strip()
    problem = problems[name]
    x = problem.initial_guess()
    start = time.process_time()
    for _ in range(20):
        calls += 1
        pred = problem.evaluate(x + calls * 1e-9)  # [m, rad] a new estimate each time: no evaluation recalled
    seconds = (time.process_time() - start) / 20
    digest = hashlib.sha256(pred.residual.tobytes() + pred.jacobian.tobytes()).hexdigest()
    print(seconds, digest, flush=True)
"""


def export(revision: str, into: Path) -> None:
    """``pincal/`` and its robot files as of ``revision`` into the folder ``into``."""
    archive = subprocess.run(["git", "-C", str(ROOT), "archive", revision, "pincal", "robots_urdf"], check=True,
                             capture_output=True).stdout
    subprocess.run(["tar", "-x", "-C", str(into)], input=archive, check=True)
    (into / "robots_urdf").rename(into / "pincal" / "robots_urdf")


def worker(source: Path, cwd: Path) -> subprocess.Popen[str]:
    """A process evaluating the campaigns with the ``pincal`` under ``source``, one campaign per line it reads."""
    return start_worker(WORKER, source, cwd)


def one_turn(process: subprocess.Popen[str], name: str) -> tuple[float, str]:
    """(CPU seconds of one evaluation, SHA-256 of its residual and Jacobian) in ``process``."""
    assert process.stdin is not None and process.stdout is not None
    process.stdin.write(name + "\n")
    process.stdin.flush()
    seconds, digest = process.stdout.readline().split()
    return float(seconds), digest


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--before", default=BEFORE, help=f"the earlier revision (default: {BEFORE})")
    parser.add_argument("--repeats", type=int, default=9, help="turns per revision (default: 9)")
    args = parser.parse_args()
    campaigns = ("pixel", "cross_pixel")
    with tempfile.TemporaryDirectory() as folder:
        old = Path(folder) / "before"
        old.mkdir()
        export(args.before, old)
        workers = {"before": worker(old, Path(folder)), "after": worker(ROOT, Path(folder))}
        times: dict[tuple[str, str], list[float]] = {}
        digests: dict[tuple[str, str], list[str]] = {}
        for turn in range(args.repeats + 1):  # the first turn warms the caches, untimed
            for name in campaigns:
                for side, process in workers.items():
                    seconds, digest = one_turn(process, name)
                    digests.setdefault((name, side), []).append(digest)
                    if turn:
                        times.setdefault((name, side), []).append(seconds)
        stop_workers(workers.values())
    print(f"python {platform.python_version()}, {os.cpu_count()} cores, load {os.getloadavg()[0]:.1f}; "
          f"medians of {args.repeats} turns of 20 evaluations; before = {args.before}, after = the working tree\n")
    print("| campaign (40 images, 35 corners) | CPU before [ms] | CPU after [ms] | after / before | same bytes |")
    print("|---|---|---|---|---|")
    for name in campaigns:
        before, after = (statistics.median(times[(name, side)]) for side in ("before", "after"))
        same = digests[(name, "before")] == digests[(name, "after")]
        print(f"| `{name}` | {before * 1e3:.1f} | {after * 1e3:.1f} | {after / before:.2f} | "
              f"{'yes' if same else 'NO'} |")


if __name__ == "__main__":
    main()
