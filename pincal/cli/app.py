"""The ``pincal`` command line.

Every command reports problems as one line ``pincal: error: ...`` and exits with a non-zero code;
``--debug`` shows the Python traceback instead.
"""

from __future__ import annotations

import argparse
import contextlib
import os
import sys
import textwrap
from collections.abc import Sequence
from pathlib import Path
from typing import Any, NoReturn

import numpy as np

from pincal.cli import report, study, view
from pincal.cli.options import (
    add_markers,
    add_measurement,
    add_parameters,
    add_payload,
    add_perturb,
    add_robot,
    add_selection_and_cv,
    add_solver_and_loss,
    add_spread,
    non_negative_float,
    non_negative_int,
    positive_float,
    positive_int,
)
from pincal.errors import DataError, PincalError
from pincal.identification.corrections import payload_from_dict
from pincal.io.corrections import corrections_path
from pincal.io.files import make_directory, write_text
from pincal.model.robot import Robot, load_robot
from pincal.plugins import load_plugins
from pincal.workflow import NOISE_CONTRADICTED

EXIT_ERROR = 2
#: Exit code of an unexpected exception (a bug), printed as one line; ``--debug`` shows the traceback.
EXIT_BUG = 3


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
    choice = robot.measured_frame_choice
    if choice.frame is None:
        lines.append(f"measured frame (default): none: {choice.reason}")
    else:
        p = robot.placement(robot.q_reference, choice.frame).translation
        why = "named like an end effector" if choice.rule == "named" else "the one moving link with none below it"
        lines.append(f"measured frame (default): {choice.frame}, moved by the actuated joints ({why}); at "
                     f"({p[0]:.6f}, {p[1]:.6f}, {p[2]:.6f}) m at the reference")
    return "\n".join(lines)


def cmd_info(args: argparse.Namespace) -> int:
    """``pincal info``: print the robot's links, joints, loops, actuated joints, mobility and its closure residual
    [m, rad] at the reference configuration."""
    print(_describe(load_robot(args.robot)))
    return 0


def _mm(value: float | None) -> str:
    return "-" if value is None or value != value else f"{value * 1e3:.4f} mm"


def cmd_simulate(args: argparse.Namespace) -> int:
    """``pincal simulate``: draw true errors, random postures and noisy measurements of a robot and write the
    dataset, the true URDF and ``truth.json`` to ``--out``."""
    from pincal.workflow import check_sample_counts, simulate, simulation_outputs, write_simulation

    robot = load_robot(args.robot)
    check_sample_counts(args.samples, args.test_samples)
    created = not Path(args.out).exists()
    simulation_outputs(robot, args.out)  # refused before any work: a file, an unwritable place, the robot's URDF
    try:
        sim = simulate(robot, args.measure, args.samples, args.test_samples, frame=args.frame, perturb=args.perturb,
                       noise=args.noise, seed=args.seed, parameter_spec=args.parameters, progress=not args.quiet,
                       spread=args.spread, payload=args.payload)
        paths = write_simulation(sim, Path(args.out))
    except PincalError:
        if created:  # the directory made above, still empty: nothing is left behind
            with contextlib.suppress(OSError):
                Path(args.out).rmdir()
        raise
    print(f"simulated {args.samples} + {args.test_samples} postures of '{robot.name}' with errors of "
          f"σ {args.perturb:g} "
          f"(m, rad) on {len(sim.parameters)} parameters; measurement noise σ {args.noise:g}")
    for path in paths:
        print(f"wrote {path}")
    return 0


#: A file named so is a job file (docs/job_file.md): ``pincal calibrate JOB.toml``.
JOB_SUFFIX = ".toml"


