"""``pincal filter`` as a user runs it, on the example programs of each language (examples/data/programs): a
calibrated UR10 (or KUKA-like arm), every Cartesian target rewritten so that the nominal controller's inverse
kinematics of it puts the calibrated model on the pose the program wrote, every other line byte-identical, constructs
it does not read named by line; errors as one line."""

from __future__ import annotations

import shutil
from pathlib import Path

import numpy as np
import pinocchio as pin
import pytest
from conftest import ROOT, run_pincal

import pincal
from pincal.io.program_reader import read_program

PROGRAMS = ROOT / "examples" / "data" / "programs"
KR16 = ROOT / "examples" / "data" / "robots" / "kr16_like.urdf"


@pytest.fixture(scope="module")
def ur10_cal(tmp_path_factory: pytest.TempPathFactory) -> Path:
    folder = tmp_path_factory.mktemp("ur10")
    done = run_pincal("simulate", "ur10", "--measure", "pose", "--samples", "30", "--seed", "1", "--quiet", "--out",
                      str(folder))
    assert done.returncode == 0, done.stderr
    done = run_pincal("calibrate", "ur10", str(folder / "measurements.csv"), "--out", str(folder / "cal.urdf"))
    assert done.returncode == 0, done.stderr
    return folder / "cal.urdf"


@pytest.fixture(scope="module")
def kr16_cal(tmp_path_factory: pytest.TempPathFactory) -> Path:
    folder = tmp_path_factory.mktemp("kr16")
    done = run_pincal("simulate", str(KR16), "--measure", "pose", "--frame", "flange", "--samples", "30", "--seed",
                      "2", "--quiet", "--out", str(folder))
    assert done.returncode == 0, done.stderr
    done = run_pincal("calibrate", str(KR16), str(folder / "measurements.csv"), "--out", str(folder / "cal.urdf"))
    assert done.returncode == 0, done.stderr
    return folder / "cal.urdf"


def _check_targets(source: Path, out: Path, cal_path: Path, nominal_name: str, flange: str, start: np.ndarray,
                   config: tuple[Path, ...] = ()) -> int:
    """Every target of ``out`` against ``source``'s: joint targets equal; each Cartesian one, sent to a nominal
    controller (its inverse kinematics from the posture it reached the one before at), puts the calibrated model's
    tool on the pose ``source`` wrote, where the pose as written misses it. Returns how many Cartesian targets."""
    old = read_program(source, pin.SE3.Identity(), config).targets
    new = read_program(out, pin.SE3.Identity(), config).targets
    cal, nominal = pincal.load_robot(cal_path), pincal.load_robot(nominal_name)
    base_n, base_c = (r.placement(r.q_reference, "base") for r in (nominal, cal))
    q = start
    count = 0
    for was, now in zip(old, new, strict=True):
        if was.pose is None:
            assert now.joints is not None and np.array_equal(was.joints, now.joints)
            q = was.joints
            continue
        assert now.pose is not None and now.line == was.line
        count += 1
        gaps = []
        for pose in (was.pose, now.pose):
            q_pose = nominal.solve_ik(base_n * was.frame * pose * was.tool.inverse(), flange, q)
            landed = base_c.inverse() * cal.placement(q_pose, flange) * was.tool
            gaps.append(float(np.linalg.norm(landed.translation - (was.frame * was.pose).translation)))
        q = q_pose
        assert gaps[0] > 2e-4  # the calibration moves the tool by a fraction of a millimetre or more
        assert gaps[1] < 1e-6  # as written: 1e-4 mm and 1e-5 degree (KRL), 1e-9 (RAPID's quaternions)
    return count


def _changed_lines(before: str, after: str) -> list[int]:
    a, b = before.splitlines(keepends=True), after.splitlines(keepends=True)
    assert len(a) == len(b)
    return [k + 1 for k, (x, y) in enumerate(zip(a, b, strict=True)) if x != y]


def _lands(cal: pincal.Robot, nominal: pincal.Robot, written: pin.SE3, intended: pin.SE3, tool: pin.SE3,
           start: np.ndarray) -> float:
    """Where the calibrated model puts the tool when a nominal controller is sent ``written`` (its inverse kinematics
    from ``start``): distance [m] to ``intended``, both in the base frame of each model."""
    base_n, base_c = (r.placement(r.q_reference, "base") for r in (nominal, cal))
    q = nominal.solve_ik(base_n * written * tool.inverse(), "tool0", start)
    landed = base_c.inverse() * cal.placement(q, "tool0") * tool
    return float(np.linalg.norm(landed.translation - intended.translation))


