"""One offline HTML file per calibration: how much better the calibrated robot is, and why to trust it.

The page holds the headline before/after errors, a summary (samples, parameters, identifiable count,
condition number, RMS and max errors, held-out errors), the 3D scene of :mod:`pincal.viz.scene`, the
figures of :mod:`pincal.viz.svg_figures` as inline SVG, the parameter table with standard deviations, and
the combinations the data cannot separate, in words. Nothing is fetched: it opens from a file.
"""

from __future__ import annotations

import html
import json
import math
import re
from pathlib import Path
from typing import Any

import numpy as np
import numpy.typing as npt

from pincal.calibration.pipeline import Calibration
from pincal.calibration.report import CalibrationReport
from pincal.calibration.report_sections import HeldOutPredictions, WorkspacePrediction
from pincal.calibration.summary import bad_reading_text, correction, report_robot
from pincal.errors import DataError
from pincal.io.files import make_directory, write_text
from pincal.progress import Progress
from pincal.records import record
from pincal.viz.page_style import SCENE_LISTENER
from pincal.viz.page_style import STYLE as STYLE  # check_page reads it here
from pincal.viz.scene import CalibrationView, static_scene, workspace_points
from pincal.viz.static_page import provenance_html, workspace_text

Array = npt.NDArray[np.float64]


@record
class ReportContent:
    """Everything the report shows.

    Attributes:
        view: The calibration (fit samples, estimates, the typed report, errors; the held-out evaluation).
        truth: True deviations by parameter name [m, rad], when known (a simulation's truth.json).
        sources: What the report was made from (robot, data), shown in the header.
    """

    view: CalibrationView
    truth: dict[str, float] | None = None
    sources: tuple[str, ...] = ()

    def held_out_errors(self) -> tuple[Array | None, Array | None]:
        """Per-sample error sizes [m] of the held-out samples before and after (Nones without held-out samples)."""
        held = self.view.held_out
        return held.sample_errors() if held is not None else (None, None)


def read_truth(path: str | Path) -> dict[str, float]:
    """True deviations from a simulation's ``truth.json`` (``pincal simulate``)."""
    try:
        content = json.loads(Path(path).read_text(encoding="utf-8"))
        return {str(k): float(v) for k, v in content["parameters"].items()}
    except (OSError, json.JSONDecodeError, KeyError, TypeError, ValueError, AttributeError) as exc:
        raise DataError(f"cannot read true parameters from '{path}' (expected the truth.json of pincal "
                        f"simulate): {exc}") from None


# --- formatting ------------------------------------------------------------------------------------
def _text(value: Any) -> str:
    """A value of the report as HTML text. Every value of the report is escaped, numbers too: with ``--result`` the
    report is a JSON file the user gives, whose values may be anything."""
    return html.escape(str(value))


def mm_text(value: float | None, digits: int = 4) -> str:
    """A length [m] as text in mm, "–" when missing or not finite."""
    return "–" if value is None or not math.isfinite(value) else f"{value * 1e3:.{digits}f} mm"


def mrad_text(value: float | None, digits: int = 4) -> str:
    """An angle [rad] as text in mrad, "–" when missing or not finite."""
    return "–" if value is None or not math.isfinite(value) else f"{value * 1e3:.{digits}f} mrad"


def _in_unit(value: float | None, unit: str) -> str:
    if value is None or not math.isfinite(value):
        return "–"
    if unit == "m":
        return f"{value * 1e3:+.4f}"
    if unit == "rad":
        return f"{math.degrees(value):+.5f}"
    return f"{value:+.6g}"


def _spread(value: float | None, unit: str) -> str:
    """A standard deviation in the display unit, three significant digits."""
    if value is None or not math.isfinite(value):
        return "–"
    return f"{value * {'m': 1e3, 'rad': 180.0 / math.pi}.get(unit, 1.0):.3g}"


def _display_unit(unit: str) -> str:
    return {"m": "mm", "rad": "deg"}.get(unit, unit)


def _ratio(before: float | None, after: float | None) -> str:
    if not before or not after or not math.isfinite(before) or not math.isfinite(after) or after <= 0:
        return ""
    return f"{before / after:.3g}× smaller" if before >= after else f"{after / before:.3g}× larger"


