"""The report's figures, drawn with matplotlib's object API (no pyplot state, no display needed).

Inputs are SI (m, rad); the axes show millimetres and degrees. Each function returns a
``matplotlib.figure.Figure``; :func:`png_bytes` renders one.
"""

from __future__ import annotations

import io
from collections.abc import Mapping, Sequence
from typing import Any

import numpy as np
import numpy.typing as npt
from matplotlib.figure import Figure

Array = npt.NDArray[np.float64]

BEFORE = "#c0392b"
AFTER = "#1e8449"
TRUTH = "#1f3a93"
MM = 1e3
DEG = 180.0 / np.pi
#: Width [in] of one character of a 7-point tick label (the parameter names).
LABEL_WIDTH = 0.058
#: Least width [in] of a panel's plot beside its names.
PANEL_WIDTH = 2.8


def png_bytes(figure: Figure, dpi: int = 100, palette: bool = False) -> bytes:
    """The figure as PNG bytes; with ``palette``, in 256 colours (a third of the size of a figure of many coloured
    points, with no visible change)."""
    buffer = io.BytesIO()
    figure.savefig(buffer, format="png", dpi=dpi)
    if not palette:
        return buffer.getvalue()
    from PIL import Image  # matplotlib's own dependency

    image = Image.open(buffer).convert("RGB").quantize(256, method=Image.Quantize.FASTOCTREE)
    buffer = io.BytesIO()
    image.save(buffer, format="png", optimize=True)
    return buffer.getvalue()


def margins(figure: Figure, left: float = 0.75, right: float = 0.2, bottom: float = 0.55, top: float = 0.4,
            wspace: float = 0.0) -> None:
    """Place the axes by fixed margins [in] around them (and ``wspace`` [in] between panels), instead of a layout
    engine that measures every tick label at each draw (matplotlib's constrained layout: a third of a report's
    figures' time)."""
    width, height = figure.get_size_inches()
    columns = max(len(figure.axes), 1)
    inner = max(width - left - right - wspace * (columns - 1), 0.1) / columns
    figure.subplots_adjust(left=left / width, right=1.0 - right / width, bottom=bottom / height, top=1.0 - top / height,
                           wspace=wspace / inner)


def _rms(values: Array) -> float:
    return float(np.sqrt(np.mean(np.square(values)))) if len(values) else float("nan")


def error_histograms(before: Array, after: Array, test_before: Array | None = None,
                     test_after: Array | None = None, rms: Mapping[str, float | None] | None = None,
                     quantity: str = "position") -> Figure:
    """Histograms of the per-sample ``quantity`` errors [m] (position, plane distance, …) before and after calibration,
    on a log axis
    (the two differ by orders of magnitude); held-out samples as outlines. Samples with no reading (NaN) are
    left out. The legend states the RMS errors [m] ``rms`` gives (``fit before``, ``fit after``, ``held out before``,
    ``held out after``: the report's, over the readings), else those of the samples drawn."""
    def stated(what: str, values: Array) -> str:
        value = rms[what] if rms is not None and what in rms else _rms(values)
        return f"RMS {value * MM:.3g} mm" if isinstance(value, int | float) else "RMS –"

    before, after = before[np.isfinite(before)], after[np.isfinite(after)]
    if test_before is not None and test_after is not None:
        test_before, test_after = test_before[np.isfinite(test_before)], test_after[np.isfinite(test_after)]
    figure = Figure(figsize=(7.5, 3.6))
    ax = figure.subplots()
    margins(figure)
    series = [v for v in (before, after, test_before, test_after) if v is not None and len(v)]
    positive = np.concatenate(series) * MM
    positive = positive[positive > 0]
    low, high = (positive.min() / 1.5, positive.max() * 1.5) if positive.size else (1e-6, 1.0)
    bins = np.logspace(np.log10(low), np.log10(high), 45).tolist()
    ax.hist(np.maximum(before * MM, low), bins, color=BEFORE, alpha=0.7,
            label=f"before, fit samples ({stated('fit before', before)})")
    ax.hist(np.maximum(after * MM, low), bins, color=AFTER, alpha=0.7,
            label=f"after, fit samples ({stated('fit after', after)})")
    if test_before is not None and test_after is not None and len(test_before):
        ax.hist(np.maximum(test_before * MM, low), bins, histtype="step", color=BEFORE, linewidth=1.6,
                linestyle="--", label=f"before, held out ({stated('held out before', test_before)})")
        ax.hist(np.maximum(test_after * MM, low), bins, histtype="step", color=AFTER, linewidth=1.6,
                linestyle="--", label=f"after, held out ({stated('held out after', test_after)})")
    ax.set_xscale("log")
    ax.set_xlabel(f"{quantity} error of a sample [mm] (log scale)")
    ax.set_ylabel("number of samples")
    ax.set_title(f"{quantity[0].upper() + quantity[1:]} errors before and after calibration")
    ax.legend(fontsize=8, loc="upper center")
    ax.grid(True, which="major", alpha=0.3)
    return figure


