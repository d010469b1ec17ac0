"""``pincal iso9283 plan`` and ``pincal iso9283 evaluate``: the ISO 9283 test's poses and cycles for a robot, and the
standard's performance figures of the measured runs (docs/iso9283.md). The work is
:mod:`pincal.calibration.iso9283` and :mod:`pincal.calibration.iso9283_plan`."""

from __future__ import annotations

import argparse
from pathlib import Path
from typing import Any

from pincal.cli.arguments import add_robot, non_negative_int, positive_float, positive_int


def _mm(value: float) -> str:
    return f"{value * 1e3:.4f}"


def cmd_evaluate(args: argparse.Namespace) -> int:
    """``pincal iso9283 evaluate``: print AP, RP, AD, RD and vAP of the runs; write the report and the page."""
    from pincal.calibration.iso9283 import evaluate_runs
    from pincal.calibration.provenance import file_digests, version
    from pincal.calibration.samples import check_recorded_robot
    from pincal.calibration.summary import robot_named
    from pincal.io.files import check_outputs, json_text, write_texts
    from pincal.io.iso_runs import read_runs
    from pincal.model.robot import load_robot

    outputs = [(flag, path) for flag, path in (("--report", args.report), ("--html", args.html)) if path]
    robot_file = args.robot if Path(args.robot).is_file() else None
    check_outputs(outputs, [p for p in (args.runs, robot_file) if p])
    runs = read_runs(args.runs)
    robot = load_robot(args.robot)
    check_recorded_robot(runs.metadata, robot, args.runs)
    figures = evaluate_runs(runs, args.instrument_uncertainty)
    print(f"iso9283: {len(runs.poses)} measurements of '{robot_named(args.robot, robot.name)}' ({args.runs}); "
          "ISO 9283:1998 figures [mm, mrad]")
    orientation = runs.attained_quaternions is not None
    print(f"{'pose':<8}{'cycles':>7}{'AP':>10}{'APx':>10}{'APy':>10}{'APz':>10}{'RP':>10}"
          + (f"{'APa':>9}{'APb':>9}{'APc':>9}{'RPa±':>9}{'RPb±':>9}{'RPc±':>9}" if orientation else ""))
    for p in figures.poses:
        angles = "".join(f" {v * 1e3:8.4f}" for v in (*(p.ap_abc or []), *(p.rp_abc or [])))
        print(f"{p.pose:<8}{p.cycles:>7}{_mm(p.ap):>10}" + "".join(f"{_mm(v):>10}" for v in p.ap_xyz)
              + f"{_mm(p.rp):>10}{angles}")
    for d in figures.distances:
        print(f"distance {d.poses[0]}-{d.poses[1]}: D_c {_mm(d.commanded)} mm, AD {_mm(d.ad)} mm, RD ± {_mm(d.rd)} mm "
              f"({d.cycles} cycles)")
    for v in figures.variations:
        angles = "" if v.vap_abc is None else ", vAP_a,b,c " + ", ".join(f"{a * 1e3:.4f}" for a in v.vap_abc) + " mrad"
        print(f"multi-directional {v.pose}: vAP {_mm(v.vap)} mm{angles} ({', '.join(v.directions)})")
    for warning in figures.warnings:
        print(f"warning: {warning}")
    content: dict[str, Any] = {
        "robot": robot_named(args.robot, robot.name), "runs": args.runs, **figures.as_dict(),
        "provenance": {"pincal_version": version(),
                       "options": {"instrument_uncertainty": args.instrument_uncertainty},
                       "sha256": file_digests(args.runs, robot_file)}}
    texts: list[tuple[str | Path, str | bytes]] = []
    if args.report:
        texts.append((args.report, json_text(content)))
    if args.html:
        from pincal.viz.iso9283_page import iso9283_page

        texts.append((args.html, iso9283_page(content)))
    for path in write_texts(texts):
        print(f"wrote {path}")
    return 0


def cmd_plan(args: argparse.Namespace) -> int:
    """``pincal iso9283 plan``: the test cube, P1–P5 and the cycle sequence as a CSV."""
    from pincal.calibration.iso9283_plan import plan_test, plan_text
    from pincal.calibration.summary import robot_named
    from pincal.io.files import check_outputs, write_text
    from pincal.model.robot import load_robot

    inputs = [p for p in (args.robot, args.model) if p and Path(p).is_file()]
    check_outputs([("--out", args.out)], inputs)
    robot = load_robot(args.robot)
    plan = plan_test(robot, region=args.region, orientation=args.orientation, frame=args.frame, model=args.model,
                     cycles=args.cycles, seed=args.seed, candidates=args.candidates,
                     min_side=args.min_side)
    cube = plan.cube
    print(f"iso9283 plan of '{robot_named(args.robot, robot.name)}', frame {plan.frame}: test cube of side "
          f"{cube.side * 1e3:.1f} mm centred at ({', '.join(f'{c:.4f}' for c in cube.centre)}) m"
          f" ({plan.region_note})")
    for name, position in zip(plan.names, plan.positions, strict=True):
        print(f"  {name}: ({', '.join(f'{c:.4f}' for c in position)}) m")
    print(f"orientation: {plan.orientation_note}; joint commands: {plan.commands_note}")
    print(f"sequence: {plan.n_rows} rows ({args.cycles} cycles of P1, P5, P4, P3, P2; then P1, P2, P4 from "
          f"3 directions each, {args.cycles} cycles each); largest FK residual of the commands "
          f"{plan.largest_residual:.2g} m")
    path = write_text(args.out, plan_text(plan, robot_named(args.robot, robot.name)))
    print(f"wrote {path}")
    return 0


