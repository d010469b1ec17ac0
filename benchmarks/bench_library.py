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
time per sample); and the median CPU time of ``calibrate()`` with everything it gives read (``report.to_json()`` and
``urdf_text``: what a revision computes on demand included, as the command reads it). Each revision's ``pincal/``
runs in its own process, the two alternating round by round, with one BLAS thread; the data are simulated once, by
the working tree. ``--phases N``: where the working tree's UR10 call spends its time instead, its report and URDF read
(each phase timed as the pipeline calls it, mean of N calls).
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
    times, read, floors = [], [], []
    for _ in range(runs):
        start = time.process_time(); floor(); floors.append(time.process_time() - start)
        start = time.process_time(); calibrate(robot, dataset, **keywords); times.append(time.process_time() - start)
        start = time.process_time(); done = calibrate(robot, dataset, **keywords)
        done.report.to_json(); done.urdf_text; read.append(time.process_time() - start)
    out[name] = {"calibrate": statistics.median(times), "floor": statistics.median(floors) / dataset.n_samples,
                 "read": statistics.median(read), "n": dataset.n_samples}
print(json.dumps(out))
"""


PHASES = r"""
import collections, functools, importlib, json, sys, time
import pincal
from pincal.calibration import calibrate
path, calls = sys.argv[1], int(sys.argv[2])
spent = collections.defaultdict(float)
def timed(module, name, label, cls=None):  # the function (or cls's method) as the pipeline calls it, its CPU time
    owner = importlib.import_module(module)  # added to label's
    owner = getattr(owner, cls) if cls else owner
    inner = getattr(owner, name)
    @functools.wraps(inner)
    def wrapper(*args, **kwargs):
        start = time.process_time()
        try:
            return inner(*args, **kwargs)
        finally:
            spent[label] += time.process_time() - start
    setattr(owner, name, wrapper)
def timed_method(module, cls, name, label):
    timed(module, name, label, cls)
PIPELINE, SELECTION = "pincal.calibration.pipeline", "pincal.identification.selection"
timed_method("pincal.identification.prior", "WithPrior", "evaluate", "the fit/of which its model evaluations")
timed_method("pincal.identification.steps", "Steps", "__init__", "the fit/of which its QR reductions and their SVDs")
timed(SELECTION, "range_guard", "the fit/of which the range guard (hold-out refits)")
timed("pincal.calibration.propagation", "chi2_upper", "inside/χ² quantiles (every bound: held out, workspace, growth)")
timed(PIPELINE, "prepare", "preparation (usable samples, parameters, idle candidates, problem)")
timed(PIPELINE, "check_units", "unit check (positions' spread at the start)")
timed(PIPELINE, "fit_prepared", "the fit (Levenberg-Marquardt, outlier test, model selection, range guard)")
timed(PIPELINE, "calibrated_robot_text", "calibrated URDF text")
timed(PIPELINE, "workspace_prediction", "predicted accuracy over the workspace (100 postures)")
timed(PIPELINE, "estimate_growth", "the bound's growth beyond the fitted range (hold-out refits)")
timed(PIPELINE, "register_setup", "the nominal robot's setup fitted (\"before\")")
timed(PIPELINE, "evaluate_held_out", "the held-out set's errors and bounds")
timed(PIPELINE, "calibrated_proof", "the calibrated URDF reloaded by plain Pinocchio (20 postures)")
timed(PIPELINE, "with_carried", "the calibration the URDF carries (<pincal_calibration>)")
robot, dataset = pincal.load_robot("ur10"), pincal.read_dataset(path)
for _ in range(3):
    calibrate(robot, dataset)
spent.clear()
total = read = 0.0
for _ in range(calls):
    start = time.process_time()
    done = calibrate(robot, dataset)
    total += time.process_time() - start
    done.report.to_json(); done.urdf_text  # what calibrate() left for its reader
    read += time.process_time() - start
extras = {k: v / calls for k, v in spent.items()}
spent.clear()
print(json.dumps({"total": total / calls, "read": read / calls, **extras}))
"""


def phases(calls: int) -> None:
    """Print where the working tree's UR10 ``calibrate()`` (1000 samples) spends its CPU time: each phase timed as
    the pipeline calls it, mean of ``calls`` calls after three warm-up calls, one BLAS thread."""
    with tempfile.TemporaryDirectory() as folder:
        work = Path(folder)
        after = export(None, work / "after")
        cases = simulate(work, after)
        env = {**environment(after), "OPENBLAS_NUM_THREADS": "1", "OMP_NUM_THREADS": "1"}
        done = subprocess.run([sys.executable, "-c", PHASES, cases["UR10, 1000 positions"][1], str(calls)], env=env,
                              capture_output=True, text=True, check=True, cwd=work)
    spent = json.loads(done.stdout)
    total, read = spent.pop("total"), spent.pop("read")
    print(f"UR10, 1000 positions: calibrate() {total * 1e3:.1f} ms CPU, {read * 1e3:.1f} ms with its report JSON and "
          f"URDF text read, mean of {calls} calls; the phases of both (the extras computed on demand included):")
    print("| phase | ms |\n|---|---|")
    parts = {label: seconds for label, seconds in spent.items() if "/" not in label}
    for label, seconds in sorted(parts.items(), key=lambda item: -item[1]):
        print(f"| {label} | {seconds * 1e3:.1f} |")
        for inner in sorted((k for k in spent if "/" in k and label.startswith(k.split("/")[0])),
                            key=lambda k: -spent[k]):
            print(f"| {inner.split('/')[1]} | {spent[inner] * 1e3:.1f} |")
    print(f"| the rest (report figures, plausibility, held-out set, JSON text, ...) | "
          f"{(read - sum(parts.values())) * 1e3:.1f} |")
    for label in (k for k in spent if k.startswith("inside/")):
        print(f"| inside the phases above: {label.split('/')[1]} | {spent[label] * 1e3:.1f} |")


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
    parser.add_argument("--phases", type=int, metavar="N",
                        help="instead: the working tree's UR10 calibrate() phase by phase, mean of N calls")
    args = parser.parse_args()
    if args.phases:
        phases(args.phases)
        return
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
    print("| case | calibrate() before | after | floor per sample | after / (N × floor) | after, floor units | "
          "all read: before | all read: after |")
    print("|---|---|---|---|---|---|---|---|")
    for name in cases:
        before, after, read_before, read_after = (
            statistics.median(r[name][what] for r in rounds[which])
            for which, what in (("before", "calibrate"), ("after", "calibrate"), ("before", "read"), ("after", "read")))
        floor = statistics.median(r[name]["floor"] for r in rounds["after"])
        n = rounds["after"][0][name]["n"]
        print(f"| {name} | {before * 1e3:.1f} ms | {after * 1e3:.1f} ms | {floor * 1e6:.2f} µs | "
              f"{after / (n * floor):.0f} × | {after / floor:,.0f} | {read_before * 1e3:.1f} ms | "
              f"{read_after * 1e3:.1f} ms |")


if __name__ == "__main__":
    main()
