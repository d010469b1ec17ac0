"""``pincal check``: a calibrated model's errors on new measurements, beside the nominal robot's."""

from __future__ import annotations

import argparse
import math
import textwrap
from typing import TYPE_CHECKING, Any

from pincal.calibration.options import OPTIONS, GivenOptions
from pincal.cli.arguments import add_calibration_options, given_options

if TYPE_CHECKING:
    from pincal.calibration.report_sections import PixelAccount

#: The calibration options ``check`` takes: the weights, the registration's solver and iteration limit, and the
#: plausibility factor of calibrate's checks of the data.
CHECK_OPTIONS = ("sigma", "solver", "max_iter", "plausible")
#: The measurement setup a calibrated URDF holds, as the parameter kinds word it:
#: ``setup_phrase(kinds_where(setup=True, in_urdf=True))`` of :mod:`pincal.identification.parameters.kinds`, which the
#: parser cannot import (``--help`` loads no NumPy); ``tests/cli/test_check_setups.py`` holds the two together.
SETUP_HELD = "measurement frame, markers, cameras, targets and contact planes"

#: How a quantity's unit is shown: SI in the files, mm and mrad on the terminal.
SHOWN = {"m": ("mm", 1e3), "rad": ("mrad", 1e3)}
#: How many postures the terminal lists with their predicted bound (the report lists them all).
SAMPLE_LINES = 12


def _shown(value: float | None, unit: str) -> str:
    name, scale = SHOWN.get(unit, (unit, 1.0))
    return "–" if value is None or not math.isfinite(value) else f"{value * scale:.4f} {name}"


def _pair(figures: dict[str, Any], suffix: str, unit: str) -> str:
    return (f"MODEL {_shown(figures.get(f'rms{suffix}'), unit)} RMS, {_shown(figures.get(f'max{suffix}'), unit)} "
            f"max; nominal {_shown(figures.get(f'nominal_rms{suffix}'), unit)} RMS, "
            f"{_shown(figures.get(f'nominal_max{suffix}'), unit)} max")


