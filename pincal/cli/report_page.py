"""``pincal report``: calibrate (or read a result) and write one offline HTML report."""

from __future__ import annotations

import argparse
from typing import TYPE_CHECKING

from pincal.cli.view import add_view_options, exit_status, load_view
from pincal.errors import DataError, listing

if TYPE_CHECKING:
    from pincal.calibration.report_sections import PixelErrors


def cmd_report(args: argparse.Namespace) -> int:
    """``pincal report``: calibrate (or read ``--result``) and write one offline HTML report; exit status 1 when
    the result may not be used (:func:`~pincal.cli.view.exit_status`)."""
    from pincal.viz.html_report import ReportContent, mm_text, read_truth, write_report

    truth = read_truth(args.truth) if args.truth else None  # before any work: an unreadable file stops it
    view, _ = load_view(args)
    if truth is not None:
        names = set(view.problem.parameters.names)
        if not names & set(truth):  # e.g. the truth.json of another robot: a column of dashes, said nowhere
            raise DataError(f"--truth '{args.truth}' holds none of the {len(names)} parameters fitted here (it lists "
                            f"{listing(sorted(truth)) or 'none'}): give the truth.json of this robot's simulation")
    content = ReportContent(view, truth, tuple(str(given) for given in (args.robot, args.data) if given is not None))
    path = write_report(content, args.out, args.quiet)
    report = view.report
    held = f"; held out {mm_text(report.test_rms_before)} → {mm_text(report.test_rms_after)}" \
        if report.has_held_out else ""
    if report.pixels is not None:  # a camera's pixels: its reprojection error, in px
        def px(figures: PixelErrors) -> str:
            return " → ".join("-" if v is None else f"{v:.3f}" for v in (figures.rms_before, figures.rms_after))
        held = f"; held out {px(report.test_pixels)} px" if report.test_pixels is not None else ""
        print(f"RMS reprojection error {px(report.pixels)} px{held}")
    else:
        print(f"RMS {report.error_words[0]} error {mm_text(report.rms_before)} → {mm_text(report.rms_after)}{held}")
    print(f"wrote {path} ({path.stat().st_size / 1e6:.1f} MB): open it in a browser, no network needed")
    return exit_status(view)


def register(sub: argparse._SubParsersAction[argparse.ArgumentParser]) -> None:
    """Add the ``report`` command."""
    report = sub.add_parser(
        "report", help="calibrate and write one offline HTML report (numbers, figures, 3D scene)",
        description="Calibrate (or read --result) and write one self-contained HTML file: errors before and "
                    "after (fit and held-out samples), identifiability, the parameter table with standard "
                    "deviations, the combinations the data cannot separate, figures, and the 3D scene.",
        epilog="example: pincal report delta sim/measurements.csv --parameters model24 --truth sim/truth.json "
               "--out report.html")
    add_view_options(report)
    report.add_argument("--out", required=True, help="HTML file to write")
    report.add_argument("--truth", metavar="TRUTH.json",
                        help="true parameters (truth.json of pincal simulate) to compare the estimates with")
    report.set_defaults(func=cmd_report, command="report")
