"""``pincal drift`` as a user runs it: sessions of one simulated Delta (``simulate --posture-seed``), the calibration's
robot unchanged in the first two and one arm's offset slipped by 2 mrad from the third (``--shift``): nothing named
before it, that joint's offset named from it on with its shift, the recalibration command that brings the error back
down; bad inputs refused in one line. The false-alarm rate over 100 seeds is measured in
examples/drift_sessions.py, not here."""

from __future__ import annotations

import json
import re
from pathlib import Path

import pytest
from conftest import run_pincal

SLIP = 0.002  # [rad]


def _session(folder: Path, name: str, posture_seed: int, *extra: str) -> str:
    done = run_pincal("simulate", "delta", "--samples", "30", "--seed", "1", "--posture-seed", str(posture_seed),
                      "--quiet", "--out", name, *extra, cwd=folder)
    assert done.returncode == 0, done.stderr
    return f"{name}/measurements.csv"


@pytest.fixture(scope="module")
def calibrated(tmp_path_factory: pytest.TempPathFactory) -> Path:
    folder = tmp_path_factory.mktemp("drift")
    day1 = run_pincal("simulate", "delta", "--samples", "40", "--seed", "1", "--quiet", "--out", "day1", cwd=folder)
    assert day1.returncode == 0, day1.stderr
    done = run_pincal("calibrate", "delta", "day1/measurements.csv", "--out", "cal.urdf", cwd=folder)
    assert done.returncode == 0, done.stderr
    return folder


def test_a_slipped_offset_is_named_from_its_session_on_and_nothing_before(calibrated: Path) -> None:
    sessions = [_session(calibrated, "s1", 11), _session(calibrated, "s2", 12),
                _session(calibrated, "s3", 13, "--shift", f"arm_2_joint.offset={SLIP}"),
                _session(calibrated, "s4", 14, "--shift", f"arm_2_joint.offset={SLIP}")]
    done = run_pincal("drift", "cal.urdf", *sessions, "--report", "drift.json", "--html", "drift.html",
                      cwd=calibrated)
    assert done.returncode == 1, done.stderr  # a change: exit 1
    report = json.loads((calibrated / "drift.json").read_text(encoding="utf-8"))
    verdicts = [(s["changed"], [g["group"] for g in s["moved"]]) for s in report["sessions"]]
    assert verdicts == [(False, []), (False, []), (True, ["arm_2_joint.offset"]), (True, ["arm_2_joint.offset"])]
    for session in report["sessions"][2:]:
        (group,) = session["moved"]
        assert abs(group["shifts"][0] - SLIP) < 5 * group["std"][0] + 1e-4
    for session in report["sessions"][:2]:  # within what the calibration predicts
        assert session["statistic"] < session["threshold"] and session["rms"] < 2 * session["expected_rms"]
    assert report["sessions"][2]["rms"] > 5 * report["sessions"][2]["expected_rms"]
    command = report["command"]
    assert command == ("pincal calibrate cal.urdf s4/measurements.csv --parameters arm_2_joint.offset 'base.*' "
                       "'marker.*' --out cal_recalibrated.urdf")
    assert f"advice: recalibrate arm_2_joint.offset (from MODEL, the setup with them): {command}" in done.stdout
    page = (calibrated / "drift.html").read_text(encoding="utf-8")
    assert "<h2>Error over time</h2>" in page and 'src="data:image/png;base64,' in page
    recalibrated = run_pincal(*command.replace("'", "").split()[1:], cwd=calibrated)
    assert recalibrated.returncode == 0, recalibrated.stderr
    later = _session(calibrated, "s5", 15, "--shift", f"arm_2_joint.offset={SLIP}")
    check = run_pincal("check", "cal_recalibrated.urdf", later, "--register", "--report", "check.json",
                       cwd=calibrated)
    assert check.returncode == 0, check.stderr
    assert json.loads((calibrated / "check.json").read_text(encoding="utf-8"))["rms"] < 2 * report["sessions"][0]["rms"]


def test_sessions_of_noise_alone_name_nothing(calibrated: Path) -> None:
    sessions = [_session(calibrated, "n1", 21), _session(calibrated, "n2", 22)]
    done = run_pincal("drift", "cal.urdf", *sessions, cwd=calibrated)
    assert done.returncode == 0, done.stdout + done.stderr
    assert "nothing to recalibrate" in done.stdout and done.stdout.count("unchanged") == 2


