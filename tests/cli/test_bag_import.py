"""``pincal import ROBOT BAG`` and a job file's ``[bag]`` (docs/bags.md), run as a user runs them.

A UR10 with errors of 1 mm / 1 mrad is simulated (``pincal simulate``: 24 postures to calibrate from, 10 held out, the
tool's pose measured with noise σ 0.1 mm / 0.1 mrad). examples/ros_bag.py records its 24 postures as the robot would
stream them: joint states at 100 Hz (shuffled, a gripper joint besides), the tool's pose at 50 Hz (noise 0.3 mm /
0.3 mrad per reading, the quaternion's sign flipped at random), smooth moves between postures, and three stops that
must not be kept: one too short, one with the tracker occluded, one with the tracked body sliding 5 mm. ``pincal
import`` finds the 24 and drops the 3, saying why; calibrating from its CSV predicts the 34 simulated postures (10
unseen) as well as calibrating from the simulation's own CSV (``pincal check``).
"""

from __future__ import annotations

import re
import subprocess
import sys
from pathlib import Path

import numpy as np
import pytest
from conftest import ROOT, run_pincal

from pincal.cli import bag_import
from pincal.cli.app import main
from pincal.io import bags, postures
from pincal.io.dataset import dataset_text
from pincal.io.dataset_reader import read_dataset

KEY = "pose:tool0"
PAGE = ROOT / "docs" / "bags.md"


def _ok(done: object) -> None:
    assert done.returncode == 0, done.stdout + done.stderr  # type: ignore[attr-defined]


def _example(*args: str) -> None:
    """``python examples/ros_bag.py ARGS``, as docs/bags.md runs it."""
    _ok(subprocess.run([sys.executable, str(ROOT / "examples" / "ros_bag.py"), *args], capture_output=True, text=True,
                       timeout=300, check=False))


@pytest.fixture(scope="module")
def recorded(tmp_path_factory: pytest.TempPathFactory) -> Path:
    """The commands of docs/bags.md: sim/ (the simulation), train.csv and test.csv (its two sets), run.bag (ROS 1,
    PoseStamped /mocap/tool, header stamps), run/ (ROS 2 mcap, the pose as TF mocap -> tool, no header stamps),
    marker/ (ROS 2 sqlite3, the tool's origin as PointStamped /marker)."""
    root = tmp_path_factory.mktemp("bags")
    _ok(run_pincal("simulate", "ur10", "--measure", "pose", "--samples", "24", "--test-samples", "10", "--noise",
                   "1e-4", "--seed", "3", "--out", "sim", "--quiet", cwd=root))
    data = read_dataset(root / "sim" / "measurements.csv")
    (root / "train.csv").write_text(dataset_text(data.of_set("train")), encoding="utf-8")
    sim = str(root / "sim" / "measurements.csv")
    _example(sim, str(root / "run.bag"))
    _example(sim, str(root / "run"), "--storage", "mcap", "--measure", "tf", "--no-stamps")
    _example(sim, str(root / "marker"), "--storage", "sqlite3", "--measure", "point")
    return root


def _checked(root: Path, urdf: Path) -> tuple[float, float]:
    """The RMS position errors [m] of ``urdf`` and of the nominal robot on the 34 simulated postures (24 calibrated
    from, 10 not), as ``pincal check`` prints them."""
    done = run_pincal("check", str(urdf), str(root / "sim" / "measurements.csv"), "--nominal", "ur10")
    _ok(done)
    found = re.search(r"lengths:\s+MODEL ([\d.]+) mm RMS, [\d.]+ mm max; nominal ([\d.]+) mm RMS", done.stdout)
    assert found, done.stdout
    return float(found[1]) * 1e-3, float(found[2]) * 1e-3


@pytest.fixture(scope="module")
def csv_route(recorded: Path) -> tuple[float, float]:
    """``pincal check`` of the calibration from the simulation's own CSV: its RMS and the nominal robot's [m]."""
    _ok(run_pincal("calibrate", "ur10", str(recorded / "sim" / "measurements.csv"), "--out",
                   str(recorded / "csv.urdf")))
    return _checked(recorded, recorded / "csv.urdf")


@pytest.fixture(scope="module")
def imported(recorded: Path) -> str:
    """The output of docs/bags.md's ``pincal import`` (run in the bag's directory, as there)."""
    done = run_pincal("import", "ur10", "run.bag", "--joints", "/joint_states", "--pose", "/mocap/tool", "--out",
                      "data.csv", cwd=recorded)
    _ok(done)
    return done.stdout


@pytest.fixture(scope="module")
def bag_route(recorded: Path, imported: str) -> tuple[float, float]:
    """``pincal check`` of the calibration from the imported CSV (cal.urdf): its RMS and the nominal robot's [m]."""
    _ok(run_pincal("calibrate", "ur10", "data.csv", "--out", "cal.urdf", cwd=recorded))
    return _checked(recorded, recorded / "cal.urdf")


