"""A camera on one chain seeing a board on another (``cross_pixel``): its Jacobians against finite differences, its
batched prediction, its closed-form start, its key, and the simulation's refusals."""

from __future__ import annotations

import numpy as np
import pinocchio as pin
import pytest
from conftest import finite_difference_jacobian

import pincal
from pincal.calibration.cross_campaign import relative_ik, simulate_cross_pixels
from pincal.errors import DataError
from pincal.identification import measurements as ms
from pincal.identification.problem import CalibrationProblem, Observations

CAMERA, HAND = "head_2_link", "arm_tool_link"
SMALL_BOARD = "charuco:3x3:0.05:0.035:DICT_4X4_50"


@pytest.fixture(scope="module")
def tiago() -> pincal.Robot:
    return pincal.load_robot("tiago_no_hand")


def _problem(robot: pincal.Robot, sim: object) -> CalibrationProblem:
    return CalibrationProblem(robot, sim.parameters, sim.measurements,  # type: ignore[attr-defined]
                              Observations(sim.dataset.joints, sim.dataset.measurements))  # type: ignore[attr-defined]


def test_jacobians_of_both_chains_match_finite_differences(tiago: pincal.Robot) -> None:
    sim = simulate_cross_pixels(tiago, CAMERA, HAND, 3, 0, board=SMALL_BOARD, seed=2)
    problem = _problem(tiago, sim)
    x = sim.x_true + np.random.default_rng(0).normal(scale=1e-4, size=len(sim.x_true))
    pred = problem.evaluate(x)
    assert pred.jacobian is not None
    fd = finite_difference_jacobian(problem, x, eps=1e-6)
    error = np.abs(pred.jacobian - fd).max(axis=0)
    scale = np.abs(fd).max(axis=0)
    names = sim.parameters.names
    assert not [(names[c], error[c], scale[c]) for c in range(len(names)) if error[c] > 1e-6 * scale[c] + 1e-5]
    # both chains move the pixels: the head's joints and the arm's, with the camera, the board and the intrinsics
    moving = {names[c].partition(".")[0] for c in range(len(names)) if scale[c] > 1.0}
    assert {"head_1_joint", "head_2_joint", "arm_1_joint", "arm_7_joint"} <= moving
    assert {p.kind for p in sim.parameters} >= {"camera", "target", "intrinsics", "joint"}
    assert "base" not in {p.kind for p in sim.parameters}
    assert f"target.{HAND}@board.tx" in names and f"camera.{CAMERA}.rx" in names
    assert f"intrinsics.{CAMERA}.fx" in names


def test_the_batched_prediction_is_the_per_sample_one(tiago: pincal.Robot) -> None:
    sim = simulate_cross_pixels(tiago, CAMERA, HAND, 4, 0, board=SMALL_BOARD, seed=3)
    batched, per_sample = _problem(tiago, sim), _problem(tiago, sim)
    assert batched._batched_trees
    per_sample._batched_trees = False
    x = sim.x_true + np.random.default_rng(1).normal(scale=1e-4, size=len(sim.x_true))
    a, b = batched.evaluate(x), per_sample.evaluate(x)
    assert a.jacobian is not None and b.jacobian is not None
    assert np.abs(a.residual - b.residual).max() <= 1e-9 * np.abs(b.residual).max()
    assert np.abs(a.jacobian - b.jacobian).max() <= 1e-9 * np.abs(b.jacobian).max()


def test_the_start_recovers_intrinsics_camera_and_board_of_exact_data(tiago: pincal.Robot) -> None:
    sim = simulate_cross_pixels(tiago, CAMERA, HAND, 8, 0, noise=0.0, perturb=0.0, seed=4,
                                intrinsics=(1000.0, 1002.0, 645.0, 478.0, 0.0, 0.0, 0.0, 0.0, 0.0))
    x = _problem(tiago, sim).initial_guess()
    checked = 0
    for k, name in enumerate(sim.parameters.names):
        if name.startswith(("intrinsics", "camera", "target")):
            assert x[k] == pytest.approx(sim.x_true[k], abs=1e-6 * max(1.0, abs(sim.x_true[k]))), name
            checked += 1
    assert checked == 6 + 6 + 9


def test_the_views_are_the_true_robot_s(tiago: pincal.Robot) -> None:
    sim = simulate_cross_pixels(tiago, CAMERA, HAND, 3, 0, board=SMALL_BOARD, noise=0.0, seed=6)
    problem = _problem(tiago, sim)
    predicted = problem.evaluate(sim.x_true, jacobian=False).predicted
    corner = sim.measurements[2]
    assert sim.board is not None
    seen = np.array([view.act(sim.board.corner(2)) for view in sim.views])
    uv, _, _ = ms.project(seen, np.array(sim.intrinsics))
    assert np.abs(uv - predicted[corner.key]).max() < 1e-9
    distances = [np.linalg.norm(v.translation) for v in sim.views]
    assert all(0.2 < d < 1.2 for d in distances)


def test_relative_ik_reaches_a_goal_within_limits(tiago: pincal.Robot) -> None:
    q_goal = tiago.q_reference.copy()
    model = tiago.model
    for name, value in (("arm_1_joint", 0.6), ("arm_4_joint", 1.2), ("head_1_joint", -0.4), ("head_2_joint", -0.3)):
        q_goal[model.joints[model.getJointId(name)].idx_q] = value
    goal = tiago.placement(q_goal, CAMERA).actInv(tiago.placement(q_goal, HAND))
    q = relative_ik(tiago, CAMERA, HAND, goal, tiago.q_reference.copy())
    assert q is not None
    reached = tiago.placement(q, CAMERA).actInv(tiago.placement(q, HAND))
    assert np.linalg.norm(pin.log6(goal.actInv(reached)).vector) < 1e-8
    assert np.all(q >= model.lowerPositionLimit - 1e-9) and np.all(q <= model.upperPositionLimit + 1e-9)


def test_keys_and_refusals() -> None:
    model = ms.parse_key(f"cross_pixel:{CAMERA}-{HAND}@7")
    assert isinstance(model, ms.CrossPixel) and model.corner == 7
    assert model.frames == (CAMERA, HAND) and model.camera == CAMERA
    assert model.columns == (f"cross_pixel:{CAMERA}-{HAND}@7:u", f"cross_pixel:{CAMERA}-{HAND}@7:v")
    kinds = {(a.kind, a.owner) for a in model.attachments}
    assert kinds == {("camera", CAMERA), ("target", f"{HAND}@board"), ("intrinsics", CAMERA)}
    for bad in (f"cross_pixel:{CAMERA}@7", f"cross_pixel:{CAMERA}-{HAND}", "cross_pixel:a-b-c@1",
                f"cross_pixel:-{HAND}@1"):
        with pytest.raises(DataError, match="<camera frame>-<board frame>@<corner>"):
            ms.parse_key(bad)
    held = model.with_metadata({"board": ms.BOARD_DEFAULT, f"intrinsics {CAMERA} held": "1000 1000 640 480 0 0 0 0 0"})
    assert isinstance(held, ms.CrossPixel) and held.held and held.board_frame == HAND
    assert all(a.kind != "intrinsics" for a in held.attachments)


def test_the_simulation_refuses_one_frame_and_a_loop(tiago: pincal.Robot) -> None:
    with pytest.raises(DataError, match="same frame"):
        simulate_cross_pixels(tiago, HAND, HAND, 3)
    with pytest.raises(DataError, match="closed loops"):
        simulate_cross_pixels(pincal.load_robot("five_bar"), "proximal_1", "end_effector", 3)
