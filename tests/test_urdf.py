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
    with pytest.raises(RobotFileError, match=r"<transmission name='[^']+'> is inside <joint"):
        pincal.load_robot(bad)


def test_limits_with_lower_above_upper_are_refused_at_load(tmp_path: Path) -> None:
    text = (ROBOTS / "five_bar.urdf").read_text()
    match = re.search(r'<joint name="([^"]+)" type="revolute">.*?<limit lower="([^"]+)" upper="([^"]+)"', text)
    assert match is not None
    name, lower, upper = match.groups()
    swapped = text.replace(match.group(0), match.group(0).replace(f'lower="{lower}" upper="{upper}"',
                                                                  f'lower="{upper}" upper="{lower}"'), 1)
    bad = tmp_path / "limits.urdf"
    bad.write_text(swapped)
    with pytest.raises(RobotFileError, match=f"joint '{name}' has limit lower .* > upper"):
        pincal.load_robot(bad)
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
