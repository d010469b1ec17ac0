"""ROS bags read without a ROS installation (the ``rosbags`` package): a joint-state topic and a measurement stream.

ROS 1 bags (``.bag``), ROS 2 bags (a directory with ``metadata.yaml``, sqlite3 or mcap storage) and a bare ``.mcap``
file are read alike. A message's time is its header stamp when that is set (not zero), else the time the bag recorded
it. Units are ROS's, SI: joint positions [rad or m], positions [m], unit quaternions (x, y, z, w).

The measurement is one of (docs/bags.md):

- ``pose``: a ``geometry_msgs/PoseStamped`` topic (a motion-capture rigid body);
- ``tf``: a child frame of ``tf2_msgs/TFMessage`` on ``/tf``, the transform from a given parent frame;
- ``point``: a ``geometry_msgs/PointStamped`` topic (one marker).
"""

from __future__ import annotations

from collections.abc import Iterator
from dataclasses import dataclass
from pathlib import Path
from typing import TYPE_CHECKING, Any, Literal

import numpy as np
import numpy.typing as npt

from pincal.errors import ArgumentError, DataError, listing, not_found

if TYPE_CHECKING:
    from rosbags.highlevel import AnyReader

Array = npt.NDArray[np.float64]
SourceKind = Literal["pose", "tf", "point"]

JOINT_STATE = "sensor_msgs/msg/JointState"
#: The message type each measurement kind reads.
MESSAGE_TYPES: dict[str, str] = {"pose": "geometry_msgs/msg/PoseStamped", "tf": "tf2_msgs/msg/TFMessage",
                                 "point": "geometry_msgs/msg/PointStamped"}
TF_TOPIC = "/tf"


@dataclass(frozen=True)
class MeasurementSource:
    """Where a bag holds the measurement.

    Attributes:
        kind: ``pose`` (PoseStamped), ``tf`` (a TF child frame) or ``point`` (PointStamped).
        topic: The topic (``/tf`` for ``tf``).
        parent: For ``tf``: the parent frame of the transform; else empty.
        child: For ``tf``: the child frame measured; else empty.
    """

    kind: SourceKind
    topic: str
    parent: str = ""
    child: str = ""

    def __post_init__(self) -> None:
        """Refuse a kind the bag reader has no message type for, naming the kinds (once a KeyError deep inside)."""
        if not isinstance(self.kind, str) or self.kind not in MESSAGE_TYPES:
            raise ArgumentError(f"MeasurementSource kind={self.kind!r}: kinds are {listing(MESSAGE_TYPES)}")

    @property
    def oriented(self) -> bool:
        """Whether the measurement has an orientation (a pose), not a point alone."""
        return self.kind != "point"

    def describe(self) -> str:
        """In words: ``PoseStamped /mocap/tool``, ``TF world -> tool on /tf``, ``PointStamped /marker``."""
        if self.kind == "tf":
            return f"TF {self.parent} -> {self.child} on {self.topic}"
        return f"{MESSAGE_TYPES[self.kind].rpartition('/')[2]} {self.topic}"


@dataclass(frozen=True)
class JointStates:
    """The joint-state messages of one topic, in time order.

    Attributes:
        times: (M,) message times [s].
        names: The joint names the messages carry, in the order first seen (grippers and other extras included).
        positions: (M, len(names)) positions [rad or m]; NaN where a message did not carry that joint.
    """

    times: Array
    names: list[str]
    positions: Array


@dataclass(frozen=True)
class MeasurementStream:
    """The measurement's readings, in time order.

    Attributes:
        times: (K,) reading times [s].
        positions: (K, 3) positions [m] in the measuring system's frame.
        quaternions: (K, 4) unit quaternions (x, y, z, w), or None for points.
    """

    times: Array
    positions: Array
    quaternions: Array | None


def _stamp(header: Any, bag_time_ns: int) -> float:
    """A message's time [s]: its header stamp when set, else the bag's record time."""
    stamp = getattr(header, "stamp", None)
    if stamp is not None and (stamp.sec or stamp.nanosec):
        return float(stamp.sec) + 1e-9 * float(stamp.nanosec)
    return 1e-9 * float(bag_time_ns)


def _open(path: Path) -> AnyReader:
    """An open reader of the bag at ``path``.

    Raises:
        DataError: the path does not exist or is not a bag rosbags can read.
    """
    from rosbags.highlevel import AnyReader, AnyReaderError
    from rosbags.typesys import Stores, get_typestore

    if not path.exists():
        raise DataError(f"bag '{path}' does not exist")
    try:
        reader = AnyReader([path], default_typestore=get_typestore(Stores.ROS2_HUMBLE))
        reader.open()
    except (AnyReaderError, OSError, ValueError) as exc:
        raise DataError(f"'{path}' is not a ROS bag pincal can read (a ROS 1 .bag, a ROS 2 bag directory or an "
                        f".mcap file): {exc}") from None
    return reader


