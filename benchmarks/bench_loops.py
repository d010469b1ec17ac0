"""Closed loops batched across samples against sample by sample: the Delta of study 000 (issue 14, item 1).

Run: ``python benchmarks/bench_loops.py`` (``--quick``: fewer repeats, no per-sample fit at N = 6000). Single-threaded
BLAS; process CPU time; both paths measured side by side in one process, interleaved (a loaded machine slows both
alike). "Per sample" is the same problem with the batched path switched off (``_batched_loops = False``, internal):
what every closed-loop robot ran before. Printed, as Markdown tables:

1. calibration: Delta, Model 24 errors of 1 mm / 1 mrad, 60 laser-tracker positions with 10 µm noise, ``identify``
   with default settings, the problem built anew each time (as ``bench_calibration.py``): median and best of the
   repeats, and the largest gap between the two paths' estimates;
2. warm forward kinematics at N = 1000: each sample solved from its own configuration at inputs moved by ~1 mrad
   (the calibration loop's situation), ``Robot.solve_fk_batch`` against ``Robot.solve_fk`` in a loop [µs/sample];
3. scaling: the same fit at N = 60, 600, 6000: iterations, evaluations, CPU time (median of 3 fits up to N = 600),
   CPU time per sample and iteration and per sample and evaluation (the figures the issue wants constant within 1.5×)
   and the peak of Python-allocated memory during the fit (``tracemalloc``, in a separate run: tracing slows Python),
   in MB and in copies of J (3N × 24 × 8 bytes).
"""

from __future__ import annotations

import os

for _var in ("OPENBLAS_NUM_THREADS", "OMP_NUM_THREADS", "MKL_NUM_THREADS"):
    os.environ.setdefault(_var, "1")

import argparse  # noqa: E402
import platform  # noqa: E402
import statistics  # noqa: E402
import time  # noqa: E402
import tracemalloc  # noqa: E402
from collections.abc import Callable  # noqa: E402

import numpy as np  # noqa: E402
import pinocchio as pin  # noqa: E402

import pincal  # noqa: E402
from pincal.calibration.campaign import simulate  # noqa: E402
from pincal.identification.measurements import Measurement  # noqa: E402
from pincal.identification.parameters import ParameterSet, choose_parameters  # noqa: E402
from pincal.identification.problem import CalibrationProblem, Observations  # noqa: E402
from pincal.identification.result import CalibrationResult  # noqa: E402
from pincal.identification.solver import identify  # noqa: E402
from pincal.io.adapters import measurements_for, observations_from  # noqa: E402

PATHS = ("batched", "per sample")


def delta_data(n: int, seed: int = 1) -> tuple[pincal.Robot, ParameterSet, list[Measurement], Observations]:
    """The Delta of ``bench_calibration.py``: Model 24 errors of 1 mm / 1 mrad, n positions with 10 µm noise."""
    robot = pincal.load_robot("delta")
    sim = simulate(robot, ["position"], n, 0, perturb=1e-3, noise=1e-5, seed=seed, parameter_spec=["model24"])
    ds = sim.dataset
    models = measurements_for(robot, list(ds.measurements), ds.joint_names, None)
    pset = choose_parameters(robot, models, ["model24"])
    return robot, pset, models, observations_from(robot, ds.joint_names, ds.joints, ds.measurements, models)


def fit(data: tuple[pincal.Robot, ParameterSet, list[Measurement], Observations], batched: bool
        ) -> tuple[float, CalibrationResult]:
    """One ``identify`` with the problem built anew: (CPU seconds, result)."""
    start = time.process_time()
    problem = CalibrationProblem(*data)
    problem._batched_loops = batched and problem._batched_loops
    result = identify(problem)
    return time.process_time() - start, result


def interleaved(runs: dict[str, Callable[[], float]], repeats: int) -> dict[str, list[float]]:
    """Each callable's timings [s], the callables taking turns."""
    out: dict[str, list[float]] = {name: [] for name in runs}
    for _ in range(repeats):
        for name, run in runs.items():
            out[name].append(run())
    return out


