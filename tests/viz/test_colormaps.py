"""The report's colour maps without matplotlib give matplotlib's colours, bit for bit."""

from __future__ import annotations

import matplotlib
import numpy as np
import pytest

from pincal.errors import ArgumentError
from pincal.viz.colormaps import colormap

#: Every bin of a 256-entry table, its edges and either side of them, outside [0, 1], and NaN.
VALUES = np.concatenate([np.linspace(-0.25, 1.25, 20_001), np.arange(257) / 256, np.nextafter(np.arange(257) / 256, 2),
                         np.nextafter(np.arange(257) / 256, -1), [np.nan, -np.inf, np.inf]])


@pytest.mark.parametrize("name", ["viridis", "RdYlGn_r"])
def test_the_colours_are_matplotlib_s(name: str) -> None:
    np.testing.assert_array_equal(colormap(name, VALUES), matplotlib.colormaps[name](VALUES))
    grid = VALUES.reshape(-1, 3)
    np.testing.assert_array_equal(colormap(name, grid), matplotlib.colormaps[name](grid))
    assert colormap(name, 0.3).tolist() == list(matplotlib.colormaps[name](0.3))


def test_an_unknown_map_is_named() -> None:
    with pytest.raises(ArgumentError, match="colour map 'jet' is not one of the report's: viridis, RdYlGn_r"):
        colormap("jet", [0.5])
