"""Every measurement model's analytic Jacobian against finite differences, on every reference robot
it applies to, with all candidate parameters (placements, anchors, offsets, base, markers)."""

from __future__ import annotations

import numpy as np
import pytest
from conftest import finite_difference_jacobian

import pincal
from pincal.errors import DataError
from pincal.identification import measurements as ms
from pincal.identification.evaluation import RECALLED
from pincal.identification.parameters import ParameterSet, candidate_parameters, cluster_parameters, marker_parameters
from pincal.identification.problem import CalibrationProblem, Observations
from pincal.model.robot import Robot
from pincal.study.simulation import random_actuated, simulate_observations

DEVICE = ("device_incl_x", "device_incl_y", "device_lvdt", "device_rotary")

CASES = {
    "delta": lambda: [ms.position("end_effector"), ms.pose("end_effector")],
    "ur10": lambda: [ms.position("tool0"), ms.pose("tool0"), ms.distance("tool0", "base_link")],
    "hexapod": lambda: [ms.pose("end_effector")],
    "hexapod_device": lambda: [ms.joint_reading(j) for j in DEVICE],
    "five_bar": lambda: [ms.joint_reading("scale_joint"), ms.position("end_effector"),
                         ms.distance("base_link", "end_effector", increment=True)],
    "ucr3": lambda: [ms.pose("end_effector"), ms.position("end_effector")],
}


def _blank(models: list, n: int) -> dict[str, np.ndarray]:
    out = {}
    for m in models:
        values = np.zeros((n, len(m.columns)))
        if isinstance(m, ms.Pose):
            values[:, 6] = 1.0  # qw: the identity rotation
        if m.incremental:
            values[0] = np.nan
        out[m.key] = values
    return out


@pytest.mark.parametrize("name", sorted(CASES))
def test_measurement_jacobians_match_finite_differences(name: str) -> None:
    robot = pincal.load_robot(name)
    models = CASES[name]()
    frames = sorted({f for m in models for f in m.frames})
    read = [m.joint for m in models if isinstance(m, ms.JointReading)]
    pset = candidate_parameters(robot, frames=frames, offsets=list(robot.actuated_joints) + read,
                                base=True, markers=True)
    rng = np.random.default_rng(11)
    qa, _ = random_actuated(robot, 5, rng)
    problem = CalibrationProblem(robot, pset, models, Observations(qa, _blank(models, 5)))
    x = rng.normal(scale=1e-3, size=len(pset))
    jac = problem.evaluate(x).jacobian
    assert jac is not None
    fd = finite_difference_jacobian(problem, x)
    scale = np.max(np.abs(fd))
    worst = np.max(np.abs(jac - fd), axis=0) / scale
    assert worst.max() < 2e-5, f"worst column {pset.names[int(np.argmax(worst))]}: {worst.max():.2e}"


# --- markers declared on a body: each one's offset, the cluster's placement, occluded readings ------------------
def _marker_problem(name: str, frame: str, occluded: dict[str, list[int]] | None = None) -> CalibrationProblem:
    """Three declared markers on ``frame`` at nominal offsets [m], the frame's own point, and a distance from the
    frame; every candidate parameter, each marker's offset and the cluster's placement; ``occluded``: marker key ->
    samples that did not see it."""
    robot = pincal.load_robot(name)
    nominal = {"m1": (0.05, 0.0, 0.02), "m2": (-0.03, 0.04, 0.0), "m3": (0.0, -0.02, 0.06)}
    models = [ms.position(frame, marker=m, nominal=n) for m, n in nominal.items()]
    models += [ms.position(frame), ms.distance(frame, robot.model.frames[1].name)]
    pset = candidate_parameters(robot, frames=[frame], offsets=list(robot.actuated_joints), base=True, markers=True)
    pset = ParameterSet(pset.parameters + [p for m in models[:3] for p in marker_parameters(m.marker_key)]
                        + cluster_parameters(frame))
    rng = np.random.default_rng(3)
    qa, _ = random_actuated(robot, 5, rng)
    values = _blank(models, 5)
    for key, samples in (occluded or {}).items():
        values[key][samples] = np.nan
    return CalibrationProblem(robot, pset, models, Observations(qa, values))


