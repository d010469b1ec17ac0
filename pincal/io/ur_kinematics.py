"""A Universal Robots arm's calibration as the ``kinematics:`` YAML ur_description reads and ur_calibration writes
(``pincal export --format ur``; docs/calibrated_urdf.md, "Exports"). SI units: m, rad.

ur_description builds the arm from ``base_link_inertia`` (the controller's base, ``base`` in pincal's UR files) as six
revolute joints about their frames' z, each joint's ``<origin>`` the entry of its key: ``shoulder``
(``shoulder_pan_joint``), ``upper_arm``, ``forearm``, ``wrist_1``, ``wrist_2``, ``wrist_3``, each ``x, y, z, roll,
pitch, yaw``; then fixed ``flange`` and ``tool0`` frames (:data:`TOOL0_FROM_WRIST_3`). Nominally the entries are UR's DH
layout (:func:`nominal_entries`: ``d1, a2, a3, d4, d5, d6``).

A URDF of other link frames (example-robot-data's) is mapped onto ur_description's: the nominal robot's layout
parameters are found by least squares from its forward kinematics (positions are linear in them), each link's
ur_description frame fixed to the link by the constant ``C_i`` between the two frames on the nominal robot, and the
calibrated entries are those frames, on the calibrated links, relative to each other. The calibrated ``tool0`` (where a
calibration moved the tool frame on the last link) is not a joint's: it is returned as the TCP to set on the
controller, relative to ur_description's ``tool0``.
"""

from __future__ import annotations

import itertools
import math

import numpy as np
import numpy.typing as npt
import pinocchio as pin

from pincal.errors import RobotFileError, listing
from pincal.model.robot import Robot
from pincal.records import record

Array = npt.NDArray[np.float64]

#: The UR joints, from the base, and ur_description's keys of their origins.
JOINTS = ("shoulder_pan_joint", "shoulder_lift_joint", "elbow_joint", "wrist_1_joint", "wrist_2_joint",
          "wrist_3_joint")
KEYS = ("shoulder", "upper_arm", "forearm", "wrist_1", "wrist_2", "wrist_3")
#: ur_description's ``wrist_3_link`` → ``flange`` (rpy 0, −π/2, −π/2) → ``tool0`` (rpy π/2, 0, π/2).
TOOL0_FROM_WRIST_3 = (pin.SE3(pin.rpy.rpyToMatrix(0.0, -math.pi / 2, -math.pi / 2), np.zeros(3))
                      * pin.SE3(pin.rpy.rpyToMatrix(math.pi / 2, 0.0, math.pi / 2), np.zeros(3)))
#: Largest gap [m, rad] of the nominal robot's forward kinematics from UR's layout, for it to be a UR
#: (example-robot-data writes pi/2 as 1.570796325: 2e-9 rad).
LAYOUT_TOLERANCE = 1e-6
#: A calibrated tool frame farther than this [m, rad] from ur_description's tool0 is named in the header, with its TCP.
TCP_NOTE = 1e-6


def _t(x: float, y: float, z: float) -> pin.SE3:
    return pin.SE3(np.eye(3), np.array([x, y, z]))


def _rpy(roll: float, pitch: float, yaw: float) -> pin.SE3:
    return pin.SE3(pin.rpy.rpyToMatrix(roll, pitch, yaw), np.zeros(3))


def _rz(angle: float) -> pin.SE3:
    return pin.SE3(pin.rpy.rpyToMatrix(0.0, 0.0, angle), np.zeros(3))


def nominal_entries(d1: float, a2: float, a3: float, d4: float, d5: float, d6: float) -> list[pin.SE3]:
    """ur_description's six joint origins for UR's DH parameters [m] (its ``default_kinematics.yaml``)."""
    return [_t(0, 0, d1), _rpy(math.pi / 2, 0, 0), _t(a2, 0, 0), _t(a3, 0, d4),
            _t(0, -d5, 0) * _rpy(math.pi / 2, 0, 0), _t(0, d6, 0) * _rpy(math.pi / 2, math.pi, math.pi)]


