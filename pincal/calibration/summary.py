"""A calibration's report as the terminal reads it: the summary ``pincal calibrate`` and ``pincal demo`` print, and
the one-word verdict of ``pincal fleet``. Everything here reads the typed report (:class:`CalibrationReport`); nothing
recomputes a figure. Lengths are printed in mm, angles in mrad.
"""

from __future__ import annotations

import math
import textwrap
from collections.abc import Callable, Sequence
from pathlib import Path

from pincal import validation
from pincal.calibration.heldout import NOISE_CONTRADICTED
from pincal.calibration.report import CalibrationReport
from pincal.calibration.report_sections import BadJointReading
from pincal.calibration.summary_camera import camera_lines
from pincal.calibration.summary_model import mm, mrad, predicted_lines, selection_lines
from pincal.identification.parameters import DEFAULT_SET, NAMED_SETS


def robot_named(given: str, urdf_name: str) -> str:
    """A robot as the user named it: a known robot's name as typed (``tiago_no_hand``, whose URDF says
    ``<robot name="tiago">``); a URDF file by its ``<robot name>`` (its path is said where the files are)."""
    return urdf_name if not given or Path(given).suffix or "/" in given else given


def urdf_name_note(given: str, urdf_name: str) -> str:
    """``(URDF <robot name="tiago">)`` when the name :func:`robot_named` gives differs from the URDF's, else empty."""
    return "" if robot_named(given, urdf_name) == urdf_name else f' (URDF <robot name="{urdf_name}">)'


def report_robot(report: CalibrationReport) -> tuple[str, str]:
    """The robot of ``report`` as the user named it and the note on its URDF's name (:func:`robot_named`,
    :func:`urdf_name_note`, from the report's provenance)."""
    given = report.provenance.robot.file if report.provenance is not None and report.provenance.robot else None
    given = given if isinstance(given, str) else ""
    return robot_named(given, report.robot), urdf_name_note(given, report.robot)


def _finite(value: float | None) -> bool:
    """Whether a figure was measured (not None, not NaN)."""
    return value is not None and math.isfinite(value)


def px(value: float | None) -> str:
    """A reprojection error [px], or ``-``."""
    return "-" if value is None else f"{value:.3f} px"


def _figure_rows(quantity: str, part: str, unit: Callable[[float | None], str], rms_before: float | None,
                 rms_after: float | None, max_before: float | None, max_after: float | None,
                 width: int = 32) -> list[str]:
    """The RMS and max rows of the before/after table for one quantity of one part (fit or held out), labels in
    ``width`` characters."""
    return [f"{f'RMS {quantity} error ({part})':{width}}{_column(unit(rms_before))}{_column(unit(rms_after))}",
            f"{f'max {quantity} error ({part})':{width}}{_column(unit(max_before))}{_column(unit(max_after))}"]


def _label_width(report: CalibrationReport) -> int:
    """The width of the before/after table's labels [characters]: 32, or the longest label it prints."""
    length, angle = report.error_words
    words = [length] + ([angle] if report.rms_angle_before is not None else [])
    parts = ["fit"] + (["held out"] if report.has_held_out else []) + (["cross-val."] if report.cv is not None else [])
    return max(32, *(len(f"RMS {word} error ({part})") for word in words for part in parts))


def _column(value: str) -> str:
    """A figure of the before/after table, right-aligned in 14 characters and never run into the one before it."""
    return f" {value:>13}"


def _heavy_payload(report: CalibrationReport) -> str | None:
    """A warning when the payload [kg] outweighs every moving link of the robot together (grams typed as kilograms,
    a load meant for another robot). When the URDF gives the links no mass there is nothing to weigh it against: a
    note says so, and that the compliances then rest on the payload's gravity torque alone."""
    payload, links = report.payload, report.links_mass
    if payload is None or links is None:
        return None
    if links <= 0.0:
        return (f"note: the URDF gives the robot's moving links no mass (no <inertial>), so the payload's "
                f"{payload.mass:g} kg cannot be checked against theirs, and the compliances rest on its gravity "
                "torque alone: right for a light arm under a heavy tool, wrong if the URDF merely leaves the masses "
                "out")
    if payload.mass <= links:
        return None
    return (f"warning: the payload ({payload.mass:g} kg) outweighs all the robot's moving links together "
            f"({links:.3g} kg, from the URDF): check its mass [kg] and its frame")


