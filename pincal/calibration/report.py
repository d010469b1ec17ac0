"""The typed report of a calibration: :class:`CalibrationReport`, built once by
:func:`~pincal.calibration.pipeline.calibrate` from the parts :func:`fit_figures`, :func:`before_figures` and the
pipeline give, its nested parts typed sections (:mod:`pincal.calibration.report_sections`).

Its fields are the keys of the report JSON (``pincal calibrate --report``, docs/report.md), in the JSON's order; a
field that holds None and is marked optional is left out of the JSON (e.g. held-out figures without held-out
samples). The JSON records its layout's :data:`SCHEMA_VERSION`; :meth:`CalibrationReport.from_json` reads the reports
of this version and older ones, and refuses newer ones. The terminal summary, the JSON, the HTML page, the 3D scene
and ``fleet`` read it by attribute; none of them recomputes a figure. Units: SI (m, rad). Wall-clock time is left
out: the same inputs give a byte-identical file.
"""

from __future__ import annotations

import json
import math
from collections.abc import Collection
from dataclasses import field, fields
from pathlib import Path
from typing import Any

import numpy as np
import numpy.typing as npt

from pincal.calibration import section
from pincal.calibration.covariance import parameter_covariance
from pincal.calibration.growth import ErrorGrowth
from pincal.calibration.on_demand import on_demand
from pincal.calibration.provenance import labelled
from pincal.calibration.report_sections import (
    BadJointReading,
    CameraRecord,
    Covariance,
    CrossValidation,
    DownWeighted,
    DroppedSample,
    EstimatedSigma,
    HeldOutPredictions,
    ImplausibleCorrection,
    ImplausibleScale,
    ModelSelection,
    OutsideRange,
    ParameterEstimate,
    PixelErrors,
    ProvenanceRecord,
    SampleError,
    WorkspacePrediction,
)
from pincal.calibration.section import OPTIONAL, Section, by_name, listed, nested
from pincal.calibration.setup_parameters import setup_columns
from pincal.errors import DataError
from pincal.identification.corrections import Payload, payload_from_dict
from pincal.identification.measurements import KIND_CLASSES
from pincal.identification.metrics import angle_error_norms, calibration_gain, error_norms, pixel_error_norms, rms
from pincal.identification.parameters import ParameterSet, kinds_where, parameter_kind
from pincal.identification.problem import CalibrationProblem
from pincal.identification.result import CalibrationResult
from pincal.io.files import json_text
from pincal.records import record

Array = npt.NDArray[np.float64]

#: The report JSON's layout version: a reader refuses a newer one.
SCHEMA_VERSION = 1

BEFORE_MEANS_REGISTERED = ("the nominal robot, with the measurement frame registered to the training data in "
                           "closed form (Kabsch), for fit and held-out samples alike")
BEFORE_MEANS_NOMINAL = "the nominal robot in the nominal measurement frame, for fit and held-out samples alike"



def _read_growth(value: Any, where: str) -> ErrorGrowth:
    """The bound's growth of a JSON object (:meth:`ErrorGrowth.as_dict`'s).

    Raises:
        DataError: not an object of its keys and numbers.
    """
    growth = ErrorGrowth.from_dict(value) if isinstance(value, dict) else None
    numbers = ("rho0", "nominal0", "nominal1", "reach", "inside", "beyond")
    if growth is not None and any(isinstance(value.get(key), (bool, str)) for key in numbers):
        growth = None  # a word or a truth value where a number belongs: not a report pincal wrote
    if growth is None:
        raise DataError(f"{where} is not an object of numbers 'rho0', 'nominal0', 'nominal1', 'reach', 'inside', "
                        "'beyond': expected a report written by 'pincal calibrate --report'")
    given = {"rho0": growth.rho0, "nominal1": growth.nominal1, "reach": growth.reach, "inside": growth.inside,
             "beyond": growth.beyond}
    if value.get("nominal0") is not None:  # null: the nominal robot's bound not known
        given["nominal0"] = growth.nominal0
    bad = [key for key, v in given.items() if not math.isfinite(v) or v < 0 or (key == "rho0" and v == 0)]
    if bad:
        raise DataError(f"{where}['{bad[0]}'] is {value.get(bad[0])!r}, not a finite number "
                        f"{'> 0' if bad[0] == 'rho0' else '≥ 0'}: expected a report written by 'pincal calibrate "
                        "--report'")
    return growth


