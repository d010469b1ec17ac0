"""``pincal check``: a calibrated model's predictions of new measurements, beside the nominal robot's.

Both robots predict every usable sample of the data (rows of either set), through the same preparation as a
calibration (:func:`~pincal.calibration.setup.prepare`) with the measurement *setup* as the only parameters: the
measurement frame (``base.*``), the markers, the cameras and targets, the contact planes
(:mod:`pincal.calibration.check_setup`). Their values:

- the model, as it stands: the setup the file holds (its ``measurement_frame`` root, its ``<frame>_marker`` links,
  its camera, target and plane links), nothing estimated;
- the nominal robot: its setup registered on the data (least squares from its placement in closed form: the measurement
  frame by Kabsch, cameras and targets hand-eye, planes fitted to the contact points, markers at their nominal
  offsets), as calibrate's "before": the gain shown is the robot's calibration, not the registration of a marker;
- with ``register``: MODEL's setup re-estimated on the data the same way, its geometry held, so that a day whose
  tracker, markers or cameras moved is judged on the robot alone.

A registration whose fit ends above its start (the σ-weighted RMS) keeps the start, and says so. The verdict is taken
on the total and, apart, on the postures beyond the fitted joint range (:mod:`pincal.calibration.check_groups`).

Errors in m (lengths) and rad (angles); every figure is predicted − measured.
"""

from __future__ import annotations

import json
from collections.abc import Mapping, Sequence
from dataclasses import replace
from pathlib import Path
from typing import Any

import numpy as np
import numpy.typing as npt

from pincal import linalg
from pincal.calibration import check_pixels as pixel_check
from pincal.calibration.check_groups import (
    SAME_ERROR,
    beyond_fitted_range,
    fitted_data,
    group_verdicts,
    nominal_bounds,
    predicted_check,
    recorded_before,
)
from pincal.calibration.check_model import CheckedModel
from pincal.calibration.check_pixels import largest as _largest
from pincal.calibration.check_pixels import number as _number
from pincal.calibration.check_plausibility import Beyond, Implausible, beyond_plausible, implausible_data
from pincal.calibration.check_setup import (
    NOMINAL_AS_CALIBRATED,
    check_exceeds_setup,
    file_setup,
    model_intrinsics,
    model_means,
    nominal_means,
    prepare_setup,
)
from pincal.calibration.options import CalibrationOptions, GivenOptions
from pincal.calibration.pipeline import check_units
from pincal.calibration.predicted import PredictedErrors, coverage
from pincal.calibration.provenance import labelled
from pincal.calibration.setup import Prepared
from pincal.errors import DataError
from pincal.identification.measurements import Measurement
from pincal.identification.metrics import angle_columns, length_columns, rms, sample_length_errors
from pincal.identification.solver import identify_with
from pincal.io.dataset import Dataset
from pincal.model.robot import Robot
from pincal.records import record

Array = npt.NDArray[np.float64]

@record(frozen=True)
class Side:
    """One robot's predictions of the checked samples.

    Attributes:
        prepared: Its problem over the setup parameters, on the checked samples.
        x: The setup's values [m, rad], in ``prepared.parameters``' order.
        errors: Per measurement key, (N, rows) errors predicted − measured [m, rad].
        converged: Whether the registration converged (None: nothing was estimated).
        note: Why the registration's start stands, when its fit ended above it (None otherwise).
    """

    prepared: Prepared
    x: Array
    errors: dict[str, Array]
    converged: bool | None = None
    note: str | None = None

    def setup(self) -> dict[str, float]:
        """The setup's values by parameter name [m, rad]."""
        return {name: float(v) for name, v in zip(self.prepared.parameters.names, self.x, strict=True)}


