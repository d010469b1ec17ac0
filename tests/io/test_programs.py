"""The program readers of ``pincal filter``: each language's targets in SI units with their tool and frame, what
they do not read named by line, and a pose written back read as that pose."""

from __future__ import annotations

import math

import numpy as np
import pinocchio as pin
import pytest

from pincal.errors import DataError
from pincal.io.krl import read_krl, robroot
from pincal.io.programs import (
    euler_zyx_near,
    language_of,
    rewritten,
    rotation_vector_near,
    vendor_mismatch,
    zyx_rotation,
)
from pincal.io.rapid import moc_base, read_rapid
from pincal.io.urscript import read_urscript


def _moved(pose: pin.SE3) -> pin.SE3:
    return pose * pin.SE3(pin.exp3(np.array([1e-3, -2e-3, 3e-3])), np.array([1e-3, 2e-3, -1.5e-3]))


def _round_trip(program, k: int, reread) -> tuple[pin.SE3, pin.SE3]:  # type: ignore[no-untyped-def]
    target = program.targets[k]
    new = _moved(target.pose)
    texts = rewritten(program, target.render(new))
    return new, reread(texts).targets[k].pose


def test_urscript_poses_joints_and_tcp() -> None:
    text = ("def p():\n  # movel(p[9, 9, 9, 0, 0, 0])\n  movel(p[0.1, -0.2, 0.3, 0, 3.14159, 0], a=1.2)\n"
            "  set_tcp(p[0, 0, 0.2, 0, 0, 0])\n  global wp=p[.5, 0, 1e-1, 0.1, 0.2, 0.3]\n  movej(wp)\n"
            "  servoj([0, -1.5, 1.5, 0, 1, 0], t=0.002)\n  movep(pose_add(wp, p[0,0,0.01,0,0,0]))\nend\n")
    tcp = pin.SE3(np.eye(3), np.array([0.0, 0.0, 0.1]))
    program = read_urscript(text, "p.script", tcp)
    first, second, third = program.targets
    assert first.line == 3 and np.allclose(first.pose.translation, [0.1, -0.2, 0.3])
    assert np.allclose(pin.log3(first.pose.rotation), [0, 3.14159, 0]) and first.tool == tcp
    assert second.name == "wp" and second.line == 5 and second.uses == (6,)
    assert np.allclose(second.tool.translation, [0, 0, 0.2]) and np.allclose(second.pose.translation, [0.5, 0, 0.1])
    assert third.pose is None and np.array_equal(third.joints, [0, -1.5, 1.5, 0, 1, 0])
    assert [(p.line, p.what.split(":")[0]) for p in program.problems] == [(8, "movep")]
    new, back = _round_trip(program, 1, lambda texts: read_urscript(texts["p.script"], "p.script", tcp))
    assert np.allclose(back.homogeneous, new.homogeneous, atol=1e-8)


def test_krl_points_in_their_base_with_their_tool() -> None:
    dat = ("DEFDAT t\nDECL E6POS XP1={X 1000.0,Y -200.0,Z 500.0,A 90.0,B 0.0,C 180.0,S 2,T 35,E1 0.0}\n"
           "DECL POS XP2={X 10.0,Y 0.0}\nENDDAT\n")
    src = ("DEF t( )\n$TOOL = TOOL_DATA[2]\n$BASE = BASE_DATA[1]\nLIN XP1 ; PTP XP9\nLIN XP2\n"
           "PTP {A1 90, A2 -90, A3 90, A4 0, A5 45, A6 0}\nEND\n")
    config = {"$config.dat": "TOOL_DATA[2]={X 0.0,Y 0.0,Z 100.0,A 0.0,B 0.0,C 0.0}\n"
                             "BASE_DATA[1]={X 500.0,Y 0.0,Z 0.0,A 0.0,B 0.0,C 0.0}\n"}
    program = read_krl(src, "t.src", dat, "t.dat", config, pin.SE3.Identity())
    point, joints = program.targets
    assert point.file == "t.dat" and point.line == 2 and point.uses == (4,)
    assert np.allclose(point.pose.translation, [1.0, -0.2, 0.5])
    assert np.allclose(point.pose.rotation, zyx_rotation(math.pi / 2, 0.0, math.pi))
    assert np.allclose(point.tool.translation, [0, 0, 0.1]) and np.allclose(point.frame.translation, [0.5, 0, 0])
    assert np.allclose(joints.joints, np.radians([90, -90, 90, 0, 45, 0]))
    assert [(p.file, p.line) for p in program.problems] == [("t.dat", 3)]  # XP2 lacks Z, A, B, C
    assert "partial point" in program.problems[0].what
    assert point.posture is not None
    assert point.posture.language == "krl" and {k: v[0] for k, v in point.posture.fields.items()} == {"S": 2, "T": 35}
    assert [dat[a:b] for _, a, b in point.posture.fields.values()] == ["2", "35"]  # where each is rewritten
    new, back = _round_trip(program, 0, lambda texts: read_krl(texts["t.src"], "t.src", texts["t.dat"], "t.dat",
                                                               config, pin.SE3.Identity()))
    assert np.allclose(back.homogeneous, new.homogeneous, atol=1e-6)


