"""Job files whose data is a ROS bag: a ``[bag]`` table in place of ``[data]`` and ``[[measure]]`` (docs/bags.md).

```toml
robot = "ur10"
[bag]
file = "run.bag"            # a ROS 1 .bag, a ROS 2 bag directory or an .mcap file, relative to the job file
joints = "/joint_states"
pose = "/mocap/tool"        # or tf = ["mocap", "tool"] (tf_topic = "/tf"), or point = "/marker"
frame = "tool0"             # optional: the robot frame measured (default: the robot's measured frame)
still_tolerance = 1e-3      # optional [rad or m], still_time = 1.0 [s], drift = 1e-3 [m, rad]
```

The calibration options, ``out`` and ``report`` are those of any job file (:mod:`pincal.calibration.job`).
"""

from __future__ import annotations

import math
from collections import Counter
from pathlib import Path
from typing import TYPE_CHECKING, Any

from pincal.calibration.job_reader import Job, JobReader
from pincal.calibration.options import JOB_OPTIONS
from pincal.errors import DataError, NotFoundError
from pincal.io.bag_dataset import BagSource
from pincal.io.bags import TF_TOPIC, MeasurementSource
from pincal.io.dataset import Dataset
from pincal.io.postures import DRIFT, STILL_TIME, STILL_TOLERANCE, StillRule

if TYPE_CHECKING:
    from pincal.model.robot import Robot

#: Keys of the top level of a job with a ``[bag]``, and of its ``[bag]`` table.
BAG_JOB_KEYS = ("robot", "bag", "out", "report", *JOB_OPTIONS)
BAG_KEYS = ("file", "joints", "pose", "tf", "tf_topic", "point", "frame", "still_tolerance", "still_time", "drift")
#: The keys that name the measurement, one of which a ``[bag]`` gives.
SOURCE_KEYS = ("pose", "tf", "point")


def _positive(reader: JobReader, table: dict[str, Any], key: str, default: float) -> float:
    """``table[key]``, a finite number > 0 [SI], or ``default``."""
    value = table.get(key, default)
    if isinstance(value, bool) or not isinstance(value, int | float) or not 0.0 < value < math.inf:
        raise reader.error(f"[bag] {key}", f"{value!r} is not a number > 0")
    return float(value)


def _source(reader: JobReader, table: dict[str, Any]) -> MeasurementSource:
    given = [key for key in SOURCE_KEYS if key in table]
    if len(given) != 1:
        raise reader.error("[bag]", "name the measurement by one of pose = \"TOPIC\", tf = [\"PARENT\", \"CHILD\"] "
                                    f"or point = \"TOPIC\" (got {len(given)})")
    kind = given[0]
    if "tf_topic" in table and kind != "tf":
        raise reader.error("[bag] tf_topic", "applies to tf = [\"PARENT\", \"CHILD\"] alone")
    if kind != "tf":
        return MeasurementSource(kind, reader.text(table[kind], f"[bag] {kind}"))  # type: ignore[arg-type]
    frames = reader.texts(table["tf"], "[bag] tf")
    if len(frames) != 2:
        raise reader.error("[bag] tf", f"{len(frames)} frames; give [\"PARENT\", \"CHILD\"]")
    return MeasurementSource("tf", reader.text(table.get("tf_topic", TF_TOPIC), "[bag] tf_topic"), *frames)


def _bag(reader: JobReader, table: dict[str, Any]) -> BagSource:
    reader.keys(table, BAG_KEYS, "in [bag]")
    for key in ("file", "joints"):
        if key not in table:
            raise reader.error("[bag]", f"'{key}' is missing (keys are: {', '.join(BAG_KEYS)})")
    written = reader.text(table["file"], "[bag] file")
    path = reader.base / Path(written).expanduser()
    if not path.exists():
        raise reader.error("[bag] file", f"'{written}' does not exist (looked for '{path.absolute()}': paths in a job "
                                         "file are relative to its directory)")
    rule = StillRule(_positive(reader, table, "still_tolerance", STILL_TOLERANCE),
                     _positive(reader, table, "still_time", STILL_TIME), _positive(reader, table, "drift", DRIFT))
    frame = reader.text(table["frame"], "[bag] frame") if "frame" in table else None
    return BagSource(path, reader.text(table["joints"], "[bag] joints"), _source(reader, table), frame, rule)


def read_bag_job(reader: JobReader, doc: dict[str, Any]) -> Job:
    """The job of ``doc``, a job file with a ``[bag]`` table, read and checked by ``reader`` (its file, its place):
    the robot, the bag, the outputs and the calibration options.

    Raises:
        DataError: naming the job file, the place in it and the fault; NotFoundError for an unknown key.
    """
    reader.keys(doc, BAG_JOB_KEYS, "at the top level of a job with a [bag] (it has no [data] nor [[measure]])")
    if "robot" not in doc:
        raise reader.error("'robot' is missing", "a job names its robot")
    robot = reader.text(doc["robot"], "robot")
    if (reader.base / robot).is_file() or Path(robot).suffix or "/" in robot:  # a path, else a robot's name
        robot = str(reader.file(robot, "robot")[0])
    bag = _bag(reader, reader.table(doc["bag"], "[bag]"))
    outputs = {name: reader.file(doc[name], name, must_exist=False)[0] if name in doc else None
               for name in ("out", "report")}
    files = bag.files
    return Job(reader.path, robot, tuple(files), tuple(str(f) for f in files), outputs["out"], outputs["report"],
               reader.options(doc), bag=bag)


def bag_job_dataset(job: Job, bag: BagSource, robot: Robot) -> Dataset:
    """The dataset of ``job``'s ``bag`` for ``robot``: its kept postures (as ``pincal import`` writes them).

    Raises:
        DataError: the bag cannot be read, or no posture is kept (the reasons counted); its ``file`` the job file,
            its ``sample`` and ``column`` the bag's (the message by its number on its topic, the joint or value).
        NotFoundError: a topic, transform or frame that does not exist; fields as DataError's.
    """
    where = f"{job.path}: [bag]: "
    try:
        done = bag.read(robot)
    except NotFoundError as exc:  # the job file as the file; the bag's message and joint kept (the text names the bag)
        raise NotFoundError(f"{where}{exc}", exc.kind, exc.name, exc.choices, file=str(job.path), sample=exc.sample,
                            column=exc.column) from None
    except DataError as exc:
        raise DataError(f"{where}{exc}", file=str(job.path), sample=exc.sample, column=exc.column) from None
    if not done.dataset.n_samples:
        reasons = Counter(p.reason.partition(" (")[0] for p in done.postures)
        raise DataError(f"{where}no posture of {len(done.postures)} kept: "
                        + ", ".join(f"{n} {reason}" for reason, n in reasons.items())
                        + f" (pincal import {job.robot} {bag.path} ... prints each)", file=str(job.path))
    return done.dataset
