"""The Delta of study 000: pincal's general closed-loop solvers against the closed forms."""

from __future__ import annotations

import numpy as np
import pinocchio as pin
import pytest
from delta_closed_form import LB, forward, inverse

import pincal


def workspace_points(n: int, seed: int) -> np.ndarray:
    """Random platform positions [m] inside the Delta's usable workspace (reachable, arms in limits)."""
    rng = np.random.default_rng(seed)
    points = []
    while len(points) < n:
        p = np.array([*rng.uniform(-0.25, 0.25, 2), rng.uniform(-0.60, -0.25)])
        try:
            alpha = inverse(p)
        except ValueError:
            continue
        if np.all(alpha > -1.0) and np.all(alpha < 1.4):
            points.append(p)
    return np.array(points)


def test_reference_configuration_closes(delta: pincal.Robot) -> None:
    assert np.max(np.abs(delta.closure_residual(delta.q_reference))) < 1e-12
    assert delta.mobility() == 3
    assert delta.actuated_joints == ["arm_1_joint", "arm_2_joint", "arm_3_joint"]
    p = delta.placement(delta.q_reference, "end_effector").translation
    np.testing.assert_allclose(p, forward(np.zeros(3)), atol=1e-12)


def test_fk_matches_sphere_intersection_cold_start(delta: pincal.Robot) -> None:
    points = workspace_points(2000, seed=1)
    failures = 0
    for p in points:
        alpha = inverse(p)
        report = delta.solve_fk_report(alpha)
        if not report.converged:
            failures += 1
            continue
        assert np.max(np.abs(delta.closure_residual(report.q))) <= 1e-10
        np.testing.assert_allclose(delta.placement(report.q, "end_effector").translation, p, atol=1e-9)
        np.testing.assert_allclose(delta.actuated_values(report.q), alpha, atol=1e-12)
    assert failures / len(points) <= 1e-3


def test_ik_matches_closed_form_per_leg(delta: pincal.Robot) -> None:
    for p in workspace_points(200, seed=2):
        q = delta.solve_ik(p)
        np.testing.assert_allclose(delta.actuated_values(q), inverse(p), atol=1e-9)
        assert np.max(np.abs(delta.closure_residual(q))) <= 1e-10
        # the platform keeps the base's orientation
        np.testing.assert_allclose(delta.placement(q, "end_effector").rotation, np.eye(3), atol=1e-12)


def test_ik_accepts_a_consistent_se3_target(delta: pincal.Robot) -> None:
    p = workspace_points(1, seed=3)[0]
    q = delta.solve_ik(pin.SE3(np.eye(3), p))
    np.testing.assert_allclose(delta.placement(q, "end_effector").translation, p, atol=1e-10)


def test_fk_warm_start_follows_a_trajectory(delta: pincal.Robot) -> None:
    points = workspace_points(2, seed=4)
    q = delta.solve_ik(points[0])
    for s in np.linspace(0.0, 1.0, 50):
        p = (1 - s) * points[0] + s * points[1]
        q = delta.solve_fk(inverse(p), q_guess=q)
        np.testing.assert_allclose(delta.placement(q, "end_effector").translation, p, atol=1e-9)


def test_batch_fk_equals_single_solves(delta: pincal.Robot) -> None:
    alphas = np.array([inverse(p) for p in workspace_points(20, seed=5)])
    batch = delta.solve_fk_batch(alphas)
    for row, alpha in zip(batch, alphas, strict=True):
        np.testing.assert_allclose(row, delta.solve_fk(alpha), atol=1e-12)


def test_closed_loop_jacobian_matches_finite_differences(delta: pincal.Robot) -> None:
    for p in workspace_points(10, seed=6):
        alpha = inverse(p)
        q = delta.solve_fk(alpha)
        jac = delta.frame_jacobian_actuated(q, "end_effector")
        eps = 1e-6
        fd = np.empty((3, 3))
        for k in range(3):
            d = np.zeros(3)
            d[k] = eps
            fd[:, k] = (forward(alpha + d) - forward(alpha - d)) / (2 * eps)
        np.testing.assert_allclose(jac[:3], fd, atol=1e-8)
        np.testing.assert_allclose(jac[3:], 0.0, atol=1e-12)


def test_unreachable_target_raises_convergence_error(delta: pincal.Robot) -> None:
    # (every arm input of this Delta is reachable: three spheres of radius Lb around elbows at most
    # 0.79 m apart always meet; FK failure is tested on a four-bar in test_closure.py)
    with pytest.raises(pincal.ConvergenceError, match="did not reach"):
        delta.solve_ik(np.array([0.0, 0.0, -(LB + 0.5)]))
