"""A robot program's errors name the file (and the line, where one is at fault) as fields beside the message: the
program files pincal filter reads, the controller's files beside them, and the overlap of two rewrites."""

from __future__ import annotations

from pathlib import Path

import pinocchio as pin
import pytest
from conftest import ROOT, run_pincal

from pincal.errors import DataError
from pincal.io.program_reader import read_program
from pincal.io.programs import Edit, read_text, rewritten
from pincal.io.rapid import moc_base
from pincal.io.urscript import read_urscript

PROGRAMS = ROOT / "examples" / "data" / "programs"
KR16 = ROOT / "examples" / "data" / "robots" / "kr16_like.urdf"


def test_a_control_byte_is_named_by_file_and_line_whatever_the_line_ends(tmp_path: Path) -> None:
    for ends in (b"\n", b"\r\n", b"\r"):
        path = tmp_path / "cell.script"
        path.write_bytes(ends.join([b"def p():", b"  movej([0, 0, 0, 0, 0, 0])", b"  x = 1\x07", b"end"]))
        with pytest.raises(DataError, match=r"is not a text file \(byte 0x07") as caught:
            read_text(path)
        assert (caught.value.file, caught.value.line) == (str(path), 3)


def test_a_missing_or_empty_program_is_named_by_file(tmp_path: Path) -> None:
    (tmp_path / "empty.mod").write_text(" \n")
    for name in ("missing.src", "empty.mod"):
        with pytest.raises(DataError) as caught:
            read_text(tmp_path / name)
        assert (caught.value.file, caught.value.line) == (str(tmp_path / name), None)


def test_a_base_given_twice_names_the_option(tmp_path: Path) -> None:
    machine = tmp_path / "machine.dat"
    machine.write_text("FRAME $ROBROOT={X 1000.0,Y 0.0,Z 0.0,A 0.0,B 0.0,C 0.0}\n")
    with pytest.raises(DataError, match="given twice") as caught:
        read_program(PROGRAMS / "palletize.src", pin.SE3.Identity(), [machine], pin.SE3.Identity())
    assert caught.value.option == "robot_base"
    with pytest.raises(DataError, match="is URScript") as caught:
        read_program(PROGRAMS / "pick_place.script", pin.SE3.Identity(), [machine])
    assert (caught.value.file, caught.value.option) == (str(PROGRAMS / "pick_place.script"), "config")


def test_a_base_frame_not_a_unit_quaternion_is_named_where_it_is_first_written() -> None:
    moc = {"MOC.cfg": "MOC:CFG_1.0:6:0::\nROBOT:\n  -name \"ROB_1\" -base_frame_pos_z 0.25 \\\n"
                      "  -base_frame_orient_u0 2\n"}
    with pytest.raises(DataError, match="not a unit quaternion") as caught:
        moc_base(moc)
    assert (caught.value.file, caught.value.line) == ("MOC.cfg", 3)


def test_two_rewrites_that_overlap_are_named_by_file_and_line() -> None:
    text = "def p():\n  movej([0, 0, 0, 0, 0, 0])\nend\n"
    program = read_urscript(text, "p.script", pin.SE3.Identity())
    start = text.index("movej")
    with pytest.raises(DataError, match="two rewrites overlap") as caught:
        rewritten(program, [Edit("p.script", start, start + 5, "a"), Edit("p.script", start + 2, start + 8, "b")])
    assert (caught.value.file, caught.value.line) == ("p.script", 2)


def test_the_command_names_the_controller_file_at_fault(tmp_path: Path) -> None:
    machine = tmp_path / "machine.dat"
    machine.write_text("; the cell's robot\nFRAME $ROBROOT={X 1000.0,Y 0.0}\n")
    done = run_pincal("filter", str(PROGRAMS / "palletize.src"), "--model", str(KR16), "--config", str(machine),
                      "--out", str(tmp_path / "out" / "palletize.src"))
    assert done.returncode == 2, done.stderr
    assert done.stderr.splitlines() == [f"pincal: error: $ROBROOT at {machine} line 2: not a frame of X, Y, Z, A, B, "
                                        "C"]
    assert [p.name for p in tmp_path.rglob("*") if p.is_file()] == ["machine.dat"]  # nothing written