def summary_text(report: CalibrationReport, seconds: float, report_path: str | None = None,
                 parameter_spec: Sequence[str] | None = None) -> str:
    """The summary ``pincal calibrate`` prints: the verdict lines first (not converged, worse than nominal, residuals
    above the stated noise, implausible corrections with their likely cause), the fit's account, the before/after
    table [mm, mrad], where every sample went, the warnings, and the combinations the data cannot separate;
    ``seconds`` is the fit's wall time; ``parameter_spec``, the parameters as the user named them (default: as the
    report's provenance records them)."""
    validation.instance("report", report, CalibrationReport, "a CalibrationReport (a calibration's .report)")
    length, angle = report.error_words
    width = _label_width(report)
    lines = [_explains_nothing(report),  # first: nothing below is a result
             f"NOT CONVERGED: {report.message} after {report.iterations} iterations; the estimate below is "
             "where the solver stopped, not a calibration (try --max-iter, fewer --parameters or more samples)"
             if not report.converged else None,
             f"WORSE THAN NOMINAL: the calibrated model predicts the held-out samples worse than the nominal one "
             f"(RMS {mm(report.test_rms_after)} against {mm(report.test_rms_before)}); keep the nominal model, "
             "or fit fewer parameters, or measure postures that cover the held-out range"
             if report.worse_than_nominal else None,
             # said first: "converged" must not read as "fits the data"
             _noise_verdict(report),
             *_implausible(report),  # after the one-line verdicts: it lists the parameters
             f"samples {report.n_samples}, parameters {report.n_parameters}, "
             f"identifiable {report.n_identifiable}, estimated {report.n_estimated}"
             f", condition number {report.condition_number:.3g}" if report.condition_number else "",
             *selection_lines(report),
             f"payload {report.payload}, in the gravity torque of the compliances"
             if report.payload is not None else None,
             _heavy_payload(report),
             f"solver {report.solver}, loss {report.loss}: {report.message} after {report.iterations} "
             f"iterations, {seconds:.3f} s",
             "",
             f"{'':{width}}{'before':>14}{'after':>14}",
             *(_figure_rows(length, "fit", mm, report.rms_before, report.rms_after, report.max_before,
                            report.max_after, width) if report.pixels is None or _finite(report.rms_before) else [])]
    if report.rms_angle_before is not None:
        lines += _figure_rows(angle, "fit", mrad, report.rms_angle_before, report.rms_angle_after,
                              report.max_angle_before, report.max_angle_after, width)
    if report.has_held_out and (report.test_pixels is None or _finite(report.test_rms_before)):
        lines += _figure_rows(length, "held out", mm, report.test_rms_before, report.test_rms_after,
                              report.test_max_before, report.test_max_after, width)
    if report.test_rms_angle_before is not None:
        lines += _figure_rows(angle, "held out", mrad, report.test_rms_angle_before,
                              report.test_rms_angle_after, report.test_max_angle_before, report.test_max_angle_after,
                              width)
    for part, figures in (("fit", report.pixels), ("held out", report.test_pixels)):
        if figures is not None:
            lines.append(f"{f'RMS reprojection error ({part})':{width}}{_column(px(figures.rms_before))}"
                         f"{_column(px(figures.rms_after))}")
    if report.before_means:
        lines += textwrap.wrap(f"(before: {report.before_means})", 120, subsequent_indent=" ")
    if report.rms_start is not None:
        held = f", {mm(report.test_rms_start)} (held out)" if report.test_rms_start is not None else ""
        what, _, why = report.start_means.partition(", for fit and held-out samples alike")
        why = why.removeprefix("; ")  # why a closed form could not place the setup: said, not dropped
        lines += textwrap.wrap(f"(the fit's start, {what}: RMS {mm(report.rms_start)} (fit){held}"
                               f"{'; ' + why if why else ''})", 120, subsequent_indent=" ")
    lines += predicted_lines(report)
    if report.joints_at_reference:
        lines += _listed_in_lines("not in the file, at their reference (they move nothing measured)",
                                  report.joints_at_reference, JOINT_LINES)
    lines += _accounting(report)
    if report.calibration_gain is not None:
        lines.append(f"{'calibration gain G (study 000)':32}{'':>14}{report.calibration_gain:>12.1f} %")
        if report.unidentifiable:
            lines.append("  (G compares every parameter with the truth; parameters the data cannot separate stay at "
                         "minimum-norm values, which caps G: the position errors are the measure that counts)")
    lines += _generalization(report)
    if report.unidentifiable:
        lines.append("")
        lines += _unseen(report, parameter_spec, report_path)
    return "\n".join(_within_width([line for line in lines if line is not None]))


