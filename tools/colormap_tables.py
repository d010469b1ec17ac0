"""Write the colour tables of ``pincal/viz/colormaps.py`` from matplotlib's colour maps.

Run: ``python tools/colormap_tables.py`` (matplotlib installed). Each map the report draws with
(:data:`pincal.viz.colormaps.MAPS`) is sampled at its 256 table entries, as matplotlib's colour map looks a value up;
the entries' RGB values (float64, in [0, 1]) are stored exactly, base64-encoded little-endian, between the module's
markers, so that :func:`pincal.viz.colormaps.colormap` gives matplotlib's colours to the last bit without importing it.
"""

from __future__ import annotations

import base64
import textwrap
from pathlib import Path

import matplotlib
import numpy as np

MODULE = Path(__file__).resolve().parent.parent / "pincal" / "viz" / "colormaps.py"
BEGIN, END = "# BEGIN TABLES (written by tools/colormap_tables.py)\n", "# END TABLES\n"


def main() -> None:
    text = MODULE.read_text(encoding="utf-8")
    head, rest = text.split(BEGIN)
    _, tail = rest.split(END)
    names = [line.split('"')[1] for line in rest.split(END)[0].splitlines() if line.startswith('    "')]
    lines = ["_TABLES = {\n"]
    for name in names:
        cmap = matplotlib.colormaps[name]
        rgb = np.ascontiguousarray(cmap(np.arange(cmap.N))[:, :3], dtype="<f8")
        encoded = base64.b64encode(rgb.tobytes()).decode("ascii")
        lines.append(f'    "{name}": (\n')
        lines.extend(f'        "{chunk}"\n' for chunk in textwrap.wrap(encoded, 100))
        lines.append("    ),\n")
    lines.append("}\n")
    MODULE.write_text(head + BEGIN + "".join(lines) + END + tail, encoding="utf-8")
    print(f"wrote {', '.join(names)} into {MODULE}")


if __name__ == "__main__":
    main()