def summary_text(content: dict[str, Any]) -> str:
    """The terminal summary of a check's report content (lengths in mm, angles in mrad)."""
    rows = ("every row, set=train and set=test alike" if content["rows"] == "all"
            else f"its set={content['rows']} rows, --set")
    lines = [f"pincal check: MODEL '{content['model']}' on {content['n_samples']} of the "
             f"{content['n_samples_in_file']} samples of '{content['data']}' ({rows})",
             f"  MODEL:   {content['model_means']}",
             f"  nominal: '{content['nominal']}'{' (--nominal)' if content['nominal_given'] else ''}, "
             f"{content['nominal_means']}", ""]
    width = max(len(q["measurement"]) for q in content["quantities"])
    lines.append(f"  {'measurement':<{width}}  {'quantity':<8} {'readings':>8}  {'MODEL RMS':>14} {'MODEL max':>14}"
                 f"  {'nominal RMS':>14} {'nominal max':>14}")
    for q in content["quantities"]:
        lines.append(f"  {q['measurement']:<{width}}  {q['quantity']:<8} {q['n']:>8}  "
                     f"{_shown(q['rms'], q['unit']):>14} {_shown(q['max'], q['unit']):>14}  "
                     f"{_shown(q['nominal_rms'], q['unit']):>14} {_shown(q['nominal_max'], q['unit']):>14}")
    lines.append("")
    if content.get("rms") is not None:
        lines.append(f"lengths:      {_pair(content, '', 'm')}")
    if "rms_angle" in content:
        lines.append(f"orientations: {_pair(content, '_angle', 'rad')}")
    lines += _pixel_lines(content)
    dropped = content["dropped_samples"]
    if dropped:
        reasons: dict[str, list[str]] = {}  # a reason per robot that left it out, one line per sample
        for d in dropped:
            said = reasons.setdefault(str(d["sample"]), [])
            if d["reason"] not in said:
                said.append(d["reason"])
        lines.append(f"samples left out ({len(reasons)}):")
        lines += [f"  {sample}: {'; '.join(why)}" for sample, why in list(reasons.items())[:10]]
        if len(reasons) > 10:
            lines.append(f"  … and {len(reasons) - 10} more (the report's 'dropped_samples')")
    outside = content["outside_range"]
    if not outside["known"]:
        lines.append(f"fitted range: not known: {outside['note']}")
    elif outside["samples"]:
        lines.append(f"outside the joint ranges the calibration fitted: {len(outside['samples'])} samples "
                     f"({', '.join(outside['samples'][:12])}{' …' if len(outside['samples']) > 12 else ''})")
        for name, part in (("outside", outside), ("inside", content["inside_range"])):
            lines.append(f"  {name + ':':<8} " + (f"reprojection {_pair(part['pixels'], '', 'px')}" if "pixels" in part
                                                  and part.get("rms") is None else _pair(part, '', 'm')))
    else:
        lines.append("every posture lies within the joint ranges the calibration fitted")
    lines += _predicted_lines(content)
    for side, note in (content.get("registration_notes") or {}).items():
        lines.append(f"note: {'MODEL' if side == 'model' else 'the nominal robot'}: {note}")
    if content.get("nominal_changed"):
        lines.append("warning: the nominal URDF changed since the calibration (its SHA-256 differs from the one "
                     "MODEL records)")
    if content["implausible"] is not None:
        lines += _implausible_lines(content)
        lines.append("verdict: none: DATA are not of a robot of this model (IMPLAUSIBLE above); the errors say nothing "
                     "of MODEL")
    elif content["worse_than_nominal"]:
        lines.append("verdict: MODEL predicts DATA WORSE than the nominal robot")
    else:
        lines.append("verdict: MODEL predicts DATA no worse than the nominal robot")
    hint = _register_hint(content)
    if hint:
        lines.append(f"  hint: {hint}")
    from pincal.calibration.check_groups import beyond_note, beyond_verdict

    beyond, few = beyond_verdict(content), beyond_note(content)
    if beyond is not None:
        lines += textwrap.wrap(f"verdict beyond the fitted range: {beyond}", 120, subsequent_indent="  ")
    elif few is not None:
        lines += textwrap.wrap(f"note: {few}", 120, subsequent_indent="  ")
    return "\n".join(lines)


def _pixel_lines(content: dict[str, Any]) -> list[str]:
    """The reprojection errors' lines [px]: over every corner seen, then each image's (the RMS of its corners)."""
    if not content.get("pixels"):
        return []
    lines = [f"reprojection: {_pair(content['pixels'], '', 'px')} (over {content['pixels']['n_corners']} corners)"]
    predicted: PixelAccount | None = content.get("pixel_predicted")
    if predicted and predicted.median_bound is not None:
        lines.append(f"predicted 95 % bound of an image's reprojection error: median {predicted.median_bound:.3f} px"
                     f"{_at_board(predicted.median_bound_at_board)} (MODEL's prediction alone "
                     f"{predicted.median_model_bound:.3f} px, the rest the corners' noise); "
                     f"{predicted.inside} of {predicted.images} images of MODEL within their bound")
    lines.append("  per image (RMS of its corners): MODEL, nominal" + (", predicted bound" if predicted else ""))
    images = [s for s in content["samples"] if "pixel_error" in s]
    lines += [f"  {s['sample']}: {_shown(s['pixel_error'], 'px')}, {_shown(s['nominal_pixel_error'], 'px')}"
              + (f", {s['pixel_bound']:.3f} px{_at_board(s['pixel_bound_at_board'])}"
                 if s.get("pixel_bound") is not None else "")
              for s in images[:SAMPLE_LINES]]
    if len(images) > SAMPLE_LINES:
        lines.append(f"  … and {len(images) - SAMPLE_LINES} more (the report's 'samples')")
    return lines


def _at_board(metres: float | None) -> str:
    """`` (x mm at the board)`` for a length [m] at the board, or nothing when not known."""
    return f" ({metres * 1e3:.3f} mm at the board)" if metres is not None else ""


