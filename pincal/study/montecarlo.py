"""Monte Carlo studies: repeat a simulated calibration over seeds and noise levels, and summarise.

A *trial* is any picklable callable ``trial(seed, level) -> {metric: value}``; it must draw all its
randomness from ``seed`` so that a study is reproducible. Trials run through any
:class:`concurrent.futures.Executor` (a process pool by default: calibrations are CPU-bound Python),
or one after the other with ``executor=None``; results come back in (level, seed) order whichever way
they ran. :class:`pincal.calibration.trial.SimulatedCalibration` is the trial of ``pincal montecarlo``.
"""

from __future__ import annotations

import math
import time
from collections.abc import Callable, Mapping, Sequence
from concurrent.futures import Executor, Future, ProcessPoolExecutor, as_completed
from dataclasses import field
from typing import Any

import numpy as np
import numpy.typing as npt

from pincal import linalg
from pincal.errors import DataError
from pincal.progress import Progress
from pincal.records import record

Array = npt.NDArray[np.float64]

Trial = Callable[[int, Any], Mapping[str, float]]


@record(frozen=True)
class TrialRecord:
    """One trial: its level, seed, metrics, and wall time [s] (not part of the reproducible result)."""

    level: Any
    seed: int
    metrics: dict[str, float]
    seconds: float


@record(frozen=True)
class Summary:
    """Statistics of one metric at one level over the seeds (NaN values are left out and counted)."""

    mean: float
    std: float
    median: float
    minimum: float
    maximum: float
    n: int
    n_nan: int = 0


@record
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
        return Summary(float(ok.mean()), float(ok.std(ddof=1)) if ok.size > 1 else 0.0, float(linalg.median(ok)),
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
        trial: Picklable callable returning ``{metric: value}`` (a module-level function or a dataclass instance
            such as :class:`pincal.calibration.trial.SimulatedCalibration`, not a lambda, for process pools).
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
