"""Robot files as a user hands them over: one too large to read is refused before it is read; one bloated by blanks
reads as the robot itself; the frame measured by default, found by its name where the tree has several ends."""

from __future__ import annotations

from pathlib import Path

import pytest
from conftest import run_pincal
from test_job_file import one_line_error

from pincal.errors import RobotFileError
from pincal.model.catalog import robot_path
from pincal.model.robot import robot_from_urdf_text


def ur10_text() -> str:
    """The UR10's URDF as example-robot-data ships it."""
    return robot_path("ur10").read_text(encoding="utf-8")


def bloated(text: str, bloat: str) -> str:
    """``text`` with ``bloat`` before its ``</robot>``."""
    end = text.index("</robot>")
    return text[:end] + bloat + text[end:]


def test_a_robot_file_above_the_size_cap_is_refused_before_it_is_read(tmp_path: Path) -> None:
    # the documented cap: 10 MiB (README, "Loops in URDF"); a 50 MB file took minutes of CPU to simulate
    big = tmp_path / "big.urdf"
    big.write_text(bloated(ur10_text(), "<!-- " + "x" * 10 * 2**20 + " -->\n"), encoding="utf-8")
    for command in (["simulate", str(big), "--out", str(tmp_path / "sim")], ["info", str(big)],
                    ["assemble", str(big), "--out", str(tmp_path / "assembled.urdf")]):
        line = one_line_error(run_pincal(*command))
        assert f"'{big}' is 10.0 MiB; pincal reads robot files of at most 10 MiB" in line, line
    assert sorted(p.name for p in tmp_path.iterdir()) == ["big.urdf"]  # nothing written
    with pytest.raises(RobotFileError, match=r"^URDF is 10\.0 MiB; pincal reads robot files of at most 10 MiB"):
        robot_from_urdf_text(big.read_text(encoding="utf-8"))


def test_a_urdf_bloated_by_blanks_reads_as_the_robot_itself(tmp_path: Path) -> None:
    # a run of blanks was rescanned from each of its characters: 1 MB of them took more than 8 CPU-minutes
    text = ur10_text()
    joint = text.index("<origin", text.index('<joint name="shoulder_pan_joint"'))
    spaced = text[:joint] + "<origin" + " " * 200_000 + text[joint + len("<origin"):]  # blanks inside a tag too
    (tmp_path / "spaced.urdf").write_text(bloated(spaced, " " * 1_000_000), encoding="utf-8")
    (tmp_path / "plain.urdf").write_text(text, encoding="utf-8")
    for name in ("plain", "spaced"):
        done = run_pincal("simulate", f"{name}.urdf", "--samples", "5", "--seed", "3", "--quiet", "--out", name,
                          cwd=tmp_path)
        assert done.returncode == 0, done.stderr
    plain, spaced_out = ((tmp_path / name / "measurements.csv").read_text(encoding="utf-8").splitlines()
                         for name in ("plain", "spaced"))
    assert [line for line in plain if not line.startswith("#")] == \
        [line for line in spaced_out if not line.startswith("#")]
    truth = (tmp_path / "spaced" / "truth.urdf").read_text(encoding="utf-8")
    assert truth.count("<pincal_provenance ") == 1 and " " * 1_000_000 in truth


def info_frame_line(robot: str) -> str:
    """The ``measured frame (default): …`` line of ``pincal info ROBOT``."""
    done = run_pincal("info", robot)
    assert done.returncode == 0, done.stderr
    return next(line for line in done.stdout.splitlines() if line.startswith("measured frame (default): "))


@pytest.mark.parametrize(("robot", "frame"), [("kinova", "j2s6s200_end_effector"),
                                              ("talos_arm", "wrist_left_ft_tool_link"),
                                              ("anymal_kinova", "j2s6s200_end_effector")])
def test_the_one_frame_named_like_an_end_effector_or_a_tool_is_measured(robot: str, frame: str) -> None:
    # Kinova's fingers are three moving ends; the arm's end effector sits above them
    assert info_frame_line(robot).startswith(f"measured frame (default): {frame}, moved by the actuated joints (the "
                                             "one frame named like an end effector or a tool); at (")


def test_a_tool_frame_on_each_arm_is_named_not_chosen(tmp_path: Path) -> None:
    assert info_frame_line("talos") == (
        "measured frame (default): none: robot 'talos' has 2 frames named like an end effector or a tool, on "
        "different branches: wrist_left_ft_tool_link, wrist_right_ft_tool_link; none of them is the obvious measured "
        "frame: name it (--frame, or the frame in the measurement keys)")
    done = run_pincal("simulate", "kinova", "--samples", "5", "--quiet", "--out", "sim", cwd=tmp_path)
    assert done.returncode == 0, done.stderr
    columns = next(line for line in (tmp_path / "sim" / "measurements.csv").read_text(encoding="utf-8").splitlines()
                   if not line.startswith("#")).split(",")
    assert columns[-3:] == [f"position:j2s6s200_end_effector:{axis}" for axis in "xyz"]
