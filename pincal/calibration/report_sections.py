"""The typed sections of the report: one frozen record per nested part of :class:`CalibrationReport`'s JSON.

Each record's fields are the keys of its JSON object, in the JSON's order; a field marked optional is left out of the
JSON while it holds None (a key the calibration writes only when it applies, e.g. a cross-validation's angle RMS
without pose readings). :meth:`Section.as_dict` gives the JSON object, :meth:`Section.from_json` reads one back: keys
this version does not know are left out, keys an older report lacks take their default, values are kept as the file
holds them. Units: SI (m, rad), as each record's docstring says.
"""

from __future__ import annotations

import dataclasses
from collections.abc import Callable, Mapping
from dataclasses import dataclass, field, fields
from typing import Any, TypeVar

from pincal.errors import DataError

S = TypeVar("S", bound="Section")

#: The metadata of a field left out of the JSON while it holds None.
OPTIONAL = {"optional": True}


def _expect_mapping(value: Any, where: str) -> Mapping[str, Any]:
    if not isinstance(value, dict):
        raise DataError(f"{where} is not a JSON object: expected a report written by 'pincal calibrate --report'")
    return value


def nested(reader: Callable[[Any, str], Any], **metadata: Any) -> dict[str, Any]:
    """The metadata of a field whose JSON value ``reader(value, where)`` reads (a section, or sections by name)."""
    return {"read": reader, **metadata}


@dataclass(frozen=True)
class Section:
    """A nested part of the report JSON as a record: its fields are the JSON object's keys, in order."""

    def as_dict(self) -> dict[str, Any]:
        """The JSON object: every field in order, the optional ones that hold None left out; nested sections as
        their own objects."""
        return {f.name: _plain(getattr(self, f.name)) for f in fields(self) if not f.metadata.get("internal")
                and not (f.metadata.get("optional") and getattr(self, f.name) is None)}

    @classmethod
    def from_json(cls: type[S], value: Any, where: str) -> S:
        """The section of a parsed JSON object ``value`` (``where`` names it in errors, e.g. ``the result JSON's
        'cv'``): its known keys, each read by its field's reader; keys it lacks take their default.

        Raises:
            DataError: ``value`` is not an object, lacks a key without default, or a nested part is not one.
        """
        content = _expect_mapping(value, where)
        given: dict[str, Any] = {}
        for f in fields(cls):
            if f.metadata.get("internal"):
                continue
            if f.name not in content:
                if f.default is dataclasses.MISSING and f.default_factory is dataclasses.MISSING:
                    raise DataError(f"{where} has no '{f.name}': expected a report written by 'pincal calibrate "
                                    "--report'")
                continue
            reader = f.metadata.get("read")
            item = content[f.name]
            given[f.name] = reader(item, f"{where}['{f.name}']") if reader is not None and item is not None else item
        return cls(**given)


def _plain(value: Any) -> Any:
    """``value`` with every section made its JSON object, through lists, tuples and dicts."""
    if isinstance(value, Section):
        return value.as_dict()
    if isinstance(value, dict):
        return {k: _plain(v) for k, v in value.items()}
    if isinstance(value, (list, tuple)):
        return [_plain(v) for v in value]
    return value


def by_name(section: type[S]) -> Callable[[Any, str], dict[str, S]]:
    """The reader of a JSON object of ``section``s by name."""

    def read(value: Any, where: str) -> dict[str, S]:
        return {name: section.from_json(item, f"{where}['{name}']")
                for name, item in _expect_mapping(value, where).items()}

    return read


def listed(section: type[S]) -> Callable[[Any, str], list[S]]:
    """The reader of a JSON list of ``section``s."""

    def read(value: Any, where: str) -> list[S]:
        if not isinstance(value, list):
            raise DataError(f"{where} is not a JSON list: expected a report written by 'pincal calibrate --report'")
        return [section.from_json(item, f"{where}[{k}]") for k, item in enumerate(value)]

    return read


@dataclass(frozen=True)
class ParameterEstimate(Section):
    """One parameter's estimate.

    Attributes:
        value: The estimate [m, rad, or the parameter's unit: px for intrinsics, rad/(N·m) for compliances], as a
            correction of the nominal robot.
        std: Its standard deviation [same unit]; None where the fit could not give it.
        identified: Whether the data identify it (False: left at minimum norm).
    """

    value: float
    std: float | None = None
    identified: bool = False


