"""The page of ``pincal iso9283 evaluate --html``: one self-contained HTML file with the ISO 9283 figures of measured
runs, read from the report content (:meth:`pincal.calibration.iso9283.Iso9283Figures.as_dict` and its sources).
Nothing is fetched: it opens from a file."""

from __future__ import annotations

import html
from typing import Any

from pincal.viz.html_report import STYLE
from pincal.viz.static_page import provenance_html


def _mm(value: float | None) -> str:
    return "–" if value is None else f"{value * 1e3:.4f}"


def _mrad(values: list[float] | None) -> str:
    return "–" if values is None else ", ".join(f"{v * 1e3:.4f}" for v in values)


def _poses(content: dict[str, Any]) -> str:
    rows = "".join(
        f"<tr><td>{html.escape(p['pose'])}</td><td>{p['cycles']}</td><td>{_mm(p['ap'])}</td>"
        f"<td>{', '.join(_mm(v) for v in p['ap_xyz'])}</td><td>{_mm(p['rp'])}</td>"
        f"<td>{_mrad(p['ap_abc'])}</td><td>{_mrad(p['rp_abc'])}</td></tr>" for p in content["poses"])
    return ("<table><tr><th>pose</th><th>cycles</th><th>AP [mm]</th><th>AP<sub>x,y,z</sub> [mm]</th><th>RP [mm]</th>"
            f"<th>AP<sub>a,b,c</sub> [mrad]</th><th>RP<sub>a,b,c</sub> ± [mrad]</th></tr>{rows}</table>")


def _distances(content: dict[str, Any]) -> str:
    if not content["distances"]:
        return "<p>No two poses measured in common cycles: no distance figures.</p>"
    rows = "".join(
        f"<tr><td>{html.escape(' – '.join(d['poses']))}</td><td>{d['cycles']}</td><td>{_mm(d['commanded'])}</td>"
        f"<td>{_mm(d['ad'])}</td><td>{', '.join(_mm(v) for v in d['ad_xyz'])}</td><td>± {_mm(d['rd'])}</td></tr>"
        for d in content["distances"])
    return ("<table><tr><th>poses</th><th>cycles</th><th>D<sub>c</sub> [mm]</th><th>AD [mm]</th>"
            f"<th>AD<sub>x,y,z</sub> [mm]</th><th>RD [mm]</th></tr>{rows}</table>")


def _variations(content: dict[str, Any]) -> str:
    if not content["variations"]:
        return "<p>No pose measured from several approach directions: no multi-directional variation.</p>"
    rows = "".join(
        f"<tr><td>{html.escape(v['pose'])}</td><td>{html.escape(', '.join(v['directions']))}</td>"
        f"<td>{_mm(v['vap'])}</td><td>{_mrad(v['vap_abc'])}</td></tr>" for v in content["variations"])
    return ("<table><tr><th>pose</th><th>directions</th><th>vAP [mm]</th><th>vAP<sub>a,b,c</sub> [mrad]</th></tr>"
            f"{rows}</table>")


def iso9283_page(content: dict[str, Any]) -> str:
    """The HTML page of an ISO 9283 evaluation's report content."""
    warnings = "".join(f'<p class="warn">{html.escape(w)}</p>' for w in content["warnings"])
    uncertainty = content["instrument_uncertainty"]
    stated = ("not stated" if uncertainty is None else f"{uncertainty * 1e3:.4g} mm")
    return f"""<!DOCTYPE html>
<html lang="en"><head><meta charset="utf-8"><title>pincal iso9283</title><style>{STYLE}</style></head>
<body><main>
<h1>ISO 9283 performance of {html.escape(content['robot'])}</h1>
<p class="sub">Runs <code>{html.escape(content['runs'])}</code>; instrument uncertainty {stated}. Formulas of ISO
9283:1998, clauses 7.2.1 (AP), 7.2.2 (RP), 7.3 (vAP), 7.4 (AD, RD): docs/iso9283.md.</p>
{warnings}
<h2>Pose accuracy and repeatability</h2>
{_poses(content)}
<h2>Distance accuracy and repeatability</h2>
{_distances(content)}
<h2>Multi-directional pose accuracy variation</h2>
{_variations(content)}
{provenance_html(content.get("provenance"))}
</main></body></html>
"""
