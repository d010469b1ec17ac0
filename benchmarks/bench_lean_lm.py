"""Issue 14, items 2 and 3: the lean Levenberg–Marquardt step and the warm-start neighbour search, old against new
in one process, interleaved (a loaded machine slows both alike).

Run: ``python benchmarks/bench_lean_lm.py [--repeats 5] [--delta-sizes 600 6000] [--delta-repeats 3]``.

- *LM*: the step as it was before issue 14 (a reference copy below: the thin SVD of the whole scaled Jacobian,
  its m × n ``U`` kept, every trial point evaluated with its Jacobian) against today's
  (:class:`pincal.identification.steps.Steps`: one QR of ``[J_s | r]`` and the SVD of its n × n triangle, trial
  points without the Jacobian). Per case: the decomposition and three damped steps of one iteration, its peak
  memory (``tracemalloc``) in copies of J, and the whole least-squares fit (same start, same analysis before and
  after, ``loss="linear"``). Cases: the UR10 with a tracker target, known frames, 1000 noisy positions
  (``bench_lm.py``'s ``ur10``), and a synthetic 150 000 × 60 problem,
  ``e(x) = A x + α (A x)² − y`` (one evaluation costs O(mn), so the linear algebra dominates).
- *Neighbour search*: the Delta's first evaluation (Model 24, Jacobian included, every sample a cold start) with
  the scan of every solved sample that ``CalibrationProblem._nearest_solution`` ran before issue 14 (a reference
  copy below) against today's trees (:mod:`pincal.identification.neighbours`), N = 600 and 6000, both sample by
  sample (the batched path closes its first solves by continuation from the reference, with no search:
  ``bench_loops.py``).

Times are medians of this process's CPU time, single-threaded BLAS (as ``identify`` sets).
"""

from __future__ import annotations

import os

for _var in ("OPENBLAS_NUM_THREADS", "OMP_NUM_THREADS", "MKL_NUM_THREADS"):
    os.environ.setdefault(_var, "1")

import argparse  # noqa: E402
import math  # noqa: E402
import statistics  # noqa: E402
import sys  # noqa: E402
import time  # noqa: E402
import tracemalloc  # noqa: E402
import types  # noqa: E402
from collections.abc import Callable  # noqa: E402
from dataclasses import dataclass  # noqa: E402
from pathlib import Path  # noqa: E402
from typing import Any  # noqa: E402

import numpy as np  # noqa: E402
from threadpoolctl import threadpool_limits  # noqa: E402

import pincal  # noqa: E402
from pincal import linalg  # noqa: E402
from pincal.calibration.campaign import simulate  # noqa: E402
from pincal.errors import IdentifiabilityError  # noqa: E402
from pincal.identification import fitting, lm  # noqa: E402
from pincal.identification.evaluation import SolveState  # noqa: E402
from pincal.identification.identifiability import analyse, correlations, covariance  # noqa: E402
from pincal.identification.parameters import choose_parameters  # noqa: E402
from pincal.identification.problem import CalibrationProblem, Prediction  # noqa: E402
from pincal.identification.steps import EXACT_FIT_AMPLIFICATION, Steps, at_floor, evaluated, exact_fit_floors  # noqa: E402
from pincal.io.adapters import measurements_for, observations_from  # noqa: E402
from pincal.model.kinematics import CONTINUATION_STEP  # noqa: E402

sys.path.insert(0, str(Path(__file__).resolve().parent))
import bench_lm  # noqa: E402

Array = np.ndarray


# --- the LM step before issue 14 (reference copy of pincal/identification/lm.py and solver.py at b8a351c) -------
class OldSteps:
    """The SVD of the scaled, weighted Jacobian ``J_s`` at one iterate (thin ``U`` kept), and the steps it gives."""

    def __init__(self, js: Array, rcond: float) -> None:
        u, s, vt = linalg.svd(js, "the scaled identification Jacobian")
        self.largest = float(s[0]) if s.size else 0.0
        keep = s > rcond * self.largest
        self.u, self.s, self.vt = u[:, keep], s[keep], vt[keep]

    @property
    def smallest_damping(self) -> float:
        return float((self.s[-1] / self.largest) ** 2) if self.s.size else 0.0

    @property
    def kept(self) -> int:
        return int(self.s.size)

    def solve(self, r: Array, lam: float) -> Array:
        if not self.s.size:
            return np.zeros(self.vt.shape[1])
        gain = self.s / (self.s**2 + lam * self.largest**2)
        return np.asarray(-(self.vt.T @ ((self.u.T @ r) * gain)), dtype=np.float64)

    def decrement(self, r: Array, information: float = 0.0) -> float:
        chosen = self.s >= information
        return float(np.sum((self.u[:, chosen].T @ r) ** 2))


