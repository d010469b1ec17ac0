"""Reading ROS bags (pincal.io.bags) and finding static postures in them (pincal.io.postures): bags written by the
``rosbags`` writer in a temporary directory (examples/ros_bag.py), as ROS 1, ROS 2 sqlite3 and ROS 2 mcap."""

from __future__ import annotations

import importlib.util
import sys
import warnings
from pathlib import Path
from types import ModuleType

import numpy as np
import pytest
from conftest import ROOT
from scipy.spatial.transform import Rotation

import pincal
from pincal.errors import ArgumentError, DataError, NotFoundError
from pincal.io.bag_dataset import bag_dataset
from pincal.io.bags import JointStates, MeasurementSource, MeasurementStream, read_bag
from pincal.io.postures import StillRule, average_quaternion, find_postures


def _example(name: str) -> ModuleType:
    """The module of ``examples/<name>.py``."""
    spec = importlib.util.spec_from_file_location(name, ROOT / "examples" / f"{name}.py")
    assert spec is not None and spec.loader is not None
    module = importlib.util.module_from_spec(spec)
    sys.modules[name] = module  # its dataclasses look themselves up there
    spec.loader.exec_module(module)
    return module


ros_bag = _example("ros_bag")
Stop, trajectory, write_bag, START = ros_bag.Stop, ros_bag.trajectory, ros_bag.write_bag, ros_bag.START
NAMES = ["j1", "j2", "j3"]
QUATERNION = Rotation.from_rotvec([0.3, -0.2, 1.1]).as_quat()  # x, y, z, w


def _stops() -> list[Stop]:
    poses = [np.array([0.5, 0.1 * k, 0.3, *QUATERNION]) for k in range(3)]
    return [Stop(np.array([0.1, -0.2, 0.3]) + 0.4 * k, poses[k], hold=1.5) for k in range(3)]


@pytest.mark.parametrize("storage", ["ros1", "sqlite3", "mcap"])
def test_joint_states_are_read_by_name_whatever_their_order(tmp_path: Path, storage: str) -> None:
    stops = _stops()
    recording = trajectory(stops, transition=0.5)
    path = write_bag(tmp_path / ("r.bag" if storage == "ros1" else "r"), storage, NAMES, recording, "pose", "/mocap")
    states, stream = read_bag(path, "/joint_states", MeasurementSource("pose", "/mocap"))
    assert sorted(states.names) == sorted([*NAMES, "gripper_finger_joint"])  # shuffled in every message
    columns = [states.names.index(n) for n in NAMES]
    np.testing.assert_allclose(states.positions[:, columns], recording["joints"], atol=1e-12)
    np.testing.assert_allclose(states.times, recording["joint_times"], atol=1e-6)  # the header stamps
    np.testing.assert_allclose(stream.positions, recording["values"][:, :3], atol=1e-12)
    assert stream.quaternions is not None
    np.testing.assert_allclose(np.abs(np.sum(stream.quaternions * recording["values"][:, 3:], axis=1)), 1.0,
                               atol=1e-12)


def test_without_header_stamps_the_bag_time_is_taken_and_tf_is_read(tmp_path: Path) -> None:
    recording = trajectory(_stops(), transition=0.5)
    path = write_bag(tmp_path / "r", "mcap", NAMES, recording, "tf", "/tf", frames=("/mocap", "tool"), stamps=False)
    states, stream = read_bag(path / "r.mcap", "/joint_states", MeasurementSource("tf", "/tf", "mocap", "tool"))
    np.testing.assert_allclose(states.times, recording["joint_times"] + 0.002, atol=1e-6)  # recorded 2 ms later
    np.testing.assert_allclose(stream.times, recording["times"] + 0.002, atol=1e-6)
    np.testing.assert_allclose(stream.positions, recording["values"][:, :3], atol=1e-12)


