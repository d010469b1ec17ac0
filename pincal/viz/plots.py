"""The PNG of a matplotlib figure, for the pages drawn with matplotlib's object API (no pyplot state, no display
needed: the check and drift pages). The report's figures are SVG (:mod:`pincal.viz.svg_figures`).
"""

from __future__ import annotations

import io

from matplotlib.figure import Figure


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
