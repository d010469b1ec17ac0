"""docs/results/talos_table_contact.md, written by ``examples/talos_table_contact.py``: its quick run is the left arm's
default command as ``pincal calibrate`` runs it, and its full run (about 30 s) gives the published page but for its
timing, leaving the published one untouched."""

from __future__ import annotations

import json
import re
from pathlib import Path

from conftest import ROOT, page_elsewhere, run_pincal

PAGE = ROOT / "docs" / "results" / "talos_table_contact.md"
SCRIPT = ROOT / "examples" / "talos_table_contact.py"
LEFT_JOB = ROOT / "examples" / "data" / "talos_table_contact" / "left_job.toml"


def untimed(text: str) -> str:
    return re.sub(r"took \d+ s", "took … s", text)


def test_the_quick_run_is_the_left_arm_s_default_command(tmp_path: Path) -> None:
    numbers = tmp_path / "numbers.json"
    page = page_elsewhere(SCRIPT, PAGE, tmp_path, "--quick", "--json", str(numbers), timeout=300)
    (line,) = json.loads(numbers.read_text(encoding="utf-8"))["lines"]
    report = tmp_path / "report.json"
    cli = run_pincal("calibrate", str(LEFT_JOB), "--cv", "5x1", "--report", str(report))
    assert cli.returncode == 0, cli.stderr
    ran = json.loads(report.read_text(encoding="utf-8"))
    assert line["held_distance"] == [ran["test_rms_before"], ran["test_rms_after"]]
    assert line["cv_distance"] == ran["cv"]["rms"] and line["cv_tilt"] == ran["cv"]["rms_angle"]
    assert (line["n_fitted"], line["n_held_out"]) == (17, 4)  # rows 4, 9, 14, 19 of 21 held out
    assert line["held_distance"][1] < line["held_distance"][0]  # the calibration predicts unseen contacts better
    assert f"{line['held_distance'][0] * 1e3:.1f} → {line['held_distance'][1] * 1e3:.1f}" in page


def test_the_published_page_is_reproduced(tmp_path: Path) -> None:
    page = page_elsewhere(SCRIPT, PAGE, tmp_path, timeout=600)
    assert untimed(page) == untimed(PAGE.read_text(encoding="utf-8"))
