"""Cameras through the command line: simulate, calibrate with the defaults, and the calibrated URDF's camera and
target links reproduce what the camera sees; a job file maps a camera's columns in millimetres."""

from __future__ import annotations

import json
from pathlib import Path

import numpy as np
import pinocchio as pin
import pytest
from conftest import run_pincal

import pincal
from pincal.identification import measurements as ms
from pincal.identification.parameters import choose_parameters
from pincal.io.dataset import Dataset, write_dataset
from pincal.study.simulation import simulate_observations

#: Per setup: the measurement key, the links of the calibrated URDF whose relative placement is what the camera
#: reads (camera, then what it sees), and whether the values are a pose.
SETUPS = {
    "eye-in-hand pose": ("camera:tool0", "tool0_camera", "camera_target", True),
    "eye-in-hand point": ("camera_point:tool0", "tool0_camera", "camera_target", False),
    "eye-to-hand pose": ("pose:tool0@tag", "measurement_frame", "tool0_target_tag", True),
}


@pytest.mark.parametrize("setup", list(SETUPS))
def test_a_camera_calibrates_with_the_defaults_and_its_links_reproduce_what_it_sees(tmp_path: Path,
                                                                                       setup: str) -> None:
    key, camera_link, seen_link, is_pose = SETUPS[setup]
    sim = run_pincal("simulate", "ur10", "--measure", key, "--samples", "50", "--test-samples", "20", "--seed", "2",
                     "--quiet", "--out", str(tmp_path))
    assert sim.returncode == 0, sim.stderr
    data = tmp_path / "measurements.csv"
    out, report = tmp_path / "cal.urdf", tmp_path / "report.json"
    done = run_pincal("calibrate", "ur10", str(data), "--out", str(out), "--report", str(report))
    assert done.returncode == 0, done.stderr
    result = json.loads(report.read_text())
    # mm before (the nominal robot with its camera and target registered) and from the start (placed in closed
    # form), the noise level after
    assert result["test_rms_after"] < 5e-5 < 1e-3 < min(result["test_rms_before"], result["test_rms_start"])
    assert "in closed form (hand-eye)" in result["start_means"] and "(registered" in result["before_means"]
    assert result["rms_before"] < result["rms_start"]  # the registration fits the training postures better
    # the calibrated URDF: the camera link and the link it sees, at the raw readings, give the readings
    dataset = pincal.read_dataset(data)
    robot = pincal.load_robot(out)
    model, fk = robot.model, robot.model.createData()
    held_out = [k for k, s in enumerate(dataset.sets) if s == "test"]
    errors = []
    for k in held_out:
        q = pin.neutral(model)
        for name, value in zip(dataset.joint_names, dataset.joints[k], strict=True):
            q[model.joints[model.getJointId(name)].idx_q] = value
        pin.framesForwardKinematics(model, fk, q)
        seen = fk.oMf[model.getFrameId(camera_link)].inverse() * fk.oMf[model.getFrameId(seen_link)]
        measured = dataset.measurements[key][k]
        errors.append(np.linalg.norm(seen.translation - measured[:3]))
        if is_pose:
            rotation = pin.Quaternion(measured[6], *measured[3:6]).matrix()
            errors.append(np.linalg.norm(pin.log3(rotation.T @ seen.rotation)))
    assert max(errors) < 1e-4  # [m, rad]: the noise (1e-5) and the calibration's error, nothing more


