"""``pincal export`` as a user runs it on robots the UR examples do not show: a closed-loop robot whose moving
platform hangs on a floating joint (the hexapod, the UCR3) exports its joint origins with ``--format yaml`` (what the
docs advise for closed loops), proved by reloading it; before, the proof held the floating joint at its origin in the
reloaded URDF and refused every such robot."""

from __future__ import annotations

from pathlib import Path

import pytest
from conftest import ROBOTS, run_pincal


@pytest.mark.parametrize("robot", ["hexapod", "ucr3"])
def test_a_closed_loop_robot_with_a_floating_platform_exports_yaml(tmp_path: Path, robot: str) -> None:
    out = tmp_path / f"{robot}.yaml"
    done = run_pincal("export", str(ROBOTS / f"{robot}.urdf"), "--format", "yaml", "--postures", "10", "--out",
                      str(out))
    assert done.returncode == 0, done.stderr
    assert "Traceback" not in done.stderr
    text = out.read_text(encoding="utf-8")
    assert "platform_" in text and "loops:" in text  # the floating joint and the loops are in the file
    assert "proved by reloading" in text
