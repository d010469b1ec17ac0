"""``pincal filter`` and the posture a target names (KRL's status and turn, RAPID's ``cfx``): a calibration that takes
a target's axis 5 across zero gets the new posture written, with a note by line; a posture the robot cannot have is
named and the target left as written. Hand-made targets on the KUKA-like arm, their bits derived by hand.

At A1 0, A2 −90°, A3 90°, A4 0, A5 = a, A6 0 the lower arm stands up (axis 3 at (0.26, 0, 1.355) m), the forearm is
level 0.035 m lower and the wrist centre at (0.93, 0, 1.32) m; the flange 0.158 m beyond it turned by a about y:
X = 930 + 158 cos a, Z = 1320 − 158 sin a [mm], A 0, B = a, C 0 (KRL's flange), and RAPID's tool0 (z out of the flange)
the quaternion of a turn by 90° + a about y. The "calibrated" model turns axis 5's origin by 0.5 mrad about its own
axis: the same pose needs A5 0.5 mrad lower. Written at a = 0.2 mrad (S 2: ahead, in front of the lower arm, A5 > 0;
T 2: A2 < 0; cfx 0), the commands have A5 = −0.3 mrad: S 6 (bit 2, A5 ≤ 0), T 18 (bit 4), cfx 1.
"""

from __future__ import annotations

import math
from pathlib import Path

from conftest import ROOT, run_pincal

KR16 = ROOT / "examples" / "data" / "robots" / "kr16_like.urdf"
A5 = 2e-4  # rad


def _calibrated(tmp_path: Path) -> Path:
    text = KR16.read_text(encoding="utf-8")
    joint = '<origin xyz="0.67 0 0" rpy="0 0 0"/><axis xyz="0 1 0"/>'
    assert text.count(joint) == 1
    path = tmp_path / "cal.urdf"
    path.write_text(text.replace(joint, joint.replace('rpy="0 0 0"', 'rpy="0 0.0005 0"')), encoding="utf-8")
    return path


def _krl_point(status: int, turn: int) -> str:
    x, z, b = 930 + 158 * math.cos(A5), 1320 - 158 * math.sin(A5), math.degrees(A5)
    return f"DECL E6POS XP1={{X {x:.4f},Y 0.0,Z {z:.4f},A 0.0,B {b:.5f},C 0.0,S {status},T {turn}}}\n"


def _krl(tmp_path: Path, status: int, turn: int) -> Path:
    folder = tmp_path / "in"
    folder.mkdir()
    (folder / "cell.src").write_text("DEF cell( )\nPTP {A1 0,A2 -90,A3 90,A4 0,A5 10,A6 0}\nPTP XP1\nEND\n",
                                     encoding="utf-8")
    (folder / "cell.dat").write_text("DEFDAT cell\n" + _krl_point(status, turn) + "ENDDAT\n", encoding="utf-8")
    return folder / "cell.src"


def test_krl_a_calibration_taking_a5_across_zero_writes_the_new_status_and_turn(tmp_path: Path) -> None:
    out = tmp_path / "out" / "cell.src"
    done = run_pincal("filter", str(_krl(tmp_path, 2, 2)), "--model", str(_calibrated(tmp_path)), "--nominal",
                      str(KR16), "--out", str(out))
    assert done.returncode == 0, done.stdout + done.stderr
    lines = (out.parent / "cell.dat").read_text(encoding="utf-8").splitlines()
    assert lines[1].endswith(",A 0.00000,B -0.01719,C 0.00000,S 6,T 18}")  # B = −0.3 mrad
    assert f"Z {1320 + 158 * 3e-4:.4f}" in lines[1]
    assert "note: " in done.stdout and "cell.dat line 2: 'XP1'" in done.stdout and "(S 2 → 6, T 2 → 18)" in done.stdout


def test_krl_a_status_no_posture_of_the_turn_has_is_named_and_left(tmp_path: Path) -> None:
    """S 0 asks the wrist behind the lower arm, A3 below −2.99° (the stretched arm); T 2 asks A3 ≥ 0: no posture."""
    out = tmp_path / "out" / "cell.src"
    program = _krl(tmp_path, 0, 2)
    done = run_pincal("filter", str(program), "--model", str(KR16), "--out", str(out))
    assert done.returncode == 1
    assert ("'XP1' left as written: no posture found matches the one the target names: S 0 written, 2 found"
            in done.stdout)
    assert (out.parent / "cell.dat").read_bytes() == (program.parent / "cell.dat").read_bytes()


