"""Error metrics of a calibration: error magnitudes per reading and per sample, RMS, calibration gain.

Errors come as :attr:`~pincal.identification.problem.Prediction.errors`: per measurement key, an (N, width) array of
predicted − measured, with NaN rows for readings not taken. Each measurement kind says which of its leading columns are
lengths [m] and which angles [rad] (``length_rows``, ``angle_rows``).
"""

from __future__ import annotations

import numpy as np
import numpy.typing as npt

from pincal.identification.measurements import KIND_CLASSES

Array = npt.NDArray[np.float64]


def length_columns(key: str) -> int:
    """How many leading error columns of measurement ``key`` are lengths [m] (its model's ``length_rows``: 3 for
    a position or a pose, 1 for a distance; 0 for other keys, e.g. IKM closure rows)."""
    model = KIND_CLASSES.get(key.split(":", 1)[0])
    return model.length_rows if model is not None else 0


def angle_columns(key: str) -> slice:
    """The error columns of measurement ``key`` that are angles [rad] (a pose's rotation vector), as a slice."""
    model = KIND_CLASSES.get(key.split(":", 1)[0])
    start = length_columns(key)
    return slice(start, start + (model.angle_rows if model is not None else 0))


def error_norms(errors: dict[str, Array], keys: list[str] | None = None) -> Array:
    """Error magnitudes [m] of the length-type readings (position, pose position, distance): one per reading taken,
    measurement after measurement; a reading not taken (an occluded marker, NaN) has none."""
    parts = [np.linalg.norm(err[:, :length_columns(key)], axis=1) for key, err in errors.items()
             if length_columns(key) and (keys is None or key in keys)]
    norms = np.concatenate(parts) if parts else np.zeros(0)
    return np.asarray(norms[~np.isnan(norms)], dtype=np.float64)


def angle_error_norms(errors: dict[str, Array]) -> Array:
    """Orientation error angles [rad] of the pose readings (norm of ``log3(R_measᵀ R_pred)``), one per reading taken
    (a reading not taken, NaN, has none)."""
    parts = [np.linalg.norm(err[:, angle_columns(key)], axis=1) for key, err in errors.items()
             if angle_columns(key).stop > angle_columns(key).start]
    norms = np.concatenate(parts) if parts else np.zeros(0)
    return np.asarray(norms[~np.isnan(norms)], dtype=np.float64)


def pixel_error_norms(errors: dict[str, Array]) -> Array:
    """Reprojection errors [px] of the pixel readings (a board corner's ``|(Δu, Δv)|``), one per reading taken."""
    parts = [np.linalg.norm(err[:, :2], axis=1) for key, err in errors.items()
             if (model := KIND_CLASSES.get(key.split(":", 1)[0])) is not None and model.units[:1] == ("px",)]
    norms = np.concatenate(parts) if parts else np.zeros(0)
    return np.asarray(norms[~np.isnan(norms)], dtype=np.float64)


def sample_length_errors(errors: dict[str, Array], n: int) -> Array | None:
    """Each sample's length-type error [m] (the position, pose position and distance rows of the readings it took,
    together; NaN for a sample that took none, e.g. saw no marker), or None when nothing length-like is measured."""
    widths = {key: length_columns(key) for key in errors}
    if not any(widths.values()):
        return None
    squares, taken = np.zeros(n), np.zeros(n, dtype=bool)
    for key, err in errors.items():
        if widths[key]:
            rows = err[:, :widths[key]]
            seen = ~np.isnan(rows).all(axis=1)  # a reading not taken is NaN in every row
            squares[seen] += np.sum(rows[seen] ** 2, axis=1)
            taken |= seen
    return np.where(taken, np.sqrt(squares), np.nan)


def rms(values: Array) -> float:
    """Root mean square of ``values`` (NaN when empty)."""
    return float(np.sqrt(np.mean(values**2))) if values.size else float("nan")


def calibration_gain(x_true: Array, x_nominal: Array, x_calibrated: Array) -> float:
    """Study 000, Eq. 4.1: ``G = 100 (‖Pr − Pn‖ − ‖Pr − Pc‖) / ‖Pr − Pn‖`` [%]."""
    before = float(np.linalg.norm(x_true - x_nominal))
    if before == 0.0:
        return float("nan")
    return 100.0 * (before - float(np.linalg.norm(x_true - x_calibrated))) / before
