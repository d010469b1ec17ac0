"""Coverage of the predicted 95 % bound: how many held-out errors lie within the bound each posture was predicted.

Run: ``python examples/coverage.py`` (about a minute on two cores) or ``--quick`` (one small campaign per robot).
Writes ``coverage.md`` under ``results/`` (``--out DIR`` elsewhere, ``--publish`` for ``docs/results``, ``--json``
for the numbers).

For every robot in ``robots_urdf/`` and the UR10, campaigns are simulated as ``pincal simulate ROBOT --samples 60
--test-samples 40 --seed S`` does (true errors of σ 1 mm / 1 mrad on every default candidate that moves a measurement,
10 µm noise, postures within the joint limits) and calibrated with the defaults (``pincal calibrate ROBOT
measurements.csv``); each held-out posture's error after calibration is compared with the 95 % bound the report predicts
for it (``predicted_held_out``). A seed whose true robot cannot be assembled is skipped and said. The real TIAGo data
(``examples/data/tiago_mocap_marker1.csv``, its ``set=test`` postures held out) are calibrated the same way.
"""

from __future__ import annotations

import math
import sys
from concurrent.futures import ProcessPoolExecutor
from pathlib import Path
from typing import Any

from study_cli import ROOT, study_main

import pincal
from pincal.calibration.campaign import simulate
from pincal.calibration.pipeline import calibrate
from pincal.calibration.samples import read_robot_dataset
from pincal.errors import ConvergenceError

ROBOTS = ["delta", "five_bar", "hexapod", "hexapod_device", "ucr3", "ur10"]
#: Campaigns per robot and their held-out postures: (trials, train, test).
PLAN = {False: (10, 60, 40), True: (1, 30, 20)}
TARGET, TOLERANCE = 0.95, 0.03
TIAGO = ROOT / "examples" / "data" / "tiago_mocap_marker1.csv"


