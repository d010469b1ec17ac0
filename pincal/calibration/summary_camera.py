"""The terminal summary's lines on cameras read from pixels: the corners the figures are made of, each image's
reprojection error, each camera's intrinsics with their σ, and, in words, what the views did not separate (the focal
length from the camera's distance to the board, the principal point from its rotation), read from the report.

Intrinsics: ``fx, fy, cx, cy`` [px], ``k1, k2, p1, p2, k3`` [1]; reprojection errors [px].
"""

from __future__ import annotations

import math

import numpy as np
import numpy.typing as npt

from pincal.calibration.check_pixels import is_pixel_key
from pincal.calibration.report import CalibrationReport

Array = npt.NDArray[np.float64]

#: How much more uncertain an intrinsic is than were the camera's placement known (the square root of its variance
#: inflation factor) from which the summary says, in words, what the views did not separate.
INFLATION = 3.0
#: What each intrinsic trades with, in words, and what to add to separate them.
TRADES = {"fx": ("the focal length fx", "the camera's distance to the board",
                 "add views nearer and farther, tilted"),
          "fy": ("the focal length fy", "the camera's distance to the board",
                 "add views nearer and farther, tilted"),
          "cx": ("the principal point cx", "the camera's rotation", "add views from other directions"),
          "cy": ("the principal point cy", "the camera's rotation", "add views from other directions")}
#: The parameter kinds of the cameras' and boards' placements.
PLACEMENTS = ("camera", "target", "base")


def _value(value: float, std: float | None, digits: int) -> str:
    return f"{value:.{digits}f}" + (f" ± {std:.{digits}f}" if std is not None and math.isfinite(std) else "")


def intrinsics_lines(report: CalibrationReport) -> list[str]:
    """Each camera's intrinsics with their σ (or held at the data's values)."""
    lines = []
    for prefix, camera in (report.cameras or {}).items():
        values, stds = camera.intrinsics, camera.std
        where = f"on '{camera.frame}'" if camera.frame else "fixed in the cell"
        held = " (held at the data's values)" if camera.held else ""
        pinhole = ", ".join(f"{c} {_value(values[c], stds[c], 2)}" for c in ("fx", "fy", "cx", "cy"))
        distortion = ", ".join(f"{c} {_value(values[c], stds[c], 4)}" for c in ("k1", "k2", "p1", "p2", "k3"))
        lines.append(f"camera {where} ({prefix}){held}: {pinhole} px; distortion {distortion}")
    return lines


def inflation(names: list[str], covariance: Array, k: int, others: list[int]) -> tuple[float, int | None]:
    """How much the σ of parameter ``k`` exceeds the σ it would have were parameters ``others`` known (the square root
    of its variance inflation factor over them, ≥ 1), and which of them it correlates with most (None: none)."""
    if not others:
        return 1.0, None
    rows = [k, *others]
    block = covariance[np.ix_(rows, rows)]
    try:
        factor = float(block[0, 0] * np.linalg.inv(block)[0, 0])
    except np.linalg.LinAlgError:
        return math.inf, others[0]
    std = np.sqrt(np.diag(block))
    correlation = block[0, 1:] / (std[0] * std[1:])
    return math.sqrt(max(factor, 1.0)), others[int(np.argmax(np.abs(correlation)))]


def separation_lines(report: CalibrationReport) -> list[str]:
    """In words, the intrinsics the views did not separate from the camera's placement: their σ more than
    :data:`INFLATION` times what a known placement would leave, with the placement parameter each correlates with
    most (from the report's covariance)."""
    covariance = report.covariance
    names = list(covariance.parameters) if covariance is not None else []
    if covariance is None or not report.cameras or not names:
        return []
    matrix = np.array([[math.nan if v is None else v for v in row] for row in covariance.matrix], dtype=float)
    lines = []
    for prefix in report.cameras:
        others = [k for k, n in enumerate(names) if n.split(".")[0] in PLACEMENTS]
        for component, (what, against, advice) in TRADES.items():
            name = f"{prefix}.{component}"
            if name not in names:
                continue
            k = names.index(name)
            if not np.all(np.isfinite(matrix[np.ix_([k, *others], [k, *others])])):
                continue
            factor, most = inflation(names, matrix, k, others)
            if factor > INFLATION and most is not None:
                rho = matrix[k, most] / math.sqrt(matrix[k, k] * matrix[most, most])
                lines.append(f"  {what} against {against}: σ {math.sqrt(matrix[k, k]):.3g} px, {factor:.3g}× what a "
                             f"known placement would leave (ρ {rho:+.2f} with {names[most]}): {advice}")
    return ["not separated by these views:", *lines] if lines else []


def image_lines(report: CalibrationReport) -> list[str]:
    """The corners the reprojection figures are made of, and the images with the largest error after the fit."""
    readings, unseen = report.readings or {}, report.readings_not_seen or {}
    held = report.test_readings or {}
    pixels = [key for key in readings if is_pixel_key(key)]
    seen = sum(readings[key] for key in pixels)
    taken = [e for e in report.sample_errors if e.pixel_after is not None and e.pixel_before is not None]
    if not taken:
        return []
    lines = [f"corners seen: fitted {seen} of {seen + sum(unseen.get(key, 0) for key in pixels)} in "
             f"{report.n_samples} images" + (f"; held out {sum(held.get(key, 0) for key in pixels)} in "
                                              f"{report.n_test_samples} images" if held else "")
             + " (each RMS reprojection error is over the corners seen)"]
    worst = sorted(taken, key=lambda e: -(e.pixel_after or 0.0))[:3]
    lines.append("largest reprojection errors after the fit (image: before → after): " + ", ".join(
        f"{e.sample} ({e.set}) {e.pixel_before:.3f} → {e.pixel_after:.3f} px" for e in worst))
    predicted = report.predicted_held_out.pixels if report.predicted_held_out is not None else None
    if predicted is not None and predicted.median_bound is not None:
        board = predicted.median_bound_at_board
        lines.append(f"predicted 95 % bound of a held-out image's reprojection error: median "
                     f"{predicted.median_bound:.3f} px" + (f" ({board * 1e3:.3f} mm at the board)" if board else "")
                     + f"; {predicted.inside} of {predicted.images} images within their bound")
    return lines


def camera_lines(report: CalibrationReport) -> list[str]:
    """Every camera line of the summary (none without pixels)."""
    if not report.cameras:
        return []
    return ["", *intrinsics_lines(report), *separation_lines(report), *image_lines(report)]