def _cards(report: CalibrationReport) -> str:
    length = report.error_words[0]
    rows = [(f"RMS {length} error, fit samples", report.rms_before, report.rms_after)]
    if report.has_held_out:
        rows.append((f"RMS {length} error, held-out samples", report.test_rms_before,
                     report.test_rms_after))
        rows.append(("largest error, held-out samples", report.test_max_before, report.test_max_after))
    else:
        rows.append(("largest error, fit samples", report.max_before, report.max_after))
    cards = []
    for what, before, after in rows:
        cards.append(f'<div class="card"><div class="what">{html.escape(what)}</div>'
                     f'<div class="nums"><span class="before">{mm_text(before)}</span> → '
                     f'<span class="after">{mm_text(after)}</span></div>'
                     f'<div class="gain">{_ratio(before, after)}</div></div>')
    return '<div class="cards">' + "".join(cards) + "</div>"


def _implausible(report: CalibrationReport) -> str:
    """The refusal of an implausible result: what is beyond its limit, and the likely cause (empty otherwise)."""
    if not report.is_implausible:
        return ""
    items = [f"the measured positions {html.escape(s.measurement)} spread {s.scale:.3g} times as far as the "
             f"nominal robot's" for s in report.implausible_scale]
    items += [f"{html.escape(c.parameter)} corrected by {html.escape(correction(c.value, c.unit))} (limit "
              f"{html.escape(correction(c.limit, c.unit).lstrip('+'))})" for c in report.implausible]
    return (f'<p class="warn">Implausible result, refused: {"; ".join(items)}. Likely cause: '
            f"{html.escape(report.implausible_cause)}.</p>")


def _explains_nothing(report: CalibrationReport) -> str:
    """The refusal of a fit that explains nothing: residuals beyond 1000 × σ (empty otherwise)."""
    if not report.explains_nothing:
        return ""
    return (f'<p class="warn">The fit explains nothing: its residuals stay at {(report.sigma2 or 0.0) ** 0.5:.3g} × σ '
            f"after calibration, beyond 1000 × σ, with RMS {mm_text(report.rms_after)} of the start's "
            f"{mm_text(report.rms_before)} left. This is not a result, and <code>pincal calibrate</code> writes no "
            "calibrated URDF of it (<code>--force</code> writes one): the data do not belong to this robot as they "
            "are read.</p>")


def _verdict(report: CalibrationReport) -> str:
    if report.explains_nothing:  # said above: the figures below are no calibration's
        return ""
    held = report.has_held_out
    before = report.test_rms_before if held else report.rms_before
    after = report.test_rms_after if held else report.rms_after
    if before is None or after is None:
        return ""
    where = f"on {_text(report.n_test_samples)} held-out poses the calibration never saw" if held else \
        "on the samples it was fitted to (no held-out samples: add rows with set=test to check it)"
    if not report.converged:
        return (f'<p class="warn">The solver did not converge ({html.escape(str(report.message))}): '
                f"treat these numbers with care. RMS error {where}: {mm_text(before)} → {mm_text(after)}.</p>")
    change = (1 - after / before) * 100 if before else 0.0
    kind = "verdict" if after < before else "warn"
    return (f'<p class="{kind}">The calibrated model predicts the robot\'s positions with an error '
            f"{_ratio(before, after) or 'as large'} than {html.escape(_started_from(report))} {where}: RMS "
            f"{mm_text(before)} → "
            f"{mm_text(after)} ({abs(change):.1f} % {'less' if change >= 0 else 'more'}).</p>")


def _started_from(report: CalibrationReport) -> str:
    """What the calibration started from, in the page's words: "the nominal model", or a calibrated URDF given as the
    robot (its "before" says so: :func:`~pincal.calibration.provenance.labelled`), named so."""
    found = re.match(r"the calibrated URDF '([^']*)' given as the robot", report.before_means or "")
    return f"the calibrated URDF '{found.group(1)}' it started from" if found else "the nominal model"


