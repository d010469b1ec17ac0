"""The posture a KRL or RAPID target names, computed on the KUKA-like arm (examples/data/robots/kr16_like.urdf) at
hand-made joint values whose geometry is worked out by hand below.

The arm: axis 1 (about −z) 0.675 m above the base, axis 2 (about y) 0.26 m ahead of it, axis 3 (about y) 0.68 m along
the lower arm, axis 4 (about −x) 0.035 m below the forearm's line, axis 5 (about y) 0.67 m along it: the wrist centre.
At A2 = −90° the lower arm stands up, axis 3 at (0.26, 0, 1.355); the forearm turns by A2 + A3 about y.
"""

from __future__ import annotations

import math

import numpy as np
import pytest
from conftest import ROOT

import pincal
from pincal.calibration.arm_posture import ArmSigns, arm_signs, mismatch, posture_edits, posture_values
from pincal.io.programs import NamedPosture

KR16 = ROOT / "examples" / "data" / "robots" / "kr16_like.urdf"


def _signs(degrees: list[float]) -> ArmSigns:
    robot = pincal.load_robot(KR16)
    raw = np.radians(degrees)
    return arm_signs(robot, robot.solve_fk(raw), raw, "base")


def _krl(s: int, t: int) -> NamedPosture:
    return NamedPosture("krl", "p.dat", {"S": (s, 0, 1), "T": (t, 2, 4)})


def _rapid(cf: list[int]) -> NamedPosture:
    return NamedPosture("rapid", "p.mod", {n: (v, 2 * k, 2 * k + 1) for k, (n, v) in
                                           enumerate(zip(("cf1", "cf4", "cf6", "cfx"), cf, strict=True))})


# (A1 … A6 [°], the wrist centre's x in the A1 system [m], S, T, RAPID [cf1, cf4, cf6, cfx]) by hand:
# 1. A2 −90, A3 90: forearm level, wrist at (0.26 + 0.67, 0, 1.355 − 0.035): ahead, in front of the upright lower arm;
#    A5 45 > 0: S 2 (bit 1); T 2 (A2 < 0); cfx 0.
# 2. A2 −90, A3 −30: the forearm turned by −120°: wrist x = 0.26 + 0.67 cos(−120°) − 0.035 sin(−120°) = −0.0447:
#    overhead (bit 0), behind the lower arm (bit 1 clear); A5 −20 ≤ 0 (bit 2): S 5; T 2 + 4 + 16 = 22; cfx 4 + 2 + 1.
# 3. case 1 turned by A1 = 100° (about −z): the A1 system turns with it, so still ahead: S 2; T 2 + 8 (A4 −10°);
#    cf1 = 1 (90–180°),
#    cf4 = −1 (A4 −10°), cf6 = 2 (A6 200°).
# 4. case 2 turned by A1 = −100°: overhead still: S 5, T 1 + 2 + 4 + 16 = 23, cf1 −2, cfx 7.
OVERHEAD = 0.26 + 0.67 * math.cos(math.radians(-120)) - 0.035 * math.sin(math.radians(-120))
CASES = [([0, -90, 90, 0, 45, 0], 0.93, 2, 2, [0, 0, 0, 0]),
         ([0, -90, -30, 0, -20, 0], OVERHEAD, 5, 22, [0, 0, 0, 7]),
         ([100, -90, 90, -10, 45, 200], 0.93, 2, 10, [1, -1, 2, 0]),
         ([-100, -90, -30, 0, -20, 0], OVERHEAD, 5, 23, [-2, 0, 0, 7])]


@pytest.mark.parametrize(("degrees", "ahead", "s", "t", "cf"), CASES)
def test_status_turn_and_configuration_at_hand_made_postures(degrees: list[float], ahead: float, s: int, t: int,
                                                              cf: list[int]) -> None:
    signs = _signs(degrees)
    assert signs.ahead == pytest.approx(ahead, abs=1e-9)
    assert mismatch(_krl(s, t), signs) is None
    assert mismatch(_rapid(cf), signs) is None
    assert {k: v[0] for k, v in posture_values(_krl(s, t), signs).items()} == {"S": s, "T": t}  # the strict values
    wrong = mismatch(_krl(s ^ 1, t), signs)
    assert wrong == f"S {s ^ 1} written, {s} found"


def test_bit_1_switches_where_the_arm_is_stretched_not_at_a3_zero() -> None:
    """The forearm's 0.035 m offset puts the stretched arm at A3 = −atan(0.035 / 0.67) = −2.99°: at A3 −2° the wrist
    centre is 0.67 cos(−92°) − 0.035 sin(−92°) = +0.0116 m in front of the upright lower arm (S bit 1 set), at −4°
    0.0118 m behind it."""
    assert posture_values(_krl(0, 0), _signs([0, -90, -2, 0, 30, 0]))["S"] == [2]
    assert posture_values(_krl(0, 0), _signs([0, -90, -4, 0, 30, 0]))["S"] == [0]
    assert _signs([0, -90, -2, 0, 30, 0]).front == pytest.approx(0.67 * math.cos(math.radians(-92))
                                                                 - 0.035 * math.sin(math.radians(-92)), abs=1e-9)


def test_a_value_at_an_edge_reads_either_way_and_higher_status_bits_are_kept() -> None:
    signs = _signs([0, -90, 90, 0, 0, 0])  # A5 = 0: S bit 2 and T bit 4 free; A1, A4, A6 = 0: T bits 0, 3, 5 free
    assert mismatch(_krl(2, 2), signs) is None and mismatch(_krl(6, 2 + 16 + 1 + 8 + 32), signs) is None
    assert mismatch(_krl(16 + 6, 2), signs) is None  # bit 4 of S is not the posture's: kept as written
    edits, words = posture_edits(_krl(16 + 3, 2), _signs([0, -90, 90, 0, 30, 0]))
    assert words == "S 19 → 18" and [e.text for e in edits] == ["18"]


def test_written_bit_strings_are_rewritten_as_bit_strings() -> None:
    named = NamedPosture("krl", "p.dat", {"S": (6, 0, 7), "T": (2, 8, 15)}, frozenset({"S"}))
    edits, words = posture_edits(named, _signs([0, -90, 90, 0, 45, 0]))
    assert words == "S 6 → 2" and [(e.start, e.end, e.text) for e in edits] == [(0, 7, "'B10'")]
