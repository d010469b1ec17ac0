"""Wrong input to the newest commands, as a new user gives it: ``pincal detect`` on files that are not images or on a
folder, ``pincal simulate --shift`` of one parameter twice, ``pincal iso9283 evaluate`` on a direction measured once,
``pincal drift`` on the calibration's own data. Each is one line naming the culprit (exit 2), or a warning."""

from __future__ import annotations

from pathlib import Path

import pytest
from conftest import run_pincal

BOARD = "charuco:8x6:0.03:0.022:DICT_4X4_50"
UR10_JOINTS = "shoulder_pan_joint,shoulder_lift_joint,elbow_joint,wrist_1_joint,wrist_2_joint,wrist_3_joint"


def _joints(root: Path, *samples: str) -> Path:
    """A joints CSV of the UR10 with one row per sample name."""
    path = root / "joints.csv"
    path.write_text("# robot: ur10\nsample," + UR10_JOINTS + "\n"
                    + "".join(f"{s},0.1,-1.2,1.5,-1.9,-1.5,{0.1 * k}\n" for k, s in enumerate(samples)))
    return path


def _one_line_error(done: object, *parts: str) -> str:
    assert done.returncode == 2, done.stdout + done.stderr  # type: ignore[attr-defined]
    err = str(done.stderr).strip()  # type: ignore[attr-defined]
    assert err.startswith("pincal: error: ") and "\n" not in err and "Traceback" not in err, err
    for part in parts:
        assert part in err, err
    return err


def test_detect_on_an_empty_image_file_is_one_line_naming_it(tmp_path: Path) -> None:
    _joints(tmp_path, "0000", "0001")
    (tmp_path / "0000.png").write_bytes(b"")
    (tmp_path / "0001.png").write_text("pose,cycle\nP1,1\n")
    done = run_pincal("detect", "0000.png", "0001.png", "--board", BOARD, "--joints", "joints.csv", "--measure",
                      "pixel:tool0", "--out", "det.csv", cwd=tmp_path)
    _one_line_error(done, "0000.png: not an image OpenCV reads", "0001.png: not an image OpenCV reads")
    assert not (tmp_path / "det.csv").exists()


def test_detect_on_a_folder_says_to_give_its_images(tmp_path: Path) -> None:
    _joints(tmp_path, "0000")
    (tmp_path / "imgs").mkdir()
    done = run_pincal("detect", "imgs", "--board", BOARD, "--joints", "joints.csv", "--measure", "pixel:tool0",
                      "--out", "det.csv", cwd=tmp_path)
    _one_line_error(done, "imgs: a directory, not an image", "imgs/*.png")


def test_simulate_refuses_a_parameter_shifted_twice(tmp_path: Path) -> None:
    done = run_pincal("simulate", "delta", "--samples", "4", "--seed", "1", "--shift", "arm_2_joint.offset=0.001",
                      "--shift", "arm_2_joint.offset=0.002", "--out", "s", cwd=tmp_path)
    _one_line_error(done, "--shift arm_2_joint.offset: given 2 times")
    assert not (tmp_path / "s").exists()


def test_a_camera_simulation_refuses_the_options_it_would_ignore(tmp_path: Path) -> None:
    done = run_pincal("simulate", "ur10", "--measure", "pixel:tool0", "--samples", "4", "--seed", "1",
                      "--posture-seed", "2", "--shift", "shoulder_lift_joint.offset=0.002", "--out", "s", cwd=tmp_path)
    _one_line_error(done, "--posture-seed, --shift: not taken by a camera simulation")
    assert not (tmp_path / "s").exists()


def _runs(root: Path, rows: list[tuple[str, int, str]]) -> Path:
    """A runs CSV of the UR10: each (pose, cycle, direction) attained 0.1 mm off its command, by cycle."""
    commands = {"P1": (0.4, 0.3, 0.2), "P2": (0.2, 0.1, 0.0)}
    lines = ["# robot: ur10", "pose,cycle,direction,cmd_x,cmd_y,cmd_z,x,y,z"]
    for pose, cycle, direction in rows:
        c = commands[pose]
        lines.append(f"{pose},{cycle},{direction},{c[0]},{c[1]},{c[2]},{c[0] + 1e-4 * cycle},{c[1]},{c[2]}")
    path = root / "runs.csv"
    path.write_text("\n".join(lines) + "\n")
    return path


def test_iso9283_refuses_a_direction_measured_in_one_cycle(tmp_path: Path) -> None:
    series = [(p, c, "") for c in (1, 2, 3) for p in ("P1", "P2")]
    _runs(tmp_path, series + [("P1", c, "+x") for c in (1, 2, 3)] + [("P1", 1, "+q")])
    _one_line_error(run_pincal("iso9283", "evaluate", "ur10", "runs.csv", cwd=tmp_path),
                    "pose P1 from direction '+q' has 1 cycle")


def test_iso9283_warns_of_poses_with_no_distance_for_want_of_common_cycles(tmp_path: Path) -> None:
    _runs(tmp_path, [("P1", 1, ""), ("P1", 2, ""), ("P2", 3, ""), ("P2", 4, "")])
    done = run_pincal("iso9283", "evaluate", "ur10", "runs.csv", cwd=tmp_path)
    assert done.returncode == 0, done.stdout + done.stderr
    assert "warning: no distance between P1-P2: measured in fewer than 2 common cycles" in done.stdout
    assert "distance P1-P2" not in done.stdout


