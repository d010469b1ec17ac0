"""A ROS bag's errors name their culprit as fields beside the message: the bag (or its metadata file and line), the
message by its number on its topic, the joint or the reading's value; ``pincal import`` still says it in one line."""

from __future__ import annotations

from pathlib import Path

import numpy as np
import pytest
from conftest import run_pincal
from test_bag_faults import UR10_JOINTS, write_bag

import pincal
from pincal.errors import DataError, NotFoundError
from pincal.io.bag_dataset import bag_dataset
from pincal.io.bags import JointStates, MeasurementSource, read_bag, read_joint_states
from pincal.io.detections import bag_joints

POSE = MeasurementSource("pose", "/mocap/tool")


def test_a_damaged_message_is_named_by_its_number(tmp_path: Path) -> None:
    bag = write_bag(tmp_path / "damaged.bag", damaged=8)
    with pytest.raises(DataError, match="is damaged") as caught:
        read_bag(bag, "/joint_states", POSE)
    assert (caught.value.file, caught.value.sample, caught.value.column) == (str(bag), 8, None)
    with pytest.raises(DataError, match="is damaged") as caught:
        read_joint_states(str(bag), "/joint_states")
    assert (caught.value.file, caught.value.sample) == (str(bag), 8)


def test_a_reading_that_is_not_finite_is_named_by_message_and_value(tmp_path: Path) -> None:
    bag = write_bag(tmp_path / "nan.bag", nan_quaternion=11)
    with pytest.raises(DataError, match="holds qx = nan") as caught:
        read_bag(bag, "/joint_states", POSE)
    assert (caught.value.file, caught.value.sample, caught.value.column) == (str(bag), 11, "qx")


def test_a_topic_the_bag_lacks_names_the_bag(tmp_path: Path) -> None:
    bag = write_bag(tmp_path / "r.bag")
    with pytest.raises(NotFoundError) as caught:
        read_bag(bag, "/joints", POSE)
    assert (caught.value.file, caught.value.name) == (str(bag), "/joints")
    missing = tmp_path / "missing.bag"
    with pytest.raises(DataError, match="does not exist") as caught:
        read_bag(missing, "/joint_states", POSE)
    assert caught.value.file == str(missing)


def test_a_metadata_file_that_does_not_parse_is_named_with_its_line(tmp_path: Path) -> None:
    bag = tmp_path / "ros2"
    bag.mkdir()
    (bag / "metadata.yaml").write_text("rosbag2_bagfile_information:\n  version: 5: 6\n", encoding="utf-8")
    with pytest.raises(DataError, match="is not a ROS bag") as caught:
        read_bag(bag, "/joint_states", POSE)
    assert (caught.value.file, caught.value.line) == (str(bag / "metadata.yaml"), 2)


def test_a_joint_at_fault_is_named_as_the_column(tmp_path: Path) -> None:
    robot = pincal.load_robot("ur10")
    bag = write_bag(tmp_path / "no_wrist.bag", names=UR10_JOINTS[:5])
    with pytest.raises(DataError, match="never carries wrist_3_joint") as caught:
        bag_dataset(robot, bag, "/joint_states", POSE)
    assert (caught.value.file, caught.value.column, caught.value.option) == (str(bag), "wrist_3_joint",
                                                                             "joints_topic")
    with pytest.raises(DataError, match="carry no wrist_3_joint") as caught:
        bag_joints(str(bag), "/joint_states", UR10_JOINTS)
    assert (caught.value.file, caught.value.column) == (str(bag), "wrist_3_joint")
    infinite = write_bag(tmp_path / "inf.bag", infinite_from=161)
    with pytest.raises(DataError, match="shoulder_lift_joint = inf") as caught:
        bag_dataset(robot, infinite, "/joint_states", POSE)
    assert (caught.value.file, caught.value.column) == (str(infinite), "shoulder_lift_joint")


def test_joint_states_not_finite_name_the_joint_without_a_file() -> None:
    states = JointStates(np.array([0.0, 0.1]), ["a", "b"], np.array([[0.0, 0.0], [0.0, np.nan]]),
                         np.ones((2, 2), dtype=bool))
    with pytest.raises(DataError, match="holds b = nan") as caught:
        states.check_finite(["a", "b"], "/joint_states")
    assert (caught.value.file, caught.value.column) == (None, "b")


def test_the_command_names_the_damaged_message(tmp_path: Path) -> None:
    bag = write_bag(tmp_path / "damaged.bag", damaged=3)
    done = run_pincal("import", "ur10", str(bag), "--joints", "/joint_states", "--pose", "/mocap/tool", "--out",
                      str(tmp_path / "out.csv"))
    assert done.returncode == 2, done.stderr
    lines = done.stderr.splitlines()
    assert len(lines) == 1 and lines[0].startswith(f"pincal: error: joint states: '{bag}' is damaged: message 3 on "
                                                   "'/joint_states'"), done.stderr
    assert not (tmp_path / "out.csv").exists()


@pytest.mark.parametrize(("spoiled", "message", "fields"), [
    ({"nan_quaternion": 11}, "holds qx = nan", (11, "qx")),
    ({"damaged": 8}, "is damaged: message 8", (8, None)),
    ({"infinite_from": 161}, "shoulder_lift_joint = inf", (None, "shoulder_lift_joint")),
])
def test_a_job_files_bag_keeps_the_bags_message_and_column(tmp_path: Path, spoiled: dict[str, int], message: str,
                                                          fields: tuple[int | None, str | None]) -> None:
    """A job file's ``[bag]`` names the job file as ``file`` (the bag's culprit in the text), and keeps the bag's
    message number as ``sample`` and its joint or value as ``column``."""
    from pincal.calibration.job import load_job_robot, read_job
    from pincal.calibration.job_data import job_dataset

    write_bag(tmp_path / "run.bag", **spoiled)  # type: ignore[arg-type]
    path = tmp_path / "job.toml"
    path.write_text('robot = "ur10"\n\n[bag]\nfile = "run.bag"\njoints = "/joint_states"\npose = "/mocap/tool"\n',
                    encoding="utf-8")
    job = read_job(path)
    with pytest.raises(DataError, match=message) as caught:
        job_dataset(job, load_job_robot(job))
    assert str(caught.value).startswith(f"{path}: [bag]: ")
    assert (caught.value.file, caught.value.sample, caught.value.column) == (str(path), *fields)
