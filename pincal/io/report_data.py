"""The calibration report as data: the JSON a fit writes (errors before/after, identifiability, samples)."""

from __future__ import annotations

import json
import math
from pathlib import Path
from typing import Any

import numpy as np
import numpy.typing as npt

from pincal.identification.metrics import angle_error_norms, calibration_gain, error_norms, rms
from pincal.identification.parameters import ParameterSet
from pincal.identification.problem import CalibrationProblem
from pincal.identification.result import CalibrationResult
from pincal.io.files import write_text

Array = npt.NDArray[np.float64]



BEFORE_MEANS_REGISTERED = ("the nominal robot, with the measurement frame registered to the training data in "
                           "closed form (Kabsch), for fit and held-out samples alike")
BEFORE_MEANS_NOMINAL = "the nominal robot in the nominal measurement frame, for fit and held-out samples alike"
BEFORE_MEANS_PLACED = ("the nominal robot, with its cameras and targets placed to the training data in closed form "
                       "(hand-eye), for fit and held-out samples alike")
BEFORE_MEANS_UNPLACED = ("the nominal robot, with its cameras and targets at the identity (the training data did not "
                         "determine them in closed form), for fit and held-out samples alike")


def registered_base(parameters: ParameterSet) -> bool:
    """True when the measurement frame is estimated whole (all six ``base.*``), so that the starting point
    registers it in closed form (:meth:`CalibrationProblem.initial_guess`)."""
    return len(parameters.groups("base").get(("base", "base", ""), [])) == 6


def _before_means(problem: CalibrationProblem) -> str:
    """What the "before" errors are of: the starting point :meth:`CalibrationProblem.initial_guess` gave."""
    if problem.parameters.of_kind("camera", "target"):
        means = BEFORE_MEANS_PLACED if problem.placed_in_closed_form else BEFORE_MEANS_UNPLACED
        return "; ".join([means, *problem.not_in_closed_form])
    return BEFORE_MEANS_REGISTERED if registered_base(problem.parameters) else BEFORE_MEANS_NOMINAL


def report_dict(result: CalibrationResult, problem: CalibrationProblem, x_true: Array | None = None,
                shifts: dict[str, float] | None = None) -> dict[str, Any]:
    """The results JSON: errors before/after [m], identifiability, estimates with std, solver account.

    Wall-clock time is left out on purpose: the same inputs and seed give a byte-identical file.
    """
    before = error_norms(result.errors_before)
    after = error_norms(result.errors_after)
    ident = result.identifiability
    angles_before = angle_error_norms(result.errors_before)
    angles_after = angle_error_norms(result.errors_after)

    def clean(v: float) -> float | None:
        return None if not math.isfinite(v) else float(v)

    out: dict[str, Any] = {
        "robot": problem.robot.name,
        "units": "SI: m, rad",
        "n_samples": problem.observations.n_samples,
        "measurements": [m.key for m in problem.measurements],
        "readings": problem.n_readings(),
        "readings_not_seen": {m.key: problem.observations.n_samples - count for m, count
                              in zip(problem.measurements, problem.n_readings().values(), strict=True)
                              if m.occludable},
        "n_parameters": len(result.names),
        "n_identifiable": ident.rank,
        "condition_number": clean(ident.condition_number),
        "rms_before": clean(rms(before)),
        "rms_after": clean(rms(after)),
        "max_before": clean(float(before.max())) if before.size else None,
        "max_after": clean(float(after.max())) if after.size else None,
        "before_means": _before_means(problem),
        "iterations": result.iterations,
        "converged": result.converged,
        "message": result.message,
        "solver": result.solver,
        "loss": result.loss,
        "sigma2": clean(result.sigma2),
        "cost_history": [float(c) for c in result.cost_history],
        "parameters": {name: {"value": float(result.x[k]), "std": clean(float(result.std[k])),
                              "identified": k in set(result.identified)}
                       for k, name in enumerate(result.names)},
        "unidentifiable": [c.description for c in ident.unidentifiable],
        "down_weighted_samples": result.down_weighted(),
        "reference_shifts": shifts or {},
    }
    if angles_before.size:
        out.update({"rms_angle_before": clean(rms(angles_before)), "rms_angle_after": clean(rms(angles_after)),
                    "max_angle_before": clean(float(angles_before.max())),
                    "max_angle_after": clean(float(angles_after.max()))})
    if x_true is not None:
        out["calibration_gain"] = clean(calibration_gain(x_true, result.x0, result.x))
        out["parameter_errors_before"] = float(np.linalg.norm(x_true - result.x0))
        out["parameter_errors_after"] = float(np.linalg.norm(x_true - result.x))
    return out


def write_json(path: str | Path, content: dict[str, Any]) -> None:
    """Write ``content`` as indented JSON (:func:`json_text`), whole or not at all."""
    write_text(path, json_text(content))


def json_text(content: dict[str, Any]) -> str:
    """``content`` as the indented JSON text of pincal's report files."""
    return json.dumps(content, indent=2, sort_keys=False) + "\n"
