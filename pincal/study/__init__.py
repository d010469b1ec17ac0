"""Studies on the model: simulation, pose selection, sensitivity statistics, Monte Carlo, zero offsets.

The names below load on first use (:mod:`pincal.lazy`).
"""

from __future__ import annotations

from typing import TYPE_CHECKING

from pincal.lazy import lazy_names

if TYPE_CHECKING:
    from pincal.study.montecarlo import MonteCarloResult, run_monte_carlo
    from pincal.study.pose_selection import PoseSelection, select_poses
    from pincal.study.simulation import perturbation, random_actuated, simulate_observations
    from pincal.study.workspace_stats import StatisticalSensitivity, statistical_sensitivity
    from pincal.study.zero_offset import ZeroOffsetResult, identify_zero_offsets

_LAZY: dict[str, str] = {
    "MonteCarloResult": ".montecarlo",
    "run_monte_carlo": ".montecarlo",
    "PoseSelection": ".pose_selection",
    "select_poses": ".pose_selection",
    "perturbation": ".simulation",
    "random_actuated": ".simulation",
    "simulate_observations": ".simulation",
    "StatisticalSensitivity": ".workspace_stats",
    "statistical_sensitivity": ".workspace_stats",
    "ZeroOffsetResult": ".zero_offset",
    "identify_zero_offsets": ".zero_offset",
}

__all__ = [
    "MonteCarloResult",
    "PoseSelection",
    "StatisticalSensitivity",
    "ZeroOffsetResult",
    "identify_zero_offsets",
    "perturbation",
    "random_actuated",
    "run_monte_carlo",
    "select_poses",
    "simulate_observations",
    "statistical_sensitivity",
]

__getattr__, __dir__ = lazy_names(__name__, _LAZY)