def robot_coverage(robot: str, quick: bool) -> dict[str, Any]:
    """One robot's campaigns: held-out errors within their bound, the bounds' median [m], seeds skipped."""
    trials, n_train, n_test = PLAN[quick]
    nominal = pincal.load_robot(robot)
    inside = total = 0
    bounds: list[float] = []
    skipped: list[int] = []
    seed = 0
    while trials:
        try:
            sim = simulate(nominal, ["position"], n_train, n_test, seed=seed)
        except ConvergenceError:
            skipped.append(seed)
            seed += 1
            continue
        held = calibrate(nominal, sim.dataset).report.predicted_held_out or {}
        inside, total = inside + held["inside"], total + held["samples"]
        bounds += [s["bound"] for s in held["samples_predicted"] if s["bound"] is not None]
        trials, seed = trials - 1, seed + 1
    bounds.sort()
    return {"robot": robot, "inside": inside, "samples": total, "fraction": inside / total,
            "median_bound": bounds[len(bounds) // 2], "skipped": skipped, "seeds": seed}


def tiago_coverage() -> dict[str, Any]:
    """The real TIAGo data, default calibration: held-out errors within their bound."""
    robot = pincal.load_robot("tiago_no_hand")
    report = calibrate(robot, read_robot_dataset(TIAGO, robot)).report
    held = report.predicted_held_out or {}
    rows = [{"sample": s["sample"], "bound": s["bound"], "widening": s["widening"]} for s in held["samples_predicted"]]
    errors = {e["sample"]: e["after"] for e in report.sample_errors if e["set"] == "test"}
    for row in rows:
        row["error"] = errors[row["sample"]]
    return {"inside": held["inside"], "samples": held["samples"], "fraction": held["fraction"], "rows": rows,
            "sigma2": report.sigma2}


def judged(row: dict[str, Any]) -> bool:
    """Whether a robot's coverage is within the target 95 ± 3 %."""
    return abs(row["fraction"] - TARGET) <= TOLERANCE + 1e-12


def page(rows: list[dict[str, Any]], tiago: dict[str, Any], quick: bool) -> str:
    """The results page: the table, the commands, the TIAGo section, every judging sentence computed here."""
    trials, n_train, n_test = PLAN[quick]
    out = ["# Coverage of the predicted 95 % bound", "",
           "Written by `python examples/coverage.py --publish`" + (" (`--quick`)" if quick else "") + ". Each robot: "
           f"{trials} simulated campaign{'s' if trials > 1 else ''} of {n_train} postures to calibrate from and "
           f"{n_test} held out, as", "",
           f"    pincal simulate ROBOT --samples {n_train} --test-samples {n_test} --seed S --out sim",
           "    pincal calibrate ROBOT sim/measurements.csv --report report.json", "",
           "make them (S = 0, 1, …; true errors of σ 1 mm / 1 mrad on every default candidate that moves a "
           "measurement, 10 µm noise). The "
           "report's `predicted_held_out` gives each held-out posture its 95 % bound (docs/predicted_accuracy.md); "
           "the table counts the held-out errors within it.", "",
           "| robot | held-out errors within the bound | coverage | median bound (mm) | seeds skipped |",
           "|---|---|---|---|---|"]
    for row in rows:
        skipped = ", ".join(map(str, row["skipped"])) or "–"
        out.append(f"| {row['robot']} | {row['inside']} of {row['samples']} | {row['fraction']:.1%} | "
                   f"{row['median_bound'] * 1e3:.3f} | {skipped} |")
    inside = [r["robot"] for r in rows if judged(r)]
    outside = [r["robot"] for r in rows if not judged(r)]
    pooled = sum(r["inside"] for r in rows) / sum(r["samples"] for r in rows)
    sentence = (f"All {len(rows)} robots are within the target 95 ± 3 %" if not outside else
                f"{len(inside)} of {len(rows)} robots are within the target 95 ± 3 %; "
                f"{', '.join(outside)} {'is' if len(outside) == 1 else 'are'} not")
    out += ["", f"{sentence}; over all robots, {pooled:.1%} of the held-out errors lie within their bound. "
            "(A seed is skipped when the simulated true robot cannot be assembled at its postures.)", ""]
    widened = [r for r in tiago["rows"] if r["widening"] > 1.0]
    out += ["## Real data: TIAGo", "",
            "    pincal calibrate tiago_no_hand examples/data/tiago_mocap_marker1.csv --report report.json", "",
            f"The {tiago['samples']} held-out postures (`set=test`) of the real TIAGo motion-capture data, default "
            f"calibration (a-posteriori σ {math.sqrt(tiago['sigma2']):.2f} × the stated 1 mm): "
            f"{tiago['inside']} of {tiago['samples']} errors lie within their predicted 95 % bound "
            f"({tiago['fraction']:.0%}), "
            + ("below the 95 % the bound claims: on real data the model misses effects the covariance does not "
               "hold, and six postures are few to judge by." if tiago["fraction"] < TARGET - TOLERANCE else
               "as the bound claims."), "",
            "| sample | error (mm) | 95 % bound (mm) | widened × |", "|---|---|---|---|"]
    out += [f"| {r['sample']} | {r['error'] * 1e3:.2f} | {r['bound'] * 1e3:.2f} | {r['widening']:.2f} |"
            for r in tiago["rows"]]
    out += ["", (f"{len(widened)} of the held-out postures {'lies' if len(widened) == 1 else 'lie'} beyond the "
                 f"fitted joint range; {'its bound is' if len(widened) == 1 else 'their bounds are'} widened."
                 if widened else "No held-out posture lies beyond the fitted joint range."), ""]
    return "\n".join(out)


def run(quick: bool, out: Path, executor: str | None) -> dict[str, Any]:
    """Every robot's coverage and the TIAGo figure; the page written into ``out``."""
    if executor is None:
        rows = [robot_coverage(robot, quick) for robot in ROBOTS]
    else:
        with ProcessPoolExecutor(max_workers=2) as pool:
            rows = list(pool.map(robot_coverage, ROBOTS, [quick] * len(ROBOTS)))
    tiago = tiago_coverage()
    text = page(rows, tiago, quick)
    out.mkdir(parents=True, exist_ok=True)
    (out / "coverage.md").write_text(text, encoding="utf-8")
    print(text)
    return {"rows": rows, "tiago": tiago, "within_target": [judged(r) for r in rows]}


if __name__ == "__main__":
    study_main(run, __doc__, "one small campaign per robot", sys.argv[1:])