def compose(entries: list[pin.SE3], q: Array) -> list[pin.SE3]:
    """The six link frames and ``tool0`` in ``base_link_inertia`` at joint values ``q`` [rad], as ur_description's
    chain puts them: ``origin_i · Rz(q_i)``, then :data:`TOOL0_FROM_WRIST_3`."""
    out, frame = [], pin.SE3.Identity()
    for entry, value in zip(entries, q, strict=True):
        frame = frame * entry * _rz(float(value))
        out.append(frame)
    return [*out, frame * TOOL0_FROM_WRIST_3]


def _layout(robot: Robot, base: str, tool: str, joints: list[int]) -> Array:
    """UR's ``d1, a2, a3, d4, d5, d6`` [m] of ``robot``, by least squares on its ``tool`` position at postures.

    Raises:
        RobotFileError: its forward kinematics is not UR's layout.
    """
    rng = np.random.default_rng(0)
    rows, rhs, postures = [], [], rng.uniform(-math.pi, math.pi, size=(12, 6))
    ex, ey, ez = np.eye(3)
    for q in postures:
        frames = compose(nominal_entries(0, 0, 0, 0, 0, 0), q)
        r2, r3, r4, r5 = (f.rotation for f in frames[1:5])
        rows.append(np.column_stack([ez, r2 @ ex, r3 @ ex, r3 @ ez, -(r4 @ ey), r5 @ ey]))
        rhs.append(_in_base(robot, base, tool, joints, q).translation)
    params = np.linalg.lstsq(np.vstack(rows), np.concatenate(rhs), rcond=None)[0]
    for q in postures:
        gap = compose(nominal_entries(*params), q)[-1].inverse() * _in_base(robot, base, tool, joints, q)
        if max(np.linalg.norm(gap.translation), np.linalg.norm(pin.log3(gap.rotation))) > LAYOUT_TOLERANCE:
            raise RobotFileError(f"the nominal robot '{robot.name}' is not of UR's layout from '{base}' to '{tool}' "
                                 f"(its {tool} is {np.linalg.norm(gap.translation):.3g} m from it): no ur_description "
                                 "kinematics")
    return np.asarray(params, dtype=float)


def _configuration(robot: Robot, joints: list[int], q: Array) -> Array:
    config = pin.neutral(robot.model)
    for j, value in zip(joints, q, strict=True):
        config[robot.model.joints[j].idx_q] = value
    return np.asarray(config, dtype=float)


def _in_base(robot: Robot, base: str, frame: str, joints: list[int], q: Array) -> pin.SE3:
    config = _configuration(robot, joints, q)
    return robot.placement(config, base).inverse() * robot.placement(config, frame)


def _joint_ids(robot: Robot) -> list[int]:
    missing = [name for name in JOINTS if not robot.model.existJointName(name)]
    if missing or robot.is_closed_loop:
        raise RobotFileError(f"robot '{robot.name}' is not a Universal Robots arm: it lacks {listing(missing)}"
                             if missing else f"robot '{robot.name}' has closed loops: not a Universal Robots arm")
    ids = [robot.model.getJointId(name) for name in JOINTS]
    if any(robot.model.joints[j].nq != 1 for j in ids):
        raise RobotFileError(f"robot '{robot.name}': a UR joint of more than one coordinate (continuous?): pincal "
                             "maps revolute joints only")
    return ids


@record(frozen=True)
class URKinematics:
    """A calibrated UR's ur_description kinematics.

    Attributes:
        entries: The six joint origins, ``shoulder`` … ``wrist_3``, in their parent link frames.
        tcp: Where the calibrated ``tool0`` sits in ur_description's ``tool0`` (identity when the calibration left the
            tool frame as it was).
        layout: The nominal robot's ``d1, a2, a3, d4, d5, d6`` [m].
        base: The base frame (``base``: the controller's, ur_description's ``base_link_inertia``).
        tool: The tool frame (``tool0``).
    """

    entries: list[pin.SE3]
    tcp: pin.SE3
    layout: Array
    base: str
    tool: str

    def chain(self, q: Array) -> list[pin.SE3]:
        """The link frames and ``tool0`` (the TCP applied) in the base frame at joint values ``q`` [rad]."""
        frames = compose(self.entries, q)
        return [*frames[:-1], frames[-1] * self.tcp]