@pytest.mark.parametrize(("name", "frame"), [("ur10", "tool0"), ("delta", "end_effector")])
def test_marker_and_cluster_jacobians_match_finite_differences(name: str, frame: str) -> None:
    """Each declared marker's point ``exp6(δ_c)·(nominal + δ_m)`` on its frame: the marker, cluster, base and robot
    columns against central differences, away from zero (the cluster's right Jacobian of exp6 matters there)."""
    problem = _marker_problem(name, frame)
    rng = np.random.default_rng(12)
    x = rng.normal(scale=1e-2, size=len(problem.parameters))  # 1 cm, 10 mrad: exp6's Jacobian is not the identity
    jac = problem.evaluate(x).jacobian
    assert jac is not None
    fd = finite_difference_jacobian(problem, x)
    worst = np.max(np.abs(jac - fd), axis=0) / np.max(np.abs(fd))
    assert worst.max() < 2e-5, f"worst column {problem.parameters.names[int(np.argmax(worst))]}: {worst.max():.2e}"
    cluster = [k for k, p in enumerate(problem.parameters) if p.kind == "cluster"]
    assert np.abs(jac[:, cluster]).max() > 0.0


def test_an_occluded_marker_has_no_rows_and_a_nan_error() -> None:
    """A reading not taken (NaN) leaves its rows out of the residual, the Jacobian and the row-to-sample map; its
    error stays NaN; the other readings of that sample are used. The Jacobian still matches finite differences."""
    frame = "tool0"
    full = _marker_problem("ur10", frame)
    key = f"position:{frame}@m2"
    problem = _marker_problem("ur10", frame, {key: [1, 3]})
    x = np.random.default_rng(4).normal(scale=1e-3, size=len(problem.parameters))
    pred, whole = problem.evaluate(x), full.evaluate(x)
    assert pred.jacobian is not None and whole.jacobian is not None
    assert pred.residual.size == whole.residual.size - 2 * 3
    assert pred.jacobian.shape == (pred.residual.size, len(problem.parameters))
    samples = problem.row_samples()
    assert samples.size == pred.residual.size
    assert np.array_equal(np.bincount(samples, minlength=5), np.bincount(full.row_samples(), minlength=5)
                          - 3 * np.isin(np.arange(5), [1, 3]))
    assert np.isnan(pred.errors[key][[1, 3]]).all() and np.isfinite(pred.errors[key][[0, 2, 4]]).all()
    assert problem.n_readings()[key] == 3 and problem.n_readings()[f"position:{frame}@m1"] == 5
    kept = np.ones(whole.residual.size, dtype=bool)
    first = 3 * 5  # m1's 15 rows come first, then m2's
    kept[[first + 3 * k + c for k in (1, 3) for c in range(3)]] = False
    np.testing.assert_array_equal(pred.residual, whole.residual[kept])
    fd = finite_difference_jacobian(problem, x)
    assert np.max(np.abs(pred.jacobian - fd)) < 2e-5 * np.max(np.abs(fd))


def test_a_reading_partly_missing_is_refused() -> None:
    problem = _marker_problem("ur10", "tool0")
    values = dict(problem.observations.values)
    values["position:tool0@m1"] = values["position:tool0@m1"].copy()
    values["position:tool0@m1"][2, 1] = np.nan
    with pytest.raises(DataError, match=r"'position:tool0@m1' of sample 2 is NaN or infinite \(a reading not taken"):
        CalibrationProblem(problem.robot, problem.parameters, problem.measurements,
                           Observations(problem.observations.actuated, values))
    values = dict(problem.observations.values)
    values["distance:tool0-" + problem.robot.model.frames[1].name] = np.full((5, 1), np.nan)
    with pytest.raises(DataError, match=r"of sample 0 is NaN or infinite$"):  # a distance cannot be occluded
        CalibrationProblem(problem.robot, problem.parameters, problem.measurements,
                           Observations(problem.observations.actuated, values))