def _summary_table(report: CalibrationReport, n_test: int | None) -> str:
    cond = report.condition_number
    rows: list[tuple[str, str, str]] = [
        ("samples (fit / held out)", f"{report.n_samples} / {n_test if n_test is not None else 0}", ""),
        ("measurements", ", ".join(report.measurements), ""),
        *_reading_rows(report),
        ("parameters", str(report.n_parameters), ""),
        ("identifiable", f"{report.n_identifiable} of {report.n_parameters}", ""),
        ("estimated (after model selection)", _estimated(report), ""),
        ("condition number (scaled)", f"{cond:.3g}" if cond else "–", ""),
        ("solver", f"{report.solver} ({report.loss} loss): {report.message}, "
                   f"{report.iterations} iterations", ""),  # no wall time: same inputs, same file
        ("a-posteriori variance factor σ²", f"{report.sigma2:.3g}" if report.sigma2 else "–", ""),
    ]
    payload = report.payload
    if payload is not None:
        x, y, z = payload.offset
        rows.append(("payload (in the gravity torque of the compliances)",
                     f"{payload.mass:g} kg on {payload.frame} at ({x:g}, {y:g}, {z:g}) m", ""))
    table = ['<table><tr><th></th><th>before</th><th>after</th></tr>']
    length, angle = report.error_words
    numbers = [(f"RMS {length} error (fit)", "rms_before", "rms_after"),
               (f"max {length} error (fit)", "max_before", "max_after")]
    if report.has_held_out:
        numbers += [(f"RMS {length} error (held out)", "test_rms_before", "test_rms_after"),
                    (f"max {length} error (held out)", "test_max_before", "test_max_after")]
    for label, b, a in numbers:
        table.append(f"<tr><td>{label}</td><td class='before'>{mm_text(getattr(report, b))}</td>"
                     f"<td class='after'>{mm_text(getattr(report, a))}</td></tr>")
    angles = [(f"RMS {angle} error (fit)", "rms_angle_before", "rms_angle_after"),
              (f"RMS {angle} error (held out)", "test_rms_angle_before", "test_rms_angle_after")]
    for label, b, a in angles:
        if getattr(report, b) is not None:
            table.append(f"<tr><td>{label}</td><td class='before'>{mrad_text(getattr(report, b))}</td>"
                         f"<td class='after'>{mrad_text(getattr(report, a))}</td></tr>")
    cv = report.cv
    if cv is not None:
        table.append(f"<tr><td>RMS {length} error (cross-validated, {_text(cv.plan)}, {_text(cv.n_samples)} "
                     f"samples)</td><td></td><td class='after'>{mm_text(cv.rms)}</td></tr>")
        for key, value in (cv.rms_by_reading or {}).items():
            table.append(f"<tr><td>&nbsp;&nbsp;{html.escape(key)}</td><td></td>"
                         f"<td class='after'>{mm_text(value)}</td></tr>")
        if cv.rms_angle is not None:
            table.append(f"<tr><td>RMS {angle} error (cross-validated)</td><td></td>"
                         f"<td class='after'>{mrad_text(cv.rms_angle)}</td></tr>")
    if report.calibration_gain is not None:
        table.append(f"<tr><td>calibration gain G (study 000, vs the truth)</td><td></td>"
                     f"<td>{report.calibration_gain:.1f} %</td></tr>")
    table.append("</table>")
    facts = "".join(f"<tr><td>{html.escape(k)}</td><td>{html.escape(v)}</td></tr>" for k, v, _ in rows)
    down = report.down_weighted_samples or []
    if down:  # a count, then which samples: an id alone reads as a count
        facts += (f"<tr><td>down-weighted samples (robust loss)</td>"
                  f"<td>{len(down)}: {'sample' if len(down) == 1 else 'samples'} "
                  f"{html.escape(', '.join(map(str, down)))}</td></tr>")
    for entry in report.bad_readings or []:
        facts += f"<tr><td>bad joint reading</td><td>{html.escape(bad_reading_text(entry))}</td></tr>"
    return (f'<div class="cards"><div><table>{facts}</table></div><div>{"".join(table)}</div></div>')


def _reading_rows(report: CalibrationReport) -> list[tuple[str, str, str]]:
    """The position readings the figures are made of (fit / held out), when some marker was not seen or several
    are measured: every RMS is over the readings taken."""
    unseen = report.readings_not_seen or {}
    if len(unseen) < 2 and not any(unseen.values()):
        return []
    fitted, held = report.readings or {}, report.test_readings or {}
    return [("position readings (fit / held out; not seen in the fit)",
             f"{sum(fitted.get(k, 0) for k in unseen)} / {sum(held.get(k, 0) for k in unseen)}; "
             f"{sum(unseen.values())}", "")]


