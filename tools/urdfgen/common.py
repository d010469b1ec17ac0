"""Small XML writer shared by the robot generators in ``tools/urdfgen``.

The URDF files in ``robots_urdf/`` are generated, so that every length and angle of the reference
configuration is computed to full double precision (the loader refuses a file whose loops do not
close to 1e-9 at the neutral configuration). Units are SI: metres and radians.

Floats are written with ``repr(float(x))``: numpy 2 reprs (``np.float64(0.1)``) break URDF parsers.
"""

from __future__ import annotations

import math
from collections.abc import Sequence
from dataclasses import dataclass, field

import numpy as np


def fmt(values: Sequence[float] | np.ndarray) -> str:
    """Space-separated floats at full precision, with -0.0 written as 0.0."""
    return " ".join(repr(float(v) + 0.0) for v in values)


def origin(xyz: Sequence[float] = (0.0, 0.0, 0.0), rpy: Sequence[float] = (0.0, 0.0, 0.0)) -> str:
    """An ``<origin>`` element; xyz [m], rpy [rad] (URDF fixed-axis roll, pitch, yaw)."""
    return f'<origin xyz="{fmt(xyz)}" rpy="{fmt(rpy)}"/>'


def box(size: Sequence[float], xyz: Sequence[float] = (0, 0, 0), rpy: Sequence[float] = (0, 0, 0)) -> str:
    return f'<visual>{origin(xyz, rpy)}<geometry><box size="{fmt(size)}"/></geometry></visual>'


def cylinder(radius: float, length: float, xyz: Sequence[float] = (0, 0, 0),
             rpy: Sequence[float] = (0, 0, 0)) -> str:
    """A cylinder along the local z axis of its visual origin."""
    return (f'<visual>{origin(xyz, rpy)}<geometry><cylinder radius="{fmt([radius])}" '
            f'length="{fmt([length])}"/></geometry></visual>')


def sphere(radius: float, xyz: Sequence[float] = (0, 0, 0)) -> str:
    return f'<visual>{origin(xyz)}<geometry><sphere radius="{fmt([radius])}"/></geometry></visual>'


def rod_rpy(direction: Sequence[float]) -> tuple[float, float, float]:
    """rpy [rad] of a frame whose local +z axis points along ``direction`` (for cylinder visuals)."""
    # math, not numpy: numpy's norm and arctan2 may differ in the last bit from one CPU's SIMD kernels to
    # another's, and the generated files must be the same on every machine
    x, y, z = (float(v) for v in direction)
    pitch = math.atan2(math.hypot(x, y), z)
    yaw = math.atan2(y, x)
    # R = Rz(yaw) Ry(pitch) maps z to d; URDF rpy = (roll, pitch, yaw) means Rz(yaw) Ry(pitch) Rx(roll).
    return (0.0, pitch, yaw)


@dataclass
class UrdfWriter:
    """Accumulates links, joints, loops and transmissions and renders one URDF document."""

    name: str
    comment: str
    parts: list[str] = field(default_factory=list)

    def link(self, name: str, *visuals: str, mass: float = 0.1) -> None:
        inertial = (f'<inertial><mass value="{fmt([mass])}"/>'
                    '<inertia ixx="1e-4" ixy="0" ixz="0" iyy="1e-4" iyz="0" izz="1e-4"/></inertial>')
        self.parts.append(f'  <link name="{name}">{inertial}{"".join(visuals)}</link>')

    def joint(self, name: str, kind: str, parent: str, child: str,
              xyz: Sequence[float] = (0, 0, 0), rpy: Sequence[float] = (0, 0, 0),
              axis: Sequence[float] | None = None, limits: tuple[float, float] | None = None) -> None:
        """A URDF joint; revolute/prismatic need ``axis`` and ``limits`` ([rad] or [m])."""
        body = f'<parent link="{parent}"/><child link="{child}"/>{origin(xyz, rpy)}'
        if axis is not None:
            body += f'<axis xyz="{fmt(axis)}"/>'
        if limits is not None:
            body += (f'<limit lower="{fmt([limits[0]])}" upper="{fmt([limits[1]])}" '
                     'effort="100" velocity="10"/>')
        self.parts.append(f'  <joint name="{name}" type="{kind}">{body}</joint>')

    def loop(self, name: str, kind: str, predecessor: str, pred_xyz: Sequence[float],
             successor: str, succ_xyz: Sequence[float], pred_rpy: Sequence[float] = (0, 0, 0),
             succ_rpy: Sequence[float] = (0, 0, 0), axis: Sequence[float] | None = None) -> None:
        """A pincal ``<loop>`` closure (README.md, "Loops in URDF"): anchors given in each link's frame."""
        ax = f'<axis xyz="{fmt(axis)}"/>' if axis is not None else ""
        self.parts.append(
            f'  <loop name="{name}" type="{kind}">'
            f'<predecessor link="{predecessor}">{origin(pred_xyz, pred_rpy)}</predecessor>'
            f'<successor link="{successor}">{origin(succ_xyz, succ_rpy)}</successor>{ax}</loop>')

    def transmission(self, joint: str) -> None:
        """Declares ``joint`` actuated (a ROS SimpleTransmission with reduction 1)."""
        self.parts.append(
            f'  <transmission name="{joint}_transmission">'
            '<type>transmission_interface/SimpleTransmission</type>'
            f'<joint name="{joint}"><hardwareInterface>hardware_interface/PositionJointInterface'
            '</hardwareInterface></joint>'
            f'<actuator name="{joint}_motor"><mechanicalReduction>1</mechanicalReduction></actuator>'
            '</transmission>')

    def render(self) -> str:
        body = "\n".join(self.parts)
        return (f'<?xml version="1.0"?>\n<!--\n{self.comment.strip()}\n-->\n'
                f'<robot name="{self.name}">\n{body}\n</robot>\n')

    def write(self, path: str) -> None:
        with open(path, "w", encoding="utf-8") as f:
            f.write(self.render())
