"""The command line as a user runs it: info, simulate, calibrate, demo; errors as one line."""

from __future__ import annotations

import json
from pathlib import Path

import numpy as np
import pytest
from conftest import ROBOTS

import pincal
from pincal.cli.app import main


def test_info_describes_the_delta(capsys: pytest.CaptureFixture[str]) -> None:
    assert main(["info", str(ROBOTS / "delta.urdf")]) == 0
    out = capsys.readouterr().out
    assert "leg_1_platform" in out and "spherical" in out
    assert "mobility 3" in out and "actuated joints (3): arm_1_joint, arm_2_joint, arm_3_joint" in out


def test_info_bad_file_is_one_line(tmp_path: Path, capsys: pytest.CaptureFixture[str]) -> None:
    bad = tmp_path / "bad.urdf"
    bad.write_text((ROBOTS / "delta.urdf").read_text().replace('type="spherical"', 'type="ball"', 1))
    assert main(["info", str(bad)]) == 2
    err = capsys.readouterr().err.strip().splitlines()
    assert len(err) == 1 and err[0].startswith("pincal: error:") and "type 'ball'" in err[0]
    with pytest.raises(pincal.LoopError):
        main(["--debug", "info", str(bad)])


def test_simulate_then_calibrate(tmp_path: Path, capsys: pytest.CaptureFixture[str]) -> None:
    sim = tmp_path / "sim"
    assert main(["simulate", "delta", "--samples", "40", "--test-samples", "10", "--measure", "position",
                 "--perturb", "1e-3", "--noise", "0", "--seed", "2", "--parameters", "model24", "--out", str(sim)]) == 0
    assert {p.name for p in sim.iterdir()} == {"measurements.csv", "truth.urdf", "truth.json"}
    truth = pincal.load_robot(sim / "truth.urdf")  # the true robot closes at zero: it loads
    assert truth.mobility() == 3
    out_urdf, report = tmp_path / "cal.urdf", tmp_path / "report.json"
    assert main(["calibrate", "delta", str(sim / "measurements.csv"), "--parameters", "model24",
                 "--out", str(out_urdf), "--report", str(report)]) == 0
    data = json.loads(report.read_text())
    for key in ("rms_before", "rms_after", "max_before", "max_after", "n_samples", "n_parameters", "n_identifiable",
                "condition_number", "iterations", "converged", "parameters"):
        assert key in data
    assert data["n_samples"] == 40 and data["n_parameters"] == 24 and data["n_identifiable"] == 21
    assert data["converged"] and data["rms_after"] < 1e-9 < 1e-4 < data["rms_before"]
    assert data["test_rms_after"] < 1e-9
    assert len(data["unidentifiable"]) == 3
    # the calibrated file loads and predicts what the truth does, at the same readings
    calibrated = pincal.load_robot(out_urdf)
    rng = np.random.default_rng(0)
    for _ in range(5):
        qa = rng.uniform(-0.3, 0.6, 3)
        p_cal = calibrated.placement(calibrated.solve_fk(qa), "end_effector").translation
        p_true = truth.placement(truth.solve_fk(qa), "end_effector").translation
        np.testing.assert_allclose(p_cal, p_true, atol=1e-9)
    text = out_urdf.read_text()
    assert "<loop" in text and "<transmission" in text and "calibrated by pincal" in text


def test_calibrate_missing_column_is_one_line(tmp_path: Path, capsys: pytest.CaptureFixture[str]) -> None:
    data = tmp_path / "m.csv"
    data.write_text("arm_1_joint,arm_2_joint,position:end_effector:x,position:end_effector:y,position:end_effector:z\n"
                    "0,0,0,0,-0.2\n0.1,0,0,0,-0.3\n")
    assert main(["calibrate", "delta", str(data)]) == 2
    err = capsys.readouterr().err
    assert err.count("\n") == 1 and "arm_3_joint" in err


def test_demo_writes_its_files(tmp_path: Path, capsys: pytest.CaptureFixture[str]) -> None:
    assert main(["demo", "--out", str(tmp_path / "demo"), "--samples", "30", "--test-samples", "10"]) == 0
    out = capsys.readouterr().out
    assert "RMS position error (held out)" in out and "wrote" in out
    report = json.loads((tmp_path / "demo" / "report.json").read_text())
    assert report["test_rms_after"] < 0.1 * report["test_rms_before"]
    assert pincal.load_robot(tmp_path / "demo" / "delta_calibrated.urdf").mobility() == 3


def test_calibrate_with_the_implicit_formulation(tmp_path: Path) -> None:
    sim = tmp_path / "sim"
    assert main(["simulate", "delta", "--samples", "30", "--test-samples", "10", "--noise", "0", "--seed", "4",
                 "--parameters", "model24", "--out", str(sim)]) == 0
    report = tmp_path / "r.json"
    assert main(["calibrate", "delta", str(sim / "measurements.csv"), "--parameters", "model24", "--formulation", "ikm",
                 "--report", str(report)]) == 0
    data = json.loads(report.read_text())
    assert data["formulation"] == "ikm" and data["converged"]
    assert data["test_rms_after"] < 1e-9 < 1e-4 < data["test_rms_before"]


def test_unknown_frame_is_one_line(tmp_path: Path, capsys: pytest.CaptureFixture[str]) -> None:
    assert main(["simulate", "delta", "--measure", "pose", "--frame", "nope", "--out", str(tmp_path)]) == 2
    err = capsys.readouterr().err.strip().splitlines()
    assert len(err) == 1 and "frame 'nope' does not exist" in err[0] and "end_effector" in err[0]
