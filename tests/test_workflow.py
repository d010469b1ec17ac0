"""What `pincal calibrate` reports, as a user runs it: honest before/after figures, orientation errors for
poses, a "before" that means the same for fit and held-out samples, refusal of a dataset with nothing to fit,
and a run that did not converge saying so everywhere."""

from __future__ import annotations

import csv
import json
from pathlib import Path

import numpy as np
import pinocchio as pin
import pytest
from conftest import run_pincal

import pincal
from pincal.dataset import read_dataset
from pincal.errors import DataError
from pincal.workflow import calibrate, simulate, write_simulation


@pytest.fixture(scope="module")
def ur10_pose(tmp_path_factory: pytest.TempPathFactory) -> Path:
    """A simulated UR10 pose dataset (30 + 10 postures, 10 µm / 10 µrad noise)."""
    out = tmp_path_factory.mktemp("ur10_pose")
    robot = pincal.load_robot("ur10")
    write_simulation(simulate(robot, ["pose"], 30, 10, perturb=1e-3, noise=1e-5, seed=3), out)
    return out / "measurements.csv"


def test_pose_data_print_orientation_errors_and_before_is_the_nominal_robot(ur10_pose: Path,
                                                                            tmp_path: Path) -> None:
    report = tmp_path / "report.json"
    done = run_pincal("calibrate", "ur10", str(ur10_pose), "--parameters", "*.offset", "--report", str(report))
    assert done.returncode == 0, done.stderr
    lines = done.stdout.splitlines()
    assert any(line.startswith("RMS orientation error (fit)") and line.endswith("mrad") for line in lines)
    assert any(line.startswith("RMS orientation error (held out)") for line in lines)
    data = json.loads(report.read_text())
    # "before" with offsets only (no measurement frame estimated) is the nominal robot: recompute it with plain
    # Pinocchio from the CSV, independently of pincal's measurement models
    robot = pincal.load_robot("ur10")
    model = robot.model
    pdata = model.createData()
    fid = model.getFrameId(robot.end_effector)
    dataset = read_dataset(ur10_pose, robot.actuated_joints)
    angles, positions = {"train": [], "test": []}, {"train": [], "test": []}
    key = f"pose:{robot.end_effector}"
    for k in range(dataset.n_samples):
        q = pin.neutral(model)
        for j, name in enumerate(dataset.joint_names):
            q[model.joints[model.getJointId(name)].idx_q] = dataset.joints[k, j]
        pin.framesForwardKinematics(model, pdata, q)
        measured = dataset.measurements[key][k]
        rot = pin.Quaternion(measured[6], *measured[3:6]).normalized().matrix()
        angles[dataset.sets[k]].append(np.linalg.norm(pin.log3(rot.T @ pdata.oMf[fid].rotation)))
        positions[dataset.sets[k]].append(np.linalg.norm(pdata.oMf[fid].translation - measured[:3]))
    rms = {s: float(np.sqrt(np.mean(np.square(v)))) for s, v in angles.items()}
    assert data["rms_angle_before"] == pytest.approx(rms["train"], rel=1e-9)
    assert data["test_rms_angle_before"] == pytest.approx(rms["test"], rel=1e-9)
    assert data["test_rms_before"] == pytest.approx(float(np.sqrt(np.mean(np.square(positions["test"])))), rel=1e-9)
    assert data["rms_angle_after"] < data["rms_angle_before"] and "nominal measurement frame" in data["before_means"]


def _shift_positions(source: Path, target: Path, offset: tuple[float, float, float]) -> None:
    """Copy a dataset with every measured position moved by ``offset`` [m] (a tracker placed elsewhere)."""
    with source.open(newline="") as f:
        rows = list(csv.reader(f))
    header = next(k for k, row in enumerate(rows) if row and row[0] == "sample")
    columns = {name: i for i, name in enumerate(rows[header])}
    for row in rows[header + 1:]:
        for axis, value in zip("xyz", offset, strict=True):
            i = columns[f"position:end_effector:{axis}"]
            row[i] = repr(float(row[i]) + value)
    with target.open("w", newline="") as f:
        csv.writer(f, lineterminator="\n").writerows(rows)


def test_before_is_the_same_model_for_fit_and_held_out_even_with_the_tracker_3_m_away(tmp_path: Path) -> None:
    sim = tmp_path / "sim"
    done = run_pincal("simulate", "delta", "--samples", "40", "--test-samples", "40", "--seed", "1", "--quiet",
                      "--out", str(sim))
    assert done.returncode == 0, done.stderr
    far = tmp_path / "far.csv"
    _shift_positions(sim / "measurements.csv", far, (3.0, -1.0, 0.5))
    report = tmp_path / "report.json"
    done = run_pincal("calibrate", "delta", str(far), "--parameters", "*.offset", "base.*", "--report", str(report))
    assert done.returncode == 0, done.stderr
    data = json.loads(report.read_text())
    # both "before" figures are the nominal robot registered to the tracker: millimetres, not metres, and the
    # same size for two sets of postures drawn alike
    assert data["rms_before"] < 0.02 and data["test_rms_before"] < 0.02
    assert 0.67 < data["test_rms_before"] / data["rms_before"] < 1.5
    assert "registered" in data["before_means"] and "registered" in done.stdout
    assert data["test_rms_after"] < data["test_rms_before"]


def test_a_dataset_with_only_held_out_rows_is_refused(tmp_path: Path) -> None:
    sim = tmp_path / "sim"
    assert run_pincal("simulate", "five_bar", "--samples", "8", "--quiet", "--out", str(sim)).returncode == 0
    text = (sim / "measurements.csv").read_text().replace(",train,", ",test,")
    only_test = tmp_path / "only_test.csv"
    only_test.write_text(text)
    done = run_pincal("calibrate", "five_bar", str(only_test), "--out", str(tmp_path / "cal.urdf"))
    assert done.returncode == 2
    assert done.stderr.strip().splitlines() == [done.stderr.strip()]
    assert done.stderr.startswith("pincal: error: all 8 samples are marked set=test")
    assert not (tmp_path / "cal.urdf").exists()
    robot = pincal.load_robot("five_bar")
    with pytest.raises(DataError, match="nothing to fit on"):
        calibrate(robot, read_dataset(only_test, robot.actuated_joints))


def test_a_run_that_did_not_converge_says_so_everywhere(tmp_path: Path) -> None:
    sim = tmp_path / "sim"
    assert run_pincal("simulate", "delta", "--samples", "40", "--seed", "4", "--quiet", "--out",
                      str(sim)).returncode == 0
    out, report = tmp_path / "cal.urdf", tmp_path / "report.json"
    done = run_pincal("calibrate", "delta", str(sim / "measurements.csv"), "--max-iter", "2", "--out", str(out),
                      "--report", str(report))
    assert done.returncode == 1
    assert done.stdout.splitlines()[0].startswith("NOT CONVERGED: iteration limit reached after 2 iterations")
    data = json.loads(report.read_text())
    assert data["converged"] is False and data["iterations"] == 2
    assert "<!-- NOT CONVERGED (iteration limit reached after 2 iterations)" in out.read_text()


def test_max_iter_must_be_a_positive_whole_number(tmp_path: Path) -> None:
    done = run_pincal("calibrate", "delta", str(tmp_path / "none.csv"), "--max-iter", "0")
    assert done.returncode == 2 and "--max-iter: 0 is not a positive whole number" in done.stderr
    assert "Traceback" not in done.stderr
