"""Plots written directly as SVG text: panels with linear or logarithmic axes, ticks, grid, points, bars, segments,
error bars, legends and colour bars, without matplotlib's figure machinery (a report's figures as vector graphics:
no rasterizing, no font layout engine, a few kB each).

Sizes are in pixels of the drawing (100 px per inch, as the PNG figures were); data are in the units the axes show
(the callers convert SI values to mm and degrees).
"""

from __future__ import annotations

import html
import math
from collections.abc import Sequence
from dataclasses import field

import numpy as np
import numpy.typing as npt

from pincal.records import record

Array = npt.NDArray[np.float64]

#: Font size [px] of tick labels, axis labels and titles.
TICK_FONT = 10.0
LABEL_FONT = 11.0
TITLE_FONT = 12.0
#: Width of a character [em], to size legend boxes (the sans-serif fonts' average).
CHAR_WIDTH = 0.56
GRID = "#b3b3b3"


def number(value: float) -> str:
    """A coordinate [px] as SVG text: two decimals, no trailing zeros."""
    text = f"{value:.2f}".rstrip("0").rstrip(".")
    return "0" if text in ("-0", "") else text


def text_width(text: str, size: float) -> float:
    """The approximate width [px] of ``text`` at font size ``size`` [px]."""
    return len(text) * size * CHAR_WIDTH


def _nice_step(span: float, count: int = 5) -> float:
    """A step of 1, 2, 2.5 or 5 × 10ᵏ that cuts ``span`` into about ``count`` intervals."""
    raw = span / count
    magnitude = 10.0 ** math.floor(math.log10(raw))
    for mantissa in (1.0, 2.0, 2.5, 5.0, 10.0):
        if mantissa * magnitude >= raw * 0.999:
            return mantissa * magnitude
    return 10.0 * magnitude


def linear_ticks(low: float, high: float) -> list[tuple[float, str]]:
    """Ticks of a linear axis from ``low`` to ``high``: (value, label)."""
    step = _nice_step(high - low)
    decimals = next(d for d in range(12) if abs(round(step * 10**d) - step * 10**d) < 1e-6 * step * 10**d or d == 11)
    first = math.ceil(low / step - 1e-9)
    ticks = []
    for k in range(first, math.floor(high / step + 1e-9) + 1):
        value = k * step
        ticks.append((value, f"{value + 0.0:.{decimals}f}".replace("-0.0", "0.0").lstrip("+")))
    return [(v, "0" if float(t) == 0.0 else t) for v, t in ticks]


def log_ticks(low: float, high: float) -> list[tuple[float, str]]:
    """Ticks of a logarithmic axis from ``low`` to ``high`` (> 0): the decades, and 2 and 5 times them when fewer
    than two decades fall inside."""
    first, last = math.floor(math.log10(low)), math.ceil(math.log10(high))
    mantissas = (1.0,) if sum(low <= 10.0 ** k <= high for k in range(first, last + 1)) >= 2 else (1.0, 2.0, 5.0)
    ticks = []
    for k in range(first, last + 1):
        for m in mantissas:
            value = m * 10.0 ** k
            if low <= value <= high:
                ticks.append((value, f"{value:g}"))
    return ticks


@record
class Axis:
    """One axis: its scale (``linear`` or ``log``) and limits, from the data drawn unless set."""

    scale: str = "linear"
    limits: tuple[float, float] | None = None
    values: list[float] = field(default_factory=list)
    margin: float = 0.05

    def add(self, values: npt.ArrayLike) -> None:
        """Values drawn on this axis, which its limits will hold."""
        flat = np.asarray(values, dtype=float).ravel()
        flat = flat[np.isfinite(flat) & ((flat > 0) if self.scale == "log" else True)]
        self.values.extend(flat.tolist())

    def resolve(self) -> tuple[float, float]:
        """The limits: set ones, else the data's range widened by ``margin`` of it (a log axis: of its decades)."""
        if self.limits is not None:
            return self.limits
        if not self.values:
            low, high = (1.0, 10.0) if self.scale == "log" else (0.0, 1.0)
        else:
            low, high = min(self.values), max(self.values)
        if self.scale == "log":
            a, b = math.log10(low), math.log10(high)
            if b - a < 1e-12:
                a, b = a - 0.5, b + 0.5
            pad = (b - a) * self.margin
            self.limits = (10.0 ** (a - pad), 10.0 ** (b + pad))
        else:
            if high - low < 1e-300:
                low, high = low - (abs(low) or 1.0) * 0.5, high + (abs(high) or 1.0) * 0.5
            pad = (high - low) * self.margin
            self.limits = (low - pad, high + pad)
        return self.limits

    def fraction(self, values: npt.ArrayLike) -> Array:
        """Where ``values`` lie between the limits, 0 to 1."""
        low, high = self.resolve()
        v = np.asarray(values, dtype=float)
        if self.scale == "log":
            with np.errstate(divide="ignore", invalid="ignore"):
                out: Array = (np.log10(np.maximum(v, 1e-300)) - math.log10(low)) / (math.log10(high)
                                                                                     - math.log10(low))
            return out
        return np.asarray((v - low) / (high - low), dtype=float)

    def ticks(self) -> list[tuple[float, str]]:
        """The axis's ticks: (value, label)."""
        low, high = self.resolve()
        return log_ticks(low, high) if self.scale == "log" else linear_ticks(low, high)


