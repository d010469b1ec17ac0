"""The report page's views of a camera read from pixels: each image's reprojection error before and after, the
residuals over the image plane, and each camera's intrinsics with their σ.

Reprojection errors in px (predicted − measured, a corner's ``|(Δu, Δv)|``; an image's the RMS of its corners);
intrinsics ``fx, fy, cx, cy`` [px], ``k1, k2, p1, p2, k3`` [1].
"""

from __future__ import annotations

import html
import math
from typing import TYPE_CHECKING

import numpy as np
import numpy.typing as npt

from pincal.calibration.check_pixels import image_errors, is_pixel_key
from pincal.calibration.report_sections import CameraRecord
from pincal.identification.measurements.pixels import INTRINSICS
from pincal.viz.svg_figures import AFTER, BEFORE
from pincal.viz.svg_plot import LegendEntry, Panel, figure, linear_ticks

if TYPE_CHECKING:
    from pincal.viz.scene import CalibrationView

Array = npt.NDArray[np.float64]
#: The connector between an image's error before and after.
SPAN = "#bbbbbb"


def images_figure(fit: tuple[Array, Array], held: tuple[Array, Array] | None, alt: str) -> str:
    """Each image's reprojection error [px] before and after, fitted images (filled) then held-out ones (hollow),
    on a log scale: an SVG figure with the text alternative ``alt``."""
    panel = Panel("pixel-images", 80, 36, 640, 250, yscale="log")
    parts = [(fit, 0, False)] + ([(held, len(fit[0]), True)] if held is not None else [])
    for (before, after), first, hollow in parts:
        index = np.arange(first, first + len(before), dtype=float)
        drawn = np.isfinite(before) & np.isfinite(after) & (before > 0) & (after > 0)
        panel.segments(index[drawn], after[drawn], index[drawn], before[drawn], SPAN, width=0.8)
        panel.points(index, before, BEFORE, "o", 3.0, hollow)
        panel.points(index, after, AFTER, "o", 3.0, hollow)
        suffix = " (held out)" if hollow else ""
        panel.legend += [LegendEntry("o", BEFORE, f"before calibration{suffix}", hollow),
                         LegendEntry("o", AFTER, f"after calibration{suffix}", hollow)]
    if held is not None:
        panel.vline(len(fit[0]) - 0.5, "#555555", dashed=True)
    panel.legend_at = "center right"  # between the errors before and after, where no image lies
    panel.title = "Reprojection error of each image (RMS of its corners)"
    panel.xlabel = "image"
    panel.ylabel = "reprojection error [px] (log scale)"
    return figure(760, 330, panel.svg(), alt)


def plane_figure(corners: Array, before: Array, after: Array) -> tuple[str, float, float]:
    """The fitted corners' residuals over the image plane, before and after (two panels, image rows downwards):
    segments from each measured corner (u, v) [px], magnified so that the largest is a tenth of the image's
    extent. Returns the SVG figure and the two magnifications."""
    u_low, u_high = (float(corners[:, 0].min()), float(corners[:, 0].max())) if len(corners) else (0.0, 1.0)
    v_low, v_high = (float(corners[:, 1].min()), float(corners[:, 1].max())) if len(corners) else (0.0, 1.0)
    extent = max(u_high - u_low, 1.0)
    pad = 0.12 * max(extent, v_high - v_low, 1.0)
    u_lim, v_lim = (u_low - pad, u_high + pad), (v_low - pad, v_high + pad)
    width = 400.0
    height = float(np.clip(width * (v_lim[1] - v_lim[0]) / (u_lim[1] - u_lim[0]), 150.0, 400.0))
    scales, panels = [], []
    for k, (errors, when, colour) in enumerate(((before, "before", BEFORE), (after, "after", AFTER))):
        largest = float(np.max(np.linalg.norm(errors, axis=1))) if len(errors) else 0.0
        scale = 0.1 * extent / largest if largest > 0 else 1.0
        scales.append(scale)
        panel = Panel(f"pixel-plane-{when}", 70 + k * (width + 40), 36, width, height)
        panel.x.limits, panel.y.limits = u_lim, (-v_lim[1], -v_lim[0])  # v grows downwards: drawn as −v
        panel.yticks = [(-value, label) for value, label in linear_ticks(*v_lim)]
        panel.segments(corners[:, 0], -corners[:, 1], corners[:, 0] + errors[:, 0] * scale,
                       -(corners[:, 1] + errors[:, 1] * scale), colour, width=1.0, scale=False)
        panel.points(corners[:, 0], -corners[:, 1], colour, "o", 1.0)
        panel.title = f"{when} calibration (×{scale:.3g})"
        panel.xlabel = "u [px]"
        if k == 0:
            panel.ylabel = "v [px]"
        panels.append(panel)
    return (figure(70 + 2 * width + 40 + 20, height + 86, "".join(p.svg() for p in panels),
                   f"residuals of the {len(corners)} fitted corners over the image plane, before (×{scales[0]:.3g}) "
                   f"and after (×{scales[1]:.3g}) calibration", ""), scales[0], scales[1])


