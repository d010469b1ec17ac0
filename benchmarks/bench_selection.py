"""The default model selection beside BIC and cross-validated selection: held-out error and time (issue 37, item 5).

Run: ``python benchmarks/bench_selection.py`` (``--quick``: one seed, 5-fold × 1). For each benchmark, three models,
each fitted by :func:`pincal.calibration.calibrate` as ``pincal calibrate`` fits it:

- *default*: ``--select auto --prior auto`` (the evidence's prior on every group, σ per axis where none is stated);
- *bic*: ``--select bic --prior 1``, the default before issue 37;
- *cv*: ``--select cv --prior 1``, selection by 5-fold cross-validated error.

The held-out error [mm]: on the real files (TIAGo one marker and three markers, the TALOS table contact of each arm),
the RMS error of ``--cv 5x4`` (every fold refits everything, selection included); on the simulated cameras (a UR10 with
an eye-in-hand camera on its tool seeing a fixed target, true errors of 1 mm / 1 mrad, the camera's depth noise four
times its lateral noise: 0.5 mm across, 2 mm in depth, 2 mrad, no ``# sigma`` line), the RMS error of the 40 held-out
postures of each of three seeds. The time [s]: the median CPU time of one ``calibrate()`` without cross-validation
(three calls, one BLAS thread), and its ratio to *bic*'s. Printed as a table; RESULTS.md keeps the latest.
"""

from __future__ import annotations

import argparse
import os
import statistics
import sys
import time
from dataclasses import replace
from pathlib import Path

os.environ.setdefault("OMP_NUM_THREADS", "1")
os.environ.setdefault("OPENBLAS_NUM_THREADS", "1")

import numpy as np

import pincal
from pincal.calibration import CalibrationOptions, calibrate
from pincal.calibration.campaign import simulate
from pincal.calibration.from_files import read_inputs
from pincal.io.dataset import Dataset

ROOT = Path(__file__).resolve().parents[1]
MODELS = {"default": {}, "bic": {"select": "bic", "prior": 1.0}, "cv": {"select": "cv", "prior": 1.0}}
REAL = {"TIAGo, one marker": ("tiago_no_hand", "examples/data/tiago_mocap_marker1.csv"),
        "TIAGo, three markers": ("tiago_no_hand", "examples/data/tiago_mocap_markers.csv"),
        "TALOS table, left arm": ("examples/data/talos_table_contact/left_job.toml", None),
        "TALOS table, right arm": ("examples/data/talos_table_contact/right_job.toml", None)}


def cameras(seed: int) -> tuple[pincal.Robot, Dataset]:
    """A simulated eye-in-hand campaign of the UR10 whose camera sees depth four times worse than across."""
    robot = pincal.load_robot("ur10")
    data = simulate(robot, ["camera"], 60, 40, perturb=1e-3, noise=0.0, seed=seed).dataset
    key = next(iter(data.measurements))
    values = data.measurements[key].copy()
    rng = np.random.default_rng(100 + seed)
    values[:, :3] += rng.normal(size=(len(values), 3)) * np.array([5e-4, 5e-4, 2e-3])
    tilt = rng.normal(size=(len(values), 3)) * 2e-3  # a small rotation of the target, as a quaternion's vector part
    quaternion = values[:, 3:7] + 0.5 * np.column_stack([tilt, np.zeros(len(values))])
    values[:, 3:7] = quaternion / np.linalg.norm(quaternion, axis=1, keepdims=True)
    metadata = {k: v for k, v in data.metadata.items() if not k.startswith("sigma")}
    return robot, replace(data, measurements={key: values}, metadata=metadata)


def cpu(robot: pincal.Robot, dataset: Dataset, options: CalibrationOptions, calls: int = 3) -> float:
    """The median CPU time [s] of ``calibrate()`` without cross-validation."""
    times = []
    for _ in range(calls):
        start = time.process_time()
        calibrate(robot, dataset, options.replace(cv=None))
        times.append(time.process_time() - start)
    return statistics.median(times)


def main(argv: list[str] | None = None) -> None:
    parser = argparse.ArgumentParser(description=(__doc__ or "").split("\n")[0])
    parser.add_argument("--quick", action="store_true", help="one seed, 5-fold × 1")
    args = parser.parse_args(argv)
    plan = "5x1" if args.quick else "5x4"
    rows = []
    for name, (robot_or_job, data) in REAL.items():
        inputs = read_inputs("calibrate", str(ROOT / robot_or_job) if robot_or_job.endswith(".toml") else robot_or_job,
                             str(ROOT / data) if data else None)
        errors, times = {}, {}
        for model, keywords in MODELS.items():
            options = inputs.options.replace(**keywords)
            cv = calibrate(inputs.robot, inputs.dataset, options.replace(cv=plan)).report.cv
            errors[model] = cv.rms if cv is not None else None
            times[model] = cpu(inputs.robot, inputs.dataset, options, 1 if args.quick else 3)
        rows.append((f"{name} (--cv {plan})", errors, times))
    seeds = (0,) if args.quick else (0, 1, 2)
    errors, times = {m: [] for m in MODELS}, {m: [] for m in MODELS}
    for seed in seeds:
        robot, dataset = cameras(seed)
        for model, keywords in MODELS.items():
            options = CalibrationOptions(**keywords)
            report = calibrate(robot, dataset, options).report
            errors[model].append(report.test_rms_after)
            times[model].append(cpu(robot, dataset, options, 1))
    rows.append((f"simulated cameras, UR10 eye-in-hand ({len(seeds)} seeds, 40 held out each)",
                 {m: float(np.sqrt(np.mean(np.square(v)))) for m, v in errors.items()},
                 {m: statistics.median(v) for m, v in times.items()}))
    print("| benchmark | default [mm] | bic [mm] | cv [mm] | default / best of bic, cv | time default / bic [s] |")
    print("|---|---|---|---|---|---|")
    for name, error, spent in rows:
        best = min(error["bic"], error["cv"])
        print(f"| {name} | {error['default'] * 1e3:.3f} | {error['bic'] * 1e3:.3f} | {error['cv'] * 1e3:.3f} | "
              f"{error['default'] / best:.3f} | {spent['default']:.2f} / {spent['bic']:.2f} "
              f"({spent['default'] / spent['bic']:.2f} ×) |")


if __name__ == "__main__":
    main(sys.argv[1:])
