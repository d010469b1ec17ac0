"""``pincal compensate``: joint commands for target positions or poses on a calibrated robot, or the targets to send
to a controller that keeps its nominal model (docs/compensate.md). The work is :mod:`pincal.calibration.compensate`.
"""

from __future__ import annotations

import argparse
from pathlib import Path
from typing import Any

from pincal.cli.arguments import non_negative_int, positive_float
from pincal.errors import DataError

#: Exit status when some target is unreachable (the file is written, those rows with their reason).
EXIT_UNREACHABLE = 1
#: Unreachable targets printed one per line; the file lists them all.
SHOWN = 10


def cmd_compensate(args: argparse.Namespace) -> int:
    """``pincal compensate``: per target, the raw actuated commands that bring the calibrated model's frame there (or,
    with ``--nominal-targets``, the nominal model's target at those commands); exit 1 when some target is
    unreachable."""
    import numpy as np

    from pincal.calibration.check_model import KIND_WORDS, file_kind
    from pincal.calibration.compensate import (
        TOLERANCE,
        beyond_fitted_range,
        compensate,
        load_model,
        nominal_targets,
        target_bounds,
        targets_frame,
    )
    from pincal.calibration.provenance import file_digests, read_provenance, version
    from pincal.calibration.samples import check_recorded_robot
    from pincal.io.files import check_outputs, write_text
    from pincal.io.targets import commands_text, read_targets, targets_text
    from pincal.model.robot import load_robot

    nominal_name = args.nominal
    if args.nominal_targets and not nominal_name:
        nominal_name = read_provenance(args.model).robot
        if nominal_name is None:
            raise DataError(f"--nominal-targets needs the nominal model the controller keeps: MODEL '{args.model}' "
                            "records none (no pincal provenance in it); give it with --nominal ROBOT")
    inputs = [p for p in (args.model, args.targets, nominal_name) if p and Path(p).is_file()]
    check_outputs([("--out", args.out)], inputs)
    kind = file_kind(Path(args.targets)) if Path(args.targets).is_file() else None
    if kind in ("job", "json", "urdf", "xml", "binary"):  # not parsed as a CSV whose cells miss its header
        raise DataError(f"TARGETS '{args.targets}' is {KIND_WORDS[kind]}, where a targets CSV was expected: 'sample' "
                        "and the columns of one position or pose (docs/compensate.md)")
    targets = read_targets(args.targets)  # its size checked before the model is loaded
    nominal = load_robot(nominal_name) if nominal_name else None
    model = load_model(args.model, nominal)
    if model.corrections_file is not None:
        inputs.append(model.corrections_file)
        check_outputs([("--out", args.out)], inputs)
    check_recorded_robot(targets.metadata, model.robot, args.targets)
    result = compensate(model, targets, args.frame, args.targets_in, args.tolerance or TOLERANCE, args.seed,
                        progress=not args.quiet)
    robot = model.robot
    where = targets_frame(result)
    corrections = (f"{model.corrections_file} (inverted: the commands are raw readings)"
                   if model.corrections_file else "none")
    from pincal.calibration.summary import robot_named

    print(f"compensate: {len(targets.ids)} targets '{targets.key}' ({args.targets}) in {where}, on "
          f"'{robot_named(str(args.model), robot.name)}' ({args.model}); frame {result.frame}; "
          f"corrections: {corrections}")
    reached = result.reached
    if reached.any():
        position = float(np.nanmax(result.residuals[reached, 0]))
        angle = "" if targets.kind == "position" else f", {float(np.nanmax(result.residuals[reached, 1])):.3g} rad"
        inverted = (f"; corrections inverted to {float(np.nanmax(result.inversion[reached])):.3g} rad or m"
                    if model.corrections is not None else "")
        print(f"reached {int(reached.sum())} of {len(reached)}: largest residual of the model at the commands "
              f"{position:.3g} m{angle}{inverted} ({result.seconds:.2f} s)")
    beyond = beyond_fitted_range(result)
    bounds = target_bounds(result, args.model, nominal)
    if beyond:
        shown = ", ".join(targets.ids[k] for k in beyond[:8]) + (" …" if len(beyond) > 8 else "")
        print(f"warning: the commands of {len(beyond)} targets ({shown}) leave the joint ranges the calibration "
              "fitted: the model extrapolates there" + (", its bound grows with the distance" if bounds is not None
                                                       else ", its accuracy is not known"))
    print(*bound_lines(targets.ids, bounds), sep="\n")
    missed = np.flatnonzero(~reached).tolist()
    if missed:
        print(f"unreachable {len(missed)} of {len(reached)} (kept in the file, commands empty):")
        for k in missed[:SHOWN]:
            print(f"  sample {targets.ids[k]}: {result.statuses[k].partition(': ')[2]}")
        if len(missed) > SHOWN:
            print(f"  ... and {len(missed) - SHOWN} more")
    common = {"pincal": version(), "robot": robot.name, "model": str(args.model), "corrections": corrections,
              "targets": f"{args.targets} ({targets.key})",
              **({"gravity torques of": nominal_name or model.corrections.nominal_urdf}
                 if model.corrections is not None and model.torque_robot is not None else {}),
              **{f"sha256 {name}": digest
                 for name, digest in file_digests(args.model, model.corrections_file, args.targets).items()}}
    if args.nominal_targets:
        assert nominal is not None
        values, statuses, frame = nominal_targets(result, nominal)
        nominal_root = nominal.model.frames[1].name
        text = targets_text(targets.key, targets.ids, values, statuses, {
            **common, "nominal": str(nominal_name) + ("" if args.nominal else " (recorded in MODEL)"),
            "contents": f"the targets to send a controller that keeps the nominal model: its frame {frame} at the raw "
                        "commands, which the calibrated model puts on each target",
            "targets in": f"the nominal robot's root link '{nominal_root}'", "frame": frame, "units": "SI (m, rad)"})
        missed_nominal = [s for s in statuses if s != "ok"]
    else:
        text = commands_text(targets.ids, robot.actuated_joints, result.commands, result.residuals, result.statuses, {
            **common, "contents": "raw actuated commands [rad or m] that bring the frame on each target; the residual "
                                  "[m, rad] of the model at the commands; status",
            "targets in": where, "frame": result.frame, "tolerance": f"{result.tolerance:g} (m, rad)",
            "seed": str(args.seed),
            "units": "SI (m, rad)"}, orientation=targets.kind == "pose", bounds=bounds)
        missed_nominal = []
    write_text(args.out, text)
    print(f"wrote {args.out}")
    return EXIT_UNREACHABLE if missed or missed_nominal else 0


