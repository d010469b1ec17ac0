"""The robot: URDF with loops, closure, kinematics, robots by name, URDF text editing."""

from __future__ import annotations

from pincal.model.catalog import known_robot_names, robot_path
from pincal.model.kinematics import ClosedLoopKinematics, SolveReport
from pincal.model.robot import Robot, Unit, joint_unit, load_robot, robot_from_urdf_text
from pincal.model.urdf import LoopSpec, read_extensions
from pincal.model.urdf_writer import calibrated_urdf_text

__all__ = [
    "ClosedLoopKinematics",
    "LoopSpec",
    "Robot",
    "SolveReport",
    "Unit",
    "calibrated_urdf_text",
    "joint_unit",
    "known_robot_names",
    "load_robot",
    "read_extensions",
    "robot_from_urdf_text",
    "robot_path",
]