@dataclass(frozen=True)
class CrossValidation(Section):
    """The cross-validation's account (``--cv``): each fold fitted without its samples predicts them.

    Attributes:
        plan: The folds, e.g. ``"5-fold × 4"`` (with the seed when it is not 0).
        n_samples: Samples cross-validated.
        n_predictions: Length errors predicted (pooled over folds and repeats).
        rms: RMS of the predicted length errors [m]; None when no fold could be fitted.
        failed_folds: Each failed fold's account (``"repeat R, fold F: reason"``), left out.
        unconverged_folds: Fold fits that stopped before converging (their predictions count).
        rms_by_reading: The RMS [m] per length-type reading (None: none predicted), when there are several.
        rms_angle: RMS of the predicted orientation errors [rad], with pose readings.
    """

    plan: str
    n_samples: int = 0
    n_predictions: int = 0
    rms: float | None = None
    failed_folds: list[str] = field(default_factory=list)
    unconverged_folds: int = 0
    rms_by_reading: dict[str, float | None] | None = field(default=None, metadata=OPTIONAL)
    rms_angle: float | None = field(default=None, metadata=OPTIONAL)


@dataclass(frozen=True)
class RangeGuard(Section):
    """What the range guard found (:mod:`pincal.identification.guard`): the automatic prior held firmer when it
    predicts each joint's range halves worse than the nominal robot.

    Attributes:
        firmer: The divisor applied to the robot parameters' prior σ [1] (1: the chosen prior kept).
        beyond: The chosen prior's beyond score [σ²]: the mean square of the held-out rows' weighted residuals.
        inside: Its inside score [σ²].
        nominal_beyond: The nominal robot's beyond score [σ²].
        scores: Each divisor tried: ``[divisor, inside, beyond]`` [1, σ², σ²].
    """

    firmer: float = 1.0
    beyond: float | None = None
    inside: float | None = None
    nominal_beyond: float | None = None
    scores: list[list[float]] = field(default_factory=list)


@dataclass(frozen=True)
class ModelSelection(Section):
    """What model selection did (``--select``) and the prior it holds (``--prior``).

    Attributes:
        policy: The policy applied: ``evidence``, ``bic``, ``cv`` or ``none``.
        removed: The parameters left out (held at nominal).
        removed_groups: Their groups (``translations``, ``rotations``, ``offsets``, …).
        n_candidates: The candidate parameters selection chose among.
        prior_factors: The factor [1] on its kinds' prior σ each group is held by (0: left out); None when the prior
            is not automatic.
        guard: The range guard's account, when it ran.
        prior: The ``--prior`` asked for: a factor [1], ``auto``, or ``off``.
    """

    policy: str = "none"
    removed: list[str] = field(default_factory=list)
    removed_groups: list[str] = field(default_factory=list)
    n_candidates: int = 0
    prior_factors: dict[str, float] | None = None
    guard: RangeGuard | None = field(default=None, metadata=nested(RangeGuard.from_json))
    prior: float | str | None = None


@dataclass(frozen=True)
class ImplausibleCorrection(Section):
    """A correction beyond what a robot of this model plausibly needs (:mod:`pincal.calibration.plausibility`).

    Attributes:
        parameter: The parameter's name.
        kind: Its kind (``offset``, ``tx``, …).
        value: The smallest equivalent correction, what the data demand [its unit].
        fitted: The estimate the calibrated URDF holds [its unit].
        limit: The plausible limit times ``--plausible`` [its unit].
        unit: Its unit (``m``, ``rad``, …).
    """

    parameter: str
    kind: str
    value: float
    fitted: float
    limit: float
    unit: str


@dataclass(frozen=True)
class ImplausibleScale(Section):
    """A measured position whose spread differs from the nominal robot's beyond the plausible band.

    Attributes:
        measurement: The measurement's key.
        scale: Its spread over the nominal robot's at the same joint readings [1].
        limit: The largest plausible ratio, either way [1].
    """

    measurement: str
    scale: float
    limit: float