def bound_lines(ids: list[str], bounds: tuple[Any, Any] | None) -> list[str]:
    """The lines on the targets' predicted 95 % bounds [mm]: their median and largest, and the targets where the
    calibrated model's bound exceeds the nominal robot's own (docs/predicted_accuracy.md)."""
    import numpy as np

    from pincal import linalg

    if bounds is None:
        return ["predicted bounds: not known (MODEL carries no calibration, or its nominal robot is not found: give "
                "--nominal ROBOT)"]
    bound, own = bounds
    known = np.isfinite(bound)
    if not known.any():
        return []
    lines = [f"predicted 95 % bound at the targets (the calibration's measured point at each command): median "
             f"{linalg.median(bound[known]) * 1e3:.4f} mm, largest {np.max(bound[known]) * 1e3:.4f} mm"]
    worse = np.flatnonzero(known & np.isfinite(own) & (bound > own))
    if worse.size:
        shown = ", ".join(ids[k] for k in worse[:8]) + (" …" if worse.size > 8 else "")
        lines.append(f"warning: at {worse.size} targets ({shown}) the calibrated model's bound exceeds the nominal "
                     "robot's own: the calibration is not predicted to do better there (the file's nominal_bound)")
    return lines


def register(sub: argparse._SubParsersAction[argparse.ArgumentParser]) -> None:
    """Add the ``compensate`` command."""
    p = sub.add_parser(
        "compensate", help="joint commands that reach target positions or poses on the calibrated robot",
        description="For each target (a targets CSV: 'sample' and the columns of one position:<frame>:x,y,z or "
                    "pose:<frame>:x,y,z,qx,qy,qz,qw, metres, docs/compensate.md), the raw actuated commands [rad or m] "
                    "that bring the frame there on MODEL: inverse kinematics through the loops from the reference "
                    "configuration, then seeded random starts, each target afresh (its answer does not depend on the "
                    "others); commands within the URDF limits; the corrections file "
                    "beside MODEL (cal.corrections.json: harmonics, compliance) inverted, so the commands are raw "
                    "readings; each checked by forward kinematics of MODEL at the commands. The frame is what the "
                    "columns read in a calibrated URDF: position:<frame> its calibrated marker <frame>_marker when "
                    "there is one, else <frame>. Writes per target the commands, the residual (m, rad) and a status, "
                    "'ok' or 'unreachable: <reason>' (such rows have empty commands). With --nominal-targets, writes "
                    "instead the targets to send a controller that keeps the nominal model. Exit status: 0 every "
                    "target reached, 1 some unreachable (the file is written), 2 an error.",
        epilog="example: pincal compensate cal.urdf targets.csv --out commands.csv; "
               "pincal compensate cal.urdf targets.csv --nominal-targets --out nominal_targets.csv")
    p.add_argument("model", metavar="MODEL", help="calibrated URDF (its .corrections.json beside it is read), another "
                                                  "URDF or a known robot name (nothing corrected)")
    p.add_argument("targets", metavar="TARGETS", help="targets CSV [m, unit quaternions] (docs/compensate.md)")
    p.add_argument("--out", required=True,
                   help="the commands CSV to write (the nominal targets with --nominal-targets)")
    p.add_argument("--targets-in", choices=("measurement", "base", "board"), default="measurement",
                   help="frame of the targets: 'measurement' (default), the model's root (a calibrated URDF's "
                        "measurement_frame, the frame of the calibration data); 'base', the robot's own root link; "
                        "'board', the calibrated board an eye-in-hand camera sees (link camera_target), for targets "
                        "of the camera (pose:<frame>_camera) relative to the board")
    p.add_argument("--frame", help="frame of MODEL that goes to the targets (default: what the targets' columns read, "
                                   "see above)")
    p.add_argument("--nominal", metavar="ROBOT",
                   help="the nominal robot (URDF or name): for --nominal-targets, and for the gravity torques of "
                        "compliance corrections (default: the nominal URDF the corrections file names)")
    p.add_argument("--nominal-targets", action="store_true",
                   help="write the targets to send a controller that keeps the nominal model (--nominal, default "
                        "the one MODEL records; in its root frame), instead of joint commands")
    p.add_argument("--tolerance", type=positive_float, metavar="TOL",
                   help="largest residual [m, rad] of the model at the commands for a reached target (default 1e-9)")
    p.add_argument("--seed", type=non_negative_int, default=0, help="seed of the random starts (default 0)")
    p.add_argument("--quiet", action="store_true", help="no progress bar (it is shown only on a terminal)")
    p.set_defaults(func=cmd_compensate)
