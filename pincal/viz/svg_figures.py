"""The report's figures as SVG (:mod:`pincal.viz.svg_plot`): the errors before and after, each sample's error, the
parameter estimates, the convergence and the predicted uncertainty over the workspace.

Inputs are SI (m, rad); the axes show millimetres and degrees. Each function returns the ``<figure>`` element, with
``alt`` as its text alternative. ``name`` prefixes the ids a figure declares (unique in a page).
"""

from __future__ import annotations

from collections.abc import Mapping, Sequence

import numpy as np

from pincal.viz import colormaps
from pincal.viz.svg_plot import Array, LegendEntry, Panel, colour_bar, figure, legend

BEFORE = "#c0392b"
AFTER = "#1e8449"
TRUTH = "#1f3a93"
SPAN = "#bbbbbb"
MM = 1e3
DEG = 180.0 / np.pi
#: Colour map of the predicted 95 % bounds, in the figure and in the 3D scene.
BOUND_COLORMAP = "viridis"
#: Width [px] of one character of a 9-px tick label (the parameter names).
LABEL_WIDTH = 5.0
#: Least width [px] of a panel's plot beside its names.
PANEL_WIDTH = 280.0


def _rms(values: Array) -> float:
    return float(np.sqrt(np.mean(np.square(values)))) if len(values) else float("nan")


def hex_colors(colormap: str, values: Array) -> list[str]:
    """``values`` in [0, 1] as ``#rrggbb`` colours of matplotlib's colour map ``colormap`` (:mod:`pincal.viz.colormaps`:
    its colours, without its import)."""
    rgba = np.atleast_2d(colormaps.colormap(colormap, np.clip(values, 0.0, 1.0)))
    return ["#{:02x}{:02x}{:02x}".format(*(round(255 * c) for c in row[:3])) for row in rgba]


def error_histograms(before: Array, after: Array, test_before: Array | None, test_after: Array | None,
                     rms: Mapping[str, float | None] | None, quantity: str, alt: str, name: str = "hist") -> str:
    """Histograms of the per-sample ``quantity`` errors [m] before and after calibration on a log axis, held-out
    samples as dashed outlines; samples with no reading (NaN) left out. The legend states the RMS errors [m] ``rms``
    gives (``fit before``, ``fit after``, ``held out before``, ``held out after``), else those of the samples."""
    def stated(what: str, values: Array) -> str:
        value = rms[what] if rms is not None and what in rms else _rms(values)
        return f"RMS {value * MM:.3g} mm" if isinstance(value, int | float) else "RMS –"

    before, after = before[np.isfinite(before)], after[np.isfinite(after)]
    held = test_before is not None and test_after is not None and len(test_before) > 0
    if held:
        assert test_before is not None and test_after is not None
        test_before, test_after = test_before[np.isfinite(test_before)], test_after[np.isfinite(test_after)]
    series = [v for v in (before, after, test_before, test_after) if v is not None and len(v)]
    positive = np.concatenate(series) * MM if series else np.zeros(0)
    positive = positive[positive > 0]
    low, high = (positive.min() / 1.5, positive.max() * 1.5) if positive.size else (1e-6, 1.0)
    edges = np.logspace(np.log10(low), np.log10(high), 45)
    width, height = 750.0, 360.0
    panel = Panel(name, 75.0, 40.0, width - 95.0, height - 95.0, xscale="log")
    panel.x.limits = (low, high)
    entries = []
    drawn: list[tuple[Array | None, str, str, str, bool]] = [
        (before, BEFORE, "before, fit samples", "fit before", False),
        (after, AFTER, "after, fit samples", "fit after", False)]
    if held:
        drawn += [(test_before, BEFORE, "before, held out", "held out before", True),
                  (test_after, AFTER, "after, held out", "held out after", True)]
    for values, color, label, key, outline in drawn:
        assert values is not None
        counts = np.histogram(np.maximum(values * MM, low), edges)[0].astype(float)
        panel.bars(edges, counts, color, outline=outline, dashed=outline)
        entries.append(LegendEntry("bar", color, f"{label} ({stated(key, values)})", dashed=outline))
    panel.y.margin = 0.0
    top = max(panel.y.values, default=1.0) * 1.05 or 1.0
    panel.y.limits = (0.0, top)
    panel.xlabel = f"{quantity} error of a sample [mm] (log scale)"
    panel.ylabel = "number of samples"
    panel.title = f"{quantity[0].upper() + quantity[1:]} errors before and after calibration"
    panel.grid_y = True
    panel.legend, panel.legend_at = entries, "upper center"
    return figure(width, height, panel.svg(), alt)


