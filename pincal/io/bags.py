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

import itertools
import math
import struct
from collections.abc import Iterator, Sequence
from pathlib import Path
from typing import TYPE_CHECKING, Any, Literal

import numpy as np
import numpy.typing as npt

from pincal import validation
from pincal.errors import ArgumentError, Culprit, DataError, listing, not_found
from pincal.progress import Progress
from pincal.records import record

if TYPE_CHECKING:
    from rosbags.highlevel import AnyReader

Array = npt.NDArray[np.float64]
SourceKind = Literal["pose", "tf", "point"]

JOINT_STATE = "sensor_msgs/msg/JointState"
#: The message type each measurement kind reads.
MESSAGE_TYPES: dict[str, str] = {"pose": "geometry_msgs/msg/PoseStamped", "tf": "tf2_msgs/msg/TFMessage",
                                 "point": "geometry_msgs/msg/PointStamped"}
TF_TOPIC = "/tf"


@record(frozen=True)
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
        """Refuse a kind that is not one of :data:`MESSAGE_TYPES`, a topic or frame that is not a string, and a
        ``tf`` source without its two frames.

        Raises:
            TypeError: a topic or frame of another type.
            ArgumentError: an unknown kind, or a ``tf`` source without a parent and a child frame.
        """
        if self.kind not in MESSAGE_TYPES:
            raise ArgumentError(f"kind={validation.shown(self.kind)}: must be one of {', '.join(MESSAGE_TYPES)}")
        for name in ("topic", "parent", "child"):
            validation.instance(name, getattr(self, name), str, "a string")
        if self.kind == "tf" and not (self.parent and self.child):
            raise ArgumentError(f"kind='tf' needs parent= and child=, the frames of the transform (got "
                                f"{self.parent!r}, {self.child!r})")

    @property
    def oriented(self) -> bool:
        """Whether the measurement has an orientation (a pose), not a point alone."""
        return self.kind != "point"

    def describe(self) -> str:
        """In words: ``PoseStamped /mocap/tool``, ``TF world -> tool on /tf``, ``PointStamped /marker``."""
        if self.kind == "tf":
            return f"TF {self.parent} -> {self.child} on {self.topic}"
        return f"{MESSAGE_TYPES[self.kind].rpartition('/')[2]} {self.topic}"


@record(frozen=True)
class JointStates:
    """The joint-state messages of one topic, in time order.

    Attributes:
        times: (M,) message times [s].
        names: The joint names the messages carry, in the order first seen (grippers and other extras included).
        positions: (M, len(names)) positions [rad or m]; NaN where a message did not carry that joint.
        carried: (M, len(names)) whether each message carried each joint (a reading NaN or infinite included); None:
            where ``positions`` is not NaN.
    """

    times: Array
    names: list[str]
    positions: Array
    carried: npt.NDArray[np.bool_] | None = None

    def check_finite(self, names: Sequence[str], topic: str) -> None:
        """Refuse a NaN or infinite reading of one of the joints ``names`` (those a calibration reads).

        Raises:
            DataError: the first such message, by its time from the recording's first [s], the joint (its
                ``column``) and the value, and how many messages hold one.
        """
        columns = [self.names.index(name) for name in names]
        values = self.positions[:, columns]
        carried = self.carried[:, columns] if self.carried is not None else ~np.isnan(values)
        bad = carried & ~np.isfinite(values)
        rows = np.flatnonzero(np.any(bad, axis=1))
        if rows.size:
            row = int(rows[0])
            shown = ", ".join(f"{names[int(k)]} = {values[row, k]}" for k in np.flatnonzero(bad[row]))
            more = f" (and {rows.size - 1} more messages)" if rows.size > 1 else ""
            at = float(self.times[row] - self.times[0])
            raise DataError(f"joint states: the message on '{topic}' at t {at:.2f} s (from the recording's first) "
                            f"holds {shown}{more}: a joint reading must be a finite number [rad or m]",
                            column=names[int(np.flatnonzero(bad[row])[0])])


@record(frozen=True)
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


def _read_errors() -> tuple[type[Exception], ...]:
    """What reading a damaged bag raises: rosbags' errors, and those of the bytes it decodes (decompression, sizes,
    text)."""
    from rosbags.highlevel import AnyReaderError
    from rosbags.rosbag1 import ReaderError as Reader1Error
    from rosbags.rosbag2 import ReaderError as Reader2Error
    from rosbags.serde import SerdeError

    return AnyReaderError, Reader1Error, Reader2Error, SerdeError, OSError, ValueError, struct.error, IndexError, \
        KeyError, EOFError