@record(frozen=True)
class Check:
    """A model checked on data, beside the nominal robot.

    Attributes:
        model, nominal: The two robots' predictions of the same samples.
        registered: Whether the setups were re-estimated (``register``).
        dropped: The samples left out, with the reason (``{"sample", "reason"}``; the robot it concerns named).
        outside_range: Readings of actuated joints outside the range the calibration fitted
            (:func:`~pincal.calibration.samples.held_out_outside_range`); empty when not known.
        range_note: Why the fitted range is not known (None when it is).
        n_samples_in_file: The data's rows.
        predicted: Each sample's predicted error under MODEL (σ per length row, the 95 % bound [m] widened beyond
            the fitted joint range), from the calibration's covariance; None when MODEL holds none (``predicted_note``
            says why).
        predicted_note: Why there is no prediction (None when there is).
        implausible: DATA judged beyond what a robot of the nominal model can produce, with the likely cause, as
            ``calibrate`` judges them (:mod:`pincal.calibration.check_plausibility`); None when plausible.
        nominal_bound: (N,) the nominal robot's own 95 % bound [m] at each sample, from the calibration MODEL holds
            (NaN: not known); None without a prediction.
        pixel_bounds: Each image's predicted reprojection error [px] under MODEL; None without pixels or covariance.
    """

    model: Side
    nominal: Side
    registered: bool
    dropped: list[dict[str, str]]
    outside_range: list[dict[str, Any]]
    range_note: str | None
    n_samples_in_file: int
    predicted: PredictedErrors | None = None
    predicted_note: str | None = None
    implausible: Implausible | None = None
    nominal_bound: Array | None = None
    pixel_bounds: pixel_check.PixelBounds | None = None

    @property
    def sample_ids(self) -> list[str]:
        """The checked samples' ids, in file order."""
        return self.model.prepared.samples.sample_ids

    @property
    def outside_samples(self) -> list[str]:
        """The ids of the samples with a reading outside the fitted range, in file order."""
        flagged = {entry["sample"] for entry in self.outside_range}
        return [s for s in self.sample_ids if s in flagged]

    @property
    def beyond(self) -> list[bool]:
        """Whether each checked sample has a reading beyond the fitted range (and its margin)."""
        flagged = set(self.outside_samples)
        return [s in flagged for s in self.sample_ids]

    def groups(self) -> dict[str, Any]:
        """The verdict inside and beyond the fitted range apart (:func:`~pincal.calibration.check_groups.
        group_verdicts`)."""
        return group_verdicts(self.model.errors, self.nominal.errors, self.beyond)

    @property
    def worse_beyond(self) -> bool:
        """Whether MODEL predicts the postures beyond its fitted range (enough of them) worse than the nominal
        robot."""
        return bool(self.groups()["beyond"]["worse"])

    @property
    def worse_than_nominal(self) -> bool:
        """Whether the model predicts the data worse than the nominal robot (by more than
        :data:`~pincal.calibration.check_groups.SAME_ERROR`): by the RMS of the length readings (positions,
        distances), else of the pixels' reprojection errors, else by the RMS of the σ-weighted errors."""
        n = len(self.sample_ids)
        model, nominal = sample_length_errors(self.model.errors, n), sample_length_errors(self.nominal.errors, n)
        if model is not None and nominal is not None:
            keep = np.isfinite(model) & np.isfinite(nominal)
            return bool(rms(model[keep]) > (1.0 + SAME_ERROR) * rms(nominal[keep]))
        pixels = pixel_check.pixels_worse(self.model.errors, self.nominal.errors, SAME_ERROR)
        return pixels if pixels is not None \
            else bool(weighted_rms(self.model) > weighted_rms(self.nominal) * (1.0 + SAME_ERROR))

    def figures(self, rows: Sequence[int] | None = None) -> dict[str, Any]:
        """RMS and max of the length errors [m] (and of the orientation errors [rad], with poses; of the reprojection
        errors [px], with pixels) of the model and of the nominal robot, over the samples ``rows`` (None: all)."""
        model, nominal = ({k: e if rows is None else e[list(rows)] for k, e in s.errors.items()}
                          for s in (self.model, self.nominal))
        out: dict[str, Any] = {"n_samples": len(self.sample_ids) if rows is None else len(rows)}
        for suffix, pick in (("", _length_norms), ("_angle", _angle_norms)):
            a, b = pick(model), pick(nominal)
            if suffix and not a.size:
                continue
            out.update({f"rms{suffix}": _number(rms(a)), f"max{suffix}": _largest(a),
                        f"nominal_rms{suffix}": _number(rms(b)), f"nominal_max{suffix}": _largest(b)})
        pixels = pixel_check.pixel_figures(model, nominal)  # the reprojection errors [px]
        return {**out, "pixels": pixels} if pixels else out

    def quantities(self) -> list[dict[str, Any]]:
        """Per measurement and quantity (``length`` [m], ``angle`` [rad], ``reading`` [its unit]): the readings'
        count, RMS and max error of the model and of the nominal robot."""
        out = []
        for m in (m for m in self.model.prepared.models if not pixel_check.is_pixel_key(m.key)):
            a, b = self.model.errors[m.key], self.nominal.errors[m.key]
            parts = []
            if length_columns(m.key):
                parts.append(("length", "m", slice(0, length_columns(m.key))))
            if angle_columns(m.key).stop > angle_columns(m.key).start:
                parts.append(("angle", "rad", angle_columns(m.key)))
            if not parts:
                parts.append(("reading", m.row_units()[0], slice(0, a.shape[1])))
            for quantity, unit, columns in parts:
                na, nb = _norms(a[:, columns]), _norms(b[:, columns])
                out.append({"measurement": m.key, "quantity": quantity, "unit": unit, "n": int(na.size),
                            "rms": _number(rms(na)), "max": _largest(na), "nominal_rms": _number(rms(nb)),
                            "nominal_max": _largest(nb)})
        return out + pixel_check.pixel_quantities(self.model.prepared.models, self.model.errors, self.nominal.errors)

    def samples(self) -> list[dict[str, Any]]:
        """Per checked sample: its id, its length error [m] and orientation error [rad] (None without such a
        reading) under the model and the nominal robot, whether a reading lies outside the fitted range, and with a
        prediction its 95 % bound [m], its distance beyond the fitted range and the nominal robot's own bound [m]."""
        n = len(self.sample_ids)
        outside = set(self.outside_samples)
        length_a, length_b = (sample_length_errors(s.errors, n) for s in (self.model, self.nominal))
        angle_a, angle_b = (sample_angle_errors(s.errors, n) for s in (self.model, self.nominal))
        pixel_a, pixel_b = (pixel_check.image_errors(s.errors, n) for s in (self.model, self.nominal))
        out = []
        for k, sample in enumerate(self.sample_ids):
            entry: dict[str, Any] = {"sample": sample}
            if length_a is not None and length_b is not None:
                entry.update({"error": _number(length_a[k]), "nominal_error": _number(length_b[k])})
            if angle_a is not None and angle_b is not None:
                entry.update({"angle_error": _number(angle_a[k]), "nominal_angle_error": _number(angle_b[k])})
            if pixel_a is not None and pixel_b is not None:  # the image's reprojection error [px]
                entry.update({"pixel_error": _number(pixel_a[k]), "nominal_pixel_error": _number(pixel_b[k]),
                              **(self.pixel_bounds.entry(k) if self.pixel_bounds is not None else {})})
            entry["outside_range"] = sample in outside
            if self.predicted is not None:
                entry.update({"bound": _number(self.predicted.bound[k]), "distance": float(self.predicted.distance[k]),
                              "nominal_bound": _number(self.nominal_bound[k]) if self.nominal_bound is not None
                              else None,
                              "sigma": [_number(v) for v in self.predicted.sigma[k]]})
            out.append(entry)
        return out

    def predicted_account(self) -> dict[str, Any]:
        """The predicted bounds' account: how many of MODEL's length errors lie within their 95 % bound (all, and
        within and beyond the fitted range apart), the median bound [m], the samples beyond the fitted range (or why
        there is no prediction)."""
        if self.predicted is None:
            return {"known": False, "note": self.predicted_note}
        errors = sample_length_errors(self.model.errors, len(self.sample_ids))
        finite = self.predicted.bound[np.isfinite(self.predicted.bound)]
        return {"known": True, "level": 0.95,
                **coverage(self.predicted, errors if errors is not None else np.full(len(self.sample_ids), np.nan)),
                "median_bound": _number(float(linalg.median(finite))) if finite.size else None,
                "beyond": [s for s, u in zip(self.sample_ids, self.predicted.distance, strict=True) if u > 0.0]}


