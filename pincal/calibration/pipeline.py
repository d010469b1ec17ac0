"""The calibration pipeline a user runs: prepare, fit (with model selection), evaluate on held-out samples, report.

:func:`calibrate` is the whole of it::

    fit = prepare(robot, dataset, options)                  # models, parameters, usable samples, problem
    # without '# sigma' lines: σ estimated by a provisional fit (calibration.noise), then prepared again
    result = identify / select_and_fit(fit.problem, ...)    # Levenberg–Marquardt on analytic Jacobians
    before = register_setup(...)                           # "before": the nominal robot, its setup fitted
    held = evaluate_held_out(fit, dataset, ...)             # "before" and "after" on the held-out samples
    report = CalibrationReport(...)                         # every figure, once; its extras when first read

SI units throughout: m, rad.
"""

from __future__ import annotations

import contextlib
import math
from collections.abc import Iterator, Sequence
from dataclasses import replace
from typing import TYPE_CHECKING, Any

import numpy as np
import numpy.typing as npt

from pincal import validation
from pincal.calibration.carried import with_carried
from pincal.calibration.check_pixels import held_out_pixels, image_errors
from pincal.calibration.columns import check_columns, column_mistake, mistake_named, refuse_column_mistake
from pincal.calibration.growth import ErrorGrowth, estimate_growth
from pincal.calibration.heldout import NOISE_CONTRADICTED, HeldOut, Registration, evaluate_held_out, register_setup
from pincal.calibration.noise import provisional_noise, with_noise
from pincal.calibration.on_demand import Pending, defer, on_demand
from pincal.calibration.options import CalibrationOptions
from pincal.calibration.plausibility import (
    explains_nothing,
    implausible_corrections,
    implausible_scales,
    likely_cause,
    nothing_explained,
    scale_limit,
)
from pincal.calibration.predicted import FitCovariance, fitted_ranges, held_out_predictions, workspace_prediction
from pincal.calibration.report import CalibrationReport, before_figures, fit_figures
from pincal.calibration.report_sections import (
    BadJointReading,
    DownWeighted,
    DroppedSample,
    HeldOutPredictions,
    ModelSelection,
    OutsideRange,
    RangeGuard,
    SampleError,
    WorkspacePrediction,
)
from pincal.calibration.samples import (
    LENGTH_SCALE_RATIO,
    check_joint_scale,
    check_length_scale,
    check_moving_frames,
    dropped_account,
)
from pincal.calibration.setup import Prepared, check_movable, dataset_models, prepare
from pincal.errors import ArgumentError, DataError
from pincal.identification.combinations import describe_unidentifiable, digest
from pincal.identification.corrections import moving_mass
from pincal.identification.guard import Guard
from pincal.identification.ikm import ImplicitProblem
from pincal.identification.metrics import angle_error_norms, error_norms, rms, sample_length_errors
from pincal.identification.parameters import influencing_joints, read_joints
from pincal.identification.prior import prior_sigma
from pincal.identification.problem import CalibrationProblem
from pincal.identification.readings import BadReading
from pincal.identification.result import CalibrationResult
from pincal.identification.selection import SelectedFit, fold_prior, select_and_fit
from pincal.identification.solver import identify_with, one_blas_thread
from pincal.io.calibrated_urdf import calibrated_robot_text, declared_markers, source_text
from pincal.io.corrections_file import Corrections, corrections_of
from pincal.io.dataset import Dataset
from pincal.model.robot import Robot, robot_from_urdf_text
from pincal.progress import Progress
from pincal.records import record

if TYPE_CHECKING:
    from pincal.calibration.crossval import Folds

Array = npt.NDArray[np.float64]

#: Most lines the summary gives the unidentifiable combinations (the report's ``unidentifiable`` has them all).
UNIDENTIFIABLE_LINES = 10


