"""``pincal view``: the 3D scene of a calibration, and the options it shares with ``pincal report``."""

from __future__ import annotations

import argparse
import sys
from dataclasses import replace
from pathlib import Path
from typing import TYPE_CHECKING, Any

from pincal.calibration.options import OPTIONS, GivenOptions
from pincal.cli.arguments import add_calibration_options, add_robot, given_options
from pincal.errors import DataError, PincalError

if TYPE_CHECKING:  # the work's modules load when a command runs, not to parse its arguments
    from pincal.calibration.from_files import Inputs
    from pincal.calibration.pipeline import Calibration
    from pincal.calibration.report import CalibrationReport
    from pincal.calibration.report_sections import ProvenanceRecord
    from pincal.viz.scene import CalibrationView


def load_view(args: argparse.Namespace) -> tuple[CalibrationView, Calibration | None]:
    """Robot, data and calibration from the common options: calibrate, or read ``--result``.

    Returns the view and the calibration (None with ``--result``).
    """
    from pincal.calibration.from_files import read_inputs
    from pincal.calibration.pipeline import calibrate
    from pincal.calibration.report import CalibrationReport
    from pincal.calibration.summary import report_robot, robot_named, urdf_name_note
    from pincal.io.corrections_file import robot_files
    from pincal.io.files import check_outputs
    from pincal.viz.scene import CalibrationView, check_same_data

    read = read_inputs(args.command, args.robot, args.data, GivenOptions.of(given_options(args), "command line"))
    robot, dataset, options = read.robot, read.dataset, read.options
    provenance = page_provenance(read, args)
    inputs = (*robot_files(robot), *read.files, args.result, getattr(args, "truth", None))
    check_outputs([("--out", args.out)], [p for p in inputs if p is not None])  # before any work
    if args.result:
        report = CalibrationReport.read(args.result)
        if report.robot and report.robot != robot.name:  # before its parameters are compared with this robot's
            raise DataError(f"--result '{args.result}' is a calibration of '{report_robot(report)[0]}', not of "
                            f"'{robot_named(read.robot_given, robot.name)}'")
        check_result_options(args, report)
        try:
            view = CalibrationView.from_result(robot, dataset, report, options)
            check_same_data(view, dataset)
        except DataError as exc:  # which of the command's files the message is about
            raise DataError(f"--result '{args.result}': {exc}") from None
        view.report = replace(view.report, provenance=provenance)
        return view, None
    if not args.quiet:
        named, note = robot_named(read.robot_given, robot.name), urdf_name_note(read.robot_given, robot.name)
        # on stdout, flushed before the work: a refusal is then the one line on stderr, as with calibrate
        print(f"calibrating '{named}'{note} from {dataset.n_samples} samples ...", flush=True)
    calibration = calibrate(robot, dataset, options, progress=not args.quiet)
    view = CalibrationView.from_calibration(calibration)
    view.report = replace(view.report, provenance=provenance)
    return view, calibration


def page_provenance(read: Inputs, args: argparse.Namespace) -> ProvenanceRecord:
    """What a page records of its inputs: the pincal version, the robot and data files (``--result`` among them) with
    their SHA-256, the options; paths relative to the page's folder."""
    from pincal.calibration.provenance import Provenance, file_source, options_dict, robot_source

    data = [file_source(p) for p in (*read.files, *([args.result] if args.result else []))]
    return Provenance(robot_source(read.robot_given, read.robot), data,
                      options_dict(read.options)).record(Path(args.out).parent)


#: The options a ``--result`` JSON records, and where: a fit's option given with ``--result`` must be the recorded one.
RECORDED = ("solver", "loss", "select", "cv", "payload", "formulation", "markers")


def check_result_options(args: argparse.Namespace, report: CalibrationReport) -> None:
    """Refuse a fit's option that contradicts the ``--result`` JSON it would be drawn from (DataError naming both):
    the options the report records (``--solver``, ``--loss``, ``--select``, ``--cv``, ``--payload``,
    ``--formulation``, ``--markers``) given with ``--result`` change nothing, so they must be what the result was
    fitted with (as when the calibrate command is repeated with ``--result``); options not given are not compared."""
    from pincal.calibration.crossval import parse_cv

    selection, cv = report.selection, report.cv
    recorded = {
        "solver": report.solver,
        "loss": report.loss,
        "select": selection.policy if selection is not None else None,
        "cv": cv.plan if cv is not None else None,
        "payload": report.payload.as_dict() if report.payload is not None else None,
        "formulation": report.formulation,
        "markers": report.markers,
    }
    for name in RECORDED:
        given = getattr(args, name, None)
        if given is None:
            continue
        if name == "cv":
            compared = parse_cv(args.cv, sys.maxsize, args.cv_seed or 0).label
        elif name == "payload":
            compared = args.payload.as_dict()
        else:
            compared = given
        fitted = recorded[name]
        if (name == "select" and given == "auto") or compared == fitted:
            continue
        flag = OPTIONS[name].flag
        shown = {"cv": args.cv, "payload": _payload_text(compared)}.get(name, given)
        made = "none" if fitted is None else repr(fitted) if name != "payload" else _payload_text(fitted)
        raise DataError(f"{flag} {shown}: the result JSON '{args.result}' was fitted with {made}; --result draws "
                        "that fit as it is: give the options it was made with, or calibrate again without --result")


