"""Inverse kinematics of many targets at once (``pincal.model.batch_ik`` on ``pincal.model.frame_kinematics``) against
the per-sample solvers of ``ClosedLoopKinematics``: the frame's placements and Jacobians (through the loops too) equal
Pinocchio's; every target converges where, and to what, the per-sample solver converges from the same start; the
stacked and the row-by-row arithmetic agree; the answers do not depend on the other rows."""

from __future__ import annotations

import numpy as np
import pinocchio as pin
import pytest

import pincal
from pincal.model.batch_ik import Goals, actuated_newton, solve_ik
from pincal.model.frame_kinematics import BatchFrame, FrameKinematics, SampleFrame
from pincal.model.robot import SOLVE_TOLERANCE
from pincal.study.simulation import random_actuated

#: robot, frame, target kind: the closed loops of the Delta and the hexapod, a six-axis arm by a point and by a pose
CASES = [("delta", "end_effector", "position"), ("hexapod", "end_effector", "pose"), ("ur10", "tool0", "position"),
         ("ur10", "tool0", "pose")]
N = 48


def _goals(robot: pincal.Robot, frame: str, kind: str, seed: int) -> tuple[Goals, list[pin.SE3 | np.ndarray]]:
    _, q = random_actuated(robot, N, np.random.default_rng(seed))
    placements = [robot.placement(config, frame) for config in q]
    if robot.name == "delta":  # a third of them out of reach: the failures must agree too
        placements = [pin.SE3(m.rotation, m.translation + np.array([0.0, 0.0, 0.15 * (k % 3 == 0)]))
                      for k, m in enumerate(placements)]
    goals = Goals(np.array([m.translation for m in placements]),
                  np.array([m.rotation for m in placements]) if kind == "pose" else None)
    return goals, [m if kind == "pose" else m.translation for m in placements]


@pytest.mark.parametrize(("name", "frame", "kind"), CASES)
def test_the_frame_at_many_configurations_is_pinocchios(name: str, frame: str, kind: str) -> None:
    robot = pincal.load_robot(name)
    kin, fid = robot.kinematics, robot.frame_id(frame)
    _, q = random_actuated(robot, N, np.random.default_rng(1))
    for frames in (BatchFrame(robot.batch, fid, SOLVE_TOLERANCE), SampleFrame(kin, fid, SOLVE_TOLERANCE)):
        state = frames.state(q)
        actuated = state.actuated_jacobian(kin)
        for k, config in enumerate(q):
            placement = robot.placement(config, frame)
            np.testing.assert_allclose(state.origin[k], placement.translation, atol=1e-12)
            np.testing.assert_allclose(state.rotation[k], placement.rotation, atol=1e-12)
            np.testing.assert_allclose(state.jacobian[k], kin.frame_jacobian(config, fid, pin.LOCAL_WORLD_ALIGNED),
                                       atol=1e-12)
            np.testing.assert_allclose(actuated[k], kin.frame_jacobian_actuated(config, fid), atol=1e-10)
        closed, ok = frames.forward(frames.actuated_values(q), None)
        assert ok.all()
        np.testing.assert_allclose(closed, q, atol=1e-9)  # random_actuated's postures are reference assemblies


@pytest.mark.parametrize(("name", "frame", "kind"), CASES)
def test_many_targets_are_solved_as_each_alone(name: str, frame: str, kind: str) -> None:
    robot = pincal.load_robot(name)
    kin, fid = robot.kinematics, robot.frame_id(frame)
    goals, targets = _goals(robot, frame, kind, seed=2)
    alone = [kin.solve_ik(target, fid, robot.q_reference.copy(), SOLVE_TOLERANCE) for target in targets]
    converged = np.array([report.converged for report in alone])
    assert converged.sum() >= N // 2
    start = np.tile(robot.q_reference, (N, 1))
    for frames in (BatchFrame(robot.batch, fid, SOLVE_TOLERANCE), SampleFrame(kin, fid, SOLVE_TOLERANCE)):
        solved = solve_ik(frames, goals, start, SOLVE_TOLERANCE)
        np.testing.assert_array_equal(solved.converged, converged)
        for k in np.flatnonzero(converged):
            np.testing.assert_allclose(solved.q[k], alone[k].q, atol=1e-9, err_msg=f"target {k}")
        # reversed, the rows' answers are the same: no row reads another
        backwards = solve_ik(frames, goals.take(np.arange(N)[::-1]), start, SOLVE_TOLERANCE)
        np.testing.assert_allclose(backwards.q[::-1][converged], solved.q[converged], atol=1e-12)


def _actuated_answer(frames: FrameKinematics, goals: Goals, start: np.ndarray, lower: np.ndarray,
                     upper: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
    solved = actuated_newton(frames, goals, start, lower, upper, SOLVE_TOLERANCE)
    return solved.q, solved.converged


def test_gauss_newton_over_the_actuated_joints_stays_within_their_limits() -> None:
    """The Delta's arms limited to a narrow range: the targets the range reaches are reached with every arm inside it,
    the others are not, in both arithmetics alike."""
    robot = pincal.load_robot("delta")
    kin, fid = robot.kinematics, robot.frame_id("end_effector")
    goals, _ = _goals(robot, "end_effector", "position", seed=3)
    lower, upper = np.full(3, -0.3), np.full(3, 0.9)
    start = np.zeros((N, 3))
    results = [_actuated_answer(frames, goals, start, lower, upper)
               for frames in (BatchFrame(robot.batch, fid, SOLVE_TOLERANCE), SampleFrame(kin, fid, SOLVE_TOLERANCE))]
    (q, ok), (q_rows, ok_rows) = results
    np.testing.assert_array_equal(ok, ok_rows)
    assert 0 < ok.sum() < N
    values = q[ok][:, [a.idx_q for a in kin.actuated]]
    assert np.all(values >= lower - 1e-12) and np.all(values <= upper + 1e-12)
    for k in np.flatnonzero(ok):
        np.testing.assert_allclose(robot.placement(q[k], "end_effector").translation, goals.positions[k], atol=1e-10)
        np.testing.assert_allclose(q[k], q_rows[k], atol=1e-9)
