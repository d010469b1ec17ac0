"""Batched closed-loop kinematics against Pinocchio and the per-sample solvers: forward kinematics, the loops'
residual and exact Jacobian (finite differences off the closure), warm and cold solves on the same assembly, the
refusals, and the structures it leaves to the per-sample solvers."""

from __future__ import annotations

import numpy as np
import pinocchio as pin
import pytest

import pincal
from pincal.model.batch_kinematics import BatchKinematics
from pincal.model.kinematics import CONTINUATION_STEP
from pincal.study.simulation import random_actuated

BATCHED = ["delta", "five_bar", "hexapod", "hexapod_device", "ucr3"]
TOL = 1e-11


def _samples(name: str, n: int = 15, seed: int = 0) -> tuple[pincal.Robot, np.ndarray, np.ndarray]:
    robot = pincal.load_robot(name)
    qa, q = random_actuated(robot, n, np.random.default_rng(seed))
    return robot, qa, q


@pytest.mark.parametrize("name", BATCHED)
def test_forward_kinematics_is_pinocchio_s(name: str) -> None:
    robot = pincal.load_robot(name)
    batch = robot.batch
    moves = np.random.default_rng(1).normal(scale=0.4, size=(6, robot.model.nv))
    q = np.array([pin.integrate(robot.model, pin.neutral(robot.model), move) for move in moves])
    placements = batch.forward(batch.geometry(robot.model, robot.closure), q)
    data = robot.model.createData()
    for k in range(len(q)):
        pin.forwardKinematics(robot.model, data, q[k])
        for j in range(1, robot.model.njoints):
            turned = data.oMi[j] * batch.turns[j - 1]
            np.testing.assert_allclose(placements.rotation(j)[k], turned.rotation, rtol=0, atol=1e-14)
            np.testing.assert_allclose(placements.translation(j)[k], turned.translation, rtol=0, atol=1e-14)


@pytest.mark.parametrize("name", BATCHED)
def test_residual_and_jacobian_are_the_closure_s(name: str) -> None:
    robot, _, q = _samples(name)
    state = robot.batch.state(robot.model, robot.closure, q)
    assert state.jacobian is not None
    for k in range(len(q)):
        residual, jacobian = robot.kinematics.closure_jacobian(q[k])
        np.testing.assert_allclose(state.residual[k], residual, rtol=0, atol=1e-14)
        np.testing.assert_allclose(state.jacobian[k], jacobian, rtol=0, atol=1e-13)


@pytest.mark.parametrize("name", BATCHED)
def test_the_jacobian_is_exact_off_the_closure(name: str) -> None:
    robot, _, q = _samples(name, n=3)
    batch, model = robot.batch, robot.model
    moves = np.random.default_rng(2).normal(scale=0.05, size=(len(q), model.nv))
    q = np.array([pin.integrate(model, row, move) for row, move in zip(q, moves, strict=True)])
    jacobian = batch.state(model, robot.closure, q).jacobian
    assert jacobian is not None
    h = 1e-6
    for i in range(model.nv):
        step = np.zeros(model.nv)
        step[i] = h
        ahead = np.array([pin.integrate(model, row, step) for row in q])
        behind = np.array([pin.integrate(model, row, -step) for row in q])
        slope = (batch.state(model, robot.closure, ahead, jacobian=False).residual
                 - batch.state(model, robot.closure, behind, jacobian=False).residual) / (2 * h)
        np.testing.assert_allclose(jacobian[:, :, i], slope, rtol=0, atol=1e-8)


@pytest.mark.parametrize("name", BATCHED)
def test_cold_and_warm_solves_are_the_per_sample_ones(name: str) -> None:
    robot, qa, q = _samples(name, n=25)
    batch, kin = robot.batch, robot.kinematics
    cold, ok = batch.solve(robot.model, robot.closure, qa, None, TOL)
    assert ok.all()
    np.testing.assert_allclose(cold, q, rtol=0, atol=1e-9)
    moved = qa + np.random.default_rng(3).normal(scale=0.002, size=qa.shape)
    warm, ok = batch.solve(robot.model, robot.closure, moved, q, TOL)
    assert ok.all()
    reference = np.array([kin.solve_fk(a, g, TOL).q for a, g in zip(moved, q, strict=True)])
    np.testing.assert_allclose(warm, reference, rtol=0, atol=1e-9)
    residual = batch.state(robot.model, robot.closure, warm, jacobian=False).residual
    assert np.abs(residual).max() <= TOL


