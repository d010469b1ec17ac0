"""The warm-start neighbour search gives the brute-force scan's answer (issue 14, item 3).

:class:`~pincal.identification.neighbours.SolvedInputs` proposes candidates from k-d trees; the answer must be
exactly the scan's that it replaces: the solved sample nearest by max-abs gap (continuous joints the short way
round), the lowest index among equals, if within the reach.
"""

from __future__ import annotations

import math

import numpy as np
import pytest

import pincal
from pincal import linalg
from pincal.calibration.campaign import simulate
from pincal.identification import neighbours
from pincal.identification.neighbours import SolvedInputs
from pincal.identification.parameters import choose_parameters
from pincal.identification.problem import CalibrationProblem
from pincal.io.adapters import measurements_for, observations_from
from pincal.model.kinematics import CONTINUATION_STEP


def scan(values: np.ndarray, query: np.ndarray, continuous: np.ndarray, reach: float) -> int:
    """The scan the search replaces (``CalibrationProblem._nearest_solution`` before issue 14)."""
    diff = query - values
    diff[:, continuous] = linalg.wrap_angle(diff[:, continuous])
    gaps = np.max(np.abs(diff), axis=1)  # NaN rows (unsolved) compare False
    return int(np.nanargmin(gaps)) if np.any(gaps <= reach) else -1


def delta_for(continuous: np.ndarray):
    def delta(target: np.ndarray, rows: np.ndarray) -> np.ndarray:
        diff = np.asarray(target, dtype=float) - rows
        diff[..., continuous] = linalg.wrap_angle(diff[..., continuous])
        return diff
    return delta


@pytest.mark.parametrize("leaf", [48, neighbours.LEAF], ids=["small-leaf", "default-leaf"])
@pytest.mark.parametrize("continuous", [[False, False, False], [True, False, True], [True]],
                         ids=["bounded", "two-continuous", "one-continuous"])
def test_nearest_is_the_scans_answer_through_inserts_updates_and_ties(continuous: list[bool], leaf: int,
                                                                      monkeypatch: pytest.MonkeyPatch) -> None:
    """A first evaluation (query, then record, sample after sample), then later ones that record every sample
    anew (a rebuild) or some of them (stale tree entries), with queries in between; a small leaf makes many trees."""
    monkeypatch.setattr(neighbours, "LEAF", leaf)
    rng = np.random.default_rng(7)
    mask = np.array(continuous)
    n, reach = 1500, CONTINUATION_STEP
    solved = SolvedInputs(n, mask, reach)
    delta = delta_for(mask)
    # spread over several reaches; continuous joints over more than a turn, so that wrapping matters
    span = np.where(mask, 4.0 * math.pi, 3.0)
    inputs = (rng.random((n, mask.size)) - 0.5) * span
    inputs[100:130] = inputs[10]  # duplicated readings: ties, resolved to the lowest index
    inputs[200, mask] = math.pi - 1e-13  # across the ±π seam from the next one
    inputs[201, mask] = -math.pi + 1e-13
    order = rng.permutation(n)
    checked = 0
    for step, k in enumerate(order):  # a first evaluation: query, then record, sample after sample
        query = inputs[k]
        assert solved.nearest(query, delta) == scan(solved.values, query, mask, reach)
        solved.record(int(k), query)
        checked += 1
        if step % 97 == 0:  # queries from elsewhere, some exactly one reach away from a solved input
            probe = (rng.random(mask.size) - 0.5) * span
            assert solved.nearest(probe, delta) == scan(solved.values, probe, mask, reach)
            edge = solved.values[order[0]] + reach
            assert solved.nearest(edge, delta) == scan(solved.values, edge, mask, reach)
    # later evaluations: every sample re-solved at moved inputs (stale entries, rebuilds), then some again
    for recorded in (n, 50, 50, 300, n):
        moved = inputs + rng.normal(scale=0.05, size=inputs.shape)
        for k in rng.choice(n, recorded, replace=False):
            solved.record(int(k), moved[k])
        for _ in range(60):
            probe = (rng.random(mask.size) - 0.5) * span
            assert solved.nearest(probe, delta) == scan(solved.values, probe, mask, reach)
            near = solved.values[rng.integers(n)] + rng.normal(scale=0.01, size=mask.size)
            assert solved.nearest(near, delta) == scan(solved.values, near, mask, reach)
    assert checked == n


def test_nothing_solved_or_nothing_within_reach_is_a_cold_start() -> None:
    mask = np.array([False, False])
    solved = SolvedInputs(3, mask, 0.5)
    delta = delta_for(mask)
    assert solved.nearest(np.zeros(2), delta) == -1
    solved.record(2, np.array([1.0, 0.0]))
    assert solved.nearest(np.zeros(2), delta) == -1  # 1.0 away: beyond the reach
    assert solved.nearest(np.array([0.5, 0.0]), delta) == 2  # exactly the reach: a neighbour, as the scan said


def test_the_problems_first_solves_start_from_the_scans_neighbour() -> None:
    """On the Delta: each first solve of a fresh problem's first evaluation, sample by sample, finds the scan's
    neighbour (the batched path closes every first solve by continuation from the reference, with no search)."""
    robot = pincal.load_robot("delta")
    sim = simulate(robot, ["position"], 300, 0, perturb=1e-3, noise=1e-5, seed=3, parameter_spec=["model24"])
    ds = sim.dataset
    models = measurements_for(robot, list(ds.measurements), ds.joint_names, None)
    problem = CalibrationProblem(robot, choose_parameters(robot, models, ["model24"]), models,
                                 observations_from(robot, ds.joint_names, ds.joints, ds.measurements, models))
    asked: list[tuple[int, int]] = []
    nearest = problem.solves.solved_inputs.nearest

    def spy(query: np.ndarray, delta) -> int:
        found = nearest(query, delta)
        asked.append((found, scan(problem.solves.solved_inputs.values, query, robot.kinematics.continuous,
                                  CONTINUATION_STEP)))
        return found

    problem.solves.solved_inputs.nearest = spy  # type: ignore[method-assign]
    problem._batched_loops = False
    problem.evaluate(np.zeros(len(problem.parameters)), jacobian=False)
    assert len(asked) == 300
    assert all(found == expected for found, expected in asked)
    assert sum(found >= 0 for found, _ in asked) > 250  # most first solves are warm