def ur_kinematics(robot: Robot, nominal: Robot, base: str = "base", tool: str = "tool0") -> URKinematics:
    """``robot``'s (a calibrated UR's) ur_description kinematics (module docstring), mapped through ``nominal``.

    Raises:
        RobotFileError: not a UR arm, or ``nominal`` not of UR's layout. NotFoundError: a frame either lacks.
    """
    ids, nominal_ids = _joint_ids(robot), _joint_ids(nominal)
    for r in (robot, nominal):
        r.frame_id(base, "format='ur': ")
        r.frame_id(tool, "format='ur': ")
    layout = _layout(nominal, base, tool, nominal_ids)
    zero = np.zeros(6)
    ur_frames = compose(nominal_entries(*layout), zero)
    q_nominal, q_robot = _configuration(nominal, nominal_ids, zero), _configuration(robot, ids, zero)
    nominal_data, data = nominal.model.createData(), robot.model.createData()
    pin.forwardKinematics(nominal.model, nominal_data, q_nominal)
    pin.forwardKinematics(robot.model, data, q_robot)
    nominal_base, base_placement = nominal.placement(q_nominal, base), robot.placement(q_robot, base)
    frames = []
    for k, (j_nominal, j) in enumerate(zip(nominal_ids, ids, strict=True)):
        constant = (nominal_base.inverse() * nominal_data.oMi[j_nominal]).inverse() * ur_frames[k]
        frames.append(base_placement.inverse() * data.oMi[j] * constant)
    entries = [frames[0], *(a.inverse() * b for a, b in itertools.pairwise(frames))]
    tcp = (frames[-1] * TOOL0_FROM_WRIST_3).inverse() * (base_placement.inverse() * robot.placement(q_robot, tool))
    return URKinematics(entries, tcp, layout, base, tool)


def _num(value: float) -> str:
    text = repr(float(value))
    return text if ("." in text or "e" in text or "n" in text) else text + ".0"


def ur_kinematics_yaml(kinematics: URKinematics, source: str, digest: str) -> str:
    """The ``kinematics:`` YAML (ur_description's ``default_kinematics.yaml`` layout) with a header saying what it
    is; ``hash`` is ``pincal_`` and the first 16 hex digits of ``digest`` (the calibrated URDF's SHA-256)."""
    lines = [f"# pincal export: ur_description kinematics of {source}",
             "# each joint's origin in its parent link's frame, as ur_description composes it: x, y, z [m], roll, "
             "pitch, yaw [rad] (R = Rz(yaw) Ry(pitch) Rx(roll)); the joints turn about their frames' z",
             f"# nominal layout d1, a2, a3, d4, d5, d6 = {', '.join(f'{v:.6g}' for v in kinematics.layout)} m; base "
             f"'{kinematics.base}' (ur_description's base_link_inertia), tool '{kinematics.tool}'",
             "# ROS 2: ros2 launch ur_robot_driver ur_control.launch.py ur_type:=<type> robot_ip:=<ip> "
             "kinematics_params_file:=<this file>",
             "# hash: not the controller's calibration checksum (the driver warns that they differ)"]
    distance = float(np.linalg.norm(kinematics.tcp.translation))
    angle = float(np.linalg.norm(pin.log3(kinematics.tcp.rotation)))
    if max(distance, angle) > TCP_NOTE:
        values = [*kinematics.tcp.translation, *pin.log3(kinematics.tcp.rotation)]
        lines.append(f"# the calibrated tool0 is {distance * 1e3:.4f} mm, {angle * 1e3:.4f} mrad from ur_description's "
                     "tool0 (a joint origin cannot hold it): set it as the TCP, p[" +
                     ", ".join(f"{v:.9f}" for v in values) + "]")
    lines.append("kinematics:")
    for key, entry in zip(KEYS, kinematics.entries, strict=True):
        rpy = pin.rpy.matrixToRpy(entry.rotation)
        lines.append(f"  {key}:")
        lines += [f"    {name}: {_num(v)}" for name, v in zip(("x", "y", "z", "roll", "pitch", "yaw"),
                                                              (*entry.translation, *rpy), strict=True)]
    lines.append(f"  hash: pincal_{digest[:16]}")
    return "\n".join(lines) + "\n"