#: The largest |bound| of --region [m]: beyond, millimetres written as metres (pincal.io.dataset's
#: MAX_PLAUSIBLE_LENGTH, spelled here so that parsing imports no NumPy).
REGION_LIMIT = 20.0


def _region(text: str) -> tuple[float, ...]:
    """An argparse type: six numbers xmin,ymin,zmin,xmax,ymax,zmax [m] with each min below its max."""
    try:
        values = tuple(float(v) for v in text.split(","))
    except ValueError:
        values = ()
    if len(values) != 6 or not all(abs(v) < float("inf") for v in values) or not all(
            values[k] < values[k + 3] for k in range(3)):
        raise argparse.ArgumentTypeError(f"'{text}' is not XMIN,YMIN,ZMIN,XMAX,YMAX,ZMAX [m] with each min below "
                                         "its max")
    if max(abs(v) for v in values) > REGION_LIMIT:
        raise argparse.ArgumentTypeError(f"'{text}' has a bound beyond {REGION_LIMIT:g} m: the region is in metres "
                                         "(millimetres divided by 1000)")
    return values


def _quaternion(text: str) -> tuple[float, ...]:
    """An argparse type: a unit quaternion QW,QX,QY,QZ."""
    try:
        values = tuple(float(v) for v in text.split(","))
    except ValueError:
        values = ()
    if len(values) != 4 or abs(sum(v * v for v in values) - 1.0) > 1e-6:
        raise argparse.ArgumentTypeError(f"'{text}' is not a unit quaternion QW,QX,QY,QZ")
    return values


def _cycles(text: str) -> int:
    """An argparse type: the cycles of a series, a whole number ≥ 2 (RP needs two)."""
    value = positive_int(text)
    if value < 2:
        raise argparse.ArgumentTypeError(f"{value}: RP needs at least 2 cycles (the standard: 30)")
    return value


def register(sub: argparse._SubParsersAction[argparse.ArgumentParser]) -> None:
    """Add the ``iso9283`` command and its ``plan`` and ``evaluate``."""
    iso = sub.add_parser("iso9283", help="ISO 9283 pose accuracy and repeatability: plan the test, evaluate it",
                         description="The performance test of ISO 9283:1998 (docs/iso9283.md): 'plan' gives the test "
                                     "cube, the poses P1-P5 and the cycles to run; 'evaluate' the standard's "
                                     "figures of the measured runs.")
    group = iso.add_subparsers(dest="iso_command", required=True)
    plan = group.add_parser("plan", help="the test cube, P1-P5 and the cycle sequence as a CSV",
                            description="The largest cube inside the reachable workspace (in --region, or the whole "
                                        "workspace), its diagonal plane, P1 at its centre and P2-P5 on the plane's "
                                        "diagonals at 10 %% of their length from the corners (ISO 9283:1998, 6.8); "
                                        "the orientation given (--orientation), the joint commands (through "
                                        "compensate with --model), 30 cycles and the approach directions of the "
                                        "multi-directional test.",
                            epilog="example: pincal iso9283 plan ur10 --out plan.csv")
    add_robot(plan)
    plan.add_argument("--out", required=True, help="the plan CSV to write")
    plan.add_argument("--region", type=_region, metavar="XMIN,YMIN,ZMIN,XMAX,YMAX,ZMAX",
                      help="where the cube goes [m, the robot's base frame] (default: anywhere it reaches); "
                           "--region=-1,… when the first number is negative")
    plan.add_argument("--orientation", type=_quaternion, metavar="QW,QX,QY,QZ",
                      help="the frame's orientation at every pose, in the base frame (default: its orientation "
                           "at the reference configuration); robots of fewer than 6 degrees of freedom take none")
    plan.add_argument("--frame", help="the frame tested (default: the robot's measured frame)")
    plan.add_argument("--model", metavar="CAL.urdf",
                      help="a calibrated URDF of the robot: the joint commands through 'pincal compensate' on it")
    plan.add_argument("--cycles", type=_cycles, default=30, help="cycles of each series, ≥ 2 (default 30)")
    plan.add_argument("--candidates", type=positive_int, default=400,
                      help="random postures sampling the workspace (default 400)")
    plan.add_argument("--seed", type=non_negative_int, default=0, help="seed of the sampled postures")
    plan.add_argument("--min-side", type=positive_float, default=0.02,
                      help="smallest side of a test cube [m] (default 0.02): refused when none fits")
    plan.set_defaults(func=cmd_plan)

    evaluate = group.add_parser("evaluate", help="AP, RP, AD, RD and vAP of measured runs",
                                description="Per pose the pose accuracy AP (and AP_x,y,z) and repeatability RP = "
                                            "l̄ + 3 S_l, orientation accuracy and repeatability when measured, "
                                            "distance accuracy and repeatability between poses, multi-directional "
                                            "variation (ISO 9283:1998, 7.2-7.4). Columns: docs/iso9283.md.",
                                epilog="example: pincal iso9283 evaluate ur10 runs.csv --report iso.json --html "
                                       "iso.html --instrument-uncertainty 2e-5")
    add_robot(evaluate)
    evaluate.add_argument("runs", metavar="MEASURED.csv",
                          help="pose, cycle, cmd_x, cmd_y, cmd_z, x, y, z [m] (+ cmd_qw…, qw…, direction)")
    evaluate.add_argument("--report", help="report JSON to write (SI: m, rad)")
    evaluate.add_argument("--html", help="HTML page to write")
    evaluate.add_argument("--instrument-uncertainty", type=positive_float, metavar="U",
                          help="the measuring instrument's stated uncertainty [m]: an RP below it is warned of")
    evaluate.set_defaults(func=cmd_evaluate)
