"""The calibration pipeline a user runs: prepare, fit (with model selection), evaluate on held-out samples, report.

:func:`calibrate` is the whole of it::

    fit = prepare(robot, dataset, options)                  # models, parameters, usable samples, problem
    result = identify / select_and_fit(fit.problem, ...)    # Levenberg–Marquardt on analytic Jacobians
    held = evaluate_held_out(fit, dataset, ...)             # "before" = the fit's start, "after" = the estimate
    report = CalibrationReport(...)                         # every figure, once

SI units throughout: m, rad.
"""

from __future__ import annotations

from dataclasses import dataclass
from typing import Any

import numpy as np
import numpy.typing as npt

from pincal.calibration.crossval import check_cross_validation, cross_validate, parse_cv
from pincal.calibration.heldout import NOISE_CONTRADICTED, HeldOut, evaluate_held_out
from pincal.calibration.options import CalibrationOptions, check_cv_seed
from pincal.calibration.report import CalibrationReport, fit_figures
from pincal.calibration.samples import check_length_scale
from pincal.calibration.setup import Prepared, check_movable, prepare
from pincal.errors import DataError
from pincal.identification.combinations import describe_unidentifiable
from pincal.identification.corrections import moving_mass
from pincal.identification.ikm import ImplicitProblem
from pincal.identification.metrics import sample_length_errors
from pincal.identification.parameters import read_joints
from pincal.identification.problem import CalibrationProblem
from pincal.identification.result import CalibrationResult
from pincal.identification.selection import select_and_fit
from pincal.identification.solver import identify
from pincal.io.calibrated_urdf import calibrated_robot_text, declared_markers, source_text
from pincal.io.corrections_file import Corrections, corrections_of
from pincal.io.dataset import Dataset
from pincal.model.robot import Robot

Array = npt.NDArray[np.float64]

#: Most lines the summary gives the unidentifiable combinations (the report's ``unidentifiable`` has them all).
UNIDENTIFIABLE_LINES = 10


@dataclass
class Calibration:
    """One calibration: its preparation (the fitted samples, with the parameters kept), the problem, the
    identification result, the held-out evaluation (None without held-out samples), the typed report, the
    calibrated URDF text and the corrections the URDF cannot hold."""

    prepared: Prepared
    problem: CalibrationProblem
    result: CalibrationResult
    held_out: HeldOut | None
    report: CalibrationReport
    urdf_text: str
    corrections: Corrections | None = None


def options_of(options: CalibrationOptions | None, keywords: dict[str, Any]) -> CalibrationOptions:
    """``options`` (default: every default) with the keyword arguments of :func:`calibrate` over them."""
    base = options if options is not None else CalibrationOptions()
    return base.replace(**keywords) if keywords else base


