"""One evaluation with Jacobian on a tree, per sample: batched against per-sample, beside the Pinocchio floor.

Run: ``python benchmarks/bench_evaluate.py [--samples 1000] [--repeats 15]``. The problem is the one of
``bench_vs_figaroh.py`` (known frames): example-robot-data's UR10 with a tracker target on the tool, the placements
and offsets of every joint (42 parameters, the issue's case; ``--corrections`` adds their harmonics and compliance,
72), N random postures; the target's position (3D) or with ``--six-d`` its pose. Measured side by side in one
process, interleaved (a loaded machine slows all alike), single-threaded BLAS, the median and the best of the
process's CPU time:

- batched: ``CalibrationProblem.evaluate(x)`` as it runs (a tree: every sample at once, issue 14);
- per sample: the same problem with the batched path switched off (``_batched_trees = False``, internal): the
  per-sample loop that every robot used before and closed loops still use;
- floor: the bare Pinocchio calls the per-sample loop needs, in a Python loop over the samples:
  ``computeJointJacobians`` + ``updateFramePlacements`` + ``getFrameJacobian(LOCAL)``.

The two evaluations are checked to agree (residual and Jacobian to 1e-10 relative; 1e-8 for poses, whose
per-sample rotation rows carry the error of Pinocchio's Jlog3 at small angles) before timing. With
``--identify RUNS``, whole fits (``identify``, the problem built anew each time as in ``bench_lm.py``) too.
"""

from __future__ import annotations

import os

for _var in ("OPENBLAS_NUM_THREADS", "OMP_NUM_THREADS", "MKL_NUM_THREADS"):
    os.environ.setdefault(_var, "1")

import argparse  # noqa: E402
import platform  # noqa: E402
import statistics  # noqa: E402
import sys  # noqa: E402
import tempfile  # noqa: E402
import time  # noqa: E402
from collections.abc import Callable  # noqa: E402
from pathlib import Path  # noqa: E402

import numpy as np  # noqa: E402
import pinocchio as pin  # noqa: E402

import pincal  # noqa: E402
from pincal.identification.measurements import pose, position  # noqa: E402
from pincal.identification.parameters import ParameterSet  # noqa: E402
from pincal.identification.problem import CalibrationProblem, Observations  # noqa: E402
from pincal.identification.solver import identify  # noqa: E402

ROOT = Path(__file__).resolve().parents[1]
sys.path.insert(0, str(ROOT / "benchmarks"))
import bench_vs_figaroh as figaroh_bench  # noqa: E402


def problems(n: int, corrections: bool, six_d: bool = False) -> tuple[CalibrationProblem, CalibrationProblem,
                                                                       np.ndarray]:
    """The batched and the per-sample problem on the same data, and a parameter vector near the truth."""
    robot = figaroh_bench.ur10_with_target(Path(tempfile.mkdtemp(prefix="pincal_eval_")))
    rng = np.random.default_rng(0)
    truth_set, x_true = figaroh_bench.truth(robot, False, six_d, rng)
    model = (pose(figaroh_bench.MARKER_LINK, figaroh_bench.SIGMA_POSITION, figaroh_bench.SIGMA_ANGLE) if six_d
             else position(figaroh_bench.MARKER_LINK, figaroh_bench.SIGMA_POSITION))
    data = figaroh_bench.simulate(robot, truth_set, x_true, model, n, rng)
    pset = figaroh_bench.estimated_set(robot, False, six_d)
    if not corrections:
        pset = ParameterSet([p for p in pset if p.kind in ("joint", "offset")])
    made = [CalibrationProblem(robot, pset, [model], Observations(data.actuated, {model.key: data.noisy}))
            for _ in range(2)]
    made[1]._batched_trees = False
    x = rng.normal(scale=1e-3, size=len(pset))
    return made[0], made[1], x


def floor(problem: CalibrationProblem) -> Callable[[], None]:
    """The bare Pinocchio loop: joint Jacobians, frame placements, the measured frame's local Jacobian."""
    robot = problem.robot
    model, data = robot.model, robot.model.createData()
    frame = robot.frame_id(figaroh_bench.MARKER_LINK)
    q = np.array([robot.solve_fk(a) for a in problem.observations.actuated])

    def run() -> None:
        for qk in q:
            pin.computeJointJacobians(model, data, qk)
            pin.updateFramePlacements(model, data)
            pin.getFrameJacobian(model, data, frame, pin.LOCAL)
    return run


