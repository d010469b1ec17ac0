"""Identification time for the Delta of study 000 (issue 3 target: ≤ 0.1 s from 60 samples).

Run: ``python benchmarks/bench_calibration.py``. Simulates 60 laser-tracker postures (Model 24 errors of
1 mm / 1 mrad, 10 µm noise) and times ``identify`` (problem construction included): median of 15 runs, in this
process's CPU time (steady on a shared machine), with the number of model evaluations. To compare two versions of
the package, run this file with ``PYTHONPATH`` on each checkout in turn.
"""

from __future__ import annotations

import statistics
import time

import pincal
from pincal.calibration.campaign import simulate
from pincal.identification.metrics import error_norms, rms
from pincal.identification.parameters import choose_parameters
from pincal.identification.problem import CalibrationProblem
from pincal.identification.solver import identify
from pincal.io.adapters import measurements_for, observations_from


def main() -> None:
    robot = pincal.load_robot("delta")
    for n in (20, 60):
        sim = simulate(robot, ["position"], n, 0, perturb=1e-3, noise=1e-5, seed=1, parameter_spec=["model24"])
        ds = sim.dataset
        models = measurements_for(robot, list(ds.measurements), ds.joint_names, None)
        pset = choose_parameters(robot, models, ["model24"])
        times, result = [], None
        for _ in range(15):
            start = time.process_time()
            problem = CalibrationProblem(robot, pset, models,
                                         observations_from(robot, ds.joint_names, ds.joints, ds.measurements, models))
            result = identify(problem)
            times.append(time.process_time() - start)
        assert result is not None
        print(f"Delta Model 24, {n} samples: median {statistics.median(times) * 1e3:.1f} ms CPU, "
              f"{result.iterations} LM iterations, {result.extra.get('evaluations', '?')} evaluations, "
              f"RMS {rms(error_norms(result.errors_before)) * 1e3:.3f} mm -> "
              f"{rms(error_norms(result.errors_after)) * 1e3:.4f} mm")


if __name__ == "__main__":
    main()
