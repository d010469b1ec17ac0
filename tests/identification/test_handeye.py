"""Closed-form hand-eye starting values: exact on perfect data, a few × the noise on noisy data, and a
DataError naming what is missing on data that cannot determine the unknowns."""

from __future__ import annotations

import numpy as np
import pinocchio as pin
import pytest

from pincal.errors import DataError
from pincal.identification.handeye import (
    solve_ax_yb,
    solve_ax_yb_translating,
    solve_point_eye_in_hand,
    solve_point_translating,
)

NOISE = 1e-4  # [m] and [rad]
X_TRUE = pin.SE3(pin.exp3(np.array([0.3, -0.5, 0.8])), np.array([0.05, 0.02, 0.10]))  # link ← camera
Y_TRUE = pin.SE3(pin.exp3(np.array([-1.0, 0.5, 0.2])), np.array([0.5, -0.3, 1.2]))  # world ← target / camera ← world
POINT_WORLD = np.array([0.8, 0.2, 0.3])  # [m], eye in hand


def random_pose(rng: np.random.Generator, angle: float = np.pi, axis: np.ndarray | None = None) -> pin.SE3:
    """A rotation of up to ``angle`` about a uniformly random axis (or ``axis``), a translation within ±1 m."""
    direction = rng.normal(size=3) if axis is None else np.asarray(axis, dtype=float)
    rotation = pin.exp3(direction / np.linalg.norm(direction) * rng.uniform(-angle, angle))
    return pin.SE3(rotation, rng.uniform(-1.0, 1.0, 3))


def perturbed(pose: pin.SE3, rng: np.random.Generator, sigma: float) -> pin.SE3:
    return pose * pin.exp6(pin.Motion(rng.normal(0.0, sigma, 3), rng.normal(0.0, sigma, 3)))


def errors(estimate: pin.SE3, truth: pin.SE3) -> tuple[float, float]:
    """Rotation error [rad] and translation error [m]."""
    angle = float(np.linalg.norm(pin.log3(estimate.rotation.T @ truth.rotation)))
    return angle, float(np.linalg.norm(estimate.translation - truth.translation))


def ax_yb_data(rng: np.random.Generator, n: int, sigma: float = 0.0, angle: float = np.pi,
               axis: np.ndarray | None = None) -> tuple[list[pin.SE3], list[pin.SE3]]:
    a = [random_pose(rng, angle, axis) for _ in range(n)]
    b = [perturbed(Y_TRUE.inverse() * ai * X_TRUE, rng, sigma) for ai in a]
    return a, b


def eye_in_hand_points(a: list[pin.SE3], rng: np.random.Generator, sigma: float = 0.0) -> np.ndarray:
    points = np.array([(X_TRUE.inverse() * ai.inverse()).act(POINT_WORLD) for ai in a])
    return points + rng.normal(0.0, sigma, points.shape)


# --- AX = YB ---------------------------------------------------------------------------------------------


@pytest.mark.parametrize("n", [3, 10, 40])
def test_ax_yb_recovers_x_and_y_exactly(n: int) -> None:
    a, b = ax_yb_data(np.random.default_rng(n), n)
    x, y = solve_ax_yb(a, b)
    assert max(errors(x, X_TRUE)) < 1e-9
    assert max(errors(y, Y_TRUE)) < 1e-9
    assert np.linalg.det(x.rotation) == pytest.approx(1.0)


def test_ax_yb_within_a_few_times_the_noise() -> None:
    rng = np.random.default_rng(1)
    a, b = ax_yb_data(rng, 30, NOISE)
    x, y = solve_ax_yb(a, b)
    for estimate, truth in ((x, X_TRUE), (y, Y_TRUE)):
        rotation_error, translation_error = errors(estimate, truth)
        assert rotation_error < 3 * NOISE
        assert translation_error < 3 * NOISE


@pytest.mark.parametrize("sigma", [0.0, NOISE])
def test_ax_yb_rotations_about_one_axis_are_refused(sigma: float) -> None:
    rng = np.random.default_rng(2)
    a, b = ax_yb_data(rng, 20, axis=np.array([0.0, 0.0, 1.0]))
    a = [perturbed(ai, rng, sigma) for ai in a]
    with pytest.raises(DataError, match=r"differ only about z.*two non-parallel axes"):
        solve_ax_yb(a, b)


def test_ax_yb_refusal_is_set_by_the_tolerance() -> None:
    rng = np.random.default_rng(3)
    a, b = ax_yb_data(rng, 20, axis=np.array([1.0, 1.0, 0.0]))
    a = [perturbed(ai, rng, NOISE) for ai in a]
    with pytest.raises(DataError, match=r"differ only about one axis, \[0.707, 0.707, 0.000\]"):
        solve_ax_yb(a, b)
    solve_ax_yb(a, b, tol=1e-6)  # the noise does separate the axes, if badly


def test_ax_yb_needs_three_poses_and_distinct_rotations() -> None:
    rng = np.random.default_rng(4)
    a, b = ax_yb_data(rng, 2)
    with pytest.raises(DataError, match=r"at least 3 poses.*got 2"):
        solve_ax_yb(a, b)
    same = [pin.SE3(a[0].rotation, rng.uniform(-1.0, 1.0, 3)) for _ in range(6)]
    with pytest.raises(DataError, match="all have the same rotation"):
        solve_ax_yb(same, [Y_TRUE.inverse() * ai * X_TRUE for ai in same])
    with pytest.raises(DataError, match="one B per A; got 2 A and 1 B"):
        solve_ax_yb(a, b[:1])


