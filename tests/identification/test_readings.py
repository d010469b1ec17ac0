"""Bad joint readings: the reading derivatives against finite differences, a wrong reading found at its size, and
wrong positions or moderate misfits left to the robust loss."""

from __future__ import annotations

import numpy as np

import pincal
from pincal.identification import measurements as ms
from pincal.identification.parameters import choose_parameters
from pincal.identification.problem import CalibrationProblem, Observations
from pincal.identification.readings import _reading_changes, _sample_terms, bad_readings, deleted_squares
from pincal.study.simulation import perturbation, random_actuated, simulate_observations

SIGMA = 1e-5  # m


def _campaign(name: str, frame: str, n: int = 30) -> tuple[CalibrationProblem, np.ndarray]:
    """A simulated campaign of robot ``name`` measuring ``frame``'s position, and the true deviations [m, rad]."""
    robot = pincal.load_robot(name)
    models = [ms.position(frame, sigma=SIGMA)]
    rng = np.random.default_rng(3)
    pset = choose_parameters(robot, models)
    x_true = perturbation(pset, 1e-3, rng)
    qa, _ = random_actuated(robot, n, rng)
    obs = simulate_observations(robot, pset, x_true, models, qa, rng, noise=SIGMA)
    return CalibrationProblem(robot, pset, models, obs), x_true


def _with(problem: CalibrationProblem, actuated: np.ndarray | None = None,
          values: dict[str, np.ndarray] | None = None) -> CalibrationProblem:
    obs = problem.observations
    return CalibrationProblem(problem.robot, problem.parameters, problem.measurements,
                              Observations(obs.actuated if actuated is None else actuated,
                                           obs.values if values is None else values))


def test_reading_derivatives_match_finite_differences_through_the_loops() -> None:
    problem, x_true = _campaign("delta", "end_effector", 4)
    robot = problem.robot
    offsets = [p for p in problem.parameters if p.kind == "offset" and p.owner in robot.actuated_joints]
    assert len(offsets) == robot.n_actuated  # the default set holds every reading offset: no column is added
    columns = np.array([[problem.parameters.index(f"{j}.offset") for j in robot.actuated_joints]])
    observed = problem.observations.subset([2])
    zero, first = np.zeros((1, robot.n_actuated)), np.zeros(1, dtype=int)
    squares, slopes, grads = _sample_terms(problem, problem.parameters, x_true, observed, first, zero, columns)
    h = 1e-6
    for i in range(robot.n_actuated):
        step = zero.copy()
        step[0, i] = h
        plus, _, _ = _sample_terms(problem, problem.parameters, x_true, observed, first, step, columns)
        minus, _, _ = _sample_terms(problem, problem.parameters, x_true, observed, first, -step, columns)
        # d‖r‖²/dq = 2 gᵀr
        assert np.isclose((plus[0] - minus[0]) / (2 * h), 2 * grads[0, i], rtol=1e-4, atol=1e-3)
    assert np.all(slopes > 0) and squares[0] >= 0


def test_a_reading_off_is_found_at_its_size_and_named() -> None:
    problem, x_true = _campaign("ur10", "tool0")
    actuated = problem.observations.actuated.copy()
    actuated[7, 1] += 0.1  # shoulder_lift_joint reads 0.1 rad high
    bad = _with(problem, actuated=actuated)
    [found] = bad_readings(bad, x_true, [7], 1.0)
    assert found.sample == 7 and found.joint == "shoulder_lift_joint" and found.unit == "rad"
    assert abs(found.off - 0.1) < 1e-6 and found.explained > 0.9999
    changes, before, after = _reading_changes(bad, x_true, [7])
    assert abs(changes[0, 1] + 0.1) < 1e-6 and after[0, 1] < 20.0 < before[0]  # [σ²]: noise after, gross before


def test_a_wrong_position_or_a_moderate_misfit_is_not_a_wrong_reading() -> None:
    problem, x_true = _campaign("ur10", "tool0")
    values = {key: v.copy() for key, v in problem.observations.values.items()}
    values["position:tool0"][7] += [0.003, -0.002, 0.004]  # a marker knocked: no one joint moves the tool so
    values["position:tool0"][9] += 8 * SIGMA  # 8 σ along x: beyond the noise, not gross
    assert bad_readings(_with(problem, values=values), x_true, [7, 9], 1.0) == []
    actuated = problem.observations.actuated.copy()
    actuated[9, 2] += 2e-4  # 0.2 mrad off moves the tool ~0.2 mm: with a noise of 1 mm (s² = 10⁴ σ²), not gross
    assert bad_readings(_with(problem, actuated=actuated), x_true, [9], 1e4) == []


def test_the_copies_evaluated_at_once_are_each_as_evaluated_alone() -> None:
    """The search evaluates every (sample, joint) pair of a step in one problem; each pair's terms are those of its
    sample evaluated alone, and a copy whose loops cannot close (a hexapod leg read 0.4 m long) is NaN without
    spoiling the others."""
    problem, x_true = _campaign("hexapod", "platform", 6)
    robot = problem.robot
    columns = np.array([problem.parameters.index(f"{j}.offset") for j in robot.actuated_joints])
    samples = np.array([3, 1, 3, 4])
    delta = np.zeros((4, robot.n_actuated))
    delta[1, 0], delta[2, 2] = 0.4, 0.003  # copy 1 cannot be assembled
    together = _sample_terms(problem, problem.parameters, x_true, problem.observations, samples, delta,
                             np.stack([columns[[0, 2]]] * 4))
    assert np.all(np.isnan([together[0][1], *together[1][1], *together[2][1]]))
    for e in (0, 2, 3):
        alone = _sample_terms(problem, problem.parameters, x_true, problem.observations, samples[e:e + 1],
                              delta[e:e + 1], columns[None, [0, 2]])
        for got, expected in zip(together, alone, strict=True):
            assert np.allclose(got[e], expected[0], rtol=1e-9, atol=1e-12)
    assert np.isfinite(together[0][[0, 2, 3]]).all() and together[0][0] != together[0][2]


def test_the_deleted_squares_are_the_residuals_of_a_linear_fit_without_each_sample() -> None:
    """For a linear weighted least-squares fit the screen's estimate is exact: each sample's squared residual at the
    fit of the other samples, made here by a solve without it; a prior's rows after the data's are ignored."""
    rng = np.random.default_rng(7)
    rows = np.repeat(np.arange(12), 3)  # 12 samples of 3 rows
    jacobian = np.vstack([rng.normal(size=(36, 5)), np.eye(5)])  # 5 prior rows after the data's
    measured = rng.normal(size=36)
    weights = rng.uniform(0.2, 1.0, 12)
    columns = [0, 1, 3, 4]

    def fit(keep: np.ndarray) -> np.ndarray:
        w = np.sqrt(weights[rows][keep])
        x, *_ = np.linalg.lstsq(jacobian[:36][keep][:, columns] * w[:, None], measured[keep] * w, rcond=None)
        return np.asarray(jacobian[:36][:, columns] @ x - measured)

    residual = np.concatenate([fit(np.ones(36, dtype=bool)), np.zeros(5)])
    samples = [0, 5, 11]
    estimated = deleted_squares(rows, residual, jacobian, weights, columns, samples)
    for k, value in zip(samples, estimated, strict=True):
        alone = fit(rows != k)[rows == k]
        assert np.isclose(value, alone @ alone, rtol=1e-9)
