"""The ``pincal`` command line.

Every command reports problems as one line ``pincal: error: ...`` and exits with a non-zero code;
``--debug`` shows the Python traceback instead.
"""

from __future__ import annotations

import argparse
import contextlib
import os
import re
import sys
from collections.abc import Sequence
from pathlib import Path
from typing import TYPE_CHECKING, Any, NoReturn

from pincal.calibration.options import CalibrationOptions, GivenOptions, options_given
from pincal.cli import (
    assemble,
    bag_import,
    check_data,
    compensation,
    drift_check,
    export_formats,
    filter_program,
    images,
    iso_commands,
    planning,
    report_page,
    robots,
    view,
)
from pincal.cli.arguments import (
    Subcommands,
    add_calibration_options,
    add_measurement,
    add_meshes,
    add_parameters,
    add_payload,
    add_perturb,
    add_robot,
    add_spread,
    command_flags,
    error_in_flags,
    given_options,
    non_negative_float,
    non_negative_int,
    parameter_shift,
    positive_int,
)
from pincal.errors import DataError, PincalError
from pincal.plugins import load_plugins

if TYPE_CHECKING:
    from pincal.model.robot import Robot

EXIT_ERROR = 2
#: Exit code of an unexpected exception (a bug), printed as one line; ``--debug`` shows the traceback.
EXIT_BUG = 3


def _describe(robot: Robot) -> str:
    import numpy as np

    from pincal.io.export import shown_name as shown  # a name with a line break quoted, as export does: one line each

    model = robot.model
    lines = [f"robot: {shown(robot.name)}" + (f"  ({robot.source})" if robot.source else "")]
    links = [shown(f.name) for f in model.frames if f.type.name == "BODY"]
    lines.append(f"links ({len(links)}): {', '.join(links)}")
    lines.append(f"joints ({model.njoints - 1} movable):")
    actuated = set(robot.actuated_joints)
    for j in range(1, model.njoints):
        name = model.names[j]
        tag = "  actuated" if name in actuated else ""
        lines.append(f"  {shown(name):<28} {model.joints[j].shortname():<22} nq={model.joints[j].nq}{tag}")
    lines.append(f"loops ({len(robot.loops)}):")
    for loop in robot.loops:
        lines.append(f"  {shown(loop.name):<28} {loop.type:<10} {shown(loop.predecessor)} -> {shown(loop.successor)} "
                     f"({loop.rows} rows)")
    lines.append(f"actuated joints ({robot.n_actuated}): {', '.join(map(shown, robot.actuated_joints))}")
    residual = robot.closure_residual(robot.q_reference)
    worst = float(np.max(np.abs(residual), initial=0.0))
    lines.append(f"configuration: nq {model.nq}, nv {model.nv}; closure rows {robot.closure.rows}; "
                 f"mobility {robot.mobility()}")
    lines.append(f"closure residual at the reference configuration: {worst:.3g} (m, rad)")
    lines += [f"note: {note}" for note in robot.notes]
    choice = robot.measured_frame_choice
    if choice.frame is None:
        lines.append(f"measured frame (default): none: {choice.reason}")
    else:
        part = robot.parts.moving([robot.frame_id(choice.frame)]).robot  # its joints only (pincal.model.parts)
        p = part.placement(part.q_reference, choice.frame).translation
        lines.append(f"measured frame (default): {shown(choice.frame)}, moved by the actuated joints ({choice.why}); "
                     f"at ({p[0]:.6f}, {p[1]:.6f}, {p[2]:.6f}) m at the reference")
    return "\n".join(lines)


def cmd_info(args: argparse.Namespace) -> int:
    """``pincal info``: print the robot's links, joints, loops, actuated joints, mobility and its closure residual
    [m, rad] at the reference configuration."""
    from pincal.model.robot import load_robot

    print(_describe(load_robot(args.robot)))
    return 0