#: The summary's widest line [characters]: a terminal of 120 columns shows each whole.
WIDTH = 120
#: Most lines the summary gives the joints left at their reference (the report's ``joints_at_reference`` has them all).
JOINT_LINES = 3


def _within_width(lines: list[str]) -> list[str]:
    """``lines`` with each longer than :data:`WIDTH` wrapped at its words, the continuation indented two spaces more
    than the line."""
    out: list[str] = []
    for line in lines:
        if len(line) <= WIDTH:
            out.append(line)
            continue
        indent = " " * (len(line) - len(line.lstrip(" ")) + 2)
        out += textwrap.wrap(line, WIDTH, subsequent_indent=indent, break_on_hyphens=False, break_long_words=False)
    return out


def _listed_in_lines(heading: str, names: Sequence[str], most: int) -> list[str]:
    """``heading: a, b, c`` in at most ``most`` lines of :data:`WIDTH` characters: the names that fit, then how many
    more there are ("and 9 more (the report's joints_at_reference)")."""
    for shown in range(len(names), 0, -1):
        rest = len(names) - shown
        more = f", and {rest} more (the report's joints_at_reference)" if rest else ""
        lines = textwrap.wrap(f"{heading}: {', '.join(names[:shown])}{more}", WIDTH, subsequent_indent="  ",
                              break_on_hyphens=False)
        if len(lines) <= most:
            return lines
    return textwrap.wrap(f"{heading}: {len(names)} joints (the report's joints_at_reference)", WIDTH,
                         subsequent_indent="  ")


def _explains_nothing(report: CalibrationReport) -> str | None:
    """The first line of a fit that explains nothing (residuals beyond 1000 × σ: not a result, no calibrated URDF);
    None for any other."""
    if not report.explains_nothing:
        return None
    left = (f", and RMS {mm(report.rms_after)} of the start's {mm(report.rms_before)} left"
            if report.rms_before is not None and report.rms_after is not None else "")
    cause = (f"likely cause: {report.implausible_cause}" if report.implausible_cause and not report.implausible
             and not report.implausible_scale else
             "the data do not belong to this robot as they are read (another robot's, readings not of their postures, "
             "a frame that does not move as the data do)")
    return (f"THE FIT EXPLAINS NOTHING: residuals {(report.sigma2 or 0.0) ** 0.5:.3g} × σ after calibration, beyond "
            f"1000 × σ{left}: not a result, and no calibrated URDF is written of it (--force writes one); {cause}")


