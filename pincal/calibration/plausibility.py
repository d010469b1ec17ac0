"""Whether a calibration's result is plausible for a robot of its model, and what a refusal suggests.

A calibration corrects a robot by millimetres and fractions of a degree; data that do not belong to the model (another
robot's, lengths in another unit, swapped joint columns) can still be fitted, by corrections of tens or hundreds of
millimetres. Two checks find them:

- **Corrections**: each parameter's correction against the plausible size of its kind
  (:attr:`~pincal.identification.parameters.kinds.ParameterKind.plausible`) times the ``plausible`` factor. What the
  data cannot see is not held against the robot: along the directions the data cannot see, the correction is first
  moved to its smallest equivalent (the same predictions, the robot's geometry corrected least, in units of each
  parameter's limit, the setup free), so that a robot placement confounded with the measurement frame or a marker
  does not inherit their metres.
- **Length scale**: the measured positions' spread against the nominal robot's at the same joint readings
  (:func:`~pincal.calibration.samples.check_length_scale`), implausible beyond ``1 + SCALE_TOLERANCE × factor``
  either way.

:func:`likely_cause` says which mistake the findings point to. Units: SI (m, rad).
"""

from __future__ import annotations

import contextlib
import math
from collections.abc import Iterator

import numpy as np
import numpy.typing as npt

from pincal.calibration.columns import ColumnMistake
from pincal.calibration.options import plausible_factor
from pincal.calibration.report_sections import ImplausibleCorrection, ImplausibleScale
from pincal.errors import ConvergenceError
from pincal.identification.parameters import ParameterSet
from pincal.identification.result import CalibrationResult

Array = npt.NDArray[np.float64]

#: The measured positions' spread may differ from the nominal robot's by this share (times the ``plausible``
#: factor) before the lengths are judged scaled: a robot off its URDF by millimetres, with its marker centimetres off
#: its frame, spreads its positions within a few percent to 15 % of the nominal robot's (the TIAGo mocap data: 15 %);
#: feet read as metres spread them 3.28 times as far.
SCALE_TOLERANCE = 0.5
#: A spread ratio farther from 1 than this share is mentioned in the likely cause of implausible corrections.
SCALE_NOTED = 0.1
#: The fit reaches the noise when its a-posteriori variance factor is below this (a 3 σ fit).
FIT_REACHES_NOISE = 9.0
#: A fit explains nothing when its a-posteriori variance factor exceeds this (residuals beyond 1000 × σ after
#: calibration) while it removed less than :data:`EXPLAINED` of the start's RMS error. Real fits stay far below the
#: factor (the TIAGo mocap data at 1.35 σ, the TALOS contacts at 1.9 and 3.8 × the σ estimated from them); readings
#: that belong to no posture of theirs stay at tens of thousands of σ (a UR10's readings shuffled between its postures
#: 6.5e4 σ, 0.99 of the start's error left; a Delta's positions mirrored 1.2e4 σ, 0.64 left). A good fit of readings
#: whose σ is stated a thousand times too small also ends beyond the factor, but with a hundredth of the start's error
#: left: a result, whose σ the summary questions. No calibrated URDF is written of a fit that explains nothing (unless
#: ``force``): its corrections are wherever the solver stopped.
EXPLAINS_NOTHING = 1e6
#: The share of the start's RMS error a fit must remove to explain something of its data (see :data:`EXPLAINS_NOTHING`).
EXPLAINED = 0.5


def explains_nothing(sigma2: float | None, rms_before: float | None, rms_after: float | None) -> bool:
    """Whether a fit explains nothing of its data: its a-posteriori variance factor ``sigma2`` beyond
    :data:`EXPLAINS_NOTHING` (residuals beyond 1000 × σ) and its RMS error after calibration ``rms_after`` still more
    than 1 − :data:`EXPLAINED` of the start's ``rms_before`` [m or rad] (either unknown: the factor alone)."""
    if sigma2 is None or not sigma2 > EXPLAINS_NOTHING:
        return False
    if rms_before is None or rms_after is None or not (math.isfinite(rms_before) and math.isfinite(rms_after)):
        return True
    return rms_after > (1.0 - EXPLAINED) * rms_before


def smallest_equivalent(result: CalibrationResult, limits: Array) -> Array:
    """The estimate ``result.x`` moved along the directions the data cannot see (the null space of the identification
    Jacobian) so that the bounded parameters' corrections, each in units of its limit, are smallest in the least-squares
    sense; the unbounded ones (``limits`` NaN: the setup) are free. Predictions are unchanged [m, rad]."""
    x = np.asarray(result.x, dtype=float)
    vectors, _, scales, _ = result.identifiability.null_space
    bounded = np.isfinite(limits)
    if vectors.size == 0 or not bounded.any():
        return x
    directions = (np.asarray(vectors) * np.asarray(scales)).T  # (p, k), in the parameters' units
    weights = 1.0 / limits[bounded]
    shift, *_ = np.linalg.lstsq(directions[bounded] * weights[:, None], -x[bounded] * weights, rcond=None)
    return x + directions @ shift