def cmd_simulate(args: argparse.Namespace) -> int:
    """``pincal simulate``: draw true errors, random postures and noisy measurements of a robot and write the
    dataset, the true URDF and ``truth.json`` to ``--out``."""
    from pincal.calibration.campaign import check_sample_counts, simulate, simulation_outputs, write_simulation
    from pincal.calibration.summary import robot_named, urdf_name_note
    from pincal.io.mesh_files import mesh_folder
    from pincal.model.robot import load_robot

    robot = load_robot(args.robot)
    check_sample_counts(args.samples, args.test_samples)
    shifted = [name for name, _ in args.shift or []]
    twice = next((name for name in shifted if shifted.count(name) > 1), None)
    if twice is not None:  # a dict would keep the last one alone
        raise DataError(f"--shift {twice}: given {shifted.count(twice)} times; give each parameter once, its whole "
                        "shift [m, rad]")
    if images.is_camera(args.measure):  # a board's corners in pixels, and their images
        args.noise = images.PIXEL_NOISE if args.noise is None else args.noise
        return images.simulate_camera(args, robot)
    args.noise = 1e-5 if args.noise is None else args.noise
    unused = [flag for flag, value in (("--board", args.board), ("--images", args.images)) if value is not None]
    if unused:
        raise DataError(f"{', '.join(unused)}: only with a camera's --measure pixel:FRAME or board_pixel:FRAME "
                        f"(here --measure {' '.join(args.measure)})")
    created = not Path(args.out).exists()
    simulation_outputs(robot, args.out, args.meshes)  # refused before any work: a file, an unwritable place, the
    # robot's URDF, a mesh to copy found nowhere
    try:
        sim = simulate(robot, args.measure, args.samples, args.test_samples, frame=args.frame, perturb=args.perturb,
                       noise=args.noise, seed=args.seed, parameter_spec=args.parameters, progress=not args.quiet,
                       spread=args.spread, payload=args.payload, posture_seed=args.posture_seed,
                       shift=dict(args.shift) if args.shift else None)
        paths = write_simulation(sim, Path(args.out), args.meshes, given=args.robot)
    except PincalError:
        if created:  # the directory made above, still empty: nothing is left behind
            with contextlib.suppress(OSError):
                Path(args.out).rmdir()
        raise
    print(f"simulated {args.samples} + {args.test_samples} postures of '{robot_named(args.robot, robot.name)}'"
          f"{urdf_name_note(args.robot, robot.name)} with errors of σ {args.perturb:g} (m, rad) on "
          f"{len(sim.parameters)} parameters; measurement noise σ {args.noise:g}")
    for path in paths:
        print(f"wrote {path}")
    for line in images.shift_warnings(sim.parameters, dict(args.shift or [])):
        print(line)
    if args.meshes == "copy":
        print(f"wrote {mesh_folder(paths[1])}/ (the meshes truth.urdf names)")
    return 0


#: A file named so is a job file (docs/job_file.md): ``pincal calibrate JOB.toml``.
JOB_SUFFIX = ".toml"


def cmd_calibrate(args: argparse.Namespace) -> int:
    """``pincal calibrate``: identify the parameters from a measurement CSV (or as a job file says), print the
    summary and write the calibrated URDF and the report; exit status 1 when the result is not usable (not converged,
    or worse than nominal on the held-out samples)."""
    from pincal.calibration.from_files import calibrate_files, calibrate_job, writes_urdf
    from pincal.calibration.summary import summary_text
    from pincal.io.corrections_file import corrections_path
    from pincal.io.mesh_files import mesh_folder

    options = given_options(args)  # options not given are left out: a job file's value stands, else the default
    job_file = args.robot.endswith(JOB_SUFFIX)
    if job_file and args.data is not None:
        raise PincalError(f"calibrate: '{args.robot}' is a job file, which names its own data; give no DATA "
                          f"(got '{args.data}'), or a robot: pincal calibrate ROBOT DATA")
    if not job_file and args.data is None:
        raise PincalError(f"calibrate: DATA is missing: give pincal calibrate ROBOT DATA.csv, or a job file "
                          f"JOB{JOB_SUFFIX} (docs/job_file.md); got only '{args.robot}'")
    if job_file:
        from pincal.calibration.job import read_job  # here: a robot and a CSV read no job file

        if options.pop("markers", "each") != "each":
            raise PincalError("calibrate: --markers cluster applies to a dataset named on the command line, not yet to "
                              "a job file")
        job = read_job(args.robot).overridden(args.out, args.report, GivenOptions.of(options, "command line"))
        cal = calibrate_job(job, args.meshes, progress=True)
        out, report_path, spec = job.out, job.report, job.options.calibration.parameter_spec
    else:
        given = options_given(options, "command line")  # checked before any work, errors in the flags' words
        spec = options.get("parameter_spec")
        cal = calibrate_files(args.robot, args.data, args.out, args.report, args.meshes, given, progress=True)
        out, report_path = args.out, args.report
    print(summary_text(cal.report, cal.result.seconds, str(report_path) if report_path else None, spec))
    if out and not writes_urdf(cal.report, bool(options.get("force"))):
        print(f"not written: {out} (the fit explains nothing; --force writes it)")
        out = None
    if out:
        print(cal.proof)
    for path in (out, report_path):
        if path:
            print(f"wrote {path}")
    if out and cal.corrections is not None:
        print(f"wrote {corrections_path(out)} (joint corrections the URDF cannot hold: docs/calibrated_urdf.md)")
    if out and args.meshes == "copy":
        print(f"wrote {mesh_folder(out)}/ (the meshes the URDF names)")
    return 0 if cal.report.usable else 1


