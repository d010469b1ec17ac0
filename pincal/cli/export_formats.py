"""``pincal export``: a (calibrated) URDF's joint placements as per-joint YAML, or as a DH / modified-DH table."""

from __future__ import annotations

import argparse
from typing import Any

from pincal.cli.arguments import add_robot, non_negative_int, positive_float, positive_int
from pincal.errors import PincalError

#: pincal.io.export's FORMATS, TOLERANCE [m, rad] and POSTURES, spelled here so that parsing imports no NumPy
#: (tests/cli/test_export.py holds them equal).
FORMATS = ("yaml", "dh", "mdh", "hayati", "ur")
DEFAULT_TOLERANCE = 1e-9
DEFAULT_POSTURES = 100
#: A calibrated UR tool frame farther than this [m, rad] from ur_description's tool0 is named, with the TCP to set.
TCP_NOTE = 1e-6


def cmd_export(args: argparse.Namespace) -> int:
    """``pincal export``: write the export and say what it holds; a DH table's conversion residual is printed."""
    from pincal.calibration.export_proof import dh_deviation, proof_postures, yaml_deviation
    from pincal.calibration.provenance import file_digests, read_provenance, version
    from pincal.io.calibrated_urdf import source_text
    from pincal.io.corrections_file import corrections_path, robot_files
    from pincal.io.export import dh_export, joint_origins_yaml, shown_name
    from pincal.io.files import check_outputs, write_text
    from pincal.model.robot import load_robot

    if args.format in ("yaml", "ur") and (args.frame or args.base):
        raise PincalError(f"export: --frame and --base choose a DH table's chain; --format {args.format} writes every "
                          "joint")
    robot = load_robot(args.robot)
    text = source_text(robot)
    data = read_provenance(robot.source).data if robot.source is not None else None  # read for the proof's postures
    check_outputs([("--out", args.out)], [*robot_files(robot), *([data] if data is not None else [])])
    digest = file_digests(robot.source).get(str(robot.source))
    source = f"{args.robot} ({f'SHA-256 {digest}, ' if digest else ''}by pincal {version()})"
    beside = corrections_path(robot.source) if robot.source is not None else None
    if beside is not None and beside.is_file():  # the table alone is not the whole calibrated model
        source += f"; apply the joint corrections of {beside.name} to the readings first (docs/calibrated_urdf.md)"
        print(f"note: {beside.name} holds joint corrections the URDF cannot: a controller applies them to the raw "
              "readings before this export's kinematics")
    postures = proof_postures(robot, robot.source, args.postures, args.seed)
    if args.format == "yaml":
        exported = joint_origins_yaml(text, source)
        written = proved(exported, [yaml_deviation(exported, text, robot, postures)], text, robot, postures, args)
        write_text(args.out, written)
        print(f"wrote {args.out}: the origin of each of the URDF's joints (x, y, z [m], roll, pitch, yaw [rad])")
        return 0
    if args.format == "ur":
        return _ur(args, robot, text, postures, digest or "")
    done = dh_export(robot, text, source, args.format, args.frame, args.base, args.tolerance,
                     args.postures, args.seed)
    table, residual = done.table, done.residual
    print(f"{args.format} table of {shown_name(table.base_frame)} -> {shown_name(table.end_frame)}, {len(table.rows)} "
          f"joints; conversion residual over {residual.postures} random postures: {residual.position:.3g} m, "
          f"{residual.orientation:.3g} rad")
    names = {"dh": ("theta", "d", "a", "alpha"), "hayati": ("theta", "d", "a", "alpha", "beta")}.get(
        args.format, ("alpha", "a", "theta", "d"))
    print(f"  {'joint':<28}" + "".join(f"{n + (' [rad]' if n in ('theta', 'alpha', 'beta') else ' [m]'):>16}"
                                       for n in names))
    for row in table.rows:
        values = {"theta": row.theta, "d": row.d, "a": row.a, "alpha": row.alpha, "beta": row.beta}
        print(f"  {shown_name(row.joint):<28}" + "".join(f"{values[n]:>16.9g}" for n in names))
    for first, _, distance in table.hayati:
        print(f"  note: {shown_name(first)} in Hayati's form (beta about y, d = 0): its classic d would be "
              f"{distance:.3g} m, beyond the chain's size {table.size:.3g} m")
    for first, second, angle, distance in table.near_parallel:
        if any(first == h[0] for h in table.hayati):
            continue
        print(f"  note: axes of {shown_name(first)} and {shown_name(second)} are {angle:.3g} rad from parallel: their "
              f"common normal is {distance:.3g} m away (exact, but d values large and cancelling)")
    write_text(args.out, proved(done.text, [dh_deviation(done.text, robot, postures)], text, robot, postures, args))
    print(f"wrote {args.out}")
    return 0