# --- a point fixed in the world, camera on the link --------------------------------------------------------


@pytest.mark.parametrize("n", [5, 12, 40])
def test_eye_in_hand_recovers_camera_and_point_exactly(n: int) -> None:
    rng = np.random.default_rng(10 + n)
    a = [random_pose(rng) for _ in range(n)]
    x, point = solve_point_eye_in_hand(a, eye_in_hand_points(a, rng))
    assert max(errors(x, X_TRUE)) < 1e-9
    assert np.linalg.norm(point - POINT_WORLD) < 1e-9


def test_eye_in_hand_within_a_few_times_the_noise() -> None:
    rng = np.random.default_rng(11)
    a = [random_pose(rng) for _ in range(30)]
    p = eye_in_hand_points(a, rng, NOISE)
    x, point = solve_point_eye_in_hand([perturbed(ai, rng, NOISE) for ai in a], p)
    rotation_error, translation_error = errors(x, X_TRUE)
    assert rotation_error < 3 * NOISE
    assert translation_error < 3 * NOISE
    assert np.linalg.norm(point - POINT_WORLD) < 3 * NOISE


@pytest.mark.parametrize("sigma", [0.0, NOISE])
def test_eye_in_hand_rotations_about_one_axis_are_refused(sigma: float) -> None:
    rng = np.random.default_rng(12)
    a = [random_pose(rng, axis=np.array([0.0, 0.0, 1.0])) for _ in range(20)]
    p = eye_in_hand_points(a, rng, sigma)
    with pytest.raises(DataError, match="link rotations differ only about z in the world frame"):
        solve_point_eye_in_hand([perturbed(ai, rng, sigma) for ai in a], p)


def test_eye_in_hand_points_in_one_camera_plane_are_refused() -> None:
    rng = np.random.default_rng(13)
    p = np.column_stack([rng.uniform(-0.2, 0.2, (20, 2)), np.full(20, 0.5)])  # all at 0.5 m depth
    a = []
    for point in p:
        rotation = random_pose(rng).rotation
        a.append(pin.SE3(rotation, POINT_WORLD - rotation @ X_TRUE.act(point)))  # A_i X p_i = y
    with pytest.raises(DataError, match="lie in one plane of the camera frame"):
        solve_point_eye_in_hand(a, p)


def test_eye_in_hand_malformed_inputs() -> None:
    rng = np.random.default_rng(14)
    a = [random_pose(rng) for _ in range(6)]
    p = eye_in_hand_points(a, rng)
    with pytest.raises(DataError, match=r"at least 5 samples.*got 4"):
        solve_point_eye_in_hand(a[:4], p[:4])
    with pytest.raises(DataError, match=r"p as \(6, 3\).*\(5, 3\)"):
        solve_point_eye_in_hand(a, p[:5])
    p[2, 1] = np.nan
    with pytest.raises(DataError, match=r"NaN/inf entries in samples \[2\]"):
        solve_point_eye_in_hand(a, p)


# --- a link that only translates (a Delta's platform) ------------------------------------------------------


def translating(rng: np.random.Generator, n: int) -> list[pin.SE3]:
    """Poses of one rotation, translations within ±0.2 m."""
    rotation = pin.exp3(np.array([0.2, -0.1, 0.4]))
    return [pin.SE3(rotation, rng.uniform(-0.2, 0.2, 3)) for _ in range(n)]


def test_a_translating_link_gives_the_rotations_and_what_the_data_see_of_the_translations() -> None:
    """Exact on perfect data: both rotations, and the translations through ``t_Y − R_A t_X`` (``t_X`` taken as 0)."""
    rng = np.random.default_rng(21)
    a = translating(rng, 8)
    x, y = solve_ax_yb_translating(a, [Y_TRUE.inverse() * ai * X_TRUE for ai in a])
    assert errors(x, X_TRUE)[0] < 1e-12 and errors(y, Y_TRUE)[0] < 1e-12
    seen = Y_TRUE.translation - a[0].rotation @ X_TRUE.translation
    assert np.allclose(x.translation, 0.0) and np.allclose(y.translation, seen, atol=1e-12)
    # the point problem: the camera's rotation, and the point through y − R_A t_X
    points = eye_in_hand_points(a, rng)
    camera, point = solve_point_translating(a, points)
    assert errors(camera, X_TRUE)[0] < 1e-12
    assert np.allclose(point, POINT_WORLD - a[0].rotation @ X_TRUE.translation, atol=1e-12)


def test_a_translating_solve_refuses_turning_poses_and_translations_in_a_line() -> None:
    rng = np.random.default_rng(22)
    turning = [random_pose(rng) for _ in range(6)]
    with pytest.raises(DataError, match="needs the poses A_i of one rotation; they turn"):
        solve_ax_yb_translating(turning, [Y_TRUE.inverse() * ai * X_TRUE for ai in turning])
    rotation = pin.exp3(np.array([0.2, -0.1, 0.4]))
    line = [pin.SE3(rotation, np.array([0.1 * k, 0.0, 0.0])) for k in range(6)]
    with pytest.raises(DataError, match="lie in a line: a translating link needs them to span a plane"):
        solve_ax_yb_translating(line, [Y_TRUE.inverse() * ai * X_TRUE for ai in line])