def errors_per_sample(before: Array, after: Array, test_before: Array | None, test_after: Array | None,
                      quantity: str, alt: str, name: str = "samples") -> str:
    """Each sample's ``quantity`` error [m] before and after, fit samples then held-out ones, on a log axis (a
    sample with no reading, NaN, has no point)."""
    width, height = 750.0, 340.0
    panel = Panel(name, 75.0, 40.0, width - 95.0, height - 95.0, yscale="log")
    n = len(before)
    index = np.arange(n, dtype=float)
    panel.segments(index, after * MM, index, before * MM, SPAN, 0.8)
    panel.points(index, before * MM, BEFORE)
    panel.points(index, after * MM, AFTER)
    entries = [LegendEntry("o", BEFORE, "before calibration"), LegendEntry("o", AFTER, "after calibration")]
    if test_before is not None and test_after is not None and len(test_before):
        held = np.arange(n, n + len(test_before), dtype=float)
        panel.segments(held, test_after * MM, held, test_before * MM, SPAN, 0.8)
        panel.points(held, test_before * MM, BEFORE, "s", hollow=True)
        panel.points(held, test_after * MM, AFTER, "s", hollow=True)
        entries += [LegendEntry("s", BEFORE, "before (held out)", hollow=True),
                    LegendEntry("s", AFTER, "after (held out)", hollow=True)]
        panel.vline(n - 0.5, "#555555", 1.0, dashed=True)
        panel.text(n - 0.5, 1.0, "  held out →")
    panel.x.add([-0.5, n - 0.5 + (0 if test_before is None else len(test_before))])
    panel.xlabel, panel.ylabel, panel.title = "sample", f"{quantity} error [mm] (log scale)", "Error of each sample"
    panel.legend, panel.legend_at = entries, "center right"
    return figure(width, height, panel.svg(), alt)