def _register_hint(content: dict[str, Any]) -> str | None:
    """Why to check with ``--register``, when DATA look measured in another setup than MODEL's: without it, MODEL worse
    than a nominal robot registered on DATA, or most of MODEL's errors beyond their predicted bound."""
    from pincal.calibration.check_setup import NOMINAL_AS_CALIBRATED

    if content["registered"] or content["implausible"] is not None:
        return None
    predicted = content["predicted"]
    if predicted["known"] and predicted["samples"] and predicted["inside"] < predicted["samples"] / 2:
        return (f"{predicted['samples'] - predicted['inside']} of {predicted['samples']} errors of MODEL exceed their "
                "predicted bound: if the tracker, the markers or the cameras moved since the calibration, check with "
                "--register")
    if content["worse_than_nominal"] and content["nominal_means"] != NOMINAL_AS_CALIBRATED:
        return ("the nominal side's measurement setup is registered on DATA, MODEL's is the file's: if the tracker, "
                "the markers or the cameras moved since the calibration, check with --register")
    return None


def _factor(plausible: float | str) -> str:
    return f"{plausible:g}" if isinstance(plausible, float | int) else str(plausible)


def _implausible_lines(content: dict[str, Any]) -> list[str]:
    """What calibrate's checks find in DATA (docs/check.md, 'Plausibility'): the nominal robot's errors beyond a robot
    of its model, the corrections a calibration on DATA would need, and the likely cause, wrapped at 120 columns."""
    from pincal.calibration.summary import correction

    found = content["implausible"]
    unit = "m" if found["quantity"] == "length" else "rad"
    demanded = [f"{c['parameter']} {correction(c['value'], c['unit'])} (limit "
                f"{correction(c['limit'], c['unit']).lstrip('+')})" for c in found["corrections"][:3]]
    more = len(found["corrections"]) - len(demanded)
    fit = (f"; calibrated on DATA, it would need {', '.join(demanded)}{f' and {more} more' if more else ''}"
           if demanded else f"; {found['note']}" if found["note"] else "")
    text = (f"IMPLAUSIBLE: the nominal robot predicts DATA {_shown(found['nominal_rms'], unit)} RMS with its "
            f"measurement setup fitted to DATA, beyond the {correction(found['limit'], unit).lstrip('+')} a robot of "
            f"this model is off by (--plausible {_factor(found['plausible'])}){fit}")
    return [*textwrap.wrap(text, 120, subsequent_indent="    ", break_on_hyphens=False),
            *textwrap.wrap(f"likely cause: {found['cause']}", 120, initial_indent="  ", subsequent_indent="    ",
                           break_on_hyphens=False)]


def _predicted_lines(content: dict[str, Any]) -> list[str]:
    """The predicted bounds' lines: each posture's bound and the coverage, and a warning for bounds widened beyond the
    fitted joint range."""
    predicted = content["predicted"]
    if not predicted["known"]:
        return [] if content.get("pixel_predicted") and not content.get("rms") else \
            [f"predicted errors: not known: {predicted['note']}"]
    lines = [f"predicted 95 % bound: median {predicted['median_bound'] * 1e3:.4f} mm; {predicted['inside']} of "
             f"{predicted['samples']} errors of MODEL within their bound ({predicted['fraction']:.0%})"]
    lines += [f"  {s['sample']}: error {s['error'] * 1e3:.4f} mm, bound {s['bound'] * 1e3:.4f} mm"
              + (f" ({s['distance']:.2f} range widths beyond the fitted range)" if s["distance"] > 0.0 else "")
              + (f"; the nominal robot's own {s['nominal_bound'] * 1e3:.4f} mm" if s.get("nominal_bound") else "")
              for s in content["samples"][:SAMPLE_LINES] if s.get("bound") is not None and s.get("error") is not None]
    if len(content["samples"]) > SAMPLE_LINES:
        lines.append(f"  … and {len(content['samples']) - SAMPLE_LINES} more (the report's 'samples')")
    beyond = predicted["beyond"]
    if beyond:
        inside, out = predicted["in_range"], predicted["beyond_range"]
        lines.append(f"warning: {len(beyond)} postures lie beyond the joint ranges the calibration fitted "
                     f"({', '.join(beyond[:8])}{' …' if len(beyond) > 8 else ''}): MODEL extrapolates there, its "
                     f"bounds grow with the distance; within their bound: {out['inside']} of {out['samples']} beyond, "
                     f"{inside['inside']} of {inside['samples']} inside")
    return lines