@pytest.mark.parametrize(("name", "solver"), [("ur10", "lm"), ("delta", "lm"), ("delta", "ridge")])
def test_the_unit_check_and_the_fit_share_the_start_s_evaluation(name: str, solver: str,
                                                                 monkeypatch: pytest.MonkeyPatch) -> None:
    """The pipeline makes the evaluation at the default start before the unit check, which reads its predictions, and
    the fit starts from that very evaluation instead of making it again (issue 27): together they evaluate the model
    as often as the fit alone, and the fit (the robust plan's restarts from the start included: one sample is off by
    5 mm) comes out the same, to the last bit, as on a problem nothing evaluated before. Any other evaluation, or
    configurations set anew (``remember``), drop the kept evaluation."""
    from pincal.calibration.samples import check_length_scale
    from pincal.identification import predictions
    from pincal.identification.solver import identify

    robot, models, pset, observations, _ = _end_effector_campaign(name, seed=4, n=40)
    observations.values[models[0].key][7] += 5e-3
    made = _counted_predictions(monkeypatch)
    fresh_problem = CalibrationProblem(robot, pset, models, observations)
    fresh_problem.initial_guess()
    made["count"] = 0
    fresh = identify(fresh_problem, solver=solver)
    alone = made["count"]
    problem = CalibrationProblem(robot, pset, models, observations)
    x0 = problem.initial_guess()
    made["count"] = 0
    problem.start_prediction()
    check_length_scale(problem)
    assert made["count"] == 1
    shared = identify(problem, solver=solver)
    assert made["count"] == alone  # the fit's first evaluation was the one the unit check read
    assert np.array_equal(shared.x, fresh.x) and shared.iterations == fresh.iterations
    assert fresh.extra["outlier_test"]  # the robust plan ran, and its restarts from the start evaluated afresh
    configurations = problem.configurations(x0)
    # a tree's evaluation is recalled besides (test_a_tree_s_evaluations_are_recalled): none here, to see the start's
    problem._recalled = None
    for drop, drops in ((lambda: problem.evaluate(x0 + 1e-6), True),
                        (lambda: predictions.remember(problem, configurations), bool(robot.loops))):
        problem.start_prediction()
        drop()  # a tree's evaluation reads no configurations: remember() leaves its start kept
        before = made["count"]
        problem.evaluate(x0, jacobian=False)
        assert made["count"] == before + drops


def _end_effector_campaign(name: str, seed: int, n: int) -> tuple[Robot, list[ms.Measurement], ParameterSet,
                                                                   Observations, np.random.Generator]:
    """Robot ``name`` measured at its end effector's position in ``n`` random postures: its 14 first candidates
    perturbed by 1 mm or mrad, noise 10 µm; with the generator seeded by ``seed``, to draw on from there."""
    robot = pincal.load_robot(name)
    models: list[ms.Measurement] = [ms.position(robot.end_effector)]
    pset = candidate_parameters(robot).subset(list(range(14)))
    rng = np.random.default_rng(seed)
    qa, _ = random_actuated(robot, n, rng)
    observations = simulate_observations(robot, pset, rng.normal(scale=1e-3, size=len(pset)), models, qa, rng,
                                         noise=1e-5)
    return robot, models, pset, observations, rng


def _counted_predictions(monkeypatch: pytest.MonkeyPatch) -> dict[str, int]:
    """The number of times a problem computes its predictions (a tree's or a loop robot's), counted from now on in
    the returned dict's ``count``."""
    from pincal.identification import predictions

    made = {"count": 0}
    for path in ("predict_tree", "predict_loops"):
        inner = getattr(predictions, path)

        def counted(*args: object, _inner: object = inner) -> object:
            made["count"] += 1
            return _inner(*args)  # type: ignore[operator]

        monkeypatch.setattr(predictions, path, counted)
    return made