def cmd_calibrate(args: argparse.Namespace) -> int:
    """``pincal calibrate``: identify the parameters from a measurement CSV (or as a job file says), print the
    summary and write the calibrated URDF and the report; exit status 1 when the result is not :func:`usable`."""
    from pincal.io.job import read_job
    from pincal.workflow import calibrate_files, calibrate_job, check_cv_seed

    # options not given are None: a job file's value stands, else calibrate()'s default
    given = {"parameter_spec": args.parameters, "solver": args.solver, "loss": args.loss, "sigma": args.sigma,
             "formulation": args.formulation, "max_iter": args.max_iter, "select": args.select, "cv": args.cv,
             "cv_seed": args.cv_seed, "markers": args.markers, "payload": args.payload}
    options = {name: value for name, value in given.items() if value is not None}
    job_file = args.robot.endswith(JOB_SUFFIX)
    if job_file and args.data is not None:
        raise PincalError(f"calibrate: '{args.robot}' is a job file, which names its own data; give no DATA "
                          f"(got '{args.data}'), or a robot: pincal calibrate ROBOT DATA")
    if not job_file and args.data is None:
        raise PincalError(f"calibrate: DATA is missing: give pincal calibrate ROBOT DATA.csv, or a job file "
                          f"JOB{JOB_SUFFIX} (docs/job_file.md); got only '{args.robot}'")
    if job_file:
        if options.pop("markers") != "each":
            raise PincalError("calibrate: --markers cluster applies to a dataset named on the command line, not yet to "
                              "a job file")
        job = read_job(args.robot).overridden(args.out, args.report, **options)
        cal = calibrate_job(job)
        out, report_path = job.out, job.report
    else:
        check_cv_seed(args.cv, args.cv_seed or 0, "command line", "command line")  # in the flags' words
        cal = calibrate_files(args.robot, args.data, args.out, args.report, progress=True, **options)
        out, report_path = args.out, args.report
    print(_summary(cal.report, cal.result.seconds, str(report_path) if report_path else None))
    for path in (out, report_path):
        if path:
            print(f"wrote {path}")
    if out and cal.corrections is not None:
        print(f"wrote {corrections_path(out)} (joint corrections the URDF cannot hold: docs/calibrated_urdf.md)")
    return 0 if usable(cal.report) else 1


def usable(report: dict[str, Any]) -> bool:
    """Whether a calibration's result may be used: converged and not worse than nominal on the held-out samples
    (each is said on the summary's first line otherwise; residuals above 3 × σ are said there too)."""
    return bool(report["converged"]) and not report.get("worse_than_nominal")


def _mrad(value: float | None) -> str:
    return "-" if value is None or value != value else f"{value * 1e3:.4f} mrad"


def _column(value: str) -> str:
    """A figure of the before/after table, right-aligned in 14 characters and never run into the one before it."""
    return f" {value:>13}"


def _heavy_payload(report: dict[str, Any]) -> str | None:
    """A warning when the payload [kg] outweighs every moving link of the robot together (grams typed as kilograms,
    a load meant for another robot). When the URDF gives the links no mass there is nothing to weigh it against: a
    note says so, and that the compliances then rest on the payload's gravity torque alone."""
    payload, links = report.get("payload"), report.get("links_mass")
    if not payload or links is None:
        return None
    if links <= 0.0:
        return (f"note: the URDF gives the robot's moving links no mass (no <inertial>), so the payload's "
                f"{payload['mass']:g} kg cannot be checked against theirs, and the compliances rest on its gravity "
                "torque alone: right for a light arm under a heavy tool, wrong if the URDF merely leaves the masses "
                "out")
    if payload["mass"] <= links:
        return None
    return (f"warning: the payload ({payload['mass']:g} kg) outweighs all the robot's moving links together "
            f"({links:.3g} kg, from the URDF): check its mass [kg] and its frame")


