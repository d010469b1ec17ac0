"""Monte Carlo studies: repeat a simulated calibration over seeds and noise levels, and summarise.

A *trial* is any picklable callable ``trial(seed, level) -> {metric: value}``; it must draw all its
randomness from ``seed`` so that a study is reproducible. Trials run through any
:class:`concurrent.futures.Executor` (a process pool by default: calibrations are CPU-bound Python),
or one after the other with ``executor=None``; results come back in (level, seed) order whichever way
they ran. :class:`SimulatedCalibration` is the ready-made trial: random true errors, random postures,
noisy measurements, identification, and the calibration gain ``G`` (study 000, Eq. 4.1) with the
held-out errors before and after.
"""

from __future__ import annotations

import functools
import math
import time
from collections.abc import Callable, Mapping, Sequence
from concurrent.futures import Executor, Future, ProcessPoolExecutor, as_completed
from dataclasses import dataclass, field
from typing import Any

import numpy as np
import numpy.typing as npt

from pincal.errors import ConvergenceError, DataError
from pincal.identification.choices import Solver
from pincal.identification.measurements import parse_key
from pincal.identification.metrics import calibration_gain, error_norms, rms
from pincal.identification.parameters import choose_parameters
from pincal.identification.problem import CalibrationProblem
from pincal.identification.solver import identify
from pincal.model.robot import Robot, load_robot
from pincal.progress import Progress
from pincal.study.simulation import perturbation, random_actuated, simulate_observations

Array = npt.NDArray[np.float64]

Trial = Callable[[int, Any], Mapping[str, float]]


@dataclass(frozen=True)
class TrialRecord:
    """One trial: its level, seed, metrics, and wall time [s] (not part of the reproducible result)."""

    level: Any
    seed: int
    metrics: dict[str, float]
    seconds: float


@dataclass(frozen=True)
class Summary:
    """Statistics of one metric at one level over the seeds (NaN values are left out and counted)."""

    mean: float
    std: float
    median: float
    minimum: float
    maximum: float
    n: int
    n_nan: int = 0


@dataclass
class MonteCarloResult:
    """All trial records of a study, in (level, seed) order."""

    levels: list[Any]
    seeds: list[int]
    records: list[TrialRecord] = field(default_factory=list)

    @property
    def metrics(self) -> list[str]:
        """The metric names any trial reported, in order of first appearance."""
        names: list[str] = []
        for rec in self.records:
            names += [k for k in rec.metrics if k not in names]
        return names

    def values(self, metric: str, level: Any) -> Array:
        """The metric's values over the seeds at one level (NaN where a trial did not report it)."""
        return np.array([rec.metrics.get(metric, math.nan) for rec in self.records if _same(rec.level, level)])

    def summary(self, metric: str, level: Any) -> Summary:
        """Statistics of the metric at one level over the seeds (NaN values left out and counted)."""
        v = self.values(metric, level)
        ok = v[np.isfinite(v)]
        if not ok.size:
            return Summary(math.nan, math.nan, math.nan, math.nan, math.nan, 0, int(v.size))
        return Summary(float(ok.mean()), float(ok.std(ddof=1)) if ok.size > 1 else 0.0, float(np.median(ok)),
                       float(ok.min()), float(ok.max()), int(ok.size), int(v.size - ok.size))

    def table(self, metrics: Sequence[str] | None = None, level_label: Callable[[Any], str] = repr,
              fmt: str = "{:.4g}") -> str:
        """A Markdown table: one row per level, ``mean ± std`` per metric."""
        names = list(metrics) if metrics is not None else self.metrics
        lines = ["| level | " + " | ".join(names) + " |", "|---|" + "---|" * len(names)]
        for level in self.levels:
            cells = []
            for name in names:
                s = self.summary(name, level)
                cells.append(f"{fmt.format(s.mean)} ± {fmt.format(s.std)}" if s.n else "–")
            lines.append(f"| {level_label(level)} | " + " | ".join(cells) + " |")
        return "\n".join(lines)

    @property
    def seconds(self) -> float:
        """Summed trial time [s] (CPU-side; the wall time is smaller with a pool)."""
        return float(sum(rec.seconds for rec in self.records))


def _same(a: Any, b: Any) -> bool:
    try:
        return bool(a == b)
    except (TypeError, ValueError):  # arrays and the like
        return a is b


def _timed(trial: Trial, seed: int, level: Any) -> tuple[dict[str, float], float]:
    start = time.perf_counter()
    metrics = {str(k): float(v) for k, v in trial(seed, level).items()}
    return metrics, time.perf_counter() - start


def run_monte_carlo(trial: Trial, seeds: Sequence[int], levels: Sequence[Any] = (None,),
                    executor: Executor | str | None = "process", max_workers: int | None = None,
                    progress: bool = False) -> MonteCarloResult:
    """Run ``trial(seed, level)`` for every level and seed.

    Args:
        trial: Picklable callable returning ``{metric: value}`` (a module-level function or a
            dataclass instance such as :class:`SimulatedCalibration`, not a lambda, for process pools).
        seeds: Random seeds, one trial each per level.
        levels: Study levels (noise σ, or any picklable value the trial understands).
        executor: An Executor to submit to (left open), ``"process"`` for a new process pool (closed
            at the end), or None to run serially in this process.
        max_workers: Workers of the pool created for ``"process"``.
        progress: Show a progress bar on stderr (when it is a terminal), one tick per finished trial.

    Returns:
        The records in (level, seed) order; identical whichever executor ran them, for a trial
        whose randomness comes only from its seed.
    """
    seeds = [int(s) for s in seeds]
    levels = list(levels)
    if not seeds or not levels:
        raise DataError("a Monte Carlo study needs at least one seed and one level")
    jobs = [(level, seed) for level in levels for seed in seeds]
    result = MonteCarloResult(levels, seeds)
    if isinstance(executor, str) and executor != "process":
        raise DataError(f"executor must be an Executor, 'process' or None; got '{executor}'")
    with Progress("Monte Carlo trials", len(jobs), quiet=not progress) as bar:
        if executor is None:
            outcomes = []
            for level, seed in jobs:
                outcomes.append(_timed(trial, seed, level))
                bar.advance()
        elif isinstance(executor, str):
            with ProcessPoolExecutor(max_workers=max_workers) as pool:
                outcomes = _submit(pool, trial, jobs, bar)
        else:
            outcomes = _submit(executor, trial, jobs, bar)
    result.records = [TrialRecord(level, seed, metrics, seconds)
                      for (level, seed), (metrics, seconds) in zip(jobs, outcomes, strict=True)]
    return result


