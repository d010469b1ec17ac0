"""A ROS bag turned into the dataset a calibration reads (docs/bags.md): the robot's joints mapped by name from the
joint-state topic, the static postures found and averaged (:mod:`pincal.io.postures`), every posture kept or dropped
with its reason, recorded as ``# posture <n>: ...`` lines in the dataset's header."""

from __future__ import annotations

from pathlib import Path

from pincal import validation
from pincal.errors import Culprit, DataError, listing
from pincal.identification.parameters import influencing_joints
from pincal.io.bags import MeasurementSource, read_bag
from pincal.io.dataset import Dataset
from pincal.io.postures import DEFAULT_RULE, Posture, StillRule, find_postures, postures_dataset
from pincal.model.robot import Robot
from pincal.records import record


@record(frozen=True)
class BagSource:
    """A bag and what to read from it, as a job file's ``[bag]`` table gives them (docs/bags.md).

    Attributes:
        path: The bag: a ROS 1 .bag, a ROS 2 bag directory or an .mcap file.
        joints_topic: The joint-state topic.
        source: The measurement.
        frame: The robot frame the measurement follows, or None (the robot's measured frame).
        rule: What counts as a static posture.
    """

    path: Path
    joints_topic: str
    source: MeasurementSource
    frame: str | None = None
    rule: StillRule = DEFAULT_RULE

    @property
    def files(self) -> list[Path]:
        """The files the bag is made of: itself, or a ROS 2 bag directory's files."""
        return sorted(p for p in self.path.iterdir() if p.is_file()) if self.path.is_dir() else [self.path]

    def read(self, robot: Robot) -> BagImport:
        """:func:`bag_dataset` of this bag for ``robot``."""
        return bag_dataset(robot, self.path, self.joints_topic, self.source, self.frame, self.rule)


@record(frozen=True)
class BagImport:
    """What a bag gave.

    Attributes:
        dataset: The kept postures as a dataset (docs/dataset.md).
        postures: Every posture found, kept or dropped.
        joints: The robot's actuated joints the topic carries: the dataset's joint columns.
        absent: The robot's actuated joints the topic never carries, none of which moves the measured frame (taken at
            their reference value by ``pincal calibrate``).
        extra: The names the topic carries that are not actuated joints of the robot (grippers), not read.
        key: The dataset's measurement key (``pose:<frame>`` or ``position:<frame>``).
    """

    dataset: Dataset
    postures: list[Posture]
    joints: list[str]
    absent: list[str]
    extra: list[str]
    key: str


def bag_dataset(robot: Robot, path: str | Path, joints_topic: str, source: MeasurementSource,
                frame: str | None = None, rule: StillRule = DEFAULT_RULE, progress: bool = False) -> BagImport:
    """The dataset of the bag at ``path`` for ``robot``: the joint states of ``joints_topic`` mapped by name onto its
    actuated joints, the measurement ``source`` read as the pose (``pose``, ``tf``) or the position (``point``) of
    ``frame`` (default: the robot's measured frame), in the static postures ``rule`` finds; with ``progress``, a bar
    per topic read on stderr (when it is a terminal).

    Raises:
        TypeError: an argument of another type (None for the robot or the bag included).
        DataError: the bag, a topic or its messages (:func:`~pincal.io.bags.read_bag`); a topic carrying none of the
            robot's actuated joints, or never one that moves ``frame``; a joint reading that is not finite; no posture
            found.
        NotFoundError: a topic, transform or frame that does not exist, listing those that do.
    """
    validation.instance("robot", robot, Robot, "a Robot (pincal.load_robot)")
    validation.path("path", path)
    validation.instance("source", source, MeasurementSource, "a MeasurementSource")
    validation.instance("rule", rule, StillRule, "a StillRule")
    if frame is not None:
        validation.instance("frame", frame, str, "a frame name (str) or None")
    frame = frame or robot.end_effector
    robot.frame_id(frame, "the measured frame: ")
    states, stream = read_bag(path, joints_topic, source, progress)
    joints = [j for j in robot.actuated_joints if j in states.names]
    if not joints:
        raise DataError(f"joint states: topic '{joints_topic}' carries none of the actuated joints of '{robot.name}' "
                        f"({listing(robot.actuated_joints)}); it carries: {listing(states.names)}",
                        option="joints_topic", file=str(path))
    moving = set(influencing_joints(robot, [frame]))
    needed = [j for j in robot.actuated_joints if j not in states.names and j in moving]
    if needed:
        which = "which moves" if len(needed) == 1 else "which move"
        raise DataError(f"joint states: topic '{joints_topic}' never carries {listing(needed)}, {which} the measured "
                        f"frame '{frame}' (a calibration needs its readings); it carries: {listing(states.names)}",
                        option="joints_topic", column=needed[0], file=str(path))
    with Culprit(file=str(path)):
        states.check_finite(joints, joints_topic)
    postures = find_postures(states, joints, stream, rule)
    if not postures:
        raise DataError(f"no static posture in '{path}': the joints of '{joints_topic}' never stay within "
                        f"{rule.tolerance:g} rad or m for {rule.time:g} s (the still tolerance and time)",
                        file=str(path))
    key = f"{'pose' if source.oriented else 'position'}:{frame}"
    metadata = {"robot": robot.name, "units": "SI (m, rad)", "bag": Path(path).name,
                "joint states": joints_topic, "measurement": source.describe(),
                "recording start": f"{float(states.times[0])!r} s (posture times count from it)",
                "postures": f"joints within {rule.tolerance:g} rad or m for {rule.time:g} s or more, measurement "
                            f"drift at most {rule.drift:g} m or rad"}
    return BagImport(postures_dataset(postures, joints, key, metadata), postures, joints,
                     [j for j in robot.actuated_joints if j not in states.names],
                     [n for n in states.names if n not in robot.actuated_joints], key)