def _summary(report: dict[str, Any], seconds: float, report_path: str | None = None) -> str:
    lines = [f"NOT CONVERGED: {report['message']} after {report['iterations']} iterations; the estimate below is "
             "where the solver stopped, not a calibration (try --max-iter, fewer --parameters or more samples)"
             if not report["converged"] else None,
             f"WORSE THAN NOMINAL: the calibrated model predicts the held-out samples worse than the nominal one "
             f"(RMS {_mm(report['test_rms_after'])} against {_mm(report['test_rms_before'])}); keep the nominal model, "
             "or fit fewer parameters, or measure postures that cover the held-out range"
             if report.get("worse_than_nominal") else None,
             # said first: "converged" must not read as "fits the data"
             f"THE FIT DOES NOT REACH THE STATED NOISE: residuals {report['sigma2'] ** 0.5:.3g} × σ after calibration; "
             "either the stated σ is wrong or the model cannot fit these data (see the warning below)"
             if (report.get("sigma2") or 0.0) > NOISE_CONTRADICTED else None,
             f"samples {report['n_samples']}, parameters {report['n_parameters']}, "
             f"identifiable {report['n_identifiable']}, estimated {report.get('n_estimated', report['n_identifiable'])}"
             f", condition number {report['condition_number']:.3g}" if report["condition_number"] else "",
             _selection_line(report),
             f"payload {payload_from_dict(report['payload'])}, in the gravity torque of the compliances"
             if report.get("payload") else None,
             _heavy_payload(report),
             f"solver {report['solver']}, loss {report['loss']}: {report['message']} after {report['iterations']} "
             f"iterations, {seconds:.3f} s",
             "",
             f"{'':32}{'before':>14}{'after':>14}",
             f"{'RMS position error (fit)':32}{_column(_mm(report['rms_before']))}{_column(_mm(report['rms_after']))}",
             f"{'max position error (fit)':32}{_column(_mm(report['max_before']))}{_column(_mm(report['max_after']))}"]
    if "rms_angle_before" in report:
        lines += [f"{'RMS orientation error (fit)':32}{_column(_mrad(report['rms_angle_before']))}"
                  f"{_column(_mrad(report['rms_angle_after']))}",
                  f"{'max orientation error (fit)':32}{_column(_mrad(report['max_angle_before']))}"
                  f"{_column(_mrad(report['max_angle_after']))}"]
    if "test_rms_before" in report:
        lines += [f"{'RMS position error (held out)':32}{_column(_mm(report['test_rms_before']))}"
                  f"{_column(_mm(report['test_rms_after']))}",
                  f"{'max position error (held out)':32}{_column(_mm(report['test_max_before']))}"
                  f"{_column(_mm(report['test_max_after']))}"]
    if "test_rms_angle_before" in report:
        lines += [f"{'RMS orientation error (held out)':32}{_column(_mrad(report['test_rms_angle_before']))}"
                  f"{_column(_mrad(report['test_rms_angle_after']))}",
                  f"{'max orientation error (held out)':32}{_column(_mrad(report['test_max_angle_before']))}"
                  f"{_column(_mrad(report['test_max_angle_after']))}"]
    if report.get("before_means"):
        lines.append(f"(before: {report['before_means']})")
    if report.get("joints_at_reference"):
        joints = report["joints_at_reference"]
        lines += textwrap.wrap(f"not in the file, at their reference (they move nothing measured): {', '.join(joints)}",
                               120, subsequent_indent="  ", break_on_hyphens=False)[:3]
    lines += _accounting(report)
    if report.get("calibration_gain") is not None:
        lines.append(f"{'calibration gain G (study 000)':32}{'':>14}{report['calibration_gain']:>12.1f} %")
        if report["unidentifiable"]:
            lines.append("  (G compares every parameter with the truth; parameters the data cannot separate stay at "
                         "minimum-norm values, which caps G: the position errors are the measure that counts)")
    lines += _generalization(report)
    if report["unidentifiable"]:
        lines.append("")
        lines.append(f"not identifiable from these data ({len(report['unidentifiable'])} directions):")
        lines += report.get("unidentifiable_listing") or [f"  - {text}" for text in report["unidentifiable"]]
        count = len(report["unidentifiable"])
        lines.append(f"  (all {count} in full: the report's 'unidentifiable')" if report_path else
                     f"  (all {count} in full: --report FILE writes them, under 'unidentifiable')")
    return "\n".join(line for line in lines if line is not None)


