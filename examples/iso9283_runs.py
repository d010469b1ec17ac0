"""ISO 9283 figures recovered: simulated runs of a planned test with a known bias and a known Gaussian repeatability
per pose, evaluated by ``pincal iso9283 evaluate``, against the figures those imply.

Run: ``python examples/iso9283_runs.py`` (about a minute) or ``--quick`` (fewer runs). Writes ``iso9283_runs.md`` under
``results/`` (``--publish`` for ``docs/results``, ``--json`` for the numbers). With ``--simulate PLAN.csv --runs
RUNS.csv [--seed S]`` it writes one simulated runs file of a plan instead (docs/iso9283.md's worked example).

The test is ``pincal iso9283 plan ur10`` (30 cycles, and 4000 to show the estimates converge). Each run draws, for
each pose, a bias b [m] (N(0, 0.1 mm) per axis) and a repeatability σ (uniform in 5–30 µm), and for each approach
direction of the multi-directional series an offset (N(0, 20 µm) per axis); the attained position of a row is its
commanded one plus the pose's bias, its direction's offset and isotropic Gaussian noise of σ; its orientation is the
commanded one turned by a bias (N(0, 0.1 mrad) per axis) and noise (N(0, 20 µrad)). What these imply: AP = |b|; RP =
σ (2√(2/π) + 3√(3 − 8/π)) (the distance from the mean of an isotropic Gaussian follows Maxwell's law, l̄ = 2σ√(2/π),
S_l = σ√(3 − 8/π)); vAP = the largest distance between two directions' offsets.
"""

from __future__ import annotations

import argparse
import contextlib
import csv
import io
import json
import math
import sys
import tempfile
import time
from pathlib import Path
from typing import Any

import numpy as np
import pinocchio as pin
from study_cli import study_main

from pincal.cli.app import main as pincal_main

RUNS = {False: 100, True: 10}
LONG_CYCLES, LONG_RUNS = 4000, {False: 10, True: 2}
MAXWELL = 2 * math.sqrt(2 / math.pi) + 3 * math.sqrt(3 - 8 / math.pi)
BIAS, DIRECTION_OFFSET, ANGLE_BIAS, ANGLE_NOISE = 1e-4, 2e-5, 1e-4, 2e-5


def _pincal(*args: str) -> str:
    with contextlib.redirect_stdout(io.StringIO()) as out, contextlib.redirect_stderr(io.StringIO()) as err:
        status = pincal_main(list(args))
    if status != 0:
        raise RuntimeError(f"pincal {' '.join(args)}: exit {status}: {err.getvalue()}")
    return out.getvalue()


def simulate_runs(plan: Path, runs: Path, seed: int) -> dict[str, Any]:
    """Write ``runs``: the plan's rows with simulated attained positions and orientations; returns the truth."""
    rng = np.random.default_rng(seed)
    lines = plan.read_text(encoding="utf-8").splitlines()
    rows = list(csv.DictReader(line for line in lines if not line.startswith("#")))
    poses = sorted({r["pose"] for r in rows})
    bias = {p: rng.normal(scale=BIAS, size=3) for p in poses}
    sigma = {p: float(rng.uniform(5e-6, 3e-5)) for p in poses}
    turn = {p: rng.normal(scale=ANGLE_BIAS, size=3) for p in poses}
    offsets = {(r["pose"], r["direction"]): rng.normal(scale=DIRECTION_OFFSET, size=3)
               for r in rows if r["direction"]}
    oriented = "cmd_qw" in rows[0]
    header = ["pose", "cycle", "direction", "cmd_x", "cmd_y", "cmd_z", "x", "y", "z"]
    header += ["cmd_qw", "cmd_qx", "cmd_qy", "cmd_qz", "qw", "qx", "qy", "qz"] if oriented else []
    out = [f"# {line[2:]}" for line in lines if line.startswith("# robot:") or line.startswith("# units:")]
    out.append(",".join(header))
    for r in rows:
        p, d = r["pose"], r["direction"]
        commanded = np.array([float(r[f"cmd_{c}"]) for c in "xyz"])
        attained = commanded + bias[p] + (offsets[(p, d)] if d else 0.0) + rng.normal(scale=sigma[p], size=3)
        cells = [p, r["cycle"], d, *(r[f"cmd_{c}"] for c in "xyz"), *(repr(float(v)) for v in attained)]
        if oriented:
            w, x, y, z = (float(r[f"cmd_q{c}"]) for c in "wxyz")
            rotation = pin.exp3(turn[p] + rng.normal(scale=ANGLE_NOISE, size=3)) @ pin.Quaternion(w, x, y, z).matrix()
            q = pin.Quaternion(rotation)
            cells += [r["cmd_qw"], r["cmd_qx"], r["cmd_qy"], r["cmd_qz"], *(repr(float(v)) for v in (q.w, q.x, q.y,
                                                                                                     q.z))]
        out.append(",".join(cells))
    runs.write_text("\n".join(out) + "\n", encoding="utf-8")
    vap = {p: max(float(np.linalg.norm(offsets[(p, h)] - offsets[(p, k)])) for (q1, h) in offsets for (q2, k) in
                  offsets if q1 == q2 == p) for p in {p for p, _ in offsets}}
    return {"ap": {p: float(np.linalg.norm(bias[p])) for p in poses}, "rp": {p: sigma[p] * MAXWELL for p in poses},
            "vap": vap}


