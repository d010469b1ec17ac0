"""How identification scales with the number of samples: UR10, positions, N = 100 … 100 000 (issue 14, item 3).

Run: ``OPENBLAS_NUM_THREADS=1 python benchmarks/bench_scaling.py`` (``--quick``: N ≤ 10 000). For each N: simulated
positions of ``tool0`` (1 mm / 1 mrad errors on every joint placement and reading offset, 10 µm noise), then one
least-squares ``identify`` from the nominal start, timed in this process's CPU time (the median of 5 fits up to
N = 10 000, one at 100 000). Printed per N: iterations, model evaluations, CPU time, CPU time per sample and iteration
and per sample and evaluation [µs] (the figures the issue wants constant within 1.5×), one evaluation with the
Jacobian on its own (median of 5) and per sample, the peak of Python-allocated memory during a fit (``tracemalloc``, in
a separate, untimed fit: tracing slows Python's allocations several-fold, which at small N is most of the time) in MB
and in copies of the Jacobian J (3N × p × 8 bytes). One small fit runs first, untimed: the process's one-time costs
(imports, BLAS discovery) are not the first size's.
"""

from __future__ import annotations

import sys
import time
import tracemalloc

import numpy as np

import pincal
from pincal.identification.measurements import position
from pincal.identification.parameters import ParameterSet, choose_parameters
from pincal.identification.problem import CalibrationProblem, Observations
from pincal.identification.solver import identify
from pincal.study.simulation import perturbation, random_actuated, simulate_observations


def data(robot: pincal.Robot, pset: ParameterSet, n: int) -> Observations:
    """n simulated positions of tool0 (1 mm / 1 mrad errors, 10 µm noise)."""
    rng = np.random.default_rng(0)
    x_true = perturbation(pset, 1e-3, rng)
    qa, _ = random_actuated(robot, n, rng)
    return simulate_observations(robot, pset, x_true, [position("tool0")], qa, rng, noise=1e-5)


def evaluation_ms(problem: CalibrationProblem, repeats: int = 5) -> float:
    """Median CPU time [ms] of one evaluation with the Jacobian at the nominal start (after one untimed)."""
    x = problem.initial_guess()
    problem.evaluate(x)
    times = []
    for _ in range(repeats):
        start = time.process_time()
        problem.evaluate(x)
        times.append(time.process_time() - start)
    return 1e3 * float(np.median(times))


def main(argv: list[str]) -> None:
    sizes = [100, 1_000, 10_000] if "--quick" in argv else [100, 1_000, 10_000, 100_000]
    robot = pincal.load_robot("ur10")
    models = [position("tool0")]
    pset = choose_parameters(robot, models, [f"{j}.{c}" for j in robot.actuated_joints for c in ("[tr]?", "offset")])
    identify(CalibrationProblem(robot, pset, models, data(robot, pset, 50)), loss="linear")  # one-time costs
    print(f"UR10, {len(pset)} parameters (joint placements and reading offsets), positions of tool0, loss linear")
    print("| N | iterations | evaluations | CPU time | µs per sample and iteration | µs per sample and evaluation | "
          "one evaluation | µs per sample in it | peak memory | peak / J |")
    print("|---|---|---|---|---|---|---|---|---|---|")
    single: list[float] = []
    for n in sizes:
        obs = data(robot, pset, n)
        times, result = [], None
        for _ in range(5 if n <= 10_000 else 1):
            start = time.process_time()
            result = identify(CalibrationProblem(robot, pset, models, obs), loss="linear")
            times.append(time.process_time() - start)
        assert result is not None
        seconds = float(np.median(times))
        tracemalloc.start()
        identify(CalibrationProblem(robot, pset, models, obs), loss="linear")
        peak = tracemalloc.get_traced_memory()[1]
        tracemalloc.stop()
        one = evaluation_ms(CalibrationProblem(robot, pset, models, obs))
        single.append(one)
        evaluations = int(result.extra["evaluations"])
        jacobian = 3 * n * len(pset) * 8
        per_iteration = 1e6 * seconds / (n * max(result.iterations, 1))
        per = 1e6 * seconds / (n * evaluations)
        print(f"| {n} | {result.iterations} | {evaluations} | {seconds:.3f} s | {per_iteration:.1f} | {per:.1f} | "
              f"{one:.2f} ms | {1e3 * one / n:.2f} | {peak / 1e6:.0f} MB | {peak / jacobian:.1f} |")
    # the part of an evaluation that does not grow with N: the smallest N's time beyond the per-sample cost at the next
    fixed = single[0] - sizes[0] * single[1] / sizes[1]
    print(f"\nfixed part of one evaluation ≈ {fixed:.2f} ms (the N = {sizes[0]} evaluation beyond N × the "
          f"per-sample cost at N = {sizes[1]})")


if __name__ == "__main__":
    main(sys.argv[1:])
