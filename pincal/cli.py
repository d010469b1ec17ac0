"""The ``pincal`` command line.

Every command reports problems as one line ``pincal: error: ...`` and exits with a non-zero code;
``--debug`` shows the Python traceback instead.
"""

from __future__ import annotations

import argparse
import sys
from collections.abc import Sequence

import numpy as np

from pincal.errors import PincalError
from pincal.robot import Robot, load_robot

EXIT_ERROR = 2


def _describe(robot: Robot) -> str:
    model = robot.model
    lines = [f"robot: {robot.name}" + (f"  ({robot.source})" if robot.source else "")]
    links = [f.name for f in model.frames if f.type.name == "BODY"]
    lines.append(f"links ({len(links)}): {', '.join(links)}")
    lines.append(f"joints ({model.njoints - 1} movable):")
    actuated = set(robot.actuated_joints)
    for j in range(1, model.njoints):
        name = model.names[j]
        tag = "  actuated" if name in actuated else ""
        lines.append(f"  {name:<28} {model.joints[j].shortname():<22} nq={model.joints[j].nq}{tag}")
    lines.append(f"loops ({len(robot.loops)}):")
    for loop in robot.loops:
        lines.append(f"  {loop.name:<28} {loop.type:<10} {loop.predecessor} -> {loop.successor} "
                     f"({loop.rows} rows)")
    lines.append(f"actuated joints ({robot.n_actuated}): {', '.join(robot.actuated_joints)}")
    residual = robot.closure_residual(robot.q_reference)
    worst = float(np.max(np.abs(residual), initial=0.0))
    lines.append(f"configuration: nq {model.nq}, nv {model.nv}; closure rows {robot.closure.rows}; "
                 f"mobility {robot.mobility()}")
    lines.append(f"closure residual at the reference configuration: {worst:.3g} (m, rad)")
    ee = robot.end_effector
    p = robot.placement(robot.q_reference, ee).translation
    lines.append(f"end effector: {ee} at ({p[0]:.6f}, {p[1]:.6f}, {p[2]:.6f}) m at the reference")
    return "\n".join(lines)


def cmd_info(args: argparse.Namespace) -> int:
    print(_describe(load_robot(args.robot)))
    return 0


def build_parser() -> argparse.ArgumentParser:
    parser = argparse.ArgumentParser(
        prog="pincal",
        description="Geometric calibration of closed-loop and serial robots described in URDF.",
        epilog="Units are SI everywhere (m, rad). Robots: a URDF path, or a name such as delta, hexapod, "
               "five_bar, ucr3, ur10, panda.")
    parser.add_argument("--debug", action="store_true", help="show Python tracebacks on errors")
    sub = parser.add_subparsers(dest="command", required=True)
    info = sub.add_parser("info", help="describe a robot: joints, loops, actuation, mobility",
                          description="Print links, joints, loops, actuated joints, mobility and the "
                                      "closure residual at the reference configuration.",
                          epilog="example: pincal info robots_urdf/delta.urdf")
    info.add_argument("robot", help="URDF file or known robot name")
    info.set_defaults(func=cmd_info)
    return parser


def main(argv: Sequence[str] | None = None) -> int:
    """Entry point of the ``pincal`` console script; returns the exit code."""
    parser = build_parser()
    args = parser.parse_args(argv)
    try:
        return int(args.func(args))
    except PincalError as exc:
        if args.debug:
            raise
        print(f"pincal: error: {exc}", file=sys.stderr)
        return EXIT_ERROR
    except KeyboardInterrupt:
        print("pincal: interrupted", file=sys.stderr)
        return 130


if __name__ == "__main__":
    sys.exit(main())