def _series(folder: Path, cycles: int, runs: int) -> dict[str, list[float]]:
    """The ratios of the figures to the true ones over ``runs`` runs of a plan of ``cycles`` cycles."""
    ratios: dict[str, list[float]] = {"ap": [], "rp": [], "vap": []}
    plan = folder / f"plan{cycles}.csv"
    _pincal("iso9283", "plan", "ur10", "--cycles", str(cycles), "--out", str(plan))
    for seed in range(1, runs + 1):
        truth = simulate_runs(plan, folder / "runs.csv", seed)
        _pincal("iso9283", "evaluate", "ur10", str(folder / "runs.csv"), "--report", str(folder / "iso.json"))
        report = json.loads((folder / "iso.json").read_text(encoding="utf-8"))
        for pose in report["poses"]:
            ratios["ap"].append(pose["ap"] / truth["ap"][pose["pose"]])
            ratios["rp"].append(pose["rp"] / truth["rp"][pose["pose"]])
        for variation in report["variations"]:
            ratios["vap"].append(variation["vap"] / truth["vap"][variation["pose"]])
    return ratios


def _rows(cycles: int, ratios: dict[str, list[float]]) -> list[str]:
    rows = []
    for key, name in (("ap", "AP"), ("rp", "RP"), ("vap", "vAP")):
        values = np.array(ratios[key])
        within = int(np.sum(np.abs(values - 1) <= 0.05))
        rows.append(f"| {cycles} | {name} | {len(values)} | {values.mean():.3f} | {values.std(ddof=1):.3f} | "
                    f"{within} ({100 * within / len(values):.0f} %) |")
    return rows


def run(quick: bool, out: Path, executor: str | None = None) -> dict[str, Any]:
    start = time.perf_counter()
    with tempfile.TemporaryDirectory() as scratch:
        standard = _series(Path(scratch), 30, RUNS[quick])
        long = _series(Path(scratch), LONG_CYCLES, LONG_RUNS[quick])
    seconds = time.perf_counter() - start
    mean_ok = all(abs(np.mean(standard[key]) - 1) <= 0.05 for key in ("ap", "rp"))
    each_ok = all(np.all(np.abs(np.array(long[key]) - 1) <= 0.05) for key in ("ap", "rp"))
    spread = float(np.std(standard["rp"], ddof=1))
    text = "\n".join([
        "# ISO 9283 figures recovered from simulated runs",
        "",
        f"Written by `python examples/iso9283_runs.py{' --quick' if quick else ''} --publish` ({seconds:.0f} s); "
        "the formulas: [docs/iso9283.md](../iso9283.md).",
        "",
        "Runs of the test `pincal iso9283 plan ur10` (5 poses × N cycles, then P1, P2 and P4 from 3 directions × N "
        "cycles), each with its own bias (N(0, 0.1 mm) per axis) and repeatability σ (5–30 µm) per pose and an offset "
        "per approach direction (N(0, 20 µm) per axis), evaluated by `pincal iso9283 evaluate`: "
        f"{RUNS[quick]} runs of the standard's 30 cycles, {LONG_RUNS[quick]} of {LONG_CYCLES}. Ratio of each figure "
        "to the one the simulation implies (AP = |bias|, RP = 3.616 σ, vAP = the largest distance between two "
        "directions' offsets):",
        "",
        "| cycles | figure | poses × runs | mean ratio | standard deviation | within 5 % |",
        "|---|---|---|---|---|---|",
        *_rows(30, standard),
        *_rows(LONG_CYCLES, long),
        "",
        ("With 30 cycles the mean of AP and of RP over the runs is within 5 % of the true value"
         if mean_ok else "With 30 cycles the mean of AP or RP over the runs is NOT within 5 % of the true value")
        + f"; one run's RP scatters about it by {100 * spread:.1f} % (S_l from 30 distances). "
        + (f"With {LONG_CYCLES} cycles every run's AP and RP is within 5 %." if each_ok
           else f"With {LONG_CYCLES} cycles some run's AP or RP is NOT within 5 %."),
        "",
    ])
    out.mkdir(parents=True, exist_ok=True)
    (out / "iso9283_runs.md").write_text(text, encoding="utf-8")
    print(f"wrote {out / 'iso9283_runs.md'} ({seconds:.0f} s)", file=sys.stderr)
    return {"standard": standard, "long": long, "seconds": seconds}


def main(argv: list[str] | None = None) -> dict[str, Any]:
    if argv is None:
        argv = sys.argv[1:]
    if "--simulate" in argv:
        parser = argparse.ArgumentParser(description="one simulated runs file of a plan")
        parser.add_argument("--simulate", type=Path, required=True, metavar="PLAN.csv")
        parser.add_argument("--runs", type=Path, required=True, metavar="RUNS.csv")
        parser.add_argument("--seed", type=int, default=1)
        args = parser.parse_args(argv)
        truth = simulate_runs(args.simulate, args.runs, args.seed)
        print(f"wrote {args.runs}: true AP " + ", ".join(f"{p} {v * 1e3:.4f}" for p, v in truth["ap"].items())
              + " mm; true RP " + ", ".join(f"{p} {v * 1e3:.4f}" for p, v in truth["rp"].items()) + " mm")
        return truth
    return study_main(run, __doc__, "10 runs instead of 100", argv)


if __name__ == "__main__":
    main()