def calibration(repeats: int) -> None:
    data = delta_data(60)
    results: dict[str, CalibrationResult] = {}

    def timed(batched: bool) -> Callable[[], float]:
        def run() -> float:
            seconds, results[PATHS[not batched]] = fit(data, batched)
            return seconds
        return run

    times = interleaved({PATHS[0]: timed(True), PATHS[1]: timed(False)}, repeats)
    gap = float(np.abs(results[PATHS[0]].x - results[PATHS[1]].x).max())
    print(f"### Delta, Model 24, 60 positions: calibration ({repeats} runs each, interleaved)\n")
    print("| path | median | best | LM iterations | evaluations |")
    print("|---|---|---|---|---|")
    for name in PATHS:
        r = results[name]
        print(f"| {name} | {statistics.median(times[name]) * 1e3:.1f} ms | {min(times[name]) * 1e3:.1f} ms | "
              f"{r.iterations} | {r.extra.get('evaluations', '?')} |")
    ratio = statistics.median(times[PATHS[1]]) / statistics.median(times[PATHS[0]])
    print(f"\nper sample / batched (medians): {ratio:.2f}×; largest gap between the estimates: {gap:.1e} "
          "(m, rad)\n")


def warm_fk(n: int, repeats: int) -> None:
    robot = pincal.load_robot("delta")
    rng = np.random.default_rng(0)
    qa = rng.uniform(-0.5, 0.5, (n, robot.n_actuated))
    q = robot.solve_fk_batch(qa)
    moved = qa + rng.normal(scale=1e-3, size=qa.shape)

    def batched() -> float:
        start = time.process_time()
        robot.solve_fk_batch(moved, q)
        return time.process_time() - start

    def per_sample() -> float:
        start = time.process_time()
        for a, g in zip(moved, q, strict=True):
            robot.solve_fk(a, g)
        return time.process_time() - start

    gap = float(np.abs(robot.solve_fk_batch(moved, q)
                       - np.array([robot.solve_fk(a, g) for a, g in zip(moved, q, strict=True)])).max())
    times = interleaved({PATHS[0]: batched, PATHS[1]: per_sample}, repeats)
    print(f"### Delta, warm forward kinematics, N = {n} ({repeats} runs each, interleaved)\n")
    print("| path | median [µs/sample] | best [µs/sample] |")
    print("|---|---|---|")
    for name in PATHS:
        print(f"| {name} | {statistics.median(times[name]) / n * 1e6:.1f} | {min(times[name]) / n * 1e6:.1f} |")
    ratio = statistics.median(times[PATHS[1]]) / statistics.median(times[PATHS[0]])
    print(f"\nper sample / batched (medians): {ratio:.1f}×; largest gap between the configurations: {gap:.1e} "
          "(rad, m)\n")


def scaling(sizes: list[int], per_sample_max: int) -> None:
    print("### Delta, Model 24: fits per N (CPU time, median of 3 up to N = 600; peak in a separate traced run)\n")
    print("| N | path | iterations | evaluations | CPU time | µs per sample and iteration | "
          "µs per sample and evaluation | peak memory | peak / J |")
    print("|---|---|---|---|---|---|---|---|---|")
    for n in sizes:
        data = delta_data(n)
        for batched in (True, False):
            if not batched and n > per_sample_max:
                continue
            fit(data, batched)  # warm the caches (imports, the batched kinematics' structure)
            runs = [fit(data, batched) for _ in range(3 if n <= 600 else 1)]
            seconds, result = statistics.median(t for t, _ in runs), runs[0][1]
            tracemalloc.start()
            fit(data, batched)
            peak = tracemalloc.get_traced_memory()[1]
            tracemalloc.stop()
            evaluations = int(result.extra["evaluations"])
            jacobian = 3 * n * len(data[1]) * 8
            print(f"| {n} | {PATHS[not batched]} | {result.iterations} | {evaluations} | {seconds:.3f} s | "
                  f"{1e6 * seconds / (n * max(result.iterations, 1)):.1f} | "
                  f"{1e6 * seconds / (n * evaluations):.1f} | {peak / 1e6:.1f} MB | {peak / jacobian:.1f} |")
    print()


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--quick", action="store_true", help="fewer repeats; no per-sample fit at N = 6000")
    args = parser.parse_args()
    print(f"pincal {pincal.__version__}, pinocchio {pin.__version__}, numpy {np.__version__}, "
          f"Python {platform.python_version()}, {platform.machine()}\n")
    calibration(5 if args.quick else 15)
    warm_fk(1000, 3 if args.quick else 9)
    scaling([60, 600, 6000], 600 if args.quick else 6000)


if __name__ == "__main__":
    main()