def _read_payload(value: Any, where: str) -> Payload | None:
    """The payload of a JSON object (:meth:`Payload.as_dict`'s).

    Raises:
        DataError: not such an object, or a bad value.
    """
    return payload_from_dict(value, f"{where}: ")


@on_demand("error_growth", "predicted_workspace")
@record(frozen=True)
class CalibrationReport:
    """A calibration's figures and account; every length in m, every angle in rad.

    The fit's figures (``rms_before`` … ``max_after``) are over the fitted samples' readings; the held-out ones
    (``test_*``) over the held-out samples', "before" being the nominal robot with its setup registered in both
    (``before_means`` says what that is; the fit's start is ``rms_start``, ``test_rms_start``, ``start_means``).
    ``parameters`` maps each parameter to its estimate (:class:`~pincal.calibration.report_sections.ParameterEstimate`);
    ``dropped_samples`` and ``down_weighted`` list samples by id with the reason or weight; ``bad_readings`` the fitted
    samples left out (weight 0) because one wrong joint reading explains their error; each nested part is a record
    of :mod:`~pincal.calibration.report_sections`, with its units;
    ``cv`` is the cross-validation's account (:class:`~pincal.calibration.report_sections.CrossValidation`).
    ``error_growth`` and ``predicted_workspace`` may be computed when first read (:mod:`~pincal.calibration.on_demand`,
    from :func:`~pincal.calibration.pipeline.calibrate`): until then the report holds the fit they are computed from
    (read them, or write the JSON, before keeping many reports).
    ``length_scale`` is each measured position's spread over the nominal robot's at the same readings; ``implausible``
    and ``implausible_scale`` list the corrections and the scales beyond what a robot of this model plausibly needs
    (the factor ``plausible`` on the documented limits, :mod:`pincal.calibration.plausibility`), and
    ``implausible_cause`` says what they most likely come from; ``explains_nothing`` is true when the residuals stay
    beyond 1000 × σ after calibration with more than half the start's error left
    (:data:`~pincal.calibration.plausibility.EXPLAINS_NOTHING`): not a result, and
    no calibrated URDF is written of it unless forced. ``no_effect`` names the default candidates left out
    because they move no measurement of the fitted samples. ``fitted_range`` is each actuated joint's range
    [min, max] [rad or m] in the fitted samples (those that move what is measured); ``predicted_held_out`` the held-out
    samples' predicted errors (σ per length row and the 95 % bound [m], widened beyond the fitted range) and how many
    errors lie within their bound, ``predicted_workspace`` the predicted 95 % bound [m] at postures drawn within the
    joint limits (:mod:`pincal.calibration.predicted`). ``error_growth`` and ``predicted_workspace`` are computed when
    first read (:mod:`pincal.calibration.on_demand`): a caller that reads neither does not pay for them.
    ``declared_markers`` holds the nominal offset [m, in its frame] of each declared marker (``<frame>@<marker>``) the
    calibration read, as the data declared it (zero when they did not): the calibrated robot's marker links are these
    plus the ``marker.*``/``cluster.*`` estimates.
    ``row_sigma`` holds the σ [m, rad] of each measurement's residual rows the fit weighed them by (stated, or
    estimated). ``estimated_sigma`` holds the σ [m, rad] estimated from
    the data for the readings no ``# sigma`` line (nor ``--sigma``) states, per measurement key: per residual row
    (``rows``, with their ``units``) and per row kind (``length``, ``angle``: the RMS of its rows;
    :mod:`pincal.calibration.noise`).
    """

    schema_version: int = SCHEMA_VERSION
    robot: str = ""
    units: str = "SI: m, rad"
    n_samples: int = 0
    measurements: list[str] = field(default_factory=list)
    readings: dict[str, int] = field(default_factory=dict)
    readings_not_seen: dict[str, int] = field(default_factory=dict)
    n_parameters: int = 0
    n_identifiable: int = 0
    condition_number: float | None = None
    rms_before: float | None = None
    rms_after: float | None = None
    max_before: float | None = None
    max_after: float | None = None
    before_means: str = ""
    before_parameters: dict[str, float] = field(default_factory=dict, metadata=nested(section.numbers_by_name))
    rms_start: float | None = field(default=None, metadata=OPTIONAL)
    rms_angle_start: float | None = field(default=None, metadata=OPTIONAL)
    start_means: str = ""
    iterations: int = 0
    converged: bool = False
    message: str = ""
    solver: str = ""
    loss: str = ""
    sigma2: float | None = field(default=None, metadata=nested(section.at_least(0.0)))
    cost_history: list[float] = field(default_factory=list)
    parameters: dict[str, ParameterEstimate] = field(default_factory=dict,
                                                     metadata=nested(by_name(ParameterEstimate)))
    unidentifiable: list[str] = field(default_factory=list)
    down_weighted_samples: list[str] = field(default_factory=list)
    reference_shifts: dict[str, float] = field(default_factory=dict)
    rms_angle_before: float | None = field(default=None, metadata=OPTIONAL)
    rms_angle_after: float | None = field(default=None, metadata=OPTIONAL)
    #: Reprojection RMS [px] of the pixel readings, fitted and held out, before and after.
    pixels: PixelErrors | None = field(default=None, metadata=nested(PixelErrors.from_json, **OPTIONAL))
    test_pixels: PixelErrors | None = field(default=None, metadata=nested(PixelErrors.from_json, **OPTIONAL))
    #: Each pixel camera's calibrated intrinsics and their σ (:func:`camera_figures`).
    cameras: dict[str, CameraRecord] | None = field(default=None, metadata=nested(by_name(CameraRecord), **OPTIONAL))
    max_angle_before: float | None = field(default=None, metadata=OPTIONAL)
    max_angle_after: float | None = field(default=None, metadata=OPTIONAL)
    calibration_gain: float | None = field(default=None, metadata=OPTIONAL)
    parameter_errors_before: float | None = field(default=None, metadata=OPTIONAL)
    parameter_errors_after: float | None = field(default=None, metadata=OPTIONAL)
    #: Each joint's corrections by term (``compliance`` [rad/(N·m) or m/N], ``sin1``, ``cos1`` … [rad or m]), as the
    #: corrections file beside the calibrated URDF holds them (:mod:`pincal.io.corrections_file`).
    corrections: dict[str, dict[str, float]] = field(default_factory=dict)
    payload: Payload | None = field(default=None, metadata=nested(_read_payload))
    links_mass: float | None = field(default=None, metadata=OPTIONAL)
    markers: str = "each"
    declared_markers: dict[str, list[float]] = field(default_factory=dict)
    formulation: str = "fkm"
    selection: ModelSelection | None = field(default=None, metadata=nested(ModelSelection.from_json, **OPTIONAL))
    unidentifiable_listing: list[str] = field(default_factory=list)
    unidentifiable_digest: str = ""
    n_estimated: int = 0
    n_residuals: int = 0
    joints_at_reference: list[str] = field(default_factory=list)
    no_effect: list[str] = field(default_factory=list)
    dropped_samples: list[DroppedSample] = field(default_factory=list, metadata=nested(listed(DroppedSample)))
    down_weighted: list[DownWeighted] = field(default_factory=list, metadata=nested(listed(DownWeighted)))
    bad_readings: list[BadJointReading] = field(default_factory=list, metadata=nested(listed(BadJointReading)))
    n_samples_in_file: int = 0
    outlier_test: list[str] = field(default_factory=list)
    dropped_test_samples: list[DroppedSample] | None = field(default=None,
                                                             metadata=nested(listed(DroppedSample), **OPTIONAL))
    held_out_outliers: list[str] | None = field(default=None, metadata=OPTIONAL)
    held_out_outside_range: list[OutsideRange] | None = field(default=None,
                                                              metadata=nested(listed(OutsideRange), **OPTIONAL))
    test_readings: dict[str, int] | None = field(default=None, metadata=OPTIONAL)
    n_test_samples: int | None = field(default=None, metadata=OPTIONAL)
    test_rms_before: float | None = field(default=None, metadata=OPTIONAL)
    test_rms_after: float | None = field(default=None, metadata=OPTIONAL)
    test_max_before: float | None = field(default=None, metadata=OPTIONAL)
    test_max_after: float | None = field(default=None, metadata=OPTIONAL)
    test_rms_angle_before: float | None = field(default=None, metadata=OPTIONAL)
    test_rms_angle_after: float | None = field(default=None, metadata=OPTIONAL)
    test_max_angle_before: float | None = field(default=None, metadata=OPTIONAL)
    test_max_angle_after: float | None = field(default=None, metadata=OPTIONAL)
    test_rms_start: float | None = field(default=None, metadata=OPTIONAL)
    test_rms_angle_start: float | None = field(default=None, metadata=OPTIONAL)
    worse_than_nominal: bool | None = field(default=None, metadata=OPTIONAL)
    length_scale: dict[str, float] = field(default_factory=dict)
    plausible: float | str = 1.0
    implausible: list[ImplausibleCorrection] = field(default_factory=list,
                                                     metadata=nested(listed(ImplausibleCorrection)))
    implausible_scale: list[ImplausibleScale] = field(default_factory=list, metadata=nested(listed(ImplausibleScale)))
    implausible_cause: str = ""
    explains_nothing: bool = False
    cv: CrossValidation | None = field(default=None, metadata=nested(CrossValidation.from_json, **OPTIONAL))
    estimated_sigma: dict[str, EstimatedSigma] | None = field(default=None,
                                                              metadata=nested(by_name(EstimatedSigma), **OPTIONAL))
    sample_errors: list[SampleError] = field(default_factory=list, metadata=nested(listed(SampleError)))
    covariance: Covariance | None = field(default=None, metadata=nested(Covariance.from_json, **OPTIONAL))
    fitted_range: dict[str, list[float]] = field(default_factory=dict, metadata=nested(section.ranges_by_name))
    error_growth: ErrorGrowth | None = field(default=None, metadata=nested(_read_growth, **OPTIONAL))
    row_sigma: dict[str, list[float]] = field(default_factory=dict, metadata=nested(section.positive_lists_by_name))
    predicted_workspace: WorkspacePrediction | None = field(default=None,
                                                            metadata=nested(WorkspacePrediction.from_json, **OPTIONAL))
    predicted_held_out: HeldOutPredictions | None = field(default=None,
                                                          metadata=nested(HeldOutPredictions.from_json, **OPTIONAL))
    provenance: ProvenanceRecord | None = field(default=None, metadata=nested(ProvenanceRecord.from_json, **OPTIONAL))
    #: The JSON keys a report read by :meth:`from_json` held (every field for a report built by a calibration).
    present: frozenset[str] = field(default=frozenset(), compare=False, repr=False, metadata={"internal": True})

    def __post_init__(self) -> None:
        if not self.present:
            object.__setattr__(self, "present", frozenset(f.name for f in fields(self)
                                                          if not f.metadata.get("internal")))

    @property
    def has_held_out(self) -> bool:
        """True when held-out samples were evaluated (the ``test_*`` figures are there; a figure of a quantity the
        held-out samples do not measure is None, or NaN before the report is written)."""
        return self.n_test_samples is not None

    @property
    def error_words(self) -> tuple[str, str]:
        """What the length errors and the angle errors are: ``("position", "orientation")``, ``("plane distance",
        "tilt")`` for frames on planes, ``("distance", …)`` for distance readings, as the measured kinds say
        (``Measurement.error_words``); ``"length"`` and ``"angle"`` when kinds that say it differently mix."""
        classes = [KIND_CLASSES.get(key.partition(":")[0]) for key in self.measurements]
        lengths = {kind.error_words[0] for kind in classes if kind is not None and kind.length_rows}
        angles = {kind.error_words[1] for kind in classes if kind is not None and kind.angle_rows}
        length = lengths.pop() if len(lengths) == 1 else ("length" if lengths else "position")
        angle = angles.pop() if len(angles) == 1 else ("angle" if angles else "orientation")
        return length, angle

    @property
    def is_implausible(self) -> bool:
        """True when a correction or the data's length scale is beyond what a robot of this model plausibly needs."""
        return bool(self.implausible or self.implausible_scale)

    @property
    def usable(self) -> bool:
        """Whether the result may be used: converged, not worse than nominal on the held-out samples, plausible, and a
        fit that explains its data."""
        return bool(self.converged) and not self.worse_than_nominal and not self.is_implausible \
            and not self.explains_nothing

    def to_json(self) -> str:
        """The report JSON: indented, in field order, optional fields that hold None left out."""
        return json_text(self.as_dict())

    def as_dict(self, keys: Collection[str] | None = None) -> dict[str, Any]:
        """The JSON's content as a dict (the optional fields that hold None left out; a figure that is not a number,
        e.g. the RMS length error of samples with no length reading, as None: JSON has no NaN); only the fields named
        in ``keys`` if given (a calibrated URDF's: not every sample's records)."""
        return {f.name: _json_value(getattr(self, f.name)) for f in fields(self) if not f.metadata.get("internal")
                and (keys is None or f.name in keys)
                and not (f.metadata.get("optional") and getattr(self, f.name) is None)}

    @classmethod
    def from_json(cls, content: Any, source: str = "the result JSON") -> CalibrationReport:
        """A report from parsed report JSON (``json.loads`` of a file ``calibrate --report`` wrote). Values are kept
        as the file holds them (a page shows them escaped); keys this version does not know are left out.

        Raises:
            DataError: not a mapping with ``parameters`` of the form ``{name: {"value": number}}``, or written by a
                newer pincal (its ``schema_version``).
        """
        parameters = content.get("parameters") if isinstance(content, dict) else None

        def number(entry: Any) -> bool:
            return isinstance(entry, dict) and isinstance(entry.get("value"), int | float) \
                and math.isfinite(entry["value"])

        if not isinstance(parameters, dict) or not all(number(entry) for entry in parameters.values()):
            raise DataError(f"{source} has no 'parameters' of the form {{name: {{\"value\": number}}}}: expected a "
                            "report written by 'pincal calibrate --report'")
        version = content.get("schema_version", SCHEMA_VERSION)
        if isinstance(version, int) and version > SCHEMA_VERSION:
            raise DataError(f"{source} has schema_version {version}, newer than this pincal reads "
                            f"({SCHEMA_VERSION}): upgrade pincal")
        known = {f.name for f in fields(cls) if not f.metadata.get("internal")}
        given = {key: value for key, value in content.items() if key in known}
        present = frozenset(given) | {"parameters"}
        for f in fields(cls):
            reader = f.metadata.get("read")
            if reader is not None and given.get(f.name) is not None:
                given[f.name] = reader(given[f.name], f"{source}'s '{f.name}'")
        return cls(**given, present=present)

    @classmethod
    def read(cls, path: str | Path) -> CalibrationReport:
        """The report of a JSON file.

        Raises:
            DataError: the file cannot be read or is not a report (:meth:`from_json`).
        """
        try:
            content = json.loads(Path(path).read_text(encoding="utf-8"))
        except (OSError, json.JSONDecodeError, UnicodeDecodeError) as exc:
            raise DataError(f"cannot read the result JSON '{path}': {exc}") from None
        return cls.from_json(content, f"the result JSON '{path}'")