def old_accelerated(problem: Any, x: Array, d: Array, r: Array, js: Array, v: Array, steps: OldSteps,
                    lam: float) -> Array | None:
    norm_v = float(np.linalg.norm(v))
    ahead = evaluated(problem, x + lm.GEODESIC_H * d * v, jacobian=False)
    if ahead is None:
        return None
    r_vv = (2.0 / lm.GEODESIC_H) * ((ahead.residual - r) / lm.GEODESIC_H - js @ v)
    damping = lam
    while damping < 1.0:
        a = steps.solve(r_vv, damping)
        if 2.0 * float(np.linalg.norm(a)) <= lm.GEODESIC_ALPHA * norm_v:
            return np.asarray(v + 0.5 * a, dtype=np.float64)
        damping *= 10.0
    return v


def old_settled(steps: OldSteps, lam: float, r: Array, cost: float, errors: dict[str, Array],
                numerical: dict[str, Array], rejected: bool) -> bool:
    if lam >= steps.smallest_damping and at_floor(errors, numerical):
        return True
    dof = r.size - steps.kept
    return bool(steps.kept and dof > 0 and (rejected or steps.s[-1] < lm.PRACTICAL_INFORMATION)
                and cost >= 0.25 * dof and steps.decrement(r, lm.PRACTICAL_INFORMATION) <= lm.NOISE_LEVEL_DECREMENT)


def old_fit(problem: Any, max_iter: int = 100, tol: float = 1e-9, rank_tol: float = 1e-8) -> tuple[Array, int]:
    """The least-squares LM fit as ``_fit`` ran it before issue 14 (solver ``lm``, loss ``linear``, defaults): the
    same analysis at the start and the end as today's; the estimate and the iterations."""
    pset = problem.parameters
    d = pset.scales
    x = problem.initial_guess()
    pred = problem.evaluate(x)
    assert np.all(np.isfinite(pred.residual)) and np.all(np.isfinite(pred.jacobian))
    units = [p.unit if p.unit in ("m", "rad") else "" for p in pset]
    analyse(pred.jacobian, pset.names, d, units=units, tol=rank_tol)
    cost = 0.5 * float(np.sum(pred.residual**2))
    numerical = exact_fit_floors(problem, 0.0, EXACT_FIT_AMPLIFICATION)
    lam, accelerate, slow, iterations = 1e-3, False, 0, 0
    for it in range(1, max_iter + 1):
        js = pred.jacobian * d * np.ones(pred.residual.size)[:, None]
        r = pred.residual
        steps = OldSteps(js, rank_tol)
        if it > 1 and old_settled(steps, lam, r, cost, pred.errors, numerical, accelerate):
            break
        iterations = it
        accepted = False
        for _ in range(12):
            dz: Array | None = steps.solve(r, lam)
            if accelerate:
                assert dz is not None
                dz = old_accelerated(problem, x, d, r, js, dz, steps, lam)
            new = evaluated(problem, x + d * dz) if dz is not None else None
            if new is not None:
                new_cost = 0.5 * float(np.sum(new.residual**2))
                if new_cost <= cost:
                    accepted = True
                    break
            lam *= 10.0
            accelerate = True
        if not accepted or new is None or dz is None:
            break
        decrease = cost - new_cost
        step_size = float(np.linalg.norm(dz))
        x, pred, cost = x + d * dz, new, new_cost
        lam = max(lam / 10.0, 1e-20)
        if decrease <= tol * max(cost, 1e-300) or step_size <= tol or cost <= 1e-30:
            break
        noise_level = cost > 0.05 * pred.residual.size
        stationary = decrease <= fitting.STATIONARY * max(cost, 1e-300) or (noise_level and decrease < 1e-2)
        slow = slow + 1 if stationary else 0
        if slow >= 3:
            break
    active = analyse(pred.jacobian, pset.names, d, units=units, tol=rank_tol).base_indices
    try:  # the covariance at the end, as fitting.fit computes it
        correlations(covariance(pred.jacobian[:, active], 1.0, names=[pset.names[k] for k in active]))
    except IdentifiabilityError:
        pass
    return x, iterations


