"""Recordings of a robot moving between static postures, written as ROS bags with the ``rosbags`` writer (ROS 1
``.bag``, ROS 2 sqlite3 or mcap): joint states at 100 Hz (the joints in a shuffled order, a gripper joint besides),
and one measurement at 50 Hz (a PoseStamped topic, a TF child frame on ``/tf`` beside another transform, or a
PointStamped topic), each with noise; smooth transitions (zero velocity at both ends) between the postures. A
quaternion's sign is flipped at random, as trackers do: averaging must not care."""

from __future__ import annotations

from collections.abc import Sequence
from dataclasses import dataclass, field
from pathlib import Path
from typing import Any

import numpy as np
from rosbags.typesys import Stores, get_types_from_msg, get_typestore

JOINT_RATE = 100.0  # [Hz]
MEASUREMENT_RATE = 50.0  # [Hz]
JOINT_NOISE = 1e-5  # [rad or m]
POSITION_NOISE = 3e-4  # [m] per coordinate
ANGLE_NOISE = 3e-4  # [rad] per axis
START = 1_700_000_000.0  # [s]: a header stamp of today's kind


@dataclass
class Stop:
    """One stop of the robot: its joint values [rad or m], the measurement there (x, y, z [m], and qx, qy, qz, qw
    for a pose), how long it holds [s], and what goes wrong: ``""``, ``"occluded"`` (no reading while it holds)
    or ``"moving"`` (the measurement drifts by ``drift`` [m] while the joints are still)."""

    joints: np.ndarray
    measurement: np.ndarray
    hold: float = 2.0
    fault: str = ""
    drift: float = 5e-3
    extra: dict[str, Any] = field(default_factory=dict)


def _smooth(u: np.ndarray) -> np.ndarray:
    return u * u * (3.0 - 2.0 * u)


def _nlerp(a: np.ndarray, b: np.ndarray, s: np.ndarray) -> np.ndarray:
    b = b if a @ b >= 0 else -b
    q = (1 - s)[:, None] * a + s[:, None] * b
    return q / np.linalg.norm(q, axis=1, keepdims=True)


def _quat_mul(a: np.ndarray, b: np.ndarray) -> np.ndarray:
    """Hamilton products of (K, 4) quaternions (x, y, z, w)."""
    ax, ay, az, aw = a.T
    bx, by, bz, bw = b.T
    return np.stack([aw * bx + ax * bw + ay * bz - az * by, aw * by - ax * bz + ay * bw + az * bx,
                     aw * bz + ax * by - ay * bx + az * bw, aw * bw - ax * bx - ay * by - az * bz], axis=1)


def trajectory(stops: Sequence[Stop], transition: float = 1.0, seed: int = 0) -> dict[str, np.ndarray]:
    """The recording of ``stops`` joined by transitions of ``transition`` [s]: joint times (M,) [s], joints (M, n),
    measurement times (K,) [s], measurements (K, 3 or 7), each with noise."""
    rng = np.random.default_rng(seed)
    jt, jq, mt, mv = [], [], [], []
    t0 = START
    for k, stop in enumerate(stops):
        times = t0 + np.arange(0.0, stop.hold, 1.0 / JOINT_RATE)
        jt.append(times)
        jq.append(np.tile(stop.joints, (times.size, 1)))
        m_times = t0 + np.arange(0.0, stop.hold, 1.0 / MEASUREMENT_RATE) + 0.003
        values = np.tile(stop.measurement, (m_times.size, 1))
        if stop.fault == "moving":
            values[:, 0] += np.linspace(0.0, stop.drift, m_times.size)
        if stop.fault != "occluded":
            mt.append(m_times)
            mv.append(values)
        t0 += stop.hold
        if k + 1 < len(stops):
            nxt = stops[k + 1]
            u = np.arange(0.0, transition, 1.0 / JOINT_RATE)[1:] / transition
            jt.append(t0 + u * transition)
            jq.append(stop.joints + _smooth(u)[:, None] * (nxt.joints - stop.joints))
            u = np.arange(0.0, transition, 1.0 / MEASUREMENT_RATE)[1:] / transition
            s = _smooth(u)
            between = stop.measurement[:3] + s[:, None] * (nxt.measurement[:3] - stop.measurement[:3])
            if stop.measurement.size == 7:
                between = np.hstack([between, _nlerp(stop.measurement[3:], nxt.measurement[3:], s)])
            mt.append(t0 + u * transition + 0.003)
            mv.append(between)
            t0 += transition
    joints = np.vstack(jq)
    joints = joints + rng.normal(0.0, JOINT_NOISE, joints.shape)
    values = np.vstack(mv)
    values[:, :3] += rng.normal(0.0, POSITION_NOISE, (values.shape[0], 3))
    if values.shape[1] == 7:
        half = 0.5 * rng.normal(0.0, ANGLE_NOISE, (values.shape[0], 3))
        noise = np.hstack([half, np.sqrt(1.0 - np.sum(half**2, axis=1, keepdims=True))])
        values[:, 3:] = _quat_mul(values[:, 3:], noise)
        values[:, 3:] *= np.where(rng.random(values.shape[0]) < 0.5, -1.0, 1.0)[:, None]
    return {"joint_times": np.concatenate(jt), "joints": joints, "times": np.concatenate(mt), "values": values}