@record
class LegendEntry:
    """A legend line: a marker (``o``, ``s``, ``x``, ``bar``, ``line``, ``errorbar``) in a colour, its label."""

    marker: str
    color: str
    label: str
    hollow: bool = False
    dashed: bool = False


class Panel:
    """One plot area of a figure: its rectangle [px], two axes, and what it draws, in data coordinates.

    Args:
        name: The panel's id in the page (its clip path's), unique there.
        left, top, width, height: The plot area's rectangle in the figure [px].
        xscale, yscale: ``linear`` or ``log``.
    """

    def __init__(self, name: str, left: float, top: float, width: float, height: float, xscale: str = "linear",
                 yscale: str = "linear") -> None:
        self.name = name
        self.left, self.top, self.width, self.height = left, top, width, height
        self.x, self.y = Axis(xscale), Axis(yscale)
        self.parts: list[tuple[str, tuple[object, ...]]] = []
        self.title = self.xlabel = self.ylabel = ""
        self.title_size = TITLE_FONT
        self.grid_x = self.grid_y = True
        self.yticks: list[tuple[float, str]] | None = None
        self.ytick_size = TICK_FONT
        self.legend: list[LegendEntry] = []
        self.legend_at = "upper right"
        self.equal = False

    # what is drawn, kept until the limits are known
    def points(self, x: npt.ArrayLike, y: npt.ArrayLike, color: str | Sequence[str], marker: str = "o",
               size: float = 3.5, hollow: bool = False) -> None:
        """Markers at (x, y): ``o`` circles, ``s`` squares, ``x`` crosses; ``size`` their radius [px]; ``color``
        one colour or one per point."""
        self.x.add(x)
        self.y.add(y)
        self.parts.append(("points", (np.asarray(x, float), np.asarray(y, float), color, marker, size, hollow)))

    def segments(self, x0: npt.ArrayLike, y0: npt.ArrayLike, x1: npt.ArrayLike, y1: npt.ArrayLike, color: str,
                 width: float = 1.0, dashed: bool = False, scale: bool = True) -> None:
        """Straight segments from (x0, y0) to (x1, y1); with ``scale``, the axes' limits hold their ends."""
        if scale:
            self.x.add(np.concatenate([np.ravel(x0), np.ravel(x1)]))
            self.y.add(np.concatenate([np.ravel(y0), np.ravel(y1)]))
        self.parts.append(("segments", (*(np.atleast_1d(np.asarray(v, float)) for v in (x0, y0, x1, y1)), color,
                                        width, dashed)))

    def polyline(self, x: npt.ArrayLike, y: npt.ArrayLike, color: str, width: float = 1.5,
                 dashed: bool = False) -> None:
        """A line through the points (x, y) in order."""
        self.x.add(x)
        self.y.add(y)
        self.parts.append(("polyline", (np.asarray(x, float), np.asarray(y, float), color, width, dashed)))

    def bars(self, edges: Array, counts: Array, color: str, opacity: float = 0.7, outline: bool = False,
             dashed: bool = False) -> None:
        """A histogram: ``counts`` between consecutive ``edges``, filled or as a stepped outline."""
        self.x.add(edges)
        self.y.add(np.append(counts, 0.0))
        self.parts.append(("bars", (np.asarray(edges, float), np.asarray(counts, float), color, opacity, outline,
                                    dashed)))

    def vline(self, x: float, color: str, width: float = 0.8, dashed: bool = False) -> None:
        """A vertical line across the panel at ``x``."""
        self.parts.append(("vline", (x, color, width, dashed)))

    def text(self, x: float, y_fraction: float, words: str, size: float = 8.0) -> None:
        """Words at data ``x`` and at ``y_fraction`` of the panel's height from its bottom."""
        self.parts.append(("text", (x, y_fraction, words, size)))

    # drawing
    def _px(self, x: npt.ArrayLike, y: npt.ArrayLike) -> tuple[Array, Array]:
        return (self.left + self.x.fraction(x) * self.width,
                self.top + (1.0 - self.y.fraction(y)) * self.height)

    def _equalize(self) -> None:
        """Widen one axis's limits so that a unit spans as many pixels on both (an equal aspect)."""
        (x0, x1), (y0, y1) = self.x.resolve(), self.y.resolve()
        per_x, per_y = (x1 - x0) / self.width, (y1 - y0) / self.height
        if per_x > per_y:
            mid, half = (y0 + y1) / 2, per_x * self.height / 2
            self.y.limits = (mid - half, mid + half)
        else:
            mid, half = (x0 + x1) / 2, per_y * self.width / 2
            self.x.limits = (mid - half, mid + half)

    def svg(self) -> str:
        """The panel as SVG elements."""
        if self.equal:
            self._equalize()
        out: list[str] = []
        right, bottom = self.left + self.width, self.top + self.height
        xticks = [(v, t) for v, t in self.x.ticks()]
        yticks = self.yticks if self.yticks is not None else self.y.ticks()
        for value, label in xticks:
            px = float(self._px(value, 1.0)[0])
            if self.grid_x:
                out.append(_line(px, self.top, px, bottom, GRID, 0.8))
            out.append(_line(px, bottom, px, bottom + 3.5, "#000", 0.8))
            out.append(_text(px, bottom + 14, label, TICK_FONT, "middle"))
        for value, label in yticks:
            py = float(self._px(self.x.resolve()[0], value)[1])
            if self.grid_y:
                out.append(_line(self.left, py, right, py, GRID, 0.8))
            out.append(_line(self.left - 3.5, py, self.left, py, "#000", 0.8))
            out.append(_text(self.left - 6, py + self.ytick_size * 0.35, label, self.ytick_size, "end"))
        clip = f"clip-{self.name}"
        out.append(f'<clipPath id="{clip}"><rect x="{number(self.left)}" y="{number(self.top)}" '
                   f'width="{number(self.width)}" height="{number(self.height)}"/></clipPath>')
        out.append(f'<g clip-path="url(#{clip})">')
        for kind, args in self.parts:
            out.append(getattr(self, f"_draw_{kind}")(*args))
        out.append("</g>")
        out.append(f'<rect x="{number(self.left)}" y="{number(self.top)}" width="{number(self.width)}" '
                   f'height="{number(self.height)}" fill="none" stroke="#000" stroke-width="0.8"/>')
        if self.title:
            out.append(_text(self.left + self.width / 2, self.top - 7, self.title, self.title_size, "middle"))
        if self.xlabel:
            out.append(_text(self.left + self.width / 2, bottom + 30, self.xlabel, LABEL_FONT, "middle"))
        if self.ylabel:
            widest = max((text_width(t, self.ytick_size) for _, t in yticks), default=0.0)
            x = self.left - widest - 14
            out.append(f'<text x="{number(x)}" y="{number(self.top + self.height / 2)}" font-size="{LABEL_FONT:g}" '
                       f'text-anchor="middle" transform="rotate(-90 {number(x)} '
                       f'{number(self.top + self.height / 2)})">{html.escape(self.ylabel)}</text>')
        if self.legend:
            out.append(legend(self.legend, self._legend_origin()))
        return "".join(out)

    def _legend_origin(self) -> tuple[float, float, str]:
        return {"upper right": (self.left + self.width - 6, self.top + 6, "right"),
                "upper left": (self.left + 6, self.top + 6, "left"),
                "upper center": (self.left + self.width / 2, self.top + 6, "center"),
                "center right": (self.left + self.width - 6, self.top + self.height / 2, "right middle")
                }[self.legend_at]

    def _draw_points(self, x: Array, y: Array, color: str | Sequence[str], marker: str, size: float,
                     hollow: bool) -> str:
        keep = np.isfinite(x) & np.isfinite(y) & ((y > 0) if self.y.scale == "log" else True)
        colors = [color] * len(x) if isinstance(color, str) else list(color)
        px, py = self._px(x, y)
        return "".join(marker_svg(marker, float(a), float(b), size, c, hollow)
                       for a, b, c, k in zip(px, py, colors, keep, strict=True) if k)

    def _draw_segments(self, x0: Array, y0: Array, x1: Array, y1: Array, color: str, width: float,
                       dashed: bool) -> str:
        a, b = self._px(x0, y0)
        c, d = self._px(x1, y1)
        path = "".join(f"M{number(p)} {number(q)}L{number(r)} {number(s)}"
                       for p, q, r, s in zip(a, b, c, d, strict=True)
                       if all(math.isfinite(v) for v in (p, q, r, s)))
        return _path(path, color, width, dashed) if path else ""

    def _draw_polyline(self, x: Array, y: Array, color: str, width: float, dashed: bool) -> str:
        a, b = self._px(x, y)
        points = [(p, q) for p, q in zip(a, b, strict=True) if math.isfinite(p) and math.isfinite(q)]
        if len(points) < 2:
            return ""
        path = "M" + "L".join(f"{number(p)} {number(q)}" for p, q in points)
        return _path(path, color, width, dashed)

    def _draw_bars(self, edges: Array, counts: Array, color: str, opacity: float, outline: bool,
                   dashed: bool) -> str:
        base = self.y.resolve()[0] if self.y.scale == "log" else 0.0
        xs = self._px(edges, np.ones_like(edges))[0].tolist()
        ys = self._px(np.zeros_like(counts), np.where(counts > 0, counts, base))[1].tolist()
        y0 = min(float(self._px(0.0, base)[1]), self.top + self.height)
        if outline:
            path = f"M{number(xs[0])} {number(y0)}"
            for k, count in enumerate(counts):
                path += f"V{number(ys[k] if count > 0 else y0)}H{number(xs[k + 1])}"
            path += f"V{number(y0)}"
            return _path(path, color, 1.6, dashed)
        rects = "".join(f'<rect x="{number(xs[k])}" y="{number(ys[k])}" width="{number(xs[k + 1] - xs[k])}" '
                        f'height="{number(y0 - ys[k])}"/>' for k, count in enumerate(counts) if count > 0)
        return f'<g fill="{color}" fill-opacity="{opacity:g}">{rects}</g>'

    def _draw_vline(self, x: float, color: str, width: float, dashed: bool) -> str:
        px = float(self._px(x, 1.0)[0])
        return _path(f"M{number(px)} {number(self.top)}V{number(self.top + self.height)}", color, width, dashed)

    def _draw_text(self, x: float, y_fraction: float, words: str, size: float) -> str:
        px = float(self._px(x, 1.0)[0])
        return _text(px, self.top + (1.0 - y_fraction) * self.height + size + 2, words, size, "start")