def _noise_verdict(report: CalibrationReport) -> str | None:
    """The verdict line of a fit that does not reach the stated noise (residuals beyond 3 × σ but not so far that it
    explains nothing); None within it."""
    ratio = (report.sigma2 or 0.0) ** 0.5
    if ratio ** 2 > NOISE_CONTRADICTED and not report.explains_nothing:
        if report.estimated_sigma:
            return (f"THE FIT DOES NOT REACH THE NOISE THE DATA SHOW: residuals {ratio:.3g} × the σ estimated from "
                    "them after calibration; the model, held as the prior holds it, cannot fit these data (see the "
                    "warning below)")
        return (f"THE FIT DOES NOT REACH THE STATED NOISE: residuals {ratio:.3g} × σ after calibration; either the "
                "stated σ is wrong or the model cannot fit these data (see the warning below)")
    return None


def _named_parameters(report: CalibrationReport, spec: Sequence[str] | None) -> bool:
    """Whether the user named parameters one by one (``--parameters`` patterns), not only sets of candidates (the
    default set, the named sets)."""
    if spec is None:
        spec = report.provenance.options.get("parameter_spec") if report.provenance is not None else None
    return any(token not in (DEFAULT_SET, *NAMED_SETS) for token in spec or [])


def _unseen(report: CalibrationReport, spec: Sequence[str] | None, report_path: str | None) -> list[str]:
    """What the data cannot see: for candidate sets, the expected redundancy in a sentence; parameters the user named
    that the data cannot separate, one line each (the first :data:`UNIDENTIFIABLE_LINES`)."""
    count = len(report.unidentifiable)
    if report.unidentifiable_digest and not _named_parameters(report, spec):
        where = "listed in the report's 'unidentifiable'" if report_path else "--report FILE lists each"
        return textwrap.wrap(f"not seen by these data: {report.unidentifiable_digest}; {where}", 120,
                             subsequent_indent="  ", break_on_hyphens=False)
    return [_unidentifiable_heading(report, spec),
            *(report.unidentifiable_listing or [f"  - {text}" for text in report.unidentifiable]),
            f"  (all {count} in full: the report's 'unidentifiable')" if report_path else
            f"  (all {count} in full: --report FILE writes them, under 'unidentifiable')"]


def _unidentifiable_heading(report: CalibrationReport, spec: Sequence[str] | None) -> str:
    """The heading of the directions the data cannot see: a note for the default set, whose candidates overlap by
    construction (placements whose motion duplicates another's, directions no measurement sees); a warning when the
    user named parameters one by one."""
    count = len(report.unidentifiable)
    if _named_parameters(report, spec):
        return (f"warning: the parameters named are not all identifiable from these data ({count} "
                f"direction{'s' if count != 1 else ''}):")
    return (f"what these data cannot see ({count} of {report.n_parameters} candidate directions; expected of "
            "candidate sets, left at minimum norm):")


#: Most implausible corrections listed one per line in the summary; the report JSON lists them all.
IMPLAUSIBLE_LINES = 8


def correction(value: float, unit: str) -> str:
    """A correction [m or rad, or a compliance's unit] for the terminal: mm, degrees, or as it is."""
    if unit == "m":
        return f"{value * 1e3:+.1f} mm"
    if unit == "rad":
        return f"{math.degrees(value):+.2f}°"
    return f"{value:+.3g} {unit}"