def test_a_job_maps_a_camera_s_columns_in_millimetres(tmp_path: Path) -> None:
    """The camera wrote its own columns (cam_x … in mm, the quaternion as w first) and the joints as it names them."""
    sim = run_pincal("simulate", "ur10", "--measure", "camera:tool0", "--samples", "40", "--seed", "5", "--quiet",
                     "--out", str(tmp_path))
    assert sim.returncode == 0, sim.stderr
    dataset = pincal.read_dataset(tmp_path / "measurements.csv")
    values = dataset.measurements["camera:tool0"]
    columns = ["j1", "j2", "j3", "j4", "j5", "j6", "cam_x", "cam_y", "cam_z", "qw", "qx", "qy", "qz"]
    rows = [",".join(columns)]
    for joints, v in zip(dataset.joints, values, strict=True):
        rows.append(",".join(f"{c:.12g}" for c in [*joints, *(1e3 * v[:3]), v[6], *v[3:6]]))
    (tmp_path / "camera.csv").write_text("\n".join(rows) + "\n")
    joints = "\n".join(f'{name} = "j{k + 1}"' for k, name in enumerate(dataset.joint_names))
    (tmp_path / "job.toml").write_text(f'''robot = "ur10"
out = "cal.urdf"

[data]
file = "camera.csv"
units = {{length = "mm", angle = "rad"}}
held_out = "every 4th"

[joints]
{joints}

[[measure]]
kind = "camera"
frame = "tool0"
columns = ["cam_x", "cam_y", "cam_z", "qx", "qy", "qz", "qw"]
sigma = 1e-5
sigma_angle = 1e-5
''')
    done = run_pincal("calibrate", str(tmp_path / "job.toml"), "--report", str(tmp_path / "report.json"))
    assert done.returncode == 0, done.stderr
    result = json.loads((tmp_path / "report.json").read_text())
    assert result["test_rms_after"] < 5e-5 and result["n_test_samples"] == 10
    assert '<link name="tool0_camera"/>' in (tmp_path / "cal.urdf").read_text()


@pytest.mark.parametrize(("column", "message"), [
    ("camera:flange_of_nothing:x", "pincal: error: frame 'flange_of_nothing' does not exist in robot 'ur10'"),
    ("pose:tool0@:x", "pincal: error: bad.csv: header (line 1): column 'pose:tool0@:x': measurement 'pose:tool0@' "
                      "must name a frame and a target as 'pose:<frame>@<target>'"),
])
def test_a_camera_column_naming_no_frame_is_one_line(tmp_path: Path, column: str, message: str) -> None:
    key = column.rsplit(":", 1)[0]
    components = ["x", "y", "z", "qx", "qy", "qz", "qw"]
    header = ",".join(["shoulder_pan_joint", "shoulder_lift_joint", "elbow_joint", "wrist_1_joint", "wrist_2_joint",
                       "wrist_3_joint", *(f"{key}:{c}" for c in components)])
    row = ",".join(["0.1"] * 6 + ["0.1", "0.2", "0.3", "0", "0", "0", "1"])
    (tmp_path / "bad.csv").write_text(f"{header}\n{row}\n{row.replace('0.1', '0.2', 6)}\n")
    done = run_pincal("calibrate", "ur10", str(tmp_path / "bad.csv"), "--out", str(tmp_path / "cal.urdf"))
    assert done.returncode == 2
    assert done.stderr.startswith(message) and len(done.stderr.strip().splitlines()) == 1, done.stderr


@pytest.mark.parametrize("key", ["camera:tool0", "pose:tool0@tag"])
def test_a_camera_reading_whose_quaternion_is_not_unit_is_refused(tmp_path: Path, key: str) -> None:
    """A pose a camera read is checked as any pose: a quaternion of norm 1.01 is refused, naming the line."""
    header = ",".join(["shoulder_pan_joint", "shoulder_lift_joint", "elbow_joint", "wrist_1_joint", "wrist_2_joint",
                       "wrist_3_joint", *(f"{key}:{c}" for c in ["x", "y", "z", "qx", "qy", "qz", "qw"])])
    rows = [",".join([f"0.{k}"] * 6 + ["0.1", "0.2", "0.3", "0", "0", "0", "1.01" if k == 2 else "1"])
            for k in range(1, 6)]
    (tmp_path / "bad.csv").write_text("\n".join([header, *rows]) + "\n")
    done = run_pincal("calibrate", "ur10", str(tmp_path / "bad.csv"), "--out", str(tmp_path / "cal.urdf"))
    assert done.returncode == 2, done.stderr
    assert done.stderr.startswith(f"pincal: error: bad.csv: measurement '{key}', line 3: quaternion"), done.stderr
    assert "has norm 1.01" in done.stderr and not (tmp_path / "cal.urdf").exists()


