"""A ROS bag of a robot measured at static postures, as a motion-capture session records it: the example of
docs/bags.md, and the bags of the tests.

Run: ``python examples/ros_bag.py sim/measurements.csv run.bag`` (``--storage sqlite3`` or ``mcap`` for a ROS 2 bag
directory; ``--measure tf`` or ``point`` for the measurement as a TF child frame or a marker point).

The robot moves through the training postures of a dataset (``pincal simulate ... --measure pose``), holding each
1.6 s, with smooth moves of 0.6 s between them (zero velocity at both ends). Three stops are added that
``pincal import`` must not keep: one held 0.5 s (too short), one with the tracker occluded, one where the tracked body
slides 5 mm while the joints are still. Joint states at 100 Hz (the joints in a shuffled order, a gripper joint
besides, noise 1e-5 rad), the tool's pose at 50 Hz (noise 0.3 mm and 0.3 mrad per reading, the quaternion's sign
flipped at random, as trackers do). Written with the ``rosbags`` writer: no ROS installation needed.
"""

from __future__ import annotations

import argparse
from collections.abc import Sequence
from dataclasses import dataclass
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


#: Each measurement kind's topic, and the TF frames (parent, child).
TOPICS = {"pose": "/mocap/tool", "tf": "/tf", "point": "/marker"}
TF_FRAMES = ("mocap", "tool")
HOLD = 1.6  # [s]
TRANSITION = 0.6  # [s]
#: Where the three stops not to keep go among the postures, and what is wrong with each.
FAULTS = ((3, "short"), (8, "occluded"), (13, "moving"))


def session_stops(joints: np.ndarray, poses: np.ndarray) -> list[Stop]:
    """The stops of a session through the postures ``joints`` (N, n) [rad or m] whose tool poses are ``poses`` (N, 7)
    (x, y, z [m], qx, qy, qz, qw), with the three faulty stops of :data:`FAULTS` inserted (their joints 0.1 rad away
    from a neighbour's)."""
    stops = [Stop(q, pose, hold=HOLD) for q, pose in zip(joints, poses, strict=True)]
    for at, fault in FAULTS:
        k = min(at, len(joints) - 1)
        stops.insert(at, Stop(joints[k] + 0.1, poses[k], hold=0.5 if fault == "short" else HOLD,
                              fault="" if fault == "short" else fault))
    return stops


def main() -> None:
    """Write the bag of the training postures of a dataset (module docstring)."""
    from pincal.io.dataset_reader import read_dataset

    parser = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    parser.add_argument("data", help="a dataset with a pose measurement (pincal simulate ... --measure pose)")
    parser.add_argument("out", help="the bag: a .bag file (ros1), or a directory (sqlite3, mcap)")
    parser.add_argument("--storage", choices=("ros1", "sqlite3", "mcap"), default="ros1")
    parser.add_argument("--measure", choices=tuple(TOPICS), default="pose")
    parser.add_argument("--no-stamps", action="store_true", help="header stamps left at zero (the bag time counts)")
    parser.add_argument("--seed", type=int, default=5)
    args = parser.parse_args()
    data = read_dataset(args.data).of_set("train")
    key = next(k for k in data.measurements if k.startswith("pose:"))
    recording = trajectory(session_stops(data.joints, data.measurements[key]), TRANSITION, args.seed)
    if args.measure == "point":
        recording["values"] = recording["values"][:, :3]
    write_bag(Path(args.out), args.storage, data.joint_names, recording, args.measure, TOPICS[args.measure],
              TF_FRAMES, stamps=not args.no_stamps, seed=args.seed)
    what = f"TF {TF_FRAMES[0]} -> {TF_FRAMES[1]} on /tf" if args.measure == "tf" else TOPICS[args.measure]
    print(f"wrote {args.out} ({args.storage}): {data.n_samples} postures of {args.data} and 3 stops not to keep "
          f"(too short, tracker occluded, body sliding); {recording['joints'].shape[0]} joint states on "
          f"/joint_states, {recording['values'].shape[0]} readings of {key.partition(':')[2]} ({what})")


if __name__ == "__main__":
    main()
