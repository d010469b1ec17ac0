"""What ``pincal check`` judges apart: the postures within the joint ranges the calibration fitted and those beyond,
and each posture's predicted 95 % bound under MODEL.

A calibration is used beyond its data, and a total can hide a group it predicts badly: a model better than the
nominal robot on postures like its fitted ones can be worse on those beyond them. So the check's verdict is also taken
on each group: MODEL predicts the postures beyond its fitted range (at least :data:`MIN_GROUP` of them) worse than the
nominal robot (its setup registered on the same data) → exit 1, whatever the total. The bounds are those of
:mod:`pincal.calibration.predicted`, from the calibration MODEL holds: a report JSON, or a calibrated URDF's
``<pincal_calibration>`` element (:mod:`pincal.calibration.carried`). Lengths in m.
"""

from __future__ import annotations

from collections.abc import Sequence
from dataclasses import replace
from typing import Any

import numpy as np
import numpy.typing as npt

from pincal.calibration.check_model import CheckedModel
from pincal.calibration.check_pixels import PixelBounds, pixel_bounds
from pincal.calibration.predicted import FitCovariance, PredictedErrors, distance, predicted_errors, weighed_as_fitted
from pincal.calibration.samples import held_out_outside_range
from pincal.calibration.setup import Prepared
from pincal.errors import DataError
from pincal.identification.metrics import length_columns, rms, sample_length_errors
from pincal.io.dataset import Dataset
from pincal.model.robot import Robot

Array = npt.NDArray[np.float64]

#: Fewest postures of a group its own verdict is taken on.
MIN_GROUP = 3
#: Relative difference of two RMS errors within which MODEL is not called worse: the two setups are registered by two
#: fits, whose ends differ in the last digits they converge to (a MODEL that is the nominal robot ties with it).
SAME_ERROR = 0.01
#: Why a check has no predicted bounds.
NO_CALIBRATION = ("MODEL carries no calibration (a URDF written before pincal recorded one, or a robot name): give a "
                  "calibrated URDF or the report JSON of its calibration as MODEL for each posture's predicted error")
NO_COVARIANCE = "MODEL's calibration holds no covariance of its estimates for these measurements"
PIXELS_ONLY = "DATA measure pixels only: each image's bound is in px (the report's 'pixel_predicted')"


def group_verdicts(model_errors: dict[str, Array], nominal_errors: dict[str, Array], beyond: Sequence[bool]
                   ) -> dict[str, Any]:
    """Per group (``inside`` and ``beyond`` the fitted range: ``beyond`` per checked sample) its postures with a
    length reading, MODEL's and the nominal robot's RMS length error [m], and whether MODEL predicts it worse (by more
    than :data:`SAME_ERROR`; a group of at least :data:`MIN_GROUP` postures)."""
    n = len(beyond)
    model, nominal = sample_length_errors(model_errors, n), sample_length_errors(nominal_errors, n)
    out: dict[str, Any] = {}
    for name, where in (("inside", ~np.asarray(beyond, dtype=bool)), ("beyond", np.asarray(beyond, dtype=bool))):
        if model is None or nominal is None:
            out[name] = {"n": 0, "rms": None, "nominal_rms": None, "worse": False}
            continue
        keep = where & np.isfinite(model) & np.isfinite(nominal)
        a, b = rms(model[keep]), rms(nominal[keep])
        count = int(np.count_nonzero(keep))
        out[name] = {"n": count, "rms": a if count else None, "nominal_rms": b if count else None,
                     "worse": bool(count >= MIN_GROUP and a > (1.0 + SAME_ERROR) * b)}
    return out


def beyond_verdict(content: dict[str, Any]) -> str | None:
    """The verdict on the postures beyond the fitted range, in words, of a check's report ``content`` (its ``groups``;
    lengths shown in mm) when MODEL predicts them worse than the nominal robot and DATA are plausible; else None. The
    terminal and the page say the same sentence."""
    beyond = (content.get("groups") or {}).get("beyond") or {}
    if content.get("implausible") is not None or not beyond.get("worse"):
        return None
    return (f"MODEL predicts the {beyond['n']} postures beyond its fitted joint range WORSE than the nominal robot "
            f"({beyond['rms'] * 1e3:.4f} mm against {beyond['nominal_rms'] * 1e3:.4f} mm RMS), whatever the total: "
            "do not use MODEL there (calibrate over postures that cover them)")


def beyond_note(content: dict[str, Any]) -> str | None:
    """Why postures beyond the fitted range that MODEL predicts worse than the nominal robot do not fail the check:
    fewer than :data:`MIN_GROUP` of them (lengths shown in mm); None otherwise."""
    beyond = (content.get("groups") or {}).get("beyond") or {}
    n, model, nominal = beyond.get("n") or 0, beyond.get("rms"), beyond.get("nominal_rms")
    if content.get("implausible") is not None or not 0 < n < MIN_GROUP or model is None or nominal is None \
            or not model > (1.0 + SAME_ERROR) * nominal:
        return None
    return (f"MODEL predicts the {n} posture{'s' if n > 1 else ''} beyond its fitted joint range worse than the "
            f"nominal robot ({model * 1e3:.4f} mm against {nominal * 1e3:.4f} mm RMS), too few (fewer than "
            f"{MIN_GROUP}) for a verdict of their own")


