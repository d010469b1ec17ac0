"""The page of ``pincal drift --html``: one self-contained HTML file with each session's error against the
calibration's predicted one over time, the changes named and the advice, read from the report content
(:func:`pincal.calibration.drift.run_drift`). Nothing is fetched: it opens from a file."""

from __future__ import annotations

import base64
import html
from typing import Any

import numpy as np
from matplotlib.figure import Figure

from pincal.calibration.drift import shift_text, statistic_text
from pincal.viz.html_report import STYLE
from pincal.viz.plots import png_bytes
from pincal.viz.static_page import provenance_html


def _plot(sessions: list[dict[str, Any]]) -> str:
    """RMS error [mm; px for a camera's pixels] per session with the calibration's predicted RMS; changed sessions
    marked."""
    index = np.arange(1, len(sessions) + 1)
    scale, unit = _unit(sessions)
    observed = np.array([s["rms"] for s in sessions]) * scale
    expected = np.array([s["expected_rms"] for s in sessions]) * scale
    changed = np.array([s["changed"] for s in sessions], dtype=bool)
    figure = Figure(figsize=(7.5, 3.4), layout="constrained")
    ax = figure.subplots()
    ax.plot(index, expected, "--", color="#777777", label="predicted by the calibration")
    ax.plot(index, observed, "-", color="#1e8449", linewidth=1.0)
    ax.plot(index[~changed], observed[~changed], "o", color="#1e8449", label="unchanged")
    if changed.any():
        ax.plot(index[changed], observed[changed], "s", color="#c0392b", label="changed")
    ax.set_xticks(index)
    ax.set_xlabel("session (time order)")
    ax.set_ylabel("RMS reprojection error [px]" if unit == "px" else "RMS length error [mm]")
    ax.set_ylim(bottom=0)
    ax.legend(fontsize=8, loc="best")
    ax.grid(True, alpha=0.3)
    alt = ("RMS error per session: " + ", ".join(f"{k}: {o:.4f} {unit}" + (" (changed)" if c else "")
                                                  for k, o, c in zip(index, observed, changed, strict=True)))
    data = base64.b64encode(png_bytes(figure)).decode("ascii")
    return f'<figure><img alt="{html.escape(alt)}" src="data:image/png;base64,{data}"></figure>'


def _unit(sessions: list[dict[str, Any]]) -> tuple[float, str]:
    """The factor from the sessions' RMS to what the page shows, and its unit: px for sessions of pixels (their
    ``unit``), else mm."""
    return (1.0, "px") if sessions and all(s.get("unit") == "px" for s in sessions) else (1e3, "mm")


def _moved(session: dict[str, Any]) -> str:
    if not session["changed"]:
        return "unchanged"
    parts = [f"{html.escape(g['group'])}: " + ", ".join(
        f"{html.escape(n)} {shift_text(v, s)}" for n, v, s in zip(g["parameters"], g["shifts"], g["std"],
                                                                              strict=True))
             for g in session["moved"]]
    return "<b>changed</b>" + (f" ({'; '.join(parts)} mm or mrad)" if parts else "")


def drift_page(content: dict[str, Any]) -> str:
    """The HTML page of a drift report's content."""
    sessions = content["sessions"]
    scale, unit = _unit(sessions)
    rows = "".join(
        f"<tr><td><code>{html.escape(s['source'])}</code></td><td>{s['n_samples']}</td><td>{s['rms'] * scale:.4f}</td>"
        f"<td>{s['expected_rms'] * scale:.4f}</td><td>{statistic_text(s['statistic'])} / {s['dof']}</td>"
        f"<td>{_moved(s)}</td></tr>"
        for s in sessions)
    if content["groups"]:
        advice = (f"<p class=\"warn\">Recalibrate {html.escape(', '.join(content['groups']))}: "
                  f"<code>{html.escape(content['command'])}</code></p>")
    elif content["command"]:
        advice = ("<p class=\"warn\">A change beyond the calibration's predicted spread that no parameter group "
                  "explains alone: measure again, or calibrate anew: "
                  f"<code>{html.escape(content['command'])}</code></p>")
    else:
        advice = '<p class="verdict">No session shows a change beyond the calibration\'s predicted spread.</p>'
    warnings = "".join(f'<p class="warn">Warning: {html.escape(w)}</p>' for w in content.get("warnings", []))

    return f"""<!DOCTYPE html>
<html lang="en"><head><meta charset="utf-8"><title>pincal drift</title><style>{STYLE}</style></head>
<body><main>
<h1>pincal drift</h1>
<p class="sub">{len(sessions)} sessions against <code>{html.escape(content['model'])}</code> (nominal robot
<code>{html.escape(content['nominal'])}</code>), each tested at level {content['level']:g}: docs/drift.md.</p>
{advice}{warnings}
<h2>Error over time</h2>
{_plot(sessions)}
<h2>Sessions</h2>
<table><tr><th>session</th><th>samples</th><th>RMS [{unit}]</th><th>predicted [{unit}]</th><th>T / dof</th>
<th>verdict</th></tr>
{rows}</table>
{provenance_html(content.get("provenance"))}
</main></body></html>
"""