def _estimated(report: CalibrationReport) -> str:
    """How many parameters were estimated, and what model selection left out."""
    left_out = report.selection.removed_groups if report.selection is not None else []
    count = str(report.n_estimated)
    return count + (f" (left out: {', '.join(left_out)})" if left_out else "")


def _parameter_table(content: ReportContent) -> str:
    view, truth = content.view, content.truth
    report = view.report.parameters
    head = "<tr><th>parameter</th><th>unit</th><th>estimate</th><th>σ</th><th>identifiable</th>"
    head += "<th>truth</th><th>error</th></tr>" if truth else "</tr>"
    rows = [head]
    for p in view.problem.parameters:
        entry = report.get(p.name)
        value, std = (entry.value, entry.std) if entry is not None else (None, None)
        ident = entry is not None and bool(entry.identified)
        cells = [html.escape(p.name), _display_unit(p.unit), _in_unit(value, p.unit),
                 _spread(std, p.unit) if ident else "–", "yes" if ident else "no"]
        if truth:
            true = truth.get(p.name)
            cells += [_in_unit(true, p.unit),
                      _in_unit(value - true, p.unit) if true is not None and value is not None else "–"]
        css = "" if ident else ' class="unidentified"'
        rows.append(f"<tr{css}>" + "".join(f"<td>{c}</td>" for c in cells) + "</tr>")
    return "<table>" + "".join(rows) + "</table>"


def _combinations(report: CalibrationReport) -> str:
    combos = report.unidentifiable or []
    if not combos:
        return "<p>Every parameter is identifiable from these data.</p>"
    items = "".join(f"<li>{html.escape(c)}</li>" for c in combos)
    return (f"<p>{len(combos)} direction(s) of the parameter space leave every measurement unchanged, so no data "
            "of this kind can separate them. The calibration keeps the minimum-norm split (it predicts the "
            "measured quantities just as well); to pin them down, measure something else (another frame, "
            "an orientation, a joint reading) or fix them from a drawing.</p>"
            f'<ul class="combos">{items}</ul>')


def _numbers(values: Any) -> Array:
    """A list of the report JSON as floats, NaN for a value it does not hold (``null``)."""
    return np.array([np.nan if v is None else float(v) for v in values or []], dtype=float)


def predicted_uncertainty(report: CalibrationReport) -> str:
    """The figure of the predicted position uncertainty over the workspace (the report's ``predicted_workspace``)
    and, with held-out samples, their bound against their actual error (``predicted_held_out``, ``sample_errors``),
    with its caption; empty when the report holds no workspace prediction (a report of an older pincal)."""
    from pincal.viz.svg_figures import predicted_uncertainty as figure

    workspace = workspace_points(report)
    if workspace is None:
        return ""
    positions, bounds = workspace
    space = report.predicted_workspace or WorkspacePrediction()
    held = report.predicted_held_out or HeldOutPredictions()
    after = {e.sample: e.after for e in report.sample_errors if e.set == "test"}
    entries = held.samples_predicted
    held_bounds = _numbers([e.bound for e in entries]) if entries else None
    held_errors = _numbers([after.get(e.sample) for e in entries]) if entries else None
    coverage = (f"; held out: {_text(held.inside)} of {_text(held.samples)} errors within their bound"
                if held.samples else "")
    text = (f"predicted 95 % bound of the position of {_text(space.measurement)} at "
            f"{len(bounds)} postures drawn within the joint limits: median "
            f"{mm_text(space.median_bound, 3)}, largest {mm_text(space.max_bound, 3)}, "
            f"{_text(space.outside_fitted_range)} beyond the fitted joint range (bound widened){coverage}")
    drawn = figure(positions, bounds, held_bounds, held_errors, text)
    return (f'<div id="predicted-uncertainty">{drawn}'
            f'<p class="caption">{text[0].upper() + text[1:]}. Positions in the measurement frame; the 3D scene '
            "shows the same postures as dots coloured by their bound.</p></div>")


def error_figures(report: CalibrationReport) -> dict[str, float | None]:
    """The RMS position errors [m] the error figures state, read from the report: ``fit before``, ``fit after``
    and, with held-out samples, ``held out before`` and ``held out after``."""
    out = {"fit before": report.rms_before, "fit after": report.rms_after}
    if report.has_held_out:
        out.update({"held out before": report.test_rms_before, "held out after": report.test_rms_after})
    return out


