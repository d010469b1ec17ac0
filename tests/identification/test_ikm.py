"""The inverse (IKM) formulation of study 000: implicit loop residuals with the measured pose held."""

from __future__ import annotations

import numpy as np
import pytest
from conftest import finite_difference_jacobian

import pincal
from pincal.errors import DataError
from pincal.identification import measurements as ms
from pincal.identification.identifiability import analyse
from pincal.identification.ikm import ImplicitProblem, chain_blocks
from pincal.identification.parameters import choose_parameters
from pincal.identification.problem import CalibrationProblem
from pincal.identification.solver import identify, identify_chains
from pincal.study.simulation import perturbation, random_actuated, simulate_observations


def _delta(n: int, seed: int, base_only: bool = True):
    robot = pincal.load_robot("delta")
    models = [ms.position("end_effector")]
    pool = choose_parameters(robot, models, ["model24"])
    rng = np.random.default_rng(seed)
    qa, _ = random_actuated(robot, n, rng)
    pset = pool
    if base_only:
        blank = simulate_observations(robot, pool, np.zeros(len(pool)), models, qa, rng)
        jac = CalibrationProblem(robot, pool, models, blank).evaluate(np.zeros(len(pool))).jacobian
        assert jac is not None
        pset = pool.subset(analyse(jac, pool.names, pool.scales).base_indices)
    x_true = perturbation(pset, 1e-3, rng)
    obs = simulate_observations(robot, pset, x_true, models, qa, rng)
    return robot, pset, x_true, ImplicitProblem(robot, pset, models, obs)


def test_residual_vanishes_at_the_truth_and_jacobian_matches() -> None:
    _, _, x_true, problem = _delta(10, seed=1, base_only=False)
    pred = problem.evaluate(x_true)
    assert np.max(np.abs(pred.residual)) * problem.measurement.sigma < 1e-11  # metres
    assert pred.jacobian is not None
    fd = finite_difference_jacobian(problem, x_true)
    assert np.max(np.abs(pred.jacobian - fd)) < 1e-5 * np.max(np.abs(fd))


def test_chains_decouple_leg_by_leg() -> None:
    _, pset, _, problem = _delta(10, seed=2, base_only=False)
    jac = problem.evaluate(np.zeros(len(pset))).jacobian
    assert jac is not None
    blocks = chain_blocks(problem, jac)
    assert sorted(loops for _, loops in blocks) == [[0], [1], [2]]
    for columns, loops in blocks:
        leg = loops[0] + 1
        assert len(columns) == 8 and all(f"_{leg}" in pset.names[c] for c in columns)


def test_ikm_recovers_the_identifiable_parameters() -> None:
    _, pset, x_true, problem = _delta(30, seed=3)
    result = identify(problem)
    assert result.converged
    np.testing.assert_allclose(result.x, x_true, atol=1e-9, rtol=0)
    chains = identify_chains(problem)
    assert len(chains) == 3 and all(r.converged for _, r in chains)
    recovered = np.zeros(len(pset))
    for _, r in chains:
        for name, value in zip(r.names, r.x, strict=True):
            recovered[pset.index(name)] = value
    np.testing.assert_allclose(recovered, x_true, atol=1e-9, rtol=0)


def test_ikm_converges_from_one_centimetre() -> None:
    """Study 000: from 1 cm initial errors the IKM converges (and so, with exact Jacobians, does FKM)."""
    robot = pincal.load_robot("delta")
    models = [ms.position("end_effector")]
    _, pset, _, _ = _delta(30, seed=4)
    rng = np.random.default_rng(5)
    x_true = perturbation(pset, 1e-2, rng)
    qa, _ = random_actuated(robot, 30, rng)
    obs = simulate_observations(robot, pset, x_true, models, qa, rng)
    for problem in (ImplicitProblem(robot, pset, models, obs), CalibrationProblem(robot, pset, models, obs)):
        result = identify(problem)
        assert result.converged, result.message
        np.testing.assert_allclose(result.x, x_true, atol=1e-8, rtol=0)


def test_ikm_refuses_serial_robots_and_extra_measurements() -> None:
    ur10 = pincal.load_robot("ur10")
    models = [ms.position("tool0")]
    pset = choose_parameters(ur10, models)
    qa, _ = random_actuated(ur10, 3, np.random.default_rng(0))
    obs = simulate_observations(ur10, pset, np.zeros(len(pset)), models, qa, np.random.default_rng(0))
    with pytest.raises(DataError, match="needs closed loops"):
        ImplicitProblem(ur10, pset, models, obs)
    _, pset, _, problem = _delta(3, seed=6, base_only=False)
    two = [ms.position("end_effector"), ms.pose("end_effector")]
    with pytest.raises(DataError, match="exactly one position or pose"):
        ImplicitProblem(problem.robot, pset, two, problem.observations)


def test_ikm_with_a_pose_target_on_a_robot_that_cannot_turn_its_platform() -> None:
    """The Delta's platform keeps its orientation: the measured orientation's rows are outside what the
    passive joints can act on, and the implicit solve must converge on the rest."""
    robot = pincal.load_robot("delta")
    pose = [ms.pose("end_effector", sigma=1e-5, sigma_angle=1e-5)]
    pset = choose_parameters(robot, [ms.position("end_effector")], ["model24i"])
    rng = np.random.default_rng(0)
    x_true = perturbation(pset, 1e-3, rng)
    qa, _ = random_actuated(robot, 30, rng)
    obs = simulate_observations(robot, pset, x_true, pose, qa, rng, noise=1e-5)
    result = identify(ImplicitProblem(robot, pset, pose, obs))
    assert result.converged
    assert np.max(np.abs(result.x - x_true)) < 1e-3  # noisy: near the truth, far from the 1 mm start errors