def registered_base(parameters: ParameterSet) -> bool:
    """True when the measurement frame is estimated whole (all six ``base.*``), so that the starting point
    registers it in closed form (:meth:`CalibrationProblem.initial_guess`)."""
    return len(parameters.groups("base").get(("base", "base", ""), [])) == 6


def before_means(problem: CalibrationProblem) -> str:
    """What the "before" errors are of: the starting point :meth:`CalibrationProblem.initial_guess` gave (the first
    attached kind of the parameters that says it, :meth:`~pincal.identification.parameters.ParameterKind.before_means`:
    cameras and targets placed by hand-eye, contact planes fitted to their points)."""
    for name in kinds_where(attached=True):
        means = parameter_kind(name).before_means(bool(problem.placed_in_closed_form))
        if means and problem.parameters.of_kind(name):
            return "; ".join([means, *problem.not_in_closed_form])
    return BEFORE_MEANS_REGISTERED if registered_base(problem.parameters) else BEFORE_MEANS_NOMINAL


def registered_means(parameters: ParameterSet, columns: list[int]) -> str:
    """What "before" is when the setup's parameters (``columns`` of ``parameters``) were fitted: the nominal robot with
    its measurement frame, markers, … registered to the training data (each kind's
    :attr:`~pincal.identification.parameters.ParameterKind.setup_words`)."""
    words: list[str] = []
    for k in columns:
        word = list(parameters)[k].kind_class.setup_words
        if word not in words:
            words.append(word)
    setup = ", ".join(words[:-1]) + f" and {words[-1]}" if len(words) > 1 else words[0]
    return (f"the nominal robot, its {setup} fitted to the training data with the robot's geometry at nominal "
            "(registered, as the calibration fits them), for fit and held-out samples alike")


