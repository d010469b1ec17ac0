"""The typed sections of the report: one frozen record per nested part of :class:`CalibrationReport`'s JSON.

Each record's fields are the keys of its JSON object, in the JSON's order; a field marked optional is left out of the
JSON while it holds None (a key the calibration writes only when it applies, e.g. a cross-validation's angle RMS
without pose readings). :meth:`Section.as_dict` gives the JSON object, :meth:`Section.from_json` reads one back: keys
this version does not know are left out, keys an older report lacks take their default, values are kept as the file
holds them. Units: SI (m, rad), as each record's docstring says.
"""

from __future__ import annotations

import dataclasses
from dataclasses import field
from typing import Any

from pincal.calibration.section import OPTIONAL, Section, listed, nested, square
from pincal.records import record


@record(frozen=True)
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


@record(frozen=True)
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


@record(frozen=True)
class RangeGuard(Section):
    """What the range guard found (:mod:`pincal.identification.guard`): the automatic prior held firmer when it
    predicts each joint's range halves worse than the nominal robot, or when a firmer one predicts the hold-outs (range
    halves and shuffled folds) better beyond chance.

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


@record(frozen=True)
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


@record(frozen=True)
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


@record(frozen=True)
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


@record(frozen=True)
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


@record(frozen=True)
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


@record(frozen=True)
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


@record(frozen=True)
class PredictedImage(Section):
    """A held-out image's reprojection error beside its predicted bound.

    Attributes:
        sample: The image's sample id.
        pixel_error: Its RMS reprojection error after the fit [px]; None: not a number.
        pixel_bound: Its predicted 95 % bound [px], the noise included; ``pixel_model_bound`` the model's part alone.
        pixel_bound_at_board: The bound at the board [m].
    """

    sample: str
    pixel_error: float | None = None
    pixel_bound: float | None = None
    pixel_model_bound: float | None = None
    pixel_bound_at_board: float | None = None


@record(frozen=True)
class PixelAccount(Section):
    """Images' predicted reprojection bounds and how many of their errors the bounds hold
    (:meth:`pincal.calibration.check_pixels.PixelBounds.account`): ``pincal check``'s ``pixel_predicted``.

    Attributes:
        level: The probability the bounds hold [1] (0.95).
        unit: The bounds' unit (``px``).
        inside: Images whose error is within their bound, of ``images`` (those with a bound and an error).
        median_bound: The bounds' median [px]; ``median_model_bound`` the model's part alone; None: none known.
        median_bound_at_board: The bounds' median at the board [m]; None: none known.
    """

    level: float = 0.95
    unit: str = "px"
    inside: int = 0
    images: int = 0
    median_bound: float | None = None
    median_model_bound: float | None = None
    median_bound_at_board: float | None = None


@record(frozen=True)
class PixelPredictions(PixelAccount):
    """The held-out images' :class:`PixelAccount` and each image's error beside its bounds
    (:func:`pincal.calibration.check_pixels.held_out_pixels`).

    Attributes:
        images_predicted: Each image's error and bounds.
    """

    images_predicted: list[PredictedImage] = field(default_factory=list, metadata=nested(listed(PredictedImage)))


@record(frozen=True)
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
        pixels: With pixel readings and the covariance, the held-out images' predicted reprojection bounds; left out
            of the JSON otherwise.
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
    pixels: PixelPredictions | None = field(default=None, metadata=nested(PixelPredictions.from_json, **OPTIONAL))


@record(frozen=True)
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


@record(frozen=True)
class DroppedSample(Section):
    """A sample of the file left out before the fit, and why.

    Attributes:
        sample: The sample's id.
        reason: Why, in words (e.g. outside the joint limits, forward kinematics did not converge).
    """

    sample: str
    reason: str = ""


@record(frozen=True)
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


@record(frozen=True)
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


@record(frozen=True)
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


@record(frozen=True)
class Covariance(Section):
    """The estimates' covariance over the identified parameters, as the fit gives it.

    Attributes:
        parameters: The identified parameters, in the matrix's order.
        matrix: ``C_ij = ρ_ij σ_i σ_j`` [products of the parameters' units: m², m·rad, rad²]; None where the fit
            could not give it.
    """

    parameters: list[str] = field(default_factory=list)
    matrix: list[list[float | None]] = field(default_factory=list)

    @classmethod
    def from_json(cls, value: Any, where: str) -> Covariance:
        """The covariance of a JSON object: n names and an n × n matrix (:func:`~pincal.calibration.section.square`).
        """
        read: Covariance = Section.from_json.__func__(cls, value, where)  # type: ignore[attr-defined]
        square(read.parameters, read.matrix, where)
        return read


@record(frozen=True)
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


@record(frozen=True)
class PixelErrors(Section):
    """The RMS reprojection error of the pixel readings, before and after calibration.

    Attributes:
        rms_before: Before [px]: the nominal robot, its setup registered; None: not a number.
        rms_after: After calibration [px]; None: not a number.
    """

    rms_before: float | None = None
    rms_after: float | None = None


@record(frozen=True)
class CameraRecord(Section):
    """A camera that pixel readings see, as the calibration left it.

    Attributes:
        frame: The frame it is on (empty: fixed in the cell).
        board: The board it sees (its spec, ``charuco:…``), or None.
        held: Whether its intrinsics were held at the data's values.
        intrinsics: The calibrated model's intrinsics, the data's nominal plus the estimate: ``fx, fy, cx, cy`` [px],
            ``k1, k2, p1, p2, k3`` [1].
        std: Their standard deviations [px, 1] (None: held, or not known).
    """

    frame: str
    board: str | None = None
    held: bool = False
    intrinsics: dict[str, float] = field(default_factory=dict)
    std: dict[str, float | None] = field(default_factory=dict)


@record(frozen=True)
class FileDigest(Section):
    """An input file as an output records it.

    Attributes:
        file: Its name: a path relative to the output's folder, or a catalog robot's name.
        sha256: Its SHA-256 (None: not a file).
    """

    file: str
    sha256: str | None = None


@record(frozen=True)
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
