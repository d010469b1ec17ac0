"""``pincal import ROBOT BAG`` and a job file's ``[bag]`` (docs/bags.md), run as a user runs them.

A UR10 with errors of 1 mm / 1 mrad is simulated (``pincal simulate``: 24 postures to calibrate from, 10 held out, the
tool's pose measured with noise σ 0.1 mm / 0.1 mrad). Its 24 postures are recorded as the robot would stream them:
joint states at 100 Hz (shuffled, a gripper joint besides), the tool's pose at 50 Hz (noise 0.3 mm / 0.3 mrad per
reading, the quaternion's sign flipped at random), smooth moves between postures, and three stops that must not be
kept: one too short, one with the tracker occluded, one with the tracked body sliding 5 mm. ``pincal import`` finds the
24 and drops the 3, saying why; calibrating from its CSV predicts the 10 held-out postures as well as calibrating from
the simulation's own CSV (``pincal check``).
"""

from __future__ import annotations

import re
from pathlib import Path

import numpy as np
import pytest
from bag_recording import Stop, trajectory, write_bag
from conftest import run_pincal

from pincal.cli import bag_import
from pincal.cli.app import main
from pincal.io import bags, postures
from pincal.io.dataset import dataset_text
from pincal.io.dataset_reader import read_dataset

KEY = "pose:tool0"


def _ok(done: object) -> None:
    assert done.returncode == 0, done.stdout + done.stderr  # type: ignore[attr-defined]


@pytest.fixture(scope="module")
def recorded(tmp_path_factory: pytest.TempPathFactory) -> Path:
    """sim/ (the simulation), train.csv and test.csv (its two sets), run.bag (ROS 1, PoseStamped /mocap/tool, header
    stamps), run/ (ROS 2 mcap, the pose as TF mocap -> tool, no header stamps), marker/ (ROS 2 sqlite3, the tool's
    origin as PointStamped /marker)."""
    root = tmp_path_factory.mktemp("bags")
    _ok(run_pincal("simulate", "ur10", "--measure", "pose", "--samples", "24", "--test-samples", "10", "--noise",
                   "1e-4", "--seed", "3", "--out", str(root / "sim"), "--quiet"))
    data = read_dataset(root / "sim" / "measurements.csv")
    train = data.of_set("train")
    (root / "train.csv").write_text(dataset_text(train), encoding="utf-8")
    (root / "test.csv").write_text(dataset_text(data.of_set("test")), encoding="utf-8")
    stops = [Stop(train.joints[k], train.measurements[KEY][k], hold=1.6) for k in range(train.n_samples)]
    stops.insert(3, Stop(train.joints[3] + 0.1, train.measurements[KEY][3], hold=0.5))
    stops.insert(8, Stop(train.joints[7] + 0.1, train.measurements[KEY][7], hold=1.6, fault="occluded"))
    stops.insert(13, Stop(train.joints[11] + 0.1, train.measurements[KEY][11], hold=1.6, fault="moving"))
    recording = trajectory(stops, transition=0.6, seed=5)
    write_bag(root / "run.bag", "ros1", train.joint_names, recording, "pose", "/mocap/tool")
    write_bag(root / "run", "mcap", train.joint_names, recording, "tf", "/tf", frames=("mocap", "tool"), stamps=False)
    points = {**recording, "values": recording["values"][:, :3]}
    write_bag(root / "marker", "sqlite3", train.joint_names, points, "point", "/marker")
    return root


def _held_out_rms(root: Path, urdf: Path) -> float:
    """The RMS position error [m] of ``urdf`` on the held-out postures, as ``pincal check`` prints it."""
    done = run_pincal("check", str(urdf), str(root / "test.csv"), "--nominal", "ur10")
    _ok(done)
    found = re.search(r"lengths:\s+MODEL ([\d.]+) mm RMS", done.stdout)
    assert found, done.stdout
    return float(found[1]) * 1e-3


@pytest.fixture(scope="module")
def csv_route(recorded: Path) -> float:
    """Held-out RMS [m] of the calibration from the simulation's own CSV."""
    _ok(run_pincal("calibrate", "ur10", str(recorded / "train.csv"), "--out", str(recorded / "csv.urdf")))
    return _held_out_rms(recorded, recorded / "csv.urdf")