DEMO_TEXT = """pincal demo: geometric calibration of the Delta robot of study 000 (robots_urdf/delta.urdf)
  truth:   the nominal robot with random errors of 1 mm / 1 mrad on the 24 parameters of the paper's Model 24
  data:    {n_train} postures measured by a laser tracker (platform position, noise σ = {noise_um:g} µm),
           {n_test} more held out for validation
  method:  forward-kinematics (FKM) residuals, analytic Jacobians through the loops, Levenberg–Marquardt
"""


def cmd_demo(args: argparse.Namespace) -> int:
    """``pincal demo``: simulate and calibrate the Delta (``model24``, platform positions); write its files and page."""
    from pincal.calibration.campaign import simulate, write_simulation
    from pincal.calibration.from_files import write_recorded
    from pincal.calibration.pipeline import calibrate
    from pincal.calibration.summary import summary_text
    from pincal.io.files import check_directory
    from pincal.model.catalog import robot_path
    from pincal.model.robot import load_robot
    from pincal.progress import Progress
    from pincal.viz.html_report import write_demo_report

    out = check_directory(args.out, "--out")  # before any work
    print(DEMO_TEXT.format(n_train=args.samples, n_test=args.test_samples, noise_um=args.noise * 1e6), flush=True)
    with Progress("simulate, calibrate", 2) as progress:
        robot = load_robot(robot_path("delta"))
        sim = simulate(robot, ["position"], args.samples, args.test_samples, perturb=1e-3, noise=args.noise,
                       seed=args.seed, parameter_spec=["model24"])
        write_simulation(sim, out)
        progress.advance()
        options = CalibrationOptions(parameter_spec=("model24",))
        cal = calibrate(robot, sim.dataset, options, x_true=sim.x_true)
        progress.advance()
    write_recorded(cal, "delta", options, out / "measurements.csv", out / "delta_calibrated.urdf", out / "report.json")
    report_html = write_demo_report(cal, out, quiet=False)  # reads out/truth.json, written above; its own bars
    print(summary_text(cal.report, cal.result.seconds, str(out / "report.json")))
    print(cal.proof)
    print()
    print(f"wrote {out}/: delta_calibrated.urdf (the calibrated robot), {report_html.name} (open it in a "
          "browser), report.json, measurements.csv, truth.urdf, truth.json")
    return 0


#: A Dask scheduler's address: ``host:port``, or with a comm's scheme (``tcp://host:port``); a host name, an IPv4
#: address or a bracketed IPv6 one.
SCHEDULER_ADDRESS = re.compile(r"(?:(?:tcp|tls|ucx|ws|wss)://)?(?:[A-Za-z0-9._-]+|\[[0-9A-Fa-f:.]+\]):(\d{1,5})")


def check_scheduler(address: str) -> None:
    """Refuse a ``--scheduler`` that is no Dask scheduler address (PincalError naming it), before any connection is
    tried: Dask's own parser raises a bare ValueError for ``bogus`` or ``host:notaport``."""
    match = SCHEDULER_ADDRESS.fullmatch(address)
    if match is None or not 0 < int(match.group(1)) < 65536:
        raise PincalError(f"--scheduler '{address}': not a Dask scheduler address (host:port or tcp://host:port)")


