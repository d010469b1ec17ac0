"""``pincal view``: the 3D scene of a calibration, and the options it shares with ``pincal report``."""

from __future__ import annotations

import argparse
import json
import sys
from pathlib import Path
from typing import Any

from pincal.cli.options import (
    add_markers,
    add_payload,
    add_robot,
    add_selection_and_cv,
    add_solver_and_loss,
    positive_float,
)
from pincal.errors import DataError, PincalError
from pincal.io.dataset import Dataset
from pincal.io.files import check_outputs, write_text
from pincal.model.robot import load_robot
from pincal.viz.scene import CalibrationView, check_same_data, open_in_meshcat, static_scene
from pincal.workflow import calibrate, check_cv_seed, parse_cv, read_robot_dataset


def load_view(args: argparse.Namespace) -> tuple[CalibrationView, Dataset, Any]:
    """Robot, data and calibration from the common options: calibrate, or read ``--result``.

    Returns the view, the dataset and the :class:`pincal.workflow.Calibration` (None with ``--result``).
    """
    check_cv_seed(args.cv, args.cv_seed or 0, "command line", "command line")  # in the flags' words
    robot = load_robot(args.robot)
    inputs = (robot.source, args.data, args.result, getattr(args, "truth", None))
    check_outputs([("--out", args.out)], [p for p in inputs if p is not None])  # before any work
    dataset = read_robot_dataset(args.data, robot)
    if args.result:
        try:
            report = json.loads(Path(args.result).read_text(encoding="utf-8"))
        except (OSError, json.JSONDecodeError) as exc:
            raise DataError(f"cannot read the result JSON '{args.result}': {exc}") from None
        check_result_options(args, report)
        try:
            view = CalibrationView.from_result(robot, dataset, report, args.parameters, args.sigma, args.markers)
            check_same_data(view, dataset)
        except DataError as exc:  # which of the command's files the message is about
            raise DataError(f"--result '{args.result}': {exc}") from None
        return view, dataset, None
    if not args.quiet:
        print(f"calibrating '{robot.name}' from {dataset.n_samples} samples ...", file=sys.stderr)
    calibration = calibrate(robot, dataset, parameter_spec=args.parameters, solver=args.solver, loss=args.loss,
                            sigma=args.sigma, select=args.select, cv=args.cv, cv_seed=args.cv_seed or 0,
                            markers=args.markers, payload=args.payload)
    return CalibrationView.from_calibration(calibration), dataset, calibration


def check_result_options(args: argparse.Namespace, report: Any) -> None:
    """Refuse a fit's option that contradicts the ``--result`` JSON it would be drawn from (DataError naming both):
    ``--solver``, ``--loss``, ``--select``, ``--cv`` and ``--payload`` given with ``--result`` change nothing, so
    they must be what the result was fitted with (as when the calibrate command is repeated with ``--result``);
    options left at their defaults are not compared."""
    if not isinstance(report, dict):
        return  # CalibrationView.from_result names what the file is not
    selection, cv, payload = report.get("selection"), report.get("cv"), report.get("payload")
    recorded = {
        "--solver": (args.solver, "lm", report.get("solver")),
        "--loss": (args.loss, "auto", report.get("loss")),
        "--select": (args.select, "auto", selection.get("policy") if isinstance(selection, dict) else None),
        "--cv": (parse_cv(args.cv, sys.maxsize, args.cv_seed or 0).label if args.cv else None, None,
                 cv.get("plan") if isinstance(cv, dict) else None),
        "--payload": (args.payload.as_dict() if args.payload else None, None, payload),
    }
    for flag, (given, default, fitted) in recorded.items():
        if given != default and given != fitted:
            shown = {"--cv": args.cv, "--payload": _payload_text(given)}.get(flag, given)
            made = "none" if fitted is None else repr(fitted) if flag != "--payload" else _payload_text(fitted)
            raise DataError(f"{flag} {shown}: the result JSON '{args.result}' was fitted with {made}; --result draws "
                            "that fit as it is: give the options it was made with, or calibrate again without --result")


def _payload_text(recorded: Any) -> str:
    """A recorded payload ``{"mass", "frame", "offset"}`` as ``MASS@FRAME:X,Y,Z``."""
    try:
        return f"{recorded['mass']:g}@{recorded['frame']}:" + ",".join(f"{v:g}" for v in recorded["offset"])
    except (TypeError, KeyError, ValueError):
        return repr(recorded)


def add_calibration_options(parser: argparse.ArgumentParser) -> None:
    """ROBOT, DATA and the calibration options shared by ``view`` and ``report``."""
    add_robot(parser)
    parser.add_argument("data", help="measurement CSV (rows with set=test are held out)")
    parser.add_argument("--parameters", nargs="+", help="a named set or name patterns, as for calibrate")
    parser.add_argument("--result", metavar="REPORT.json",
                        help="reuse the results JSON of 'pincal calibrate --report' instead of calibrating again")
    add_solver_and_loss(parser)
    add_selection_and_cv(parser)
    add_markers(parser)
    add_payload(parser, "as for calibrate (with --result, the result's payload is used: one given must be it)")
    parser.add_argument("--sigma", type=positive_float,
                        help="one measurement σ [m, rad] for weighting every channel, over the file's '# sigma' "
                             "lines (default: those lines, else 1e-5; 1e-6 m for distances)")
    parser.add_argument("--quiet", action="store_true", help="no progress output")


def cmd_view(args: argparse.Namespace) -> int:
    """``pincal view``: write the 3D scene (nominal and calibrated robot, measured points, errors) as HTML, and
    with ``--open`` show it in meshcat; exit status 1 when the fit did not converge."""
    if args.open == "" and not sys.stdin.isatty():  # before any work: the server would wait for an Enter
        raise PincalError("--open without a ZMQ_URL starts a meshcat server that runs until Enter is pressed, but "
                          "standard input is not a terminal; give the address of a running meshcat server "
                          "(--open tcp://127.0.0.1:6000) or run from a terminal")
    view, _, calibration = load_view(args)
    page, summary = static_scene(view, quiet=args.quiet)
    out = write_text(args.out, page)
    errors = f", errors magnified ×{summary.magnification:g}" if summary.has_points else ""
    print(f"wrote {out} ({out.stat().st_size / 1e6:.1f} MB): {summary.n_visuals} shapes per robot, "
          f"{summary.n_samples} samples{errors}; open it in a browser")
    for note in summary.notes:
        print(f"  note: {note}")
    if args.open is not None:
        open_in_meshcat(view, args.open or None, args.quiet)
    return 0 if calibration is None or calibration.result.converged else 1


def register(sub: argparse._SubParsersAction[argparse.ArgumentParser]) -> None:
    """Add the ``view`` command."""
    view = sub.add_parser(
        "view", help="3D scene: nominal vs calibrated robot, measured points, errors (HTML or meshcat)",
        description="Calibrate (or read --result), then draw the nominal robot ghosted, the calibrated robot "
                    "solid, the measured points and each sample's error before and after calibration as "
                    "magnified segments coloured by size, one animation frame per sample. Writes one "
                    "self-contained HTML file (no network needed); --open also shows it in meshcat.",
        epilog="example: pincal view delta sim/measurements.csv --parameters model24 --out scene.html")
    add_calibration_options(view)
    view.add_argument("--out", required=True, help="HTML file to write")
    view.add_argument("--open", nargs="?", const="", metavar="ZMQ_URL",
                      help="also draw in meshcat: a running server (e.g. tcp://127.0.0.1:6000) or, without a "
                           "URL, a new one kept until Enter")
    view.set_defaults(func=cmd_view)