def _line(x0: float, y0: float, x1: float, y1: float, color: str, width: float) -> str:
    return (f'<line x1="{number(x0)}" y1="{number(y0)}" x2="{number(x1)}" y2="{number(y1)}" stroke="{color}" '
            f'stroke-width="{width:g}"/>')


def _path(path: str, color: str, width: float, dashed: bool = False) -> str:
    dash = ' stroke-dasharray="5 3"' if dashed else ""
    return f'<path d="{path}" fill="none" stroke="{color}" stroke-width="{width:g}"{dash}/>'


def _text(x: float, y: float, words: str, size: float, anchor: str) -> str:
    return (f'<text x="{number(x)}" y="{number(y)}" font-size="{size:g}" text-anchor="{anchor}">'
            f"{html.escape(words)}</text>")


def marker_svg(marker: str, x: float, y: float, size: float, color: str, hollow: bool = False) -> str:
    """One marker centred at (x, y) [px] of radius ``size`` [px]."""
    fill = "none" if hollow else color
    if marker == "s":
        return (f'<rect x="{number(x - size)}" y="{number(y - size)}" width="{number(2 * size)}" '
                f'height="{number(2 * size)}" fill="{fill}" stroke="{color}"/>')
    if marker == "x":
        return _path(f"M{number(x - size)} {number(y - size)}L{number(x + size)} {number(y + size)}"
                     f"M{number(x - size)} {number(y + size)}L{number(x + size)} {number(y - size)}", color, 1.5)
    return f'<circle cx="{number(x)}" cy="{number(y)}" r="{number(size)}" fill="{fill}" stroke="{color}"/>'


