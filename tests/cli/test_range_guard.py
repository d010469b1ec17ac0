"""``pincal calibrate`` with the automatic prior passes the range guard (docs/calibrated_urdf.md, 'The prior'): on the
TALOS right arm's table contacts with four rows at the ends of its joints' ranges held out, the evidence's prior
predicts each joint's range halves worse than the nominal robot; the guard holds it firmer, says so, and the held-out
rows are predicted better than by the nominal robot."""

from __future__ import annotations

import json
import re
import shutil
from pathlib import Path

from conftest import run_pincal

TALOS = Path(__file__).resolve().parents[2] / "examples" / "data" / "talos_table_contact"


def _right_arm_job(tmp_path: Path, held_out: list[int]) -> Path:
    """The TALOS right arm's job in ``tmp_path``, the rows ``held_out`` (counted from 0) held out."""
    shutil.copy(TALOS / "right_train.csv", tmp_path / "right_train.csv")
    job = (TALOS / "right_job.toml").read_text(encoding="utf-8")
    job, count = re.subn(r"^held_out = .*$", f"held_out = {held_out}", job, flags=re.M)
    assert count == 1
    (tmp_path / "job.toml").write_text(job, encoding="utf-8")
    return tmp_path / "job.toml"


def test_the_guard_holds_a_prior_that_extrapolates_worse_than_nominal(tmp_path: Path) -> None:
    job = _right_arm_job(tmp_path, [2, 12, 23, 24])
    report = tmp_path / "r.json"
    done = run_pincal("calibrate", str(job), "--out", str(tmp_path / "cal.urdf"), "--report",
                      str(report))
    assert done.returncode == 0, done.stdout + done.stderr
    text = " ".join(done.stdout.split())  # the summary wraps its lines at 120 columns
    found = re.search(r"the range guard holds them (\d+)× firmer than the evidence says \(each joint's range halves "
                      r"predicted each other ([\d.e+]+) σ² mean square, the evidence's prior ([\d.e+]+), the nominal "
                      r"robot ([\d.e+]+); shuffled folds ([\d.e+]+), the evidence's prior ([\d.e+]+)\)", text)
    assert found, done.stdout
    content = json.loads(report.read_text(encoding="utf-8"))
    guard = content["selection"]["guard"]
    assert guard["firmer"] == float(found[1]) > 1.0
    assert guard["beyond"] <= guard["nominal_beyond"]  # held firmer until no worse than the nominal robot
    tried = {divisor: beyond for divisor, _, beyond in guard["scores"]}
    assert tried[1.0] > guard["nominal_beyond"]  # the evidence's own prior: worse
    assert content["test_rms_after"] < content["test_rms_before"]  # the held-out rows, predicted for real
    assert (tmp_path / "cal.urdf").is_file()


def test_the_guard_holds_a_prior_firmer_that_predicts_its_hold_outs_better(tmp_path: Path) -> None:
    """The TALOS right arm with six other rows held out: the evidence's prior predicts the range halves no worse than
    the nominal robot beyond chance, but a firmer one predicts the halves and the shuffled folds better beyond chance;
    the guard takes it, says so, and the held-out rows are predicted better than by the nominal robot."""
    job = _right_arm_job(tmp_path, [3, 4, 12, 17, 24, 28])
    report = tmp_path / "r.json"
    done = run_pincal("calibrate", str(job), "--report", str(report), "--out",
                      str(tmp_path / "cal.urdf"))
    assert done.returncode == 0, done.stdout + done.stderr
    text = " ".join(done.stdout.split())
    assert re.search(r"the range guard holds them \d+× firmer than the evidence says", text), done.stdout
    content = json.loads(report.read_text(encoding="utf-8"))
    guard = content["selection"]["guard"]
    sums = {divisor: inside + beyond for divisor, inside, beyond in guard["scores"]}
    assert guard["firmer"] > 1.0 and sums[guard["firmer"]] == min(sums.values()) < sums[1.0]
    assert content["test_rms_after"] < 0.5 * content["test_rms_before"]