def cmd_check(args: argparse.Namespace) -> int:
    """``pincal check``: predict DATA with MODEL and with the nominal robot, print the errors side by side, write
    ``--report`` and ``--html``; exit status 1 when MODEL predicts DATA worse than the nominal robot, a registration
    did not converge, or DATA are implausible for a robot of this model (calibrate's checks)."""
    from pincal.calibration.check import run_check
    from pincal.io.files import json_text, write_texts

    outputs = [(what, path) for what, path in (("--report", args.report), ("--html", args.html)) if path]
    given = GivenOptions.of(given_options(args), "command line")
    check, content = run_check(args.model, args.data, args.nominal_path, given, args.register, outputs, args.rows)
    print(summary_text(content))
    texts = []
    if args.report:
        texts.append((args.report, json_text(content)))
    if args.html:
        from pincal.viz.check_page import check_page

        texts.append((args.html, check_page(content)))
    for path in write_texts(texts):
        print(f"wrote {path}")
    unconverged = [side for side, done in (("MODEL", check.model.converged), ("nominal robot", check.nominal.converged))
                   if done is False]
    if unconverged:  # the comparison is of setups not yet fitted
        print(f"NOT CONVERGED: the registration of the {' and the '.join(unconverged)} reached the iteration limit "
              "(--max-iter): the figures compare setups not yet fitted")
    return 1 if check.worse_than_nominal or check.worse_beyond or unconverged or check.implausible is not None else 0


def register(sub: argparse._SubParsersAction[argparse.ArgumentParser]) -> None:
    """Add the ``check`` command."""
    check = sub.add_parser(
        "check", help="predict new measurements with a calibrated model, beside the nominal robot",
        description="Predict every measurement of DATA (every row, set=train and set=test alike; --set: one set) "
                    "with MODEL and "
                    "with the nominal robot; print the RMS and max error of each quantity side by side. MODEL is "
                    f"used as it stands (its {SETUP_HELD} as the file holds them); the nominal robot has the "
                    "measurement setup the calibration registered for it on its own data (calibrate's 'before', "
                    "which MODEL records; registered on DATA when MODEL "
                    "records none). --register re-estimates both setups on DATA (least squares), the robots held. "
                    "Exit status 1 when MODEL predicts DATA worse than the nominal robot, or a registration "
                    "did not converge, or DATA are implausible for a robot of this model, as calibrate judges them "
                    "(docs/check.md); 2 for lengths or joint readings in a wrong unit (calibrate's checks, before any "
                    "work).",
        epilog="example: pincal check cal.urdf new_day.csv --register --report check.json --html check.html")
    check.add_argument("model", metavar="MODEL",
                       help="calibrated URDF (its .corrections.json beside it is read), a known robot name, or the "
                            "report JSON of 'pincal calibrate --report'")
    check.add_argument("data", metavar="DATA", help="measurement CSV (docs/dataset.md) or job file JOB.toml")
    check.add_argument("--nominal", metavar="ROBOT", dest="nominal_path",
                       help="the nominal robot (URDF or known name; default: the one MODEL records)")
    check.add_argument("--register", action="store_true",
                       help=f"re-estimate the measurement setup ({SETUP_HELD}) of both robots on DATA, their "
                            "geometry held")
    check.add_argument("--set", choices=("train", "test"), dest="rows",
                       help="check only the rows of this set (a CSV's 'set' column; a job file's held_out rows are "
                            "'test'): calibrate on train, check on test (default: every row)")
    check.add_argument("--report", metavar="R.json", help="report JSON to write (SI units)")
    check.add_argument("--html", metavar="PAGE.html", help="self-contained HTML page to write")
    add_calibration_options(check, skip=[name for name in OPTIONS if name not in CHECK_OPTIONS])
    check.set_defaults(func=cmd_check)