def _plane_data(view: CalibrationView) -> tuple[Array, Array, Array]:
    """The fitted corners seen: measured (u, v) [px] and the residuals before and after [px]."""
    points, before, after = [], [], []
    for key, values in view.problem.observations.values.items():
        if not is_pixel_key(key):
            continue
        seen = np.isfinite(values[:, :2]).all(axis=1) & np.isfinite(view.errors_after[key][:, :2]).all(axis=1)
        points.append(values[seen, :2])
        before.append(view.errors_before[key][seen, :2])
        after.append(view.errors_after[key][seen, :2])
    stack = (np.concatenate(parts) if parts else np.zeros((0, 2)) for parts in (points, before, after))
    corners, errors_before, errors_after = stack
    return corners, errors_before, errors_after


def intrinsics_table(cameras: dict[str, CameraRecord], truth: dict[str, float] | None) -> str:
    """Each camera's intrinsics with their σ (and the truth, when known)."""
    rows = []
    for prefix, camera in cameras.items():
        for c in INTRINSICS:
            value, std = camera.intrinsics[c], camera.std[c]
            true = truth.get(f"{prefix}.{c}") if truth else None
            cells = [html.escape(f"{prefix}.{c}"), "px" if c in INTRINSICS[:4] else "1", f"{value:.6g}",
                     "held" if camera.held else ("–" if std is None or not math.isfinite(std) else f"{std:.3g}")]
            if truth is not None:
                cells.append("–" if true is None else f"{true:.6g}")
            rows.append("<tr>" + "".join(f"<td>{cell}</td>" for cell in cells) + "</tr>")
    head = "<tr><th>intrinsic</th><th>unit</th><th>value</th><th>σ</th>" + \
        ("<th>truth</th>" if truth is not None else "") + "</tr>"
    return f"<table>{head}{''.join(rows)}</table>"


def camera_section(view: CalibrationView, truth: dict[str, float] | None) -> str:
    """The page's camera section of the calibration ``view`` (empty without pixels): the images' errors, the image
    plane, the intrinsics (with the ``truth`` [px, 1] when known)."""
    report = view.report
    if not report.cameras:
        return ""
    n = view.problem.observations.n_samples
    fit = image_errors(view.errors_before, n), image_errors(view.errors_after, n)
    if fit[0] is None or fit[1] is None:
        return ""
    held = None
    if view.held_out is not None:
        m = view.held_out.prepared.samples.n_samples
        pair = image_errors(view.held_out.errors_before, m), image_errors(view.held_out.errors_after, m)
        held = (pair[0], pair[1]) if pair[0] is not None and pair[1] is not None else None
    parts = [images_figure((fit[0], fit[1]), held,
                           f"reprojection error of each image before and after calibration: {n} fitted images"
                           + (f", {len(held[0])} held out" if held is not None else ""))]
    corners, before, after = _plane_data(view)
    if len(corners):
        parts.append(plane_figure(corners, before, after)[0])
    parts.append("<p>Each fitted corner's residual (predicted − measured) drawn from where it was seen: after "
                 "calibration, arrows of one direction over a region of the image point to a distortion the model "
                 "misses; a pattern that turns about the centre, to a principal point or a rotation left "
                 f"unseparated. Before: {html.escape(report.before_means or 'the nominal robot')}.</p>")
    parts.append(intrinsics_table(report.cameras, truth))
    return "<h2>Camera</h2>\n" + "\n".join(parts)