@pytest.mark.parametrize(("key", "draws_points"), [("camera:tool0", False), ("pose:tool0@tag", True)])
def test_view_draws_no_point_where_a_camera_on_the_robot_reads_its_target(tmp_path: Path, key: str,
                                                                          draws_points: bool) -> None:
    """An eye-in-hand reading is the target in the moving camera's frame, not a point of the scene: the view draws the
    calibrated end effector with no error segment; an eye-to-hand reading is in the fixed camera's frame."""
    sim = run_pincal("simulate", "ur10", "--measure", key, "--samples", "20", "--seed", "2", "--quiet",
                     "--out", str(tmp_path))
    assert sim.returncode == 0, sim.stderr
    done = run_pincal("view", "ur10", str(tmp_path / "measurements.csv"), "--quiet", "--out", str(tmp_path / "s.html"))
    assert done.returncode == 0, done.stderr
    assert ("errors magnified" in done.stdout) is draws_points, done.stdout


def test_the_summary_says_why_a_camera_start_was_not_found_in_closed_form(tmp_path: Path) -> None:
    """Only the UR10's first joint turns, about z: neither hand-eye closed form (rotations about two axes, or none
    at all for a link that only translates) can place the camera; the fit's start says why."""
    robot = pincal.load_robot("ur10")
    model = ms.camera_pose("tool0")
    pset = choose_parameters(robot, [model])
    qa = np.tile([0.0, -1.2, 1.3, -0.4, 1.1, 0.3], (20, 1))
    qa[:, 0] = np.linspace(-1.0, 1.0, 20)
    x_true = pset.vector({"camera.tool0.tz": 0.1, "target.tx": 1.0})
    obs = simulate_observations(robot, pset, x_true, [model], qa, np.random.default_rng(1), noise=1e-5)
    data = tmp_path / "one_axis.csv"
    write_dataset(Dataset(list(robot.actuated_joints), qa, {model.key: obs.values[model.key]},
                          [str(k) for k in range(20)], ["train"] * 20, {"robot": "ur10"}), data)
    done = run_pincal("calibrate", "ur10", str(data), "--report", str(tmp_path / "r.json"))
    assert done.returncode == 0, done.stderr
    start = json.loads((tmp_path / "r.json").read_text())["start_means"]
    assert "at the identity" in start and "camera:tool0: " in start, start
    assert "the rotations of A_i differ only about z" in start
    why = start.split("for fit and held-out samples alike; ", 1)[1]
    assert f"{' '.join(why.split())})" in " ".join(done.stdout.split())  # the summary says why, within 120 columns
    assert all(len(line) <= 120 for line in done.stdout.splitlines())


def _reading_errors(urdf: Path, data: Path, key: str, camera_link: str, seen_link: str) -> list[float]:
    """Position [m] and angle [rad] errors of the file's camera link → seen link placement against every reading."""
    dataset = pincal.read_dataset(data)
    model = pincal.load_robot(urdf).model
    fk = model.createData()
    errors = []
    for joints, measured in zip(dataset.joints, dataset.measurements[key], strict=True):
        q = pin.neutral(model)
        for name, value in zip(dataset.joint_names, joints, strict=True):
            q[model.joints[model.getJointId(name)].idx_q] = value
        pin.framesForwardKinematics(model, fk, q)
        seen = fk.oMf[model.getFrameId(camera_link)].inverse() * fk.oMf[model.getFrameId(seen_link)]
        rotation = pin.Quaternion(measured[6], *measured[3:6]).matrix()
        errors += [float(np.linalg.norm(seen.translation - measured[:3])),
                   float(np.linalg.norm(pin.log3(rotation.T @ seen.rotation)))]
    return errors