def _time(store: Any, t: float) -> Any:
    sec = int(np.floor(t))
    return store.types["builtin_interfaces/msg/Time"](sec=sec, nanosec=round((t - sec) * 1e9) % 1_000_000_000)


def _header(store: Any, ros1: bool, t: float, frame: str) -> Any:
    header = store.types["std_msgs/msg/Header"]
    if ros1:
        return header(seq=0, stamp=_time(store, t), frame_id=frame)
    return header(stamp=_time(store, t), frame_id=frame)


def _measurement_message(store: Any, kind: str, header: Any, value: np.ndarray, frames: tuple[str, str]) -> Any:
    t = store.types
    point = t["geometry_msgs/msg/Point"](x=value[0], y=value[1], z=value[2])
    if kind == "point":
        return t["geometry_msgs/msg/PointStamped"](header=header, point=point)
    quaternion = t["geometry_msgs/msg/Quaternion"](x=value[3], y=value[4], z=value[5], w=value[6])
    if kind == "pose":
        return t["geometry_msgs/msg/PoseStamped"](header=header, pose=t["geometry_msgs/msg/Pose"](
            position=point, orientation=quaternion))
    header_cls = type(header)
    fields = {"stamp": header.stamp, "frame_id": frames[0]} | ({"seq": 0} if hasattr(header, "seq") else {})
    other = {**fields, "frame_id": "world"}
    transforms = [t["geometry_msgs/msg/TransformStamped"](
        header=header_cls(**other), child_frame_id="camera_link", transform=t["geometry_msgs/msg/Transform"](
            translation=t["geometry_msgs/msg/Vector3"](x=1.0, y=0.0, z=0.0),
            rotation=t["geometry_msgs/msg/Quaternion"](x=0.0, y=0.0, z=0.0, w=1.0)))]
    transforms.append(t["geometry_msgs/msg/TransformStamped"](
        header=header_cls(**fields), child_frame_id=frames[1], transform=t["geometry_msgs/msg/Transform"](
            translation=t["geometry_msgs/msg/Vector3"](x=value[0], y=value[1], z=value[2]), rotation=quaternion)))
    return t["tf2_msgs/msg/TFMessage"](transforms=transforms)


MESSAGE = {"pose": "geometry_msgs/msg/PoseStamped", "point": "geometry_msgs/msg/PointStamped",
           "tf": "tf2_msgs/msg/TFMessage"}


def write_bag(path: Path, storage: str, names: Sequence[str], recording: dict[str, np.ndarray], kind: str,
              topic: str, frames: tuple[str, str] = ("mocap", "tool"), stamps: bool = True, seed: int = 0) -> Path:
    """Write ``recording`` (:func:`trajectory`) of the joints ``names`` as a bag: ``storage`` ``ros1`` (``path`` a
    .bag file), ``sqlite3`` or ``mcap`` (``path`` a ROS 2 bag directory). The joint states name the joints in a
    shuffled order with a gripper joint besides; the measurement goes on ``topic`` (``/tf`` for ``kind`` ``tf``,
    from ``frames[0]`` to ``frames[1]``). Header stamps are set (``stamps``) or zero (the bag time is then each
    message's time); the bag records each message 2 ms after its stamp."""
    rng = np.random.default_rng(seed)
    ros1 = storage == "ros1"
    store = get_typestore(Stores.ROS1_NOETIC if ros1 else Stores.ROS2_HUMBLE)
    if ros1:  # ROS 1's tf2_msgs is not among rosbags' stored types: its definition, as tf2_msgs/TFMessage.msg has it
        store.register(get_types_from_msg("geometry_msgs/TransformStamped[] transforms", "tf2_msgs/msg/TFMessage"))
    if ros1:
        from rosbags.rosbag1 import Writer as Writer1

        writer: Any = Writer1(path)
    else:
        from rosbags.rosbag2 import StoragePlugin
        from rosbags.rosbag2 import Writer as Writer2

        plugin = StoragePlugin.MCAP if storage == "mcap" else StoragePlugin.SQLITE3
        writer = Writer2(path, version=9, storage_plugin=plugin)
    serialize = store.serialize_ros1 if ros1 else store.serialize_cdr
    joint_state = store.types["sensor_msgs/msg/JointState"]
    events = []
    for t, q in zip(recording["joint_times"], recording["joints"], strict=True):
        order = rng.permutation(len(names) + 1)
        all_names, values = [*names, "gripper_finger_joint"], [*q, 0.04]
        msg = joint_state(header=_header(store, ros1, t if stamps else 0.0, ""),
                          name=[all_names[k] for k in order], position=np.array([values[k] for k in order]),
                          velocity=np.zeros(0), effort=np.zeros(0))
        events.append((t, 0, msg))
    for t, value in zip(recording["times"], recording["values"], strict=True):
        header = _header(store, ros1, t if stamps else 0.0, frames[0])
        events.append((t, 1, _measurement_message(store, kind, header, value, frames)))
    events.sort(key=lambda e: e[0])
    with writer:
        connections = [writer.add_connection("/joint_states", "sensor_msgs/msg/JointState", typestore=store),
                       writer.add_connection(topic, MESSAGE[kind], typestore=store)]
        types = ["sensor_msgs/msg/JointState", MESSAGE[kind]]
        for t, which, msg in events:
            writer.write(connections[which], round((t + 0.002) * 1e9), serialize(msg, types[which]))
    return path