def _payload_text(recorded: Any) -> str:
    """A recorded payload ``{"mass", "frame", "offset"}`` as ``MASS@FRAME:X,Y,Z``."""
    try:
        return f"{recorded['mass']:g}@{recorded['frame']}:" + ",".join(f"{v:g}" for v in recorded["offset"])
    except (TypeError, KeyError, ValueError):
        return repr(recorded)


def add_view_options(parser: argparse.ArgumentParser) -> None:
    """ROBOT, DATA, ``--result`` and every calibration option, shared by ``view`` and ``report``."""
    add_robot(parser, "or a job file JOB.toml naming its robot, data and options: docs/job_file.md")
    parser.add_argument("data", nargs="?", help="measurement CSV (rows with set=test are held out); none with a job "
                                                "file")
    parser.add_argument("--result", metavar="REPORT.json",
                        help="reuse the results JSON of 'pincal calibrate --report' instead of calibrating again")
    add_calibration_options(parser)
    parser.add_argument("--quiet", action="store_true", help="no progress output")


def exit_status(view: CalibrationView) -> int:
    """The exit status of a command that fits (or reads a fit): 1 when the result may not be used (not converged,
    worse than nominal on the held-out samples, or implausible, as ``calibrate`` says it, said on stderr), else 0."""
    from pincal.calibration.summary import verdict

    report = view.report
    if report.usable:
        return 0
    cause = f"; likely cause: {report.implausible_cause}" if report.is_implausible and report.implausible_cause else ""
    print(f"the result may not be used: {verdict(report)}{cause}", file=sys.stderr)
    return 1


def cmd_view(args: argparse.Namespace) -> int:
    """``pincal view``: write the 3D scene (nominal and calibrated robot, measured points, errors) as HTML, and
    with ``--open`` show it in meshcat; exit status 1 when the result may not be used (:func:`exit_status`)."""
    from pincal.io.files import write_text
    from pincal.viz.scene import open_in_meshcat, static_scene

    if args.open == "" and not sys.stdin.isatty():  # before any work: the server would wait for an Enter
        raise PincalError("--open without a ZMQ_URL starts a meshcat server that runs until Enter is pressed, but "
                          "standard input is not a terminal; give the address of a running meshcat server "
                          "(--open tcp://127.0.0.1:6000) or run from a terminal")
    view, _ = load_view(args)
    page, summary = static_scene(view, quiet=args.quiet)
    out = write_text(args.out, page)
    errors = f", errors magnified ×{summary.magnification:g}" if summary.has_points else ""
    print(f"wrote {out} ({out.stat().st_size / 1e6:.1f} MB): {summary.n_visuals} shapes per robot, "
          f"{summary.n_samples} samples{errors}; open it in a browser")
    for note in summary.notes:
        print(f"  note: {note}")
    if args.open is not None:
        open_in_meshcat(view, args.open or None, args.quiet)
    return exit_status(view)


def register(sub: argparse._SubParsersAction[argparse.ArgumentParser]) -> None:
    """Add the ``view`` command."""
    view = sub.add_parser(
        "view", help="3D scene: nominal vs calibrated robot, measured points, errors (HTML or meshcat)",
        description="Calibrate (or read --result), then draw the nominal robot ghosted, the calibrated robot "
                    "solid, the measured points and each sample's error before and after calibration as "
                    "magnified segments coloured by size, one animation frame per sample. Writes one "
                    "self-contained HTML file (no network needed); --open also shows it in meshcat.",
        epilog="example: pincal view delta sim/measurements.csv --parameters model24 --out scene.html")
    add_view_options(view)
    view.add_argument("--out", required=True, help="HTML file to write")
    view.add_argument("--open", nargs="?", const="", metavar="ZMQ_URL",
                      help="also draw in meshcat: a running server (e.g. tcp://127.0.0.1:6000) or, without a "
                           "URL, a new one kept until Enter")
    view.set_defaults(func=cmd_view, command="view")
