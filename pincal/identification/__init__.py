"""Identification: parameters, measurement models, FKM and IKM problems, solvers, identifiability.

The names below load on first use, as :mod:`pincal`'s do: importing one light module of the package
(:mod:`pincal.identification.choices`, the solver and loss names a command-line parser reads) does not import
Pinocchio or SciPy.
"""

from __future__ import annotations

from typing import TYPE_CHECKING

from pincal.lazy import lazy_names

if TYPE_CHECKING:
    from pincal.identification.choices import Loss, Solver
    from pincal.identification.combinations import Combination
    from pincal.identification.fit_options import FitOptions
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
    from pincal.identification.solver import identify, identify_chains, identify_with

#: Public name -> the module that defines it (imported on first access).
_LAZY: dict[str, str] = {
    "Loss": "pincal.identification.choices",
    "Solver": "pincal.identification.choices",
    "Combination": "pincal.identification.combinations",
    "FitOptions": "pincal.identification.fit_options",
    "Identifiability": "pincal.identification.identifiability",
    "analyse": "pincal.identification.identifiability",
    "ImplicitProblem": "pincal.identification.ikm",
    "Distance": "pincal.identification.measurements",
    "JointReading": "pincal.identification.measurements",
    "Measurement": "pincal.identification.measurements",
    "Pose": "pincal.identification.measurements",
    "Position": "pincal.identification.measurements",
    "distance": "pincal.identification.measurements",
    "joint_reading": "pincal.identification.measurements",
    "parse_key": "pincal.identification.measurements",
    "pose": "pincal.identification.measurements",
    "position": "pincal.identification.measurements",
    "NAMED_SETS": "pincal.identification.parameters",
    "Parameter": "pincal.identification.parameters",
    "ParameterKind": "pincal.identification.parameters",
    "ParameterSet": "pincal.identification.parameters",
    "candidate_parameters": "pincal.identification.parameters",
    "choose_parameters": "pincal.identification.parameters",
    "CalibrationProblem": "pincal.identification.problem",
    "Observations": "pincal.identification.problem",
    "Prediction": "pincal.identification.problem",
    "Problem": "pincal.identification.problem",
    "CalibrationResult": "pincal.identification.result",
    "identify": "pincal.identification.solver",
    "identify_chains": "pincal.identification.solver",
    "identify_with": "pincal.identification.solver",
}

__all__ = [
    "NAMED_SETS",
    "CalibrationProblem",
    "CalibrationResult",
    "Combination",
    "Distance",
    "FitOptions",
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
    "identify_with",
    "joint_reading",
    "parse_key",
    "pose",
    "position",
]


__getattr__, __dir__ = lazy_names(__name__, _LAZY)