def errors_per_sample(before: Array, after: Array, test_before: Array | None = None,
                      test_after: Array | None = None, quantity: str = "position") -> Figure:
    """Each sample's ``quantity`` error [m] (position, plane distance, …) before and after, fit samples then held-out
    ones (a sample with no reading, NaN, has no point)."""
    figure = Figure(figsize=(7.5, 3.4))
    ax = figure.subplots()
    margins(figure)
    n = len(before)
    index = np.arange(n)
    ax.vlines(index, after * MM, before * MM, color="#bbbbbb", linewidth=0.8)
    ax.plot(index, before * MM, "o", color=BEFORE, markersize=3.5, label="before calibration")
    ax.plot(index, after * MM, "o", color=AFTER, markersize=3.5, label="after calibration")
    if test_before is not None and test_after is not None and len(test_before):
        held = np.arange(n, n + len(test_before))
        ax.vlines(held, test_after * MM, test_before * MM, color="#bbbbbb", linewidth=0.8)
        ax.plot(held, test_before * MM, "s", mfc="none", color=BEFORE, markersize=3.5, label="before (held out)")
        ax.plot(held, test_after * MM, "s", mfc="none", color=AFTER, markersize=3.5, label="after (held out)")
        ax.axvline(n - 0.5, color="#555555", linestyle=":", linewidth=1)
        ax.text(n - 0.5, 1.0, "  held out →", transform=ax.get_xaxis_transform(), va="top", fontsize=8)
    ax.set_yscale("log")
    ax.set_xlabel("sample")
    ax.set_ylabel(f"{quantity} error [mm] (log scale)")
    ax.set_title("Error of each sample")
    ax.legend(fontsize=8, ncol=2, loc="center right")
    ax.grid(True, which="major", alpha=0.3)
    return figure


def parameter_estimates(names: Sequence[str], units: Sequence[str], values: Array, std: Array,
                        identified: Sequence[bool], truth: Array | None = None, limit: int = 80) -> Figure:
    """Estimated deviations with ±2σ error bars, lengths [mm] and angles [deg] in two panels.

    Args:
        names: Parameter names.
        units: Their units (``m``, ``rad``; others shown as is).
        values: Estimates [SI].
        std: Standard deviations [SI]; NaN for parameters not identified.
        identified: Which parameters the data identifies (the others: hollow markers, no bar).
        truth: True deviations, if known (a simulation).
        limit: At most this many parameters, the largest relative to their σ or value first.
    """
    values, std = np.asarray(values, float), np.asarray(std, float)
    order = list(range(len(names)))
    if len(order) > limit:
        size = np.abs(values) / np.where(np.isfinite(std) & (std > 0), std, np.abs(values).max() or 1.0)
        order = sorted(int(k) for k in np.argsort(-size)[:limit])
    panels = [(unit, [k for k in order if units[k] == unit]) for unit in ("m", "rad")]
    others = [k for k in order if units[k] not in ("m", "rad")]
    panels = [p for p in panels if p[1]] + ([("other", others)] if others else [])
    rows = max((len(p[1]) for p in panels), default=1)
    names_width = max((len(names[k]) for _, ks in panels for k in ks), default=4) * LABEL_WIDTH + 0.15  # [in]
    columns = max(len(panels), 1)  # each panel its names and at least PANEL_WIDTH of plot
    figure = Figure(figsize=(max(4.2 * columns + 1.6, columns * (names_width + 0.1 + PANEL_WIDTH) + 0.1),
                             0.24 * rows + 1.8))
    axes = np.atleast_1d(figure.subplots(1, columns, squeeze=False)[0])
    margins(figure, left=names_width, bottom=0.85, top=0.45, wspace=names_width + 0.1)
    scale = {"m": (MM, "deviation [mm]"), "rad": (DEG, "deviation [deg]"), "other": (1.0, "deviation [SI]")}
    for ax, (unit, ks) in zip(axes, panels, strict=False):
        factor, label = scale[unit]
        y = rows - 1 - np.arange(len(ks))  # same row spacing in every panel, from the top
        for yi, k in zip(y, ks, strict=True):
            ok = identified[k] and np.isfinite(std[k])
            ax.errorbar(values[k] * factor, yi, xerr=2 * std[k] * factor if ok else None, fmt="o",
                        color=AFTER if ok else "#888888", mfc=None if ok else "none", markersize=4, capsize=2)
            if truth is not None:
                ax.plot(truth[k] * factor, yi, "x", color=TRUTH, markersize=6)
        ax.set_yticks(y, [names[k] for k in ks], fontsize=7)
        ax.set_ylim(-0.7, rows - 0.3)
        ax.axvline(0, color="#555555", linewidth=0.8)
        ax.set_xlabel(label)
        ax.grid(True, axis="x", alpha=0.3)
    handles = [axes[0].errorbar([], [], xerr=[], fmt="o", color=AFTER, capsize=2, label="estimate ± 2σ"),
               axes[0].plot([], [], "o", color="#888888", mfc="none", label="not identifiable (minimum norm)")[0]]
    if truth is not None:
        handles.append(axes[0].plot([], [], "x", color=TRUTH, label="truth (simulation)")[0])
    figure.legend(handles=handles, loc="lower center", ncol=len(handles), fontsize=8, frameon=False)
    title = "Estimated parameter deviations from the nominal robot"
    if len(order) < len(names):
        title += f" ({len(order)} of {len(names)} shown)"
    figure.suptitle(title, fontsize=11)
    return figure


