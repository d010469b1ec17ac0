"""pincal: geometric calibration of closed-loop and serial robots described in URDF, on Pinocchio."""

from pincal.errors import (
    ConvergenceError,
    DataError,
    IdentifiabilityError,
    LoopError,
    NotFoundError,
    PincalError,
    RobotFileError,
)
from pincal.library import known_robot_names, robot_path
from pincal.robot import Robot, load_robot

__version__ = "0.1.0"

__all__ = [
    "ConvergenceError",
    "DataError",
    "IdentifiabilityError",
    "LoopError",
    "NotFoundError",
    "PincalError",
    "Robot",
    "RobotFileError",
    "__version__",
    "known_robot_names",
    "load_robot",
    "robot_path",
]
