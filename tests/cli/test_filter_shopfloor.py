"""``pincal filter`` on what shop-floor programs hold beyond the examples: a point changed by the program after its
declaration, a tool set for one move, Polyscope's ``movej(get_inverse_kin(…))``. A point the program moves to with
another value than the one written, or with another tool than pincal read, must be named and left as written, never
rewritten for a pose the robot is not sent to. The robot's own URDF as the model (nothing moves): no calibration."""

from __future__ import annotations

from pathlib import Path

import numpy as np
import pinocchio as pin
from conftest import ROOT, run_pincal

import pincal
from pincal.calibration.joint_commands import Model
from pincal.calibration.program_filter import filter_program
from pincal.io.program_reader import read_program

KR16 = ROOT / "examples" / "data" / "robots" / "kr16_like.urdf"
UR_POSE = "p[-0.45, -0.55, 0.20, 2.2214, -2.2214, 0.0]"


def _filter(program: Path, *options: str) -> tuple[int, str, str]:
    out = program.parent / "out" / program.name
    done = run_pincal("filter", str(program), "--out", str(out), *options)
    assert "Traceback" not in done.stderr, done.stderr
    return done.returncode, done.stdout + done.stderr, out.read_text(encoding="utf-8") if out.exists() else ""


def test_urscript_pose_variable_changed_by_an_expression_is_named_and_left(tmp_path: Path) -> None:
    program = tmp_path / "cell.script"
    text = (f"def cell():\n  global Pick_p={UR_POSE}\n  movel(Pick_p, a=1.2, v=0.25)\n"
            "  Pick_p = pose_add(Pick_p, p[0, 0, 0.1, 0, 0, 0])\n  movel(Pick_p, a=1.2, v=0.25)\nend\n")
    program.write_text(text, encoding="utf-8")
    code, said, written = _filter(program, "--model", "ur10")
    assert code == 1, said
    assert "cell.script line 3: target 'Pick_p': assigned 2 times" in said
    assert "0 Cartesian" in said and written == text


POINT = "{X 1100.0,Y -200.0,Z 900.0,A 180.0,B 45.0,C 180.0,S 2,T 2}"
CONFIG = ("DEFDAT $CONFIG\nTOOL_DATA[1]={X 0.0,Y 0.0,Z 180.0,A 0.0,B 0.0,C 0.0}\n"
          "TOOL_DATA[2]={X 0.0,Y 100.0,Z 250.0,A 0.0,B 0.0,C 0.0}\n"
          "BASE_DATA[1]={X 0.0,Y 0.0,Z -100.0,A 0.0,B 0.0,C 0.0}\nENDDAT\n")


def _krl(tmp_path: Path, src: str, dat: str) -> Path:
    (tmp_path / "config.dat").write_text(CONFIG, encoding="utf-8")
    (tmp_path / "cell.src").write_text(f"DEF cell( )\n{src}END\n", encoding="utf-8")
    (tmp_path / "cell.dat").write_text(f"DEFDAT cell\n{dat}ENDDAT\n", encoding="utf-8")
    return tmp_path / "cell.src"


def test_krl_spline_inline_form_takes_the_tool_and_base_of_its_with_clause(tmp_path: Path) -> None:
    """KSS 8's inline form writes the tool and base of each spline move in its WITH clause, from the point's FDAT."""
    src = ("$TOOL = TOOL_DATA[2]\n"
           "SPTP XP1 WITH $VEL_AXIS[1] = SVEL_JOINT(100.0), $TOOL = STOOL2(FP1), $BASE = SBASE(FP1.BASE_NO), "
           "$IPO_MODE = SIPO_MODE(FP1.IPO_FRAME), $LOAD = SLOAD(FP1.TOOL_NO)\n"
           "SLIN XP2 WITH $TOOL = TOOL_DATA[1], $BASE = BASE_DATA[1]\nLIN XP3\n")
    dat = (f"DECL E6POS XP1={POINT}\nDECL FDAT FP1={{TOOL_NO 1,BASE_NO 1,IPO_FRAME #BASE}}\n"
           f"DECL E6POS XP2={POINT}\nDECL E6POS XP3={POINT}\n")
    code, said, _ = _filter(_krl(tmp_path, src, dat), "--model", str(KR16), "--config", str(tmp_path / "config.dat"))
    assert code == 1, said
    for name in ("XP1", "XP2"):
        assert f"'{name}' left as written" not in said and f"line 4: '{name}'" not in said
    assert "2 Cartesian" in said
    assert "cell.dat line 5: 'XP3': its tool or base is not known" in said  # after a WITH: set again, or not known
    targets = read_program(tmp_path / "cell.src", pin.SE3.Identity(), [tmp_path / "config.dat"]).targets
    assert [t.name for t in targets] == ["XP1", "XP2"]
    for target in targets:  # TOOL_DATA[1] and BASE_DATA[1], not the TOOL_DATA[2] set before
        assert target.tool.translation.tolist() == [0.0, 0.0, 0.18]
        assert target.frame.translation.tolist() == [0.0, 0.0, -0.1]


