"""``pincal drift``: sessions of a calibrated robot judged in time order against its calibration: which changed, which
parameter groups moved, and the command that recalibrates them (docs/drift.md). The work is
:mod:`pincal.calibration.drift`."""

from __future__ import annotations

import argparse
from pathlib import Path

from pincal.cli.arguments import positive_float

#: Exit status when some session shows a change (the report is written).
EXIT_CHANGED = 1


def _moved(session: dict[str, object]) -> str:
    from pincal.calibration.drift import shift_text

    groups = session["moved"]
    assert isinstance(groups, list)
    parts = []
    for g in groups:
        shifts = ", ".join(f"{n.rsplit('.', 1)[1]} {shift_text(v, s)}"
                           for n, v, s in zip(g["parameters"], g["shifts"], g["std"], strict=True))
        parts.append(f"{g['group']} ({shifts})")
    return "; ".join(parts) if parts else "no group named"


def cmd_drift(args: argparse.Namespace) -> int:
    """``pincal drift``: print each session's judgement and the advice; exit 1 when some session changed."""
    from pincal.calibration.drift import run_drift, statistic_text
    from pincal.io.files import check_outputs, json_text, write_texts

    outputs = [(flag, path) for flag, path in (("--report", args.report), ("--html", args.html)) if path]
    check_outputs(outputs, [args.model, *args.sessions, *([args.nominal] if args.nominal and
                                                           Path(args.nominal).is_file() else [])])
    drift, content = run_drift(args.model, args.sessions, args.level, args.nominal)
    print(f"drift: {len(drift.sessions)} sessions against {args.model} (nominal robot {content['nominal']}); each "
          f"tested at level {args.level:g} against the calibration's predicted spread, its setup re-registered "
          f"[{'px' if all(s.unit == 'px' for s in drift.sessions) else 'mm'}; shifts in mm or mrad]")
    width = max(len(s.source) for s in drift.sessions)
    print(f"{'session':<{width}}  samples  RMS     expected  T / dof          verdict")
    for s in drift.sessions:
        verdict = f"CHANGED: {_moved(content['sessions'][drift.sessions.index(s)])}" if s.changed else "unchanged"
        scale = 1.0 if s.unit == "px" else 1e3  # a camera's reprojection errors in px, lengths in mm
        print(f"{s.source:<{width}}  {s.n_samples:>7}  {s.rms * scale:.4f}  {s.expected_rms * scale:.4f}    "
              f"{statistic_text(s.statistic):>8} / {s.dof:<5} {verdict}")
    for warning in content["warnings"]:
        print(f"warning: {warning}")
    if drift.parameters:
        print(f"advice: recalibrate {', '.join(drift.groups)} (from MODEL, the setup with them): {content['command']}")
    elif content["command"]:
        changed = ", ".join(s.source for s in drift.sessions if s.changed)
        print(f"advice: {changed} changed beyond the calibration's predicted spread, but no parameter group explains "
              f"it alone: measure again, or calibrate anew: {content['command']}")
    else:
        print("advice: no session shows a change beyond the calibration's predicted spread: nothing to recalibrate")
    texts: list[tuple[str | Path, str | bytes]] = []
    if args.report:
        texts.append((args.report, json_text(content)))
    if args.html:
        from pincal.viz.drift_page import drift_page

        texts.append((args.html, drift_page(content)))
    for path in write_texts(texts):
        print(f"wrote {path}")
    return EXIT_CHANGED if drift.parameters or any(s.changed for s in drift.sessions) else 0


def _level(text: str) -> float:
    value = positive_float(text)
    if not value < 0.5:
        raise argparse.ArgumentTypeError(f"{text} is not between 0 and 0.5")
    return value


def register(sub: argparse._SubParsersAction[argparse.ArgumentParser]) -> None:
    """Add the ``drift`` command."""
    drift = sub.add_parser(
        "drift", help="has the robot changed since its calibration? sessions judged in time order",
        description="Each session (a measurement CSV or a job file, in time order) against the calibrated MODEL: "
                    "its setup re-registered, its residuals tested against the spread the calibration predicts (a "
                    "chi-square test at --level), and when it changed, the parameter groups that moved with their "
                    "shift and sigma, and the 'pincal calibrate' command that recalibrates them. Exit 1 when a "
                    "session changed (docs/drift.md).",
        epilog="example: pincal drift cal.urdf week2.csv week3.csv --report drift.json --html drift.html")
    drift.add_argument("model", metavar="MODEL", help="the calibrated URDF ('pincal calibrate --out')")
    drift.add_argument("sessions", metavar="SESSION", nargs="+", help="measurement CSV or job files, in time order")
    drift.add_argument("--level", type=_level, default=0.01,
                       help="chance of a false alarm per session when nothing changed (default 0.01)")
    drift.add_argument("--nominal", metavar="ROBOT", help="the nominal robot (default: the one MODEL records)")
    drift.add_argument("--report", help="report JSON to write (SI: m, rad)")
    drift.add_argument("--html", help="HTML page to write, with the error over time")
    drift.set_defaults(func=cmd_drift)
