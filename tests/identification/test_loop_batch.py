"""The batched evaluation of closed-loop robots against the per-sample one it replaces: every closed-loop robot
pincal ships, every measurement kind (positions, poses, markers with a cluster and occluded readings, distances,
incremental distances, passive joint readings, a model without a batched prediction), harmonics, with and without
the joint readings' noise, first and warm evaluations; the per-sample path is the reference."""

from __future__ import annotations

import numpy as np
import pytest
from conftest import random_readings
from test_measurements import Height

import pincal
from pincal.errors import ConvergenceError
from pincal.identification import evaluation, predictions
from pincal.identification import measurements as ms
from pincal.identification import problem as problem_module
from pincal.identification.parameters import ParameterSet, cluster_parameters, marker_parameters, parameter_pool
from pincal.identification.problem import CalibrationProblem, Observations
from pincal.study.simulation import random_actuated

#: Largest gap between the batched and the per-sample evaluation, relative to the largest entry, with both closing
#: the loops to the tight tolerance below.
AGREEMENT = 1e-10
#: Closure tolerance [m, rad] of both paths in the comparison: at the default (1e-11) each path's configuration is
#: within the tolerance of the exact closure, and they differ by up to the passive joints' gain times it.
TIGHT = 1e-13
N_SAMPLES = 12

#: Robot -> a passive joint with a sensor (the five-bar's linear scale, the hexapod's measuring device).
PASSIVE = {"delta": "rod_1_pitch", "five_bar": "scale_joint", "hexapod": "leg_1_u1", "hexapod_device": "device_lvdt",
           "ucr3": "limb_1_roll"}
#: The robots the batched path takes (joints of one coordinate and free-flyers): all of them.
BATCHED = {"delta", "five_bar", "hexapod", "hexapod_device", "ucr3"}


def _models(robot: pincal.Robot) -> list[ms.Measurement]:
    frame, base = robot.end_effector, robot.model.frames[1].name
    return [ms.position(frame), ms.pose(frame), ms.distance(frame, base), ms.distance(frame, base, increment=True),
            ms.joint_reading(PASSIVE[robot.name]), ms.position(frame, marker="m1", nominal=(0.01, 0.02, 0.0)),
            Height(f"height:{frame}", 1, 1e-6, frame), ms.plane_point(frame), ms.plane_contact(frame, base)]


def _problems(name: str, joint_sigma: float | None, n: int = N_SAMPLES
              ) -> tuple[CalibrationProblem, CalibrationProblem, np.ndarray]:
    """The batched and the per-sample problem on the same data: every parameter the pool offers but compliance
    (which needs a tree's gravity torques), a declared marker with its offsets and cluster, some readings missing."""
    robot = pincal.load_robot(name)
    models = _models(robot)
    pool = parameter_pool(robot, models)
    frame = robot.end_effector
    extra = [p for p in marker_parameters(f"{frame}@m1") + cluster_parameters(frame) if p.name not in pool]
    pset = ParameterSet([p for p in pool.parameters if p.kind != "compliance"] + extra)
    rng = np.random.default_rng(23)
    qa, _ = random_actuated(robot, n, rng)
    values = random_readings(models, n, rng)
    made = [CalibrationProblem(robot, pset, models, Observations(qa, dict(values)), joint_sigma=joint_sigma)
            for _ in range(2)]
    made[1]._batched_loops = False
    return made[0], made[1], rng.normal(scale=1e-3, size=len(pset))


def _compare(a: problem_module.Prediction, b: problem_module.Prediction, names: list[str], agreement: float) -> None:
    scale = np.abs(b.residual).max()
    assert np.abs(a.residual - b.residual).max() <= agreement * scale
    for key in b.predicted:
        np.testing.assert_array_equal(np.isnan(a.errors[key]), np.isnan(b.errors[key]))
        reach = np.nanmax(np.abs(b.predicted[key]))
        np.testing.assert_allclose(a.predicted[key], b.predicted[key], rtol=0, atol=agreement * reach, equal_nan=True)
    if b.jacobian is None:
        assert a.jacobian is None
        return
    assert a.jacobian is not None
    worst = np.abs(a.jacobian - b.jacobian).max(axis=0) / np.abs(b.jacobian).max()
    assert worst.max() <= agreement, f"column {names[int(np.argmax(worst))]}: {worst.max()}"


#: σ of the actuated readings [rad or m] with which the residuals are whitened in the comparison. At 1e-3 the 3-UCR's
#: small prismatic legs make each pose's covariance ill-conditioned (condition ~1e8), and the whitening amplifies the
#: paths' 1e-12 gaps in the predictions to 4e-10 of the residual: the conditioning's, not the batching's.
JOINT_SIGMA = 1e-4


