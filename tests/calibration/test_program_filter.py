"""filter_program, the work of ``pincal filter``: with the nominal robot as the model nothing moves; a model of
another robot, or a joint target of another count of joints, is refused naming it."""

from __future__ import annotations

import numpy as np
import pinocchio as pin
import pytest
from conftest import ROOT

import pincal
from pincal.calibration.compensate import load_model
from pincal.calibration.program_filter import default_frames, filter_program
from pincal.errors import DataError
from pincal.io.krl import read_krl
from pincal.io.program_reader import read_program
from pincal.io.programs import Program, Target
from pincal.io.targets import OK
from pincal.io.urscript import read_urscript

PROGRAMS = ROOT / "examples" / "data" / "programs"


def test_the_nominal_model_moves_no_target() -> None:
    nominal = pincal.load_robot("ur10")
    program = read_program(PROGRAMS / "pick_place.script", pin.SE3.Identity())
    result = filter_program(program, load_model("ur10"), nominal)
    assert (result.base_frame, result.flange, result.joint_targets) == ("base", "tool0", 2)
    assert [r.status for r in result.results] == [OK] * 6
    assert max(r.move[0] for r in result.results) < 1e-9 and max(r.move[1] for r in result.results) < 1e-9
    assert all(np.isnan(r.bound) for r in result.results)  # a robot name carries no calibration


def test_another_robot_and_another_joint_count_are_refused() -> None:
    kr16 = pincal.load_robot(ROOT / "examples" / "data" / "robots" / "kr16_like.urdf")
    program = read_program(PROGRAMS / "pick_place.script", pin.SE3.Identity())
    with pytest.raises(DataError, match="not the same robot"):
        filter_program(program, load_model("ur10"), kr16)
    short = read_urscript("def p():\n  movej([0, 1, 2])\nend\n", "p.script", pin.SE3.Identity())
    assert short.targets == [] and "movej" in short.problems[0].what  # three numbers: not a joint list
    assert default_frames(kr16, "krl") == ("base", "flange")
    partial = read_krl("DEF p( )\nPTP {A1 10.0}\nEND\n", "p.src", None, "p.dat", {}, pin.SE3.Identity())
    assert partial.targets == [] and "partial axis point" in partial.problems[0].what
    five = Program("urscript", {"p.script": ""}, [Target("p.script", 2, "movej", np.zeros(5), None,
                                                         pin.SE3.Identity(), pin.SE3.Identity(), "joints")])
    with pytest.raises(DataError, match="has 5 values") as caught:
        filter_program(five, load_model("ur10"), pincal.load_robot("ur10"))
    assert (caught.value.file, caught.value.line) == ("p.script", 2)
