"""Small planar mechanisms written as URDF text, for tests of loop types the reference robots lack.

All assembled at the neutral configuration; lengths [m], angles [rad].
"""

from __future__ import annotations

import math

import numpy as np

JOINT = ('<joint name="{name}" type="{kind}"><parent link="{parent}"/><child link="{child}"/>'
         '<origin xyz="{x!r} {y!r} 0.0" rpy="0 0 {yaw!r}"/><axis xyz="{axis}"/>'
         '<limit lower="-10" upper="10" effort="1" velocity="1"/></joint>')


def _joint(name: str, kind: str, parent: str, child: str, x: float = 0.0, y: float = 0.0,
           yaw: float = 0.0, axis: str = "0 0 1") -> str:
    return JOINT.format(name=name, kind=kind, parent=parent, child=child, x=float(x), y=float(y),
                        yaw=float(yaw), axis=axis)


def _circle_intersection(p0: np.ndarray, r0: float, p1: np.ndarray, r1: float) -> np.ndarray:
    d = float(np.linalg.norm(p1 - p0))
    a = (r0**2 - r1**2 + d**2) / (2 * d)
    h = math.sqrt(r0**2 - a**2)
    mid = p0 + a * (p1 - p0) / d
    perp = np.array([-(p1 - p0)[1], (p1 - p0)[0]]) / d
    return mid + h * perp


#: Four-bar lengths [m]: crank a (actuated), coupler b, rocker c, ground d. Grashof with the rocker
#: shortest: the rocker turns fully, the crank only rocks, so some crank angles are unreachable.
FOUR_BAR = {"a": 0.25, "b": 0.22, "c": 0.12, "d": 0.30}
FOUR_BAR_CRANK_HOME = math.pi / 4  # crank angle at the reference configuration [rad]


def four_bar_urdf(lengths: dict[str, float] | None = None, home: float = FOUR_BAR_CRANK_HOME,
                  crank: str = "revolute") -> str:
    """Four-bar with a revolute loop between the coupler end and the rocker end.

    ``crank="continuous"`` makes the actuated crank an unbounded revolute (nq = 2 in Pinocchio).
    """
    a, b, c, d = ((lengths or FOUR_BAR)[k] for k in "abcd")
    pb = a * np.array([math.cos(home), math.sin(home)])
    pc = _circle_intersection(pb, b, np.array([d, 0.0]), c)
    coupler_yaw = math.atan2(*(pc - pb)[::-1]) - home
    rocker_yaw = math.atan2(*(pc - np.array([d, 0.0]))[::-1])
    return f"""<robot name="four_bar">
<link name="ground"/><link name="crank"/><link name="coupler"/><link name="rocker"/>
{_joint("crank_joint", crank, "ground", "crank", yaw=home)}
{_joint("coupler_joint", "revolute", "crank", "coupler", x=a, yaw=coupler_yaw)}
{_joint("rocker_joint", "revolute", "ground", "rocker", x=d, yaw=rocker_yaw)}
<loop name="coupler_rocker" type="revolute">
  <predecessor link="coupler"><origin xyz="{b!r} 0 0"/></predecessor>
  <successor link="rocker"><origin xyz="{c!r} 0 0"/></successor>
  <axis xyz="0 0 1"/>
</loop>
<transmission name="t"><joint name="crank_joint"/></transmission>
</robot>"""


def four_bar_rocker_angle(crank: float) -> float:
    """Closed form: rocker angle [rad] (world) for a crank angle, on the file's assembly branch."""
    a, b, c, d = (FOUR_BAR[k] for k in "abcd")
    pb = a * np.array([math.cos(crank), math.sin(crank)])
    pc = _circle_intersection(pb, b, np.array([d, 0.0]), c)
    return math.atan2(pc[1], pc[0] - d)


SLIDER = {"a": 0.10, "b": 0.30}  # crank, connecting rod [m]


def slider_crank_urdf() -> str:
    """Slider-crank: crank (actuated), rod, slider block; a prismatic loop keeps the block on x."""
    a, b = SLIDER["a"], SLIDER["b"]
    # reference: crank up; rod end on the x axis
    pb = np.array([0.0, a])
    pc = np.array([math.sqrt(b**2 - a**2), 0.0])
    rod_yaw = math.atan2(*(pc - pb)[::-1]) - math.pi / 2
    slider_yaw = -(math.pi / 2 + rod_yaw)  # undo the crank and rod rotations: block aligned with x
    return f"""<robot name="slider_crank">
<link name="ground"/><link name="crank"/><link name="rod"/><link name="block"/>
{_joint("crank_joint", "revolute", "ground", "crank", yaw=math.pi / 2)}
{_joint("rod_joint", "revolute", "crank", "rod", x=a, yaw=rod_yaw)}
{_joint("block_joint", "revolute", "rod", "block", x=b, yaw=slider_yaw)}
<loop name="block_on_rail" type="prismatic">
  <predecessor link="ground"><origin xyz="0 0 0"/></predecessor>
  <successor link="block"><origin xyz="0 0 0"/></successor>
  <axis xyz="1 0 0"/>
</loop>
<transmission name="t"><joint name="crank_joint"/></transmission>
</robot>"""


