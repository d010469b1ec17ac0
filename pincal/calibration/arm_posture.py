"""The posture of a six-axis arm as a robot program names it (``pincal filter``, docs/filter.md, "Posture"): KUKA's
status and turn (``S``, ``T``) and ABB's ``confdata`` (``cf1, cf4, cf6, cfx``), computed from a robot's geometry at
joint values. SI units: m, rad.

The vendors define them on the arm's geometry (KUKA's KSS programming manual, "Status" and "Turn"; ABB's RAPID
reference manual, ``confdata``):

- the **wrist centre**: where axes 4, 5 and 6 meet (here: the point of axis 4 nearest axis 5);
- **in front of axis 1** (KUKA's basic area, S bit 0 clear; ABB ``cfx`` bit 2 clear): the wrist centre's x in the A1
  coordinate system (the base frame turned with axis 1) is positive; else overhead, behind axis 1;
- **in front of the lower arm** (KUKA S bit 1 set: A3 at or above the angle at which the arm is stretched; ABB ``cfx``
  bit 1 clear): the wrist centre lies on the front side of the line from axis 2 to axis 3, the side the arm reaches
  forward to when the lower arm stands upright;
- **axis 5**: KUKA S bit 2 set when A5 ≤ 0, ABB ``cfx`` bit 0 set when axis 5 is negative; KUKA's turn bit k set
  when axis k + 1 is negative; ABB's ``cf1, cf4, cf6`` the quarter turn ``floor(angle / 90°)`` of axes 1, 4 and 6.

Joint values are the URDF's (the programs' values are taken as the URDF's, docs/filter.md). A quantity within
:data:`SLACK` of its edge counts as of either side: round-off decides nothing.
"""

from __future__ import annotations

import itertools
import math

import numpy as np
import numpy.typing as npt
import pinocchio as pin

from pincal.io.programs import Edit, NamedPosture
from pincal.model.joint_motion import joint_motion
from pincal.model.robot import Robot
from pincal.records import record

Array = npt.NDArray[np.float64]

#: A distance [m] or angle [rad] this close to an edge counts as on either side.
SLACK = 1e-6
#: Largest distance [m] between axes 4 and 5 of an arm whose wrist centre is where they meet.
WRIST_GAP = 1e-3


@record(frozen=True)
class ArmSigns:
    """What the postures are read from, at one configuration.

    Attributes:
        axes: The actuated joints' values [rad].
        ahead: The wrist centre's x [m] in the A1 coordinate system (negative: overhead, behind axis 1); NaN when the
            arm has no wrist centre (axes 4 and 5 do not meet) or fewer than five joints.
        front: The wrist centre's distance [m] from the line of the lower arm (axis 2 to axis 3), positive on its
            front side; NaN as ``ahead``.
    """

    axes: Array
    ahead: float
    front: float


def _axis(model: pin.Model, data: pin.Data, joint: int) -> tuple[Array, Array] | None:
    """A revolute joint's axis in the world: a point on it [m] and its unit direction; None for another joint."""
    motion = joint_motion(model, joint)
    if motion is None or not motion.revolute:
        return None
    placement = data.oMi[joint] * motion.start
    omega = motion.twist[3:] / motion.rate
    point = np.cross(omega, motion.twist[:3] / motion.rate)  # the axis of the twist (v, ω) passes there
    return placement.act(point), placement.rotation @ omega


def arm_signs(robot: Robot, q: Array, raw: Array, base_frame: str) -> ArmSigns:
    """The postures' quantities of ``robot`` at configuration ``q`` (its actuated values ``raw`` [rad]), the A1
    coordinate system turning ``base_frame`` (the robot's base, KUKA's ``$ROBROOT``) with axis 1."""
    missing = ArmSigns(np.asarray(raw, dtype=float), math.nan, math.nan)
    if robot.n_actuated < 5:
        return missing
    model, data = robot.model, robot.kinematics.data
    ids = [robot.joint_id(name) for name in robot.actuated_joints[:5]]
    base = robot.placement(q, base_frame)  # (Pinocchio's data now hold q's placements)
    axes = [_axis(model, data, j) for j in ids]
    if any(a is None for a in axes):
        return missing
    (_, n1), (p2, n2), (p3, _), (p4, n4), (p5, n5) = (a for a in axes if a is not None)
    cross = np.cross(n4, n5)
    if float(np.linalg.norm(cross)) < 1e-9:
        return missing
    # the point of axis 4 nearest axis 5; their distance tells whether they meet
    gap = float(abs((p5 - p4) @ cross) / np.linalg.norm(cross))
    if gap > WRIST_GAP:
        return missing
    along = float(np.cross(p5 - p4, n5) @ cross / (cross @ cross))
    wrist = p4 + along * n4
    pin.forwardKinematics(model, data, pin.neutral(model))
    turned = data.oMi[ids[0]].rotation.copy()
    pin.forwardKinematics(model, data, q)
    forward = data.oMi[ids[0]].rotation @ turned.T @ base.rotation[:, 0]  # the base's x turned with axis 1
    forward -= (forward @ n1) * n1
    ahead = float((wrist - base.translation) @ forward / np.linalg.norm(forward))
    up = base.rotation[:, 2]
    lower = p3 - p2
    normal = np.cross(n2, lower)
    side = 1.0 if float(np.cross(n2, up) @ forward) >= 0 else -1.0  # the front side when the lower arm stands up
    front = float(side * (wrist - p2) @ normal / np.linalg.norm(normal))
    return ArmSigns(np.asarray(raw, dtype=float), ahead, front)