@pytest.mark.parametrize("name", BATCHED)
def test_warm_starts_are_refused_where_the_per_sample_solver_refuses_them(name: str) -> None:
    """Inputs moved far (some out of the workspace): the batched warm starts that close are those the per-sample
    solver keeps, and on the same configurations."""
    robot, qa, q = _samples(name, n=25)
    moved = qa + np.random.default_rng(4).normal(scale=0.02, size=qa.shape)
    warm, ok = robot.batch.warm_solve(robot.model, robot.closure, moved, q, TOL)
    reports = [robot.kinematics.warm_solve(a, g, TOL) for a, g in zip(moved, q, strict=True)]
    np.testing.assert_array_equal(ok, [report is not None for report in reports])
    for k in np.flatnonzero(ok):
        np.testing.assert_allclose(warm[k], reports[k].q, rtol=0, atol=1e-9)


def test_a_far_guess_is_refused_and_solved_by_continuation() -> None:
    """A guess more than one continuation step away in actuated values is not a warm start (the per-sample rule):
    the sample comes back from continuation, on the reference assembly."""
    robot, qa, q = _samples("delta", n=6)
    batch = robot.batch
    far = qa.copy()
    far[0] += 2 * CONTINUATION_STEP
    _, warm = batch.warm_solve(robot.model, robot.closure, far, q, TOL)
    assert not warm[0] and warm[1:].all()
    solved, ok = batch.solve(robot.model, robot.closure, far, q, TOL)
    assert ok.all()
    np.testing.assert_allclose(solved[0], robot.solve_fk(far[0]), rtol=0, atol=1e-9)


def test_a_jump_is_refused() -> None:
    """Newton that would move a passive joint by more than one continuation step stops, unconverged."""
    robot, _, q = _samples("delta", n=4)
    batch = robot.batch
    guesses = batch.retract(q, np.array([0.0, 1.2, 0.0, 0.0])[:, None] * np.ones(len(batch.passive_v)))  # sample 1
    solved, _, converged = batch.close_loops(robot.model, robot.closure, guesses, TOL, max_move=CONTINUATION_STEP)
    assert converged[[0, 2, 3]].all() and not converged[1]
    assert np.abs(batch.passive_difference(solved, guesses)[1]).max() > CONTINUATION_STEP


def test_solve_fk_batch_matches_solve_fk() -> None:
    robot, qa, q = _samples("five_bar", n=10)
    np.testing.assert_allclose(robot.solve_fk_batch(qa), q, rtol=0, atol=1e-9)
    moved = qa + 0.01
    reference = np.array([robot.solve_fk(a, g) for a, g in zip(moved, q, strict=True)])
    np.testing.assert_allclose(robot.solve_fk_batch(moved, q), reference, rtol=0, atol=1e-9)
    np.testing.assert_allclose(robot.solve_fk_batch(moved[:1], q[0]), reference[:1], rtol=0, atol=1e-9)


def test_another_joint_kind_is_left_to_the_per_sample_solvers() -> None:
    """A spherical joint (three coordinates, a quaternion) is not one the batched kinematics takes: it says which."""
    from pincal.model.closure import LoopClosure
    from pincal.model.kinematics import ActuatedJoint, ClosedLoopKinematics

    model = pin.Model()
    hinge = model.addJoint(0, pin.JointModelRZ(), pin.SE3.Identity(), "hinge")
    model.addJoint(hinge, pin.JointModelSpherical(), pin.SE3.Identity(), "ball")
    kinematics = ClosedLoopKinematics(model, LoopClosure(model, []), [ActuatedJoint("hinge", hinge, 0, 0, 1)])
    assert BatchKinematics(kinematics).unsupported == "joint 'ball' (JointModelSpherical)"
