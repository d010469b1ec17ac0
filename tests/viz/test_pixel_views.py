"""The report's camera figures as SVG: each image's reprojection error, the residuals over the image plane."""

from __future__ import annotations

import re

import numpy as np

from pincal.viz.pixel_views import images_figure, plane_figure
from pincal.viz.svg_figures import AFTER, BEFORE


def _circles(svg: str) -> list[tuple[float, float, str, str]]:
    """(cx, cy, fill, stroke) of every circle."""
    return [(float(x), float(y), fill, stroke) for x, y, fill, stroke
            in re.findall(r'<circle cx="([-\d.]+)" cy="([-\d.]+)" r="[\d.]+" fill="([^"]+)" stroke="([^"]+)"/>', svg)]


def test_each_image_has_a_mark_before_and_after_held_out_ones_hollow() -> None:
    fit = (np.array([3.0, 4.0, 5.0]), np.array([0.3, 0.4, np.nan]))
    held = (np.array([6.0, 2.0]), np.array([0.5, 0.2]))
    svg = images_figure(fit, held, "errors: 3 fitted images, 2 held out")
    assert svg.startswith("<figure><svg ") and 'aria-label="errors: 3 fitted images, 2 held out"' in svg
    assert "data:image/png" not in svg
    marks = _circles(svg)
    filled = [m for m in marks if m[2] != "none"]
    hollow = [m for m in marks if m[2] == "none"]
    # fitted: 3 before, 2 after (the NaN image has none), filled; held out: 2 + 2 hollow; legend: 2 of each
    assert sum(m[2] == BEFORE for m in filled) == 3 + 1 and sum(m[2] == AFTER for m in filled) == 2 + 1
    assert sum(m[3] == BEFORE for m in hollow) == 2 + 1 and sum(m[3] == AFTER for m in hollow) == 2 + 1
    plotted = [m for m in filled if m[2] == BEFORE][:3]  # the plotted ones come before the legend's
    assert plotted[0][0] < plotted[1][0] < plotted[2][0]  # image order along x
    assert plotted[0][1] > plotted[1][1] > plotted[2][1]  # larger error higher up (smaller SVG y)
    assert "before calibration (held out)" in svg and "reprojection error [px] (log scale)" in svg
    assert svg.count("stroke-dasharray") >= 1  # the line between fitted and held-out images


def test_the_image_plane_draws_each_corner_s_residual_rows_downwards() -> None:
    corners = np.array([[100.0, 100.0], [900.0, 100.0], [100.0, 700.0]])
    before = np.array([[10.0, 0.0], [0.0, 5.0], [0.0, 0.0]])
    after = before / 10.0
    svg, magnified_before, magnified_after = plane_figure(corners, before, after)
    assert magnified_before == 0.1 * 800.0 / 10.0 and magnified_after == 0.1 * 800.0 / 1.0
    assert "(×8)" in svg and "(×80)" in svg and "residuals of the 3 fitted corners" in svg
    dots = _circles(svg)
    assert len(dots) == 6  # each corner in both panels
    first = [d for d in dots if d[2] == BEFORE]
    assert first[2][1] > first[0][1]  # v = 700 is drawn below v = 100
    assert first[1][0] > first[0][0]
    paths = re.findall(r'<path d="([^"]+)" fill="none" stroke="([^"]+)"', svg)
    moves = next(p for p, colour in paths if colour == BEFORE)
    segments = re.findall(r"M([-\d.]+) ([-\d.]+)L([-\d.]+) ([-\d.]+)", moves)
    assert len(segments) == 3
    (x0, y0, x1, y1), (a0, b0, a1, b1) = ([float(v) for v in s] for s in segments[:2])
    assert x1 > x0 and y1 == y0  # +u: to the right
    assert b1 > b0 and a1 == a0  # +v: downwards, as image rows grow
