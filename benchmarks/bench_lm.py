"""Levenberg–Marquardt before/after: one identification module against another on the same problems.

Run: ``python benchmarks/bench_lm.py [--before REV] [--repeats 7] [--cases delta60 ur10]``. "before" is
the solver module (``pincal/identification/solver.py``) as committed at git revision REV (default ``HEAD``),
loaded beside the working copy's; REV must be one with the same package layout (the figures in RESULTS.md
were measured before the restructuring, when the module was ``pincal/identification.py``, by this script as
committed then); everything else (problems, FK, analysis) is shared, and the two run interleaved in one process, so
a loaded machine slows both alike. Times are medians of this process's CPU time (single-threaded BLAS, as
``identify`` itself sets), problem construction included as in ``bench_calibration.py``.

Cases (the well-conditioned ones that must not get slower, issue 9):

- ``delta60``: the Delta, Model 24 errors of 1 mm / 1 mrad, 60 tracker positions, 10 µm noise
  (``bench_calibration.py``, ``pincal demo``);
- ``ur10``: the UR10 with a tracker target, known frames, 1000 noisy positions (σ 0.1 mm), every joint's
  placement and offset (``bench_vs_figaroh.py``, known frames, 3D, N = 1000);
- ``ur10u``: the same with the tracker frame and the target unknown (unknown frames, 3D, N = 1000).
"""

from __future__ import annotations

import os

for _var in ("OPENBLAS_NUM_THREADS", "OMP_NUM_THREADS", "MKL_NUM_THREADS"):
    os.environ.setdefault(_var, "1")

import argparse  # noqa: E402
import importlib.util  # noqa: E402
import statistics  # noqa: E402
import subprocess  # noqa: E402
import sys  # noqa: E402
import tempfile  # noqa: E402
import time  # noqa: E402
from collections.abc import Callable  # noqa: E402
from pathlib import Path  # noqa: E402
from types import ModuleType  # noqa: E402
from typing import Any  # noqa: E402

import numpy as np  # noqa: E402

import pincal  # noqa: E402
import pincal.identification.solver  # noqa: E402
from pincal.calibration.campaign import simulate  # noqa: E402
from pincal.identification.measurements import position  # noqa: E402
from pincal.identification.parameters import choose_parameters  # noqa: E402
from pincal.identification.problem import CalibrationProblem, Observations  # noqa: E402
from pincal.io.adapters import measurements_for, observations_from  # noqa: E402

ROOT = Path(__file__).resolve().parents[1]


def module_at(revision: str) -> ModuleType:
    """``pincal/identification/solver.py`` as committed at ``revision``, as a module of its own."""
    text = subprocess.run(["git", "show", f"{revision}:pincal/identification/solver.py"], cwd=ROOT, check=True,
                          capture_output=True, text=True).stdout
    path = Path(tempfile.mkdtemp(prefix="pincal_lm_")) / "identification_before.py"
    path.write_text(text, encoding="utf-8")
    spec = importlib.util.spec_from_file_location("identification_before", path)
    assert spec is not None and spec.loader is not None
    module = importlib.util.module_from_spec(spec)
    sys.modules["identification_before"] = module
    spec.loader.exec_module(module)
    return module


def delta60() -> Callable[[], CalibrationProblem]:
    robot = pincal.load_robot("delta")
    sim = simulate(robot, ["position"], 60, 0, perturb=1e-3, noise=1e-5, seed=1, parameter_spec=["model24"])
    ds = sim.dataset
    models = measurements_for(robot, list(ds.measurements), ds.joint_names, None)
    pset = choose_parameters(robot, models, ["model24"])
    return lambda: CalibrationProblem(robot, pset, models,
                                      observations_from(robot, ds.joint_names, ds.joints, ds.measurements, models))


def ur10(unknown_frames: bool) -> Callable[[], CalibrationProblem]:
    sys.path.insert(0, str(ROOT / "benchmarks"))
    import bench_vs_figaroh as figaroh_bench

    robot = figaroh_bench.ur10_with_target(Path(tempfile.mkdtemp(prefix="pincal_lm_")))
    rng = np.random.default_rng(0)
    truth_set, x_true = figaroh_bench.truth(robot, unknown_frames, False, rng)
    model = position(figaroh_bench.MARKER_LINK, figaroh_bench.SIGMA_POSITION)
    figaroh_bench.simulate(robot, truth_set, x_true, model, figaroh_bench.N_HELD_OUT, rng)  # same draws as there
    train = figaroh_bench.simulate(robot, truth_set, x_true, model, figaroh_bench.N_TRAIN, rng)
    pset = figaroh_bench.estimated_set(robot, unknown_frames, False)
    return lambda: CalibrationProblem(robot, pset, [model], Observations(train.actuated, {model.key: train.noisy}))


CASES: dict[str, Callable[[], Callable[[], CalibrationProblem]]] = {
    "delta60": delta60, "ur10": lambda: ur10(False), "ur10u": lambda: ur10(True)}


def timed(module: ModuleType, make: Callable[[], CalibrationProblem]) -> tuple[float, Any]:
    start = time.process_time()
    result = module.identify(make())
    return time.process_time() - start, result


def main(argv: list[str] | None = None) -> None:
    parser = argparse.ArgumentParser(description=__doc__.split("\n", 1)[0])
    parser.add_argument("--before", default="HEAD", help="git revision of the 'before' identification.py")
    parser.add_argument("--repeats", type=int, default=7)
    parser.add_argument("--cases", nargs="+", default=list(CASES), choices=list(CASES))
    args = parser.parse_args(argv)
    before = module_at(args.before)
    after = pincal.identification.solver
    print("| case | before: iterations, median CPU time | after: iterations, median CPU time | after / before |")
    print("|---|---|---|---|")
    for name in args.cases:
        make = CASES[name]()
        times: dict[str, list[float]] = {"before": [], "after": []}
        results: dict[str, Any] = {}
        for _ in range(args.repeats):  # interleaved: load on the machine hits both alike
            for label, module in (("before", before), ("after", after)):
                seconds, results[label] = timed(module, make)
                times[label].append(seconds)
        b, a = statistics.median(times["before"]), statistics.median(times["after"])
        print(f"| {name} | {results['before'].iterations}, {b * 1e3:.1f} ms (min {min(times['before']) * 1e3:.1f}) "
              f"| {results['after'].iterations}, {a * 1e3:.1f} ms (min {min(times['after']) * 1e3:.1f}) "
              f"| {a / b:.3f} |", flush=True)


if __name__ == "__main__":
    main()
