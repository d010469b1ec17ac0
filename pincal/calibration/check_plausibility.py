"""Whether the data ``pincal check`` reads can be of the nominal robot at all, judged as ``calibrate`` judges them.

A check compares two robots' predictions of DATA; data that belong to neither — another robot's, positions ten
times too large, two joint columns swapped, a joint read with the other sign — are predicted metres off by both, and
which of the two is worse then says nothing. So a check runs calibrate's checks:

- before any work, the units (:func:`~pincal.calibration.pipeline.check_units`: the measured positions' spread
  against the nominal robot's, joint columns read in too small a unit), refused as ``calibrate`` refuses them;
- after the registration, the nominal robot's errors with its measurement setup fitted to DATA: beyond what a
  robot of this model can be off by (:func:`beyond_plausible`: one placement's plausible correction, 20 mm or 2°,
  times the ``plausible`` factor, as an RMS over DATA), DATA are calibrated on the nominal robot exactly as
  ``pincal calibrate`` would calibrate them, and its plausibility check
  (:mod:`pincal.calibration.plausibility`) says whether the corrections they demand are beyond a robot of this model,
  and their likely cause (:func:`implausible_data`).

Units: SI (m, rad).
"""

from __future__ import annotations

import math
from dataclasses import field, replace
from typing import Any

from pincal.calibration.options import CalibrationOptions, plausible_factor
from pincal.calibration.report_sections import ImplausibleCorrection, ImplausibleScale
from pincal.errors import PincalError
from pincal.identification.measurements import Measurement
from pincal.identification.parameters.kinds import PLACEMENT_PLAUSIBLE
from pincal.io.dataset import Dataset
from pincal.model.robot import Robot
from pincal.records import record

#: The likely cause when no calibration on the data can say more (calibrate's causes, together).
UNKNOWN_CAUSE = ("a wrong robot model (the data of another robot), lengths in another unit, swapped or mislabelled "
                 "joint columns, or a joint read with the other sign")


@record(frozen=True)
class Beyond:
    """The nominal robot's errors on the checked data, beyond what a robot of its model can be off by.

    Attributes:
        quantity: ``length`` or ``angle``: the errors judged.
        rms: Their RMS with the measurement setup fitted to the data [m or rad].
        limit: What a robot of this model can be off by: one placement's plausible correction (20 mm, 2°) times the
            ``plausible`` factor [m or rad].
    """

    quantity: str
    rms: float
    limit: float


@record(frozen=True)
class Implausible:
    """Data that a robot of the nominal model cannot have produced, and the likely cause.

    Attributes:
        beyond: The nominal robot's errors that set the calibration off.
        plausible: The ``plausible`` factor the limits were taken times.
        corrections: The corrections a calibration on the data demands beyond their limits, as ``calibrate``'s report
            lists them (``parameter``, ``kind``, ``value``, ``fitted``, ``limit``, ``unit``); empty when it could not
            fit (``note``).
        scales: The measured positions whose spread is beyond the plausible band (``measurement``, ``scale``,
            ``limit``).
        cause: The likely cause, in a sentence.
        note: Why no calibration on the data judged them (its error), or None.
    """

    beyond: Beyond
    plausible: float | str
    corrections: list[ImplausibleCorrection] = field(default_factory=list)
    scales: list[ImplausibleScale] = field(default_factory=list)
    cause: str = UNKNOWN_CAUSE
    note: str | None = None

    def content(self) -> dict[str, Any]:
        """The check report's ``implausible`` entry (docs/check.md), SI units."""
        return {"quantity": self.beyond.quantity, "nominal_rms": self.beyond.rms, "limit": self.beyond.limit,
                "plausible": self.plausible, "corrections": [c.as_dict() for c in self.corrections],
                "scales": [s.as_dict() for s in self.scales],
                "cause": self.cause, "note": self.note}


def beyond_plausible(length_rms: float, angle_rms: float, plausible: float | str) -> Beyond | None:
    """The nominal robot's RMS length error [m] or orientation error [rad] (NaN: none measured) when beyond one
    placement's plausible correction times ``plausible``; None when within, or ``plausible`` is ``"off"``."""
    factor = plausible_factor(plausible)
    if factor is None:
        return None
    for quantity, value, unit in (("length", length_rms, "m"), ("angle", angle_rms, "rad")):
        limit = PLACEMENT_PLAUSIBLE[unit] * factor
        if math.isfinite(value) and value > limit:
            return Beyond(quantity, value, limit)
    return None


def implausible_data(beyond: Beyond, nominal: Robot, samples: Dataset, models: list[Measurement],
                     options: CalibrationOptions, explained: bool = False) -> Implausible | None:
    """The checked ``samples`` judged as ``pincal calibrate`` judges them. A joint column read with the other sign or
    two columns exchanged (:func:`~pincal.calibration.columns.column_mistake`, which ``calibrate`` refuses before any
    fit) is the cause, with its evidence and remedy. Otherwise the samples are calibrated on ``nominal`` as
    ``calibrate`` would (every sample fitted, the options of the check, no cross-validation) and judged by its
    plausibility check: the corrections and scales beyond what a robot of this model needs and their likely cause;
    None when the calibration finds none (the data are of a robot far off its URDF, but plausibly so). When no
    calibration can be made (too few samples, a failed solve), the data are judged implausible on ``beyond`` alone,
    the cause left open, unless ``explained``: the calibrated model checked predicts them within the limits, so a
    robot of this model does (the TALOS arm's 4 held-out table contacts: 12 readings for 98 parameters, the nominal
    robot's tilt beyond 2°, the calibrated arm's within)."""
    from pincal.calibration.columns import column_mistake
    from pincal.calibration.pipeline import calibrate

    try:
        mistake = column_mistake(nominal, samples, models)
    except PincalError:  # data the probe cannot read say nothing of their columns
        mistake = None
    if mistake is not None:
        return Implausible(beyond, options.plausible,
                           cause=f"{mistake.what}: {mistake.evidence}; {mistake.fix}, or give --plausible off to "
                                 "compare the two robots on the readings as they are")
    fitted = replace(samples, sets=["train"] * samples.n_samples)
    try:
        report = calibrate(nominal, fitted, options.replace(cv=None)).report
    except PincalError as exc:
        if explained:  # MODEL, a calibrated robot of this model, gives these data within the limits
            return None
        return Implausible(beyond, options.plausible, note=f"a calibration on DATA cannot tell the cause: {exc}")
    if not report.is_implausible:
        return None
    return Implausible(beyond, options.plausible, report.implausible, report.implausible_scale,
                       report.implausible_cause or UNKNOWN_CAUSE)