def test_krl_point_changed_by_the_program_is_named_and_left(tmp_path: Path) -> None:
    src = "PTP XP1\nXP1.Z = XP1.Z + 50.0\nLIN XP1\nxp2 = XP1\nLIN XP2\nPTP XP3\n"
    dat = f"DECL E6POS XP1={POINT}\nDECL E6POS XP2={POINT}\nDECL E6POS XP3={POINT}\n"
    code, said, _ = _filter(_krl(tmp_path, src, dat), "--model", str(KR16))
    assert code == 1, said
    for line, name, moves in ((3, "XP1", "lines 2, 4"), (5, "XP2", "line 6")):
        assert f"cell.src line {line}: point '{name}' is changed by the program here (its moves: {moves})" in said
    assert "1 Cartesian" in said  # XP3 alone


RAPID = """MODULE Cell
    PERS tooldata tGlue:=[TRUE,[[0,0,150],[1,0,0,0]],[1.5,[0,0,60],[1,0,0,0],0,0,0]];
    PERS tooldata tPen:=[TRUE,[[0,0,100],[1,0,0,0]],[1.5,[0,0,60],[1,0,0,0],0,0,0]];
    PERS robtarget pA:=[[930,0,1100],[0,0,1,0],[0,0,0,0],[9E9,9E9,9E9,9E9,9E9,9E9]];
    VAR robtarget pB:=[[930,0,1100],[0,0,1,0],[0,0,0,0],[9E9,9E9,9E9,9E9,9E9,9E9]];
    CONST robtarget pC:=[[930,0,1000],[0,0,1,0],[0,0,0,0],[9E9,9E9,9E9,9E9,9E9,9E9]];
    PROC main()
        MoveL \\Conc, pA, v500, z20, tPen;
        pB.trans.z := pB.trans.z + 50; MoveL pB, v100, fine, tPen;
        tGlue.tframe.trans.z := 160;
        moveL pC, v100\\T:=5, fine, tGlue;
    ENDPROC
ENDMODULE
"""


def test_rapid_robtarget_or_tool_changed_by_the_program_is_named_and_left(tmp_path: Path) -> None:
    program = tmp_path / "cell.mod"
    program.write_text(RAPID, encoding="utf-8")
    code, said, _ = _filter(program, "--model", str(KR16))
    assert code == 1, said
    assert "cell.mod line 9: point 'pB' is changed by the program here (its moves: line 9)" in said
    assert "cell.mod line 6: 'pC': 'tGlue' is changed by the program at line 10: left as written" in said
    assert "1 Cartesian" in said  # pA alone


#: A UR10 posture off the branch the reference posture's inverse kinematics finds, and its tool0 pose in base [m, rad].
BRANCH_Q = [0.4, -1.2, -1.6, -1.9, 1.5, 0.3]
BRANCH_POSE = "p[0.46639948, 0.01211814, 0.79889303, 2.31402357, -2.09438857, 0.10836935]"


def test_urscript_polyscope_movej_through_get_inverse_kin_is_filtered_from_its_qnear(tmp_path: Path) -> None:
    """Polyscope writes a MoveJ waypoint as ``movej(get_inverse_kin(Waypoint_1_p, qnear=Waypoint_1_q), …)``: the
    pose is the target, the controller's inverse kinematics starts from qnear (as pincal's must)."""
    program = tmp_path / "cell.script"
    q = ", ".join(map(str, BRANCH_Q))
    program.write_text(f"def cell():\n  global Waypoint_1_p={BRANCH_POSE}\n  global Waypoint_1_q=[{q}]\n"
                       "  movej(get_inverse_kin(Waypoint_1_p, qnear=Waypoint_1_q), a=1.39, v=1.04)\n"
                       f"  movel(get_inverse_kin({BRANCH_POSE}, [{q}], tcp=p[0,0,0.1,0,0,0]), a=1.2)\nend\n",
                       encoding="utf-8")
    code, said, _ = _filter(program, "--model", "ur10")
    assert code == 1, said
    assert "1 Cartesian" in said and "Waypoint_1_p" in said and "Waypoint_1_q" not in said
    assert "line 5: movel: get_inverse_kin: its argument 'tcp=p[0,0,0.1,0,0,0]' is not read" in said
    program_read = read_program(program, pin.SE3.Identity())
    [target] = program_read.targets
    assert target.name == "Waypoint_1_p" and target.near is not None and target.near.tolist() == BRANCH_Q
    robot = pincal.load_robot("ur10")
    [result] = filter_program(program_read, Model(robot), robot).results
    assert np.abs(result.commands - np.array(BRANCH_Q)).max() < 1e-6  # the branch of qnear, not of the reference