def test_rapid_targets_tools_and_work_objects() -> None:
    text = ("MODULE m\n  PERS tooldata t1:=[TRUE,[[0,0,100],[1,0,0,0]],[1,[0,0,1],[1,0,0,0],0,0,0]];\n"
            "  PERS tooldata fixed:=[FALSE,[[0,0,100],[1,0,0,0]],[1,[0,0,1],[1,0,0,0],0,0,0]];\n"
            "  PERS wobjdata w1:=[FALSE,TRUE,\"\",[[100,0,0],[1,0,0,0]],[[0,50,0],[0.7071068,0,0,0.7071068]]];\n"
            "  CONST robtarget p1:=[[10,20,30],[0,0,1,0],[0,0,-1,0],[9E9,9E9,9E9,9E9,9E9,9E9]];\n"
            "  PROC main()\n    MoveL p1, v100, fine, t1\\WObj:=w1; ! MoveL p9, v1, z1, t1;\n"
            "    MoveJ \\Conc, [[1,2,3],[1,0,0,0],[0,0,0,0],[9E9,9E9,9E9,9E9,9E9,9E9]], v100, z10, fixed;\n"
            "    MoveAbsJ [[0,10,20,30,40,50],[9E9,9E9,9E9,9E9,9E9,9E9]], v100, fine, tool0;\n  ENDPROC\nENDMODULE\n")
    program = read_rapid(text, "m.mod", pin.SE3.Identity())
    point, joints = program.targets
    assert point.name == "p1" and point.line == 5 and point.uses == (7,)
    assert np.allclose(point.pose.translation, [0.01, 0.02, 0.03])
    assert np.allclose(point.pose.rotation, pin.Quaternion(0, 0, 1, 0).matrix())  # q1 is w
    assert np.allclose(point.tool.translation, [0, 0, 0.1])
    assert np.allclose(point.frame.translation, [0.1, 0.05, 0]) and np.allclose(point.frame.rotation[:, 0], [0, 1, 0])
    assert np.allclose(joints.joints, np.radians([0, 10, 20, 30, 40, 50]))
    assert [(p.line, "stationary tool" in p.what) for p in program.problems] == [(8, True)]
    assert point.posture is not None and point.posture.language == "rapid"
    assert {k: v[0] for k, v in point.posture.fields.items()} == {"cf1": 0, "cf4": 0, "cf6": -1, "cfx": 0}
    assert [text[a:b] for _, a, b in point.posture.fields.values()] == ["0", "0", "-1", "0"]
    new, back = _round_trip(program, 0, lambda texts: read_rapid(texts["m.mod"], "m.mod", pin.SE3.Identity()))
    assert np.allclose(back.homogeneous, new.homogeneous, atol=1e-7)


def test_angles_written_near_the_old_ones() -> None:
    rng = np.random.default_rng(0)
    for _ in range(20):
        rotation = pin.exp3(rng.normal(size=3))
        near = rng.uniform(-4, 4, size=3)
        a, b, c = euler_zyx_near(rotation, near)
        assert np.allclose(zyx_rotation(a, b, c), rotation)
        r = rotation_vector_near(rotation, near)
        assert np.allclose(pin.exp3(r), rotation)
    assert np.allclose(rotation_vector_near(pin.exp3(np.array([0, 0, math.pi - 1e-3])), [0, 0, -3.2]),
                       [0, 0, -math.pi - 1e-3])


def test_unknown_suffix_refused() -> None:
    with pytest.raises(DataError, match="URScript") as caught:
        language_of("prog.txt")
    assert caught.value.file == "prog.txt"


def test_angles_at_b_plus_minus_90_keep_the_written_split() -> None:
    for written in ((0.0, 90.0, 0.0), (10.0, 90.0, -20.0), (170.0, -90.0, 30.0), (-45.0, -90.0, 45.0)):
        near = np.radians(written)
        rotation = zyx_rotation(*near)
        assert np.allclose(np.degrees(euler_zyx_near(rotation, near)), written, atol=1e-9)
        other = zyx_rotation(*np.radians(written)) @ pin.exp3(np.array([0.0, 0.0, 1e-3]))  # off the singularity
        assert np.allclose(zyx_rotation(*euler_zyx_near(other, near)), other)


