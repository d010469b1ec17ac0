"""A closed-loop URDF of many independent four-bars on one base: the README's four-bar repeated ``loops`` times,
each one a plane of its own (0.1 m apart along z), each with its own actuated crank and its own ``<loop>``.

No two loops share a joint, so the closure Jacobian is block diagonal: what a robot of many loops costs should grow
with the loops, not with their square. Lengths [m]: crank 0.1, coupler 0.25, rocker 0.2, ground 0.3; angles [rad].
"""

from __future__ import annotations

import math

import numpy as np

#: The README's lengths [m]: crank, coupler, rocker, ground.
CRANK, COUPLER, ROCKER, GROUND = 0.1, 0.25, 0.2, 0.3
#: The passive joints' angles as a draft draws them [rad] (the README's: the loops do not close there).
DRAFT_ANGLES = (0.35, 1.9)


def closed_angles() -> tuple[float, float]:
    """The coupler's and the rocker's directions [rad] that close a loop with the crank along +y (two circles
    intersected: the solution above the ground line)."""
    b, d = np.array([0.0, CRANK]), np.array([GROUND, 0.0])
    distance = float(np.linalg.norm(d - b))
    along = (COUPLER ** 2 - ROCKER ** 2 + distance ** 2) / (2 * distance)
    unit = (d - b) / distance
    c = b + along * unit + math.sqrt(COUPLER ** 2 - along ** 2) * np.array([-unit[1], unit[0]])
    return math.atan2(*(c - b)[::-1]), math.atan2(*(c - d)[::-1])


def four_bar(k: int, coupler_yaw: float, rocker_yaw: float) -> str:
    """The links, joints, loop and transmission of the ``k``-th four-bar, in the plane ``z = 0.1 k`` [m]."""
    z = repr(0.1 * k)
    return f"""
  <link name="crank_{k}"/><link name="coupler_{k}"/><link name="rocker_{k}"/>
  <joint name="crank_joint_{k}" type="revolute">
    <parent link="base"/><child link="crank_{k}"/>
    <origin xyz="0 0 {z}" rpy="0 0 0"/><axis xyz="0 0 1"/>
    <limit lower="-0.5" upper="0.5" effort="10" velocity="1"/>
  </joint>
  <joint name="coupler_joint_{k}" type="continuous">
    <parent link="crank_{k}"/><child link="coupler_{k}"/>
    <origin xyz="0 {CRANK!r} 0" rpy="0 0 {coupler_yaw!r}"/><axis xyz="0 0 1"/>
  </joint>
  <joint name="rocker_joint_{k}" type="continuous">
    <parent link="base"/><child link="rocker_{k}"/>
    <origin xyz="{GROUND!r} 0 {z}" rpy="0 0 {rocker_yaw!r}"/><axis xyz="0 0 1"/>
  </joint>
  <loop name="coupler_rocker_{k}" type="revolute">
    <predecessor link="coupler_{k}"><origin xyz="{COUPLER!r} 0 0" rpy="0 0 0"/></predecessor>
    <successor link="rocker_{k}"><origin xyz="{ROCKER!r} 0 0" rpy="0 0 0"/></successor>
    <axis xyz="0 0 1"/>
  </loop>
  <transmission name="crank_transmission_{k}">
    <type>transmission_interface/SimpleTransmission</type>
    <joint name="crank_joint_{k}"><hardwareInterface>hardware_interface/PositionJointInterface</hardwareInterface>
    </joint>
    <actuator name="crank_motor_{k}"><mechanicalReduction>1</mechanicalReduction></actuator>
  </transmission>"""


def many_four_bars_urdf(loops: int, assembled: bool = True) -> str:
    """``loops`` independent four-bars on one base (module docstring), 3 joints each; an ``end_effector`` frame on
    the first coupler's middle. ``assembled``: the passive joints' origins at the angles that close every loop
    (``pincal info`` loads it); otherwise at the README draft's (``pincal assemble`` closes them)."""
    coupler, rocker = closed_angles() if assembled else DRAFT_ANGLES
    bars = "".join(four_bar(k, coupler, rocker) for k in range(loops))
    return f"""<?xml version="1.0"?>
<robot name="four_bars_{loops}">
  <link name="base"/>
  <link name="end_effector"/>{bars}
  <joint name="end_effector_joint" type="fixed">
    <parent link="coupler_0"/><child link="end_effector"/>
    <origin xyz="0.125 0.05 0" rpy="0 0 0"/>
  </joint>
</robot>
"""