def _norms(errors: Array) -> Array:
    """Each row's norm, rows not taken (NaN) left out."""
    norms = np.linalg.norm(errors, axis=1)
    return np.asarray(norms[np.isfinite(norms)], dtype=np.float64)


def _length_norms(errors: dict[str, Array]) -> Array:
    parts = [_norms(err[:, :length_columns(key)]) for key, err in errors.items() if length_columns(key)]
    return np.concatenate(parts) if parts else np.zeros(0)


def _angle_norms(errors: dict[str, Array]) -> Array:
    parts = [_norms(err[:, angle_columns(key)]) for key, err in errors.items()
             if angle_columns(key).stop > angle_columns(key).start]
    return np.concatenate(parts) if parts else np.zeros(0)


def sample_angle_errors(errors: dict[str, Array], n: int) -> Array | None:
    """Each sample's orientation error [rad] (the rotation rows of its pose readings together; NaN for a sample with
    none), or None when no orientation is measured."""
    keys = [key for key in errors if angle_columns(key).stop > angle_columns(key).start]
    if not keys:
        return None
    squares, taken = np.zeros(n), np.zeros(n, dtype=bool)
    for key in keys:
        rows = errors[key][:, angle_columns(key)]
        seen = ~np.isnan(rows).all(axis=1)
        squares[seen] += np.sum(rows[seen] ** 2, axis=1)
        taken |= seen
    return np.where(taken, np.sqrt(squares), np.nan)


