"""The planning commands: ``pincal design`` (which postures to measure) and ``pincal montecarlo`` (how well a
calibration campaign recovers the geometry, over random seeds and noise levels).

``design`` draws random reachable candidate postures, stacks each one's rows of the identification
Jacobian (:func:`pincal.study.pose_selection.jacobian_blocks`), chooses the requested number by condition number or
D-optimality (:func:`pincal.study.pose_selection.select_poses`) and compares the choice with random sets of the same
size; the chosen actuated values go to a CSV a user can drive the robot to. ``montecarlo`` repeats
:class:`pincal.calibration.trial.SimulatedCalibration` over seeds and noise levels in a process pool and prints
one row per noise level. SI units throughout: m, rad.
"""

from __future__ import annotations

import argparse
import sys
import textwrap
import time
from pathlib import Path
from typing import TYPE_CHECKING

from pincal.calibration.options import OPTIONS
from pincal.cli.arguments import (
    add_measurement,
    add_parameters,
    add_perturb,
    add_robot,
    add_spread,
    non_negative_float,
    non_negative_int,
    positive_int,
)
from pincal.errors import DataError, listing
from pincal.identification.choices import SOLVERS
from pincal.study.criteria import CRITERIA

if TYPE_CHECKING:  # the work's modules load when a command runs, not to parse its arguments
    from pincal.study.montecarlo import MonteCarloResult

#: The most trials ``pincal montecarlo`` runs per noise level.
MAX_TRIALS = 10_000


# --- design --------------------------------------------------------------------------------------

def cmd_design(args: argparse.Namespace) -> int:
    """``pincal design``: choose ``--poses`` of ``--candidates`` random postures by the conditioning of the scaled
    identification Jacobian, compare with random sets, and print or write their actuated values [rad or m]."""
    import numpy as np

    from pincal.calibration.design import RANDOM_SETS, design_poses
    from pincal.io.dataset import Dataset, write_dataset
    from pincal.io.files import check_outputs
    from pincal.model.robot import joint_unit, load_robot

    robot = load_robot(args.robot)
    if args.out:
        check_outputs([("--out", args.out)], [robot.source] if robot.source else [])
    design = design_poses(robot, args.measure, args.frame, args.parameters, args.candidates, args.poses,
                          args.criterion, args.seed, args.spread, progress=not args.quiet)
    selection, pset, qa, keys = design.selection, design.parameters, design.candidates, design.keys
    kappa_random, logdet_random = design.kappa_random, design.logdet_random
    from pincal.calibration.summary import robot_named, urdf_name_note

    named = f"'{robot_named(args.robot, robot.name)}'{urdf_name_note(args.robot, robot.name)}"
    print(f"design for {named}: {args.poses} of {args.candidates} random reachable postures "
          f"(seed {args.seed}), measuring {keys}, by {args.criterion}")
    off = design.off_nominal
    print(f"parameters: {len(pset)}; designed for the {len(selection.columns)} the candidates can identify"
          + (" at the nominal geometry" if off else ""))
    if off is not None:
        hidden = off.identifiable - len(selection.columns)
        cause = (f"exactly parallel joint axes ({'; '.join(', '.join(run) for run in off.parallel_axes)}) hide"
                 if off.parallel_axes else "exact geometry (axes exactly parallel, perpendicular or meeting) hides")
        print(textwrap.fill(
            f"{off.identifiable} on the robot off it (every parameter off by σ {off.sigma:g} m or rad, as a real "
            f"robot is): the nominal's {cause} {hidden} direction{'s' if hidden > 1 else ''} that a robot slightly "
            "off shows weakly, and which pincal calibrate, counting at its estimate, can count; no postures can be "
            "chosen for them on the nominal", width=118, initial_indent="  ", subsequent_indent="  "))
    if selection.dropped:
        print(f"  left out, not separable from the others at any candidate ({len(selection.dropped)}): "
              f"{listing(selection.dropped, 8)}")
    finite = np.isfinite([selection.condition_number, kappa_random]).all()
    print(f"{'scaled identification Jacobian':40}{'chosen':>12}{'random (median)':>18}")
    print(f"{'condition number κ (lower is better)':40}{selection.condition_number:>12.4g}{kappa_random:>18.4g}"
          + (f"   {kappa_random / selection.condition_number:.1f}× lower" if finite else ""))
    print(f"{'log det(JᵀJ) (higher is better)':40}{selection.log_det:>12.4g}{logdet_random:>18.4g}")
    print(f"  (random: median over {RANDOM_SETS} random sets of {args.poses} of the same candidates)")
    chosen = qa[selection.indices]
    units = [joint_unit(robot, j) for j in robot.actuated_joints]
    if args.out:
        from pincal.calibration.provenance import sha256, version

        out = Path(args.out)
        write_dataset(Dataset(list(robot.actuated_joints), chosen, {}, [str(k) for k in range(len(chosen))],
                              ["train"] * len(chosen),
                              {"robot": robot.name, "pincal": version(),
                               **({"robot sha256": sha256(robot.source)} if robot.source is not None else {}),
                               "parameters": " ".join(args.parameters or ["default"]),
                               "units": "SI (m, rad)", "design": args.criterion,
                               "condition number": f"{selection.condition_number:.6g}",
                               "candidates": str(args.candidates), "seed": str(args.seed),
                               "measure": keys, **({"spread": repr(args.spread)} if args.spread is not None else {})}),
                      out)
        print(f"wrote {out}: {len(chosen)} postures (in measuring order) × {len(units)} actuated joints "
              f"({', '.join(f'{j} [{u}]' for j, u in zip(robot.actuated_joints, units, strict=True))})")
    else:
        print("chosen postures, in measuring order (actuated values):")
        print("  " + "".join(f"{f'{j} [{u}]':>22}" for j, u in zip(robot.actuated_joints, units, strict=True)))
        for row in chosen:
            print("  " + "".join(f"{v:>22.9f}" for v in row))
    return 0