@pytest.mark.parametrize("joint_sigma", [None, JOINT_SIGMA])
@pytest.mark.parametrize("name", sorted(PASSIVE))
def test_batched_evaluation_equals_the_per_sample_one(name: str, joint_sigma: float | None,
                                                     monkeypatch: pytest.MonkeyPatch) -> None:
    """First evaluation (cold and neighbour starts), then warm ones at moved parameters, with and without Jacobian."""
    monkeypatch.setattr(problem_module, "SOLVE_TOLERANCE", TIGHT)
    monkeypatch.setattr(predictions, "SOLVE_TOLERANCE", TIGHT)
    monkeypatch.setattr(evaluation, "SOLVE_TOLERANCE", TIGHT)
    batched, per_sample, x = _problems(name, joint_sigma)
    assert batched._batched_loops == (name in BATCHED), \
        batched.loop_batch.unsupported if batched.loop_batch else "no loops"
    kinds = {p.kind for p in batched.parameters}
    assert {"joint", "anchor", "offset", "harmonic", "marker", "cluster", "base"} <= kinds
    rng = np.random.default_rng(5)
    for step in range(3):
        for jacobian in (True, False):
            _compare(batched.evaluate(x, jacobian), per_sample.evaluate(x, jacobian), batched.parameters.names,
                     AGREEMENT)
        x = x + rng.normal(scale=1e-4 * (step + 1), size=x.size)


@pytest.mark.parametrize("name", sorted(BATCHED))
def test_at_the_default_tolerance_both_paths_agree_within_the_closure_tolerance(name: str) -> None:
    """Each path closes the loops to 1e-11; their predictions then differ by no more than the passive joints' gain
    times that (1e-9 of the largest entry, the Jacobian's too)."""
    batched, per_sample, x = _problems(name, None)
    for _ in range(2):
        _compare(batched.evaluate(x), per_sample.evaluate(x), batched.parameters.names, 1e-9)
        x = x + 1e-4


def test_blocks_of_samples_give_the_same_numbers(monkeypatch: pytest.MonkeyPatch) -> None:
    """Blocks of 5 samples (12 in all: two full blocks and a partial one), the incremental distance across them."""
    monkeypatch.setattr(problem_module, "SOLVE_TOLERANCE", TIGHT)
    monkeypatch.setattr(predictions, "SOLVE_TOLERANCE", TIGHT)
    monkeypatch.setattr(evaluation, "SOLVE_TOLERANCE", TIGHT)
    batched, per_sample, x = _problems("delta", JOINT_SIGMA)
    whole = batched.evaluate(x)
    monkeypatch.setattr(predictions, "BATCH_SAMPLES", 5)
    _compare(batched.evaluate(x), whole, batched.parameters.names, 1e-12)
    _compare(batched.evaluate(x), per_sample.evaluate(x), batched.parameters.names, AGREEMENT)


def test_small_sets_are_solved_together_with_the_same_answers(monkeypatch: pytest.MonkeyPatch) -> None:
    """With every set of samples stacked (none small enough to go one by one), the first and the warm evaluations
    still give the per-sample configurations, and every sample's warm start is remembered."""
    monkeypatch.setattr(problem_module, "SOLVE_TOLERANCE", TIGHT)
    monkeypatch.setattr(predictions, "SOLVE_TOLERANCE", TIGHT)
    monkeypatch.setattr(evaluation, "SOLVE_TOLERANCE", TIGHT)
    monkeypatch.setattr(predictions, "SMALL_BATCH", 1)
    batched, per_sample, x = _problems("five_bar", None, n=40)
    for _ in range(2):
        np.testing.assert_allclose(batched.configurations(x), per_sample.configurations(x), rtol=0, atol=1e-10)
        _compare(batched.evaluate(x), per_sample.evaluate(x), batched.parameters.names, AGREEMENT)
        assert all(q is not None for q in batched.solves.configurations)
        x = x + 1e-3


def test_samples_are_not_reordered_by_their_warm_starts(monkeypatch: pytest.MonkeyPatch) -> None:
    """The same samples in reverse order: each gets its own configuration back (a first solve is continuation from
    the reference, whatever the order)."""
    monkeypatch.setattr(problem_module, "SOLVE_TOLERANCE", TIGHT)
    monkeypatch.setattr(predictions, "SOLVE_TOLERANCE", TIGHT)
    monkeypatch.setattr(evaluation, "SOLVE_TOLERANCE", TIGHT)
    monkeypatch.setattr(predictions, "SMALL_BATCH", 1)
    robot = pincal.load_robot("delta")
    models = [ms.position(robot.end_effector)]
    pset = ParameterSet([p for p in parameter_pool(robot, models) if p.kind != "compliance"])
    qa, _ = random_actuated(robot, 30, np.random.default_rng(8))
    order = np.arange(30)[::-1]
    values = {models[0].key: np.zeros((30, 3))}
    forward = CalibrationProblem(robot, pset, models, Observations(qa, values))
    backward = CalibrationProblem(robot, pset, models, Observations(qa[order], values))
    x = np.random.default_rng(9).normal(scale=1e-3, size=len(pset))
    np.testing.assert_allclose(backward.configurations(x), forward.configurations(x)[order], rtol=0, atol=1e-12)