def _parser_error(exc: BaseException) -> BaseException | None:
    """The parser's error under ``exc`` (a YAML parser's, with a ``problem`` and its ``problem_mark``), or None."""
    cause: BaseException | None = exc
    while cause is not None:
        if getattr(cause, "problem", None) and getattr(cause, "problem_mark", None) is not None:
            return cause
        cause = cause.__cause__ or cause.__context__
    return None


def one_line(exc: BaseException) -> str:
    """``exc``'s message on one line: a YAML parser's as ``line 5, column 4: <its problem>``, another's lines
    joined."""
    parser = _parser_error(exc)
    if parser is not None:
        mark = parser.problem_mark  # type: ignore[attr-defined]
        return f"line {mark.line + 1}, column {mark.column + 1}: {parser.problem}"  # type: ignore[attr-defined]
    return " ".join(str(exc).split()) or type(exc).__name__


def _open(path: Path) -> AnyReader:
    """An open reader of the bag at ``path``.

    Raises:
        DataError: the path does not exist or is not a bag rosbags can read (a ROS 2 bag's metadata file that does
            not parse: that file and its line as the fields).
    """
    from rosbags.highlevel import AnyReader
    from rosbags.typesys import Stores, get_typestore

    if not path.exists():
        raise DataError(f"bag '{path}' does not exist")
    try:
        reader = AnyReader([path], default_typestore=get_typestore(Stores.ROS2_HUMBLE))
        reader.open()
    except _read_errors() as exc:
        parser = _parser_error(exc) if path.is_dir() else None  # the metadata file, by its line
        where = f"{path / 'metadata.yaml'}, " if parser is not None else ""
        raise DataError(f"'{path}' is not a ROS bag pincal can read (a ROS 1 .bag, a ROS 2 bag directory or an "
                        f".mcap file): {where}{one_line(exc)}", file=str(path / "metadata.yaml") if parser else None,
                        line=parser.problem_mark.line + 1 if parser else None) from None  # type: ignore[attr-defined]
    except TypeError:  # rosbags' MCAP reader on a file cut short after its magic: ord() of an empty read
        raise DataError(f"'{path}' is not a ROS bag pincal can read (a ROS 1 .bag, a ROS 2 bag directory or an "
                        ".mcap file): the file ends early (truncated or damaged)") from None
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


def _messages(reader: AnyReader, bag: Path, connections: list[Any], role: str,
              progress: bool = False) -> Iterator[tuple[int, Any, int]]:
    """Each message of ``connections``: its number on the topic (from 1, in the bag's order), the message
    deserialised, its bag time [ns]; with ``progress``, a bar on stderr (on a terminal) counting the topic's messages.

    Raises:
        DataError: the bag's bytes do not hold a message (a damaged bag, its index intact): the bag, the topic and the
            message named (its number the error's ``sample``).
    """
    errors = _read_errors()
    topic = connections[0].topic
    stream = reader.messages(connections=connections)
    total = sum(int(getattr(c, "msgcount", 0) or 0) for c in connections)
    with Progress(f"reading {topic}", total, quiet=not progress) as bar:
        for number in itertools.count(1):
            try:
                item = next(stream, None)
            except errors as exc:
                raise DataError(f"{role}: '{bag}' is damaged: message {number} on '{topic}' cannot be read: "
                                f"{one_line(exc)}", sample=number) from None
            if item is None:
                bar.finish()
                return
            connection, bag_time, raw = item
            try:
                message = reader.deserialize(raw, connection.msgtype)
            except errors as exc:
                raise DataError(f"{role}: '{bag}' is damaged: message {number} on '{topic}' (bag time "
                                f"{1e-9 * bag_time:.3f} s) is not a {connection.msgtype}: {one_line(exc)}",
                                sample=number) from None
            bar.advance()
            yield number, message, bag_time


def _joint_states(reader: AnyReader, bag: Path, topic: str, progress: bool = False) -> JointStates:
    rows: list[tuple[float, dict[str, float]]] = []
    role = "joint states"
    connections = _connections(reader, topic, JOINT_STATE, role)
    for number, msg, bag_time in _messages(reader, bag, connections, role, progress):
        positions = np.asarray(msg.position, dtype=float)
        if len(msg.name) != positions.size:
            raise DataError(f"joint states: message {number} on '{topic}' names {len(msg.name)} joints but holds "
                            f"{positions.size} positions", sample=number)
        rows.append((_stamp(msg.header, bag_time), dict(zip(msg.name, positions.tolist(), strict=True))))
    if not rows:
        raise DataError(f"joint states: topic '{topic}' holds no message")
    rows.sort(key=lambda row: row[0])
    names = list(dict.fromkeys(name for _, row in rows for name in row))
    positions = np.array([[row.get(name, np.nan) for name in names] for _, row in rows], dtype=float)
    carried = np.array([[name in row for name in names] for _, row in rows], dtype=bool)
    return JointStates(np.array([t for t, _ in rows]), names, positions, carried)