def test_a_calibrated_urdf_with_a_camera_is_recalibrated(tmp_path: Path) -> None:
    """docs/calibrated_urdf.md, "Recalibrating a calibrated file": the camera and world target links of the first
    calibration get the new placements (they were refused as names taken); the target stays in the robot's world
    when the file's root is the tracker's measurement frame (a camera and a tracked point here)."""
    sim = run_pincal("simulate", "ur10", "--measure", "camera:tool0", "position", "--frame", "tool0", "--samples", "40",
                     "--seed", "3", "--quiet", "--out", str(tmp_path))
    assert sim.returncode == 0, sim.stderr
    data, first, second = tmp_path / "measurements.csv", tmp_path / "cal.urdf", tmp_path / "cal2.urdf"
    done = run_pincal("calibrate", "ur10", str(data), "--out", str(first))
    assert done.returncode == 0, done.stderr
    done = run_pincal("calibrate", str(first), str(data), "--out", str(second))
    assert done.returncode == 0, done.stderr
    text = second.read_text()
    assert text.count('<link name="tool0_camera"/>') == 1 and text.count('<link name="camera_target"/>') == 1
    assert max(_reading_errors(second, data, "camera:tool0", "tool0_camera", "camera_target")) < 1e-4


def test_a_camera_reading_with_some_cells_empty_is_refused_as_a_target_not_seen(tmp_path: Path) -> None:
    header = ",".join(["shoulder_pan_joint", "shoulder_lift_joint", "elbow_joint", "wrist_1_joint", "wrist_2_joint",
                       "wrist_3_joint", *(f"camera:tool0:{c}" for c in ["x", "y", "z", "qx", "qy", "qz", "qw"])])
    rows = [",".join([f"0.{k}"] * 6 + (["", "", ""] if k == 2 else ["0.1", "0.2", "0.3"]) + ["0", "0", "0", "1"])
            for k in range(1, 6)]
    (tmp_path / "half.csv").write_text("\n".join([header, *rows]) + "\n")
    done = run_pincal("calibrate", "ur10", str(tmp_path / "half.csv"))
    assert done.returncode == 2, done.stderr
    assert done.stderr.startswith("pincal: error: half.csv: column 'camera:tool0:x', line 3: the cell is empty")
    assert "a target that was not seen leaves all the cells of 'camera:tool0' empty" in done.stderr, done.stderr


def test_the_html_report_gives_a_camera_s_orientation_errors(tmp_path: Path) -> None:
    """``pincal report`` on camera readings: the orientation rows (fit and held out, before and after, in mrad) beside
    the position rows, the same figures as the report JSON of ``calibrate``."""
    sim = run_pincal("simulate", "ur10", "--measure", "camera:tool0", "--samples", "30", "--test-samples", "10",
                     "--seed", "3", "--quiet", "--out", str(tmp_path))
    assert sim.returncode == 0, sim.stderr
    data, page, report = tmp_path / "measurements.csv", tmp_path / "report.html", tmp_path / "report.json"
    assert run_pincal("report", "ur10", str(data), "--quiet", "--out", str(page)).returncode == 0
    assert run_pincal("calibrate", "ur10", str(data), "--report", str(report)).returncode == 0
    result, text = json.loads(report.read_text()), page.read_text()
    for label, before, after in (("RMS orientation error (fit)", "rms_angle_before", "rms_angle_after"),
                                 ("RMS orientation error (held out)", "test_rms_angle_before", "test_rms_angle_after")):
        row = (f"<tr><td>{label}</td><td class='before'>{result[before] * 1e3:.4f} mrad</td>"
               f"<td class='after'>{result[after] * 1e3:.4f} mrad</td></tr>")
        assert row in text, label
    assert result["test_rms_angle_after"] < 1e-4 < 1e-3 < result["test_rms_angle_before"]