def cmd_fleet(args: argparse.Namespace) -> int:
    """``pincal fleet``: calibrate one robot per CSV (or job file) of a directory (process pool or Dask scheduler) and
    print one row per robot; exit status 1 unless every result is usable."""
    from pincal.calibration.summary import verdict
    from pincal.calibration.summary_model import mm
    from pincal.fleet import calibrate_fleet, jobs_from_directory

    where = Path(args.data_dir)
    if not where.is_dir():
        what = "is a file, not a directory of CSV files (one per robot)" if where.exists() else "does not exist"
        raise DataError(f"fleet: DATA_DIR '{args.data_dir}' {what}")
    options_given(given_options(args), "command line")  # checked before any job, errors in the flags' words
    if args.scheduler:
        check_scheduler(args.scheduler)
    given = GivenOptions.of(given_options(args), "command line")
    jobs = jobs_from_directory(args.robot, args.data_dir, args.out, given)
    if not jobs:
        raise DataError(f"no *.csv or *{JOB_SUFFIX} files in '{args.data_dir}'")
    if args.scheduler:
        from dask.distributed import Client

        try:
            client = Client(args.scheduler)
        except OSError as exc:  # unreachable, refused, timed out
            raise PincalError(f"cannot reach the Dask scheduler at '{args.scheduler}': {exc}") from None
        with client:
            results = calibrate_fleet(jobs, executor=client.get_executor(), progress=True)
    else:
        results = calibrate_fleet(jobs, workers=args.workers, progress=True)
    print(f"{'robot':<24}{'held out before':>16}{'held out after':>16}{'fitted':>8}{'dropped':>9}"
          f"{'down-weighted':>15}  status")
    for r in results:
        if r.report is None:
            print(f"{r.name:<24}{'-':>16}{'-':>16}{'-':>8}{'-':>9}{'-':>15}  failed: {r.error}")
            continue
        report = r.report
        print(f"{r.name:<24}{mm(report.test_rms_before):>16}{mm(report.test_rms_after):>16}"
              f"{report.n_samples:>8}{len(report.dropped_samples):>9}{len(report.down_weighted):>15}  "
              f"{verdict(report)}")
    print(f"wrote {args.out}/ (one calibrated URDF and one report JSON per robot; the JSON names every dropped "
          "and down-weighted sample)")
    return 0 if all(r.report is not None and r.report.usable for r in results) else 1


class _Parser(argparse.ArgumentParser):
    """argparse with pincal's error form: one line, ``pincal: error: ...``, exit 2 (no usage block); a negative number
    in scientific notation (``--sigma -1e-5``) is a value, as ``-0.5`` is, not an unknown option."""

    def __init__(self, *args: Any, **kwargs: Any) -> None:
        super().__init__(*args, **kwargs)
        # argparse takes '-1e-5' for an option ("expected one argument"): its own test of a negative number knows no
        # exponent (Python 3.11's _negative_number_matcher, the parser's one place for it; no option of pincal's
        # looks like a number)
        self._negative_number_matcher = re.compile(r"^-(\d+\.?\d*|\.\d+)([eE][-+]?\d+)?$|^-(inf|nan)$",
                                                   re.IGNORECASE)

    def error(self, message: str) -> NoReturn:
        command = self.prog.removeprefix("pincal").strip()
        where = f"{command}: " if command else ""
        self.exit(EXIT_ERROR, f"pincal: error: {where}{message} (see '{self.prog} --help')\n")


class _Version(argparse.Action):
    """``--version``: print ``pincal X.Y.Z``, the installed package's version (its metadata: pyproject's
    ``version``), and exit 0; read only when asked, so that no other command pays for it."""

    def __init__(self, option_strings: Sequence[str], dest: str, help: str | None = None) -> None:
        super().__init__(option_strings, dest, nargs=0, default=argparse.SUPPRESS, help=help)

    def __call__(self, parser: argparse.ArgumentParser, namespace: argparse.Namespace, values: Any,
                 option_string: str | None = None) -> None:
        from importlib import metadata

        print(f"pincal {metadata.version('pincal')}")
        parser.exit(0)