def parameter_estimates(names: Sequence[str], units: Sequence[str], values: Array, std: Array,
                        identified: Sequence[bool], truth: Array | None, alt: str, limit: int = 80,
                        name: str = "estimates") -> str:
    """Estimated deviations with ±2σ error bars, lengths [mm] and angles [deg] in panels side by side.

    Args:
        names: Parameter names.
        units: Their units (``m``, ``rad``; others shown as is).
        values: Estimates [SI].
        std: Standard deviations [SI]; NaN for parameters not identified.
        identified: Which parameters the data identifies (the others: hollow markers, no bar).
        truth: True deviations [SI], if known (a simulation).
        alt: The figure's text alternative.
        limit: At most this many parameters, the largest relative to their σ or value first.
        name: The prefix of the figure's ids.
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
    names_width = max((len(names[k]) for _, ks in panels for k in ks), default=4) * LABEL_WIDTH + 20.0
    columns = max(len(panels), 1)
    width = max(420.0 * columns + 160.0, columns * (names_width + 10.0 + PANEL_WIDTH) + 10.0)
    height = 24.0 * rows + 180.0
    inner = (width - 20.0 - columns * names_width) / columns
    scale = {"m": (MM, "deviation [mm]"), "rad": (DEG, "deviation [deg]"), "other": (1.0, "deviation [SI]")}
    body = []
    for column, (unit, ks) in enumerate(panels):
        factor, label = scale[unit]
        panel = Panel(f"{name}-{column}", names_width + column * (inner + names_width), 45.0, inner, height - 130.0)
        y = rows - 1 - np.arange(len(ks), dtype=float)
        ok = np.array([identified[k] and np.isfinite(std[k]) for k in ks], dtype=bool)
        v, s = values[ks] * factor, np.where(ok, 2 * std[ks] * factor, 0.0)
        panel.segments(v[ok] - s[ok], y[ok], v[ok] + s[ok], y[ok], AFTER, 1.2)
        for end in (-1.0, 1.0):
            panel.segments(v[ok] + end * s[ok], y[ok] - 0.12, v[ok] + end * s[ok], y[ok] + 0.12, AFTER, 1.2,
                           scale=False)
        panel.points(v[ok], y[ok], AFTER, size=3.0)
        panel.points(v[~ok], y[~ok], "#888888", size=3.0, hollow=True)
        if truth is not None:
            panel.points(truth[ks] * factor, y, TRUTH, "x", size=3.5)
        panel.x.add([0.0])
        panel.y.limits = (-0.7, rows - 0.3)
        panel.yticks = [(float(yi), names[k]) for yi, k in zip(y, ks, strict=True)]
        panel.ytick_size = 9.0
        panel.vline(0.0, "#555555", 0.8)
        panel.xlabel, panel.grid_y = label, False
        body.append(panel.svg())
    entries = [LegendEntry("errorbar", AFTER, "estimate ± 2σ"),
               LegendEntry("o", "#888888", "not identifiable (minimum norm)", hollow=True)]
    if truth is not None:
        entries.append(LegendEntry("x", TRUTH, "truth (simulation)"))
    body.append(legend(entries, (width / 2, height - 30.0, "center"), columns=len(entries)))
    title = "Estimated parameter deviations from the nominal robot"
    if len(order) < len(names):
        title += f" ({len(order)} of {len(names)} shown)"
    return figure(width, height, "".join(body), alt, title)


def convergence(cost_history: Sequence[float], alt: str, name: str = "convergence") -> str:
    """The weighted cost ½‖r‖² after each accepted iteration (log scale)."""
    width, height = 450.0, 300.0
    panel = Panel(name, 85.0, 40.0, width - 105.0, height - 95.0, yscale="log")
    cost = np.maximum(np.asarray(cost_history, float), 1e-300)
    steps = np.arange(len(cost), dtype=float)
    panel.polyline(steps, cost, "#34495e")
    panel.points(steps, cost, "#34495e", size=2.5)
    panel.xlabel, panel.ylabel, panel.title = "iteration", "cost ½‖r‖² (weighted, log scale)", "Convergence"
    return figure(width, height, panel.svg(), alt)


def predicted_uncertainty(positions: Array, bounds: Array, held_bounds: Array | None, held_errors: Array | None,
                          alt: str, name: str = "predicted") -> str:
    """The predicted position uncertainty over the workspace: the postures' predicted positions ``positions``
    (N, 3) [m] in the measurement frame, from above (x–y) and from the side (x–z), coloured by their predicted 95 %
    bound ``bounds`` (N,) [m] on one colour bar [mm]; with ``held_bounds`` and ``held_errors`` (M,) [m], a third
    panel sets each held-out posture's actual error against its bound, with the line error = bound. Postures
    without a bound (NaN) are left out."""
    known = np.isfinite(bounds) & np.all(np.isfinite(positions), axis=1)
    points, values = positions[known] * MM, bounds[known] * MM
    held = held_bounds is not None and held_errors is not None and bool(np.any(np.isfinite(held_bounds)))
    width, height = (1050.0 if held else 750.0), 360.0
    low, high = (float(values.min()), float(values.max())) if values.size else (0.0, 1.0)
    colors = hex_colors(BOUND_COLORMAP, (values - low) / (high - low if high > low else 1.0))
    side = 200.0
    body = []
    for k, ((i, j), view) in enumerate(zip(((0, 1), (0, 2)), ("from above", "from the side"), strict=True)):
        panel = Panel(f"{name}-{k}", 70.0 + k * (side + 80.0), 60.0, side, height - 120.0)
        panel.points(points[:, i], points[:, j], colors, size=2.1)
        panel.equal = True
        panel.xlabel, panel.ylabel = f"{'xyz'[i]} [mm]", f"{'xyz'[j]} [mm]"
        panel.title, panel.title_size = f"{len(values)} postures, {view}", 9.0
        body.append(panel.svg())
    ramp = hex_colors(BOUND_COLORMAP, np.linspace(0.0, 1.0, 11))
    body.append(colour_bar(70.0 + 2 * side + 100.0, 60.0, 14.0, height - 120.0, ramp, low, high,
                           "predicted 95 % bound [mm]", f"{name}-ramp"))
    if held:
        assert held_bounds is not None and held_errors is not None
        body.append(_bound_against_error(f"{name}-held", 70.0 + 2 * side + 260.0, 60.0, width - 2 * side - 360.0,
                                         height - 120.0, held_bounds, held_errors))
    title = "Predicted position uncertainty over the workspace (postures within the joint limits)"
    return figure(width, height, "".join(body), alt, title)


def _bound_against_error(name: str, left: float, top: float, width: float, height: float, bounds: Array,
                         errors: Array) -> str:
    """Each held-out posture's actual error [m] against its predicted 95 % bound [m], with the line error =
    bound."""
    known = np.isfinite(bounds) & np.isfinite(errors)
    x, y = bounds[known] * MM, errors[known] * MM
    inside = y <= x
    panel = Panel(name, left, top, width, height)
    top_value = float(max(x.max(initial=0.0), y.max(initial=0.0))) * 1.05 or 1.0
    panel.x.limits = panel.y.limits = (0.0, top_value)
    panel.points(x[inside], y[inside], AFTER)
    panel.points(x[~inside], y[~inside], BEFORE)
    panel.segments([0.0], [0.0], [top_value], [top_value], "#555555", 1.0, dashed=True)
    panel.xlabel, panel.ylabel = "predicted 95 % bound [mm]", "actual error after calibration [mm]"
    panel.title, panel.title_size = f"{len(x)} held-out postures", 9.0
    panel.legend = [LegendEntry("o", AFTER, f"within the bound ({int(inside.sum())})"),
                    LegendEntry("o", BEFORE, f"beyond it ({int((~inside).sum())})"),
                    LegendEntry("line", "#555555", "error = bound", dashed=True)]
    panel.legend_at = "upper left"
    return panel.svg()


__all__ = ["BOUND_COLORMAP", "convergence", "error_histograms", "errors_per_sample", "hex_colors",
           "parameter_estimates", "predicted_uncertainty"]
