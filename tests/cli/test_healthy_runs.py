"""Clean simulated campaigns calibrated with the default command: the summary raises no alarm, noise-free data
converge, and the alarms still fire where they should (issue 25).

An alarm line is one that starts with ``warning:`` or with a verdict in capitals (``NOT CONVERGED``, ``WORSE THAN
NOMINAL``, ``IMPLAUSIBLE``, ``THE FIT DOES NOT REACH``)."""

from __future__ import annotations

import json
import re
from pathlib import Path

import pytest
from conftest import run_pincal

ALARM = re.compile(r"^(warning:|NOT CONVERGED|WORSE THAN NOMINAL|IMPLAUSIBLE|THE FIT DOES NOT REACH)")


def _alarms(stdout: str) -> list[str]:
    return [line for line in stdout.splitlines() if ALARM.match(line)]


def _simulated(tmp_path: Path, robot: str, *args: str) -> Path:
    out = tmp_path / robot
    done = run_pincal("simulate", robot, *args, "--quiet", "--out", str(out))
    assert done.returncode == 0, done.stderr
    return out / "measurements.csv"


@pytest.mark.parametrize(("robot", "args"), [
    ("delta", ["--samples", "60", "--test-samples", "20", "--seed", "1"]),
    ("hexapod", ["--samples", "60", "--test-samples", "20", "--measure", "pose", "--seed", "3"]),
    ("ur10", ["--samples", "60", "--test-samples", "20", "--measure", "pose", "--seed", "1"]),
])
def test_a_clean_simulated_campaign_raises_no_alarm(tmp_path: Path, robot: str, args: list[str]) -> None:
    data = _simulated(tmp_path, robot, *args)
    report = tmp_path / "report.json"
    done = run_pincal("calibrate", robot, str(data), "--report", str(report))
    assert done.returncode == 0, done.stderr
    assert _alarms(done.stdout) == []
    content = json.loads(report.read_text())
    assert content["converged"] is True and content["held_out_outside_range"] == []
    assert content["bad_readings"] == [] and content["dropped_samples"] == []
    unseen = content["n_parameters"] - content["n_identifiable"]
    assert unseen > 0  # the default set's candidates overlap: the note says so calmly
    # in one sentence, each direction in the report only
    said = [line for line in done.stdout.splitlines() if line.startswith("not seen by these data: ")]
    assert said and said[0].startswith(f"not seen by these data: {len(content['unidentifiable'])} of "
                                       f"{content['n_parameters']} candidate directions, as expected")
    assert not any(line.startswith("  - ") for line in done.stdout.splitlines())
    # no candidate of the default set is one that moves no measurement
    assert not any(text.endswith("has no effect on the measurements") for text in content["unidentifiable"])


@pytest.mark.parametrize(("robot", "args"), [
    ("delta", ["--samples", "40", "--seed", "2"]),
    ("hexapod", ["--samples", "60", "--measure", "pose", "--seed", "3"]),
    ("ur10", ["--samples", "40", "--measure", "pose", "--seed", "3"]),
])
def test_noise_free_data_converge(tmp_path: Path, robot: str, args: list[str]) -> None:
    data = _simulated(tmp_path, robot, *args, "--noise", "0")
    report = tmp_path / "report.json"
    done = run_pincal("calibrate", robot, str(data), "--report", str(report))
    assert done.returncode == 0, done.stderr
    content = json.loads(report.read_text())
    assert content["converged"] is True and content["iterations"] <= 20
    # m: the data are reproduced far below any measurement noise; not to round-off, as the simulation also moves the
    # candidates that move no measurement at the nominal geometry (their effect at the true one is of second order)
    # and the default set leaves them out
    assert content["rms_after"] < 1e-6
    assert not any(line.startswith("NOT CONVERGED") for line in done.stdout.splitlines())


def test_an_unidentifiable_combination_of_parameters_named_one_by_one_is_a_warning(tmp_path: Path) -> None:
    """A Delta's arm offset and its rod's placement move the tool the same way: named one by one, that is a warning."""
    data = _simulated(tmp_path, "delta", "--samples", "30", "--seed", "1")
    done = run_pincal("calibrate", "delta", str(data), "--parameters", "arm_1_joint.offset", "rod_1_pitch.t*")
    assert done.returncode == 0, done.stderr
    assert any(line.startswith("warning: the parameters named are not all identifiable from these data")
               for line in _alarms(done.stdout))


def test_held_out_postures_far_outside_the_fitted_range_still_warn(tmp_path: Path) -> None:
    """Few training postures: a held-out one well past their range is still named."""
    data = _simulated(tmp_path, "delta", "--samples", "30", "--test-samples", "10", "--seed", "1")
    done = run_pincal("calibrate", "delta", str(data))
    assert done.returncode == 0, done.stderr
    assert any("outside the fitted range" in line for line in _alarms(done.stdout))


def test_default_candidates_leave_out_parameters_with_no_effect(tmp_path: Path) -> None:
    """On a hexapod measured by its platform's pose, the universal joints' and legs' placements that a loop absorbs
    move no measurement: the default set leaves them out and the report names them; named one by one, they stay and
    the summary lists them as not seen."""
    data = _simulated(tmp_path, "hexapod", "--samples", "30", "--measure", "pose", "--seed", "3")
    report = tmp_path / "default.json"
    done = run_pincal("calibrate", "hexapod", str(data), "--report", str(report))
    assert done.returncode == 0, done.stderr
    content = json.loads(report.read_text())
    assert "leg_1_prismatic.tx" in content["no_effect"] and "leg_1_prismatic.tx" not in content["parameters"]
    assert not set(content["no_effect"]) & set(content["parameters"])
    named = tmp_path / "named.json"
    done = run_pincal("calibrate", "hexapod", str(data), "--parameters", "default", "leg_1_prismatic.tx",
                      "--select", "none", "--report", str(named))
    assert done.returncode == 0, done.stderr
    content = json.loads(named.read_text())
    assert content["no_effect"] == [] and "leg_1_prismatic.tx" in content["parameters"]
    assert "leg_1_prismatic.tx has no effect on the measurements" in content["unidentifiable"]
    assert "warning: the parameters named are not all identifiable" in done.stdout
