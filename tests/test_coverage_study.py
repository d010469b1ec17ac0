"""docs/results/coverage.md, written by ``examples/coverage.py``: its quick run leaves the page alone and computes its
sentences; its full run (about a minute on two cores) reproduces the published page and keeps the coverage of the
95 % bound within 95 ± 3 % on the simulated campaigns."""

from __future__ import annotations

import json
import os
import subprocess
import sys
from pathlib import Path

ROOT = Path(__file__).resolve().parents[1]
PAGE = ROOT / "docs" / "results" / "coverage.md"
ENV = dict(os.environ, OMP_NUM_THREADS="1", OPENBLAS_NUM_THREADS="1")


def _run(tmp_path: Path, *extra: str) -> tuple[str, dict]:
    numbers = tmp_path / "numbers.json"
    done = subprocess.run([sys.executable, str(ROOT / "examples" / "coverage.py"), "--out", str(tmp_path / "page"),
                           "--json", str(numbers), *extra], capture_output=True, text=True, timeout=600, env=ENV,
                          cwd=tmp_path, check=False)
    assert done.returncode == 0, done.stderr
    return (tmp_path / "page" / "coverage.md").read_text(encoding="utf-8"), json.loads(numbers.read_text("utf-8"))


def test_the_quick_run_counts_every_robot_and_leaves_the_page_alone(tmp_path: Path) -> None:
    published = PAGE.read_bytes()
    page, result = _run(tmp_path, "--quick")
    assert PAGE.read_bytes() == published
    assert [r["robot"] for r in result["rows"]] == ["delta", "five_bar", "hexapod", "hexapod_device", "ucr3", "ur10"]
    for row in result["rows"]:
        assert row["samples"] >= 15 and 0.0 < row["fraction"] <= 1.0
        assert f"| {row['robot']} | {row['inside']} of {row['samples']} | {row['fraction']:.1%} |" in page
    tiago = result["tiago"]
    assert tiago["samples"] == 6 and f"{tiago['inside']} of 6 errors lie within their predicted 95 % bound" in page


def test_the_full_run_reproduces_the_page_and_the_coverage_holds(tmp_path: Path) -> None:
    page, result = _run(tmp_path)
    assert page == PAGE.read_text(encoding="utf-8")  # every figure and sentence as published
    rows = result["rows"]
    pooled = sum(r["inside"] for r in rows) / sum(r["samples"] for r in rows)
    assert abs(pooled - 0.95) <= 0.02
    within = [r["robot"] for r in rows if abs(r["fraction"] - 0.95) <= 0.03 + 1e-12]
    assert within == [r["robot"] for r, ok in zip(rows, result["within_target"], strict=True) if ok]
    assert all(result["within_target"])  # the target, 95 ± 3 %, on every robot
