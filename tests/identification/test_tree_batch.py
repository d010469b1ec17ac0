"""The batched evaluation of trees against the per-sample one it replaces: every tree robot the tests use, every
measurement kind, markers and clusters with occluded readings, cameras and targets, harmonics and compliance, with
and without the joint readings' noise; the per-sample path is the reference (and the closed loops' path)."""

from __future__ import annotations

from collections.abc import Callable
from dataclasses import dataclass
from typing import ClassVar

import numpy as np
import pinocchio as pin
import pytest
from conftest import random_readings
from test_measurements import Height

import pincal
from pincal.identification import measurements as ms
from pincal.identification import predictions
from pincal.identification.parameters import (
    ParameterSet,
    choose_parameters,
    cluster_parameters,
    marker_parameters,
    parameter_pool,
)
from pincal.identification.problem import CalibrationProblem, Observations
from pincal.model.joint_motion import joint_motion
from pincal.study.simulation import random_actuated

#: Largest gap between the batched and the per-sample evaluation, relative to the largest entry.
AGREEMENT = 1e-10
N_SAMPLES = 6


def _ur10() -> list[ms.Measurement]:
    return [ms.position("tool0"), ms.pose("tool0"), ms.distance("tool0", "base_link"),
            ms.distance("tool0", "base_link", increment=True), ms.joint_reading("elbow_joint"),
            Height("height:tool0", 1, 1e-6, "tool0")]


def _tiago() -> list[ms.Measurement]:
    frame = "wrist_ft_tool_link"
    nominal = {"m1": (0.05, 0.0, 0.02), "m2": (-0.03, 0.04, 0.0), "m3": (0.0, -0.02, 0.06)}
    return [*(ms.position(frame, marker=m, nominal=n) for m, n in nominal.items()), ms.position(frame),
            ms.pose("torso_lift_link"), ms.distance(frame, "base_footprint"), ms.joint_reading("wheel_left_joint"),
            ms.pose("wheel_right_link")]  # a continuous joint in the chain


def _panda() -> list[ms.Measurement]:
    return [ms.position("panda_rightfinger"), ms.pose("panda_leftfinger"), ms.pose("panda_hand_tcp")]


def _cameras() -> list[ms.Measurement]:
    return [ms.camera_pose("tool0"), ms.camera_point("tool0"), ms.pose("wrist_2_link", target="tag")]


def _planes() -> list[ms.Measurement]:
    return [ms.plane_point("tool0"), ms.plane_contact("tool0", "forearm_link"), ms.plane_contact("wrist_2_link")]


def _passive() -> list[ms.Measurement]:
    return [ms.position("tool0"), ms.joint_reading("wrist_3_joint")]


def _ur10_passive_wrist() -> pincal.Robot:
    """The UR10 with its last joint not actuated (held at its reference, read by a sensor with a zero offset)."""
    robot = pincal.load_robot("ur10")
    return pincal.Robot(robot.model, [], robot.actuated_joints[:-1], "ur10_passive_wrist")


#: Case -> its robot and measurements (every kind, on every tree robot the tests load).
CASES: dict[str, tuple[Callable[[], pincal.Robot], Callable[[], list[ms.Measurement]]]] = {
    "ur10": (lambda: pincal.load_robot("ur10"), _ur10),
    "tiago markers": (lambda: pincal.load_robot("tiago_no_hand"), _tiago),
    "panda mimic": (lambda: pincal.load_robot("panda"), _panda),
    "ur10 cameras": (lambda: pincal.load_robot("ur10"), _cameras),
    "ur10 planes": (lambda: pincal.load_robot("ur10"), _planes),
    "ur10 passive wrist": (_ur10_passive_wrist, _passive)}

#: Placements far from the identity [m, rad] for the cameras and targets (exp6's Jacobian matters there).
FAR = {"camera.tool0.tx": 0.05, "camera.tool0.rx": 0.4, "camera.tool0.ry": -1.2, "camera.tool0.rz": 2.0,
       "target.tx": 1.0, "target.ty": 0.4, "target.rz": -0.8, "target.wrist_2_link@tag.tz": 0.08,
       "target.wrist_2_link@tag.rx": 1.0, "base.tx": 2.0, "base.rz": 1.5, "base.rx": 0.2,
       "plane.tz": 0.4, "plane.rx": 0.3, "plane.forearm_link.ry": -0.5}