def _submit(executor: Executor, trial: Trial, jobs: list[tuple[Any, int]],
            bar: Progress) -> list[tuple[dict[str, float], float]]:
    """The trials' outcomes in ``jobs`` order; the bar ticks as they finish, in whatever order, and the
    first trial to fail raises at once."""
    futures: list[Future[tuple[dict[str, float], float]]] = [executor.submit(_timed, trial, seed, level)
                                                            for level, seed in jobs]
    for done in as_completed(futures):
        done.result()
        bar.advance()
    return [f.result() for f in futures]


# --- the ready-made trial ----------------------------------------------------------------------------
@functools.lru_cache(maxsize=8)
def _robot(name_or_path: str) -> Robot:
    """One Robot per process and name (a Robot owns its Data: never shared between threads)."""
    return load_robot(name_or_path)


@dataclass(frozen=True)
class SimulatedCalibration:
    """A simulated calibration campaign as a Monte Carlo trial; ``level`` is the noise σ [m, rad].

    Each trial draws true errors (σ = ``perturb`` [m, rad]), ``n_train + n_test`` random postures
    and noisy readings from its seed, identifies from the training postures (nominal start) and
    reports:

    - ``gain`` [%]: G of study 000 Eq. 4.1 over all parameters, ``gain_identified`` over the
      identified ones;
    - ``rms_before``, ``rms_after`` [m]: RMS length-type error on the held-out postures;
    - ``parameter_error`` [m, rad]: ``max |x̂ − x_true|`` over the identified parameters;
    - ``rank``, ``condition_number``, ``iterations``, ``converged`` (1/0).

    Attributes:
        robot: Robot name or URDF path.
        measurements: Measurement keys (``position:end_effector``, ``joint:device_lvdt``, ...).
        parameters: Named set or patterns (see :func:`pincal.identification.parameters.choose_parameters`); None: all.
        n_train, n_test: Postures to calibrate from and to validate on.
        perturb: σ of the true parameter errors [m and rad].
        joint_noise: σ of the actuated readings' noise [m or rad] per unit of ``level`` (0: exact).
        solver: ``lm``, ``tsvd`` or ``ridge``.
        spread: Half-range [rad or m] of the random actuated values about the reference, within the URDF limits;
            None: within the URDF limits (:func:`pincal.study.simulation.actuated_ranges`).
    """

    robot: str
    measurements: tuple[str, ...]
    parameters: tuple[str, ...] | None = None
    n_train: int = 30
    n_test: int = 20
    perturb: float = 1e-3
    joint_noise: float = 0.0
    solver: Solver = "lm"
    spread: float | None = None

    def __call__(self, seed: int, level: Any) -> dict[str, float]:
        """Run the trial of ``seed`` at noise σ ``level`` [m, rad]; its metrics (only ``converged`` if it did not)."""
        noise = float(level or 0.0)
        robot = _robot(self.robot)
        rng = np.random.default_rng(seed)
        sigma = max(noise, 1e-7)  # the weights; exact data are weighted as if 0.1 µm
        models = [parse_key(key, sigma) for key in self.measurements]
        pset = choose_parameters(robot, models, list(self.parameters) if self.parameters else None)
        x_true = perturbation(pset, self.perturb, rng)
        qa, _ = random_actuated(robot, self.n_train + self.n_test, rng, spread=self.spread)
        train_qa, test_qa = qa[: self.n_train], qa[self.n_train:]
        train = simulate_observations(robot, pset, x_true, models, train_qa, rng, noise=noise,
                                      joint_noise=noise * self.joint_noise)
        try:
            result = identify(CalibrationProblem(robot, pset, models, train), solver=self.solver)
        except ConvergenceError:
            return {"converged": 0.0}
        metrics = {
            "gain": calibration_gain(x_true, result.x0, result.x),
            "gain_identified": calibration_gain(x_true[result.identified], result.x0[result.identified],
                                                result.x[result.identified]),
            "parameter_error": float(np.max(np.abs(result.x - x_true)[result.identified])),
            "rank": float(result.identifiability.rank),
            "condition_number": float(result.identifiability.condition_number),
            "iterations": float(result.iterations),
            "converged": float(result.converged),
        }
        if self.n_test:
            test = simulate_observations(robot, pset, x_true, models, test_qa, rng)
            problem = CalibrationProblem(robot, pset, models, test)
            # "before" is the fit's start, as in every report (pincal.calibration.heldout)
            metrics["rms_before"] = rms(error_norms(problem.evaluate(result.x0, jacobian=False).errors))
            metrics["rms_after"] = rms(error_norms(problem.evaluate(result.x, jacobian=False).errors))
        return metrics

