"""docs/results/talos_table_contact.md, written by ``examples/talos_table_contact.py``: its quick run is the left arm's
default command as ``pincal calibrate`` runs it, and its full run (about 30 s) gives the published page but for its
timing, leaving the published one untouched."""

from __future__ import annotations

import json
import os
import re
import subprocess
import sys
from pathlib import Path

from conftest import ROOT, run_pincal

PAGE = ROOT / "docs" / "results" / "talos_table_contact.md"
SCRIPT = ROOT / "examples" / "talos_table_contact.py"
LEFT_JOB = ROOT / "examples" / "data" / "talos_table_contact" / "left_job.toml"
ENV = dict(os.environ, OMP_NUM_THREADS="1", OPENBLAS_NUM_THREADS="1")


def untimed(text: str) -> str:
    return re.sub(r"took \d+ s", "took … s", text)


def test_the_quick_run_is_the_left_arm_s_default_command(tmp_path: Path) -> None:
    numbers = tmp_path / "numbers.json"
    done = subprocess.run([sys.executable, str(SCRIPT), "--quick", "--out", str(tmp_path / "page"), "--json",
                           str(numbers)], capture_output=True, text=True, timeout=300, env=ENV, cwd=tmp_path,
                          check=False)
    assert done.returncode == 0, done.stderr
    (line,) = json.loads(numbers.read_text(encoding="utf-8"))["lines"]
    report = tmp_path / "report.json"
    cli = run_pincal("calibrate", str(LEFT_JOB), "--cv", "5x1", "--report", str(report))
    assert cli.returncode == 0, cli.stderr
    ran = json.loads(report.read_text(encoding="utf-8"))
    assert line["held_distance"] == [ran["test_rms_before"], ran["test_rms_after"]]
    assert line["cv_distance"] == ran["cv"]["rms"] and line["cv_tilt"] == ran["cv"]["rms_angle"]
    assert (line["n_fitted"], line["n_held_out"]) == (17, 4)  # rows 4, 9, 14, 19 of 21 held out
    assert line["held_distance"][1] < line["held_distance"][0]  # the calibration predicts unseen contacts better
    page = (tmp_path / "page" / "talos_table_contact.md").read_text(encoding="utf-8")
    assert f"{line['held_distance'][0] * 1e3:.1f} → {line['held_distance'][1] * 1e3:.1f}" in page


def test_the_published_page_is_reproduced(tmp_path: Path) -> None:
    published = PAGE.read_bytes()
    done = subprocess.run([sys.executable, str(SCRIPT), "--out", str(tmp_path / "page")], capture_output=True,
                          text=True, timeout=600, env=ENV, cwd=tmp_path, check=False)
    assert done.returncode == 0, done.stderr
    assert PAGE.read_bytes() == published  # only --publish writes into docs/
    page = (tmp_path / "page" / "talos_table_contact.md").read_text(encoding="utf-8")
    assert untimed(page) == untimed(published.decode())