def _problems(name: str, joint_sigma: float | None) -> tuple[CalibrationProblem, CalibrationProblem, np.ndarray]:
    """The batched and the per-sample problem on the same data: all parameters the pool offers (harmonics and
    compliance included), declared markers with their offsets and cluster, some readings missing."""
    robot_of, models_of = CASES[name]
    robot = robot_of()
    models = models_of()
    actuated_readings = [m for m in models if isinstance(m, ms.JointReading) and m.joint in robot.actuated_joints]
    pool = parameter_pool(robot, [m for m in models if m not in actuated_readings])  # their offsets are there
    extra = [p for m in models if isinstance(m, ms.Position) and m.marker for p in marker_parameters(m.marker_key)]
    clusters = sorted({m.frame for m in models if isinstance(m, ms.Position) and m.marker})
    pset = ParameterSet(pool.parameters + [p for p in extra + [c for f in clusters for c in cluster_parameters(f)]
                                           if p.name not in pool])
    rng = np.random.default_rng(17)
    qa, _ = random_actuated(robot, N_SAMPLES, rng)
    values = random_readings(models, N_SAMPLES, rng)
    made = [CalibrationProblem(robot, pset, models, Observations(qa, dict(values)), joint_sigma=joint_sigma)
            for _ in range(2)]
    made[1]._batched_trees = False
    x = rng.normal(scale=1e-2, size=len(pset))
    for key, value in FAR.items():
        if key in pset:
            x[pset.index(key)] = value
    return made[0], made[1], x


@pytest.mark.parametrize("joint_sigma", [None, 1e-3])
@pytest.mark.parametrize("name", sorted(CASES))
def test_batched_evaluation_equals_the_per_sample_one(name: str, joint_sigma: float | None) -> None:
    batched, per_sample, x = _problems(name, joint_sigma)
    assert batched._batched_trees, batched.tree_batch.unsupported if batched.tree_batch else "no tree"
    kinds = {p.kind for p in batched.parameters}
    assert {"harmonic", "compliance", "offset", "joint"} <= kinds
    for jacobian in (True, False):
        a, b = batched.evaluate(x, jacobian), per_sample.evaluate(x, jacobian)
        scale = np.abs(b.residual).max()
        assert np.abs(a.residual - b.residual).max() <= AGREEMENT * scale
        for key in b.errors:
            np.testing.assert_array_equal(np.isnan(a.errors[key]), np.isnan(b.errors[key]))
            np.testing.assert_allclose(a.predicted[key], b.predicted[key], rtol=0, atol=1e-12, equal_nan=True)
        if jacobian:
            assert a.jacobian is not None and b.jacobian is not None
            worst = np.abs(a.jacobian - b.jacobian).max(axis=0) / np.abs(b.jacobian).max()
            assert worst.max() <= AGREEMENT, f"column {batched.parameters.names[int(np.argmax(worst))]}: {worst.max()}"
        else:
            assert a.jacobian is None and b.jacobian is None


@pytest.mark.parametrize("name", ["ur10", "tiago markers"])
def test_the_batched_evaluation_by_blocks_of_samples_is_the_same(name: str, monkeypatch: pytest.MonkeyPatch) -> None:
    """Blocks of 4 samples (6 in all: a full block and a partial one), the incremental distance across them."""
    batched, per_sample, x = _problems(name, 1e-3)
    whole = batched.evaluate(x)
    monkeypatch.setattr(predictions, "BATCH_SAMPLES", 4)
    blocks, reference = batched.evaluate(x), per_sample.evaluate(x)
    assert blocks.jacobian is not None and reference.jacobian is not None and whole.jacobian is not None
    np.testing.assert_allclose(blocks.residual, whole.residual, rtol=0, atol=1e-12 * np.abs(whole.residual).max())
    np.testing.assert_allclose(blocks.jacobian, reference.jacobian, rtol=0,
                               atol=AGREEMENT * np.abs(reference.jacobian).max())


def test_a_second_evaluation_reuses_nothing_it_returned() -> None:
    """The batched path keeps its intermediates from one evaluation to the next; what it returned stays as it was."""
    batched, _, x = _problems("ur10", None)
    first = batched.evaluate(x)
    kept = (first.residual.copy(), None if first.jacobian is None else first.jacobian.copy())
    batched.evaluate(x + 1e-3)
    np.testing.assert_array_equal(first.residual, kept[0])
    np.testing.assert_array_equal(first.jacobian, kept[1])