def predicted_check(model: CheckedModel, nominal: Prepared
                    ) -> tuple[PredictedErrors | None, str | None, PixelBounds | None]:
    """Each checked sample's predicted error under MODEL (:mod:`pincal.calibration.predicted`): the calibration's
    estimates, covariance and growth, as its report or its calibrated URDF holds them, on ``nominal``'s samples, at
    their distance beyond the fitted range it records. None and why when MODEL holds none. Then each image's predicted
    reprojection error [px] (:class:`~pincal.calibration.check_pixels.PixelBounds`), None without pixels."""
    report = model.calibration
    if report is None:
        return None, NO_CALIBRATION, None
    from pincal.identification.parameters import choose_parameters

    names = list(report.parameters)
    try:
        parameters = choose_parameters(nominal.robot, nominal.models, names, "cluster" if report.markers == "cluster"
                                       else "each")
    except (DataError, KeyError):
        return None, "MODEL's parameters are not those of these measurements: no predicted errors", None
    x = np.array([float(report.parameters[name].value) for name in parameters.names])
    on = replace(nominal, models=weighed_as_fitted(nominal.models, report)).on(nominal.samples, parameters)
    growth = report.error_growth
    fit = FitCovariance.of_report(report.covariance, report.sigma2, parameters.names, growth)
    pixels = pixel_bounds(on.problem, fit.matrix, fit.columns, fit.sigma2, x)
    if not any(length_columns(m.key) for m in on.problem.measurements):
        return None, PIXELS_ONLY if pixels is not None else NO_COVARIANCE, pixels
    ranges = report.fitted_range or model.provenance.fitted_range or {}
    predicted = predicted_errors(on.problem, fit, x, distance(nominal.robot, on.problem.observations.actuated, ranges))
    if not np.any(np.isfinite(predicted.bound)):
        return None, NO_COVARIANCE, pixels
    return predicted, None, pixels


def nominal_bounds(model: CheckedModel, predicted: PredictedErrors) -> npt.NDArray[np.float64]:
    """The nominal robot's own 95 % bound [m] at each checked posture (:meth:`~pincal.calibration.growth.ErrorGrowth.
    nominal`, at the posture's distance), NaN where the calibration holds none."""
    growth = model.calibration.error_growth if model.calibration is not None else None
    if growth is None:
        return np.full(predicted.bound.size, np.nan)
    return growth.nominal(predicted.distance)


def outside_recorded(robot: Robot, ranges: dict[str, list[float]], samples: Dataset,
                     joints: Sequence[str]) -> list[dict[str, Any]]:
    """The readings of ``samples`` outside the fitted ``ranges`` MODEL records ({joint: [min, max]} [rad or m]) by
    more than their margin, as :func:`~pincal.calibration.samples.held_out_outside_range` lists them."""
    names = [j for j in robot.actuated_joints if j in ranges and j in joints and j in samples.joint_names]
    limits = np.array([[ranges[j][0] for j in names], [ranges[j][1] for j in names]])
    bounds = Dataset(names, limits, {}, ["min", "max"], ["train", "train"], {})
    return held_out_outside_range(robot, bounds, samples, joints=names)


def beyond_fitted_range(model: CheckedModel, nominal: Robot, checked: Prepared, fitted: Dataset | None,
                        note: str | None) -> tuple[list[dict[str, Any]], str | None]:
    """The readings of the ``checked`` samples beyond the fitted range (as
    :func:`~pincal.calibration.samples.held_out_outside_range` lists them), and why the range is not known (``note``,
    None when it is): the range MODEL records, of the samples the calibration fitted (not of rows it dropped), as the
    bounds read it; for a MODEL written before it recorded one, the training rows of its data (``fitted``)."""
    from pincal.identification.parameters import influencing_joints, read_joints

    moving = influencing_joints(nominal, sorted({f for m in checked.models for f in m.frames}),
                                read_joints(checked.models))
    ranges = model.calibration.fitted_range if model.calibration is not None else None
    ranges = ranges or model.provenance.fitted_range
    if ranges:
        return outside_recorded(nominal, ranges, checked.samples, moving), None
    if fitted is not None:
        train = fitted.of_set("train") if "train" in fitted.sets else fitted
        return held_out_outside_range(nominal, train, checked.samples, joints=moving), note
    return [], note


def fitted_data(model: CheckedModel, nominal: Robot) -> tuple[Dataset | None, str | None]:
    """The data the calibration fitted, as the model's provenance records it, or None and why not (no record, the
    file gone or changed since, or unreadable)."""
    from pincal.calibration.job import read_job
    from pincal.calibration.job_data import job_dataset
    from pincal.calibration.provenance import sha256
    from pincal.calibration.samples import read_robot_dataset
    from pincal.errors import PincalError

    path, recorded = model.provenance.data, model.provenance.data_sha256
    if path is None:
        return None, "MODEL records no calibration data (no provenance): postures outside the fitted range cannot be " \
                     "flagged"
    if not path.is_file():
        return None, f"the calibration's data '{path}' (recorded in MODEL) is not there: postures outside the " \
                     "fitted range cannot be flagged"
    if recorded and sha256(path) != recorded:
        return None, f"the calibration's data '{path}' changed since the calibration (its SHA-256 differs): " \
                     "postures outside the fitted range cannot be flagged"
    try:
        if path.suffix.lower() == ".toml":
            return job_dataset(read_job(path), nominal), None
        return read_robot_dataset(path, nominal), None
    except PincalError as exc:
        return None, f"the calibration's data '{path}' cannot be read ({exc}): postures outside the fitted range " \
                     "cannot be flagged"


def recorded_before(model: CheckedModel, nominal: Prepared) -> Array | None:
    """The nominal robot's setup as the calibration registered it on its own data (its "before": the
    ``before_parameters`` MODEL carries), in ``nominal``'s setup parameters; None when MODEL records none, or not of
    every setup parameter DATA needs."""
    recorded = model.calibration.before_parameters if model.calibration is not None else {}
    names = nominal.parameters.names
    if not recorded or not all(name in recorded for name in names):
        return None
    return np.array([float(recorded[name]) for name in names])