@dataclass(frozen=True)
class SampleError(Section):
    """One sample's error before and after calibration.

    Attributes:
        sample: The sample's id.
        set: ``train`` (fitted) or ``test`` (held out).
        before: Its length-type error [m] with the nominal robot, its setup registered; None: no length reading.
        after: Its length-type error [m] after calibration; None: no length reading.
        pixel_before: With pixel readings, its image's reprojection error [px] before (the RMS of its corners; None:
            no corner seen).
        pixel_after: The same after calibration [px].
        imaged: Whether the calibration read pixels (the two ``pixel_*`` keys are then written, None or not).
    """

    sample: str
    set: str = "train"
    before: float | None = None
    after: float | None = None
    pixel_before: float | None = None
    pixel_after: float | None = None
    imaged: bool = field(default=False, metadata={"internal": True})

    def as_dict(self) -> dict[str, Any]:
        """The JSON object: the ``pixel_*`` keys only with pixel readings."""
        out = super().as_dict()
        if not self.imaged:
            del out["pixel_before"], out["pixel_after"]
        return out

    @classmethod
    def from_json(cls, value: Any, where: str) -> SampleError:
        """The sample's errors of a JSON object (see :meth:`Section.from_json`)."""
        read = super().from_json(value, where)
        return dataclasses.replace(read, imaged="pixel_before" in value or "pixel_after" in value)


@dataclass(frozen=True)
class Coverage(Section):
    """How many errors lie within their predicted 95 % bound.

    Attributes:
        inside: Errors within their bound.
        samples: Errors with a bound.
        fraction: ``inside / samples`` [1]; None without samples.
    """

    inside: int = 0
    samples: int = 0
    fraction: float | None = None


@dataclass(frozen=True)
class PredictedSample(Section):
    """A held-out sample's predicted error (:mod:`pincal.calibration.predicted`).

    Attributes:
        sample: The sample's id.
        sigma: The predicted σ of each length row [m] (None: not known).
        bound: Its predicted 95 % bound [m], grown beyond the fitted range and capped (None: not known).
        linear_bound: The bound with no growth [m].
        distance: Its extrapolation distance beyond the fitted joint range [1] (0: inside).
        capped: Whether the nominal robot's own bound set it.
    """

    sample: str
    sigma: list[float | None] = field(default_factory=list)
    bound: float | None = None
    linear_bound: float | None = None
    distance: float = 0.0
    capped: bool = False


@dataclass(frozen=True)
class HeldOutPredictions(Section):
    """The held-out samples' predicted errors and how many of their errors the bounds hold.

    Attributes:
        level: The probability the bounds hold [1] (0.95).
        inside: Errors within their bound, of ``samples``; ``fraction`` the share [1].
        samples: Errors with a bound.
        fraction: ``inside / samples`` [1]; None without samples.
        in_range: The same of the samples within the fitted joint range.
        beyond_range: The same of the samples beyond it.
        median_bound: The bounds' median [m]; None: none known.
        beyond: The samples beyond the fitted range, by id.
        samples_predicted: Each sample's prediction.
        pixels: With pixel readings and the covariance, each held-out image's predicted reprojection bound
            (:func:`pincal.calibration.check_pixels.held_out_pixels`: ``median_bound`` [px], ``median_bound_at_board``
            [m], ``inside`` of ``images``, ``images_predicted``); left out of the JSON otherwise.
    """

    level: float = 0.95
    inside: int = 0
    samples: int = 0
    fraction: float | None = None
    in_range: Coverage | None = field(default=None, metadata=nested(Coverage.from_json))
    beyond_range: Coverage | None = field(default=None, metadata=nested(Coverage.from_json))
    median_bound: float | None = None
    beyond: list[str] = field(default_factory=list)
    samples_predicted: list[PredictedSample] = field(default_factory=list, metadata=nested(listed(PredictedSample)))
    pixels: dict[str, Any] | None = field(default=None, metadata=OPTIONAL)


@dataclass(frozen=True)
class WorkspacePrediction(Section):
    """The predicted error over the workspace: postures drawn within the joint limits.

    Attributes:
        postures: Postures drawn (those the calibrated robot closes).
        measurement: The measurement whose first point is predicted.
        positions: Each posture's predicted position of that point [m], in the measurement frame.
        bounds: Each posture's predicted 95 % bound [m] (None or inf: not known).
        distance: Each posture's extrapolation distance beyond the fitted joint range [1].
        outside_fitted_range: Postures beyond the fitted range.
        capped: Postures whose bound the nominal robot's own bound set.
        median_bound: The bounds' median [m]; None: none known.
        max_bound: Their maximum [m]; None: none known.
    """

    postures: int = 0
    measurement: str = ""
    positions: list[list[float]] = field(default_factory=list)
    bounds: list[float | None] = field(default_factory=list)
    distance: list[float] = field(default_factory=list)
    outside_fitted_range: int = 0
    capped: int = 0
    median_bound: float | None = None
    max_bound: float | None = None