def legend(entries: Sequence[LegendEntry], origin: tuple[float, float, str], columns: int = 1,
           size: float = 9.0) -> str:
    """A legend box of ``entries`` in ``columns``, placed by ``origin`` (x, y [px], and which of its sides or its
    centre sits there: ``left``, ``right``, ``center``; ``middle`` centres it vertically on y)."""
    rows = math.ceil(len(entries) / columns)
    cell = max(text_width(e.label, size) for e in entries) + 30
    width, height = cell * columns + 6, rows * (size + 6) + 6
    x, y, where = origin
    left = x - width if "right" in where else x - width / 2 if "center" in where else x
    top = y - height / 2 if "middle" in where else y
    out = [f'<rect x="{number(left)}" y="{number(top)}" width="{number(width)}" height="{number(height)}" '
           'fill="#fff" fill-opacity="0.8" stroke="#ccc" rx="3"/>']
    for k, entry in enumerate(entries):
        cx, cy = left + 6 + (k % columns) * cell, top + 6 + (k // columns) * (size + 6) + size / 2
        out.append(legend_mark(entry, cx, cy))
        out.append(_text(cx + 26, cy + size * 0.35, entry.label, size, "start"))
    return "".join(out)


def legend_mark(entry: LegendEntry, x: float, y: float) -> str:
    """The mark of a legend entry, in a 20 px box starting at x, centred on y [px]."""
    if entry.marker == "bar":
        if entry.dashed:
            return _path(f"M{number(x)} {number(y - 4)}H{number(x + 20)}V{number(y + 4)}H{number(x)}Z",
                         entry.color, 1.6, True)
        return (f'<rect x="{number(x)}" y="{number(y - 4)}" width="20" height="8" fill="{entry.color}" '
                'fill-opacity="0.7"/>')
    if entry.marker == "line":
        return _path(f"M{number(x)} {number(y)}H{number(x + 20)}", entry.color, 1.2, entry.dashed)
    if entry.marker == "errorbar":
        return (_path(f"M{number(x)} {number(y)}H{number(x + 20)}M{number(x)} {number(y - 2.5)}V{number(y + 2.5)}"
                      f"M{number(x + 20)} {number(y - 2.5)}V{number(y + 2.5)}", entry.color, 1.2)
                + marker_svg("o", x + 10, y, 3.0, entry.color))
    return marker_svg(entry.marker, x + 10, y, 3.0, entry.color, entry.hollow)


def colour_bar(left: float, top: float, width: float, height: float, colors: Sequence[str], low: float,
               high: float, label: str, name: str) -> str:
    """A vertical colour bar from ``low`` (bottom) to ``high`` (top) through ``colors`` (evenly spaced stops),
    with ticks and ``label``; ``name`` its gradient's id."""
    stops = "".join(f'<stop offset="{k / (len(colors) - 1):.4g}" stop-color="{c}"/>' for k, c in enumerate(colors))
    out = [f'<defs><linearGradient id="{name}" x1="0" y1="1" x2="0" y2="0">{stops}</linearGradient></defs>',
           f'<rect x="{number(left)}" y="{number(top)}" width="{number(width)}" height="{number(height)}" '
           f'fill="url(#{name})" stroke="#000" stroke-width="0.8"/>']
    axis = Axis("linear", (low, high) if high > low else (low - 0.5, low + 0.5))
    for value, text in axis.ticks():
        y = top + (1.0 - float(axis.fraction(value))) * height
        out.append(_line(left + width, y, left + width + 3.5, y, "#000", 0.8))
        out.append(_text(left + width + 6, y + 3.5, text, TICK_FONT, "start"))
    x, y = left + width + 48, top + height / 2
    out.append(f'<text x="{number(x)}" y="{number(y)}" font-size="{LABEL_FONT:g}" text-anchor="middle" '
               f'transform="rotate(-90 {number(x)} {number(y)})">{html.escape(label)}</text>')
    return "".join(out)


def figure(width: float, height: float, body: str, alt: str, title: str = "") -> str:
    """An SVG figure of ``width`` × ``height`` [px] holding ``body``, ``title`` at its top centre, ``alt`` its
    text alternative."""
    heading = _text(width / 2, 18, title, TITLE_FONT, "middle") if title else ""
    return (f'<figure><svg xmlns="http://www.w3.org/2000/svg" role="img" aria-label="{html.escape(alt)}" '
            f'viewBox="0 0 {number(width)} {number(height)}" width="{number(width)}" height="{number(height)}" '
            f'font-family="DejaVu Sans, Arial, sans-serif"><title>{html.escape(alt)}</title>'
            f'<rect width="100%" height="100%" fill="#fff"/>{heading}{body}</svg></figure>')