def test_urscript_targets_rewritten_for_the_nominal_controller(ur10_cal: Path, tmp_path: Path) -> None:
    source = PROGRAMS / "pick_place.script"
    out = tmp_path / "filtered.script"
    done = run_pincal("filter", str(source), "--model", str(ur10_cal), "--out", str(out))
    assert done.returncode == 0, done.stdout + done.stderr
    assert "6 Cartesian and 2 joint targets" in done.stdout
    assert done.stdout.count("rewritten") == 6 and f"wrote {out}" in done.stdout
    before, after = source.read_text(encoding="utf-8"), out.read_text(encoding="utf-8")
    assert _changed_lines(before, after) == [6, 7, 14, 15, 16]  # the poses' lines alone; joint lists kept
    tool = pin.SE3(np.eye(3), np.array([0.0, 0.0, 0.15]))
    old = read_program(source, tool).targets
    new = read_program(out, tool).targets
    cal, nominal = pincal.load_robot(ur10_cal), pincal.load_robot("ur10")
    start = np.array([0.0, -1.5708, 1.5708, -1.5708, -1.5708, 0.0])
    for was, now in zip(old, new, strict=True):
        if was.pose is None:
            assert now.joints is not None and np.array_equal(was.joints, now.joints)
            continue
        assert now.pose is not None
        unfiltered = _lands(cal, nominal, was.pose, was.pose, tool, start)
        filtered = _lands(cal, nominal, now.pose, was.pose, tool, start)
        assert unfiltered > 2e-4  # the calibration moves the tool by a fraction of a millimetre or more
        assert filtered < 1e-6  # 8 decimals written: 1e-8 m and rad


def test_urscript_constructs_not_read_are_named(ur10_cal: Path, tmp_path: Path) -> None:
    program = tmp_path / "odd.script"
    program.write_text("def odd():\n  movel(pose_trans(get_actual_tcp_pose(), p[0, 0, 0.1, 0, 0, 0]), a=1.2)\n"
                       "  movel(wp, a=1.2)\n  # movel(p[9, 9, 9, 0, 0, 0])\n"
                       "  movel(p[-0.5, -0.4, 0.3, 2.2214, -2.2214, 0.0])\nend\n", encoding="utf-8")
    out = tmp_path / "out.script"
    done = run_pincal("filter", str(program), "--model", str(ur10_cal), "--out", str(out))
    assert done.returncode == 1, done.stdout + done.stderr
    assert f"warning: {program} line 2: movel: target 'pose_trans(" in done.stdout
    assert f"warning: {program} line 3: target 'wp': never assigned a literal" in done.stdout
    assert "1 Cartesian and 0 joint targets" in done.stdout  # the commented-out move is not one
    assert _changed_lines(program.read_text(encoding="utf-8"), out.read_text(encoding="utf-8")) == [5]


def test_filter_refuses_to_write_over_its_input(ur10_cal: Path, tmp_path: Path) -> None:
    program = tmp_path / "p.script"
    shutil.copy(PROGRAMS / "pick_place.script", program)
    before = program.read_bytes()
    done = run_pincal("filter", str(program), "--model", str(ur10_cal), "--out", str(program))
    assert done.returncode == 2
    assert done.stderr.startswith("pincal: error: --out") and "input" in done.stderr
    assert done.stderr.count("\n") == 1 and program.read_bytes() == before
    done = run_pincal("filter", str(tmp_path / "p.txt"), "--model", str(ur10_cal), "--out", str(tmp_path / "o.txt"))
    assert done.returncode == 2 and "URScript (.script)" in done.stderr and "Traceback" not in done.stderr