def build_parser(command: str | None = None) -> argparse.ArgumentParser:
    """The ``pincal`` argument parser, with every subcommand; given the command a command line runs (its first word
    that is no option), with that subcommand alone, when it is one (else every subcommand: the error lists them)."""
    parser = _Parser(
        prog="pincal",
        description="Geometric calibration of closed-loop and serial robots described in URDF.",
        epilog="Units are SI everywhere (m, rad). Robots: a URDF path, or a name such as delta, hexapod, "
               "five_bar, ucr3, ur10, panda.")
    parser.add_argument("--version", action=_Version, help="print the installed pincal's version and exit")
    parser.add_argument("--debug", action="store_true", help="show Python tracebacks on errors")
    sub = parser.add_subparsers(dest="command", required=True, action=Subcommands)
    assert isinstance(sub, Subcommands)
    sub.only = command
    info = sub.add_parser("info", help="describe a robot: joints, loops, actuation, mobility",
                          description="Print links, joints, loops, actuated joints, mobility and the "
                                      "closure residual at the reference configuration.",
                          epilog="example: pincal info robots_urdf/delta.urdf")
    add_robot(info)
    info.set_defaults(func=cmd_info)

    sim = sub.add_parser("simulate", help="simulate a calibration dataset with known errors",
                         description="Perturb the robot's geometry (the truth), draw reachable postures (within "
                                     "the URDF joint limits, or --spread), measure them with noise; write "
                                     "DIR/measurements.csv, DIR/truth.urdf, DIR/truth.json.",
                         epilog="example: pincal simulate delta --samples 60 --measure position --perturb 1e-3 "
                                "--noise 1e-5 --seed 1 --out sim/")
    add_robot(sim)
    sim.add_argument("--samples", type=positive_int, default=60, help="postures to calibrate from (default 60)")
    sim.add_argument("--test-samples", type=non_negative_int, default=0, help="extra postures held out for validation")
    add_measurement(sim)
    add_perturb(sim)
    sim.add_argument("--noise", type=non_negative_float, default=None,
                     help="σ of the measurement noise [m, rad] (default 1e-5); with --measure pixel:FRAME or "
                          "board_pixel:FRAME, of the corners [px] (default 0.3)")
    sim.add_argument("--seed", type=non_negative_int, default=0,
                     help="random seed (the robot's errors; and the postures and noise without --posture-seed)")
    sim.add_argument("--posture-seed", type=non_negative_int,
                     help="seed of the postures and noise alone: the same --seed with another --posture-seed is the "
                          "same robot measured on new postures (a later session)")
    sim.add_argument("--shift", type=parameter_shift, action="append", metavar="NAME=VALUE",
                     help="add VALUE [m, rad] to the true error of parameter NAME (a robot that changed: "
                          "--shift arm_1_joint.offset=0.002); repeatable")
    add_spread(sim)
    add_parameters(sim, "parameters with errors: named sets (default, model24, model24i, hexapod42, "
                        "hexapod44) and name patterns, as for calibrate (default: the default set)")
    add_payload(sim, "truth.corrections.json records it")
    sim.add_argument("--out", required=True, help="output directory")
    add_meshes(sim, "truth.urdf")
    images.add_camera_arguments(sim)
    sim.add_argument("--quiet", action="store_true", help="no progress bar")
    sim.set_defaults(func=cmd_simulate)

    cal = sub.add_parser("calibrate", help="identify the geometry from a dataset; write a calibrated URDF",
                         usage="pincal calibrate ROBOT DATA [options]  or  pincal calibrate JOB.toml [options]",
                         description="Levenberg-Marquardt identification (forward-kinematics residuals, analytic "
                                     "Jacobians) on the identifiable parameters; rows with set=test are held out. "
                                     "A job file (JOB.toml, docs/job_file.md) names the robot, the data as the "
                                     "measuring system wrote them and the options; options given here override it.",
                         epilog="examples: pincal calibrate delta sim/measurements.csv --out delta_cal.urdf "
                                "--report report.json; pincal calibrate examples/tiago_job.toml --cv loo")
    cal.add_argument("robot", metavar="ROBOT|JOB.toml",
                     help="URDF file or known robot name; or a job file (docs/job_file.md), with no DATA")
    cal.add_argument("data", nargs="?", help="measurement CSV (see docs/dataset.md)")
    cal.add_argument("--out", help="calibrated URDF to write")
    cal.add_argument("--report", help="report JSON to write")
    add_meshes(cal, "the calibrated URDF")
    add_calibration_options(cal)
    cal.set_defaults(func=cmd_calibrate)

    demo = sub.add_parser("demo", help="simulate and calibrate the Delta robot; print before/after",
                          description="The main job on an embedded default: the Delta of study 000.",
                          epilog="example: pincal demo --out pincal-demo")
    demo.add_argument("--out", default="pincal-demo", help="output directory (default ./pincal-demo)")
    demo.add_argument("--samples", type=positive_int, default=60, help="calibration postures (default 60)")
    demo.add_argument("--test-samples", type=non_negative_int, default=40, help="validation postures (default 40)")
    demo.add_argument("--noise", type=non_negative_float, default=1e-5, help="tracker noise σ [m] (default 1e-5)")
    demo.add_argument("--seed", type=non_negative_int, default=1, help="random seed")
    demo.set_defaults(func=cmd_demo)

    fleet = sub.add_parser("fleet", help="calibrate many robots, one CSV each, in parallel",
                           description="One calibration per *.csv in DATA_DIR on the same nominal robot (ROBOT), and "
                                       "one per job file *.toml in DATA_DIR (docs/job_file.md: its own robot and "
                                       "data), in a process pool (or on a Dask cluster with --scheduler). The "
                                       "calibration options are those of calibrate; given here, they override "
                                       "the job files' own.",
                           epilog="example: pincal fleet delta measurements/ --out calibrated/ --workers 2")
    add_robot(fleet, "the nominal model")
    fleet.add_argument("data_dir", help="directory of measurement CSV files, one per robot")
    fleet.add_argument("--out", required=True, help="output directory")
    add_calibration_options(fleet)
    fleet.add_argument("--workers", type=positive_int, help="processes (default: the machine's cores)")
    fleet.add_argument("--scheduler", help="address of a Dask scheduler (pip install 'pincal[dask]')")
    fleet.set_defaults(func=cmd_fleet)

    for module in (view, report_page, planning, check_data, compensation, export_formats, filter_program, bag_import,
                   assemble, robots, iso_commands, drift_check, images):  # command groups of their own
        module.register(sub)
    if command is not None and command not in sub.choices:  # no command of that name: every one, to list them
        return build_parser()
    return parser