def figures_text(report: CalibrationReport) -> str:
    """The RMS figures of :func:`error_figures` in words, as the error figures' text alternative states them:
    ``before, fit: RMS 1.7300 mm; after, fit: RMS 0.0144 mm; ...``."""
    parts = []
    for what, value in error_figures(report).items():
        where, when = what.rsplit(" ", 1)
        parts.append(f"{when}, {where}: RMS {mm_text(value)}")
    return "; ".join(parts)


def _per_sample_text(before: Array, after: Array, test_before: Array | None, test_after: Array | None) -> str:
    """What the per-sample figure draws, in words: how many samples, and the largest error of each series [mm]."""
    def largest(values: Array | None) -> str:
        finite = values[np.isfinite(values)] if values is not None else np.zeros(0)
        return mm_text(float(finite.max())) if finite.size else "–"

    text = f"{len(before)} fit samples, largest before {largest(before)}, after {largest(after)}"
    if test_before is not None and len(test_before):
        text += f"; {len(test_before)} held out, largest before {largest(test_before)}, after {largest(test_after)}"
    return text


def _difference_text(difference: float) -> str:
    """How far apart the two robots are drawn [m], in words."""
    if not math.isfinite(difference):
        return "their difference could not be measured"
    return f"their frames lie at most {mm_text(difference, 3)} apart over the samples"


def _camera_section(view: CalibrationView, truth: dict[str, float] | None) -> str:
    """The page's camera section (:func:`pincal.viz.pixel_views.camera_section`), empty without cameras: its module
    draws with matplotlib, imported here only for a calibration that has cameras (a third of a report's time)."""
    if not view.report.cameras:
        return ""
    from pincal.viz.pixel_views import camera_section

    return camera_section(view, truth)