def test_rapid_a_calibration_taking_axis_5_across_zero_writes_the_new_cfx(tmp_path: Path) -> None:
    half = (math.pi / 2 + A5) / 2
    point = (f"[[{930 + 158 * math.cos(A5):.4f},0,{1320 - 158 * math.sin(A5):.4f}],[{math.cos(half):.9f},0,"
             f"{math.sin(half):.9f},0],[0,0,0,0],[9E9,9E9,9E9,9E9,9E9,9E9]]")
    program = tmp_path / "cell.mod"
    program.write_text("MODULE cell\n  CONST robtarget p1:=" + point + ";\n  PROC main()\n"
                       "    MoveAbsJ [[0,-90,90,0,10,0],[9E9,9E9,9E9,9E9,9E9,9E9]], v100, fine, tool0;\n"
                       "    MoveJ p1, v100, fine, tool0;\n  ENDPROC\nENDMODULE\n", encoding="utf-8")
    out = tmp_path / "out.mod"
    done = run_pincal("filter", str(program), "--model", str(_calibrated(tmp_path)), "--nominal", str(KR16),
                      "--out", str(out))
    assert done.returncode == 0, done.stdout + done.stderr
    assert "],[0,0,0,1],[9E9" in out.read_text(encoding="utf-8").splitlines()[1]
    assert "line 2: 'p1'" in done.stdout and "(cfx 0 → 1)" in done.stdout


# The robot's base given in the program's world frame: the robot stands at x = 1 m, turned half a turn about z. The
# posture above, seen from the world: X = 1000 − (930 + 158 cos a), Y 0, Z as above; A 180, B = a, C 0 (Rz(π) Ry(a)).
MACHINE = "DEFDAT $MACHINE PUBLIC\nDECL FRAME $ROBROOT={X 1000.0,Y 0.0,Z 0.0,A 180.0,B 0.0,C 0.0}\nENDDAT\n"


def _krl_world(tmp_path: Path) -> Path:
    folder = tmp_path / "in"
    folder.mkdir()
    x, z, b = 1000 - 930 - 158 * math.cos(A5), 1320 - 158 * math.sin(A5), math.degrees(A5)
    (folder / "cell.src").write_text("DEF cell( )\n$BASE = $NULLFRAME\nPTP {A1 0,A2 -90,A3 90,A4 0,A5 10,A6 0}\n"
                                     "PTP XP1\nEND\n", encoding="utf-8")
    (folder / "cell.dat").write_text(f"DEFDAT cell\nDECL E6POS XP1={{X {x:.4f},Y 0.0,Z {z:.4f},A 180.0,B {b:.5f},"
                                     "C 0.0,S 2,T 2}\nENDDAT\n", encoding="utf-8")
    (tmp_path / "machine.dat").write_text(MACHINE, encoding="utf-8")
    return folder / "cell.src"


def test_krl_points_in_world_placed_by_robroot_or_robot_base(tmp_path: Path) -> None:
    program, cal = _krl_world(tmp_path), _calibrated(tmp_path)
    runs = {}
    for how, extra in (("robroot", ["--config", str(tmp_path / "machine.dat")]),
                       ("option", ["--robot-base", f"1,0,0,0,0,{math.pi}"]), ("none", [])):
        out = tmp_path / how / "cell.src"
        runs[how] = run_pincal("filter", str(program), "--model", str(cal), "--nominal", str(KR16), "--out",
                               str(out), *extra)
        runs[how + " dat"] = (out.parent / "cell.dat").read_text(encoding="utf-8") if out.exists() else ""
    assert runs["robroot"].returncode == 0, runs["robroot"].stdout + runs["robroot"].stderr
    line = runs["robroot dat"].splitlines()[1]
    assert line == (f"DECL E6POS XP1={{X {70 - 158 * math.cos(3e-4):.4f},Y 0.0000,Z {1320 + 158 * 3e-4:.4f},"
                    "A 180.00000,B -0.01719,C 0.00000,S 6,T 18}")
    assert f"robot base in $WORLD: $ROBROOT of {tmp_path / 'machine.dat'} line 2" in runs["robroot"].stdout
    assert runs["option"].returncode == 0 and runs["option dat"] == runs["robroot dat"]
    assert "robot base in $WORLD: --robot-base" in runs["option"].stdout
    assert "$WORLD taken as the robot's base (none given: --config $machine.dat or --robot-base)" in runs["none"].stdout
    assert runs["none dat"].splitlines()[1] != line  # the world point taken in the robot's base is another pose


