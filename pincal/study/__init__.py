"""Studies on the model: simulation, pose selection, sensitivity statistics, Monte Carlo, zero offsets."""

from __future__ import annotations

from pincal.study.montecarlo import MonteCarloResult, run_monte_carlo
from pincal.study.pose_selection import PoseSelection, select_poses
from pincal.study.simulation import perturbation, random_actuated, simulate_observations
from pincal.study.workspace_stats import StatisticalSensitivity, statistical_sensitivity
from pincal.study.zero_offset import ZeroOffsetResult, identify_zero_offsets

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