@on_demand("urdf_text", "proof")
@record
class Calibration:
    """One calibration: its preparation (the fitted samples, with the parameters kept), the problem, the identification
    result, the held-out evaluation (None without held-out samples), the typed report, the calibrated URDF text, the
    corrections the URDF cannot hold, "before" and the proof of the URDF (the line :func:`~pincal.calibration.
    export_proof.calibrated_proof` gives, written in its header). The URDF text and its proof are made when first read
    (the text carries the report's bound growth, computed on demand); a PincalError of the proof is raised there."""

    prepared: Prepared
    problem: CalibrationProblem
    result: CalibrationResult
    held_out: HeldOut | None
    report: CalibrationReport
    urdf_text: str
    corrections: Corrections | None = None
    before: Registration | None = None
    proof: str = ""


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
    is the nominal robot with its setup registered on the training samples, for the fit and the held-out samples
    alike (``report.before_means`` says what it is; the fit's start is ``report.rms_start``). Samples
    that cannot be used are dropped and listed; ``x_true`` (a simulation's true deviations [m, rad]) adds the
    calibration gain G; ``progress`` shows the stages, then the cross-validation's folds, on stderr (on a terminal).

    Raises:
        DataError: an option out of range; no training sample (every row is ``set=test``, or none can be used).
        TypeError: ``robot``, ``dataset`` or ``options`` of the wrong type (named, with the value).
    """
    validation.instance("robot", robot, Robot, "a Robot (pincal.load_robot)")
    validation.instance("dataset", dataset, Dataset, "a Dataset (pincal.read_dataset)")
    if options is not None:
        validation.instance("options", options, CalibrationOptions, "CalibrationOptions or None")
    options = options_of(options, keywords)
    check_movable(robot)
    check_trainable(dataset)
    # the stages on stderr when it is a terminal; the cross-validation after them has its own bar
    models = dataset_models(robot, dataset, options)
    check_moving_frames(robot, models)  # before the samples are solved
    # BLAS on one thread for the whole of it, as the command line starts: the algebra is small (tens of columns), and
    # model selection, the range guard and the bound's hold-outs run outside identify's own limit (benchmarks/
    # bench_threads.py: a library call on this 2-core machine, loaded, several times the CPU on two threads)
    with one_blas_thread(), Progress("calibrate: prepare, fit, evaluate", 3, quiet=not progress) as stages:
        try:
            fit = prepare(robot, dataset, options)
        except DataError:  # none usable: perhaps none within the joint limits as the columns are read
            refuse_column_mistake(robot, dataset.of_set("train"), models, options.plausible)
            raise
        x_true = _checked_truth(x_true, fit.parameters.names)
        if options.formulation == "fkm":  # the fit starts from this evaluation, whose predictions the unit check reads
            fit.problem.start_prediction()
        length_scale = check_units(fit, dataset, options.plausible)  # before any fit, the provisional one included
        check_columns(fit, dataset.of_set("train"), options.plausible)
        with dropped_named(fit):
            estimated = provisional_noise(fit.problem, dataset.metadata, options)
        if estimated:  # weighted by the noise the data show, as '# sigma' lines would: before selection
            dataset = with_noise(dataset, estimated, fit.models)
            fit = prepare(robot, dataset, options)
        every, folds = cross_validation_folds(fit, dataset, options)  # checked before any fit
        stages.advance()
        with dropped_named(fit), mistake_named(fit, dataset.of_set("train"), options.plausible):
            fitted = fit_prepared(fit, options)
        kept = fit.fitted_by(fitted.problem)
        result = fitted.result
        stages.advance()
        checked = plausibility(fitted, length_scale, options.plausible, fit, dataset.of_set("train"))
        status = "" if result.converged else f"NOT CONVERGED ({result.message} after {result.iterations} iterations): "
        if checked["implausible"] or checked["implausible_scale"]:
            status += "IMPLAUSIBLE (corrections beyond what a robot of this model needs; the report's implausible): "
        if checked["explains_nothing"]:
            status += f"EXPLAINS NOTHING (residuals {result.sigma2 ** 0.5:.3g} × σ after calibration: not a result): "
        with nothing_explained(checked["explains_nothing"], result.sigma2):  # its estimate may not even evaluate
            text, shifts = calibrated_robot_text(
                robot, source_text(robot), kept.parameters, result.x, read_joints=read_joints(fit.models),
                markers=declared_markers(fit.models), note=f"{status}calibrated by pincal from {fit.samples.n_samples} "
                f"samples ({', '.join(m.key for m in fit.models)})")
            samples = fit.samples
            proof = Pending(lambda: _proof(text, samples.joint_names, samples.joints))
            corrections = corrections_of(robot, kept.parameters, result.x, options.payload)
            before = register_setup(fitted.problem, result.x0, options.fitting)
            growth = Pending(lambda: error_growth(kept, fitted, options, before.x))
            if fitted.problem.robot.loops:  # its evaluations follow the warm starts: in this order, whoever reads it
                growth.value()
            held = evaluate_held_out(kept, dataset, kept.parameters, before.x, result.x,
                                     trusted=result.sigma2 <= NOISE_CONTRADICTED, result=result,
                                     x_start=result.x0 if before.registered else None,
                                     growth=growth.value() if "test" in dataset.sets else None)
            content = report_content(fit, fitted, held, dataset, options, x_true, shifts, corrections, before, growth)
            content.update(checked)
            content["estimated_sigma"] = estimated or None
        stages.advance()
    if folds is not None and every is not None:
        from pincal.calibration.crossval import cross_validate

        with one_blas_thread():
            content["cv"] = cross_validate(robot, fit.parameters, fit.models, every.problem.observations, folds,
                                           select=options.selection, options=options.fitting,
                                           progress=progress, payload=options.payload)
    report = CalibrationReport(**content)
    calibration = Calibration(kept, fitted.problem, result, held, report, "", corrections, before)
    defer(calibration, "proof", proof)
    defer(calibration, "urdf_text", lambda: with_carried(_with_proof(text, proof.value()), report))
    return calibration


def _proof(text: str, joint_names: Sequence[str], joints: Array) -> str:
    """:func:`~pincal.calibration.export_proof.calibrated_proof` of the calibrated URDF ``text`` at the fitted samples'
    joint readings (``joints`` [rad or m], columns ``joint_names``): its module imported when a proof is read (a
    calibration whose URDF is not written needs none)."""
    from pincal.calibration.export_proof import calibrated_proof

    return calibrated_proof(text, robot_from_urdf_text(text), list(joint_names), joints)


def _with_proof(text: str, proof: str) -> str:
    """:func:`~pincal.calibration.export_proof.with_comment`: ``text`` with ``proof`` in its header."""
    from pincal.calibration.export_proof import with_comment

    return with_comment(text, proof)


@contextlib.contextmanager
def dropped_named(fit: Prepared) -> Iterator[None]:
    """The fit's DataError ("12 residuals cannot identify 40 parameters ... add samples") with the samples dropped
    before it named, when there were any: many dropped outside the joint limits point at the file, not at its size."""
    try:
        yield
    except DataError as exc:
        if type(exc) is not DataError or not fit.dropped:
            raise
        total = fit.samples.n_samples + len(fit.dropped)
        raise DataError(f"{exc}, or correct those dropped: {dropped_account(fit.dropped, total)}") from None


def check_units(fit: Prepared, dataset: Dataset, plausible: float | str) -> dict[str, float]:
    """Refuse, before any fit, a column read in a wrong unit: positions whose spread differs from the nominal robot's
    beyond the plausible band (:func:`~pincal.calibration.plausibility.scale_limit`; with ``plausible`` off, only
    beyond :data:`~pincal.calibration.samples.LENGTH_SCALE_RATIO`), and joint readings that span a sliver of their
    range (:func:`~pincal.calibration.samples.check_joint_scale`, skipped with ``plausible`` off). Returns the length
    scale of each measured position.

    Raises:
        DataError: naming the column, the unit it was read in and the likely one.
    """
    limit = scale_limit(plausible)
    scales = check_length_scale(fit.problem, dataset.metadata, limit if limit is not None else LENGTH_SCALE_RATIO)
    if limit is not None:
        check_joint_scale(fit.robot, dataset)
    return scales


def check_trainable(dataset: Dataset) -> None:
    """Refuse a dataset with no training sample.

    Raises:
        DataError: every row is ``set=test``.
    """
    if "train" not in dataset.sets:
        raise DataError(f"all {dataset.n_samples} samples are marked set=test: there is nothing to fit on; mark "
                        "the samples to calibrate from set=train (or leave the set column out)")


def cross_validation_folds(fit: Prepared, dataset: Dataset,
                           options: CalibrationOptions) -> tuple[Prepared | None, Folds | None]:
    """Every sample of ``dataset`` prepared as ``fit`` is, and the folds ``options.cv`` asks for (None, None without
    cross-validation); checked before any fit.

    Raises:
        DataError: ``select`` ``bic`` or ``cv`` with the ``ikm`` formulation; cross-validation the models cannot do,
            or folds the samples cannot make (naming the option).
    """
    if options.select in ("bic", "cv") and options.formulation != "fkm":
        raise DataError(f"select={options.select!r} chooses among fkm fits; with formulation={options.formulation!r} "
                        "use select='none' or select='auto'", option="select")
    if options.cv is None:
        return None, None
    from pincal.calibration.crossval import check_cross_validation, parse_cv  # here: only a cross-validation needs it

    check_cross_validation(fit.models, options.formulation, options.cv)
    every = fit.on(dataset)
    return every, parse_cv(options.cv, every.samples.n_samples, options.cv_seed)


def fit_prepared(fit: Prepared, options: CalibrationOptions) -> SelectedFit:
    """Fit ``fit``'s problem as ``options`` say: by forward kinematics with model selection (``fkm``), or on the
    loops' implicit residuals (``ikm``: no selection; the result's errors are then recomputed by forward kinematics,
    the closure residuals kept in ``extra``)."""
    problem = fit.problem
    if options.formulation == "ikm":
        result = identify_with(ImplicitProblem(fit.robot, fit.parameters, fit.models, problem.observations),
                               options.fitting)
        result.extra["closure_before"] = result.errors_before
        result.extra["closure_after"] = result.errors_after
        result.errors_before = problem.evaluate(result.x0, jacobian=False).errors
        result.errors_after = problem.evaluate(result.x, jacobian=False).errors
        return SelectedFit(problem, result, result, [], {})
    return select_and_fit(problem, options.selection, options.fitting)


def plausibility(fitted: SelectedFit, length_scale: dict[str, float], plausible: float | str, fit: Prepared,
                 part: Dataset) -> dict[str, Any]:
    """The report's account of plausibility (:mod:`pincal.calibration.plausibility`): the data's length scale, the
    corrections and scales beyond ``plausible`` times the documented limits, their likely cause (a joint column of
    ``part``, the training samples ``fit`` prepared, read with the other sign or exchanged with another), and whether
    the fit explains nothing (residuals beyond 1000 × σ, whatever ``plausible`` says)."""
    corrections = implausible_corrections(fitted.problem.parameters, fitted.result, plausible)
    scales = implausible_scales(length_scale, plausible)
    nothing = explains_nothing(fitted.result.sigma2, *fit_rms(fitted.result))
    mistake = column_mistake(fit.robot, part, fit.models) if (corrections or nothing) and not scales \
        and plausible != "off" else None
    cause = likely_cause(corrections, scales, length_scale, fitted.result.sigma2, mistake)
    if nothing and not cause and mistake is not None:  # the fit explains nothing: a column read wrongly says why
        cause = f"{mistake.what}: {mistake.evidence}; {mistake.fix}"
    return {"length_scale": length_scale, "plausible": plausible, "implausible": corrections,
            "implausible_scale": scales, "implausible_cause": cause, "explains_nothing": nothing}


def fit_rms(result: CalibrationResult) -> tuple[float, float]:
    """The fit's RMS error before (its start) and after [m]: of its length readings, else of its angles [rad]."""
    before, after = error_norms(result.errors_before), error_norms(result.errors_after)
    if not before.size:
        before, after = angle_error_norms(result.errors_before), angle_error_norms(result.errors_after)
    return rms(before), rms(after)


def _checked_truth(x_true: Any, names: Sequence[str]) -> Array | None:
    """``x_true`` as a vector of one finite true deviation [m, rad] per candidate parameter, or None.

    Raises:
        TypeError: not an array of numbers.
        ArgumentError: the wrong length, or NaN/inf.
    """
    if x_true is None:
        return None
    try:
        truth = np.asarray(x_true, dtype=float)
    except (TypeError, ValueError):
        raise TypeError(f"x_true={validation.shown(x_true)}: expected an array of numbers [m, rad], one per "
                        "candidate parameter") from None
    if truth.shape != (len(names),) or not np.all(np.isfinite(truth)):
        raise ArgumentError(f"x_true has shape {truth.shape}{'' if np.all(np.isfinite(truth)) else ' and NaN/inf'}: "
                            f"give {len(names)} finite values [m, rad], one per candidate parameter")
    return truth


def report_content(fit: Prepared, fitted: SelectedFit, held: HeldOut | None, dataset: Dataset,
                   options: CalibrationOptions, x_true: Array | None, shifts: dict[str, Any],
                   corrections: Corrections | None, before: Registration,
                   growth: Pending[ErrorGrowth | None]) -> dict[str, Any]:
    """The fields of the :class:`~pincal.calibration.report.CalibrationReport` of one calibration (all but ``cv``);
    "before" is ``before``, the nominal robot with its setup registered; the bound's ``growth`` and what reads it
    computed when the report's field is first read."""
    problem, result, first, removed = fitted.problem, fitted.result, fitted.first, fitted.removed
    if x_true is not None and removed:  # the truth of the parameters kept
        x_true = x_true[[fit.parameters.index(name) for name in problem.parameters.names]]
    content = fit_figures(result, problem, x_true)
    content.update(before_figures(problem, before))
    if "pixels_before" in content:  # "before" is the registered nominal robot, as for the lengths
        content["pixels"] = replace(content["pixels"], rms_before=content.pop("pixels_before"))
    ids = fit.samples.sample_ids
    lengths = sample_length_errors(result.errors_after, problem.observations.n_samples)
    suspects = result.extra.get("outlier_test", [])
    content.update({
        "reference_shifts": shifts,
        "corrections": corrections.joints if corrections is not None else {},
        "payload": options.payload,
        "links_mass": moving_mass(fit.robot) if options.payload is not None else None,  # what it is weighed against
        "markers": options.markers,
        "declared_markers": {target: list(offset) for target, offset in declared_markers(fit.models).items()},
        "formulation": options.formulation,
        "selection": ModelSelection(policy=options.selection if options.formulation == "fkm" else "none",
                                    removed=removed, removed_groups=list(fitted.removed_groups) if removed else [],
                                    n_candidates=len(fit.parameters), prior_factors=_held_factors(fitted),
                                    guard=range_guard(fitted.guard), prior=options.prior),
        "unidentifiable_listing": describe_unidentifiable(first.identifiability.unidentifiable, UNIDENTIFIABLE_LINES),
        "unidentifiable_digest": digest(first.identifiability.unidentifiable, len(fit.parameters)),
        "n_estimated": len(result.identified),
        "n_residuals": int(problem.row_samples().size),
        "joints_at_reference": fit.joints_at_reference,
        "no_effect": fit.no_effect,
        "dropped_samples": dropped_samples(fit.dropped),
        "down_weighted_samples": [ids[k] for k in result.down_weighted()],
        "down_weighted": [DownWeighted(sample=ids[k], weight=float(result.sample_weights[k]),
                                       error_after=float(lengths[k]) if lengths is not None and np.isfinite(lengths[k])
                                       else None) for k in result.down_weighted()],
        "bad_readings": [BadJointReading(sample=ids[b.sample], joint=b.joint, off=b.off, unit=b.unit,
                                         explained=b.explained) for b in bad_readings_of(result)],
        "n_samples_in_file": dataset.n_samples,
        "outlier_test": [ids[k] for k in suspects] if isinstance(suspects, list) else [],
        # what the data cannot see among all the candidates, not only among the kept ones
        "n_identifiable": first.identifiability.rank, "n_parameters": len(fit.parameters),
        "unidentifiable": [c.description for c in first.identifiability.unidentifiable],
    })
    content["sample_errors"] = sample_errors(ids, before.errors, result.errors_after, "train")
    content.update(prediction_content(fit.fitted_by(problem), result, held, before.x, growth))
    if held is not None:
        content["sample_errors"] += sample_errors(held.prepared.samples.sample_ids, held.errors_before,
                                                  held.errors_after, "test")
        content.update({"dropped_test_samples": dropped_samples(held.prepared.dropped) or None,  # never silently
                        "held_out_outliers": held.outliers,
                        "held_out_outside_range": [OutsideRange(sample=o["sample"], joint=o["joint"], value=o["value"],
                                                                range=o["range"]) for o in held.outside_range],
                        "test_readings": held.prepared.problem.n_readings(), **held.figures(),
                        "worse_than_nominal": held.worse_than_nominal})
    return content


def dropped_samples(dropped: list[dict[str, str]]) -> list[DroppedSample]:
    """The report's account of the samples ``dropped`` before a fit (``{"sample", "reason"}`` each, as
    :func:`~pincal.calibration.setup.prepare` lists them)."""
    return [DroppedSample(sample=d["sample"], reason=d["reason"]) for d in dropped]


def range_guard(guard: Guard | None) -> RangeGuard | None:
    """The report's account of the range guard ``guard`` (None: it did not run)."""
    if guard is None:
        return None
    return RangeGuard(firmer=guard.firmer, beyond=guard.beyond, inside=guard.inside,
                      nominal_beyond=guard.nominal_beyond, scores=[list(s) for s in guard.scores])


def _held_factors(fitted: SelectedFit) -> dict[str, float] | None:
    """The prior factor each group is held by: the evidence's, divided by the range guard's divisor (None: the prior
    was not automatic)."""
    if fitted.evidence is None:
        return None
    firmer = fitted.guard.firmer if fitted.guard is not None else 1.0
    return {group: factor / firmer for group, factor in fitted.evidence.factors.items()}


def moving_joints(fit: Prepared) -> list[str]:
    """The actuated joints that move what ``fit`` measures (their ranges are the fitted range)."""
    return influencing_joints(fit.robot, sorted({f for m in fit.models for f in m.frames}), read_joints(fit.models))


def error_growth(fit: Prepared, fitted: SelectedFit, options: CalibrationOptions,
                 x_before: Array) -> ErrorGrowth | None:
    """How the fit's predicted bound grows beyond its range, and the registered nominal robot's (``x_before``) own
    error bound, estimated on the fit's samples (:func:`~pincal.calibration.growth.estimate_growth`, with the prior the
    fit was made with)."""
    problem = fitted.problem
    prior = fitted.prior_sigma if fitted.prior_sigma is not None \
        else prior_sigma(problem.parameters, options.fitting.fixed_prior())
    moving = moving_joints(fit)
    columns = [k for k, j in enumerate(fit.robot.actuated_joints) if j in moving]
    with one_blas_thread():  # also when the report's field is first read, after calibrate() returned
        return estimate_growth(problem, fitted.result, prior, columns, x_before, fold_prior(fitted))


def prediction_content(fit: Prepared, result: CalibrationResult, held: HeldOut | None, x_before: Array,
                       growth: Pending[ErrorGrowth | None]) -> dict[str, Any]:
    """The report's predicted accuracy (:mod:`pincal.calibration.predicted`): the fitted joint ranges, the bound's
    growth beyond them and the predicted error over the workspace (both :class:`Pending`: computed when the report's
    field is first read), and the held-out samples' predicted bounds with their coverage."""
    ranges = fitted_ranges(fit.robot, fit.problem.observations.actuated, moving_joints(fit))

    def workspace() -> WorkspacePrediction | None:  # when first read: BLAS on one thread, as in calibrate()
        with one_blas_thread():
            return workspace_prediction(fit.problem, FitCovariance.of_result(result, growth.value()), result.x, ranges)

    out: dict[str, Any] = {"fitted_range": ranges, "error_growth": growth, "predicted_workspace": Pending(workspace)}
    if held is not None and held.predicted is not None:
        out["predicted_held_out"] = held_out_predictions(held.prepared.samples.sample_ids, held.predicted,
                                                         held.sample_errors()[1])
    covariance = FitCovariance.of_result(result) if held else None  # its growth is not read
    pixels = held_out_pixels(held.prepared.problem, covariance.matrix, covariance.columns, covariance.sigma2,
                             result.x, held.errors_after, held.prepared.samples.sample_ids) \
        if held and covariance is not None else None
    if pixels is not None:  # each held-out image's predicted reprojection error [px]
        out["predicted_held_out"] = replace(out.get("predicted_held_out") or HeldOutPredictions(), pixels=pixels)
    return out


def bad_readings_of(result: CalibrationResult) -> list[BadReading]:
    """The samples ``result``'s fit left out as bad joint readings (:mod:`pincal.identification.readings`)."""
    found = result.extra.get("bad_readings", [])
    return [b for b in found if isinstance(b, BadReading)] if isinstance(found, list) else []


def sample_errors(ids: list[str], before: dict[str, Array], after: dict[str, Array], part: str) -> list[SampleError]:
    """Per sample of ``part`` (``train`` or ``test``): its id and its length-type error [m] before (the nominal robot
    with its setup registered) and after (None for a sample with no length reading); with pixels, its image's
    reprojection error [px] before and after (``pixel_before``, ``pixel_after``: the RMS of its corners)."""
    n = len(ids)

    def finite(values: Array | None) -> list[float | None]:
        return [v if math.isfinite(v) else None for v in values.tolist()] if values is not None else [None] * n

    lengths = zip(ids, finite(sample_length_errors(before, n)), finite(sample_length_errors(after, n)), strict=True)
    images = image_errors(before, n), image_errors(after, n)
    if images[0] is None:
        return [SampleError(sample=s, set=part, before=b, after=a) for s, b, a in lengths]
    return [SampleError(sample=s, set=part, before=b, after=a, pixel_before=pb, pixel_after=pa, imaged=True)
            for (s, b, a), pb, pa in zip(lengths, finite(images[0]), finite(images[1]), strict=True)]