def test_a_noisier_instrument_stating_its_sigma_is_no_change_and_one_not_stating_it_is(calibrated: Path) -> None:
    """A session of three times the noise, its file's '# sigma' lines saying so, is judged by its own σ; the same
    file without them, by the calibration's, is a change."""
    stated = _session(calibrated, "noisy", 31, "--noise", "3e-5")
    lines = (calibrated / stated).read_text(encoding="utf-8").splitlines()
    (calibrated / "unstated.csv").write_text("\n".join(line for line in lines if not line.startswith("# sigma")) + "\n",
                                             encoding="utf-8")
    done = run_pincal("drift", "cal.urdf", stated, "unstated.csv", "--report", "noisy.json", cwd=calibrated)
    report = json.loads((calibrated / "noisy.json").read_text(encoding="utf-8"))
    verdicts = [s["changed"] for s in report["sessions"]]
    assert verdicts == [False, True] and done.returncode == 1, done.stdout
    # noise is no parameter's shift: no group named, the advice is to measure again or calibrate anew
    assert [g for s in report["sessions"] for g in s["moved"]] == []
    command = "pincal calibrate delta unstated.csv --out cal_recalibrated.urdf"
    assert report["command"] == command
    assert ("advice: unstated.csv changed beyond the calibration's predicted spread, but no parameter group explains "
            f"it alone: measure again, or calibrate anew: {command}") in done.stdout


def test_a_job_file_session_is_judged_as_its_csv(calibrated: Path) -> None:
    session = _session(calibrated, "job", 41)
    (calibrated / "job" / "job.toml").write_text(
        'robot = "delta"\n[data]\nfile = "measurements.csv"\nignore = ["set"]\nsample = "sample"\n[[measure]]\n'
        'kind = "position"\nframe = "end_effector"\n'
        'columns = ["position:end_effector:x", "position:end_effector:y", "position:end_effector:z"]\n',
        encoding="utf-8")
    done = run_pincal("drift", "cal.urdf", "job/job.toml", session, "--report", "job.json", cwd=calibrated)
    assert done.returncode == 0, done.stdout + done.stderr
    first, second = json.loads((calibrated / "job.json").read_text(encoding="utf-8"))["sessions"]
    assert first["n_samples"] == second["n_samples"] == 30
    assert first["statistic"] == pytest.approx(second["statistic"], rel=1e-9)


@pytest.mark.parametrize(("arguments", "message"), [
    (["delta", "n1/measurements.csv"], "MODEL 'delta' is not a calibrated URDF file"),
    (["day1/truth.urdf", "n1/measurements.csv"], "carries no pincal calibration"),
    (["cal.urdf", "n1/measurements.csv", "--level", "0.7"], "0.7 is not between 0 and 0.5"),
    (["cal.urdf", "cal.urdf", "--report", "cal.urdf"], "cal.urdf"),
])
def test_drift_refuses_bad_inputs_in_one_line(calibrated: Path, arguments: list[str], message: str) -> None:
    if not (calibrated / "n1").is_dir():
        _session(calibrated, "n1", 21)
    before = (calibrated / "cal.urdf").read_bytes()
    done = run_pincal("drift", *arguments, cwd=calibrated)
    assert done.returncode == 2 and done.stderr.count("\n") == 1 and message in done.stderr, done.stderr
    assert re.match(r"pincal: error: ", done.stderr) and (calibrated / "cal.urdf").read_bytes() == before


def test_the_calibration_s_own_data_and_a_session_given_twice_are_warned_of(calibrated: Path) -> None:
    s1 = _session(calibrated, "w1", 21)
    done = run_pincal("drift", "cal.urdf", "day1/measurements.csv", s1, s1, "--report", "w.json", "--html", "w.html",
                      cwd=calibrated)
    assert done.returncode == 0, done.stdout + done.stderr
    assert ("warning: session 'day1/measurements.csv' is the data MODEL was calibrated from: its residuals were "
            "fitted, not predicted") in done.stdout
    assert f"warning: session '{s1}' is given twice: judged twice" in done.stdout
    assert len(json.loads((calibrated / "w.json").read_text())["warnings"]) == 2
    assert (calibrated / "w.html").read_text().count('<p class="warn">Warning: session') == 2