def new_fit(problem: Any) -> tuple[Array, int]:
    result = fitting.fit(problem, loss="linear")
    return result.x, result.iterations


# --- problems --------------------------------------------------------------------------------------------------
@dataclass
class _Parameter:
    name: str
    unit: str = "m"


class _Parameters(list[_Parameter]):
    """The parameter set's surface ``identify`` reads: names, units, typical sizes."""

    @property
    def names(self) -> list[str]:
        return [p.name for p in self]

    @property
    def scales(self) -> Array:
        return np.ones(len(self))


@dataclass
class _Observations:
    n_samples: int


class Synthetic:
    """``e(x) = A x + α (A x)² − y`` (m rows, n parameters, one row per sample): a mildly nonlinear least-squares
    problem whose evaluation costs O(mn), so that the LM linear algebra dominates."""

    def __init__(self, m: int, n: int, alpha: float = 0.05, seed: int = 0) -> None:
        rng = np.random.default_rng(seed)
        self.a = rng.normal(size=(m, n)) / math.sqrt(n)
        self.alpha = alpha
        truth = rng.normal(size=n)
        self.y = self._model(truth) + 1e-3 * rng.normal(size=m)
        self.parameters = _Parameters([_Parameter(f"p{k}") for k in range(n)])
        self.observations = _Observations(m)

    def _model(self, x: Array) -> Array:
        ax = self.a @ x
        return np.asarray(ax + self.alpha * ax**2, dtype=np.float64)

    def evaluate(self, x: Array, jacobian: bool = True) -> Prediction:
        ax = self.a @ x
        e = ax + self.alpha * ax**2 - self.y
        jac = self.a * (1.0 + 2.0 * self.alpha * ax)[:, None] if jacobian else None
        return Prediction(e, jac, {"synthetic": e[:, None]}, {"synthetic": (e + self.y)[:, None]})

    def row_samples(self) -> Array:
        return np.arange(self.observations.n_samples, dtype=np.int64)

    def initial_guess(self) -> Array:
        return np.zeros(len(self.parameters))

    def settle_assembly(self, x: Array) -> list[int]:
        return []


def delta(n: int) -> Callable[[], CalibrationProblem]:
    robot = pincal.load_robot("delta")
    sim = simulate(robot, ["position"], n, 0, perturb=1e-3, noise=1e-5, seed=1, parameter_spec=["model24"])
    ds = sim.dataset
    models = measurements_for(robot, list(ds.measurements), ds.joint_names, None)
    pset = choose_parameters(robot, models, ["model24"])
    return lambda: CalibrationProblem(robot, pset, models,
                                      observations_from(robot, ds.joint_names, ds.joints, ds.measurements, models))


# --- the neighbour search before issue 14 (reference copy of the problem's _nearest_solution at b8a351c) ----
def old_nearest_solution(self: SolveState, robot: Any, qa: Array) -> Array | None:
    if not robot.loops:
        return None
    diff = robot.kinematics.actuated_delta(qa, self.solved_inputs.values)  # continuous joints: the short way round
    gaps = np.max(np.abs(diff), axis=1)  # NaN rows (unsolved) compare False
    k = int(np.nanargmin(gaps)) if np.any(gaps <= CONTINUATION_STEP) else -1
    return None if k < 0 else self.configurations[k]


# --- measurement ------------------------------------------------------------------------------------------------
def cpu(call: Callable[[], Any]) -> tuple[float, Any]:
    start = time.process_time()
    out = call()
    return time.process_time() - start, out


def peak_copies(call: Callable[[], Any], jacobian: Array) -> float:
    """Peak memory ``call`` allocates (tracemalloc), in copies of ``jacobian``."""
    tracemalloc.start()
    try:
        call()
        _, peak = tracemalloc.get_traced_memory()
    finally:
        tracemalloc.stop()
    return peak / jacobian.nbytes