def slider_position(crank: float) -> float:
    """Closed form: block position on x [m] for a crank angle [rad] (block on the +x side)."""
    a, b = SLIDER["a"], SLIDER["b"]
    return a * math.cos(crank) + math.sqrt(b**2 - (a * math.sin(crank)) ** 2)


def planar_coupler_urdf() -> str:
    """The four-bar with its coupler on a planar joint (nq = 4) from the ground, closed at both ends."""
    a, b, c, d = (FOUR_BAR[k] for k in "abcd")
    home = FOUR_BAR_CRANK_HOME
    pb = a * np.array([math.cos(home), math.sin(home)])
    pc = _circle_intersection(pb, b, np.array([d, 0.0]), c)
    coupler_yaw = math.atan2(*(pc - pb)[::-1])
    rocker_yaw = math.atan2(*(pc - np.array([d, 0.0]))[::-1])
    return f"""<robot name="planar_coupler">
<link name="ground"/><link name="crank"/><link name="coupler"/><link name="rocker"/>
{_joint("crank_joint", "revolute", "ground", "crank", yaw=home)}
{_joint("coupler_planar", "planar", "ground", "coupler", x=pb[0], y=pb[1], yaw=coupler_yaw)}
{_joint("rocker_joint", "revolute", "ground", "rocker", x=d, yaw=rocker_yaw)}
<loop name="crank_coupler" type="revolute">
  <predecessor link="crank"><origin xyz="{a!r} 0 0"/></predecessor>
  <successor link="coupler"><origin xyz="0 0 0"/></successor><axis xyz="0 0 1"/>
</loop>
<loop name="coupler_rocker" type="revolute">
  <predecessor link="coupler"><origin xyz="{b!r} 0 0"/></predecessor>
  <successor link="rocker"><origin xyz="{c!r} 0 0"/></successor><axis xyz="0 0 1"/>
</loop>
<transmission name="t"><joint name="crank_joint"/></transmission>
</robot>"""


#: Crank-rocker lengths [m]: crank a (actuated, shortest: it turns a full circle), coupler b, rocker c,
#: ground d (Grashof: a + b <= c + d).
CRANK_ROCKER = {"a": 0.10, "b": 0.35, "c": 0.25, "d": 0.30}


def crank_rocker_urdf(crank_limits: tuple[float, float] = (-math.pi, math.pi)) -> str:
    """A four-bar as one chain, ground -> crank -> coupler -> rocker, cut at the rocker's ground pivot.

    No frame is named like an end effector, and the file's last link, ``stand``, is fixed to the ground:
    the rocker is the one moving link with no moving link below it. The crank is at angle 0 at the
    reference; ``crank_limits`` [rad] are its URDF limits (the passive joints have none to speak of).
    """
    a, b, c, d = (CRANK_ROCKER[k] for k in "abcd")
    pb = np.array([a, 0.0])
    pc = _circle_intersection(pb, b, np.array([d, 0.0]), c)
    coupler_yaw = math.atan2(*(pc - pb)[::-1])
    rocker_yaw = math.atan2(*(np.array([d, 0.0]) - pc)[::-1])
    crank = JOINT.replace('lower="-10" upper="10"', f'lower="{float(crank_limits[0])!r}" '
                                                     f'upper="{float(crank_limits[1])!r}"')
    return f"""<robot name="crank_rocker">
<link name="ground"/><link name="crank"/><link name="coupler"/><link name="rocker"/><link name="stand"/>
{crank.format(name="crank_joint", kind="revolute", parent="ground", child="crank", x=0.0, y=0.0, yaw=0.0,
              axis="0 0 1")}
{_joint("coupler_joint", "revolute", "crank", "coupler", x=a, yaw=coupler_yaw)}
{_joint("rocker_joint", "revolute", "coupler", "rocker", x=b, yaw=rocker_yaw - coupler_yaw)}
<joint name="stand_joint" type="fixed"><parent link="ground"/><child link="stand"/>
  <origin xyz="0.15 -0.05 0" rpy="0 0 0"/></joint>
<loop name="rocker_ground" type="revolute">
  <predecessor link="rocker"><origin xyz="{c!r} 0 0"/></predecessor>
  <successor link="ground"><origin xyz="{d!r} 0 0"/></successor>
  <axis xyz="0 0 1"/>
</loop>
<transmission name="crank_motor"><joint name="crank_joint"/></transmission>
</robot>"""
