"""Closed-loop forward kinematics per solve, warm and cold start, beside a bare Pinocchio call.

Run: ``python benchmarks/bench_fk.py`` (add ``--quick`` for a short run). Prints medians of many
timed repetitions, measured side by side in one run, as a Markdown table.

- bare FK: one ``pinocchio.forwardKinematics`` call on the same model (the floor: no loops closed);
- warm start: FK along a straight trajectory of 200 inputs between two reachable ones (steps of a few
  mrad or mm), each solve started from the previous solution (the calibration loop's case: the same
  sample, slightly changed parameters);
- batch warm: the same through ``solve_fk_batch`` with per-sample guesses;
- cold start: FK from the reference configuration to random reachable inputs.
"""

from __future__ import annotations

import argparse
import platform
import statistics
import time
from collections.abc import Callable

import numpy as np
import pinocchio as pin

import pincal


def median_time(fn: Callable[[], object], repeats: int, inner: int) -> float:
    """Median over ``repeats`` of the mean time of ``inner`` calls [s]."""
    samples = []
    for _ in range(repeats):
        start = time.perf_counter()
        for _ in range(inner):
            fn()
        samples.append((time.perf_counter() - start) / inner)
    return statistics.median(samples)


def reachable_inputs(robot: pincal.Robot, n: int, spread: float, seed: int) -> tuple[np.ndarray, np.ndarray]:
    """Random reachable actuated inputs near the reference, with their solved configurations."""
    rng = np.random.default_rng(seed)
    qa, qs = [], []
    while len(qa) < n:
        a = rng.uniform(-spread, spread, robot.n_actuated)
        report = robot.solve_fk_report(a)
        if report.converged:
            qa.append(a)
            qs.append(report.q)
    return np.array(qa), np.array(qs)


SPREAD = {"delta": 0.5, "five_bar": 0.3, "hexapod": 0.1, "hexapod_device": 0.1, "ucr3": 0.05}


def bench_robot(name: str, quick: bool) -> dict[str, float]:
    robot = pincal.load_robot(name)
    repeats, n = (5, 50) if quick else (15, 200)
    qa, qs = reachable_inputs(robot, n, SPREAD.get(name, 0.2), seed=0)
    model, data = robot.model, robot.model.createData()
    q0 = qs[0]
    bare = median_time(lambda: pin.forwardKinematics(model, data, q0), repeats, 1000)

    # a trajectory of n small steps between two reachable inputs, solved warm
    traj = qa[0] + np.outer(np.linspace(0.0, 1.0, n), qa[1] - qa[0])
    guesses = np.empty((n, model.nq))
    q = qs[0]
    for k, a in enumerate(traj):
        guesses[k] = q
        q = robot.solve_fk(a, q)

    def warm() -> None:
        for a, g in zip(traj, guesses, strict=True):
            robot.solve_fk(a, g)

    def batch() -> None:
        robot.solve_fk_batch(traj, guesses)

    def cold() -> None:
        for a in qa:
            robot.solve_fk(a)

    warm_t = median_time(warm, repeats, 1) / n
    batch_t = median_time(batch, repeats, 1) / n
    cold_t = median_time(cold, max(3, repeats // 3), 1) / n
    return {"bare": bare, "warm": warm_t, "batch": batch_t, "cold": cold_t, "nq": model.nq,
            "loops": len(robot.loops)}


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--quick", action="store_true", help="fewer repetitions")
    parser.add_argument("--robots", nargs="*", default=["delta", "five_bar", "ucr3", "hexapod", "hexapod_device"])
    args = parser.parse_args()
    print(f"pincal {pincal.__version__}, pinocchio {pin.__version__}, numpy {np.__version__}, "
          f"Python {platform.python_version()}, {platform.machine()}")
    print()
    print("| robot | nq | loops | bare pin FK [µs] | warm FK [µs] | batch warm FK [µs/sample] | cold FK [µs] "
          "| warm / bare |")
    print("|---|---|---|---|---|---|---|---|")
    for name in args.robots:
        try:
            r = bench_robot(name, args.quick)
        except pincal.NotFoundError:
            continue
        print(f"| {name} | {r['nq']} | {r['loops']} | {r['bare'] * 1e6:.2f} | {r['warm'] * 1e6:.1f} | "
              f"{r['batch'] * 1e6:.1f} | {r['cold'] * 1e6:.1f} | {r['warm'] / r['bare']:.0f}× |")


if __name__ == "__main__":
    main()