def _implausible(report: CalibrationReport) -> list[str]:
    """The verdict lines of an implausible result: the scales and the corrections beyond their limits, the likely
    cause and how to change the limits (nothing for a plausible one)."""
    if not report.is_implausible:
        return []
    n = len(report.implausible)
    found = (["the data's lengths are scaled against this robot's"] if report.implausible_scale else []) \
        + ([f"{n} correction{'s' if n != 1 else ''} beyond what a robot of this model needs"] if n else [])
    lines = textwrap.wrap(f"IMPLAUSIBLE: {' and '.join(found)} (--plausible {report.plausible:g} times the limits of "
                          "docs/calibrated_urdf.md, 'Plausible corrections'); the result is refused", 120,
                          subsequent_indent="  ", break_on_hyphens=False)
    for s in report.implausible_scale:
        lines += textwrap.wrap(f"  - the measured positions '{s.measurement}' spread {s.scale:.3g} times as far "
                               "as the nominal robot's at the same joint readings (plausible within "
                               f"{s.limit:.3g} times either way)", 120, subsequent_indent="    ",
                               break_on_hyphens=False)
    lines += [f"  - {c.parameter} corrected by {correction(c.value, c.unit)} (limit "
              f"{correction(c.limit, c.unit).lstrip('+')})" for c in report.implausible[:IMPLAUSIBLE_LINES]]
    if len(report.implausible) > IMPLAUSIBLE_LINES:
        lines.append(f"  … and {len(report.implausible) - IMPLAUSIBLE_LINES} more (the report's 'implausible')")
    if report.implausible_cause:
        lines += textwrap.wrap(f"likely cause: {report.implausible_cause}", 120, initial_indent="  ",
                               subsequent_indent="    ", break_on_hyphens=False)
    lines.append("  (if the data are right for this robot: --plausible F widens the limits F times, --plausible off "
                 "turns the check off)")
    return lines


#: Cross-validated error above this multiple of the fit error is called overfitting.
OVERFIT_RATIO = 1.5
#: Fewer measured values than this per estimated parameter are called few (when no held-out sample or
#: cross-validation measures the generalization).
VALUES_PER_PARAMETER = 5


def _generalization(report: CalibrationReport) -> list[str]:
    """The cross-validated error beside the fit's, and the warnings about generalization."""
    lines = []
    cv = report.cv
    cv_rms = cv.rms if cv is not None else None
    if cv is not None and cv_rms is None:
        lines.append(f"cross-validation ({cv.plan}): no fold could be fitted; first: {cv.failed_folds[0]}")
    elif cv is not None and cv_rms is not None:
        (length, angle), width = report.error_words, _label_width(report)
        row = f"{f'RMS {length} error (cross-val.)':{width}}{'':>14}{mm(cv_rms):>14}"
        plan = f"({cv.plan}, {cv.n_samples} samples, {cv.n_predictions} predictions)"
        lines += [f"{row}  {plan}"] if len(row) + 2 + len(plan) <= WIDTH else [row, f"  {plan}"]
        for key, value in (cv.rms_by_reading or {}).items():
            lines.append(f"{'  ' + key:{width}}{'':>14}{mm(value):>14}")
        if cv.rms_angle is not None:
            lines.append(f"{f'RMS {angle} error (cross-val.)':{width}}{'':>14}{mrad(cv.rms_angle):>14}")
        if cv.failed_folds:
            lines.append(f"  ({len(cv.failed_folds)} fold fits failed and are left out; the report lists them)")
        if cv.unconverged_folds:
            lines.append(f"  ({cv.unconverged_folds} fold fits stopped before converging; their predictions count)")
        fit = report.rms_after
        if fit and cv_rms > OVERFIT_RATIO * fit:
            lines.append(f"warning: the cross-validated error is {cv_rms / fit:.2g} × the fit error: the model "
                         "follows these samples more closely than it predicts new ones (overfitting)")
    rows = report.n_residuals
    estimated = report.n_estimated
    measured = report.has_held_out or cv is not None  # generalization measured: the figures above say it, not a count
    if rows and estimated and rows < VALUES_PER_PARAMETER * estimated and not measured:
        lines.append(f"warning: {rows / estimated:.2g} measured values per estimated parameter "
                     f"(< {VALUES_PER_PARAMETER}): check generalization with --cv 5, or add postures")
    return lines


