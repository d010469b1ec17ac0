"""``pincal detect --pair time`` with the joint readings streamed in a ROS bag, as a user runs it: a UR10 holds each
posture of a simulated camera campaign for a second while its joint states are recorded at 100 Hz; each image, named
by the time it was taken, pairs with the joint state nearest in time, within ``--tolerance``."""

from __future__ import annotations

import shutil
from pathlib import Path

import numpy as np
from conftest import run_pincal
from rosbags.rosbag1 import Writer
from rosbags.typesys import Stores, get_typestore

from pincal.io.dataset_reader import read_dataset

BOARD = "charuco:8x6:0.03:0.022:DICT_4X4_50"
START, HOLD, RATE = 1700000000.0, 1.0, 100.0  # [s], [s], [Hz]


def _ok(done: object) -> str:
    assert done.returncode == 0, done.stdout + done.stderr  # type: ignore[attr-defined]
    return str(done.stdout)  # type: ignore[attr-defined]


def _record(path: Path, names: list[str], postures: np.ndarray) -> None:
    """Joint states at RATE: posture k held from START + k·HOLD for HOLD seconds (header stamps)."""
    store = get_typestore(Stores.ROS1_NOETIC)
    types = store.types
    with Writer(path) as writer:
        topic = writer.add_connection("/joint_states", "sensor_msgs/msg/JointState", typestore=store)
        for m in range(int(len(postures) * HOLD * RATE)):
            t = START + m / RATE
            sec, nanosec = int(t), round((t - int(t)) * 1e9)
            header = types["std_msgs/msg/Header"](seq=m, stamp=types["builtin_interfaces/msg/Time"](
                sec=sec, nanosec=nanosec), frame_id="")
            message = types["sensor_msgs/msg/JointState"](
                header=header, name=[*names, "gripper_joint"], position=np.r_[postures[int(m / (HOLD * RATE))], 0.0],
                velocity=np.zeros(0), effort=np.zeros(0))
            writer.write(topic, round(t * 1e9), store.serialize_ros1(message, "sensor_msgs/msg/JointState"))


def test_images_pair_with_the_joint_states_of_a_bag_by_time(tmp_path: Path) -> None:
    _ok(run_pincal("simulate", "ur10", "--measure", "pixel:tool0", "--samples", "4", "--images", "imgs", "--seed",
                   "2", "--out", "sim", cwd=tmp_path))
    joints = read_dataset(tmp_path / "sim" / "joints.csv")
    _record(tmp_path / "run.bag", joints.joint_names, joints.joints)
    offsets = [0.5, 0.5, 0.5, HOLD * RATE]  # the last image's time is far beyond the recording
    files = []
    for k, offset in enumerate(offsets):
        name = tmp_path / f"{START + k * HOLD + offset:.3f}.png"
        shutil.copy(tmp_path / "imgs" / f"{k:04d}.png", name)
        files.append(str(name))
    out = _ok(run_pincal("detect", *files, "--board", BOARD, "--joints", "run.bag", "--robot", "ur10", "--pair",
                         "time", "--tolerance", "0.02", "--measure", "pixel:tool0", "--out", "det.csv", cwd=tmp_path))
    assert "in 3 of 4 images (1 left out)" in out and "paired 3 of the bag's 400 joint states" in out
    assert f"image '{START + 3 * HOLD + offsets[3]:.3f}': the nearest joint row" in out and "beyond the tolerance " \
        "0.02 s" in out
    detected = read_dataset(tmp_path / "det.csv")
    assert detected.joint_names == joints.joint_names  # the robot's joints, the bag's gripper left out
    assert np.array_equal(detected.joints, joints.joints[:3])  # each image's posture, held when it was taken
    assert detected.sample_ids == [f"{START + k * HOLD + 0.5:.6f}" for k in range(3)]
    done = run_pincal("detect", *files, "--board", BOARD, "--joints", "run.bag", "--measure", "pixel:tool0",
                      "--out", "d2.csv", cwd=tmp_path)
    assert done.returncode == 2 and len(done.stderr.splitlines()) == 1
    assert "is a ROS bag: its joint states pair with the images by time" in done.stderr