def convergence(cost_history: Sequence[float]) -> Figure:
    """The weighted cost ½‖r‖² after each accepted iteration (log scale)."""
    figure = Figure(figsize=(4.5, 3.0))
    ax = figure.subplots()
    margins(figure, left=0.85)
    cost = np.asarray(cost_history, float)
    ax.semilogy(np.arange(len(cost)), np.maximum(cost, 1e-300), "o-", color="#34495e", markersize=4)
    ax.set_xlabel("iteration")
    ax.set_ylabel("cost ½‖r‖² (weighted, log scale)")
    ax.set_title("Convergence")
    ax.grid(True, which="major", alpha=0.3)
    return figure


#: Colour map of the predicted 95 % bounds, in the figure and in the 3D scene.
BOUND_COLORMAP = "viridis"


def predicted_uncertainty(positions: Array, bounds: Array, held_bounds: Array | None = None,
                          held_errors: Array | None = None) -> Figure:
    """The predicted position uncertainty over the workspace: the postures' predicted positions ``positions``
    (N, 3) [m] in the measurement frame, seen from above (x–y) and from the side (x–z), coloured by their predicted
    95 % bound ``bounds`` (N,) [m] on one colour bar [mm]; with ``held_bounds`` and ``held_errors`` (M,) [m], a third
    panel sets each held-out posture's actual error against its bound, with the line error = bound (points below it
    lie within their bound). Postures without a bound (NaN) are left out."""
    known = np.isfinite(bounds) & np.all(np.isfinite(positions), axis=1)
    points, values = positions[known] * MM, bounds[known] * MM
    held = held_bounds is not None and held_errors is not None and bool(np.any(np.isfinite(held_bounds)))
    figure = Figure(figsize=(10.5 if held else 7.5, 3.6))
    axes = figure.subplots(1, 3 if held else 2)
    margins(figure, left=0.7, right=0.25, bottom=0.5, top=0.6, wspace=0.9)
    low, high = (float(values.min()), float(values.max())) if values.size else (0.0, 1.0)
    for ax, (i, j), view in zip(axes, ((0, 1), (0, 2)), ("from above", "from the side"), strict=False):
        drawn = ax.scatter(points[:, i], points[:, j], c=values, cmap=BOUND_COLORMAP, vmin=low, vmax=high, s=14)
        ax.set_xlabel(f"{'xyz'[i]} [mm]")
        ax.set_ylabel(f"{'xyz'[j]} [mm]")
        ax.set_aspect("equal", adjustable="datalim")
        ax.set_title(f"{len(values)} postures, {view}", fontsize=9)
        ax.grid(True, alpha=0.3)
    figure.colorbar(drawn, ax=list(axes[:2]), label="predicted 95 % bound [mm]", shrink=0.9)
    if held:
        assert held_bounds is not None and held_errors is not None
        _bound_against_error(axes[2], held_bounds, held_errors)
    figure.suptitle("Predicted position uncertainty over the workspace (postures within the joint limits)",
                    fontsize=11)
    return figure


def _bound_against_error(ax: Any, bounds: Array, errors: Array) -> None:
    """Each held-out posture's actual error [m] against its predicted 95 % bound [m], with the line error = bound."""
    known = np.isfinite(bounds) & np.isfinite(errors)
    x, y = bounds[known] * MM, errors[known] * MM
    inside = y <= x
    ax.plot(x[inside], y[inside], "o", color=AFTER, markersize=4, label=f"within the bound ({inside.sum()})")
    ax.plot(x[~inside], y[~inside], "o", color=BEFORE, markersize=4, label=f"beyond it ({(~inside).sum()})")
    top = float(max(x.max(initial=0.0), y.max(initial=0.0))) * 1.05 or 1.0
    ax.plot([0.0, top], [0.0, top], "--", color="#555555", linewidth=1, label="error = bound")
    ax.set_xlim(0.0, top)
    ax.set_ylim(0.0, top)
    ax.set_xlabel("predicted 95 % bound [mm]")
    ax.set_ylabel("actual error after calibration [mm]")
    ax.set_title(f"{len(x)} held-out postures", fontsize=9)
    ax.legend(fontsize=8, loc="upper left")
    ax.grid(True, alpha=0.3)