def _readings(report: CalibrationReport) -> list[str]:
    """How many position readings the figures are made of, per marker, when a file measures several markers or
    some were not seen (nothing otherwise: then every sample holds every reading)."""
    fitted, unseen = report.readings or {}, report.readings_not_seen or {}
    if report.cameras:  # corners, not positions: the camera lines count them
        return camera_lines(report)
    if len(unseen) < 2 and not any(unseen.values()):
        return []
    per_frame: dict[str, list[str]] = {}
    for key in unseen:  # position:<frame>@<marker> or position:<frame>
        frame, _, marker = key.partition(":")[2].partition("@")
        per_frame.setdefault(frame, []).append(f"{marker or 'origin'} {fitted[key]}")
    parts = "; ".join(f"{frame}: {', '.join(counts)}" for frame, counts in per_frame.items())
    held = report.test_readings or {}
    return [f"position readings: fitted {sum(fitted[key] for key in unseen)} ({parts}), not seen "
            f"{sum(unseen.values())}" + (f"; held out {sum(held.get(key, 0) for key in unseen)}" if held else ""),
            "  (each RMS position error is over the readings taken: one 3D error per marker seen)"]


#: Most samples listed one per line in the summary; the report JSON lists them all.
LISTED = 10
#: Share of down-weighted samples from which the summary warns that the robust fit is stretched.
ROBUST_WARNING_FRACTION = 0.25


def bad_reading_text(entry: BadJointReading) -> str:
    """One bad joint reading of the report (``bad_readings``) in words: the sample, the joint, how far its reading looks
    off (rad, or mm for a prismatic joint) and the share of the sample's error that explains."""
    off = float(entry.off)
    size = f"{off * 1e3:+.1f} mm" if entry.unit == "m" else f"{off:+.3f} rad"
    return (f"sample {entry.sample}: {entry.joint} reading looks {size} off (explains "
            f"{math.floor(1000.0 * float(entry.explained)) / 10.0:.1f} % of its error); left out")


def _accounting(report: CalibrationReport) -> list[str]:
    """Where every sample of the file went, and whether the residuals agree with the stated noise."""
    dropped = report.dropped_samples + (report.dropped_test_samples or [])
    weighted = report.down_weighted
    held = report.n_test_samples or 0
    total = report.n_samples_in_file or report.n_samples + held + len(dropped)
    lines = ["", f"samples in the file {total}: fitted {report.n_samples}, held out {held}, dropped {len(dropped)}"
                 + (f", down-weighted {len(weighted)} of the fitted" if weighted else "")]
    lines += _readings(report)
    if dropped:
        lines.append(f"dropped ({len(dropped)}):")
        lines += [f"  - sample {d.sample}: {d.reason}" for d in dropped[:LISTED]]
    bad = report.bad_readings or []
    if bad:
        lines.append(f"bad joint readings, left out of the fit ({len(bad)}):")
        lines += [f"  - {bad_reading_text(entry)}" for entry in bad[:LISTED]]
    named = {str(entry.sample) for entry in bad}
    weighted_only = [w for w in weighted if str(w.sample) not in named]
    if weighted_only:
        lines.append(f"down-weighted by the robust loss ({len(weighted_only)}):")
        lines += [f"  - sample {w.sample}: weight {w.weight:.3g}"
                  + (f", error {mm(w.error_after)} after calibration" if w.error_after is not None else "")
                  for w in weighted_only[:LISTED]]
    strange = report.held_out_outliers or []
    if strange:
        shown = ", ".join(strange[:LISTED]) + (" ..." if len(strange) > LISTED else "")
        lines += [f"held-out samples the calibrated model cannot explain ({len(strange)}): {shown}",
                  "  (they weigh on the held-out figures, not on the comparison with the nominal model)"]
    outside = report.held_out_outside_range or []
    if outside:  # one line of at most 120 characters: a few samples, else their count
        ids, joints = list(dict.fromkeys(str(o.sample) for o in outside)), list(dict.fromkeys(o.joint for o in outside))
        where = joints[0] if len(joints) == 1 else f"{len(joints)} actuated joints"
        shown = ", ".join(ids[:3]) + (f" (+{len(ids) - 3})" if len(ids) > 3 else "")
        lines.append(next(line for line in (f"warning: held-out sample {shown} lies outside the fitted range of "
                                            f"{where}: its error measures extrapolation" if len(ids) == 1 else
                                            f"warning: held-out samples {shown} lie outside the fitted range of "
                                            f"{where}: their errors measure extrapolation",
                                            f"warning: {len(ids)} held-out samples lie outside the fitted range of "
                                            f"{where}: their errors measure extrapolation",
                                            f"warning: {len(ids)} held-out samples lie outside the fitted range of "
                                            "the actuated joints: their errors measure extrapolation")
                          if len(line) <= 120))
    if weighted and len(weighted) >= ROBUST_WARNING_FRACTION * report.n_samples:
        lines.append(f"warning: {len(weighted)} of the {report.n_samples} fitted samples "
                     f"({len(weighted) / report.n_samples:.0%}) were down-weighted: a robust fit is not meant for "
                     "that many; check the measuring set-up and the model before using the result")
    if len(dropped) > LISTED or len(weighted) > LISTED:
        lines.append(f"  (the first {LISTED} of each are listed; --report writes them all)")
    lines += _estimated_sigma(report)
    sigma2 = report.sigma2
    if sigma2 is not None and sigma2 > 0:
        ratio = sigma2**0.5
        stated = "estimated" if report.estimated_sigma else "stated"
        lines.append(f"a-posteriori σ: {ratio:.3g} × the {stated} σ (σ² factor {sigma2:.4g}); the standard deviations "
                     "use it")
        if not 1 / 3 <= ratio <= 3 and report.estimated_sigma:
            lines += textwrap.wrap(
                f"warning: the residuals are {ratio:.3g} × the noise the data show (σ estimated with every parameter "
                "free): the model misses an effect of these postures that only parameters held loosely could absorb "
                "(the prior and its range guard hold them where they predict beyond the data), or the data hold "
                "outliers", 120, subsequent_indent="  ")
        elif not 1 / 3 <= ratio <= 3:
            lines.append(f"warning: the residuals are {ratio:.3g} × the stated noise: the stated σ (--sigma or the "
                         "file's '# sigma' lines) is wrong, or the model misses an effect")
    return lines