def test_rapid_points_in_world_placed_by_the_base_frame_of_moc_cfg(tmp_path: Path) -> None:
    """Rz(π) Ry(90° + a) has the quaternion (0, −sin h, 0, cos h), h = (90° + a) / 2."""
    half = (math.pi / 2 + A5) / 2
    point = (f"[[{70 - 158 * math.cos(A5):.4f},0,{1320 - 158 * math.sin(A5):.4f}],[0,{-math.sin(half):.9f},0,"
             f"{math.cos(half):.9f}],[0,0,0,0],[9E9,9E9,9E9,9E9,9E9,9E9]]")
    program = tmp_path / "cell.mod"
    program.write_text("MODULE cell\n  CONST robtarget p1:=" + point + ";\n  PROC main()\n"
                       "    MoveAbsJ [[0,-90,90,0,10,0],[9E9,9E9,9E9,9E9,9E9,9E9]], v100, fine, tool0;\n"
                       "    MoveJ p1, v100, fine, tool0;\n  ENDPROC\nENDMODULE\n", encoding="utf-8")
    moc = tmp_path / "MOC.cfg"
    moc.write_text("MOC:CFG_1.0:6:0::\nROBOT:\n      -name \"ROB_1\" -use_robot_type \"ROB1\" \\\n"
                   "      -base_frame_pos_x 1 -base_frame_orient_u0 0 -base_frame_orient_u3 1\n", encoding="utf-8")
    out = tmp_path / "out.mod"
    done = run_pincal("filter", str(program), "--model", str(_calibrated(tmp_path)), "--nominal", str(KR16),
                      "--config", str(moc), "--out", str(out))
    assert done.returncode == 0, done.stdout + done.stderr
    new = (math.pi / 2 + A5 - 5e-4) / 2
    assert out.read_text(encoding="utf-8").splitlines()[1] == (
        f"  CONST robtarget p1:=[[{70 - 158 * math.cos(3e-4):.4f},0.0000,{1320 + 158 * 3e-4:.4f}],[0.000000000,"
        f"{-math.sin(new):.9f},0.000000000,{math.cos(new):.9f}],[0,0,0,1],[9E9,9E9,9E9,9E9,9E9,9E9]];")
    assert f"robot base in the world frame: the base frame of {moc} line 4" in done.stdout


def test_the_robot_base_given_twice_or_to_urscript_is_an_error(tmp_path: Path) -> None:
    program = _krl_world(tmp_path)
    twice = run_pincal("filter", str(program), "--model", str(KR16), "--out", str(tmp_path / "o" / "cell.src"),
                       "--config", str(tmp_path / "machine.dat"), "--robot-base", "1,0,0,0,0,0")
    assert twice.returncode == 2 and twice.stderr.startswith("pincal: error: the robot's base is given twice: $ROBROOT")
    (tmp_path / "second.dat").write_text(MACHINE, encoding="utf-8")
    two = run_pincal("filter", str(program), "--model", str(KR16), "--out", str(tmp_path / "o" / "cell.src"),
                     "--config", str(tmp_path / "machine.dat"), "--config", str(tmp_path / "second.dat"))
    assert two.returncode == 2 and "$ROBROOT is declared 2 times" in two.stderr and "second.dat line 2" in two.stderr
    script = tmp_path / "p.script"
    script.write_text("def p():\n  movel(p[0.5, 0.1, 0.4, 0, 3.14, 0])\nend\n", encoding="utf-8")
    ur = run_pincal("filter", str(script), "--model", "ur10", "--out", str(tmp_path / "o.script"), "--robot-base",
                    "1,0,0,0,0,0")
    assert ur.returncode == 2 and "is URScript, whose poses are in the robot's base frame" in ur.stderr
    assert not (tmp_path / "o" / "cell.src").exists() and not (tmp_path / "o.script").exists()  # nothing written
    assert all("Traceback" not in r.stderr and len(r.stderr.strip().splitlines()) == 1 for r in (twice, two, ur))


def test_a_config_file_nothing_is_read_from_is_said(tmp_path: Path) -> None:
    program = _krl_world(tmp_path)
    (tmp_path / "notes.dat").write_text("DEFDAT notes\nDECL INT COUNT=3\nENDDAT\n", encoding="utf-8")
    krl = run_pincal("filter", str(program), "--model", str(KR16), "--out", str(tmp_path / "k" / "cell.src"),
                     "--config", str(tmp_path / "notes.dat"))
    assert krl.returncode == 1
    assert (f"warning: {tmp_path / 'notes.dat'} line 1: --config file: no TOOL_DATA, BASE_DATA nor $ROBROOT declared "
            "in it: nothing read") in krl.stdout
    module = tmp_path / "cell.mod"
    module.write_text("MODULE cell\n  PROC main()\n    MoveAbsJ [[0,-90,90,0,10,0],[9E9,9E9,9E9,9E9,9E9,9E9]], v100, "
                      "fine, tool0;\n  ENDPROC\nENDMODULE\n", encoding="utf-8")
    rapid = run_pincal("filter", str(module), "--model", str(KR16), "--out", str(tmp_path / "r.mod"), "--config",
                       str(tmp_path / "notes.dat"))
    assert rapid.returncode == 2 and "is not a MOC.cfg" in rapid.stderr and not (tmp_path / "r.mod").exists()