def test_import_finds_the_postures_and_calibrates_as_well_as_the_csv(recorded: Path, imported: str,
                                                                     csv_route: tuple[float, float],
                                                                     bag_route: tuple[float, float]) -> None:
    assert "not read: gripper_finger_joint" in imported and "kept 24 of 27" in imported
    dropped = re.findall(r"(p\d+) .*dropped, ([a-z ]+) \(", imported)
    assert dropped == [("p4", "too short"), ("p9", "measurement missing"), ("p14", "measurement moving")]
    out = recorded / "data.csv"
    header = [line for line in out.read_text(encoding="utf-8").splitlines() if line.startswith("# posture ")]
    assert len(header) == 27 and "dropped, measurement missing" in header[8]
    data, train = read_dataset(out), read_dataset(recorded / "train.csv")
    assert data.n_samples == 24 and data.joint_names == train.joint_names
    np.testing.assert_allclose(data.joints, train.joints, atol=2e-5)  # [rad]: still within the tolerance
    np.testing.assert_allclose(data.measurements[KEY][:, :3], train.measurements[KEY][:, :3], atol=2e-4)  # [m]

    assert bag_route[0] < 1.2 * csv_route[0] and bag_route[0] < 0.1 * bag_route[1]


def test_the_page_quotes_what_the_commands_print(imported: str, csv_route: tuple[float, float],
                                                 bag_route: tuple[float, float]) -> None:
    """docs/bags.md's output lines are the command's, and its figures those of ``pincal check`` (0.01 mm)."""
    page = PAGE.read_text(encoding="utf-8")
    quoted = [line for line in page.splitlines() if re.match(r"\s+p\d+  t ", line) or line.startswith("kept ")]
    assert len(quoted) == 6 and all(line in imported.splitlines() for line in quoted)
    figures = re.search(r"predicts the 34 postures to \*\*([\d.]+) mm\*\* RMS, the one calibrated from the CSV to\s+"
                        r"([\d.]+) mm, the nominal robot to ([\d.]+) mm", page)
    assert figures, "docs/bags.md's sentence of figures"
    assert figures.groups() == tuple(f"{v * 1e3:.2f}" for v in (bag_route[0], csv_route[0], csv_route[1]))


def test_a_job_file_reads_a_ros2_bag_with_the_pose_on_tf(recorded: Path, csv_route: tuple[float, float]) -> None:
    job = recorded / "job.toml"
    job.write_text('robot = "ur10"\nout = "job.urdf"\n\n[bag]\nfile = "run"\njoints = "/joint_states"\n'
                   'tf = ["mocap", "tool"]\nframe = "tool0"\n', encoding="utf-8")
    done = run_pincal("calibrate", str(job))
    _ok(done)
    assert "samples in the file 24" in done.stdout
    assert _checked(recorded, recorded / "job.urdf")[0] < 1.2 * csv_route[0]


def test_a_marker_point_gives_position_columns(recorded: Path) -> None:
    out = recorded / "marker.csv"
    _ok(run_pincal("import", "ur10", str(recorded / "marker"), "--joints", "/joint_states", "--point", "/marker",
                   "--out", str(out)))
    imported, train = read_dataset(out), read_dataset(recorded / "train.csv")
    assert list(imported.measurements) == ["position:tool0"]  # the robot's measured frame, by default
    np.testing.assert_allclose(imported.measurements["position:tool0"], train.measurements[KEY][:, :3], atol=2e-4)


def test_bad_input_is_one_line_and_exit_2(recorded: Path, tmp_path: Path, capsys: pytest.CaptureFixture[str]) -> None:
    """One case as a user meets it (a subprocess), the others through the same entry point in this process."""
    bag = str(recorded / "run.bag")
    done = run_pincal("import", "ur10", bag, "--joints", "/joints", "--pose", "/mocap/tool", "--out",
                      str(tmp_path / "x.csv"))
    assert done.returncode == 2 and done.stderr.startswith("pincal: error: joint states: topic '/joints' does not "
                                                           "exist in the bag; topics are: /joint_states")
    assert len(done.stderr.strip().splitlines()) == 1
    cases = [
        ([bag, "--joints", "/joint_states", "--point", "/mocap/tool"], "carries geometry_msgs/msg/PoseStamped, not "
                                                                       "geometry_msgs/msg/PointStamped"),
        ([bag, "--joints", "/joint_states", "--pose", "/mocap/tool", "--still-time", "5"], "no posture of"),
        ([bag, "--joints", "/joint_states", "--pose", "/mocap/tool", "--frame", "tool9"], "frame 'tool9' does not "
                                                                                          "exist"),
        ([str(recorded / "train.csv"), "--joints", "/j", "--pose", "/p"], "is not a ROS bag pincal can read"),
        ([bag, "--joints", "/joint_states", "--pose", "/mocap/tool", "--still-time", "0"], "--still-time"),
    ]
    for flags, message in cases:
        assert _status(["import", "ur10", *flags, "--out", str(tmp_path / "x.csv")]) == 2
        error = capsys.readouterr().err
        assert message in error and error.startswith("pincal: error: ") and len(error.strip().splitlines()) == 1
    assert not (tmp_path / "x.csv").exists()
    job = tmp_path / "job.toml"
    job.write_text(f'robot = "ur10"\n[bag]\nfile = "{recorded / "run"}"\njoints = "/joint_states"\npose = "/p"\n'
                   'point = "/q"\n', encoding="utf-8")
    assert _status(["calibrate", str(job)]) == 2
    assert "[bag]: name the measurement by one of" in capsys.readouterr().err


def _status(argv: list[str]) -> int | str | None:
    """``pincal ARGV``'s exit status, run in this process (argument errors included)."""
    try:
        return main(argv)
    except SystemExit as stop:
        return stop.code


def test_the_command_line_spells_the_defaults_of_the_library() -> None:
    assert bag_import.STILL_TOLERANCE == postures.STILL_TOLERANCE
    assert bag_import.STILL_TIME == postures.STILL_TIME and bag_import.DRIFT == postures.DRIFT
    assert bag_import.TF_TOPIC == bags.TF_TOPIC
