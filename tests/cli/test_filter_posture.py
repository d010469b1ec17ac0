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