def before_figures(problem: CalibrationProblem, before: Any) -> dict[str, Any]:
    """The report's "before" (``before``, a :class:`~pincal.calibration.heldout.Registration` of ``problem``): its
    errors on the fitted samples [m, rad], what it is, its setup's values, and the fit's start beside it when the
    registration moved off it."""
    norms, angles = error_norms(before.errors), angle_error_norms(before.errors)
    columns = setup_columns(problem.parameters)
    source = problem.robot.source  # a calibrated URDF given as the robot is named so, not "the nominal robot"
    out: dict[str, Any] = {
        "rms_before": _clean(rms(norms)), "max_before": _clean(float(norms.max())) if norms.size else None,
        "before_parameters": {problem.parameters.names[k]: float(before.x[k]) for k in columns},
        "before_means": labelled(registered_means(problem.parameters, columns) if before.registered
                                 else "; ".join(filter(None, [before_means(problem), before.note])), source)}
    if angles.size:
        out.update({"rms_angle_before": _clean(rms(angles)), "max_angle_before": _clean(float(angles.max()))})
    if pixel_error_norms(before.errors).size:  # the registered robot's reprojection error, beside the fit's after
        out["pixels_before"] = _clean(rms(pixel_error_norms(before.errors)))
    if before.registered:
        start, start_angles = error_norms(before.start_errors), angle_error_norms(before.start_errors)
        out.update({"rms_start": _clean(rms(start)), "start_means": labelled(before_means(problem), source),
                    "rms_angle_start": _clean(rms(start_angles)) if start_angles.size else None})
    return out