def weighted_rms(side: Side) -> float:
    """The RMS of a side's errors, each row divided by its σ (dimensionless)."""
    parts = []
    for m in side.prepared.models:
        err = side.errors[m.key] / m.row_sigmas()
        parts.append(err[np.isfinite(err)])
    values = np.concatenate(parts) if parts else np.zeros(0)
    return rms(values)


def _side(prepared: Prepared, x: Array, register: bool, options: CalibrationOptions,
          which: str | None = None) -> Side:
    """A robot's predictions at ``x``, or, with ``register``, at its setup re-estimated from ``x`` by σ-weighted least
    squares (the solver and iteration limit of ``options``); the start kept, and said so, where the fit ends above
    it; a fit of DATA exactly refused for side ``which`` (None: a probe) by :func:`check_exceeds_setup`."""
    problem = prepared.problem
    start = Side(prepared, x, problem.evaluate(x, jacobian=False).errors)
    if not register or not len(prepared.parameters):
        return start
    result = identify_with(problem, replace(options.fitting, loss="linear"), x)  # least squares
    check_exceeds_setup(which, problem, len(result.identified))
    side = Side(prepared, result.x, problem.evaluate(result.x, jacobian=False).errors, bool(result.converged))
    if weighted_rms(side) > weighted_rms(start):
        return replace(start, converged=side.converged,
                       note=f"the registration ended at a σ-weighted RMS of {weighted_rms(side):.4g} above its start's "
                            f"{weighted_rms(start):.4g}: the start is kept")
    return side


def _common(model: Prepared, nominal: Prepared, model_data: Dataset,
            data: Dataset) -> tuple[Prepared, Prepared, list[dict[str, str]]]:
    """The two preparations on the samples both robots can use, and every sample left out with the robot it
    concerns."""
    dropped = [{"sample": d["sample"], "reason": f"MODEL: {d['reason']}"} for d in model.dropped]
    dropped += [{"sample": d["sample"], "reason": f"nominal robot: {d['reason']}"} for d in nominal.dropped]
    both = set(model.samples.sample_ids) & set(nominal.samples.sample_ids)
    if not both:
        raise DataError(f"none of the {data.n_samples} samples can be used by both MODEL and the nominal robot: "
                        f"{dropped[0]['reason'] if dropped else 'no data'}")
    rows = [k for k, s in enumerate(data.sample_ids) if s in both]
    if len(both) < model.samples.n_samples:
        model = model.on(model_data.subset(rows))
    if len(both) < nominal.samples.n_samples:
        nominal = nominal.on(data.subset(rows))
    order = {s: k for k, s in enumerate(data.sample_ids)}
    return model, nominal, sorted(dropped, key=lambda d: order.get(d["sample"], 0))


