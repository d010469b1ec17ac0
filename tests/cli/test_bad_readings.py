"""A wrong joint reading in one fitted sample (one joint off, a digit lost) or a loop that cannot close at one
sample's readings: ``pincal calibrate`` ends exit 0, as accurate as on the clean file (a wrong reading: as without
its sample), and names the sample and the joint; the clean files name none.

Each case edits one cell of a campaign ``pincal simulate`` wrote. The five-bar and hexapod cases take 6-10 s: their
least-squares first pass, pulled 0.1 m or 20 mm by the wrong reading, takes 50-140 iterations before the robust
refits."""

from __future__ import annotations

import json
from collections.abc import Callable
from pathlib import Path
from typing import Any

import pytest
from conftest import run_pincal

#: Simulated campaigns, by robot: ``pincal simulate`` arguments.
CAMPAIGNS = {
    "delta": ["--samples", "60", "--test-samples", "20", "--seed", "1"],
    "ur10": ["--samples", "60", "--test-samples", "20", "--seed", "1"],
    "five_bar": ["--samples", "30", "--test-samples", "10", "--seed", "1"],
    "hexapod": ["--samples", "60", "--test-samples", "20", "--seed", "1"],
}


@pytest.fixture(scope="module")
def campaigns(tmp_path_factory: pytest.TempPathFactory) -> Callable[[str], tuple[Path, dict[str, Any]]]:
    """The clean simulated file of a robot and the report of its default calibration, made once per robot."""
    made: dict[str, tuple[Path, dict[str, Any]]] = {}

    def campaign(robot: str) -> tuple[Path, dict[str, Any]]:
        if robot not in made:
            out = tmp_path_factory.mktemp(robot)
            done = run_pincal("simulate", robot, *CAMPAIGNS[robot], "--quiet", "--out", str(out))
            assert done.returncode == 0, done.stderr
            _, report = _calibrated(robot, out / "measurements.csv", out, "clean")
            made[robot] = (out / "measurements.csv", report)
        return made[robot]

    return campaign


def _with_reading(clean: Path, out: Path, sample: str, joint: str, edit: Callable[[str], str]) -> tuple[float, float]:
    """``clean`` with fitted ``sample``'s reading of ``joint`` replaced by ``edit(text)``, written to ``out``; the
    reading before and after [rad or m]."""
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


def _without(clean: Path, out: Path, sample: str) -> Path:
    """``clean`` without its fitted ``sample``, written to ``out``."""
    lines = clean.read_text().splitlines()
    out.write_text("\n".join(line for line in lines if line.split(",")[:2] != [sample, "train"]) + "\n")
    return out


def _calibrated(robot: str, data: Path, where: Path, name: str) -> tuple[Any, dict[str, Any]]:
    """``pincal calibrate ROBOT DATA --out … --report …`` (exit 0 asserted); its run and its report."""
    report = where / f"{name}.json"
    done = run_pincal("calibrate", robot, str(data), "--out", str(where / f"{name}.urdf"), "--report", str(report))
    assert done.returncode == 0, done.stdout + done.stderr
    return done, json.loads(report.read_text())


def _lost_digit(text: str) -> str:
    """``text`` without the first digit after the decimal point (0.0762… → 0.762…, -0.604… → -0.04…)."""
    point = text.index(".")
    return text[:point + 1] + text[point + 2:]


def _off_by(change: float) -> Callable[[str], str]:
    return lambda text: repr(float(text) + change)


@pytest.mark.parametrize(("robot", "sample", "joint", "edit"), [
    ("delta", "17", "arm_2_joint", _off_by(0.1)),
    ("delta", "11", "arm_2_joint", _off_by(0.1)),
    ("delta", "17", "arm_1_joint", _lost_digit),
    ("ur10", "17", "shoulder_lift_joint", _lost_digit),
    ("five_bar", "7", "theta_1_joint", _off_by(0.3)),
    ("hexapod", "17", "leg_1_prismatic", _off_by(0.03)),
], ids=["delta arm_2 0.1 rad off", "delta arm_2 0.1 rad off (refused as implausible before)",
        "delta a digit lost", "ur10 a digit lost", "five_bar crank 0.3 rad off", "hexapod leg 30 mm off"])
def test_a_wrong_joint_reading_is_named_and_left_out(campaigns: Callable[[str], tuple[Path, dict[str, Any]]],
                                                      robot: str, sample: str, joint: str,
                                                      edit: Callable[[str], str], tmp_path: Path) -> None:
    clean, good = campaigns(robot)
    before, after = _with_reading(clean, tmp_path / "bad.csv", sample, joint, edit)
    done, bad = _calibrated(robot, tmp_path / "bad.csv", tmp_path, "bad")
    [named] = bad["bad_readings"]
    assert named["sample"] == sample and named["joint"] == joint
    assert named["off"] == pytest.approx(after - before, abs=0.002)  # rad or m: the edit, found from the data
    assert named["explained"] > 0.99
    assert sample in bad["down_weighted_samples"] and bad["dropped_samples"] == []
    assert f"  - sample {sample}: {joint} reading looks " in done.stdout
    # as accurate as the clean file without the sample whose reading is wrong (left out, the posture is lost: on the
    # five-bar's 30 postures that alone costs 7 % of the held-out RMS); the wrong reading costs nothing more
    _, spared = _calibrated(robot, _without(clean, tmp_path / "spared.csv", sample), tmp_path, "spared")
    assert bad["test_rms_after"] <= 1.1 * spared["test_rms_after"]
    assert bad["implausible"] == [] and bad["converged"]
    assert good["bad_readings"] == []  # the clean file names none


def test_a_wrong_position_is_not_taken_for_a_wrong_reading(
        campaigns: Callable[[str], tuple[Path, dict[str, Any]]], tmp_path: Path) -> None:
    """A measured position 5 mm off (no joint reading explains it) is down-weighted by the robust loss, not named."""
    clean, good = campaigns("ur10")
    _with_reading(clean, tmp_path / "bad.csv", "17", "position:tool0:x", _off_by(0.005))
    done, bad = _calibrated("ur10", tmp_path / "bad.csv", tmp_path, "bad")
    assert bad["bad_readings"] == [] and "17" in bad["down_weighted_samples"]
    assert "bad joint readings" not in done.stdout
    assert bad["test_rms_after"] <= 1.1 * good["test_rms_after"]


def test_a_loop_that_cannot_close_at_one_samples_readings_drops_that_sample(
        campaigns: Callable[[str], tuple[Path, dict[str, Any]]], tmp_path: Path) -> None:
    """A hexapod leg read 0.4 m long: the loops cannot be assembled there; that sample is dropped with the reason."""
    clean, good = campaigns("hexapod")
    _with_reading(clean, tmp_path / "bad.csv", "17", "leg_1_prismatic", _off_by(0.4))
    done, bad = _calibrated("hexapod", tmp_path / "bad.csv", tmp_path, "bad")
    [dropped] = bad["dropped_samples"]
    assert dropped["sample"] == "17"
    assert dropped["reason"].startswith("the loops cannot be assembled at its readings: forward kinematics did not "
                                        "converge")
    assert "  - sample 17: the loops cannot be assembled at its readings" in done.stdout
    assert bad["n_samples"] == good["n_samples"] - 1 and bad["bad_readings"] == []
    assert bad["test_rms_after"] <= 1.1 * good["test_rms_after"]