def test_import_finds_the_postures_and_calibrates_as_well_as_the_csv(recorded: Path, csv_route: float) -> None:
    out = recorded / "imported.csv"
    done = run_pincal("import", "ur10", str(recorded / "run.bag"), "--joints", "/joint_states", "--pose",
                      "/mocap/tool", "--frame", "tool0", "--out", str(out))
    _ok(done)
    assert "not read: gripper_finger_joint" in done.stdout and "kept 24 of 27" in done.stdout
    dropped = re.findall(r"(p\d+) .*dropped, ([a-z ]+) \(", done.stdout)
    assert dropped == [("p4", "too short"), ("p9", "measurement missing"), ("p14", "measurement moving")]
    header = [line for line in out.read_text(encoding="utf-8").splitlines() if line.startswith("# posture ")]
    assert len(header) == 27 and "dropped, measurement missing" in header[8]
    imported, train = read_dataset(out), read_dataset(recorded / "train.csv")
    assert imported.n_samples == 24 and imported.joint_names == train.joint_names
    np.testing.assert_allclose(imported.joints, train.joints, atol=2e-5)  # [rad]: still within the tolerance
    np.testing.assert_allclose(imported.measurements[KEY][:, :3], train.measurements[KEY][:, :3], atol=2e-4)  # [m]

    _ok(run_pincal("calibrate", "ur10", str(out), "--out", str(recorded / "bag.urdf")))
    bag_route = _held_out_rms(recorded, recorded / "bag.urdf")
    assert bag_route < 1.2 * csv_route and bag_route < 3e-4  # [m]; the nominal robot: about 2.5 mm


def test_a_job_file_reads_a_ros2_bag_with_the_pose_on_tf(recorded: Path, csv_route: float) -> None:
    job = recorded / "job.toml"
    job.write_text('robot = "ur10"\nout = "job.urdf"\n\n[bag]\nfile = "run"\njoints = "/joint_states"\n'
                   'tf = ["mocap", "tool"]\nframe = "tool0"\n', encoding="utf-8")
    done = run_pincal("calibrate", str(job))
    _ok(done)
    assert "samples in the file 24" in done.stdout
    assert _held_out_rms(recorded, recorded / "job.urdf") < 1.2 * csv_route


def test_a_marker_point_gives_position_columns(recorded: Path) -> None:
    out = recorded / "marker.csv"
    _ok(run_pincal("import", "ur10", str(recorded / "marker"), "--joints", "/joint_states", "--point", "/marker",
                   "--out", str(out)))
    imported, train = read_dataset(out), read_dataset(recorded / "train.csv")
    assert list(imported.measurements) == ["position:tool0"]  # the robot's measured frame, by default
    np.testing.assert_allclose(imported.measurements["position:tool0"], train.measurements[KEY][:, :3], atol=2e-4)


def test_bad_input_is_one_line_and_exit_2(recorded: Path, tmp_path: Path, capsys: pytest.CaptureFixture[str]) -> None:
    """One case as a user meets it (a subprocess), the others through the same entry point in this process."""
    bag = str(recorded / "run.bag")
    done = run_pincal("import", "ur10", bag, "--joints", "/joints", "--pose", "/mocap/tool", "--out",
                      str(tmp_path / "x.csv"))
    assert done.returncode == 2 and done.stderr.startswith("pincal: error: joint states: topic '/joints' does not "
                                                           "exist in the bag; topics are: /joint_states")
    assert len(done.stderr.strip().splitlines()) == 1
    cases = [
        ([bag, "--joints", "/joint_states", "--point", "/mocap/tool"], "carries geometry_msgs/msg/PoseStamped, not "
                                                                       "geometry_msgs/msg/PointStamped"),
        ([bag, "--joints", "/joint_states", "--pose", "/mocap/tool", "--still-time", "5"], "no posture of"),
        ([bag, "--joints", "/joint_states", "--pose", "/mocap/tool", "--frame", "tool9"], "frame 'tool9' does not "
                                                                                          "exist"),
        ([str(recorded / "train.csv"), "--joints", "/j", "--pose", "/p"], "is not a ROS bag pincal can read"),
        ([bag, "--joints", "/joint_states", "--pose", "/mocap/tool", "--still-time", "0"], "--still-time"),
    ]
    for flags, message in cases:
        assert _status(["import", "ur10", *flags, "--out", str(tmp_path / "x.csv")]) == 2
        error = capsys.readouterr().err
        assert message in error and error.startswith("pincal: error: ") and len(error.strip().splitlines()) == 1
    assert not (tmp_path / "x.csv").exists()
    job = tmp_path / "job.toml"
    job.write_text(f'robot = "ur10"\n[bag]\nfile = "{recorded / "run"}"\njoints = "/joint_states"\npose = "/p"\n'
                   'point = "/q"\n', encoding="utf-8")
    assert _status(["calibrate", str(job)]) == 2
    assert "[bag]: name the measurement by one of" in capsys.readouterr().err


def _status(argv: list[str]) -> int | str | None:
    """``pincal ARGV``'s exit status, run in this process (argument errors included)."""
    try:
        return main(argv)
    except SystemExit as stop:
        return stop.code


def test_the_command_line_spells_the_defaults_of_the_library() -> None:
    assert bag_import.STILL_TOLERANCE == postures.STILL_TOLERANCE
    assert bag_import.STILL_TIME == postures.STILL_TIME and bag_import.DRIFT == postures.DRIFT
    assert bag_import.TF_TOPIC == bags.TF_TOPIC
