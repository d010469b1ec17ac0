"""Malformed ROS bags through ``pincal import`` and a job file's ``[bag]``, as a user meets them: each ends in one line
``pincal: error: ...`` naming the bag, the topic, the message or the file and line (exit 2), no warning text before
it, and no CSV written.

The bags are written here with the ``rosbags`` writer: a UR10 holding two postures 1.5 s each (joint states at
100 Hz, the tool's pose at 50 Hz), then spoiled one way: a message's bytes damaged behind an intact index, a NaN in a
quaternion, infinite joint readings, a joint never published, a ROS 2 bag whose metadata.yaml does not parse.
"""

from __future__ import annotations

import struct
from pathlib import Path

import numpy as np
import pytest
from conftest import run_pincal
from rosbags.rosbag1 import Writer
from rosbags.typesys import Stores, get_typestore

UR10_JOINTS = ["shoulder_pan_joint", "shoulder_lift_joint", "elbow_joint", "wrist_1_joint", "wrist_2_joint",
               "wrist_3_joint"]
START = 100.0  # [s]: the first message's stamp and bag time
JOINT_RATE, POSE_EVERY = 100.0, 2  # [Hz]; a pose with every second joint state
MESSAGES = 300  # joint states: two postures of 1.5 s


def write_bag(path: Path, names: list[str] = UR10_JOINTS, damaged: int | None = None,
              nan_quaternion: int | None = None, infinite_from: int | None = None) -> Path:
    """A ROS 1 bag of the two postures: ``damaged`` the number (from 1) of the joint-state message whose name list
    claims 2³¹ − 16 entries; ``nan_quaternion`` the number of the pose whose qx is NaN; ``infinite_from`` the number of
    the first joint-state message whose shoulder_lift_joint reads +inf (all later ones too)."""
    store = get_typestore(Stores.ROS1_NOETIC)
    types = store.types
    with Writer(path) as writer:
        joints = writer.add_connection("/joint_states", "sensor_msgs/msg/JointState", typestore=store)
        poses = writer.add_connection("/mocap/tool", "geometry_msgs/msg/PoseStamped", typestore=store)
        for k in range(MESSAGES):
            t = START + k / JOINT_RATE
            sec, nanosec = int(t), round((t - int(t)) * 1e9)
            header = types["std_msgs/msg/Header"](seq=k, stamp=types["builtin_interfaces/msg/Time"](
                sec=sec, nanosec=nanosec), frame_id="")
            positions = np.full(len(names), 0.1 if k >= MESSAGES // 2 else 0.0)
            if infinite_from is not None and k + 1 >= infinite_from:
                positions[names.index("shoulder_lift_joint")] = np.inf
            raw = store.serialize_ros1(types["sensor_msgs/msg/JointState"](
                header=header, name=names, position=positions, velocity=np.zeros(0), effort=np.zeros(0)),
                "sensor_msgs/msg/JointState")
            if damaged == k + 1:  # the name list's length field, after the header (seq, stamp, empty frame_id)
                raw = bytes(raw[:16]) + struct.pack("<I", 2**31 - 16) + bytes(raw[20:])
            writer.write(joints, round(t * 1e9), raw)
            if k % POSE_EVERY == 0:
                qx = np.nan if nan_quaternion == k // POSE_EVERY + 1 else 0.0
                pose = types["geometry_msgs/msg/PoseStamped"](header=header, pose=types["geometry_msgs/msg/Pose"](
                    position=types["geometry_msgs/msg/Point"](x=0.5, y=0.1, z=0.3),
                    orientation=types["geometry_msgs/msg/Quaternion"](x=qx, y=0.0, z=0.0, w=1.0)))
                writer.write(poses, round(t * 1e9), store.serialize_ros1(pose, "geometry_msgs/msg/PoseStamped"))
    return path


def _import(bag: Path, out: Path, *extra: str) -> tuple[int, str, str]:
    done = run_pincal("import", "ur10", str(bag), "--joints", "/joint_states", "--pose", "/mocap/tool", "--out",
                      str(out), *extra)
    return done.returncode, done.stdout, done.stderr


def _one_line(stderr: str) -> str:
    """The one line of ``stderr``, checked to be ``pincal: error: ...`` and alone."""
    lines = stderr.splitlines()
    assert len(lines) == 1 and lines[0].startswith("pincal: error: "), stderr
    return lines[0].removeprefix("pincal: error: ")


def test_a_damaged_message_behind_an_intact_index_is_named(tmp_path: Path) -> None:
    status, stdout, stderr = _import(write_bag(tmp_path / "good.bag"), tmp_path / "good.csv")
    assert status == 0 and "kept 2 of 2" in stdout, stderr  # the bag undamaged
    bag = write_bag(tmp_path / "damaged.bag", damaged=8)
    status, _, stderr = _import(bag, tmp_path / "out.csv")
    assert status == 2
    assert _one_line(stderr).startswith(f"joint states: '{bag}' is damaged: message 8 on '/joint_states' (bag time "
                                        "100.070 s) is not a sensor_msgs/msg/JointState: Invalid sequence length")
    assert not (tmp_path / "out.csv").exists()


def test_a_nan_quaternion_is_named_by_import_and_by_a_job_file(tmp_path: Path) -> None:
    bag = write_bag(tmp_path / "nan.bag", nan_quaternion=11)
    status, _, stderr = _import(bag, tmp_path / "out.csv")
    named = "measurement (pose): message 11 on '/mocap/tool' (at 100.200 s) holds qx = nan: every value of a " \
            "reading must be a finite number"
    assert status == 2 and _one_line(stderr) == named
    assert not (tmp_path / "out.csv").exists()
    job = tmp_path / "job.toml"
    job.write_text('robot = "ur10"\nout = "cal.urdf"\n\n[bag]\nfile = "nan.bag"\njoints = "/joint_states"\n'
                   'pose = "/mocap/tool"\n', encoding="utf-8")
    done = run_pincal("calibrate", str(job))
    assert done.returncode == 2 and _one_line(done.stderr) == f"{job}: [bag]: {named}"
    assert not (tmp_path / "cal.urdf").exists()


def test_infinite_joint_readings_are_one_line_without_a_warning(tmp_path: Path) -> None:
    status, _, stderr = _import(write_bag(tmp_path / "inf.bag", infinite_from=161), tmp_path / "out.csv")
    assert status == 2
    assert _one_line(stderr) == ("joint states: the message on '/joint_states' at t 1.60 s (from the recording's "
                                 "first) holds shoulder_lift_joint = inf (and 139 more messages): a joint reading must "
                                 "be a finite number [rad or m]")
    assert not (tmp_path / "out.csv").exists()


def test_a_joint_never_published_is_refused_at_import_when_it_moves_the_measured_frame(tmp_path: Path) -> None:
    """Without wrist_3_joint, the tool's pose cannot be calibrated from: said at import, no CSV. The same bag for a
    frame the wrist does not move (the forearm) is imported, the wrist's absence said."""
    bag = write_bag(tmp_path / "no_wrist.bag", names=UR10_JOINTS[:5])
    status, _, stderr = _import(bag, tmp_path / "out.csv")
    assert status == 2
    assert _one_line(stderr) == ("joint states: topic '/joint_states' never carries wrist_3_joint, which moves the "
                                 "measured frame 'tool0' (a calibration needs its readings); it carries: "
                                 + ", ".join(UR10_JOINTS[:5]))
    assert not (tmp_path / "out.csv").exists()
    status, stdout, stderr = _import(bag, tmp_path / "forearm.csv", "--frame", "forearm_link")
    assert status == 0, stderr
    assert "not on /joint_states: wrist_3_joint (they move no measured frame" in stdout


@pytest.mark.parametrize(("metadata", "where"), [
    ("rosbag2_bagfile_information:\n  version: 5\n  topics_with_message_count: [\n   - {a: b\n",
     "line 4, column 4: expected the node content, but found '-'"),
    ("rosbag2_bagfile_information:\n  version: 5: 6\n", "line 2, column 13: mapping values are not allowed here"),
], ids=["unclosed-list", "two-colons"])
def test_a_metadata_file_that_does_not_parse_is_one_line_naming_its_line(tmp_path: Path, metadata: str,
                                                                         where: str) -> None:
    bag = tmp_path / "ros2"
    bag.mkdir()
    (bag / "metadata.yaml").write_text(metadata, encoding="utf-8")
    status, _, stderr = _import(bag, tmp_path / "out.csv")
    assert status == 2
    assert _one_line(stderr) == (f"'{bag}' is not a ROS bag pincal can read (a ROS 1 .bag, a ROS 2 bag directory or "
                                 f"an .mcap file): {bag / 'metadata.yaml'}, {where}")


@pytest.mark.parametrize(("content", "reason"), [
    (b"\x89MCAP0\r\n", "the file ends early (truncated or damaged)"),  # the magic alone: rosbags' ord() of nothing
    (b"\x89MCA", "File magic is invalid."),
], ids=["magic-only", "magic-cut"])
def test_a_truncated_mcap_file_is_one_line_naming_it(tmp_path: Path, content: bytes, reason: str) -> None:
    bag = tmp_path / "cut.mcap"
    bag.write_bytes(content)
    status, _, stderr = _import(bag, tmp_path / "out.csv")
    assert status == 2
    assert _one_line(stderr) == (f"'{bag}' is not a ROS bag pincal can read (a ROS 1 .bag, a ROS 2 bag directory or "
                                 f"an .mcap file): {reason}")
    assert not (tmp_path / "out.csv").exists()