def test_rapid_a_string_that_reads_like_a_move_is_not_a_move(tmp_path: Path) -> None:
    program = tmp_path / "cell.mod"
    text = RAPID.replace("        tGlue.tframe.trans.z := 160;\n", '        TPWrite "MoveL pA, v100, fine, tool0;";\n')
    program.write_text(text.replace("pB.trans.z := pB.trans.z + 50; ", ""), encoding="utf-8")
    code, said, _ = _filter(program, "--model", str(KR16))
    assert code == 0, said
    assert "3 Cartesian" in said
    assert [k for k in said.splitlines() if k.startswith("warning") and "KUKA arm" not in k] == []


def test_a_rapid_program_on_a_ur_is_warned_in_plain_english(tmp_path: Path) -> None:
    program = tmp_path / "cell.mod"
    program.write_text(RAPID, encoding="utf-8")
    _, said, _ = _filter(program, "--model", "ur10")
    assert ("warning: the program is RAPID (the language of ABB) but robot 'ur10' is named like a Universal Robots "
            "arm") in said


def test_krl_tool_data_declared_differently_in_two_files_is_not_guessed(tmp_path: Path) -> None:
    program = _krl(tmp_path, "$TOOL = TOOL_DATA[1]\nPTP XP1\n$TOOL = TOOL_DATA[2]\nPTP XP2\n",
                   f"DECL E6POS XP1={POINT}\nDECL E6POS XP2={POINT}\n")
    other = tmp_path / "backup.dat"
    other.write_text("DEFDAT $CONFIG\nTOOL_DATA[1]={X 0.0,Y 0.0,Z 100.0,A 0.0,B 0.0,C 0.0}\n"
                     "TOOL_DATA[2]={X 0.0,Y 100.0,Z 250.0,A 0.0,B 0.0,C 0.0}\nENDDAT\n", encoding="utf-8")
    code, said, _ = _filter(program, "--model", str(KR16), "--config", str(tmp_path / "config.dat"), "--config",
                            str(other))
    assert code == 1, said
    assert "'XP1': its tool or base is not known: TOOL_DATA[1] is declared differently in" in said
    assert "config.dat line 2 and" in said and "backup.dat line 2" in said
    assert "1 Cartesian" in said  # XP2: TOOL_DATA[2] is the same in both


def test_a_tcp_in_millimetres_or_degrees_is_refused_by_name(tmp_path: Path) -> None:
    program = tmp_path / "cell.script"
    program.write_text(f"def cell():\n  movel({UR_POSE}, a=1.2, v=0.25)\nend\n", encoding="utf-8")
    for tcp, says in (("0,0,150,0,0,0", "a tool centre point 150 m from the flange: --tcp is in metres"),
                      ("0,0,0.15,0,180,0", "a rotation vector of 180 rad: --tcp turns in radians")):
        done = run_pincal("filter", str(program), "--model", "ur10", "--tcp", tcp, "--out", str(tmp_path / "o.script"))
        assert done.returncode == 2 and says in done.stderr, done.stdout + done.stderr
        assert done.stderr.count("\n") == 1 and not (tmp_path / "o.script").exists()
    done = run_pincal("filter", str(program), "--model", "ur10", "--robot-base", "0,0,0,0,0,90", "--out",
                      str(tmp_path / "o.script"))
    assert done.returncode == 2 and "a rotation vector of 90 rad: --robot-base turns in radians" in done.stderr


def test_rapid_points_are_named_as_the_module_spells_them(tmp_path: Path) -> None:
    program = tmp_path / "cell.mod"
    program.write_text(RAPID.replace("        tGlue.tframe.trans.z := 160;\n", "        MoveL pA, v100, fine, tGlue;\n")
                       .replace("pB.trans.z := pB.trans.z + 50; ", ""), encoding="utf-8")
    _, said, _ = _filter(program, "--model", str(KR16))
    assert "cell.mod line 4: 'pA' is reached with several tools or work objects (lines 8, 10)" in said