def check_model(model: CheckedModel, nominal: Robot, dataset: Dataset, options: CalibrationOptions,
                register: bool = False, fitted: Dataset | None = None, range_note: str | None = None) -> Check:
    """Predict every usable sample of ``dataset`` with ``model`` and with ``nominal`` (see the module's account of
    each side's setup); ``register`` re-estimates both setups. ``fitted`` is the data the calibration fitted (its
    ``train`` rows set the fitted range; None: not known, ``range_note`` says why).

    Raises:
        DataError: the data measure a frame a robot lacks, no sample usable by both, lengths or joint readings in the
            wrong unit (:func:`~pincal.calibration.pipeline.check_units`, as ``calibrate`` refuses them, before any
            work), a camera the model holds no link or intrinsics for (without ``register``).
    """
    setup = options.replace(parameter_spec=None, markers="each", payload=None)
    nominal_prepared = prepare_setup(nominal, dataset, setup)
    check_units(nominal_prepared, dataset, options.plausible)
    model_data = model_intrinsics(model.calibration.cameras if model.calibration is not None else None,
                                  model.readings(dataset, nominal), register)
    model_prepared = prepare_setup(model.robot, model_data, setup)
    model_prepared, nominal_prepared, dropped = _common(model_prepared, nominal_prepared, model_data, dataset)
    x_model = file_setup(model_prepared.problem, register)
    if register:
        x_model = model_prepared.problem.initial_guess(x_model)
    model_side = _side(model_prepared, x_model, register, options, "MODEL")
    recorded = recorded_before(model, nominal_prepared) if not register else None
    nominal_side = _side(nominal_prepared, recorded, False, options) if recorded is not None \
        else _side(nominal_prepared, nominal_prepared.problem.initial_guess(), True, options, "the nominal robot")
    outside, range_note = beyond_fitted_range(model, nominal, nominal_prepared, fitted, range_note)
    predicted, note, pixels = predicted_check(model, nominal_prepared)
    return Check(model_side, nominal_side, register, dropped, outside, range_note, dataset.n_samples, predicted, note,
                 _plausibility(nominal_side, model_side, recorded is None, options),
                 nominal_bounds(model, predicted) if predicted is not None else None, pixels)


def _plausibility(nominal: Side, model: Side, register: bool, options: CalibrationOptions) -> Implausible | None:
    """Whether DATA can be of the nominal robot, as ``calibrate`` judges it
    (:mod:`pincal.calibration.check_plausibility`), when its errors with its setup fitted to DATA are beyond a robot of
    its model (registered here for that when the check does not register: a setup placed in closed form may be what
    is off); MODEL's errors within those limits say that a calibrated robot of this model explains them."""
    def beyond(side: Side) -> Beyond | None:
        return beyond_plausible(rms(_length_norms(side.errors)), rms(_angle_norms(side.errors)), options.plausible)

    found = beyond(nominal)
    if found is not None and not register:
        found = beyond(_side(nominal.prepared, nominal.x, True, options))
    return None if found is None else implausible_data(found, nominal.prepared.robot, nominal.prepared.samples,
                                                       nominal.prepared.models, options, beyond(model) is None)


def check_content(check: Check, sources: Mapping[str, Any]) -> dict[str, Any]:
    """The report JSON of a check (docs/check.md): SI units, lengths in m, angles in rad."""
    models: list[Measurement] = check.model.prepared.models
    ids = check.sample_ids
    outside = [k for k, s in enumerate(ids) if s in set(check.outside_samples)]
    inside = [k for k in range(len(ids)) if k not in set(outside)]
    content: dict[str, Any] = {
        "format": "pincal check 1",
        "units": "SI: m, rad",
        **dict(sources),
        "registered": check.registered,
        "model_means": model_means(check.model.prepared.parameters, check.registered),
        "nominal_means": labelled(NOMINAL_AS_CALIBRATED if check.nominal.converged is None and not check.registered
                                  else nominal_means(check.nominal.prepared.parameters),
                                  check.nominal.prepared.robot.source),
        "registration_notes": {side: s.note for side, s in (("model", check.model), ("nominal", check.nominal))
                               if s.note},
        "n_samples_in_file": check.n_samples_in_file,
        "measurements": [m.key for m in models],
        **check.figures(),
        "worse_than_nominal": check.worse_than_nominal,
        "groups": check.groups(),
        "worse_beyond": check.worse_beyond,
        "implausible": check.implausible.content() if check.implausible is not None else None,
        "quantities": check.quantities(),
        "samples": check.samples(),
        "dropped_samples": check.dropped,
        "outside_range": {"known": check.range_note is None, "note": check.range_note,
                          "readings": check.outside_range, "samples": check.outside_samples,
                          **(check.figures(outside) if outside else {})},
        "inside_range": check.figures(inside) if outside else None,
        "predicted": check.predicted_account(),
        "pixel_predicted": pixel_check.pixel_account(check.pixel_bounds,
                                                     pixel_check.image_errors(check.model.errors, len(ids))),
        "setup": {"parameters": list(check.model.prepared.parameters.names),
                  "model": check.model.setup(), "nominal": check.nominal.setup(),
                  "model_converged": check.model.converged, "nominal_converged": check.nominal.converged},
    }
    return content