def test_a_missing_topic_a_wrong_type_a_missing_transform_and_a_non_bag_are_named(tmp_path: Path) -> None:
    recording = trajectory(_stops(), transition=0.5)
    path = write_bag(tmp_path / "r.bag", "ros1", NAMES, recording, "tf", "/tf")
    with pytest.raises(NotFoundError, match=r"topic '/joints' does not exist in the bag; topics are: /joint_states "
                                            r"\(sensor_msgs/msg/JointState\), /tf \(tf2_msgs/msg/TFMessage\)"):
        read_bag(path, "/joints", MeasurementSource("tf", "/tf", "mocap", "tool"))
    with pytest.raises(DataError, match="topic '/tf' carries tf2_msgs/msg/TFMessage, not geometry_msgs/msg/Pose"):
        read_bag(path, "/joint_states", MeasurementSource("pose", "/tf"))
    with pytest.raises(NotFoundError, match="transform 'mocap -> tol' does not exist on /tf; transforms are: mocap "
                                            "-> tool, world -> camera_link"):
        read_bag(path, "/joint_states", MeasurementSource("tf", "/tf", "mocap", "tol"))
    (tmp_path / "notes.txt").write_text("not a bag", encoding="utf-8")
    with pytest.raises(DataError, match="is not a ROS bag pincal can read"):
        read_bag(tmp_path / "notes.txt", "/joint_states", MeasurementSource("pose", "/mocap"))


def test_the_average_quaternion_ignores_signs_and_recovers_the_orientation() -> None:
    rng = np.random.default_rng(4)
    noise = Rotation.from_rotvec(rng.normal(0.0, 1e-2, (400, 3)))
    samples = (Rotation.from_quat(QUATERNION) * noise).as_quat()
    flipped = samples * np.where(rng.random(400) < 0.5, -1.0, 1.0)[:, None]
    mean = average_quaternion(flipped)
    assert np.linalg.norm(mean) == pytest.approx(1.0) and mean[3] >= 0
    error = (Rotation.from_quat(mean).inv() * Rotation.from_quat(QUATERNION)).magnitude()
    assert error < 3 * 1e-2 / np.sqrt(400)  # [rad]: the noise averaged down
    assert np.linalg.norm(np.mean(flipped, axis=0)) < 0.5  # the arithmetic mean of signed quaternions would not do


def _still(stops: list[Stop]) -> tuple[JointStates, MeasurementStream]:
    recording = trajectory(stops, transition=0.5, seed=2)
    states = JointStates(recording["joint_times"], NAMES, recording["joints"])
    return states, MeasurementStream(recording["times"], recording["values"][:, :3], recording["values"][:, 3:])


def test_each_posture_is_kept_and_averaged_or_dropped_with_its_reason() -> None:
    stops = [*_stops(), Stop(np.array([1.5, 0.5, 0.2]), np.array([0.4, 0.4, 0.4, *QUATERNION]), hold=0.5),
             Stop(np.array([1.2, 0.2, 0.2]), np.array([0.4, 0.3, 0.4, *QUATERNION]), fault="occluded"),
             Stop(np.array([0.9, 0.0, 0.2]), np.array([0.4, 0.2, 0.4, *QUATERNION]), fault="moving")]
    states, stream = _still(stops)
    postures = find_postures(states, NAMES, stream, StillRule(tolerance=1e-3, time=1.0, drift=1e-3))
    assert [p.reason.partition(" (")[0] for p in postures] == ["", "", "", "too short", "measurement missing",
                                                               "measurement moving"]
    assert postures[0].start == pytest.approx(0.0) and postures[1].start == pytest.approx(2.0, abs=0.06)
    for posture, stop in zip(postures[:3], stops, strict=False):
        assert posture.kept and posture.n_states >= 1.5 * ros_bag.JOINT_RATE - 1
        np.testing.assert_allclose(posture.joints, stop.joints, atol=1e-5)  # 1e-5 noise averaged over 150 readings
        np.testing.assert_allclose(posture.position, stop.measurement[:3], atol=2e-4)
        assert posture.quaternion is not None
        assert abs(float(posture.quaternion @ stop.measurement[3:])) == pytest.approx(1.0, abs=1e-7)
    assert "too short (0.5" in postures[3].line() and "dropped" in postures[3].line()


def test_a_stricter_drift_drops_a_turning_measurement_and_a_silent_joint_drops_its_posture() -> None:
    stops = _stops()
    states, stream = _still(stops)
    turned = stream.quaternions.copy()  # type: ignore[union-attr]
    second = (stream.times > START + 2.0) & (stream.times < START + 3.5)
    late = second & (stream.times > START + 2.75)
    turned[late] = (Rotation.from_quat(turned[late]) * Rotation.from_rotvec([0.0, 0.0, 0.01])).as_quat()
    positions = states.positions.copy()
    positions[(states.times > START + 3.9), 2] = np.nan  # j3 no longer published from the third posture on
    postures = find_postures(JointStates(states.times, NAMES, positions), NAMES,
                             MeasurementStream(stream.times, stream.positions, turned), StillRule(drift=5e-3))
    assert postures[0].kept
    assert postures[1].reason.startswith("measurement turning (")
    assert postures[2].reason == "joint j3 not published during it"