def _selection_line(report: dict[str, Any]) -> str | None:
    """What model selection left out, in one line (None when it left nothing out)."""
    selection = report.get("selection") or {}
    removed = selection.get("removed") or []
    if not removed:
        return None
    return (f"model selection ({selection['policy']}): left out the {', '.join(selection['removed_groups'])} "
            f"({len(removed)} parameters at nominal); --select none keeps them")


#: Cross-validated error above this multiple of the fit error is called overfitting.
OVERFIT_RATIO = 1.5
#: Fewer measured values than this per estimated parameter are called few.
VALUES_PER_PARAMETER = 5


def _generalization(report: dict[str, Any]) -> list[str]:
    """The cross-validated error beside the fit's, and the warnings about generalization."""
    lines = []
    cv = report.get("cv")
    if cv and cv["rms"] is None:
        lines.append(f"cross-validation ({cv['plan']}): no fold could be fitted; first: {cv['failed_folds'][0]}")
    elif cv:
        lines.append(f"{'RMS position error (cross-val.)':32}{'':>14}{_mm(cv['rms']):>14}  ({cv['plan']}, "
                     f"{cv['n_samples']} samples, {cv['n_predictions']} predictions)")
        for key, value in (cv.get("rms_by_reading") or {}).items():
            lines.append(f"{'  ' + key:32}{'':>14}{_mm(value):>14}")
        if "rms_angle" in cv:
            lines.append(f"{'RMS orientation error (cross-val.)':32}{'':>14}{_mrad(cv['rms_angle']):>14}")
        if cv.get("failed_folds"):
            lines.append(f"  ({len(cv['failed_folds'])} fold fits failed and are left out; the report lists them)")
        if cv.get("unconverged_folds"):
            lines.append(f"  ({cv['unconverged_folds']} fold fits stopped before converging; their predictions count)")
        fit = report.get("rms_after")
        if fit and cv["rms"] > OVERFIT_RATIO * fit:
            lines.append(f"warning: the cross-validated error is {cv['rms'] / fit:.2g} × the fit error: the model "
                         "follows these samples more closely than it predicts new ones (overfitting)")
    rows = report.get("n_residuals")
    estimated = report.get("n_estimated")
    if rows and estimated and rows < VALUES_PER_PARAMETER * estimated:
        lines.append(f"warning: {rows / estimated:.2g} measured values per estimated parameter "
                     f"(< {VALUES_PER_PARAMETER}): check generalization with --cv 5, or add postures")
    return lines


def _readings(report: dict[str, Any]) -> list[str]:
    """How many position readings the figures are made of, per marker, when a file measures several markers or
    some were not seen (nothing otherwise: then every sample holds every reading)."""
    fitted, unseen = report.get("readings") or {}, report.get("readings_not_seen") or {}
    if len(unseen) < 2 and not any(unseen.values()):
        return []
    per_frame: dict[str, list[str]] = {}
    for key in unseen:  # position:<frame>@<marker> or position:<frame>
        frame, _, marker = key.partition(":")[2].partition("@")
        per_frame.setdefault(frame, []).append(f"{marker or 'origin'} {fitted[key]}")
    parts = "; ".join(f"{frame}: {', '.join(counts)}" for frame, counts in per_frame.items())
    held = report.get("test_readings") or {}
    return [f"position readings: fitted {sum(fitted[key] for key in unseen)} ({parts}), not seen "
            f"{sum(unseen.values())}" + (f"; held out {sum(held.get(key, 0) for key in unseen)}" if held else ""),
            "  (each RMS position error is over the readings taken: one 3D error per marker seen)"]


#: Most samples listed one per line in the summary; the report JSON lists them all.
LISTED = 10
#: Share of down-weighted samples from which the summary warns that the robust fit is stretched.
ROBUST_WARNING_FRACTION = 0.25


