"""The report's figures are placed by fixed margins: every label stays inside the figure, whatever the names."""

from __future__ import annotations

import numpy as np
import pytest

from pincal.viz.plots import LABEL_WIDTH, parameter_estimates, png_bytes


@pytest.mark.parametrize("length", [4, 30, 96, 200])
def test_the_parameter_figure_makes_room_for_its_longest_name(length: int) -> None:
    """A parameter name of ``length`` characters fits left of its panel, and each panel keeps a plot wider than an
    inch beside its names (a 96-character name once made the margins cross: 'left cannot be >= right')."""
    names = ["j" * length + ".tx", "arm.offset"]
    figure = parameter_estimates(names, ["m", "rad"], np.array([1e-3, 2e-3]), np.array([1e-4, 1e-4]), [True, True])
    assert png_bytes(figure).startswith(b"\x89PNG")
    width = figure.get_size_inches()[0]
    for ax in figure.axes[:2]:
        box = ax.get_position()
        assert box.x1 - box.x0 > 1.0 / width  # more than an inch of plot
        assert box.x0 * width >= (length + 3) * LABEL_WIDTH  # the names' room left of it
