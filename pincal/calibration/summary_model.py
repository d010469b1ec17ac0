"""The lines of a calibration's summary on what the model chose and how far its predictions may be off: model
selection and the prior it holds (the range guard's too), the predicted 95 % bounds held out and over the workspace.
Lengths are printed in mm, angles in mrad (:func:`mm`, :func:`mrad`).
"""

from __future__ import annotations

import math
import textwrap

from pincal.calibration.report import CalibrationReport
from pincal.calibration.report_sections import Coverage, ModelSelection


def mm(value: float | None) -> str:
    """A length [m] in mm for the terminal ("-" when missing)."""
    return "-" if value is None or value != value else f"{value * 1e3:.4f} mm"


def mrad(value: float | None) -> str:
    """An angle [rad] in mrad for the terminal ("-" when missing)."""
    return "-" if value is None or value != value else f"{value * 1e3:.4f} mrad"


def predicted_lines(report: CalibrationReport) -> list[str]:
    """The predicted accuracy's lines: the held-out samples' 95 % bounds and how many errors they hold, the bound over
    the workspace (pincal.calibration.predicted)."""
    lines = []
    held, space = report.predicted_held_out, report.predicted_workspace
    if held is not None and held.median_bound is not None:
        lines.append(f"predicted 95 % bound (held out): median {mm(held.median_bound)}; {held.inside} of "
                     f"{held.samples} errors within their bound ({held.fraction:.0%})")
        beyond = held.beyond_range or Coverage()
        if beyond.samples:
            inside = held.in_range or Coverage()
            lines.append(f"  beyond the fitted joint range {beyond.inside} of {beyond.samples} within their "
                         f"bound (grown with the distance), inside it {inside.inside} of {inside.samples}")
    if space is not None and space.median_bound is not None:
        capped = f"; {space.capped} at the nominal robot's own bound plus the noise's" if space.capped else ""
        lines.append(f"predicted 95 % bound over the workspace ({space.postures} postures within the joint "
                     f"limits): median {mm(space.median_bound)}, max {mm(space.max_bound)}{capped}")
    growth = report.error_growth
    if growth is not None and math.isfinite(growth.nominal0):
        lines += textwrap.wrap(
            f"the data's hold-outs: bound × {growth.rho0 ** 0.5:.2f} inside the fitted range, + "
            f"{mm(growth.nominal1)} per range width beyond it; the nominal robot's own bound "
            f"{mm(growth.nominal0)} inside it, growing as much, and no bound above it plus the noise's "
            "(docs/predicted_accuracy.md)", 120,
            initial_indent="  ", subsequent_indent="    ")
    return lines


def selection_lines(report: CalibrationReport) -> list[str]:
    """What model selection left out, and how firmly the evidence holds each group kept (nothing when neither
    applies)."""
    selection = report.selection or ModelSelection()
    removed = selection.removed
    factors = selection.prior_factors or {}
    held = ", ".join(f"{group} {factor:.2g}×" for group, factor in factors.items() if factor > 0.0)
    guard = selection.guard
    firmer = guard.firmer if guard is not None else 1.0
    guarded = ""
    if guard is not None and firmer != 1.0:
        _, inside, beyond = guard.scores[0]  # the evidence's own prior (divisor 1)
        guarded = (f"; the range guard holds them {firmer:g}× firmer than the evidence says (each joint's range halves "
                   f"predicted each other {guard.beyond:.3g} σ² mean square, the evidence's prior {beyond:.3g}, the "
                   f"nominal robot {guard.nominal_beyond:.3g}; shuffled folds {guard.inside:.3g}, the evidence's "
                   f"prior {inside:.3g})")
    if selection.policy == "evidence":
        words = f"left out the {', '.join(selection.removed_groups)} ({len(removed)} parameters at nominal); " \
            if removed else ""
        prior = f"the prior holds the {held} of their kinds' σ{guarded}" if held else "no group estimated"
        return textwrap.wrap(f"model selection (evidence): {words}{prior} (docs/calibrated_urdf.md, 'The prior')", 120,
                             subsequent_indent="  ")
    lines = [f"model selection ({selection.policy}): left out the {', '.join(selection.removed_groups)} "
             f"({len(removed)} parameters at nominal); --select none keeps them"] if removed else []
    if held:
        lines += textwrap.wrap(f"prior (auto): the evidence holds the {held} of their kinds' σ{guarded}", 120,
                               subsequent_indent="  ")
    return lines
