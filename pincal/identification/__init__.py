"""Identification: parameters, measurement models, FKM and IKM problems, solvers, identifiability."""

from __future__ import annotations

from pincal.identification.choices import Loss, Solver
from pincal.identification.combinations import Combination
from pincal.identification.identifiability import Identifiability, analyse
from pincal.identification.ikm import ImplicitProblem
from pincal.identification.measurements import (
    Distance,
    JointReading,
    Measurement,
    Pose,
    Position,
    distance,
    joint_reading,
    parse_key,
    pose,
    position,
)
from pincal.identification.parameters import (
    NAMED_SETS,
    Parameter,
    ParameterKind,
    ParameterSet,
    candidate_parameters,
    choose_parameters,
)
from pincal.identification.problem import CalibrationProblem, Observations, Prediction, Problem
from pincal.identification.result import CalibrationResult
from pincal.identification.solver import identify, identify_chains

__all__ = [
    "NAMED_SETS",
    "CalibrationProblem",
    "CalibrationResult",
    "Combination",
    "Distance",
    "Identifiability",
    "ImplicitProblem",
    "JointReading",
    "Loss",
    "Measurement",
    "Observations",
    "Parameter",
    "ParameterKind",
    "ParameterSet",
    "Pose",
    "Position",
    "Prediction",
    "Problem",
    "Solver",
    "analyse",
    "candidate_parameters",
    "choose_parameters",
    "distance",
    "identify",
    "identify_chains",
    "joint_reading",
    "parse_key",
    "pose",
    "position",
]
