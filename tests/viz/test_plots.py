"""The report's figures are placed by fixed margins: every label stays inside the figure, whatever the names."""

from __future__ import annotations

import re

import numpy as np
import pytest

from pincal.viz.svg_figures import LABEL_WIDTH, parameter_estimates


@pytest.mark.parametrize("length", [4, 30, 96, 200])
def test_the_parameter_figure_makes_room_for_its_longest_name(length: int) -> None:
    """A parameter name of ``length`` characters fits left of its panel, and each panel keeps a plot wider than an
    inch (100 px) beside its names (a 96-character name once made the margins cross)."""
    names = ["j" * length + ".tx", "arm.offset"]
    drawn = parameter_estimates(names, ["m", "rad"], np.array([1e-3, 2e-3]), np.array([1e-4, 1e-4]), [True, True],
                                None, "two parameters")
    width = float(re.search(r'<svg [^>]*width="([0-9.]+)"', drawn).group(1))  # type: ignore[union-attr]
    panels = [(float(x), float(w)) for x, w in
              re.findall(r'<clipPath id="clip-estimates-\d"><rect x="([0-9.]+)" y="[0-9.]+" width="([0-9.]+)"', drawn)]
    assert len(panels) == 2
    left = 0.0
    for x, w in panels:
        assert w > 100.0  # more than an inch of plot
        assert x - left >= (length + 3) * LABEL_WIDTH  # the names' room left of it
        left = x + w
    assert left <= width