def say_replaced() -> None:
    """Say which existing files the command replaced (their old content is gone)."""
    files = sys.modules.get("pincal.io.files")  # not imported: nothing written
    replaced = files.take_replaced() if files is not None else []
    if replaced:
        print(f"note: replaced the existing {'file' if len(replaced) == 1 else 'files'} "
              f"{', '.join(str(p) for p in replaced)}")


def main(argv: Sequence[str] | None = None) -> int:
    """Entry point of the ``pincal`` console script; returns the exit code."""
    words = sys.argv[1:] if argv is None else list(argv)
    parser = build_parser(next((w for w in words if not w.startswith("-")), None))  # pincal's options take no value
    args = parser.parse_args(words)
    files = sys.modules.get("pincal.io.files")
    if files is not None:
        files.take_replaced()  # what the library replaced before this command is not this command's to say
    try:
        load_plugins()  # the user's kinds (PINCAL_PLUGINS), before any command reads a key or a file
        status = int(args.func(args))
        say_replaced()
        return status
    except PincalError as exc:
        if args.debug:
            raise
        say_replaced()
        print(f"pincal: error: {error_in_flags(exc, command_flags(parser, args.func))}", file=sys.stderr)
        return EXIT_ERROR
    except KeyboardInterrupt:
        print("pincal: interrupted", file=sys.stderr)
        return 130
    except BrokenPipeError:  # `pincal ... | head`: the reader left; say nothing more, as Unix tools do
        os.dup2(os.open(os.devnull, os.O_WRONLY), sys.stdout.fileno())
        return 141
    except MemoryError:
        print("pincal: error: out of memory: the data or the parameter set is too large for this machine",
              file=sys.stderr)
        return EXIT_ERROR
    except Exception as exc:  # a bug: one line for the user, the traceback with --debug
        if _interrupt_pending():  # a Ctrl-C inside a C extension's import surfaces as its ImportError (NumPy's)
            print("pincal: interrupted", file=sys.stderr)
            return 130
        if args.debug:
            raise
        print(f"pincal: internal error: {type(exc).__name__}: {exc} (a bug in pincal: run again with --debug and "
              "report the traceback)", file=sys.stderr)
        return EXIT_BUG



def _interrupt_pending() -> bool:
    """Whether the command's SIGINT handler (:mod:`pincal.__main__`, the console script's module, or ``__main__``
    under ``python -m pincal``) has seen a Ctrl-C: an exception raised after it is the interrupt's doing."""
    entry = sys.modules.get("pincal.__main__") or sys.modules.get("__main__")
    return bool(getattr(entry, "_interrupted", False))


if __name__ == "__main__":
    sys.exit(main())
