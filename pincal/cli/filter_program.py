"""``pincal filter``: a URScript, KRL or RAPID program's Cartesian targets rewritten for the calibrated robot
(docs/filter.md). The work is :mod:`pincal.calibration.program_filter`; the programs are read by
:mod:`pincal.io.programs`."""

from __future__ import annotations

import argparse
import math
import os
from collections.abc import Callable
from pathlib import Path

from pincal.cli.arguments import non_negative_int, positive_float
from pincal.errors import ArgumentError, DataError

#: Exit status when some target or construct is left as written (the program is written, the rest rewritten).
EXIT_LEFT = 1


#: Longest tool centre point offset [m] --tcp takes: a longer one is millimetres (150 for 0.15 m).
LONGEST_TOOL = 5.0


def _pose_option(what: str) -> Callable[[str], tuple[float, ...]]:
    """The parser of ``what`` (``--tcp``, ``--robot-base``): ``x,y,z,rx,ry,rz``, metres and a rotation vector [rad];
    a rotation vector longer than a turn (degrees), or a tool farther than :data:`LONGEST_TOOL` (millimetres), is
    refused by name."""
    def parse(text: str) -> tuple[float, ...]:
        try:
            values = tuple(float(v) for v in text.split(","))
        except ValueError:
            values = ()
        if len(values) != 6 or not all(abs(v) < float("inf") for v in values):
            raise argparse.ArgumentTypeError(f"'{text}': give six finite numbers x,y,z,rx,ry,rz (m, rotation vector "
                                             "rad)")
        turn = math.hypot(*values[3:])
        if turn > 2 * math.pi + 1e-9:
            raise argparse.ArgumentTypeError(f"'{text}': a rotation vector of {turn:g} rad: {what} turns in radians "
                                             "(a whole turn is 6.28), not degrees")
        reach = math.hypot(*values[:3])
        if what == "--tcp" and reach > LONGEST_TOOL:
            raise argparse.ArgumentTypeError(f"'{text}': a tool centre point {reach:g} m from the flange: --tcp is in "
                                             f"metres (150 mm is 0.15)")
        return values
    return parse


def outputs_of(program: str, out: str, files: list[str]) -> dict[str, Path]:
    """Where each file of the program goes: the program to ``out``; a KRL program's ``.dat`` beside it, with the same
    stem and the ``.dat`` suffix (KRL names a module by its files)."""
    targets = {program: Path(out)}
    for name in files:
        if name != program and Path(name).suffix.lower() == ".dat" and Path(name).stem == Path(program).stem:
            targets[name] = Path(out).with_suffix(Path(name).suffix)
    return targets


def shown(path: str) -> str:
    """A file's path as printed: normalised (``./a//b/../c`` → ``a/c``), relative if it was given so."""
    return os.path.normpath(path)