def run_check(model_path: str, data_path: str, nominal_path: str | None, options: GivenOptions,
              register: bool = False, outputs: Sequence[tuple[str, str]] = (),
              rows: str | None = None) -> tuple[Check, dict[str, Any]]:
    """``pincal check`` from files: MODEL (a calibrated URDF, a robot name or a report JSON), DATA (a CSV or a job
    file, whose options apply under ``options``, those given with where each was given), the nominal robot
    (``nominal_path``, else the one MODEL records); ``rows`` the set checked (``train`` or ``test``: a CSV's ``set``
    column, a job's ``held_out`` rows; None: every row); ``outputs`` (``(what, path)``) are checked before any work
    (never over an input). Returns the check and its report content.

    Raises:
        DataError: no nominal robot given or recorded, or one given that MODEL does not record; no row of set
            ``rows``; as :func:`check_model`.
    """
    from pincal.calibration.check_model import check_arguments, is_report, load_model, load_nominal
    from pincal.calibration.job import read_job
    from pincal.calibration.job_data import job_dataset
    from pincal.calibration.provenance import file_digests, read_provenance, sha256, version
    from pincal.calibration.samples import read_robot_dataset
    from pincal.io.corrections_file import corrections_path
    from pincal.io.files import check_outputs

    check_arguments(model_path, data_path)
    if is_report(model_path):  # an unreadable report is named as such, not as one that records nothing
        try:
            json.loads(Path(model_path).read_text(encoding="utf-8"))
        except (OSError, UnicodeDecodeError, json.JSONDecodeError) as exc:
            raise DataError(f"MODEL '{model_path}' is not a readable report JSON: {exc}") from None
    provenance = read_provenance(model_path)
    nominal_name = nominal_path or provenance.robot
    if nominal_name is None:
        raise DataError(f"MODEL '{model_path}' records no nominal robot (no pincal provenance in it): give the robot "
                        "it was calibrated from with nominal_path=ROBOT", option="nominal_path")
    nominal = load_nominal(model_path, nominal_path, nominal_name, provenance)
    job = read_job(data_path) if data_path.endswith(".toml") else None
    inputs: list[str | Path] = [model_path, corrections_path(model_path), data_path, *(job.files if job else ()),
                                *(p for p in (nominal.source, provenance.data) if p is not None)]
    check_outputs(outputs, inputs)
    given = job.options.over(options) if job is not None else options
    dataset = job_dataset(job, nominal) if job is not None else read_robot_dataset(data_path, nominal)
    n_rows = dataset.n_samples
    if rows is not None:
        dataset = rows_of_set(dataset, rows, data_path)
    model = load_model(model_path, nominal, dataset)
    fitted, note = fitted_data(model, nominal)
    changed = (nominal_path is None and provenance.robot_sha256 and nominal.source is not None
               and sha256(nominal.source) != provenance.robot_sha256)
    result = check_model(model, nominal, dataset, given.calibration, register, fitted, note)
    result = replace(result, n_samples_in_file=n_rows)
    nominal_file = nominal_name if Path(nominal_name).is_file() else None  # else a known robot, by its name
    sources = {"model": model_path, "nominal": nominal_name,
               "nominal_given": nominal_path is not None, "data": data_path, "rows": rows or "all",
               "provenance": {"pincal_version": version(),
                              "options": {**given.values, "register": register, "set": rows},
                              "sha256": file_digests(model_path, corrections_path(model_path), data_path,
                                                     *(job.files if job else ()), nominal_file)}}
    content = check_content(result, sources)
    if changed:
        content["nominal_changed"] = True
    return result, content


def rows_of_set(dataset: Dataset, name: str, data_path: str) -> Dataset:
    """The rows of ``dataset`` in set ``name`` (``train`` or ``test``).

    Raises:
        DataError: ``dataset`` has no row of that set.
    """
    chosen = dataset.of_set(name)
    if not chosen.n_samples:
        counts = ", ".join(f"{s} {dataset.sets.count(s)}" for s in sorted(set(dataset.sets)))
        raise DataError(f"DATA '{data_path}' has no set={name} row ({counts}): mark the rows to check in its 'set' "
                        "column, or a job file's held_out, or leave rows out to check every row", option="rows")
    return chosen