def render_report(content: ReportContent, quiet: bool = True) -> str:
    """The report as one self-contained HTML page."""
    from pincal import __version__
    from pincal.viz import svg_figures as plots

    view, report = content.view, content.view.report
    problem = view.problem
    before, after = view.sample_errors()
    test_before, test_after = content.held_out_errors()
    has_lengths = view.has_lengths
    figures: list[str] = []
    names = problem.parameters.names
    units = [p.unit for p in problem.parameters]
    values = np.array([report.parameters[n].value for n in names], dtype=float)
    std = np.array([np.nan if report.parameters[n].std is None else report.parameters[n].std
                    for n in names], dtype=float)
    identified = [bool(report.parameters[n].identified) for n in names]
    truth = None if content.truth is None else np.array([content.truth.get(n, np.nan) for n in names])
    rms = error_figures(report)
    length = report.error_words[0]
    with Progress("figures", 4, quiet) as progress:
        if has_lengths:
            figures.append(plots.error_histograms(before, after, test_before, test_after, rms, length,
                                                  f"histograms of the {length} errors before and after calibration: "
                                                  + figures_text(report)))
            progress.advance()
            figures.append(plots.errors_per_sample(before, after, test_before, test_after, length,
                                                   f"{length} error of each sample before and after calibration: "
                                                   f"{_per_sample_text(before, after, test_before, test_after)}"))
            progress.advance()
        figures.append(plots.parameter_estimates(names, units, values, std, identified, truth,
                                                 f"estimated parameter deviations with error bars: {len(names)} "
                                                 f"parameters, {sum(identified)} identifiable"))
        progress.advance()
        if report.cost_history:
            history = report.cost_history
            figures.append(plots.convergence(history, f"cost per iteration: {len(history)} values, from "
                                                      f"{history[0]:.4g} to {history[-1]:.4g}"))
        progress.advance()
    scene, summary = static_scene(view, quiet=quiet)
    srcdoc = html.escape(scene, quote=True)
    notes = "".join(f"<li>{html.escape(n)}</li>" for n in summary.notes)
    dots = workspace_text(summary)  # the workspace points, coloured by their predicted bound
    shifts = report.reference_shifts or {}
    shift_text = ""
    if shifts:
        listed = ", ".join(f"{html.escape(k)} {v:+.6g}" for k, v in shifts.items())
        shift_text = (f"<p>The calibrated URDF is re-assembled at zero actuated readings; the passive joints' "
                      f"zero moved by (rad or m): {listed}. What the sensor of an instrumented passive joint reads "
                      "in the new file's terms is in its <code>&lt;joint_sensor joint=… zero=…&gt;</code> element "
                      "(the sensor reads q + zero; see docs/calibrated_urdf.md).</p>")
    tied = (", and the parameters tied to them (see below) may then differ from the truth while predicting the "
            "measurements just as well") if report.unidentifiable and content.truth else ""
    n_test = None if test_before is None else len(test_before)
    elsewhere = "camera below" if report.cameras else "parameter estimates"
    named, note = report_robot(report) if report.robot else (problem.robot.name, "")
    title = f"Calibration of {named}"
    ghost = "the nominal one" if _started_from(report) == "the nominal model" else _started_from(report)
    sources = " · ".join(html.escape(s) for s in content.sources)
    magnified = (f"errors magnified ×{summary.magnification:g}, coloured by size on the scale of the largest error "
                 f"({summary.error_scale * 1e3:.3g} mm)") if summary.has_points else "no 3D measurements"
    return f"""<!DOCTYPE html>
<html lang="en"><head><meta charset="utf-8"><meta name="viewport" content="width=device-width">
<title>{html.escape(title)} — pincal report</title><style>{STYLE}</style></head>
<body><main>
<h1>{html.escape(title)}</h1>
<p class="sub">{_text(report.n_samples)} fit samples{f', {n_test} held out' if n_test else ''} ·
{html.escape(', '.join(report.measurements))} · {_text(report.n_parameters)} parameters ·
pincal {__version__}{' · ' + sources if sources else ''}{' · ' + html.escape(note.strip(' ()')) if note else ''}</p>
{_cards(report)}
{_explains_nothing(report)}{_implausible(report)}{_verdict(report)}
<h2>The robot in 3D</h2>
<iframe id="scene" title="3D scene: nominal and calibrated robot with the sample errors" srcdoc="{srcdoc}"></iframe>
<p class="caption">Orange: the calibrated robot; blue ghost: {html.escape(ghost)}, both in the measurement frame
({html.escape(_difference_text(summary.robot_difference))});
black dots: measured points; segments: each sample's error, {magnified}. Use the slider (or ← →) to step through
the samples; drag to orbit, scroll to zoom.{' ' + html.escape(dots[:1].upper() + dots[1:]) + ' mm.' if dots else ''}</p>
<p class="caption" id="scene-status">3D scene: waiting for the viewer (needs JavaScript and WebGL).</p>
{f'<ul class="caption">{notes}</ul>' if notes else ''}
<h2>Summary</h2>
{_summary_table(report, n_test)}
<h2>Errors</h2>
{''.join(figures[:2]) if has_lengths else f'<p>No length-type measurement: see the {elsewhere}.</p>'}
{predicted_uncertainty(report)}
{_camera_section(content.view, content.truth)}
<h2>Parameters</h2>
{''.join(figures[2:] if has_lengths else figures)}
<p>Deviations from the nominal robot (lengths in mm, angles in degrees); σ is the standard deviation of the
estimate (±2σ bars in the figure). Parameters that are not identifiable keep minimum-norm values{tied}.</p>
{_parameter_table(content)}
{shift_text}
<h2>What the data cannot separate</h2>
{_combinations(report)}
{provenance_html(report.provenance.as_dict() if report.provenance is not None else None)}
</main>
<script>{SCENE_LISTENER}</script>
</body></html>
"""


def write_report(content: ReportContent, out: str | Path, quiet: bool = True) -> Path:
    """Write the report of ``content`` to ``out`` (parents created); returns the path."""
    path = Path(out)
    make_directory(path.parent, f"report '{path}'")
    return write_text(path, render_report(content, quiet))


def write_demo_report(calibration: Calibration, out_dir: str | Path, quiet: bool = True) -> Path:
    """``out_dir/report.html`` for ``pincal demo`` (with the truth from ``out_dir/truth.json`` if present); unless
    ``quiet``, the bars of its stages (figures, the scene) on stderr when it is a terminal."""
    out = Path(out_dir)
    view = CalibrationView.from_calibration(calibration)
    truth_path = out / "truth.json"
    truth = read_truth(truth_path) if truth_path.is_file() else None
    content = ReportContent(view, truth, ("pincal demo", str(out / "measurements.csv")))
    return write_report(content, out / "report.html", quiet)
