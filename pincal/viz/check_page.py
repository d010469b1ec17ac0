"""The page of ``pincal check --html``: one self-contained HTML file with the figures of a check side by side (MODEL
and the nominal robot, per measurement and quantity) and each sample's error, read from the check's report content
(:func:`pincal.calibration.check.check_content`). Nothing is fetched: it opens from a file."""

from __future__ import annotations

import base64
import html
import math
from typing import Any

import numpy as np
from matplotlib.figure import Figure

from pincal.calibration.check_groups import beyond_verdict
from pincal.viz.html_report import STYLE
from pincal.viz.plots import png_bytes
from pincal.viz.static_page import provenance_html

#: Display unit and scale of each SI unit.
SHOWN = {"m": ("mm", 1e3), "rad": ("mrad", 1e3)}


def _shown(value: float | None, unit: str) -> str:
    name, scale = SHOWN.get(unit, (unit, 1.0))
    return "–" if value is None or not math.isfinite(value) else f"{value * scale:.4f} {name}"


def _table(content: dict[str, Any]) -> str:
    rows = "".join(
        f"<tr><td><code>{html.escape(q['measurement'])}</code></td><td>{q['quantity']}</td><td>{q['n']}</td>"
        f"<td>{_shown(q['rms'], q['unit'])}</td><td>{_shown(q['max'], q['unit'])}</td>"
        f"<td>{_shown(q['nominal_rms'], q['unit'])}</td><td>{_shown(q['nominal_max'], q['unit'])}</td></tr>"
        for q in content["quantities"])
    return ("<table><tr><th>measurement</th><th>quantity</th><th>readings</th><th>MODEL RMS</th><th>MODEL max</th>"
            f"<th>nominal RMS</th><th>nominal max</th></tr>{rows}</table>")


def _plot(content: dict[str, Any]) -> str:
    """Each sample's length error, MODEL and nominal (log scale), samples outside the fitted range marked."""
    samples = [s for s in content["samples"] if s.get("error") is not None and s.get("nominal_error") is not None]
    if not samples:
        return "<p>No length reading: no per-sample plot.</p>"
    model = np.array([s["error"] for s in samples]) * 1e3
    nominal = np.array([s["nominal_error"] for s in samples]) * 1e3
    outside = np.array([s["outside_range"] for s in samples])
    figure = Figure(figsize=(7.5, 3.4), layout="constrained")
    ax = figure.subplots()
    index = np.arange(len(samples))
    ax.vlines(index, model, nominal, color="#bbbbbb", linewidth=0.8)
    ax.plot(index, nominal, "o", color="#c0392b", markersize=3.5, label="nominal robot")
    ax.plot(index, model, "o", color="#1e8449", markersize=3.5, label="MODEL")
    if outside.any():
        ax.plot(index[outside], model[outside], "s", mfc="none", color="#000000", markersize=7,
                label="outside the fitted range")
    ax.set_yscale("log")
    ax.set_xlabel("sample (file order)")
    ax.set_ylabel("length error [mm] (log scale)")
    ax.legend(fontsize=8, loc="best")
    ax.grid(True, which="major", alpha=0.3)
    alt = (f"Length error of each of the {len(samples)} samples: MODEL RMS {_shown(content.get('rms'), 'm')}, max "
           f"{_shown(content.get('max'), 'm')}; nominal robot RMS {_shown(content.get('nominal_rms'), 'm')}, max "
           f"{_shown(content.get('nominal_max'), 'm')}; {int(outside.sum())} outside the fitted range")
    data = base64.b64encode(png_bytes(figure)).decode("ascii")
    return f'<figure><img alt="{html.escape(alt)}" src="data:image/png;base64,{data}"></figure>'


def check_page(content: dict[str, Any]) -> str:
    """The HTML page of a check's report content."""
    worse = content["worse_than_nominal"]
    verdict = ('<p class="warn">MODEL predicts DATA <b>worse</b> than the nominal robot.</p>' if worse
               else '<p class="verdict">MODEL predicts DATA no worse than the nominal robot.</p>')
    implausible = content.get("implausible")
    if implausible:  # DATA no robot of this model gives as they stand: no verdict on MODEL (docs/check.md)
        verdict = (f'<p class="warn"><b>IMPLAUSIBLE</b>: DATA are not of a robot of this model; likely cause: '
                   f'{html.escape(implausible["cause"])}. No verdict on MODEL.</p>')
    beyond = beyond_verdict(content)  # the postures beyond the fitted range, judged apart (docs/check.md)
    if beyond is not None:
        verdict += f'<p class="warn"><b>Verdict beyond the fitted range</b>: {html.escape(beyond)}</p>'
    outside = content["outside_range"]
    if not outside["known"]:
        range_text = f"Fitted range not known: {html.escape(str(outside['note']))}."
    else:
        range_text = (f"{len(outside['samples'])} samples lie outside the joint ranges the calibration fitted"
                      + (f": {html.escape(', '.join(outside['samples']))}." if outside["samples"] else "."))
    dropped = "".join(f"<li>{html.escape(d['sample'])}: {html.escape(d['reason'])}</li>"
                      for d in content["dropped_samples"])
    return f"""<!DOCTYPE html>
<html lang="en"><head><meta charset="utf-8"><title>pincal check</title><style>{STYLE}</style></head>
<body><main>
<h1>pincal check</h1>
<p class="sub">MODEL <code>{html.escape(content['model'])}</code> on {content['n_samples']} of the
{content['n_samples_in_file']} samples of <code>{html.escape(content['data'])}</code>; nominal robot
<code>{html.escape(content['nominal'])}</code>.</p>
<p>MODEL: {html.escape(content['model_means'])}.<br>Nominal: {html.escape(content['nominal_means'])}.</p>
{verdict}
<h2>Errors</h2>
{_table(content)}
<h2>Each sample</h2>
{_plot(content)}
<p>{range_text}</p>
{f'<h2>Samples left out</h2><ul>{dropped}</ul>' if dropped else ''}
{provenance_html(content.get("provenance"))}
</main></body></html>
"""