def _estimated_sigma(report: CalibrationReport) -> list[str]:
    """The σ estimated from the data for the readings no '# sigma' line states: one line, in mm and mrad (a joint
    reading's in its own unit, rad or m)."""
    if not report.estimated_sigma:
        return []
    parts = []
    for key, kinds in report.estimated_sigma.items():
        rows, units = kinds.rows, kinds.units
        shown = [f"{name} {value * 1e3:.3g} {'mm' if units.get(name) == 'm' else 'mrad'}"
                 if units.get(name) in ("m", "rad") else f"{name} {value:.3g} {units.get(name, '')}".rstrip()
                 for name, value in rows.items()]
        parts.append(f"{key} {', '.join(shown)}")
    return textwrap.wrap(f"σ estimated from the data, per axis (no '# sigma' line): {'; '.join(parts)}", 120,
                         subsequent_indent="  ")


def verdict(report: CalibrationReport) -> str:
    """One robot's outcome in a word or two: what the summary's first line would say."""
    if report.explains_nothing:
        return f"EXPLAINS NOTHING (residuals {(report.sigma2 or 0.0) ** 0.5:.3g} × σ)"
    if not report.converged:
        return f"NOT CONVERGED ({report.message})"
    if report.worse_than_nominal:
        return "WORSE THAN NOMINAL"
    if report.is_implausible:
        return "IMPLAUSIBLE (" + ", ".join([s.measurement + " scaled" for s in report.implausible_scale]
                                           + [c.parameter for c in report.implausible][:3]) + \
            (" …)" if len(report.implausible) > 3 else ")")
    if (report.sigma2 or 0.0) > NOISE_CONTRADICTED:
        return f"converged; residuals {(report.sigma2 or 0.0) ** 0.5:.3g} × σ"
    return "converged"