@pytest.mark.parametrize("name", ["ur10", "delta"])
def test_a_tree_s_evaluations_are_recalled(name: str, monkeypatch: pytest.MonkeyPatch) -> None:
    """A tree's problem evaluates again at one of its last vectors without computing (a closed-loop robot's always
    computes: its solves follow their warm starts), giving what a problem nothing evaluated before computes there, to
    the last bit, Jacobian (with spare rows of zeros) or not; what it hands out is a copy the caller may change."""

    robot, models, pset, observations, rng = _end_effector_campaign(name, seed=5, n=12)
    made = _counted_predictions(monkeypatch)
    xs = [rng.normal(scale=1e-3, size=len(pset)) for _ in range(3)]
    problem = CalibrationProblem(robot, pset, models, observations)
    for x in xs:
        first = problem.evaluate(x, spare_rows=2)
        first.jacobian[:] = first.residual[:] = np.nan  # the caller's to change
    for x in reversed(xs):
        before = made["count"]
        again = problem.evaluate(x, spare_rows=3)
        alone = CalibrationProblem(robot, pset, models, observations).evaluate(x, spare_rows=3)
        assert made["count"] == before + 1 + bool(robot.loops)  # the fresh problem's, and a loop's own
        if robot.loops:  # solved from other warm starts: the same to the solver's tolerance, not to the bit
            np.testing.assert_allclose(again.residual, alone.residual, rtol=0, atol=1e-6)
            continue
        np.testing.assert_array_equal(again.residual, alone.residual)
        np.testing.assert_array_equal(again.jacobian, alone.jacobian)
        assert again.errors.keys() == alone.errors.keys()
        for key in alone.errors:
            np.testing.assert_array_equal(again.errors[key], alone.errors[key])
            np.testing.assert_array_equal(again.predicted[key], alone.predicted[key])
        assert problem.evaluate(x, jacobian=False).jacobian is None


def test_the_problem_s_robot_is_rebuilt_only_when_the_kinematic_deviations_move() -> None:
    robot = pincal.load_robot("delta")
    models = [ms.position("end_effector")]
    pset = candidate_parameters(robot, frames=["end_effector"], offsets=list(robot.actuated_joints), base=True)
    rng = np.random.default_rng(5)
    qa, _ = random_actuated(robot, 4, rng)
    problem = CalibrationProblem(robot, pset, models, Observations(qa, _blank(models, 4)))
    x = rng.normal(scale=1e-3, size=len(pset))
    placed = problem.placed_robot(x)
    kinematic = np.zeros(len(pset), dtype=bool)
    kinematic[problem.kinematic] = True
    moved = x.copy()
    moved[~kinematic] += 1e-3  # offsets and base only: the same placements
    assert problem.placed_robot(moved) is placed
    fresh = problem.robot_at(x)
    assert fresh is not placed
    for built, own in zip(fresh.model.jointPlacements, placed.model.jointPlacements, strict=True):
        assert np.array_equal(built.homogeneous, own.homogeneous)
    other = x.copy()
    other[problem.kinematic[0]] += 1e-3
    assert problem.placed_robot(other) is not placed
    # the evaluation on the kept robot is the one a new problem gives, number for number
    again = CalibrationProblem(robot, pset, models, Observations(qa, _blank(models, 4)))
    for step in (x, moved, other, x):
        ours, theirs = problem.evaluate(step), again.evaluate(step)
        assert ours.jacobian is not None and theirs.jacobian is not None
        assert np.array_equal(ours.residual, theirs.residual) and np.array_equal(ours.jacobian, theirs.jacobian)


def test_a_tree_s_start_is_recalled_after_later_evaluations(monkeypatch: pytest.MonkeyPatch) -> None:
    """The start's evaluation outlives the last few a tree's problem keeps: a refit from the start (model selection's,
    the setup's fit for "before") after a fit's steps evaluates there without computing, to the last bit."""
    robot, models, pset, observations, rng = _end_effector_campaign("ur10", seed=5, n=12)
    problem = CalibrationProblem(robot, pset, models, observations)
    start = problem.initial_guess()
    first = problem.evaluate(start, spare_rows=2)
    for _ in range(RECALLED + 2):  # more than the last evaluations kept
        problem.evaluate(start + rng.normal(scale=1e-4, size=start.size))
    made = _counted_predictions(monkeypatch)
    again = problem.evaluate(start, spare_rows=1)
    assert problem.evaluate(start, jacobian=False).jacobian is None
    assert made["count"] == 0
    np.testing.assert_array_equal(again.residual, first.residual)
    np.testing.assert_array_equal(again.jacobian[:-1], first.jacobian[:-2])
    assert not again.jacobian[-1].any()
