"""Simulation that just works on a closed-loop robot written by a user: the Delta with its platform named
``platform`` (no ``end_effector``), the hexapod under another name (drawn within its URDF limits, not the shipped
hexapod's spread), each through ``pincal simulate`` and ``pincal calibrate`` as subprocesses."""

from __future__ import annotations

import re
from pathlib import Path

from conftest import ROBOTS, run_pincal

import pincal


def _without_end_effector(text: str, name: str) -> str:
    """The URDF text with its ``end_effector`` link and the fixed joint holding it removed, the robot renamed."""
    text = re.sub(r'<link name="end_effector">.*?</link>', "", text, flags=re.S)
    text = re.sub(r'<joint name="end_effector_joint" type="fixed">.*?</joint>', "", text, flags=re.S)
    return re.sub(r'<robot name="[^"]+"', f'<robot name="{name}"', text, count=1)


def _held_out(stdout: str) -> tuple[float, float]:
    """RMS position error before and after on the held-out samples [mm], as the summary prints them."""
    line = next(line for line in stdout.splitlines() if line.startswith("RMS position error (held out)"))
    before, after = (float(v) for v in line.split()[-4::2])
    return before, after


def test_a_delta_whose_platform_is_named_platform_is_measured_there(tmp_path: Path) -> None:
    path = tmp_path / "my_delta.urdf"
    path.write_text(_without_end_effector((ROBOTS / "delta.urdf").read_text(), "my_delta"))
    robot = pincal.load_robot(path)
    assert not robot.model.existFrame("end_effector")
    assert robot.end_effector == "platform" and robot.measured_frame_choice.rule == "platform"
    assert {"rod_1", "rod_2", "rod_3", "platform"} <= set(robot.measured_frame_choice.candidates)
    done = run_pincal("info", str(path))
    assert "measured frame (default): platform, moved by the actuated joints (the link every loop closes on" \
        in done.stdout
    sim = tmp_path / "sim"
    done = run_pincal("simulate", str(path), "--samples", "30", "--test-samples", "10", "--seed", "1", "--quiet",
                      "--out", str(sim))
    assert done.returncode == 0, done.stderr
    assert "position:platform:x" in (sim / "measurements.csv").read_text()
    done = run_pincal("calibrate", str(path), str(sim / "measurements.csv"), "--out", str(tmp_path / "cal.urdf"))
    assert done.returncode == 0, done.stderr
    before, after = _held_out(done.stdout)
    assert after < 0.05 and before > 20 * after  # [mm]


def test_a_hexapod_drawn_within_its_urdf_limits_assembles(tmp_path: Path) -> None:
    """Within its URDF limits, 77 % of a hexapod's postures do not assemble, and near the workspace's edge some the
    nominal robot assembles are beyond the simulated (perturbed) robot: both are drawn again."""
    path = tmp_path / "my_hexapod.urdf"
    path.write_text(_without_end_effector((ROBOTS / "hexapod.urdf").read_text(), "my_hexapod"))
    assert pincal.load_robot(path).end_effector == "platform"
    sim = tmp_path / "sim"
    done = run_pincal("simulate", str(path), "--samples", "40", "--test-samples", "10", "--seed", "3", "--quiet",
                      "--out", str(sim))  # a seed whose first draw held 2 postures the simulated robot cannot assemble
    assert done.returncode == 0, done.stderr
    done = run_pincal("calibrate", str(path), str(sim / "measurements.csv"), "--out", str(tmp_path / "cal.urdf"))
    assert done.returncode == 0, done.stderr
    before, after = _held_out(done.stdout)
    assert after < 0.1 and before > 10 * after  # [mm]


def test_postures_the_simulated_robot_cannot_assemble_are_counted(tmp_path: Path) -> None:
    done = run_pincal("simulate", "ucr3", "--perturb", "0.05", "--samples", "20", "--seed", "1", "--quiet", "--out",
                      str(tmp_path / "sim"))
    assert done.returncode == 2 and len(done.stderr.splitlines()) == 1
    assert "the simulated robot, with true errors of σ 0.05 (m, rad), cannot be assembled at 20 of 20 random " \
           "postures of 'ucr3' that the nominal robot assembles: give errors smaller than --perturb 0.05, or a " \
           "smaller --spread S about the reference" in done.stderr
