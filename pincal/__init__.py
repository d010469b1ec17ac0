"""pincal: geometric calibration of closed-loop and serial robots described in URDF, on Pinocchio.

The names below load on first use, so that ``import pincal`` (and the ``pincal`` command's start,
which an early Ctrl-C may interrupt) does not import Pinocchio until it is needed. The console script imports this
module before :mod:`pincal.__main__` can take over Ctrl-C: it imports no module the interpreter has not already
loaded (not even ``typing``), so that the window in which an interrupt would still print Python's traceback is as
short as the interpreter allows.
"""

from __future__ import annotations

from pincal.errors import (
    ArgumentError,
    ConvergenceError,
    DataError,
    IdentifiabilityError,
    LoopError,
    NotFoundError,
    OutputError,
    PincalError,
    RobotFileError,
)
from pincal.lazy import lazy_names

TYPE_CHECKING = False  # typing.TYPE_CHECKING without importing typing (mypy reads it as typing's)

if TYPE_CHECKING:
    from pincal.calibration import (
        Calibration,
        CalibrationOptions,
        CalibrationReport,
        Simulation,
        calibrate,
        read_robot_dataset,
        simulate,
    )
    from pincal.identification import (
        CalibrationProblem,
        CalibrationResult,
        Distance,
        Identifiability,
        ImplicitProblem,
        JointReading,
        Observations,
        Parameter,
        ParameterSet,
        Pose,
        Position,
        analyse,
        choose_parameters,
        distance,
        identify,
        joint_reading,
        pose,
        position,
    )
    from pincal.io import Dataset, read_dataset, write_dataset
    from pincal.model import Robot, known_robot_names, load_robot, robot_path

__version__ = "0.2.0"

#: Public name -> the module that defines it (imported on first access).
_LAZY: dict[str, str] = {
    "Robot": "pincal.model",
    "load_robot": "pincal.model",
    "known_robot_names": "pincal.model",
    "robot_path": "pincal.model",
    "Dataset": "pincal.io",
    "read_dataset": "pincal.io",
    "write_dataset": "pincal.io",
    "Position": "pincal.identification",
    "Pose": "pincal.identification",
    "Distance": "pincal.identification",
    "JointReading": "pincal.identification",
    "position": "pincal.identification",
    "pose": "pincal.identification",
    "distance": "pincal.identification",
    "joint_reading": "pincal.identification",
    "Parameter": "pincal.identification",
    "ParameterSet": "pincal.identification",
    "choose_parameters": "pincal.identification",
    "CalibrationProblem": "pincal.identification",
    "Observations": "pincal.identification",
    "ImplicitProblem": "pincal.identification",
    "identify": "pincal.identification",
    "CalibrationResult": "pincal.identification",
    "analyse": "pincal.identification",
    "Identifiability": "pincal.identification",
    "calibrate": "pincal.calibration",
    "simulate": "pincal.calibration",
    "Calibration": "pincal.calibration",
    "Simulation": "pincal.calibration",
    "read_robot_dataset": "pincal.calibration",
    "CalibrationOptions": "pincal.calibration",
    "CalibrationReport": "pincal.calibration",
}

__all__ = [
    "ArgumentError",
    "Calibration",
    "CalibrationOptions",
    "CalibrationProblem",
    "CalibrationReport",
    "CalibrationResult",
    "ConvergenceError",
    "DataError",
    "Dataset",
    "Distance",
    "Identifiability",
    "IdentifiabilityError",
    "ImplicitProblem",
    "JointReading",
    "LoopError",
    "NotFoundError",
    "Observations",
    "OutputError",
    "Parameter",
    "ParameterSet",
    "PincalError",
    "Pose",
    "Position",
    "Robot",
    "RobotFileError",
    "Simulation",
    "__version__",
    "analyse",
    "calibrate",
    "choose_parameters",
    "distance",
    "identify",
    "joint_reading",
    "known_robot_names",
    "load_robot",
    "pose",
    "position",
    "read_dataset",
    "read_robot_dataset",
    "robot_path",
    "simulate",
    "write_dataset",
]


__getattr__, __dir__ = lazy_names(__name__, _LAZY)