def test_krl_points_of_the_dat_and_the_src_rewritten(kr16_cal: Path, tmp_path: Path) -> None:
    out = tmp_path / "filtered" / "palletize.src"
    config = PROGRAMS / "config_excerpt.dat"
    done = run_pincal("filter", str(PROGRAMS / "palletize.src"), "--model", str(kr16_cal), "--config", str(config),
                      "--out", str(out))
    assert done.returncode == 1, done.stdout + done.stderr  # the relative move is left as written
    assert "6 Cartesian and 2 joint targets" in done.stdout and "base frame base, flange flange" in done.stdout
    assert done.stdout.count("warning:") == 1 and "line 42: LIN_REL: a relative move" in done.stdout
    for suffix, lines in ((".src", [40]), (".dat", [8, 11, 14, 15, 16])):
        before = (PROGRAMS / f"palletize{suffix}").read_text(encoding="utf-8")
        assert _changed_lines(before, out.with_suffix(suffix).read_text(encoding="utf-8")) == lines
    home = np.radians([0.0, -90.0, 90.0, 0.0, 0.0, 0.0])
    assert _check_targets(PROGRAMS / "palletize.src", out, kr16_cal, str(KR16), "flange", home, (config,)) == 6


def test_krl_without_the_controllers_tool_data_leaves_those_points(kr16_cal: Path, tmp_path: Path) -> None:
    out = tmp_path / "palletize.src"
    done = run_pincal("filter", str(PROGRAMS / "palletize.src"), "--model", str(kr16_cal), "--out", str(out))
    assert done.returncode == 1
    assert "TOOL_DATA[1], which no file given holds (give the controller's $config.dat with --config)" in done.stdout
    assert "0 Cartesian and 2 joint targets" in done.stdout  # every point's tool is TOOL_DATA[1]: none guessed
    assert done.stdout.count("its tool or base is not known") == 6
    for suffix in (".src", ".dat"):
        assert out.with_suffix(suffix).read_bytes() == (PROGRAMS / f"palletize{suffix}").read_bytes()
    done = run_pincal("filter", str(PROGRAMS / "palletize.src"), "--model", str(kr16_cal), "--out",
                      str(tmp_path / "p.dat"))
    assert done.returncode == 2 and "written as a .src" in done.stderr


def test_rapid_robtargets_declared_and_inline_rewritten(kr16_cal: Path, tmp_path: Path) -> None:
    out = tmp_path / "glue.mod"
    source = PROGRAMS / "glue.mod"
    done = run_pincal("filter", str(source), "--model", str(kr16_cal), "--flange", "tool0", "--out", str(out))
    assert done.returncode == 1, done.stdout + done.stderr  # Offs(pEnd, …) is left as written
    assert "line 17: MoveL: point 'Offs(pEnd,0,0,100)'" in done.stdout and done.stdout.count("warning:") == 2
    assert "warning: the program is RAPID (the language of ABB) but robot 'kr16_like' is named like a KUKA arm" in (
        done.stdout)  # the KUKA-like arm runs the ABB module here: said, not refused
    before, after = source.read_text(encoding="utf-8"), out.read_text(encoding="utf-8")
    assert _changed_lines(before, after) == [7, 8, 9, 10, 18]
    home = np.radians([0.0, -30.0, 30.0, 0.0, 60.0, 0.0])
    assert _check_targets(source, out, kr16_cal, str(KR16), "tool0", home) == 5


def test_joint_targets_rewritten_for_the_pose_the_nominal_model_gives_them(ur10_cal: Path, tmp_path: Path) -> None:
    source = PROGRAMS / "pick_place.script"
    out = tmp_path / "joints.script"
    done = run_pincal("filter", str(source), "--model", str(ur10_cal), "--joint-targets", "intended", "--out",
                      str(out))
    assert done.returncode == 0, done.stdout + done.stderr
    assert "rewrote 8 of 6 Cartesian and 2 joint targets" in done.stdout
    assert _changed_lines(source.read_text(encoding="utf-8"), out.read_text(encoding="utf-8")) == [5, 6, 7, 14, 15,
                                                                                                  16, 18]
    cal, nominal = pincal.load_robot(ur10_cal), pincal.load_robot("ur10")
    old = [t for t in read_program(source, pin.SE3.Identity()).targets if t.joints is not None]
    new = [t for t in read_program(out, pin.SE3.Identity()).targets if t.joints is not None]
    assert len(old) == len(new) == 2
    for was, now in zip(old, new, strict=True):
        intended = nominal.placement(was.joints, "base").inverse() * nominal.placement(was.joints, "tool0")
        reached = cal.placement(now.joints, "base").inverse() * cal.placement(now.joints, "tool0")
        as_written = cal.placement(was.joints, "base").inverse() * cal.placement(was.joints, "tool0")
        assert np.linalg.norm(reached.translation - intended.translation) < 1e-7  # 8 decimals of radians written
        assert np.linalg.norm(as_written.translation - intended.translation) > 1e-3
