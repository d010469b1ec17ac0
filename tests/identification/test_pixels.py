"""Pixels of a board's corners: OpenCV's projection, its analytic Jacobian, the closed-form starts."""

from __future__ import annotations

import numpy as np
import pinocchio as pin
import pytest
from conftest import finite_difference_jacobian

import pincal
from pincal.calibration.pixel_campaign import DEFAULT_INTRINSICS, simulate_pixels
from pincal.errors import DataError
from pincal.identification import measurements as ms
from pincal.identification.pixel_starts import board_pose, homography, zhang_intrinsics
from pincal.identification.problem import CalibrationProblem, Observations


def test_projection_derivatives_match_finite_differences() -> None:
    rng = np.random.default_rng(3)
    points = np.c_[rng.uniform(-0.3, 0.3, (5, 2)), rng.uniform(0.4, 0.9, 5)]
    k = np.array([900.0, 910.0, 640.0, 480.0, -0.2, 0.1, 1e-3, -2e-3, 0.05])
    _, dp, dk = ms.project(points, k)
    eps = 1e-6
    for c in range(3):
        step = np.zeros(3)
        step[c] = eps
        fd = (ms.project(points + step, k)[0] - ms.project(points - step, k)[0]) / (2 * eps)
        assert np.allclose(dp[:, :, c], fd, rtol=1e-6, atol=1e-6)
    for c in range(9):
        step = np.zeros(9)
        step[c] = eps
        fd = (ms.project(points, k + step)[0] - ms.project(points, k - step)[0]) / (2 * eps)
        assert np.allclose(dk[:, :, c], fd, rtol=1e-6, atol=1e-5)


def test_projection_is_opencv_s_model_written_out() -> None:
    # a point on the axis lands on the principal point; without distortion u = fx X/Z + cx
    k = np.array([800.0, 820.0, 320.0, 240.0, 0.0, 0.0, 0.0, 0.0, 0.0])
    uv, _, _ = ms.project(np.array([[0.0, 0.0, 2.0], [0.1, -0.2, 0.5]]), k)
    assert np.allclose(uv, [[320.0, 240.0], [800 * 0.2 + 320, 820 * -0.4 + 240]], atol=1e-12)
    # radial distortion scales by 1 + k1 r²
    k[4] = -0.1
    uv, _, _ = ms.project(np.array([[0.1, 0.0, 0.5]]), k)
    assert uv[0, 0] == pytest.approx(800 * 0.2 * (1 - 0.1 * 0.04) + 320, abs=1e-9)


@pytest.mark.parametrize(("name", "frame", "eye_to_hand"), [("ur10", "tool0", False), ("panda", "panda_hand", True)])
def test_pixel_jacobians_match_finite_differences(name: str, frame: str, eye_to_hand: bool) -> None:
    robot = pincal.load_robot(name)
    sim = simulate_pixels(robot, frame, 3, 0, eye_to_hand=eye_to_hand, board="charuco:3x3:0.05:0.035:DICT_4X4_50",
                          seed=2)
    problem = CalibrationProblem(robot, sim.parameters, sim.measurements,
                                 Observations(sim.dataset.joints, sim.dataset.measurements))
    x = sim.x_true + np.random.default_rng(0).normal(scale=1e-4, size=len(sim.x_true))
    pred = problem.evaluate(x)
    assert pred.jacobian is not None
    fd = finite_difference_jacobian(problem, x, eps=1e-6)
    error = np.abs(pred.jacobian - fd).max(axis=0)
    scale = np.abs(fd).max(axis=0)
    names = sim.parameters.names
    bad = [(names[c], error[c], scale[c]) for c in range(len(names)) if error[c] > 1e-6 * scale[c] + 1e-6]
    assert not bad
    # every kind of column is there: the robot's, the camera's or the board's, the intrinsics
    kinds = {p.kind for p in sim.parameters}
    assert {"joint", "target", "intrinsics"} <= kinds
    assert ("base" if eye_to_hand else "camera") in kinds


def test_the_start_recovers_intrinsics_and_placements_of_exact_data() -> None:
    robot = pincal.load_robot("ur10")
    sim = simulate_pixels(robot, "tool0", 8, 0, noise=0.0, perturb=0.0, seed=4,
                          intrinsics=(1000.0, 1002.0, 645.0, 478.0, 0.0, 0.0, 0.0, 0.0, 0.0))
    problem = CalibrationProblem(robot, sim.parameters, sim.measurements,
                                 Observations(sim.dataset.joints, sim.dataset.measurements))
    x = problem.initial_guess()
    names = sim.parameters.names
    for k, name in enumerate(names):
        if name.startswith(("intrinsics", "camera", "target")):
            assert x[k] == pytest.approx(sim.x_true[k], abs=1e-6 * max(1.0, abs(sim.x_true[k]))), name