def cmd_filter(args: argparse.Namespace) -> int:
    """``pincal filter``: rewrite the program's Cartesian targets, list each one's move and bound, warn of what is left
    as written; exit 1 when something is."""
    import math

    import numpy as np
    import pinocchio as pin

    from pincal.calibration.compensate import load_model
    from pincal.calibration.program_filter import TOLERANCE, filter_program
    from pincal.calibration.provenance import read_provenance
    from pincal.io.files import check_outputs, write_texts
    from pincal.io.program_reader import dat_of, read_program
    from pincal.io.programs import encoding_of, language_of, vendor_mismatch
    from pincal.io.targets import OK
    from pincal.model.robot import load_robot

    language = language_of(args.program)
    program_path = Path(args.program)
    inputs = [p for p in (args.program, args.model, args.nominal, *args.config) if p and Path(p).is_file()]
    dat = dat_of(program_path)
    if language == "krl" and dat is not None:
        inputs.append(str(dat))
    if language == "krl" and Path(args.out).suffix.lower() != ".src":
        raise ArgumentError(f"--out '{args.out}': a KRL program is written as a .src (its .dat beside it)")
    planned = outputs_of(args.program, args.out, [str(p) for p in inputs])
    check_outputs([("--out", path) for path in planned.values()], inputs)
    values = args.tcp or (0.0,) * 6
    tcp = pin.SE3(pin.exp3(np.array(values[3:])), np.array(values[:3]))
    base = None if args.robot_base is None else pin.SE3(pin.exp3(np.array(args.robot_base[3:])),
                                                        np.array(args.robot_base[:3]))
    program = read_program(args.program, tcp, args.config, base)
    nominal_name = args.nominal or read_provenance(args.model).robot or args.model
    nominal = load_robot(nominal_name)
    model = load_model(args.model, nominal)
    if model.corrections_file is not None:
        check_outputs([("--out", path) for path in planned.values()], [*inputs, model.corrections_file])
    result = filter_program(program, model, nominal, args.base, args.flange, args.tolerance or TOLERANCE,
                            args.seed, args.joint_targets)
    cartesian = sum(r.target.pose is not None for r in result.results)
    print(f"filter: {shown(args.program)} ({language}), {cartesian} Cartesian and {result.joint_targets} joint "
          f"targets; model {shown(args.model)}, controller's nominal model {shown(nominal_name)}; base frame "
          f"{result.base_frame}, flange "
          f"{result.flange}" + (f"; {program.robot_base}" if program.robot_base else "")
          + ("; joint targets rewritten for the nominal pose they give" if args.joint_targets ==
                                "intended" else ""))
    if result.results:
        print(f"  {'line':>6}  {'target':<24}{'move mm':>10}{'mrad':>9}{'95% bound mm':>14}  status")
    for outcome in result.results:
        target = outcome.target
        move = "" if math.isnan(outcome.move[0]) else f"{outcome.move[0] * 1e3:.4f}"
        angle = "" if math.isnan(outcome.move[1]) else f"{outcome.move[1] * 1e3:.4f}"
        bound = "" if math.isnan(outcome.bound) else f"{outcome.bound * 1e3:.4f}"
        where = target.line if target.file == args.program else f"{Path(target.file).name}:{target.line}"
        print(f"  {where!s:>6}  {target.name[:23]:<24}{move:>10}{angle:>9}{bound:>14}  "
              f"{'rewritten' if outcome.status == OK else 'left as written'}")
    left = [r for r in result.results if r.status != OK]
    for outcome in left:
        target = outcome.target
        print(f"warning: {shown(target.file)} line {target.line}: '{target.name}' left as written: "
              f"{outcome.status}")
    for problem in result.program.problems:
        print(f"warning: {shown(problem.file)} line {problem.line}: {problem.what}")
    maker = vendor_mismatch(language, [nominal.name, model.robot.name])
    if maker is not None:
        print(f"warning: {maker}")
    for outcome in result.results:
        if outcome.posture[1] is not None:
            target = outcome.target
            print(f"note: {shown(target.file)} line {target.line}: '{target.name}': the calibrated "
                  f"commands have another posture than the one written ({outcome.posture[1]}): the new one is written, "
                  "so that the controller picks them")
    done = [r for r in result.results if r.status == OK]
    if done:
        largest = max(r.residual[0] for r in done)
        what = f"{cartesian} Cartesian" + (f" and {result.joint_targets} joint" if args.joint_targets == "intended"
                                            else "")
        print(f"rewrote {len(done)} of {what} targets (largest residual of the model at their commands "
              f"{largest:.3g} m); moves up to {max(r.move[0] for r in done) * 1e3:.4f} mm, "
              f"{max(r.move[1] for r in done) * 1e3:.4f} mrad; every other byte as it was")
    written: list[tuple[str | Path, str | bytes]] = []
    for name, text in result.texts.items():
        destination = planned.get(name)
        if destination is None:
            if text != program.texts[name]:
                raise DataError(f"{name} would change but has no output: pincal never writes over an input")
            continue
        written.append((destination, text.encode(encoding_of(name))))  # the input's encoding: every byte kept
    for destination in write_texts(written):
        print(f"wrote {destination}")
    if language == "krl" and Path(args.out).stem.lower() != program_path.stem.lower():
        print(f"note: KRL names a module by its files: {Path(args.out).name} still declares the module "
              f"'{program_path.stem}' (DEF, DEFDAT); to load it on the controller, give it that name in another "
              "folder")
    return EXIT_LEFT if left or result.program.problems else 0


