"""``pincal iso9283`` as a user runs it: ``evaluate`` on a runs file (its report and page, the warning of an RP the
instrument cannot resolve, bad files refused in one line) and ``plan`` on the UR10, the Panda, the Delta and the
hexapod (the commands' forward kinematics is the planned poses)."""

from __future__ import annotations

import csv
import json
import math
from pathlib import Path

import numpy as np
import pytest
from conftest import run_pincal

HEADER = ["pose", "cycle", "direction", "cmd_x", "cmd_y", "cmd_z", "x", "y", "z"]


def _write_runs(path: Path, rows: list[list[object]], header: list[str] = HEADER) -> None:
    with path.open("w", newline="", encoding="utf-8") as stream:
        stream.write("# robot: ur10\n")
        writer = csv.writer(stream)
        writer.writerow(header)
        writer.writerows([[repr(c) if isinstance(c, float) else c for c in row] for row in rows])


def _simulated_rows(rng: np.random.Generator) -> tuple[list[list[object]], dict[str, np.ndarray]]:
    commanded = {"P1": np.array([0.6, 0.1, 0.4]), "P2": np.array([0.7, 0.2, 0.3])}
    bias = np.array([2e-4, -1e-4, 0.0])
    attained = {name: c + bias + rng.normal(scale=2e-5, size=(30, 3)) for name, c in commanded.items()}
    rows = [[name, cycle, "", *commanded[name].tolist(), *attained[name][cycle].tolist()]
            for cycle in range(30) for name in commanded]
    return rows, attained


def test_evaluate_prints_writes_and_warns_as_the_standard_computes(tmp_path: Path) -> None:
    rows, attained = _simulated_rows(np.random.default_rng(7))
    _write_runs(tmp_path / "runs.csv", rows)
    done = run_pincal("iso9283", "evaluate", "ur10", "runs.csv", "--report", "iso.json", "--html", "iso.html",
                      "--instrument-uncertainty", "1e-4", cwd=tmp_path)
    assert done.returncode == 0, done.stderr
    report = json.loads((tmp_path / "iso.json").read_text(encoding="utf-8"))
    assert report["units"] == "SI: m, rad" and [p["pose"] for p in report["poses"]] == ["P1", "P2"]
    for pose, name in zip(report["poses"], ("P1", "P2"), strict=True):
        mean = attained[name].mean(axis=0)
        lengths = np.linalg.norm(attained[name] - mean, axis=1)
        assert pose["ap"] == pytest.approx(np.linalg.norm(mean - rows[0 if name == "P1" else 1][3:6]), rel=1e-9)
        assert pose["rp"] == pytest.approx(lengths.mean() + 3 * lengths.std(ddof=1), rel=1e-9)
    distances = np.linalg.norm(attained["P1"] - attained["P2"], axis=1)
    (pair,) = report["distances"]
    assert pair["ad"] == pytest.approx(distances.mean() - math.sqrt(0.03), rel=1e-6)
    assert pair["rd"] == pytest.approx(3 * distances.std(ddof=1), rel=1e-9)
    assert "warning: RP of P1, P2 is below the instrument's stated uncertainty 0.1 mm" in done.stdout
    page = (tmp_path / "iso.html").read_text(encoding="utf-8")
    assert "<h2>Pose accuracy and repeatability</h2>" in page and f"{report['poses'][0]['rp'] * 1e3:.4f}" in page
    assert f"{report['poses'][0]['rp'] * 1e3:.4f}" in done.stdout


@pytest.mark.parametrize(("header", "cells", "message"), [
    (["pose", "cycle", "x", "y", "z"], ["P1", "0", "0", "0", "0"], "no column cmd_x, cmd_y, cmd_z"),
    (HEADER, ["P1", "zero", "", "0", "0", "0", "0", "0", "0"], "line 3: cycle 'zero' is not a whole number"),
    (HEADER, ["P1", "0", "", "0", "0", "0", "1500", "0", "0"], "a position beyond"),
    ([*HEADER, "qw"], ["P1", "0", "", "0", "0", "0", "0", "0", "0", "1"], "orientation columns qw without"),
])
def test_evaluate_refuses_a_bad_runs_file_in_one_line(tmp_path: Path, header: list[str], cells: list[str],
                                                      message: str) -> None:
    _write_runs(tmp_path / "runs.csv", [cells, [*cells[:1], "1", *cells[2:]]], header)
    done = run_pincal("iso9283", "evaluate", "ur10", "runs.csv", cwd=tmp_path)
    assert done.returncode == 2 and done.stderr.startswith("pincal: error: runs.csv: ") and message in done.stderr
    assert done.stderr.count("\n") == 1


def test_evaluate_writes_no_report_over_its_input(tmp_path: Path) -> None:
    rows, _ = _simulated_rows(np.random.default_rng(1))
    _write_runs(tmp_path / "runs.csv", rows)
    before = (tmp_path / "runs.csv").read_bytes()
    done = run_pincal("iso9283", "evaluate", "ur10", "runs.csv", "--report", "runs.csv", cwd=tmp_path)
    assert done.returncode == 2 and "runs.csv" in done.stderr and (tmp_path / "runs.csv").read_bytes() == before