def _connections(reader: AnyReader, topic: str, msgtype: str, role: str) -> list[Any]:
    """The connections of ``topic``, checked to carry ``msgtype``; an error lists the bag's topics."""
    found = [c for c in reader.connections if c.topic == topic]
    topics = sorted({f"{c.topic} ({c.msgtype})" for c in reader.connections})
    if not found:
        raise not_found("topic", topic, topics, " in the bag", f"{role}: ")
    wrong = sorted({c.msgtype for c in found if c.msgtype != msgtype})
    if wrong:
        raise DataError(f"{role}: topic '{topic}' carries {listing(wrong)}, not {msgtype}")
    return found


def _messages(reader: AnyReader, connections: list[Any]) -> Iterator[tuple[Any, int]]:
    """Each message of ``connections`` deserialised, with its bag time [ns]."""
    for connection, bag_time, raw in reader.messages(connections=connections):
        yield reader.deserialize(raw, connection.msgtype), bag_time


def _joint_states(reader: AnyReader, topic: str) -> JointStates:
    rows: list[tuple[float, dict[str, float]]] = []
    for msg, bag_time in _messages(reader, _connections(reader, topic, JOINT_STATE, "joint states")):
        positions = np.asarray(msg.position, dtype=float)
        if len(msg.name) != positions.size:
            raise DataError(f"joint states: a message on '{topic}' names {len(msg.name)} joints but holds "
                            f"{positions.size} positions")
        rows.append((_stamp(msg.header, bag_time), dict(zip(msg.name, positions.tolist(), strict=True))))
    if not rows:
        raise DataError(f"joint states: topic '{topic}' holds no message")
    rows.sort(key=lambda row: row[0])
    names = list(dict.fromkeys(name for _, row in rows for name in row))
    positions = np.array([[row.get(name, np.nan) for name in names] for _, row in rows], dtype=float)
    return JointStates(np.array([t for t, _ in rows]), names, positions)


def _strip(frame: str) -> str:
    return frame.lstrip("/")


def _readings(reader: AnyReader, source: MeasurementSource) -> list[tuple[float, list[float]]]:
    """(time [s], x, y, z [m] and, for a pose, qx, qy, qz, qw) of each reading."""
    role = f"measurement ({source.kind})"
    found = []
    pairs: set[str] = set()
    for msg, bag_time in _messages(reader, _connections(reader, source.topic, MESSAGE_TYPES[source.kind], role)):
        if source.kind == "point":
            p = msg.point
            found.append((_stamp(msg.header, bag_time), [p.x, p.y, p.z]))
        elif source.kind == "pose":
            p, q = msg.pose.position, msg.pose.orientation
            found.append((_stamp(msg.header, bag_time), [p.x, p.y, p.z, q.x, q.y, q.z, q.w]))
        else:
            for tf in msg.transforms:
                parent, child = _strip(tf.header.frame_id), _strip(tf.child_frame_id)
                pairs.add(f"{parent} -> {child}")
                if (parent, child) == (_strip(source.parent), _strip(source.child)):
                    p, q = tf.transform.translation, tf.transform.rotation
                    found.append((_stamp(tf.header, bag_time), [p.x, p.y, p.z, q.x, q.y, q.z, q.w]))
    if not found and source.kind == "tf":
        raise not_found("transform", f"{source.parent} -> {source.child}", sorted(pairs), f" on {source.topic}",
                        f"{role}: ")
    if not found:
        raise DataError(f"{role}: topic '{source.topic}' holds no message")
    return sorted(found, key=lambda reading: reading[0])


def _stream(reader: AnyReader, source: MeasurementSource) -> MeasurementStream:
    readings = _readings(reader, source)
    values = np.array([v for _, v in readings], dtype=float)
    quaternions = None
    if source.oriented:
        quaternions = values[:, 3:7]
        norms = np.linalg.norm(quaternions, axis=1)
        if np.any(np.abs(norms - 1.0) > 1e-3):
            k = int(np.argmax(np.abs(norms - 1.0)))
            raise DataError(f"measurement ({source.kind}): the reading at {readings[k][0]:.3f} s has a quaternion of "
                            f"norm {norms[k]:.6g}, not a unit quaternion")
        quaternions = quaternions / norms[:, None]
    return MeasurementStream(np.array([t for t, _ in readings]), values[:, :3], quaternions)


def read_bag(path: str | Path, joints_topic: str, source: MeasurementSource) -> tuple[JointStates, MeasurementStream]:
    """The joint states of ``joints_topic`` and the measurement ``source`` of the bag at ``path``.

    Raises:
        DataError: not a bag; a topic carrying another message type, or empty; a non-unit quaternion.
        NotFoundError: a topic (or a TF transform) the bag does not have, listing those it has.
    """
    reader = _open(Path(path))
    try:
        return _joint_states(reader, joints_topic), _stream(reader, source)
    finally:
        reader.close()
