"""A wrong joint reading in one fitted sample (one joint off, a digit lost): the default robust fit rejects that sample,
names it, and calibrates as well as without it."""

from __future__ import annotations

import json
from pathlib import Path
from typing import Any

import pytest
from conftest import run_pincal

BAD_SAMPLE = "17"


def _simulated(robot: str, out: Path) -> Path:
    done = run_pincal("simulate", robot, "--samples", "60", "--test-samples", "20", "--seed", "1", "--quiet",
                      "--out", str(out))
    assert done.returncode == 0, done.stderr
    return out / "measurements.csv"


def _with_reading(clean: Path, out: Path, sample: str, joint: str, edit: Any) -> tuple[float, float]:
    """``clean`` with ``sample``'s reading of ``joint`` replaced by ``edit(text)``, written to ``out``; the reading
    before and after [rad]."""
    lines = clean.read_text().splitlines()
    header = next(k for k, line in enumerate(lines) if line.startswith("sample,"))
    column = lines[header].split(",").index(joint)
    row = next(k for k in range(header + 1, len(lines)) if lines[k].split(",")[:2] == [sample, "train"])
    cells = lines[row].split(",")
    before = cells[column]
    cells[column] = edit(before)
    lines[row] = ",".join(cells)
    out.write_text("\n".join(lines) + "\n")
    return float(before), float(cells[column])


def _calibrated(robot: str, data: Path, tmp_path: Path, name: str) -> tuple[Any, dict[str, Any]]:
    report = tmp_path / f"{name}.json"
    done = run_pincal("calibrate", robot, str(data), "--out", str(tmp_path / f"{name}.urdf"), "--report", str(report))
    assert done.returncode == 0, done.stdout + done.stderr
    return done, json.loads(report.read_text())


def _lost_digit(text: str) -> str:
    """``text`` without the first digit after the decimal point (1.7912… → 1.712…)."""
    point = text.index(".")
    return text[:point + 1] + text[point + 2:]


@pytest.mark.parametrize(("robot", "joint", "edit"), [
    ("delta", "arm_2_joint", lambda text: repr(float(text) + 0.1)),
    ("ur10", "shoulder_lift_joint", _lost_digit),
], ids=["delta one joint 0.1 rad off", "ur10 a digit lost"])
def test_a_wrong_joint_reading_is_rejected_and_named(robot: str, joint: str, edit: Any, tmp_path: Path) -> None:
    clean = _simulated(robot, tmp_path / "data")
    before, after = _with_reading(clean, tmp_path / "bad.csv", BAD_SAMPLE, joint, edit)
    assert abs(after - before) > 0.05  # the edit is a gross error, far beyond the readings' noise
    _, good = _calibrated(robot, clean, tmp_path, "clean")
    done, bad = _calibrated(robot, tmp_path / "bad.csv", tmp_path, "bad")
    assert bad["down_weighted_samples"] == [BAD_SAMPLE]
    listed = bad["down_weighted"][0]
    assert listed["sample"] == BAD_SAMPLE and listed["weight"] < 1e-3
    assert f"  - sample {BAD_SAMPLE}: weight " in done.stdout
    assert bad["dropped_samples"] == [] and bad["n_samples"] == good["n_samples"]  # kept in the file's account
    assert bad["test_rms_after"] <= 1.5 * good["test_rms_after"]
    assert bad["plausible"] and not bad["implausible"]


def test_the_fit_without_the_rejected_sample_is_the_fit_with_it_rejected(tmp_path: Path) -> None:
    """Rejecting the sample leaves the others' estimate where deleting the sample from the file does (to within
    the estimates' standard deviations)."""
    clean = _simulated("delta", tmp_path / "data")
    _with_reading(clean, tmp_path / "bad.csv", BAD_SAMPLE, "arm_2_joint", lambda text: repr(float(text) + 0.1))
    lines = clean.read_text().splitlines()
    (tmp_path / "without.csv").write_text("\n".join(
        line for line in lines if not line.startswith(f"{BAD_SAMPLE},train,")) + "\n")
    _, bad = _calibrated("delta", tmp_path / "bad.csv", tmp_path, "bad")
    _, without = _calibrated("delta", tmp_path / "without.csv", tmp_path, "without")
    compared = 0
    for name, estimate in without["parameters"].items():
        if estimate["identified"] and bad["parameters"][name]["identified"]:
            # within one standard deviation: the kept samples weigh by the Cauchy loss there, all 1 here
            assert abs(bad["parameters"][name]["value"] - estimate["value"]) <= estimate["std"], name
            compared += 1
    assert compared > 20
    assert abs(bad["test_rms_after"] - without["test_rms_after"]) <= 0.05 * without["test_rms_after"]