def test_a_robot_named_for_another_maker_than_the_languages() -> None:
    assert vendor_mismatch("urscript", ["ur10e", "UR5"]) is None and vendor_mismatch("krl", ["kr16_like"]) is None
    assert vendor_mismatch("rapid", ["abb_irb2400", "my_arm", "panda"]) is None  # a name of no maker says nothing
    assert vendor_mismatch("krl", ["pur10", "tur5x"]) is None  # 'ur' inside a word is not a UR arm
    assert "named like a KUKA arm" in (vendor_mismatch("urscript", ["kr16_2"]) or "")
    assert "robot 'irb_120' is named like an ABB arm" in (vendor_mismatch("krl", ["irb_120"]) or "")
    assert "Universal Robots arm" in (vendor_mismatch("rapid", ["ur10"]) or "")


def test_a_pose_literal_with_a_space_before_its_bracket() -> None:
    text = ("def p():\n  global A_p = p [0.5, 0.1, 0.4, 0, 3.1, 0]\n  movel(A_p)\n  movej(p\t[0.4, 0, 0.5, 0, 3, 0])\n"
            "end\n")
    program = read_urscript(text, "p.script", pin.SE3.Identity())
    assert program.problems == [] and [(t.name, t.line) for t in program.targets] == [("A_p", 2), ("movej", 4)]
    assert np.allclose(program.targets[0].pose.translation, [0.5, 0.1, 0.4])


def test_the_robots_base_from_machine_dat_and_moc_cfg() -> None:
    """$ROBROOT's X, Y, Z [mm], A, B, C [°]; MOC.cfg's base frame in m and a quaternion, ABB's defaults where not
    written; several of either refused, naming them."""
    machine = {"m.dat": "; $ROBROOT={X 9}\nFRAME $ROBROOT={X 1000.0,Y -500.0,Z 20.0,A 90.0,B 0.0,C 0.0}\n"}
    frame, words = robroot(machine) or (None, "")
    assert words == "$ROBROOT of m.dat line 2"  # the commented line is not read
    assert frame is not None and np.allclose(frame.translation, [1.0, -0.5, 0.02])
    assert np.allclose(frame.rotation, [[0, -1, 0], [1, 0, 0], [0, 0, 1]])
    with pytest.raises(DataError, match=r"declared 2 times \(m\.dat line 2, n\.dat line 1\)") as caught:
        robroot({**machine, "n.dat": "DECL FRAME $ROBROOT={X 0,Y 0,Z 0,A 0,B 0,C 0}\n"})
    assert (caught.value.file, caught.value.line) == ("n.dat", 1)  # the second declaration
    with pytest.raises(DataError, match="not a frame") as caught:
        robroot({"m.dat": "\n$ROBROOT={X 0,Y 0}\n"})
    assert (caught.value.file, caught.value.line) == ("m.dat", 2)
    assert robroot({"c.dat": "TOOL_DATA[1]={X 0,Y 0,Z 0,A 0,B 0,C 0}\n"}) is None
    moc = {"MOC.cfg": "MOC:CFG_1.0:6:0::\nROBOT:\n  -name \"ROB_1\" -base_frame_pos_z 0.25 \\\n"
                      "  -base_frame_orient_u0 0.7071068 -base_frame_orient_u3 0.7071068\n"}
    found = moc_base(moc)
    assert found is not None and found[1] == "the base frame of MOC.cfg line 3"
    assert np.allclose(found[0].translation, [0, 0, 0.25])
    assert np.allclose(found[0].rotation, [[0, -1, 0], [1, 0, 0], [0, 0, 1]], atol=1e-7)  # 90° about z
    with pytest.raises(DataError, match="several robots' base frames") as caught:
        moc_base({"MOC.cfg": moc["MOC.cfg"] + "  -name \"ROB_2\" -base_frame_pos_z 1\n"})
    assert (caught.value.file, caught.value.line) == ("MOC.cfg", 5)
    default = moc_base({"MOC.cfg": "MOC:CFG_1.0:6:0::\nROBOT:\n  -name \"ROB_1\" -use_robot_type \"ROB1\"\n"})
    assert default is not None and default[0] == pin.SE3.Identity() and "ABB's default" in default[1]
    with pytest.raises(DataError) as caught:
        moc_base({"$config.dat": "DEFDAT $CONFIG\nENDDAT\n"})
    assert (caught.value.file, caught.value.option, caught.value.line) == ("$config.dat", "config", None)


def test_status_and_turn_written_as_bit_strings() -> None:
    dat = "DEFDAT t\nDECL E6POS XP1={X 1000.0,Y 0.0,Z 500.0,A 0.0,B 90.0,C 0.0,S 'B110',T 'B100011'}\nENDDAT\n"
    program = read_krl("DEF t( )\nPTP XP1\nEND\n", "t.src", dat, "t.dat", {}, pin.SE3.Identity())
    posture = program.targets[0].posture
    assert posture is not None and posture.binary == frozenset({"S", "T"})
    assert {k: v[0] for k, v in posture.fields.items()} == {"S": 6, "T": 35}
    assert [dat[a:b] for _, a, b in posture.fields.values()] == ["'B110'", "'B100011'"]