def test_library_arguments_are_refused_as_the_command_line_refuses_them(tmp_path: Path) -> None:
    """bag_dataset, read_bag, StillRule, MeasurementSource and average_quaternion name the argument and the value:
    what ``pincal import`` refuses of its flags is refused here too, never a result the command line would not give."""
    robot = pincal.load_robot("ur10")
    for rule, message in (({"tolerance": float("nan")}, r"tolerance=nan: must be a finite number > 0 \[rad or m\]"),
                          ({"time": -1}, r"time=-1: must be a finite number > 0 \[s\]"),
                          ({"drift": 0.0}, r"drift=0.0: must be a finite number > 0 \[m, rad\]")):
        with pytest.raises(ArgumentError, match=message):
            StillRule(**rule)
    with pytest.raises(TypeError, match=r"time='1': expected a number, not str"):
        StillRule(time="1")  # type: ignore[arg-type]
    source = MeasurementSource("pose", "/mocap")
    with pytest.raises(TypeError, match=r"path=None: expected a path \(str or pathlib.Path\), not NoneType"):
        bag_dataset(robot, None, "/joint_states", source)  # type: ignore[arg-type]
    with pytest.raises(TypeError, match=r"path=None: expected a path"):
        read_bag(None, "/joint_states", source)  # type: ignore[arg-type]
    with pytest.raises(TypeError, match=r"robot=None: expected a Robot \(pincal.load_robot\), not NoneType"):
        bag_dataset(None, tmp_path / "r.bag", "/joint_states", source)  # type: ignore[arg-type]
    with pytest.raises(TypeError, match=r"rule=1.0: expected a StillRule, not float"):
        bag_dataset(robot, tmp_path / "r.bag", "/joint_states", source, rule=1.0)  # type: ignore[arg-type]
    with pytest.raises(ArgumentError, match=r"kind='posee': must be one of pose, tf, point"):
        MeasurementSource("posee", "/mocap")  # type: ignore[arg-type]
    with pytest.raises(ArgumentError, match=r"kind='tf' needs parent= and child="):
        MeasurementSource("tf", "/tf")
    with pytest.raises(ArgumentError, match=r"quaternions\[1\] = \[0.0, 0.0, 0.0, 0.0\]: not a rotation \(norm 0\)"):
        average_quaternion(np.array([QUATERNION, np.zeros(4)]))
    with pytest.raises(ArgumentError, match=r"quaternions: shape \(0, 4\); give \(K, 4\) quaternions"):
        average_quaternion(np.zeros((0, 4)))
    with pytest.raises(ArgumentError, match=r"quaternions\[0\] = \[nan, 0.0, 0.0, 1.0\]: not finite"):
        average_quaternion(np.array([[np.nan, 0.0, 0.0, 1.0]]))


def test_readings_too_large_to_average_are_neither_a_warning_nor_a_still_measurement() -> None:
    """Finite readings whose sums overflow: joints at 1e308 average to 1e308 exactly; a marker jumping between
    ±1e308 is moving (its halves' gap infinite), not kept with a NaN; no RuntimeWarning either way."""
    times = START + np.arange(200) / ros_bag.JOINT_RATE
    states = JointStates(times, NAMES, np.full((200, 3), 1e308))
    jumping = np.repeat([[1e308], [-1e308]], 50, axis=0).reshape(-1, 1) * np.ones((100, 3))
    still = MeasurementStream(times[::2], np.full((100, 3), 1e308), None)
    with warnings.catch_warnings():
        warnings.simplefilter("error")
        kept = find_postures(states, NAMES, still)
        dropped = find_postures(states, NAMES, MeasurementStream(times[::2], jumping, None))
    assert [p.reason for p in kept] == [""]
    np.testing.assert_array_equal(kept[0].joints, np.full(3, 1e308))
    np.testing.assert_array_equal(kept[0].position, np.full(3, 1e308))
    assert dropped[0].reason == "measurement moving (inf mm between its halves > 1 mm)"