def implausible_corrections(parameters: ParameterSet, result: CalibrationResult,
                            plausible: float | str) -> list[ImplausibleCorrection]:
    """The corrections beyond their kind's plausible size times ``plausible`` (none when it is ``"off"``), largest
    share of its limit first: ``parameter``, ``kind``, ``value`` (the smallest equivalent correction, what the data
    demand [unit]), ``fitted`` (the estimate the calibrated URDF holds [unit]), ``limit`` [unit], ``unit``."""
    factor = plausible_factor(plausible)
    if factor is None or not len(result.names):
        return []
    by_name = {p.name: p for p in parameters}
    limits = np.full(len(result.names), math.nan)
    for k, name in enumerate(result.names):
        parameter = by_name[name]
        limit = parameter.kind_class.plausible_limit(parameter.unit)
        if limit is not None:
            limits[k] = limit * factor
    demanded = smallest_equivalent(result, limits)
    found = [(abs(demanded[k]) / limits[k], k) for k in np.flatnonzero(np.isfinite(limits))
             if abs(demanded[k]) > limits[k]]
    return [ImplausibleCorrection(parameter=result.names[k], kind=by_name[result.names[k]].kind,
                                  value=float(demanded[k]), fitted=float(result.x[k]), limit=float(limits[k]),
                                  unit=by_name[result.names[k]].unit)
            for _, k in sorted(found, key=lambda item: -item[0])]


def scale_limit(plausible: float | str) -> float | None:
    """The largest plausible ratio (either way) of the measured positions' spread to the nominal robot's; None when
    ``plausible`` is ``"off"``."""
    factor = plausible_factor(plausible)
    return None if factor is None else 1.0 + SCALE_TOLERANCE * factor


def implausible_scales(length_scale: dict[str, float], plausible: float | str) -> list[ImplausibleScale]:
    """The measured positions whose spread differs from the nominal robot's beyond :func:`scale_limit` either way:
    ``measurement`` (its key), ``scale`` (measured spread / nominal spread), ``limit``."""
    limit = scale_limit(plausible)
    if limit is None:
        return []
    return [ImplausibleScale(measurement=key, scale=scale, limit=limit) for key, scale in length_scale.items()
            if not 1.0 / limit <= scale <= limit]


def likely_cause(corrections: list[ImplausibleCorrection], scales: list[ImplausibleScale],
                 length_scale: dict[str, float], sigma2: float | None, mistake: ColumnMistake | None = None) -> str:
    """What the implausible ``corrections`` and ``scales`` most likely come from, in a sentence (empty when there are
    none): lengths in another unit when the data's spread is scaled; the joint column read with the other sign, or the
    two exchanged, that the nominal robot's start says explain the data (``mistake``,
    :func:`~pincal.calibration.columns.column_mistake`); a wrong robot model when the robot's placements are corrected
    far and the fit nevertheless reaches the noise (``sigma2``, the a-posteriori variance factor); swapped or
    mislabelled joint columns (or a wrong model) when it does not; a joint's zero or sign when only reading offsets are
    off."""
    if scales:
        worst = max(scales, key=lambda s: abs(math.log(s.scale)))
        return (f"lengths in another unit: the measured positions '{worst.measurement}' spread "
                f"{worst.scale:.3g} times as far as the nominal robot's at the same joint readings (feet read as "
                "metres give 3.28, inches 39.4; a CSV is in metres, a job file says its [data] units), or a robot of "
                "another size (a wrong robot model)")
    if not corrections:
        return ""
    if mistake is not None:
        return f"{mistake.what}: {mistake.evidence}; {mistake.fix}"
    noted = [(key, scale) for key, scale in length_scale.items() if abs(scale - 1.0) > SCALE_NOTED]
    size = (f"; the data's positions spread {noted[0][1]:.3g} times as far as this robot's would" if noted else "")
    kinds = {c.kind for c in corrections}
    if kinds == {"offset"}:
        return ("a joint's zero or sign: the readings of the joints named are off by more than a zeroing error "
                "(a joint read with the other sign, in another zero convention, or the columns of two joints "
                "swapped)")
    if sigma2 is not None and sigma2 <= FIT_REACHES_NOISE:
        return ("a wrong robot model: the fit reaches the noise only by moving the robot far from this URDF (the data "
                f"of another robot, or of another variant of it: check the robot named and the file's '# robot:' "
                f"line){size}")
    return ("swapped or mislabelled joint columns, or a joint read with the other sign, or a wrong robot model: the "
            f"fit does not reach the noise even with these corrections{size}")


@contextlib.contextmanager
def nothing_explained(explains_nothing: bool, sigma2: float) -> Iterator[None]:
    """A fit that explains nothing (``explains_nothing``, its variance factor ``sigma2``) whose estimate then fails to
    evaluate (a Delta's loops that no longer close, a sample's kinematics that no longer converge): the error says the
    verdict first, as its summary would have (the estimate is not a result; whether it evaluates depends on digits a
    BLAS build changes).

    Raises:
        ConvergenceError: the error met, the verdict first.
    """
    try:
        yield
    except ConvergenceError as exc:
        if not explains_nothing:
            raise
        raise ConvergenceError(f"the fit explains nothing (residuals {sigma2 ** 0.5:.3g} × σ after calibration: not "
                               f"a result), and its estimate cannot be evaluated: {exc}") from None