@dataclass(frozen=True)
class DroppedSample(Section):
    """A sample of the file left out before the fit, and why.

    Attributes:
        sample: The sample's id.
        reason: Why, in words (e.g. outside the joint limits, forward kinematics did not converge).
    """

    sample: str
    reason: str = ""


@dataclass(frozen=True)
class DownWeighted(Section):
    """A fitted sample the robust loss down-weighted.

    Attributes:
        sample: The sample's id.
        weight: Its weight in the fit [1] (0: left out).
        error_after: Its length-type error after calibration [m]; None: no length reading.
    """

    sample: str
    weight: float = 1.0
    error_after: float | None = None


@dataclass(frozen=True)
class BadJointReading(Section):
    """A fitted sample left out (weight 0) because one wrong joint reading explains its error
    (:mod:`pincal.identification.readings`).

    Attributes:
        sample: The sample's id.
        joint: The actuated joint whose reading looks off.
        off: How far it looks off [rad, or m for a prismatic joint].
        unit: ``rad`` or ``m``.
        explained: The share of the sample's error that explains [1, 0–1].
    """

    sample: str
    joint: str
    off: float
    unit: str = "rad"
    explained: float = 0.0


@dataclass(frozen=True)
class OutsideRange(Section):
    """A held-out sample's actuated-joint reading outside the range the calibration fitted (its error measures
    extrapolation).

    Attributes:
        sample: The sample's id.
        joint: The actuated joint.
        value: Its reading [rad or m].
        range: The fitted range [min, max] [rad or m].
    """

    sample: str
    joint: str
    value: float
    range: list[float] = field(default_factory=list)


@dataclass(frozen=True)
class Covariance(Section):
    """The estimates' covariance over the identified parameters, as the fit gives it.

    Attributes:
        parameters: The identified parameters, in the matrix's order.
        matrix: ``C_ij = ρ_ij σ_i σ_j`` [products of the parameters' units: m², m·rad, rad²]; None where the fit
            could not give it.
    """

    parameters: list[str] = field(default_factory=list)
    matrix: list[list[float | None]] = field(default_factory=list)


@dataclass(frozen=True)
class EstimatedSigma(Section):
    """The σ of one measurement's readings estimated from the data, where no ``# sigma`` line states it
    (:mod:`pincal.calibration.noise`).

    Attributes:
        rows: Each estimated residual row's σ, by row name [its unit].
        units: Each row's unit (``m``, ``rad``, ``px``, …).
        length: The RMS of its estimated length rows [m], when asked of this kind.
        angle: The RMS of its estimated angle rows [rad], when asked of this kind.
    """

    rows: dict[str, float] = field(default_factory=dict)
    units: dict[str, str] = field(default_factory=dict)
    length: float | None = field(default=None, metadata=OPTIONAL)
    angle: float | None = field(default=None, metadata=OPTIONAL)


@dataclass(frozen=True)
class PixelErrors(Section):
    """The RMS reprojection error of the pixel readings, before and after calibration.

    Attributes:
        rms_before: Before [px]: the nominal robot, its setup registered; None: not a number.
        rms_after: After calibration [px]; None: not a number.
    """

    rms_before: float | None = None
    rms_after: float | None = None


@dataclass(frozen=True)
class FileDigest(Section):
    """An input file as an output records it.

    Attributes:
        file: Its name: a path relative to the output's folder, or a catalog robot's name.
        sha256: Its SHA-256 (None: not a file).
    """

    file: str
    sha256: str | None = None


@dataclass(frozen=True)
class ProvenanceRecord(Section):
    """What made the report (:mod:`pincal.calibration.provenance`).

    Attributes:
        pincal_version: The pincal version that wrote it.
        robot: The robot file (or name) with its SHA-256.
        data: The data files read (a job file and its data files) with their SHA-256.
        options: Every calibration option, by its job-file key (values in SI units, as the job file writes them).
    """

    pincal_version: str = ""
    robot: FileDigest | None = field(default=None, metadata=nested(FileDigest.from_json))
    data: list[FileDigest] = field(default_factory=list, metadata=nested(listed(FileDigest)))
    options: dict[str, Any] = field(default_factory=dict)