def _json_value(value: Any) -> Any:
    """``value`` with every float that is not finite made None, through sections, lists and dicts."""
    if isinstance(value, Section | ErrorGrowth | Payload):
        return _json_value(value.as_dict())
    if isinstance(value, float):
        return value if math.isfinite(value) else None
    if isinstance(value, dict):
        return {k: _json_value(v) for k, v in value.items()}
    if isinstance(value, (list, tuple)):
        return [_json_value(v) for v in value]
    return value


def _clean(v: float) -> float | None:
    return None if not math.isfinite(v) else float(v)


def fit_figures(result: CalibrationResult, problem: CalibrationProblem, x_true: Array | None = None) -> dict[str, Any]:
    """The fit's part of the report: errors before/after [m, rad], identifiability, estimates with their standard
    deviations, the solver's account (and the calibration gain when the truth ``x_true`` is known)."""
    before = error_norms(result.errors_before)
    after = error_norms(result.errors_after)
    ident = result.identifiability
    angles_before = angle_error_norms(result.errors_before)
    angles_after = angle_error_norms(result.errors_after)
    out: dict[str, Any] = {
        "robot": problem.robot.name,
        "n_samples": problem.observations.n_samples,
        "measurements": [m.key for m in problem.measurements],
        "readings": problem.n_readings(),
        "readings_not_seen": {m.key: problem.observations.n_samples - count for m, count
                              in zip(problem.measurements, problem.n_readings().values(), strict=True)
                              if m.occludable},
        "n_parameters": len(result.names),
        "n_identifiable": ident.rank,
        "condition_number": _clean(ident.condition_number),
        "rms_before": _clean(rms(before)),
        "rms_after": _clean(rms(after)),
        "max_before": _clean(float(before.max())) if before.size else None,
        "max_after": _clean(float(after.max())) if after.size else None,
        "before_means": before_means(problem),
        "iterations": result.iterations,
        "converged": result.converged,
        "message": result.message,
        "solver": result.solver,
        "loss": result.loss,
        "sigma2": _clean(result.sigma2),
        "cost_history": [float(c) for c in result.cost_history],
        "parameters": {name: ParameterEstimate(float(result.x[k]), _clean(float(result.std[k])),
                                               k in set(result.identified))
                       for k, name in enumerate(result.names)},
        "unidentifiable": [c.description for c in ident.unidentifiable],
        "covariance": covariance_of(result),
        "row_sigma": {m.key: [float(v) for v in m.row_sigmas()] for m in problem.measurements},
    }
    if angles_before.size:
        out.update({"rms_angle_before": _clean(rms(angles_before)), "rms_angle_after": _clean(rms(angles_after)),
                    "max_angle_before": _clean(float(angles_before.max())),
                    "max_angle_after": _clean(float(angles_after.max()))})
    pixels_before = pixel_error_norms(result.errors_before)
    if pixels_before.size:
        out["pixels"] = PixelErrors(rms_before=_clean(rms(pixels_before)),
                                    rms_after=_clean(rms(pixel_error_norms(result.errors_after))))
    cameras = camera_figures(problem, result)
    if cameras:
        out["cameras"] = cameras
    if x_true is not None:
        out["calibration_gain"] = _clean(calibration_gain(x_true, result.x0, result.x))
        out["parameter_errors_before"] = float(np.linalg.norm(x_true - result.x0))
        out["parameter_errors_after"] = float(np.linalg.norm(x_true - result.x))
    return out