@pytest.mark.parametrize("name", ["ur10", "delta"])
def test_the_jacobian_written_in_place_is_the_copied_one(name: str, monkeypatch: pytest.MonkeyPatch) -> None:
    """Every reading taken, no joint noise: the models write the Jacobian's own rows, scaled in place (one m × p
    array); the same numbers, bit for bit, as the derivative blocks copied out, and a second evaluation leaves the
    first one's Jacobian as it was."""
    robot = pincal.load_robot(name)
    models = [ms.position(robot.end_effector),
              ms.Distance.from_key("distance", f"{robot.end_effector}-{robot.model.frames[1].name}", None)]
    pset = choose_parameters(robot, models)
    rng = np.random.default_rng(4)
    qa, _ = random_actuated(robot, 7, rng)
    values = {m.key: np.ones((7, m.size)) for m in models}
    problem = CalibrationProblem(robot, pset, models, Observations(qa, values))
    assert problem._in_place(True)
    x = rng.normal(scale=1e-3, size=len(pset))
    direct = problem.evaluate(x)
    kept = np.array(direct.jacobian)
    monkeypatch.setattr(CalibrationProblem, "_in_place", lambda self, output_jacobian: False)
    copied = problem.evaluate(x)
    np.testing.assert_array_equal(direct.jacobian, copied.jacobian)
    np.testing.assert_array_equal(direct.residual, copied.residual)
    problem.evaluate(x + 1e-3)
    np.testing.assert_array_equal(direct.jacobian, kept)


@dataclass(frozen=True)
class _SubclassedPosition(ms.Position):
    """A user's variant of a batched model that changes only the per-sample prediction (doubles the position)."""

    kinds: ClassVar[tuple[str, ...]] = ()

    def predict(self, ctx: ms.SampleContext, out: np.ndarray, jac: np.ndarray | None) -> None:
        super().predict(ctx, out, jac)
        out *= 2.0
        if jac is not None:
            jac *= 2.0


def test_only_a_model_s_own_batched_prediction_is_used() -> None:
    """A model without ``predict_batch`` (the test's Height), or one that overrides ``predict`` below the class that
    batches it, is predicted sample by sample inside the batched evaluation, with the same result."""
    assert ms.position("tool0").batched and ms.camera_pose("tool0").batched and ms.joint_reading("a").batched
    assert not Height("height:tool0", 1, 1e-6, "tool0").batched
    doubled = _SubclassedPosition("doubled:tool0", 3, 1e-5, "tool0")
    assert not doubled.batched
    robot = pincal.load_robot("ur10")
    models = [ms.position("tool0"), doubled]
    pset = parameter_pool(robot, models)
    qa, _ = random_actuated(robot, 4, np.random.default_rng(2))
    problem = CalibrationProblem(robot, pset, models, Observations(qa, {m.key: np.zeros((4, 3)) for m in models}))
    pred = problem.evaluate(np.random.default_rng(3).normal(scale=1e-3, size=len(pset)))
    np.testing.assert_allclose(pred.predicted[doubled.key], 2 * pred.predicted["position:tool0"], rtol=1e-14)
    assert pred.jacobian is not None
    np.testing.assert_allclose(pred.jacobian[12:], 2 * pred.jacobian[:12], rtol=1e-12, atol=1e-9)


def test_closed_loops_and_other_joints_are_evaluated_sample_by_sample() -> None:
    delta = pincal.load_robot("delta")
    pset = ParameterSet([p for p in parameter_pool(delta, [ms.position("end_effector")]) if p.kind != "compliance"])
    qa, _ = random_actuated(delta, 2, np.random.default_rng(1))
    problem = CalibrationProblem(delta, pset, [ms.position("end_effector")],
                                 Observations(qa, {"position:end_effector": np.zeros((2, 3))}))
    assert problem.tree_batch is None and not problem._batched_trees
    model = pin.Model()
    ball = model.addJoint(0, pin.JointModelSpherical(), pin.SE3.Identity(), "ball")
    hinge = model.addJoint(ball, pin.JointModelRevoluteUnaligned(np.array([0.0, 0.6, 0.8])), pin.SE3.Random(),
                           "hinge")
    slide = model.addJoint(hinge, pin.JointModelPrismaticUnaligned(np.array([0.6, 0.0, -0.8])), pin.SE3.Random(),
                           "slide")
    assert joint_motion(model, ball) is None
    for joint, revolute in ((hinge, True), (slide, False)):
        motion = joint_motion(model, joint)
        assert motion is not None and motion.revolute == revolute and motion.rate == pytest.approx(1.0)