# --- Monte Carlo ---------------------------------------------------------------------------------
#: The table's metrics: name, heading, factor to the printed unit, format.
TABLE = (("rms_before", "RMS before [mm]", 1e3, "{:.4f}"), ("rms_after", "RMS after [mm]", 1e3, "{:.4f}"),
         ("gain", "G [%]", 1.0, "{:.1f}"), ("iterations", "iterations", 1.0, "{:.0f}"))


def monte_carlo_table(result: MonteCarloResult) -> str:
    """One row per noise level: median [min, max] over the trials of the held-out RMS errors before and
    after calibration, the calibration gain G and the solver's iterations, and how many converged."""
    import numpy as np

    headings = [heading for _, heading, _, _ in TABLE]
    lines = [f"{'noise σ [m, rad]':>16}" + "".join(f"  {h:>23}" for h in headings) + f"{'converged':>11}"]
    for level in result.levels:
        cells = []
        for name, _, factor, fmt in TABLE:
            s = result.summary(name, level)
            if not s.n:
                cells.append("-")
                continue
            cells.append(f"{fmt.format(s.median * factor)} [{fmt.format(s.minimum * factor)}, "
                         f"{fmt.format(s.maximum * factor)}]")
        converged = result.values("converged", level)
        lines.append(f"{level:>16g}" + "".join(f"  {c:>23}" for c in cells)
                     + f"{f'{int(np.nansum(converged))}/{converged.size}':>11}")
    return "\n".join(lines)


def cmd_montecarlo(args: argparse.Namespace) -> int:
    """``pincal montecarlo``: repeat a simulated calibration over seeds and noise levels [m, rad] and print the
    table of held-out RMS errors, calibration gains and iterations."""
    import numpy as np

    from pincal.calibration.trial import monte_carlo_trial
    from pincal.io.dataset import MAX_SAMPLES
    from pincal.model.robot import load_robot
    from pincal.study.montecarlo import run_monte_carlo

    robot = load_robot(args.robot)  # fails here, once, on a bad name rather than in every worker
    if args.trials < 1:
        raise DataError(f"--trials must be at least 1, not {args.trials}")
    if args.trials > MAX_TRIALS:
        raise DataError(f"--trials {args.trials}: pincal runs at most {MAX_TRIALS} trials per noise level (a "
                        "median over a few hundred is already stable)")
    if max(args.samples, args.test_samples) > MAX_SAMPLES:
        raise DataError(f"--samples {args.samples}, --test-samples {args.test_samples}: pincal simulates at most "
                        f"{MAX_SAMPLES} postures of each")
    if args.samples < 1 or args.test_samples < 1:
        raise DataError(f"--samples and --test-samples must be at least 1 (got {args.samples}, "
                        f"{args.test_samples}): the table compares held-out errors")
    if args.workers is not None and args.workers < 1:
        raise DataError(f"--workers must be at least 1, not {args.workers}")
    if any(not np.isfinite(v) or v < 0 for v in args.noise) or not args.perturb >= 0:
        raise DataError("--noise and --perturb must be non-negative σ values [m, rad]")
    source = str(Path(args.robot).resolve()) if Path(args.robot).is_file() else args.robot
    trial, n_parameters = monte_carlo_trial(robot, source, args.measure, args.frame, args.parameters, args.samples,
                                            args.test_samples, args.perturb, args.solver, args.spread)
    seeds = list(range(args.seed, args.seed + args.trials))
    start = time.perf_counter()
    result = run_monte_carlo(trial, seeds, list(args.noise), executor=None if args.workers == 1 else "process",
                             max_workers=args.workers, progress=not args.quiet)
    from pincal.calibration.summary import robot_named, urdf_name_note

    named = f"'{robot_named(args.robot, robot.name)}'{urdf_name_note(args.robot, robot.name)}"
    print(f"Monte Carlo on {named}: {args.trials} trials (seeds {seeds[0]}..{seeds[-1]}) per noise level; "
          f"true errors σ {args.perturb:g} (m, rad) on {n_parameters} parameters")
    print(f"measuring {', '.join(trial.measurements)}; {args.samples} postures to calibrate, "
          f"{args.test_samples} held out")
    print("cells: median [min, max] over the trials. RMS: held-out length errors. G: calibration gain of study 000 "
          "Eq. 4.1 over all parameters (capped when some cannot be identified)")
    print(monte_carlo_table(result))
    if not args.quiet:
        print(f"{len(result.records)} calibrations in {time.perf_counter() - start:.1f} s", file=sys.stderr)
    return 0