def covariance_of(result: CalibrationResult) -> Covariance:
    """The estimates' covariance over the identified parameters (:func:`parameter_covariance`) [m², m·rad, rad²]:
    their names and the matrix (None where the fit could not give it)."""
    matrix = parameter_covariance(result)
    return Covariance(parameters=[result.names[k] for k in result.identified],
                      matrix=[[_clean(float(v)) for v in row] for row in matrix])


def camera_figures(problem: CalibrationProblem, result: CalibrationResult) -> dict[str, CameraRecord]:
    """Each camera that pixel readings see, by its intrinsics' prefix (``intrinsics.<frame>``, ``intrinsics`` for the
    fixed camera): its ``frame`` (empty: fixed in the cell), the ``board`` it sees, whether its intrinsics were
    ``held`` at the data's values, and the ``intrinsics`` the calibrated model has (the data's nominal plus the
    estimate; ``fx, fy, cx, cy`` [px], ``k1, k2, p1, p2, k3`` [1]) with their ``std`` (None: held, or not known)."""
    from pincal.identification.measurements.pixels import INTRINSICS, Pixel, intrinsics_name

    index = {name: k for k, name in enumerate(result.names)}
    out: dict[str, CameraRecord] = {}
    for m in problem.measurements:
        if not isinstance(m, Pixel) or intrinsics_name(m.camera) in out:
            continue
        prefix = intrinsics_name(m.camera)
        values: list[float] = list(m.intrinsics)
        stds: list[float | None] = [None for _ in INTRINSICS]
        for c, component in enumerate(INTRINSICS):
            k = index.get(f"{prefix}.{component}")
            if k is not None:
                values[c] += float(result.x[k])
                stds[c] = _clean(float(result.std[k]))
        out[prefix] = CameraRecord(frame=m.camera, board=m.board.spec if m.board is not None else None, held=m.held,
                                   intrinsics=dict(zip(INTRINSICS, values, strict=True)),
                                   std=dict(zip(INTRINSICS, stds, strict=True)))
    return out
