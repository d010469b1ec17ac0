"""Experiment design: per-pose Jacobian blocks and pose selection by condition number or D-optimality."""

from __future__ import annotations

import numpy as np
import pytest

import pincal
from pincal.errors import DataError
from pincal.identification import measurements as ms
from pincal.identification.parameters import choose_parameters
from pincal.identification.problem import CalibrationProblem
from pincal.study.pose_selection import condition_number, jacobian_blocks, log_det, select_poses
from pincal.study.simulation import random_actuated, simulate_observations


@pytest.fixture(scope="module")
def delta_candidates() -> tuple[CalibrationProblem, np.ndarray]:
    """150 candidate postures of the Delta, position measured, Model 24 (21 of 24 identifiable)."""
    robot = pincal.load_robot("delta")
    models = [ms.position("end_effector", sigma=1e-5)]
    pset = choose_parameters(robot, models, ["model24"])
    rng = np.random.default_rng(11)
    qa, _ = random_actuated(robot, 150, rng)
    obs = simulate_observations(robot, pset, np.zeros(len(pset)), models, qa, rng)
    problem = CalibrationProblem(robot, pset, models, obs)
    return problem, jacobian_blocks(problem)


def test_blocks_are_the_problem_jacobian_regrouped_by_pose() -> None:
    robot = pincal.load_robot("hexapod_device")
    models = [ms.joint_reading("device_incl_x", 1e-5), ms.joint_reading("device_lvdt", 2e-6)]
    pset = choose_parameters(robot, models, ["hexapod44"])
    rng = np.random.default_rng(2)
    qa, _ = random_actuated(robot, 5, rng)
    problem = CalibrationProblem(robot, pset, models, simulate_observations(robot, pset, np.zeros(44), models, qa, rng))
    jac = problem.evaluate(np.zeros(44)).jacobian
    blocks = jacobian_blocks(problem)
    assert blocks.shape == (5, 2, 44)
    # the problem stacks by measurement, then sample; the blocks by sample, then measurement
    np.testing.assert_array_equal(blocks.transpose(1, 0, 2).reshape(-1, 44), jac)
    raw = jacobian_blocks(problem, weighted=False)
    np.testing.assert_allclose(raw[:, 0], blocks[:, 0] * 1e-5)
    np.testing.assert_allclose(raw[:, 1], blocks[:, 1] * 2e-6)


def test_condition_selection_beats_random_sets(delta_candidates) -> None:
    problem, blocks = delta_candidates
    scales = problem.parameters.scales
    sel = select_poses(problem, 12, "condition")
    # Model 24 with position data: three combinations are invisible to any pose set (study 000)
    assert len(sel.columns) == 21 and len(sel.dropped) == 3
    assert len(sel.indices) == len(set(sel.indices)) == 12
    assert sel.condition_number == pytest.approx(condition_number(blocks, sel.indices, scales, sel.columns))
    rng = np.random.default_rng(0)
    random = [condition_number(blocks, rng.choice(150, 12, replace=False), scales, sel.columns) for _ in range(30)]
    assert sel.condition_number < min(random)
    assert sel.condition_number < 0.5 * float(np.median(random))
    # the exchange passes only ever improve on the greedy set
    greedy = select_poses(blocks, 12, "condition", scales=scales, columns=sel.columns, exchange=False)
    assert sel.condition_number <= greedy.condition_number * (1 + 1e-9)


def test_d_optimal_selection_increases_log_det(delta_candidates) -> None:
    problem, blocks = delta_candidates
    scales = problem.parameters.scales
    sel = select_poses(blocks, 12, "d-optimal", scales=scales, names=problem.parameters.names)
    # each greedy addition increases log det (the information only grows) ...
    assert all(b > a for a, b in zip(sel.history, sel.history[1:], strict=False))
    # ... and the chosen set has more information than random sets
    rng = np.random.default_rng(1)
    random = [log_det(blocks, rng.choice(150, 12, replace=False), scales, sel.columns) for _ in range(30)]
    assert sel.log_det > max(random)
    assert sel.log_det == pytest.approx(log_det(blocks, sel.indices, scales, sel.columns))


def test_imposed_poses_stay_and_incremental_rows_use_differences() -> None:
    robot = pincal.load_robot("five_bar")
    pset = choose_parameters(robot, [], ["*.offset"])
    absolute = [ms.distance("scale_body", "scale_slider", sigma=1e-6)]
    rng = np.random.default_rng(3)
    qa, _ = random_actuated(robot, 40, rng)
    problem = CalibrationProblem(robot, pset, absolute, simulate_observations(robot, pset, np.zeros(2), absolute, qa,
                                                                               rng))
    blocks = jacobian_blocks(problem)
    sel = select_poses(blocks, 6, "condition", scales=pset.scales, difference=True, initial=[7])
    assert sel.indices[0] == 7
    # the κ reported is that of the consecutive differences, which is what an incremental scale sees
    increment = [ms.distance("scale_body", "scale_slider", sigma=1e-6, increment=True)]
    chosen = simulate_observations(robot, pset, np.zeros(2), increment, qa[sel.indices], rng)
    jac = CalibrationProblem(robot, pset, increment, chosen).evaluate(np.zeros(2)).jacobian
    sv = np.linalg.svd(jac * pset.scales, compute_uv=False)
    assert sel.condition_number == pytest.approx(sv[0] / sv[-1], rel=1e-9)
    with pytest.raises(DataError, match="incremental"):
        jacobian_blocks(CalibrationProblem(robot, pset, increment, chosen))


def test_bad_requests_raise_data_errors(delta_candidates) -> None:
    _, blocks = delta_candidates
    with pytest.raises(DataError, match="unknown design criterion 'a-optimal'"):
        select_poses(blocks, 5, "a-optimal")
    with pytest.raises(DataError, match="cannot choose 200 of 150"):
        select_poses(blocks, 200)
    with pytest.raises(DataError, match="scales"):
        select_poses(blocks, 5, scales=np.ones(3))
    assert condition_number(blocks, [0]) == float("inf")  # 3 rows cannot condition 24 columns


def test_jacobian_blocks_through_an_executor_equal_the_serial_ones() -> None:
    """Large candidate sets: chunks computed in a process pool give the same blocks, and the same choice."""
    import concurrent.futures

    import pincal
    from pincal.identification import measurements as ms
    from pincal.identification.parameters import choose_parameters
    from pincal.identification.problem import CalibrationProblem
    from pincal.study.pose_selection import jacobian_blocks, select_poses
    from pincal.study.simulation import random_actuated, simulate_observations

    robot = pincal.load_robot("delta")
    models = [ms.position("end_effector")]
    pset = choose_parameters(robot, models, ["model24i"])
    rng = np.random.default_rng(5)
    qa, _ = random_actuated(robot, 450, rng)
    obs = simulate_observations(robot, pset, np.zeros(len(pset)), models, qa, rng)
    serial = jacobian_blocks(CalibrationProblem(robot, pset, models, obs))
    with concurrent.futures.ProcessPoolExecutor(max_workers=2) as pool:
        pooled = jacobian_blocks(CalibrationProblem(robot, pset, models, obs), executor=pool, chunk=100)
        choice = select_poses(CalibrationProblem(robot, pset, models, obs), 24, executor=pool)
    np.testing.assert_allclose(pooled, serial, rtol=0, atol=1e-9 * np.max(np.abs(serial)))
    assert choice.indices == select_poses(serial, 24, scales=pset.scales).indices
