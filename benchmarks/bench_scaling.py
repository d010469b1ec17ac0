"""How identification scales with the number of samples: UR10, positions, N = 100 … 100 000 (issue 14, item 3).

Run: ``OPENBLAS_NUM_THREADS=1 python benchmarks/bench_scaling.py`` (``--quick``: N ≤ 10 000). For each N: simulated
positions of ``tool0`` (1 mm / 1 mrad errors on every joint placement and reading offset, 10 µm noise), then one
least-squares ``identify`` from the nominal start, timed in this process's CPU time. Printed per N: iterations, model
evaluations, CPU time, CPU time per sample and evaluation [µs] (the figure the issue wants constant within 1.5×),
the peak of Python-allocated memory during the fit (``tracemalloc``) in MB and in copies of the Jacobian J
(3N × p × 8 bytes).
"""

from __future__ import annotations

import sys
import time
import tracemalloc

import numpy as np

import pincal
from pincal.identification.measurements import position
from pincal.identification.parameters import choose_parameters
from pincal.identification.problem import CalibrationProblem
from pincal.identification.solver import identify
from pincal.study.simulation import perturbation, random_actuated, simulate_observations


def main(argv: list[str]) -> None:
    sizes = [100, 1_000, 10_000] if "--quick" in argv else [100, 1_000, 10_000, 100_000]
    robot = pincal.load_robot("ur10")
    models = [position("tool0")]
    pset = choose_parameters(robot, models, [f"{j}.{c}" for j in robot.actuated_joints for c in ("[tr]?", "offset")])
    print(f"UR10, {len(pset)} parameters (joint placements and reading offsets), positions of tool0, loss linear")
    print("| N | iterations | evaluations | CPU time | µs per sample and evaluation | peak memory | peak / J |")
    print("|---|---|---|---|---|---|---|")
    for n in sizes:
        rng = np.random.default_rng(0)
        x_true = perturbation(pset, 1e-3, rng)
        qa, _ = random_actuated(robot, n, rng)
        obs = simulate_observations(robot, pset, x_true, models, qa, rng, noise=1e-5)
        tracemalloc.start()
        start = time.process_time()
        result = identify(CalibrationProblem(robot, pset, models, obs), loss="linear")
        seconds = time.process_time() - start
        peak = tracemalloc.get_traced_memory()[1]
        tracemalloc.stop()
        evaluations = int(result.extra["evaluations"])
        jacobian = 3 * n * len(pset) * 8
        per = 1e6 * seconds / (n * evaluations)
        print(f"| {n} | {result.iterations} | {evaluations} | {seconds:.2f} s | {per:.1f} | {peak / 1e6:.0f} MB "
              f"| {peak / jacobian:.1f} |")


if __name__ == "__main__":
    main(sys.argv[1:])
