"""URDF files that are wrong in ways Pinocchio reads silently are refused at load, naming the culprit."""

from __future__ import annotations

import re
from pathlib import Path

import pytest
from conftest import ROBOTS, run_pincal

import pincal
from pincal.errors import RobotFileError


def test_a_loop_nested_in_a_link_is_refused_not_ignored(tmp_path: Path) -> None:
    """Today's trap: a <loop> inside a <link> was skipped, and a four-bar loaded as a serial robot."""
    text = (ROBOTS / "delta.urdf").read_text()
    loop = re.search(r"<loop name=\"leg_1_platform\".*?</loop>", text, re.S)
    assert loop is not None
    moved = text.replace(loop.group(0), "").replace("</link>", loop.group(0) + "</link>", 1)
    bad = tmp_path / "nested.urdf"
    bad.write_text(moved)
    with pytest.raises(RobotFileError, match=r"<loop name='leg_1_platform'> is inside <link name='[^']+'>"):
        pincal.load_robot(bad)
    done = run_pincal("info", str(bad))
    assert done.returncode == 2 and "is inside <link" in done.stderr and "Traceback" not in done.stderr


def test_a_transmission_nested_in_a_joint_is_refused(tmp_path: Path) -> None:
    text = (ROBOTS / "five_bar.urdf").read_text()
    transmission = re.search(r"<transmission .*?</transmission>", text, re.S)
    assert transmission is not None
    moved = text.replace(transmission.group(0), "").replace("</joint>", transmission.group(0) + "</joint>", 1)
    bad = tmp_path / "nested.urdf"
    bad.write_text(moved)
    with pytest.raises(RobotFileError, match=r"<transmission name='[^']+'> is inside <joint") as caught:
        pincal.load_robot(bad)
    assert caught.value.file == str(bad)


def test_limits_with_lower_above_upper_are_refused_at_load(tmp_path: Path) -> None:
    text = (ROBOTS / "five_bar.urdf").read_text()
    match = re.search(r'<joint name="([^"]+)" type="revolute">.*?<limit lower="([^"]+)" upper="([^"]+)"', text)
    assert match is not None
    name, lower, upper = match.groups()
    swapped = text.replace(match.group(0), match.group(0).replace(f'lower="{lower}" upper="{upper}"',
                                                                  f'lower="{upper}" upper="{lower}"'), 1)
    bad = tmp_path / "limits.urdf"
    bad.write_text(swapped)
    with pytest.raises(RobotFileError, match=f"joint '{name}' has limit lower .* > upper") as caught:
        pincal.load_robot(bad)
    assert caught.value.file == str(bad)
    done = run_pincal("simulate", str(bad), "--samples", "5", "--out", str(tmp_path / "sim"))
    assert done.returncode == 2 and f"joint '{name}' has limit lower" in done.stderr
    assert not (tmp_path / "sim").exists()


def test_a_duplicated_loop_is_refused_at_load_not_at_simulate(tmp_path: Path) -> None:
    """Two identical loops: the closure has more rows but no more rank. Once, `info` said mobility 2 and
    `simulate` failed later with a misleading non-convergence message."""
    text = (ROBOTS / "five_bar.urdf").read_text()
    loop = re.search(r'<loop name="([^"]+)".*?</loop>', text, re.S)
    assert loop is not None
    again = loop.group(0).replace(f'name="{loop.group(1)}"', f'name="{loop.group(1)}_again"', 1)
    bad = tmp_path / "duplicated.urdf"
    bad.write_text(text.replace(loop.group(0), loop.group(0) + "\n  " + again, 1))
    with pytest.raises(pincal.LoopError, match=f"loops {loop.group(1)}, {loop.group(1)}_again add no constraint"):
        pincal.load_robot(bad)
    done = run_pincal("simulate", str(bad), "--samples", "3", "--quiet", "--out", str(tmp_path / "sim"))
    assert done.returncode == 2 and "a duplicated or redundant loop" in done.stderr


def test_a_known_robot_name_shadowed_by_a_directory_is_the_known_robot(tmp_path: Path,
                                                                        monkeypatch: pytest.MonkeyPatch) -> None:
    """``pincal simulate delta --out delta`` then ``pincal calibrate delta delta/measurements.csv``: the directory
    named like the robot is no robot file, so ``delta`` is the shipped Delta."""
    monkeypatch.chdir(tmp_path)
    done = run_pincal("simulate", "delta", "--samples", "30", "--seed", "1", "--quiet", "--out", "delta")
    assert done.returncode == 0, done.stderr
    done = run_pincal("calibrate", "delta", "delta/measurements.csv", "--out", "delta/cal.urdf")
    assert done.returncode == 0, done.stderr
    assert (tmp_path / "delta" / "cal.urdf").is_file()
    assert "RMS position error (fit)" in done.stdout


def test_a_directory_or_a_device_given_as_the_robot_is_named_as_such(tmp_path: Path) -> None:
    done = run_pincal("info", str(tmp_path))
    assert done.returncode == 2 and f"robot file '{tmp_path}' is a directory" in done.stderr
    done = run_pincal("info", "/dev/null")
    assert done.returncode == 2 and "robot file '/dev/null' is not a regular file" in done.stderr


def test_a_link_with_two_parent_joints_is_named(tmp_path: Path) -> None:
    text = (ROBOTS / "delta.urdf").read_text()
    joint = re.search(r'<joint name="end_effector_joint".*?</joint>', text, re.S)
    assert joint is not None
    bad = tmp_path / "two_parents.urdf"
    bad.write_text(text.replace(joint.group(0), joint.group(0) + joint.group(0).replace(
        'name="end_effector_joint"', 'name="second_parent"'), 1))
    done = run_pincal("info", str(bad))
    assert done.returncode == 2 and "Traceback" not in done.stderr
    assert "link 'end_effector' is the child of 2 joints (end_effector_joint, second_parent)" in done.stderr


def test_a_chain_too_long_for_pinocchio_data_is_refused_at_once(tmp_path: Path) -> None:
    """Pinocchio's data grow with the cube of the chain: a 3000-joint chain once ended as 'out of memory'."""
    links = "".join(f'<link name="l{k}"/>' for k in range(202))
    joints = "".join(f'<joint name="j{k}" type="revolute"><parent link="l{k - 1}"/><child link="l{k}"/>'
                     '<axis xyz="0 0 1"/><limit lower="-1" upper="1" effort="1" velocity="1"/></joint>'
                     for k in range(1, 202))
    chain = tmp_path / "chain.urdf"
    chain.write_text(f'<robot name="chain">{links}{joints}</robot>')
    done = run_pincal("info", str(chain))
    assert done.returncode == 2 and "has 201 joints; pincal takes at most 200" in done.stderr