def _accounting(report: dict[str, Any]) -> list[str]:
    """Where every sample of the file went, and whether the residuals agree with the stated noise."""
    dropped = report.get("dropped_samples", []) + report.get("dropped_test_samples", [])
    weighted = report.get("down_weighted", [])
    held = report.get("n_test_samples", 0)
    total = report.get("n_samples_in_file", report["n_samples"] + held + len(dropped))
    lines = ["", f"samples in the file {total}: fitted {report['n_samples']}, held out {held}, dropped {len(dropped)}"
                 + (f", down-weighted {len(weighted)} of the fitted" if weighted else "")]
    lines += _readings(report)
    if dropped:
        lines.append(f"dropped ({len(dropped)}):")
        lines += [f"  - sample {d['sample']}: {d['reason']}" for d in dropped[:LISTED]]
    if weighted:
        lines.append(f"down-weighted by the robust loss ({len(weighted)}):")
        lines += [f"  - sample {w['sample']}: weight {w['weight']:.3g}"
                  + (f", error {_mm(w['error_after'])} after calibration" if w["error_after"] is not None else "")
                  for w in weighted[:LISTED]]
    strange = report.get("held_out_outliers", [])
    if strange:
        lines.append(f"held-out samples the calibrated model cannot explain ({len(strange)}; they weigh on the "
                     f"held-out figures, not on the comparison with the nominal model): {', '.join(strange[:LISTED])}"
                     + (" ..." if len(strange) > LISTED else ""))
    outside = report.get("held_out_outside_range", [])
    if outside:  # one line of at most 120 characters: a few samples, else their count
        ids, joints = (list(dict.fromkeys(str(o[key]) for o in outside)) for key in ("sample", "joint"))
        where = joints[0] if len(joints) == 1 else f"{len(joints)} actuated joints"
        shown = ", ".join(ids[:3]) + (f" (+{len(ids) - 3})" if len(ids) > 3 else "")
        lines.append(next(line for line in (f"warning: held-out sample {shown} lies outside the fitted range of "
                                            f"{where}: its error measures extrapolation" if len(ids) == 1 else
                                            f"warning: held-out samples {shown} lie outside the fitted range of "
                                            f"{where}: their errors measure extrapolation",
                                            f"warning: {len(ids)} held-out samples lie outside the fitted range of "
                                            f"{where}: their errors measure extrapolation",
                                            f"warning: {len(ids)} held-out samples lie outside the fitted range of "
                                            "the actuated joints: their errors measure extrapolation")
                          if len(line) <= 120))
    if weighted and len(weighted) >= ROBUST_WARNING_FRACTION * report["n_samples"]:
        lines.append(f"warning: {len(weighted)} of the {report['n_samples']} fitted samples "
                     f"({len(weighted) / report['n_samples']:.0%}) were down-weighted: a robust fit is not meant for "
                     "that many; check the measuring set-up and the model before using the result")
    if len(dropped) > LISTED or len(weighted) > LISTED:
        lines.append(f"  (the first {LISTED} of each are listed; --report writes them all)")
    sigma2 = report.get("sigma2")
    if sigma2 is not None and sigma2 > 0:
        ratio = sigma2**0.5
        lines.append(f"a-posteriori σ: {ratio:.3g} × the stated σ (σ² factor {sigma2:.4g}); the standard deviations "
                     "use it")
        if not 1 / 3 <= ratio <= 3:
            lines.append(f"warning: the residuals are {ratio:.3g} × the stated noise: the stated σ (--sigma or the "
                         "file's '# sigma' lines) is wrong, or the model misses an effect")
    return lines


DEMO_TEXT = """pincal demo: geometric calibration of the Delta robot of study 000 (robots_urdf/delta.urdf)
  truth:   the nominal robot with random errors of 1 mm / 1 mrad on the 24 parameters of the paper's Model 24
  data:    {n_train} postures measured by a laser tracker (platform position, noise σ = {noise_um:g} µm),
           {n_test} more held out for validation
  method:  forward-kinematics (FKM) residuals, analytic Jacobians through the loops, Levenberg–Marquardt
"""