def register(sub: argparse._SubParsersAction[argparse.ArgumentParser]) -> None:
    """Add the ``filter`` command."""
    p = sub.add_parser(
        "filter", help="rewrite a robot program's targets (URScript, KRL, RAPID) for the calibrated robot",
        description="Every Cartesian target of PROGRAM (URScript .script: movej/movel/movep/movec/servoj poses; KUKA "
                    "KRL .src with its .dat: E6POS/POS/FRAME targets, declared or inline; ABB RAPID .mod: robtargets, "
                    "declared or inline) rewritten so that the robot's controller, which keeps the nominal model, "
                    "puts the calibrated robot (MODEL) on the pose the target intends: the nominal controller's answer "
                    "found from the move before, the calibrated commands from it on the same branch, the target "
                    "written as the nominal pose at those commands. Joint targets and every other byte are kept. Each "
                    "target's move (mm, mrad) and the calibration's predicted 95 % bound at it are listed; a target "
                    "not reached or a construct pincal does not read is named by line and left as written. Exit "
                    "status: 0 every target rewritten, 1 something left as written (the program is written), 2 an "
                    "error.",
        epilog="example: pincal filter weld.script --model cal.urdf --out weld_cal.script (docs/filter.md)")
    p.add_argument("program", metavar="PROGRAM", help="the program: .script (URScript), .src (KRL; its .dat beside it "
                                                      "is read), .mod (RAPID)")
    p.add_argument("--model", required=True, help="the calibrated URDF (pincal calibrate --out; its .corrections.json "
                                                   "beside it is read)")
    p.add_argument("--out", required=True, help="the program to write (a KRL .src: its .dat is written beside it)")
    p.add_argument("--nominal", metavar="ROBOT", help="the controller's nominal robot (URDF or name; default the one "
                                                      "MODEL records)")
    p.add_argument("--tcp", type=_pose_option("--tcp"), metavar="X,Y,Z,RX,RY,RZ",
                   help="the tool centre point in the flange frame (m, rotation vector rad) where the program sets "
                        "none (default: the flange)")
    p.add_argument("--base-frame", dest="base",
                   help="the frame the program's coordinates are in (default 'base', else the robot's root link)")
    p.add_argument("--flange", help="the flange frame tools hang on (default: KRL 'flange', else 'tool0')")
    p.add_argument("--config", action="append", default=[], metavar="FILE",
                   help="a file of the controller: KRL its TOOL_DATA and BASE_DATA ($config.dat) or $ROBROOT "
                        "($machine.dat), RAPID the robot's base frame (MOC.cfg); may be repeated")
    p.add_argument("--robot-base", type=_pose_option("--robot-base"), metavar="X,Y,Z,RX,RY,RZ",
                   help="KRL, RAPID: the robot's base frame in the program's world frame (m, rotation vector rad) "
                        "where no --config file gives it (default: the world frame is the robot's base)")
    p.add_argument("--joint-targets", choices=("keep", "intended"), default="keep",
                   help="keep: joint targets as written (default); intended: each taken for the flange pose the "
                        "nominal model gives it (joints computed offline) and rewritten as the calibrated commands "
                        "for it")
    p.add_argument("--tolerance", type=positive_float, metavar="TOL",
                   help="largest residual [m, rad] of the model at a rewritten target's commands (default 1e-9)")
    p.add_argument("--seed", type=non_negative_int, default=0, help="seed of the random starts (default 0)")
    p.set_defaults(func=cmd_filter)