# --- command line --------------------------------------------------------------------------------
def register(sub: argparse._SubParsersAction[argparse.ArgumentParser]) -> None:
    """Add the ``design`` and ``montecarlo`` commands."""
    design = sub.add_parser(
        "design", help="choose the postures to measure: best conditioned among random candidates",
        description="Draw N random reachable postures, linearise the calibration at each, and choose K of them "
                    "minimising the condition number of the scaled identification Jacobian (or maximising "
                    "log det, d-optimal). Prints κ of the choice against random sets of K and writes the chosen "
                    "actuated values (SI: rad, m) as a CSV to drive the robot to; add the measurement columns "
                    "once measured and calibrate from it.",
        epilog="example: pincal design delta --candidates 300 --poses 12 --measure position --parameters model24 "
               "--out poses.csv")
    add_robot(design)
    design.add_argument("--candidates", type=positive_int, default=300, help="random candidate postures (default 300)")
    design.add_argument("--poses", type=positive_int, required=True, help="postures to choose")
    add_measurement(design)
    add_parameters(design)
    design.add_argument("--criterion", choices=CRITERIA, default="condition",
                        help="condition: minimise κ (default); d-optimal: maximise log det(JᵀJ)")
    design.add_argument("--seed", type=non_negative_int, default=0, help="random seed of the candidates")
    add_spread(design)
    design.add_argument("--out", metavar="CSV",
                        help="CSV of the chosen actuated values [rad or m] (default: print them)")
    design.add_argument("--quiet", action="store_true", help="no progress bars")
    design.set_defaults(func=cmd_design)

    mc = sub.add_parser(
        "montecarlo", help="repeat a simulated calibration over seeds and noise levels; table of results",
        description="For each noise level and each of T seeds: draw true errors (σ --perturb), random postures "
                    "and noisy measurements (σ = the level), calibrate, and measure the held-out errors. Prints "
                    "per noise level the median and range of the held-out RMS error before and after, of the "
                    "calibration gain G and of the iterations. Trials run in a process pool (--workers 1: "
                    "serially); the table depends only on the seed. Units: m, rad.",
        epilog="example: pincal montecarlo delta --trials 20 --samples 60 --measure position --parameters model24 "
               "--perturb 1e-3 --noise 1e-5 1e-4 --workers 4")
    add_robot(mc)
    mc.add_argument("--trials", type=positive_int, default=10, help="seeds per noise level (default 10)")
    mc.add_argument("--samples", type=positive_int, default=60, help="postures to calibrate from (default 60)")
    mc.add_argument("--test-samples", type=non_negative_int, default=20,
                    help="held-out postures per trial (default 20)")
    add_measurement(mc)
    add_perturb(mc)
    mc.add_argument("--noise", type=non_negative_float, nargs="+", default=[1e-5],
                    help="measurement noise σ levels [m, rad] (default 1e-5)")
    add_parameters(mc)
    mc.add_argument("--solver", choices=list(SOLVERS), default="lm", help=OPTIONS["solver"].help)
    mc.add_argument("--workers", type=positive_int, help="processes (default: the machine's cores; 1: serial)")
    mc.add_argument("--seed", type=non_negative_int, default=0, help="first seed (trials use seed, seed+1, ...)")
    add_spread(mc)
    mc.add_argument("--quiet", action="store_true", help="no progress bar or timing")
    mc.set_defaults(func=cmd_montecarlo)
