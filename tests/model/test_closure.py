"""Loop-closure residuals and Jacobians: every loop type against finite differences, and the
small mechanisms against their closed forms."""

from __future__ import annotations

import math

import numpy as np
import pinocchio as pin
import pytest
from mechanisms import (
    FOUR_BAR_CRANK_HOME,
    four_bar_rocker_angle,
    four_bar_urdf,
    slider_crank_urdf,
    slider_position,
)

import pincal
from pincal.model.closure import LoopClosure
from pincal.model.urdf import LOOP_ROWS, LoopSpec


def _random_se3(rng: np.random.Generator) -> pin.SE3:
    return pin.exp6(rng.normal(size=6) * 0.5)


@pytest.mark.parametrize("kind", sorted(LOOP_ROWS))
def test_loop_jacobian_matches_finite_differences(kind: str) -> None:
    """Anywhere on a UR10 (loops not closed), for every loop type, dc/dv equals finite differences."""
    robot = pincal.load_robot("ur10")
    model = robot.model
    rng = np.random.default_rng(7)
    axis = rng.normal(size=3)
    spec = LoopSpec("test", kind, "forearm_link", _random_se3(rng), "wrist_3_link", _random_se3(rng),
                    axis / np.linalg.norm(axis))
    closure = LoopClosure(model, [spec])
    data = model.createData()
    for _ in range(5):
        q = rng.uniform(-np.pi, np.pi, model.nq)  # seeded (Pinocchio's own generator is not)
        pin.computeJointJacobians(model, data, q)
        r, jac = closure.residual_and_jacobian(data)
        assert r.shape == (LOOP_ROWS[kind],)
        fd = np.empty_like(jac)
        eps = 1e-7
        for k in range(model.nv):
            dv = np.zeros(model.nv)
            dv[k] = eps
            pin.forwardKinematics(model, data, pin.integrate(model, q, dv))
            plus = closure.residual(data)
            pin.forwardKinematics(model, data, pin.integrate(model, q, -dv))
            fd[:, k] = (plus - closure.residual(data)) / (2 * eps)
        np.testing.assert_allclose(jac, fd, atol=1e-7)


def test_four_bar_revolute_loop_against_closed_form() -> None:
    robot = pincal.model.robot.robot_from_urdf_text(four_bar_urdf())
    assert robot.mobility() == 1
    for crank in np.linspace(FOUR_BAR_CRANK_HOME - 0.35, FOUR_BAR_CRANK_HOME + 0.35, 21):
        q = robot.solve_fk(np.array([crank - FOUR_BAR_CRANK_HOME]))
        rocker = q[robot.model.joints[robot.model.getJointId("rocker_joint")].idx_q]
        home_rocker = four_bar_rocker_angle(FOUR_BAR_CRANK_HOME)
        expected = four_bar_rocker_angle(crank) - home_rocker
        assert math.isclose(math.remainder(rocker - expected, 2 * math.pi), 0.0, abs_tol=1e-9)
        assert np.max(np.abs(robot.closure_residual(q))) <= 1e-10


def test_four_bar_unreachable_crank_angle_raises() -> None:
    robot = pincal.model.robot.robot_from_urdf_text(four_bar_urdf())
    with pytest.raises(pincal.ConvergenceError, match=r"crank_joint.*closure residual"):
        robot.solve_fk(np.array([math.pi]))


def test_slider_crank_prismatic_loop_against_closed_form() -> None:
    robot = pincal.model.robot.robot_from_urdf_text(slider_crank_urdf())
    assert robot.mobility() == 1
    for crank in np.linspace(-math.pi, math.pi, 37):
        q = robot.solve_fk(np.array([crank]), q_guess=None)
        block = robot.placement(q, "block")
        home = math.pi / 2
        np.testing.assert_allclose(block.translation, [slider_position(home + crank), 0.0, 0.0], atol=1e-9)
        np.testing.assert_allclose(block.rotation, np.eye(3), atol=1e-9)


def test_slider_crank_jacobian_through_the_loop() -> None:
    robot = pincal.model.robot.robot_from_urdf_text(slider_crank_urdf())
    home = math.pi / 2
    for crank in (-1.0, 0.3, 2.0):
        q = robot.solve_fk(np.array([crank]))
        jac = robot.frame_jacobian_actuated(q, "block")
        eps = 1e-6
        fd = (slider_position(home + crank + eps) - slider_position(home + crank - eps)) / (2 * eps)
        np.testing.assert_allclose(jac[:, 0], [fd, 0, 0, 0, 0, 0], atol=1e-8)


def test_continuous_crank_takes_the_short_way_round() -> None:
    """An unbounded crank (nq = 2): readings past ±π are the same angle, not a full turn away."""
    from pincal.identification import measurements as ms
    from pincal.identification.parameters import candidate_parameters
    from pincal.identification.problem import CalibrationProblem, Observations

    crank_rocker = {"a": 0.1, "b": 0.3, "c": 0.25, "d": 0.3}  # Grashof, crank shortest: it turns fully
    robot = pincal.model.robot.robot_from_urdf_text(four_bar_urdf(crank_rocker, home=0.0, crank="continuous"))
    assert robot.model.joints[robot.model.getJointId("crank_joint")].nq == 2
    q = robot.solve_fk(np.array([3.0]))
    across = robot.solve_fk_report(np.array([-3.0]), q)  # 0.28 rad further on, across ±π
    assert across.converged and across.iterations <= 10
    direct = robot.solve_fk(np.array([2 * math.pi - 3.0]))
    for link in ("coupler", "rocker"):  # the same mechanism pose (passive angles may differ by 2π)
        np.testing.assert_allclose(robot.placement(across.q, link).homogeneous,
                                   robot.placement(direct, link).homogeneous, atol=1e-9)
    # an encoder on the crank that counts past π reads 3.2 where atan2 gives 3.2 - 2π: no 2π residual
    pset = candidate_parameters(robot, offsets=[])
    reading = ms.joint_reading("crank_joint")
    problem = CalibrationProblem(robot, pset, [reading],
                                 Observations(np.array([[3.2]]), {reading.key: np.array([[3.2]])}))
    assert np.max(np.abs(problem.evaluate(np.zeros(len(pset)), jacobian=False).residual)) < 1e-6