def _strip(frame: str) -> str:
    return frame.lstrip("/")


#: The fields of a reading, in the order :func:`_readings` gives them.
READING_FIELDS = ("x", "y", "z", "qx", "qy", "qz", "qw")


def _readings(reader: AnyReader, bag: Path, source: MeasurementSource,
              progress: bool = False) -> list[tuple[float, list[float]]]:
    """(time [s], x, y, z [m] and, for a pose, qx, qy, qz, qw) of each reading.

    Raises:
        DataError: a reading holds a NaN or an infinite value (the message, its time and the field named).
    """
    role = f"measurement ({source.kind})"
    found = []
    pairs: set[str] = set()
    connections = _connections(reader, source.topic, MESSAGE_TYPES[source.kind], role)
    for number, msg, bag_time in _messages(reader, bag, connections, role, progress):
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
        bad = [(k, v) for k, v in enumerate(found[-1][1]) if not math.isfinite(v)] if found else []
        if bad:
            shown = ", ".join(f"{READING_FIELDS[k]} = {v}" for k, v in bad)
            raise DataError(f"{role}: message {number} on '{source.topic}' (at {found[-1][0]:.3f} s) holds {shown}: "
                            "every value of a reading must be a finite number", sample=number,
                            column=READING_FIELDS[bad[0][0]])
    if not found and source.kind == "tf":
        raise not_found("transform", f"{source.parent} -> {source.child}", sorted(pairs), f" on {source.topic}",
                        f"{role}: ")
    if not found:
        raise DataError(f"{role}: topic '{source.topic}' holds no message")
    return sorted(found, key=lambda reading: reading[0])


def _stream(reader: AnyReader, bag: Path, source: MeasurementSource, progress: bool = False) -> MeasurementStream:
    readings = _readings(reader, bag, source, progress)
    values = np.array([v for _, v in readings], dtype=float)
    quaternions = None
    if source.oriented:
        quaternions = values[:, 3:7]
        with np.errstate(over="ignore"):  # a huge component: an infinite norm, refused below
            norms = np.linalg.norm(quaternions, axis=1)
        if np.any(np.abs(norms - 1.0) > 1e-3):
            k = int(np.argmax(np.abs(norms - 1.0)))
            raise DataError(f"measurement ({source.kind}): the reading at {readings[k][0]:.3f} s has a quaternion of "
                            f"norm {norms[k]:.6g}, not a unit quaternion")
        quaternions = quaternions / norms[:, None]
    return MeasurementStream(np.array([t for t, _ in readings]), values[:, :3], quaternions)


def read_bag(path: str | Path, joints_topic: str, source: MeasurementSource,
             progress: bool = False) -> tuple[JointStates, MeasurementStream]:
    """The joint states of ``joints_topic`` and the measurement ``source`` of the bag at ``path``; with ``progress``, a
    bar per topic on stderr (when it is a terminal) counting the messages read.

    Raises:
        TypeError: an argument of another type (None for the bag included).
        DataError: not a bag, or a damaged one; a topic carrying another message type, or empty; a measurement reading
            that is not finite; a non-unit quaternion. Its ``file`` is ``path``; a message at fault is its ``sample``
            (its number on the topic, from 1), a value at fault its ``column`` (``x`` … ``qw``).
        NotFoundError: a topic (or a TF transform) the bag does not have, listing those it has.
    """
    bag = Path(validation.path("path", path))
    topic = validation.instance("joints_topic", joints_topic, str, "a topic name (str)")
    validation.instance("source", source, MeasurementSource, "a MeasurementSource")
    with Culprit(file=str(path)):
        reader = _open(bag)
        try:
            return _joint_states(reader, bag, topic, progress), _stream(reader, bag, source, progress)
        finally:
            reader.close()


def read_joint_states(path: str | Path, topic: str, progress: bool = False) -> JointStates:
    """The joint states of ``topic`` in the bag at ``path``, in time order (times [s]: header stamps, else bag time).

    Raises:
        DataError: not a bag, or a damaged one; the topic carries another message type, or nothing (its ``file``
            ``path``, a message at fault its ``sample``: :func:`read_bag`).
        NotFoundError: a topic the bag does not have, listing those it has.
    """
    bag = Path(validation.path("path", path))
    with Culprit(file=str(path)):
        reader = _open(bag)
        try:
            return _joint_states(reader, bag, validation.instance("topic", topic, str, "a topic name (str)"), progress)
        finally:
            reader.close()
