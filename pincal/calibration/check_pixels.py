"""``pincal check`` on pixels: each image's reprojection error under MODEL and under the nominal robot.

A pixel reading is a board corner seen in one image (a sample); its error is ``|(Δu, Δv)|`` [px], predicted −
measured. An image's reprojection error is the RMS of its corners' errors; the check's verdict on pixels compares
the RMS over every corner seen. MODEL predicts with its calibrated camera (placement and intrinsics, as its file
holds them); the nominal robot with its camera registered on the data (placement and intrinsics), calibrate's
"before" (:mod:`pincal.calibration.check_setup`).
"""

from __future__ import annotations

from collections.abc import Sequence
from typing import Any

import numpy as np
import numpy.typing as npt

from pincal.identification.measurements import KIND_CLASSES, Measurement
from pincal.identification.measurements.pixels import Pixel
from pincal.identification.metrics import pixel_error_norms, rms

Array = npt.NDArray[np.float64]


def is_pixel_key(key: str) -> bool:
    """Whether measurement ``key`` is a pixel reading (its kind's readings are in px)."""
    kind = KIND_CLASSES.get(key.partition(":")[0])
    return kind is not None and issubclass(kind, Pixel)


def image_errors(errors: dict[str, Array], n: int) -> Array | None:
    """Each of ``n`` samples' (images') reprojection error [px]: the RMS of ``|(Δu, Δv)|`` over the corners it saw
    (NaN for an image that saw none); None when no pixel is measured."""
    keys = [key for key in errors if is_pixel_key(key)]
    if not keys:
        return None
    squares, seen = np.zeros(n), np.zeros(n)
    for key in keys:
        rows = errors[key][:, :2]
        taken = ~np.isnan(rows).any(axis=1)
        squares[taken] += np.sum(rows[taken] ** 2, axis=1)
        seen += taken
    with np.errstate(invalid="ignore", divide="ignore"):
        return np.where(seen > 0, np.sqrt(squares / np.maximum(seen, 1)), np.nan)


def number(value: float) -> float | None:
    """A figure for JSON: None when not finite (no reading)."""
    return float(value) if np.isfinite(value) else None


def largest(values: Array) -> float | None:
    """The largest of ``values``; None when there is none."""
    return float(values.max()) if values.size else None


def pixel_figures(model: dict[str, Array], nominal: dict[str, Array]) -> dict[str, Any] | None:
    """RMS and max reprojection error [px] of MODEL and of the nominal robot (their errors per measurement key, rows
    predicted − measured) over every corner seen, and the corners' count; None when no pixel is measured."""
    if not any(is_pixel_key(key) for key in model):
        return None
    a, b = pixel_error_norms(model), pixel_error_norms(nominal)
    return {"unit": "px", "n_corners": int(a.size), "rms": number(rms(a)),
            "max": largest(a), "nominal_rms": number(rms(b)),
            "nominal_max": largest(b)}


def pixel_quantities(models: Sequence[Measurement], model: dict[str, Array],
                     nominal: dict[str, Array]) -> list[dict[str, Any]]:
    """One row per camera (``pixel:<frame>``, ``board_pixel:<frame>``) of ``check``'s quantities: its corners seen,
    the RMS and max reprojection error [px] of MODEL and of the nominal robot."""
    groups: dict[str, list[str]] = {}
    for m in models:
        if isinstance(m, Pixel):
            groups.setdefault(m.key.rpartition("@")[0], []).append(m.key)
    out = []
    for name, keys in groups.items():
        a = pixel_error_norms({k: model[k] for k in keys})
        b = pixel_error_norms({k: nominal[k] for k in keys})
        out.append({"measurement": name, "quantity": "reprojection", "unit": "px", "n": int(a.size),
                    "rms": number(rms(a)), "max": largest(a),
                    "nominal_rms": number(rms(b)), "nominal_max": largest(b)})
    return out


def pixels_worse(model: dict[str, Array], nominal: dict[str, Array], same: float) -> bool | None:
    """Whether MODEL's RMS reprojection error exceeds the nominal robot's by more than the fraction ``same``; None
    when no pixel is measured."""
    figures = pixel_figures(model, nominal)
    if figures is None or figures["rms"] is None or figures["nominal_rms"] is None:
        return None
    return bool(figures["rms"] > (1.0 + same) * figures["nominal_rms"])