def _ur(args: argparse.Namespace, robot: Any, urdf_text: str, postures: Any, digest: str) -> int:
    """``--format ur``: ur_description's kinematics YAML, proved by composing it as ur_description does."""
    from pincal.calibration.export_proof import ur_deviations
    from pincal.calibration.provenance import read_provenance
    from pincal.io.files import write_text
    from pincal.io.ur_kinematics import ur_kinematics, ur_kinematics_yaml
    from pincal.model.robot import load_robot

    recorded = read_provenance(robot.source).robot if robot.source is not None else None
    nominal = load_robot(recorded) if recorded else robot
    kinematics = ur_kinematics(robot, nominal)
    exported = ur_kinematics_yaml(kinematics, str(args.robot), digest)
    chain, alone = ur_deviations(exported, kinematics.tcp, robot, kinematics.base, kinematics.tool, postures)
    write_text(args.out, proved(exported, [chain], urdf_text, robot, postures, args))
    if max(alone.position, alone.orientation) > TCP_NOTE:
        print(f"note: the calibrated tool0 is {alone.position * 1e3:.4f} mm, {alone.orientation * 1e3:.4f} mrad from "
              "ur_description's tool0: set the TCP the file's header gives (the file's chain with it matches)")
    print(f"wrote {args.out}: ur_description's kinematics (nominal layout from '{nominal.name}')")
    return 0


def proved(exported: str, deviations: list[Any], urdf_text: str, robot: Any, postures: Any,
           args: argparse.Namespace) -> str:
    """The export with its proof in its header (pincal.calibration.export_proof): the URDF reloaded by Pinocchio and
    yourdfpy, and ``deviations`` (the export read back); printed; refused above ``--tolerance``."""
    from pincal.calibration.export_proof import header_line, urdf_deviations, with_header

    every = [*urdf_deviations(urdf_text, robot, postures), *deviations]
    line = header_line(every, postures)
    print(line[2:])
    worst = max(every, key=lambda d: max(d.position, d.orientation))
    if max(worst.position, worst.orientation) > args.tolerance:
        raise PincalError(f"export: {worst.reader} reads the {args.format} export {worst.position:.3g} m, "
                          f"{worst.orientation:.3g} rad away from the model (tolerance {args.tolerance:g}): not "
                          "written")
    return with_header(exported, line)


def register(sub: argparse._SubParsersAction[argparse.ArgumentParser]) -> None:
    """Add ``export`` to the ``pincal`` subcommands."""
    parser = sub.add_parser(
        "export", help="a URDF's joint placements as per-joint YAML, or a DH / modified-DH table",
        description="yaml: every joint's <origin> (x, y, z [m], roll, pitch, yaw [rad], URDF rpy) keyed by joint "
                    "name, as ur_description's default_kinematics.yaml lays them out, and each loop's anchors; any "
                    "robot. dh, mdh: the serial chain from --base to --frame as a classic or modified (Craig) "
                    "Denavit-Hartenberg table in YAML, with the base and tool transforms that make it exact and "
                    "its conversion residual against Pinocchio's forward kinematics; refused for closed loops, "
                    "joints neither revolute nor prismatic, or a residual above --tolerance. hayati: the dh table "
                    "with Hayati's parallel-axis rows (beta about y, d = 0) where the classic d would exceed the "
                    "chain's size. ur: a Universal Robots arm's kinematics as ur_description's kinematics file "
                    "(shoulder ... wrist_3, hash), for the ROS driver's kinematics_params_file. Every export is read "
                    "back (the URDF by Pinocchio and yourdfpy; the YAML composed into joint origins; the table as "
                    "forward kinematics; the ur file as ur_description's chain) and compared with the model at the "
                    "calibration data's postures and --postures random ones: the largest deviation printed and in "
                    "the header, the export refused above --tolerance (docs/calibrated_urdf.md, 'Exports').",
        epilog="examples: pincal export cal.urdf --format yaml --out kinematics.yaml; "
               "pincal export cal.urdf --format hayati --out dh.yaml; "
               "pincal export cal.urdf --format ur --out cal_kinematics.yaml")
    add_robot(parser, "e.g. a calibrated URDF")
    parser.add_argument("--format", choices=FORMATS, default=FORMATS[0], help="what to write (default yaml)")
    parser.add_argument("--out", required=True, help="the YAML file to write")
    parser.add_argument("--frame", help="dh, mdh, hayati: the chain's end frame (default: the robot's measured frame)")
    parser.add_argument("--base", help="dh, mdh, hayati: the chain's base frame (default: the URDF's root link; in a "
                                       "calibrated URDF the robot's own root below measurement_frame)")
    parser.add_argument("--tolerance", type=positive_float, default=DEFAULT_TOLERANCE,
                        help=f"largest deviation [m, rad] of the export read back (and of a DH table's conversion) "
                             f"from the model, for it to be written (default {DEFAULT_TOLERANCE:g})")
    parser.add_argument("--postures", type=positive_int, default=DEFAULT_POSTURES,
                        help=f"random postures the export is checked at, besides the fitted ones (default "
                             f"{DEFAULT_POSTURES})")
    parser.add_argument("--seed", type=non_negative_int, default=0, help="their random seed (default 0)")
    parser.set_defaults(func=cmd_export)