def cmd_demo(args: argparse.Namespace) -> int:
    """``pincal demo``: simulate and calibrate the Delta robot (``model24`` parameters, platform positions) and
    write the calibrated URDF, an offline HTML report and the simulated data."""
    from pincal.io.report_data import write_json
    from pincal.model.catalog import robot_path
    from pincal.viz.html_report import write_demo_report
    from pincal.workflow import calibrate, simulate, write_simulation

    robot = load_robot(robot_path("delta"))
    out = make_directory(args.out, "--out")  # before any work
    sim = simulate(robot, ["position"], args.samples, args.test_samples, perturb=1e-3, noise=args.noise,
                   seed=args.seed, parameter_spec=["model24"])
    write_simulation(sim, out)
    cal = calibrate(robot, sim.dataset, parameter_spec=["model24"], x_true=sim.x_true)
    urdf = out / "delta_calibrated.urdf"
    write_text(urdf, cal.urdf_text)
    write_json(out / "report.json", cal.report)
    report_html = write_demo_report(cal, sim.dataset, out)  # reads out/truth.json, written above
    print(DEMO_TEXT.format(n_train=args.samples, n_test=args.test_samples, noise_um=args.noise * 1e6))
    print(_summary(cal.report, cal.result.seconds, str(out / "report.json")))
    print()
    print(f"wrote {out}/: delta_calibrated.urdf (the calibrated robot), {report_html.name} (open it in a "
          "browser), report.json, measurements.csv, truth.urdf, truth.json")
    return 0


def cmd_fleet(args: argparse.Namespace) -> int:
    """``pincal fleet``: calibrate one robot per CSV of a directory (process pool or Dask scheduler) and print one
    row per robot; exit status 1 unless every result is :func:`usable`."""
    from pincal.fleet import calibrate_fleet, jobs_from_directory

    where = Path(args.data_dir)
    if not where.is_dir():
        what = "is a file, not a directory of CSV files (one per robot)" if where.exists() else "does not exist"
        raise DataError(f"fleet: DATA_DIR '{args.data_dir}' {what}")
    jobs = jobs_from_directory(args.robot, args.data_dir, args.out, parameter_spec=args.parameters,
                               formulation=args.formulation)
    if not jobs:
        raise DataError(f"no *.csv files in '{args.data_dir}'")
    if args.scheduler:
        from dask.distributed import Client

        try:
            client = Client(args.scheduler)
        except OSError as exc:  # unreachable, refused, timed out
            raise PincalError(f"cannot reach the Dask scheduler at '{args.scheduler}': {exc}") from None
        with client:
            results = calibrate_fleet(jobs, executor=client.get_executor())
    else:
        results = calibrate_fleet(jobs, workers=args.workers)
    print(f"{'robot':<24}{'held out before':>16}{'held out after':>16}{'fitted':>8}{'dropped':>9}"
          f"{'down-weighted':>15}  status")
    for r in results:
        if r.report is None:
            print(f"{r.name:<24}{'-':>16}{'-':>16}{'-':>8}{'-':>9}{'-':>15}  failed: {r.error}")
            continue
        report = r.report
        print(f"{r.name:<24}{_mm(report.get('test_rms_before')):>16}{_mm(report.get('test_rms_after')):>16}"
              f"{report['n_samples']:>8}{len(report['dropped_samples']):>9}{len(report['down_weighted']):>15}  "
              f"{_verdict(report)}")
    print(f"wrote {args.out}/ (one calibrated URDF and one report JSON per robot; the JSON names every dropped "
          "and down-weighted sample)")
    return 0 if all(r.report is not None and usable(r.report) for r in results) else 1


def _verdict(report: dict[str, Any]) -> str:
    """One robot's outcome in a word or two: what the summary's first line would say."""
    if not report["converged"]:
        return f"NOT CONVERGED ({report['message']})"
    if report.get("worse_than_nominal"):
        return "WORSE THAN NOMINAL"
    if (report.get("sigma2") or 0.0) > NOISE_CONTRADICTED:
        return f"converged; residuals {report['sigma2'] ** 0.5:.3g} × σ"
    return "converged"