def test_homography_pose_and_zhang_on_exact_views() -> None:
    k = np.array([[1000.0, 0, 640], [0, 990.0, 470], [0, 0, 1]])
    board = np.array([[x, y] for x in np.linspace(0, 0.2, 5) for y in np.linspace(0, 0.15, 4)])
    hs, poses = [], []
    for rx, ry, rz in [(0.3, 0.1, 0.2), (-0.2, 0.35, -0.1), (0.1, -0.3, 0.4), (0.25, 0.25, 0.0)]:
        pose = pin.SE3(pin.rpy.rpyToMatrix(rx, ry, rz), np.array([-0.1, -0.05, 0.6]))
        cam = (pose.rotation @ np.c_[board, np.zeros(len(board))].T).T + pose.translation
        uv = (cam @ k.T)[:, :2] / cam[:, [2]]
        hs.append(homography(board, uv))
        poses.append(pose)
    pinhole = zhang_intrinsics(hs)
    assert np.allclose(pinhole, [1000.0, 990.0, 640.0, 470.0], atol=1e-6)
    for h, pose in zip(hs, poses, strict=True):
        assert np.allclose(board_pose(h, pinhole).homogeneous, pose.homogeneous, atol=1e-9)
    with pytest.raises(DataError, match="3 or more"):
        zhang_intrinsics(hs[:2])


def test_keys_and_metadata_are_checked() -> None:
    model = ms.parse_key("pixel:tool0@3")
    assert isinstance(model, ms.Pixel) and model.corner == 3 and model.columns == ("pixel:tool0@3:u",
                                                                                   "pixel:tool0@3:v")
    assert isinstance(ms.parse_key("board_pixel:tool0@0"), ms.BoardPixel)
    with pytest.raises(DataError, match="pixel:<frame>@<corner>"):
        ms.parse_key("pixel:tool0")
    with pytest.raises(DataError, match="# board"):
        model.with_metadata({})
    with pytest.raises(DataError, match="corner 30 is not on board"):
        ms.parse_key("pixel:tool0@30").with_metadata({"board": "charuco:5x4:0.04:0.03:DICT_4X4_50"})
    with pytest.raises(DataError, match="is not charuco"):
        ms.parse_board("chessboard:5x4")
    with pytest.raises(DataError, match="nine numbers"):
        model.with_metadata({"board": ms.BOARD_DEFAULT, "intrinsics tool0": "1 2 3"})
    held = model.with_metadata({"board": ms.BOARD_DEFAULT, "intrinsics tool0 held": " ".join(map(str,
                                                                                             DEFAULT_INTRINSICS))})
    assert isinstance(held, ms.Pixel) and held.held and held.intrinsics == DEFAULT_INTRINSICS
    assert all(a.kind != "intrinsics" for a in held.attachments)
    board = ms.parse_board("charuco:5x4:0.04:0.03:DICT_4X4_50")
    assert board.n_corners == 12
    assert np.allclose(board.corner(5), [0.08, 0.08, 0.0])


@pytest.mark.parametrize(("name", "frame", "eye_to_hand"), [("ur10", "tool0", False), ("panda", "panda_hand", True)])
def test_the_batched_prediction_is_the_per_sample_one(name: str, frame: str, eye_to_hand: bool) -> None:
    robot = pincal.load_robot(name)
    sim = simulate_pixels(robot, frame, 4, 0, eye_to_hand=eye_to_hand, board="charuco:4x3:0.05:0.035:DICT_4X4_50",
                          seed=3)

    def problem() -> CalibrationProblem:
        return CalibrationProblem(robot, sim.parameters, sim.measurements,
                                  Observations(sim.dataset.joints, sim.dataset.measurements))

    batched, per_sample = problem(), problem()
    assert batched._batched_trees
    per_sample._batched_trees = False
    x = sim.x_true + np.random.default_rng(1).normal(scale=1e-4, size=len(sim.x_true))
    a, b = batched.evaluate(x), per_sample.evaluate(x)
    assert a.jacobian is not None and b.jacobian is not None
    assert np.abs(a.residual - b.residual).max() <= 1e-9 * np.abs(b.residual).max()
    assert np.abs(a.jacobian - b.jacobian).max() <= 1e-9 * np.abs(b.jacobian).max()


def test_a_grid_s_corners_are_opencv_s() -> None:
    import cv2

    board = ms.parse_board("aruco:3x2:0.04:0.01:DICT_APRILTAG_36h11")
    assert board.spec == "aruco:3x2:0.04:0.01:DICT_APRILTAG_36h11" and board.n_corners == 24
    grid = cv2.aruco.GridBoard((3, 2), 0.04, 0.01, cv2.aruco.getPredefinedDictionary(cv2.aruco.DICT_APRILTAG_36h11))
    assert np.allclose(board.corners(), np.array(grid.getObjPoints()).reshape(-1, 3), atol=1e-7)
    assert board.extent == pytest.approx((0.14, 0.09))
    charuco = ms.parse_board("charuco:5x4:0.04:0.03:DICT_4X4_50")
    plate = cv2.aruco.CharucoBoard((5, 4), 0.04, 0.03, cv2.aruco.getPredefinedDictionary(cv2.aruco.DICT_4X4_50))
    assert np.allclose(charuco.corners(), plate.getChessboardCorners(), atol=1e-7)
