"""pincal: geometric calibration of closed-loop and serial robots described in URDF, on Pinocchio.

The names below load on first use, so that ``import pincal`` (and the ``pincal`` command's start,
which an early Ctrl-C may interrupt) does not import Pinocchio until it is needed.
"""

from __future__ import annotations

import importlib
from typing import TYPE_CHECKING, Any

from pincal.errors import (
    ConvergenceError,
    DataError,
    IdentifiabilityError,
    LoopError,
    NotFoundError,
    PincalError,
    RobotFileError,
)

if TYPE_CHECKING:
    from pincal.model.catalog import known_robot_names, robot_path
    from pincal.model.robot import Robot, load_robot

__version__ = "0.1.0"

#: Public name -> the module that defines it (imported on first access).
_LAZY: dict[str, str] = {
    "known_robot_names": "pincal.model.catalog",
    "robot_path": "pincal.model.catalog",
    "Robot": "pincal.model.robot",
    "load_robot": "pincal.model.robot",
}

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


def __getattr__(name: str) -> Any:
    module = _LAZY.get(name)
    if module is None:
        raise AttributeError(f"module 'pincal' has no attribute '{name}'")
    value = getattr(importlib.import_module(module), name)
    globals()[name] = value
    return value


def __dir__() -> list[str]:
    return sorted(set(globals()) | set(__all__))
