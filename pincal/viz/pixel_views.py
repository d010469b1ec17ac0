"""The report page's views of a camera read from pixels: each image's reprojection error before and after, the
residuals over the image plane, and each camera's intrinsics with their σ.

Reprojection errors in px (predicted − measured, a corner's ``|(Δu, Δv)|``; an image's the RMS of its corners);
intrinsics ``fx, fy, cx, cy`` [px], ``k1, k2, p1, p2, k3`` [1].
"""

from __future__ import annotations

import base64
import html
import math
from typing import TYPE_CHECKING, Any

import numpy as np
import numpy.typing as npt
from matplotlib.figure import Figure

from pincal.calibration.check_pixels import image_errors, is_pixel_key
from pincal.identification.measurements.pixels import INTRINSICS
from pincal.viz.plots import png_bytes
from pincal.viz.svg_figures import AFTER, BEFORE

if TYPE_CHECKING:
    from pincal.viz.scene import CalibrationView

Array = npt.NDArray[np.float64]


def _png(figure: Figure, alt: str) -> str:
    data = base64.b64encode(png_bytes(figure)).decode("ascii")
    return f'<figure><img alt="{html.escape(alt)}" src="data:image/png;base64,{data}"></figure>'


def images_figure(fit: tuple[Array, Array], held: tuple[Array, Array] | None) -> Figure:
    """Each image's reprojection error [px] before and after, fitted images then held-out ones (log scale)."""
    figure = Figure(figsize=(7.5, 3.4))
    ax = figure.subplots()
    figure.set_layout_engine("tight")
    parts = [(fit, 0, "o", "")] + ([(held, len(fit[0]), "s", " (held out)")] if held is not None else [])
    for (before, after), first, marker, label in parts:
        index = np.arange(first, first + len(before))
        ax.vlines(index, after, before, color="#bbbbbb", linewidth=0.8)
        ax.plot(index, before, marker, color=BEFORE, mfc="none" if label else BEFORE, markersize=3.5,
                label=f"before calibration{label}")
        ax.plot(index, after, marker, color=AFTER, mfc="none" if label else AFTER, markersize=3.5,
                label=f"after calibration{label}")
    if held is not None:
        ax.axvline(len(fit[0]) - 0.5, color="#555555", linestyle=":", linewidth=1)
    ax.set_yscale("log")
    ax.set_xlabel("image")
    ax.set_ylabel("reprojection error [px] (log scale)")
    ax.set_title("Reprojection error of each image (RMS of its corners)")
    ax.legend(fontsize=8, ncol=2, loc="best")
    ax.grid(True, which="major", alpha=0.3)
    return figure


def plane_figure(corners: Array, before: Array, after: Array) -> tuple[Figure, float, float]:
    """The fitted corners' residuals over the image plane, before and after (two panels): arrows from each measured
    corner (u, v) [px], magnified so that the largest is a tenth of the image's extent. Returns the figure and the
    two magnifications."""
    figure = Figure(figsize=(9.0, 3.6))
    axes = figure.subplots(1, 2, sharex=True, sharey=True)
    figure.subplots_adjust(left=0.07, right=0.98, bottom=0.14, top=0.88, wspace=0.08)
    extent = float(np.ptp(corners[:, 0])) if len(corners) else 1.0
    scales = []
    for ax, errors, when, colour in ((axes[0], before, "before", BEFORE), (axes[1], after, "after", AFTER)):
        largest = float(np.max(np.linalg.norm(errors, axis=1))) if len(errors) else 0.0
        scale = 0.1 * extent / largest if largest > 0 else 1.0
        scales.append(scale)
        ax.quiver(corners[:, 0], corners[:, 1], errors[:, 0] * scale, errors[:, 1] * scale, angles="xy",
                  scale_units="xy", scale=1.0, color=colour, width=0.003)
        ax.set_title(f"{when} calibration (arrows ×{scale:.3g})", fontsize=9)
        ax.set_xlabel("u [px]")
        ax.grid(True, alpha=0.3)
    axes[0].set_ylabel("v [px]")
    axes[0].invert_yaxis()  # image rows grow downwards
    for ax in axes:
        ax.set_aspect("equal", adjustable="box")
    return figure, scales[0], scales[1]


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


def intrinsics_table(cameras: dict[str, dict[str, Any]], truth: dict[str, float] | None) -> str:
    """Each camera's intrinsics with their σ (and the truth, when known)."""
    rows = []
    for prefix, camera in cameras.items():
        for c in INTRINSICS:
            value, std = camera["intrinsics"][c], camera["std"][c]
            true = truth.get(f"{prefix}.{c}") if truth else None
            cells = [html.escape(f"{prefix}.{c}"), "px" if c in INTRINSICS[:4] else "1", f"{value:.6g}",
                     "held" if camera["held"] else ("–" if std is None or not math.isfinite(std) else f"{std:.3g}")]
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
    parts = [_png(images_figure((fit[0], fit[1]), held),
                  f"reprojection error of each image before and after calibration: {n} fitted images"
                  + (f", {len(held[0])} held out" if held is not None else ""))]
    corners, before, after = _plane_data(view)
    if len(corners):
        figure, magnified_before, magnified_after = plane_figure(corners, before, after)
        parts.append(_png(figure, f"residuals of the {len(corners)} fitted corners over the image plane, before "
                                  f"(×{magnified_before:.3g}) and after (×{magnified_after:.3g}) calibration"))
    parts.append("<p>Each fitted corner's residual (predicted − measured) drawn from where it was seen: after "
                 "calibration, arrows of one direction over a region of the image point to a distortion the model "
                 "misses; a pattern that turns about the centre, to a principal point or a rotation left "
                 "unseparated. Before: the fit's start, the nominal robot with its camera and intrinsics placed in "
                 "closed form (Zhang, then hand-eye).</p>")
    parts.append(intrinsics_table(report.cameras, truth))
    return "<h2>Camera</h2>\n" + "\n".join(parts)