def calibrate(robot: Robot, dataset: Dataset, options: CalibrationOptions | None = None, *,
              x_true: Array | None = None, progress: bool = False, **keywords: Any) -> Calibration:
    """Identify ``robot``'s parameters from ``dataset``'s ``train`` samples; evaluate on its ``test`` samples.

    ``options`` (:class:`~pincal.calibration.options.CalibrationOptions`; every field may also be given as a keyword,
    e.g. ``parameter_spec=["model24"]``, ``cv="5x4"``) choose the parameters, the solver and loss, the weights, the
    formulation, model selection and cross-validation. Errors before/after are position errors [m] (and, for poses,
    orientation errors [rad]) by forward kinematics, so the ``fkm`` and ``ikm`` formulations can be compared; "before"
    is the fit's start for the fit and the held-out samples alike (``report.before_means`` says what it is). Samples
    that cannot be used are dropped and listed; ``x_true`` (a simulation's true deviations [m, rad]) adds the
    calibration gain G; ``progress`` shows the cross-validation's folds on stderr (on a terminal).

    Raises:
        DataError: an option out of range; no training sample (every row is ``set=test``, or none can be used).
    """
    options = options_of(options, keywords)
    check_movable(robot)
    check_cv_seed(options.cv, options.cv_seed)
    if "train" not in dataset.sets:
        raise DataError(f"all {dataset.n_samples} samples are marked set=test: there is nothing to fit on; mark "
                        "the samples to calibrate from set=train (or leave the set column out)")
    fit = prepare(robot, dataset, options)
    if options.select == "bic" and options.formulation != "fkm":
        raise DataError("--select bic chooses among fkm fits; with --formulation ikm use --select none (or auto)")
    select = options.selection
    folds, every = None, None
    if options.cv is not None:  # checked before any fit
        check_cross_validation(fit.models, options.formulation)
        every = fit.on(dataset)
        folds = parse_cv(options.cv, every.samples.n_samples, options.cv_seed)
    problem = fit.problem
    fitting: dict[str, Any] = {"solver": options.solver, "loss": options.loss, "max_iter": options.max_iter}
    full_set, removed, removed_groups, first = fit.parameters, [], [], None
    if options.formulation == "ikm":
        result = identify(ImplicitProblem(robot, fit.parameters, fit.models, problem.observations), **fitting)
        result.extra["closure_before"] = result.errors_before
        result.extra["closure_after"] = result.errors_after
        result.errors_before = problem.evaluate(result.x0, jacobian=False).errors
        result.errors_after = problem.evaluate(result.x, jacobian=False).errors
    else:
        check_length_scale(problem)
        fitted = select_and_fit(problem, select, **fitting)
        problem, result, removed, first = fitted.problem, fitted.result, fitted.removed, fitted.first
        removed_groups = list(fitted.removed_groups) if removed else []
        if x_true is not None and removed:
            x_true = x_true[[full_set.index(name) for name in problem.parameters.names]]
    pset = problem.parameters
    kept = Prepared(robot, fit.models, pset, fit.samples, fit.dropped, problem, fit.joints_at_reference, fit.payload)
    status = "" if result.converged else f"NOT CONVERGED ({result.message} after {result.iterations} iterations): "
    text, shifts = calibrated_robot_text(robot, source_text(robot), pset, result.x,
                                         note=f"{status}calibrated by pincal from {problem.observations.n_samples} "
                                              f"samples ({', '.join(m.key for m in fit.models)})",
                                         read_joints=read_joints(fit.models),
                                         markers=declared_markers(fit.models))
    corrections = corrections_of(robot, pset, result.x, options.payload)
    held = evaluate_held_out(kept, dataset, pset, result.x0, result.x, trusted=result.sigma2 <= NOISE_CONTRADICTED)
    content = fit_figures(result, problem, x_true)
    ids = fit.samples.sample_ids
    lengths = sample_length_errors(result.errors_after, problem.observations.n_samples)
    suspects = result.extra.get("outlier_test", [])
    content.update({
        "reference_shifts": shifts,
        "corrections": corrections.joints if corrections is not None else {},
        "payload": options.payload.as_dict() if options.payload is not None else None,
        "links_mass": moving_mass(robot) if options.payload is not None else None,  # what its mass is weighed against
        "markers": options.markers,
        "formulation": options.formulation,
        "selection": {"policy": select if options.formulation == "fkm" else "none", "removed": removed,
                      "removed_groups": removed_groups, "n_candidates": len(full_set)},
        "unidentifiable_listing": describe_unidentifiable((first or result).identifiability.unidentifiable,
                                                          UNIDENTIFIABLE_LINES),
        "n_estimated": len(result.identified),
        "n_residuals": int(problem.row_samples().size),
        "joints_at_reference": fit.joints_at_reference,
        "dropped_samples": fit.dropped,
        "down_weighted_samples": [ids[k] for k in result.down_weighted()],
        "down_weighted": [{"sample": ids[k], "weight": float(result.sample_weights[k]),
                           "error_after": float(lengths[k]) if lengths is not None and np.isfinite(lengths[k])
                           else None} for k in result.down_weighted()],
        "n_samples_in_file": dataset.n_samples,
        "outlier_test": [ids[k] for k in suspects] if isinstance(suspects, list) else [],
    })
    if first is not None:  # what the data cannot see among all the candidates, not only among the kept ones
        content.update({"n_identifiable": first.identifiability.rank, "n_parameters": len(full_set),
                        "unidentifiable": [c.description for c in first.identifiability.unidentifiable]})
    if held is not None:
        content.update({"dropped_test_samples": held.prepared.dropped or None,  # listed, never silently
                        "held_out_outliers": held.outliers, "held_out_outside_range": held.outside_range,
                        "test_readings": held.prepared.problem.n_readings(), **held.figures(),
                        "worse_than_nominal": held.worse_than_nominal})
    if folds is not None and every is not None:
        content["cv"] = cross_validate(robot, full_set, fit.models, every.problem.observations, folds, select=select,
                                       progress=progress, payload=options.payload, **fitting)
    return Calibration(kept, problem, result, held, CalibrationReport(**content), text, corrections)
