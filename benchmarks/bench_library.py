"""Library ``calibrate()`` with its defaults, in units of the Pinocchio floor measured beside it, before and after.

Run: ``python benchmarks/bench_library.py`` (``--before REV``, default ``e429d2a``: main before issue 27's work;
``--repeats K``, default 5 rounds; ``--runs M``, default 7 calls per round). The two cases of issue 27:

- UR10, 1000 positions of its tool (``pincal simulate ur10 --samples 1000``'s data): ``calibrate(robot, dataset)``;
- Delta, 60 positions with Model 24's errors (``pincal simulate delta --parameters model24``):
  ``calibrate(robot, dataset, parameter_spec=["model24"])``.

The floor: the bare Pinocchio calls a per-sample evaluation needs, in a Python loop over the samples
(``computeJointJacobians`` + ``updateFramePlacements`` + ``getFrameJacobian(LOCAL)`` of the measured frame, at random
configurations), per sample. Printed: the median CPU time of ``calibrate()`` and of the floor per sample, measured in
the same process, and their ratio, as ``× (N × floor)`` (N the samples) and as floor units (calibrate time / floor
time per sample). Each revision's ``pincal/`` runs in its own process, the two alternating round by round, with one
BLAS thread; the data are simulated once, by the working tree.
"""

from __future__ import annotations

import argparse
import json
import os
import statistics
import subprocess
import sys
import tempfile
from pathlib import Path

sys.path.insert(0, str(Path(__file__).resolve().parent))
from bench_commands import BEFORE, environment, export

ROUND = r"""
import json, statistics, sys, time
import numpy as np, pinocchio as pin
import pincal
from pincal.calibration import calibrate
cases, runs = json.loads(sys.argv[1]), int(sys.argv[2])
out = {}
for name, (robot_name, path, keywords) in cases.items():
    robot, dataset = pincal.load_robot(robot_name), pincal.read_dataset(path)
    fit = calibrate(robot, dataset, **keywords)
    frame = robot.frame_id(fit.prepared.models[0].frames[0])
    model, data = robot.model, robot.model.createData()
    rng = np.random.default_rng(0)
    q = [pin.randomConfiguration(model) for _ in range(dataset.n_samples)]
    def floor():
        for qk in q:
            pin.computeJointJacobians(model, data, qk)
            pin.updateFramePlacements(model, data)
            pin.getFrameJacobian(model, data, frame, pin.LOCAL)
    times, floors = [], []
    for _ in range(runs):
        start = time.process_time(); floor(); floors.append(time.process_time() - start)
        start = time.process_time(); calibrate(robot, dataset, **keywords); times.append(time.process_time() - start)
    out[name] = {"calibrate": statistics.median(times), "floor": statistics.median(floors) / dataset.n_samples,
                 "n": dataset.n_samples}
print(json.dumps(out))
"""


def simulate(work: Path, after: Path) -> dict[str, tuple[str, str, dict[str, list[str]]]]:
    """The two cases' data, simulated once by the working tree; each case's robot, data file and keywords."""
    env = {**environment(after), "OPENBLAS_NUM_THREADS": "1"}
    launch = "import sys; from pincal.__main__ import main; sys.argv[0] = 'pincal'; sys.exit(main())"
    for robot, extra in (("ur10", ["--samples", "1000"]), ("delta", ["--parameters", "model24"])):
        subprocess.run([sys.executable, "-c", launch, "simulate", robot, *extra, "--seed", "1", "--quiet", "--out",
                        str(work / robot)], env=env, check=True, capture_output=True)
    return {"UR10, 1000 positions": ("ur10", str(work / "ur10/measurements.csv"), {}),
            "Delta, 60 positions, model24": ("delta", str(work / "delta/measurements.csv"),
                                             {"parameter_spec": ["model24"]})}


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--before", default=BEFORE, help=f"the revision to compare with (default {BEFORE})")
    parser.add_argument("--repeats", type=int, default=5, help="rounds, each revision once per round")
    parser.add_argument("--runs", type=int, default=7, help="calls of calibrate() per round")
    args = parser.parse_args()
    with tempfile.TemporaryDirectory() as folder:
        work = Path(folder)
        sources = {"before": export(args.before, work / "before"), "after": export(None, work / "after")}
        cases = simulate(work, sources["after"])
        rounds: dict[str, list[dict[str, dict[str, float]]]] = {"before": [], "after": []}
        for _ in range(args.repeats):
            for which, source in sources.items():
                env = {**environment(source), "OPENBLAS_NUM_THREADS": "1", "OMP_NUM_THREADS": "1"}
                done = subprocess.run([sys.executable, "-c", ROUND, json.dumps(cases), str(args.runs)], env=env,
                                      capture_output=True, text=True, check=True, cwd=work)
                rounds[which].append(json.loads(done.stdout))
    print(f"python {sys.version.split()[0]}, {os.cpu_count()} cores; before = {args.before}, after = the working "
          f"tree; medians of {args.repeats} rounds of {args.runs} calls, CPU time")
    print("| case | calibrate() before | after | floor per sample | after / (N × floor) | after, floor units |")
    print("|---|---|---|---|---|---|")
    for name in cases:
        before = statistics.median(r[name]["calibrate"] for r in rounds["before"])
        after = statistics.median(r[name]["calibrate"] for r in rounds["after"])
        floor = statistics.median(r[name]["floor"] for r in rounds["after"])
        n = rounds["after"][0][name]["n"]
        print(f"| {name} | {before * 1e3:.1f} ms | {after * 1e3:.1f} ms | {floor * 1e6:.2f} µs | "
              f"{after / (n * floor):.0f} × | {after / floor:,.0f} |")


if __name__ == "__main__":
    main()