def test_simulate_refuses_board_and_images_without_a_camera(tmp_path: Path) -> None:
    done = run_pincal("simulate", "ur10", "--samples", "3", "--images", "imgs", "--board", BOARD, "--out", "s",
                      cwd=tmp_path)
    _one_line_error(done, "--board, --images: only with a camera's --measure pixel:FRAME")
    assert not (tmp_path / "imgs").exists() and not (tmp_path / "s").exists()


def test_simulated_images_over_an_earlier_run_s_are_noted_and_the_stale_ones_warned_of(tmp_path: Path) -> None:
    for samples in ("4", "2"):
        done = run_pincal("simulate", "ur10", "--measure", "pixel:tool0", "--samples", samples, "--seed", "1",
                          "--images", "imgs", "--out", "s", cwd=tmp_path)
        assert done.returncode == 0, done.stdout + done.stderr
    assert "note: replaced 2 existing images in imgs/" in done.stdout
    assert "warning: imgs/ holds 2 other images (0002.png, 0003.png) from before" in done.stdout


def test_iso9283_refuses_a_column_it_reads_given_twice(tmp_path: Path) -> None:
    path = _runs(tmp_path, [("P1", 1, ""), ("P1", 2, "")])
    lines = path.read_text().splitlines()
    path.write_text("\n".join([lines[0], lines[1] + ",x", *(line + ",9.9" for line in lines[2:])]) + "\n")
    _one_line_error(run_pincal("iso9283", "evaluate", "ur10", "runs.csv", cwd=tmp_path),
                    "runs.csv: header (line 2): column 'x' appears twice (columns 7 and 10)")


def test_a_shift_too_large_to_assemble_is_named_in_the_error(tmp_path: Path) -> None:
    done = run_pincal("simulate", "delta", "--samples", "3", "--seed", "1", "--shift", "arm_2_joint.offset=1e3",
                      "--out", "s", cwd=tmp_path)
    _one_line_error(done, "and arm_2_joint.offset shifted by 1000, cannot be assembled",
                    "give errors smaller than --perturb 0.001 and --shift NAME=VALUE, or a smaller --spread S")


@pytest.mark.parametrize(("args", "message"), [
    (["iso9283", "plan", "ur10", "--cycles", "1", "--out", "p.csv"], "argument --cycles: 1: RP needs at least 2"),
    (["iso9283", "plan", "ur10", "--cycles", "x", "--out", "p.csv"], "argument --cycles: 'x' is not a whole number"),
    (["iso9283", "plan", "ur10", "--region", "200,-300,0,700,300,500", "--out", "p.csv"],
     "argument --region: '200,-300,0,700,300,500' has a bound beyond 20 m: the region is in metres"),
    (["iso9283", "plan", "five_bar", "--out", "p.csv"], "'five_bar' has 2 degrees of freedom: its frame cannot reach"),
    (["simulate", "ur10", "--samples", "2.5", "--out", "s"], "argument --samples: '2.5' is not a whole number"),
    (["drift", "cal.urdf", "s.csv", "--level", "x"], "argument --level: 'x' is not a number"),
    (["iso9283", "evaluate", "ur10", "r.csv", "--instrument-uncertainty", "2mm"],
     "argument --instrument-uncertainty: '2mm' is not a number"),
])
def test_a_bad_option_value_is_named_with_its_option(tmp_path: Path, args: list[str], message: str) -> None:
    err = _one_line_error(run_pincal(*args, cwd=tmp_path), message)
    assert "positive_int" not in err and "_level" not in err and "_cycles" not in err


def test_iso9283_warns_of_an_orientation_no_robot_reaches_and_keeps_its_columns_apart(tmp_path: Path) -> None:
    """Quaternions written x, y, z, w: the identity read as a half turn about z."""
    header = "pose,cycle,cmd_x,cmd_y,cmd_z,x,y,z,cmd_qw,cmd_qx,cmd_qy,cmd_qz,qw,qx,qy,qz"
    rows = [f"P1,{c},0.4,0.3,0.2,0.4,0.3,0.2{c},1,0,0,0,0,0,0,1" for c in (1, 2)]
    (tmp_path / "runs.csv").write_text("\n".join(["# robot: ur10", header, *rows]) + "\n")
    done = run_pincal("iso9283", "evaluate", "ur10", "runs.csv", cwd=tmp_path)
    assert done.returncode == 0, done.stdout + done.stderr
    assert "warning: an attained orientation 3.14 rad from its command (line 3): no robot errs so much" in done.stdout
    row = next(line for line in done.stdout.splitlines() if line.startswith("P1 "))
    assert len(row.split()) == 13  # pose, cycles, AP, APx..z, RP, six angles: each figure its own column


def test_iso9283_warns_when_the_attained_positions_are_the_commands(tmp_path: Path) -> None:
    """x, y, z copied from cmd_x, cmd_y, cmd_z: every figure zero, which no robot measures."""
    rows = [f"P1,{c},0.4,0.3,0.2,0.4,0.3,0.2" for c in (1, 2)]
    (tmp_path / "runs.csv").write_text("\n".join(["pose,cycle,cmd_x,cmd_y,cmd_z,x,y,z", *rows]) + "\n")
    done = run_pincal("iso9283", "evaluate", "ur10", "runs.csv", cwd=tmp_path)
    assert done.returncode == 0, done.stdout + done.stderr
    assert "warning: every attained position x, y, z equals its command cmd_x, cmd_y, cmd_z" in done.stdout