def test_a_sample_outside_the_workspace_is_named() -> None:
    """A reading the loops cannot close fails as the per-sample path fails: naming the sample."""
    batched, per_sample, x = _problems("delta", None, n=4)
    actuated = batched.observations.actuated.copy()
    actuated[2] = [300.0, 0.0, 0.0]  # far beyond any workspace: continuation refuses it at once
    for problem in (batched, per_sample):
        bad = CalibrationProblem(problem.robot, problem.parameters, problem.measurements,
                                 Observations(actuated, problem.observations.values))
        bad._batched_loops = problem._batched_loops
        with pytest.raises(ConvergenceError, match="sample 2"):
            bad.evaluate(x)


def test_settling_and_configurations_see_the_batched_solves() -> None:
    """The bookkeeping the per-sample path keeps (remembered configurations, travel) is kept by the batched one."""
    batched, per_sample, x = _problems("delta", None)
    for problem in (batched, per_sample):
        problem.evaluate(x)
        problem.evaluate(x + 2e-3)
    np.testing.assert_allclose(batched.solves.travel, per_sample.solves.travel, rtol=0, atol=1e-9)
    np.testing.assert_allclose(np.array(batched.solves.configurations), np.array(per_sample.solves.configurations),
                               rtol=0, atol=1e-9)
    assert batched.settle_assembly(x) == per_sample.settle_assembly(x) == []


@pytest.mark.parametrize("name", sorted(BATCHED))
def test_warm_starts_moved_along_the_response_stay_on_the_assembly(name: str, monkeypatch: pytest.MonkeyPatch) -> None:
    """Warm starts move along the last Jacobian's dv/dθ: after small and large parameter changes (past the largest
    predicted move, where the prediction is dropped) the configurations are still the per-sample ones."""
    monkeypatch.setattr(problem_module, "SOLVE_TOLERANCE", TIGHT)
    monkeypatch.setattr(predictions, "SOLVE_TOLERANCE", TIGHT)
    monkeypatch.setattr(evaluation, "SOLVE_TOLERANCE", TIGHT)
    batched, per_sample, x = _problems(name, None, n=20)
    for size in (1e-5, 1e-3, 1e-2):
        for problem in (batched, per_sample):
            problem.evaluate(x)
        assert batched.solves.response is not None
        moved = x + size * np.random.default_rng(int(1 / size)).normal(size=x.size)
        try:
            reference = per_sample.evaluate(moved)
        except ConvergenceError as failed:  # too far for these loops (the 3-UCR's legs are centimetres long)
            sample = str(failed).split(":")[0]
            with pytest.raises(ConvergenceError, match=sample):
                batched.evaluate(moved)
            continue
        _compare(batched.evaluate(moved), reference, batched.parameters.names, AGREEMENT)
        x = moved


@pytest.mark.parametrize("name", ["delta", "hexapod"])
def test_an_evaluation_that_moves_only_the_setup_takes_the_loops_twists_again(name: str) -> None:
    """At the same kinematic deviations and configurations (a step of the base, the markers and the offsets' readings
    left as they were) the loops' placements and twists are taken again, not recomputed: the same residual and
    Jacobian, bit for bit, as a problem that recomputes them; a step of a joint's placement recomputes them."""
    kept, fresh, x = _problems(name, None)
    fresh._batched_loops = True  # both batched: one keeps the loops' twists, the other forgets them each time
    setup = np.array([p.kind in ("base", "marker", "cluster") for p in kept.parameters])
    moved = x + np.where(setup, 1e-3, 0.0)
    joint = x + np.where(np.array([p.kind == "joint" for p in kept.parameters]), 1e-4, 0.0)
    for step in (x, moved, joint, moved):
        before = kept.solves.twists
        a = kept.evaluate(step)
        fresh.solves.twists = None
        b = fresh.evaluate(step)
        assert np.array_equal(a.residual, b.residual) and np.array_equal(a.jacobian, b.jacobian)
        again = before is not None and kept.solves.twists is before
        assert again == (step is moved and before[0] is kept.placed_robot(step))  # type: ignore[index]
    assert setup.any()