def cpu_time(fn: Callable[[], object]) -> float:
    start = time.process_time()
    fn()
    return time.process_time() - start


def main(argv: list[str] | None = None) -> None:
    parser = argparse.ArgumentParser(description=__doc__.split("\n", 1)[0])
    parser.add_argument("--samples", type=int, default=1000)
    parser.add_argument("--repeats", type=int, default=15)
    parser.add_argument("--corrections", action="store_true", help="estimate the joints' harmonics and compliance too")
    parser.add_argument("--six-d", action="store_true", help="the target's pose instead of its position")
    parser.add_argument("--identify", type=int, default=0, metavar="RUNS",
                        help="also time RUNS whole fits (identify) with each path")
    args = parser.parse_args(argv)
    batched, per_sample, x = problems(args.samples, args.corrections, args.six_d)
    a, b = batched.evaluate(x), per_sample.evaluate(x)
    assert a.jacobian is not None and b.jacobian is not None
    gap = max(float(np.abs(a.residual - b.residual).max() / np.abs(b.residual).max()),
              float(np.abs(a.jacobian - b.jacobian).max() / np.abs(b.jacobian).max()))
    # a pose's rotation rows: Pinocchio's Jlog3 (the per-sample path) loses up to 2e-9 at the residual angles the
    # noise gives (1e-4 to 1e-3 rad, cancellation in 1 − cos θ); the batched path's half-angle form does not
    tolerance = 1e-8 if args.six_d else 1e-10
    assert gap < tolerance, f"batched and per-sample evaluations differ by {gap:.2e} (relative)"
    cases: dict[str, Callable[[], object]] = {"batched": lambda: batched.evaluate(x),
                                              "per sample": lambda: per_sample.evaluate(x),
                                              "floor": floor(per_sample)}
    times: dict[str, list[float]] = {name: [] for name in cases}
    for _ in range(args.repeats):
        for name, fn in cases.items():
            times[name].append(cpu_time(fn))
    per = {name: statistics.median(t) / args.samples * 1e6 for name, t in times.items()}
    best = {name: min(t) / args.samples * 1e6 for name, t in times.items()}
    print(f"pincal {pincal.__version__}, pinocchio {pin.__version__}, numpy {np.__version__}, "
          f"Python {platform.python_version()}, {platform.machine()}; UR10 + target, "
          f"{'pose' if args.six_d else 'position'}, N = {args.samples}, "
          f"{len(batched.parameters)} parameters, {args.repeats} interleaved repeats; agreement {gap:.1e}")
    print()
    print("| evaluation with Jacobian | µs per sample: median | / floor | best | / floor |")
    print("|---|---|---|---|---|")
    for name in cases:
        print(f"| {name} | {per[name]:.2f} | {per[name] / per['floor']:.1f}× | {best[name]:.2f} | "
              f"{best[name] / best['floor']:.1f}× |")
    print()
    print(f"per sample / batched: {per['per sample'] / per['batched']:.1f}× (median), "
          f"{best['per sample'] / best['batched']:.1f}× (best)")
    if args.identify:
        fits: dict[str, list[float]] = {"batched": [], "per sample": []}
        results = {}
        for _ in range(args.identify):
            for name, flag in (("batched", True), ("per sample", False)):
                fresh, _, _ = problems(args.samples, args.corrections, args.six_d)
                fresh._batched_trees = flag
                start = time.process_time()
                results[name] = identify(fresh)
                fits[name].append(time.process_time() - start)
        print()
        print("| identify (whole fit, problem built) | iterations | CPU time: median | best |")
        print("|---|---|---|---|")
        for name, t in fits.items():
            print(f"| {name} | {results[name].iterations} | {statistics.median(t) * 1e3:.0f} ms | "
                  f"{min(t) * 1e3:.0f} ms |")


if __name__ == "__main__":
    main()