def lm_case(name: str, make: Callable[[], Any], repeats: int) -> None:
    problem = make()
    pred = problem.evaluate(problem.initial_guess())
    jac, d = pred.jacobian, problem.parameters.scales
    rw, e = np.ones(pred.residual.size), pred.residual

    def old_step() -> Array:
        steps = OldSteps(jac * d * rw[:, None], 1e-8)
        return np.array([steps.solve(rw * e, lam) for lam in (1e-3, 1e-2, 1e-1)])

    def new_step() -> Array:
        steps = Steps(jac, d, rw, e, lm.LevenbergMarquardt(1e-8, 0.0))
        return np.array([steps.solve(lam) for lam in (1e-3, 1e-2, 1e-1)])

    step_times: dict[str, list[float]] = {"old": [], "new": []}
    fit_times: dict[str, list[float]] = {"old": [], "new": []}
    out: dict[str, Any] = {}
    for _ in range(repeats):
        for label, step, fit in (("old", old_step, old_fit), ("new", new_step, new_fit)):
            seconds, out[label + "_step"] = cpu(step)
            step_times[label].append(seconds)
            fresh = make()
            seconds, out[label + "_fit"] = cpu(lambda fit=fit, fresh=fresh: fit(fresh))  # type: ignore[misc]
            fit_times[label].append(seconds)
    copies = {"old": peak_copies(old_step, jac), "new": peak_copies(new_step, jac)}
    step_gap = float(np.max(np.abs(out["old_step"] - out["new_step"])))
    fit_gap = float(np.max(np.abs(out["old_fit"][0] - out["new_fit"][0])))
    so, sn = statistics.median(step_times["old"]), statistics.median(step_times["new"])
    fo, fn = statistics.median(fit_times["old"]), statistics.median(fit_times["new"])
    m, n = jac.shape
    print(f"| {name} ({m} × {n}) | step: {so * 1e3:.1f} ms, {copies['old']:.1f} J | {sn * 1e3:.1f} ms, "
          f"{copies['new']:.1f} J | {sn / so:.2f} | fit: {out['old_fit'][1]} it, {fo * 1e3:.0f} ms "
          f"| {out['new_fit'][1]} it, {fn * 1e3:.0f} ms | {fn / fo:.2f} | {step_gap:.1e} / {fit_gap:.1e} |", flush=True)


def delta_case(n: int, repeats: int) -> None:
    make = delta(n)
    times: dict[str, list[float]] = {"old": [], "new": []}
    residuals: dict[str, Array] = {}
    for _ in range(repeats):
        for label in ("old", "new"):
            problem = make()
            problem._batched_loops = False  # the batched path closes its first solves with no neighbour search
            if label == "old":
                problem.solves.nearest = types.MethodType(old_nearest_solution, problem.solves)  # type: ignore[method-assign]
            x0 = np.zeros(len(problem.parameters))
            seconds, pred = cpu(lambda problem=problem, x0=x0: problem.evaluate(x0))  # type: ignore[misc]
            times[label].append(seconds)
            residuals[label] = pred.residual
    same = np.array_equal(residuals["old"], residuals["new"])
    o, w = statistics.median(times["old"]), statistics.median(times["new"])
    print(f"| Delta, N = {n} | {o:.2f} s ({o / n * 1e3:.2f} ms/sample) | {w:.2f} s ({w / n * 1e3:.2f} ms/sample) "
          f"| {w / o:.2f} | {'identical' if same else 'DIFFERENT'} |", flush=True)


def main(argv: list[str] | None = None) -> None:
    parser = argparse.ArgumentParser(description=__doc__.split("\n", 1)[0])
    parser.add_argument("--repeats", type=int, default=5, help="runs of each LM case")
    parser.add_argument("--synthetic-rows", type=int, default=150_000)
    parser.add_argument("--delta-sizes", type=int, nargs="*", default=[600, 6000])
    parser.add_argument("--delta-repeats", type=int, default=3)
    args = parser.parse_args(argv)
    with threadpool_limits(limits=1, user_api="blas"):
        print("| case | old | new | new / old | old | new | new / old | max gap step / fit |")
        print("|---|---|---|---|---|---|---|---|")
        lm_case("UR10, 1000 positions, known frames", bench_lm.ur10(False), args.repeats)
        lm_case("synthetic", lambda: Synthetic(args.synthetic_rows, 60), args.repeats)
        print()
        print("| first evaluation (cold) | old scan | trees | new / old | residuals |")
        print("|---|---|---|---|---|")
        for n in args.delta_sizes:
            delta_case(n, args.delta_repeats)


if __name__ == "__main__":
    main()
