"""The SVG plots of the report: ticks a reader can read, limits that hold the data, markers where the data are."""

from __future__ import annotations

import re

import numpy as np

from pincal.viz.svg_plot import Panel, figure, linear_ticks, log_ticks, number


def test_linear_ticks_are_round_steps_within_the_limits() -> None:
    assert linear_ticks(-0.3, 1.05) == [(0.0, "0"), (0.5, "0.5"), (1.0, "1.0")]
    assert linear_ticks(-0.1, 1.05) == [(0.0, "0"), (0.25, "0.25"), (0.5, "0.50"), (0.75, "0.75"), (1.0, "1.00")]
    assert [t for _, t in linear_ticks(-330.0, 230.0)] == ["-200", "0", "200"]
    assert [t for _, t in linear_ticks(-5.0, 105.0)] == ["0", "25", "50", "75", "100"]  # no decimal a step lacks


def test_log_ticks_are_decades_and_their_halves_when_few() -> None:
    assert [t for _, t in log_ticks(0.05, 2000.0)] == ["0.1", "1", "10", "100", "1000"]
    assert [t for _, t in log_ticks(0.7, 8.0)] == ["1", "2", "5"]


def test_numbers_are_short_and_never_minus_zero() -> None:
    assert (number(1.0), number(2.345), number(-0.001), number(12.5)) == ("1", "2.35", "0", "12.5")


def test_a_panel_places_points_inside_its_area_and_the_ends_of_the_data_on_its_edges() -> None:
    panel = Panel("t", 50.0, 20.0, 200.0, 100.0)
    panel.x.margin = panel.y.margin = 0.0
    panel.points(np.array([0.0, 1.0, 2.0]), np.array([10.0, 20.0, 30.0]), "#123456")
    body = panel.svg()
    centres = [(float(x), float(y)) for x, y in re.findall(r'<circle cx="([^"]+)" cy="([^"]+)"', body)]
    assert centres == [(50.0, 120.0), (150.0, 70.0), (250.0, 20.0)]  # y grows downwards in SVG
    page = figure(300.0, 150.0, body, "three points: 0 to 2")
    assert page.startswith("<figure><svg ") and "<title>three points: 0 to 2</title>" in page


def test_a_log_axis_leaves_out_what_it_cannot_draw() -> None:
    panel = Panel("t", 0.0, 0.0, 100.0, 100.0, yscale="log")
    panel.points(np.arange(4.0), np.array([1.0, 0.0, np.nan, 100.0]), "#000000")
    assert len(re.findall(r"<circle ", panel.svg())) == 2  # zero and NaN have no place on a log axis
