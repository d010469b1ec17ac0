"""Monte Carlo studies: reproducible for fixed seeds, the same through a process pool as serially."""

from __future__ import annotations

import math
from concurrent.futures import ProcessPoolExecutor

import numpy as np
import pytest

from pincal.calibration.trial import SimulatedCalibration
from pincal.errors import DataError
from pincal.study.montecarlo import run_monte_carlo

FIVE_BAR = SimulatedCalibration("five_bar", ("distance_increment:base_link-end_effector",), ("*.offset",),
                                n_train=10, n_test=5, joint_noise=1.0)


def noisy_mean(seed: int, level: float) -> dict[str, float]:
    """A trivial trial: statistics of a few normal draws of σ = level (NaN-free unless level < 0)."""
    draws = np.random.default_rng(seed).normal(scale=level, size=8)
    out = {"mean": float(draws.mean()), "spread": float(draws.std())}
    if level > 1.0:
        out["rare"] = 1.0
    return out


def test_records_and_summaries() -> None:
    result = run_monte_carlo(noisy_mean, [3, 1, 2], [0.5, 2.0], executor=None)
    assert [(r.level, r.seed) for r in result.records] == [(0.5, 3), (0.5, 1), (0.5, 2), (2.0, 3), (2.0, 1), (2.0, 2)]
    assert result.metrics == ["mean", "spread", "rare"]
    spread = result.values("spread", 2.0)
    s = result.summary("spread", 2.0)
    assert s.n == 3 and s.mean == pytest.approx(spread.mean()) and s.std == pytest.approx(spread.std(ddof=1))
    assert (s.minimum, s.maximum, s.median) == (spread.min(), spread.max(), pytest.approx(np.median(spread)))
    # a metric a level's trials do not report is NaN there, and counted
    rare = result.summary("rare", 0.5)
    assert rare.n == 0 and rare.n_nan == 3 and math.isnan(rare.mean)
    table = result.table(["spread"], level_label=lambda v: f"σ = {v}")
    assert table.splitlines()[0] == "| level | spread |" and "| σ = 2.0 | " in table


def test_simulated_calibration_is_deterministic_and_executor_independent() -> None:
    seeds, levels = [0, 1], [0.0, 1e-6]
    serial = run_monte_carlo(FIVE_BAR, seeds, levels, executor=None)
    again = run_monte_carlo(FIVE_BAR, seeds, levels, executor=None)
    with ProcessPoolExecutor(max_workers=2) as pool:
        pooled = run_monte_carlo(FIVE_BAR, seeds, levels, executor=pool)
    default = run_monte_carlo(FIVE_BAR, seeds[:1], levels[:1], max_workers=2)  # a process pool of its own
    metrics = [r.metrics for r in serial.records]
    assert metrics == [r.metrics for r in again.records]
    assert metrics == [r.metrics for r in pooled.records]
    assert default.records[0].metrics == metrics[0]
    # noise-free: the zero offsets come back exactly (G = 100 %); with noise, close to it
    for rec in serial.records:
        assert rec.metrics["converged"] == 1.0 and rec.metrics["rank"] == 2.0
        assert rec.metrics["gain"] > (99.999 if rec.level == 0.0 else 50.0)
        assert rec.metrics["rms_after"] < rec.metrics["rms_before"]
    assert serial.summary("gain", 0.0).minimum > 99.999


def test_bad_arguments_raise_data_errors() -> None:
    with pytest.raises(DataError, match="at least one seed"):
        run_monte_carlo(noisy_mean, [], [1.0])
    with pytest.raises(DataError, match="executor must be"):
        run_monte_carlo(noisy_mean, [0], [1.0], executor="threads")