class _Parser(argparse.ArgumentParser):
    """argparse with pincal's error form: one line, ``pincal: error: ...``, exit 2 (no usage block)."""

    def error(self, message: str) -> NoReturn:
        command = self.prog.removeprefix("pincal").strip()
        where = f"{command}: " if command else ""
        self.exit(EXIT_ERROR, f"pincal: error: {where}{message} (see '{self.prog} --help')\n")


def build_parser() -> argparse.ArgumentParser:
    """The ``pincal`` argument parser, with every subcommand."""
    parser = _Parser(
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
    sim.add_argument("--noise", type=non_negative_float, default=1e-5,
                     help="σ of the measurement noise [m, rad] (default 1e-5)")
    sim.add_argument("--seed", type=non_negative_int, default=0, help="random seed")
    add_spread(sim)
    add_parameters(sim, "parameters with errors: named sets (default, model24, model24i, hexapod42, "
                        "hexapod44) and name patterns, as for calibrate (default: the default set)")
    add_payload(sim, "truth.corrections.json records it")
    sim.add_argument("--out", required=True, help="output directory")
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
    add_parameters(cal)
    add_solver_and_loss(cal)
    cal.add_argument("--sigma", type=positive_float,
                        help="one measurement σ [m, rad] for weighting every channel, over the file's '# sigma' "
                             "lines (default: those lines, else 1e-5; 1e-6 m for distances)")
    cal.add_argument("--max-iter", type=positive_int, default=100,
                     help="iteration limit of the solver (default 100); a run that reaches it exits 1")
    add_selection_and_cv(cal)
    add_markers(cal)
    add_payload(cal, "the corrections file and the report record it (overrides a job file's payload)")
    cal.add_argument("--formulation", choices=["fkm", "ikm"], default="fkm",
                     help="fkm: measured - predicted by forward kinematics; ikm: implicit loop residuals with the "
                          "measured pose held fixed (study 000; closed-loop robots)")
    # None: not given on the command line, so that a job file's value stands (calibrate()'s default otherwise)
    cal.set_defaults(func=cmd_calibrate, solver=None, loss=None, select=None, max_iter=None, formulation=None)

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
                           description="One calibration per *.csv in DATA_DIR on the same nominal robot, in a "
                                       "process pool (or on a Dask cluster with --scheduler).",
                           epilog="example: pincal fleet delta measurements/ --out calibrated/ --workers 2")
    add_robot(fleet, "the nominal model")
    fleet.add_argument("data_dir", help="directory of measurement CSV files, one per robot")
    fleet.add_argument("--out", required=True, help="output directory")
    add_parameters(fleet)
    fleet.add_argument("--formulation", choices=["fkm", "ikm"], default="fkm")
    fleet.add_argument("--workers", type=positive_int, help="processes (default: the machine's cores)")
    fleet.add_argument("--scheduler", help="address of a Dask scheduler (pip install 'pincal[dask]')")
    fleet.set_defaults(func=cmd_fleet)

    for module in (view, report, study):  # command groups of their own
        module.register(sub)
    return parser


def main(argv: Sequence[str] | None = None) -> int:
    """Entry point of the ``pincal`` console script; returns the exit code."""
    parser = build_parser()
    args = parser.parse_args(argv)
    try:
        load_plugins()  # the user's kinds (PINCAL_PLUGINS), before any command reads a key or a file
        return int(args.func(args))
    except PincalError as exc:
        if args.debug:
            raise
        print(f"pincal: error: {exc}", file=sys.stderr)
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
        if args.debug:
            raise
        print(f"pincal: internal error: {type(exc).__name__}: {exc} (a bug in pincal: run again with --debug and "
              "report the traceback)", file=sys.stderr)
        return EXIT_BUG


if __name__ == "__main__":
    sys.exit(main())