def _bits(flags: list[tuple[int, bool, bool]]) -> list[int]:
    """Every value of the bits ``(bit, set, free)``: a free bit (within the slack) either way; the strict value
    first."""
    strict = sum(1 << bit for bit, on, _ in flags if on)
    free = [bit for bit, _, loose in flags if loose]
    values = [strict]
    for chosen in itertools.product((0, 1), repeat=len(free)):
        value = strict
        for bit, on in zip(free, chosen, strict=True):
            value = value | (1 << bit) if on else value & ~(1 << bit)
        if value not in values:
            values.append(value)
    return values


def _quadrants(angle: float) -> list[int]:
    exact = math.floor(angle / (math.pi / 2))
    return [exact, *sorted({math.floor((angle + d) / (math.pi / 2)) for d in (-SLACK, SLACK)} - {exact})]


def posture_values(named: NamedPosture, signs: ArmSigns) -> dict[str, list[int]]:
    """The values of each field ``named`` writes that the posture ``signs`` has, the strict one first (a field the
    geometry cannot give, such as S's bits 0 and 1 on an arm without a wrist centre, keeps the written bits)."""
    q = signs.axes
    out: dict[str, list[int]] = {}
    for name, (written, _, _) in named.fields.items():
        if named.language == "krl" and name == "T":
            out[name] = _bits([(k, float(v) < 0, abs(float(v)) <= SLACK) for k, v in enumerate(q[:6])])
        elif named.language == "krl" and name == "S" and len(q) >= 5:
            flags = [(2, float(q[4]) <= 0, abs(float(q[4])) <= SLACK)]
            for bit, value, on in ((0, signs.ahead, signs.ahead < 0), (1, signs.front, signs.front >= 0)):
                flags.append((bit, bool(written >> bit & 1) if math.isnan(value) else on,
                              not math.isnan(value) and abs(value) <= SLACK))
            out[name] = [(written & ~7) | v for v in _bits(flags)]
        elif named.language == "rapid" and name in ("cf1", "cf4", "cf6") and len(q) >= 6:
            out[name] = _quadrants(float(q[{"cf1": 0, "cf4": 3, "cf6": 5}[name]]))
        elif named.language == "rapid" and name == "cfx" and len(q) >= 5:
            flags = [(0, float(q[4]) < 0, abs(float(q[4])) <= SLACK)]
            for bit, value, on in ((2, signs.ahead, signs.ahead < 0), (1, signs.front, signs.front < 0)):
                flags.append((bit, bool(written >> bit & 1) if math.isnan(value) else on,
                              not math.isnan(value) and abs(value) <= SLACK))
            out[name] = _bits(flags)
    return out


def mismatch(named: NamedPosture, signs: ArmSigns) -> str | None:
    """Why the posture ``signs`` is not the one ``named`` writes (``S 2 asks … (S 6 found)``), None when it is."""
    found = posture_values(named, signs)
    wrong = [(name, named.fields[name][0], values[0]) for name, values in found.items()
             if named.fields[name][0] not in values]
    if not wrong:
        return None
    return "; ".join(f"{name} {written} written, {got} found" for name, written, got in wrong)


def posture_edits(named: NamedPosture, signs: ArmSigns) -> tuple[list[Edit], str | None]:
    """The edits writing the posture ``signs`` in place of the fields of ``named`` it changes (each the value of the
    posture nearest the one written), and what changed in words (None: nothing)."""
    edits: list[Edit] = []
    words = []
    for name, values in posture_values(named, signs).items():
        written, start, end = named.fields[name]
        if written in values:
            continue
        # the value nearest the one written: its bits (or quarter turn) kept where the posture leaves them free
        new = min(values, key=lambda v: (abs(v - written) if name.startswith("cf") and name != "cfx" else
                                         bin(v ^ written).count("1"), values.index(v)))
        text = f"'B{new:b}'" if name in named.binary else str(new)
        edits.append(Edit(named.file, start, end, text))
        words.append(f"{name} {written} → {new}")
    return edits, ", ".join(words) or None
