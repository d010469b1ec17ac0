"""Simulated camera campaigns across two chains: a camera on one robot frame sees a board on another frame of the
same robot (``cross_pixel``, :mod:`~pincal.identification.measurements.cross_pixels`).

At the reference configuration the camera sits on its frame looking at the board frame's origin, and the board is
centred on that origin facing the camera. Each image draws a view as :mod:`~pincal.calibration.pixel_campaign` does
(``0.3–1.0 m``, up to 50° off the board's normal, 25° about the camera's axis); damped least squares on the two frames'
relative placement, from the reference with random joint offsets, gives the nominal robot's joint readings (views it
cannot reach within its joint limits are drawn again). Nothing checks that the robot's own links hide the board.
SI units: m, rad; pixels [px].
"""

from __future__ import annotations

import numpy as np
import numpy.typing as npt
import pinocchio as pin

from pincal.calibration.pixel_campaign import (
    DEFAULT_IMAGE_SIZE,
    DEFAULT_INTRINSICS,
    TRIES,
    PixelSimulation,
    check_campaign,
    pixel_campaign,
    random_view,
    set_placement_values,
)
from pincal.calibration.setup import parameters_for
from pincal.errors import ConvergenceError, DataError
from pincal.identification.measurements import BOARD_DEFAULT, Board, cross_pixel, parse_board
from pincal.identification.measurements.pixels import BOARD
from pincal.identification.problem import CalibrationProblem, Observations
from pincal.model.robot import Robot
from pincal.study.simulation import perturbation

Array = npt.NDArray[np.float64]

#: Damped least squares on the relative placement: iterations, damping, tolerance [m, rad] and the σ [rad or m] of
#: the random joint offsets each attempt starts from.
IK_ITERATIONS = 100
IK_DAMPING = 1e-6
IK_TOLERANCE = 1e-9
IK_START = 0.3


def relative_ik(robot: Robot, camera_frame: str, board_frame: str, goal: pin.SE3, start: Array) -> Array | None:
    """The nominal robot's configuration placing ``board_frame`` at ``goal`` in ``camera_frame`` (A⁻¹ B = goal)
    within its joint limits (each step projected onto them), from ``start`` (None: not reached). The relative
    placement's local twist is ``J_B − Ad(M⁻¹) J_A`` (M = A⁻¹ B, local frame Jacobians)."""
    model, data = robot.model, robot.model.createData()
    ids = robot.frame_id(camera_frame), robot.frame_id(board_frame)
    bounded = [model.joints[j].idx_q for j in range(1, model.njoints) if model.joints[j].nq == 1]
    low, high = model.lowerPositionLimit[bounded], model.upperPositionLimit[bounded]
    q = start.copy()
    q[bounded] = np.clip(q[bounded], low, high)
    for _ in range(IK_ITERATIONS):
        pin.computeJointJacobians(model, data, q)
        pin.updateFramePlacements(model, data)
        rel = data.oMf[ids[0]].actInv(data.oMf[ids[1]])
        error = pin.log6(goal.actInv(rel)).vector
        if np.linalg.norm(error) < IK_TOLERANCE:
            break
        local = [pin.getFrameJacobian(model, data, i, pin.ReferenceFrame.LOCAL) for i in ids]
        jac = pin.Jlog6(goal.actInv(rel)) @ (local[1] - rel.inverse().action @ local[0])
        step = np.linalg.solve(jac.T @ jac + IK_DAMPING * np.eye(model.nv), jac.T @ error)
        q = pin.integrate(model, q, -step)
        q[bounded] = np.clip(q[bounded], low, high)  # projected onto the joint limits
    else:
        return None
    inside = np.all(q >= model.lowerPositionLimit - 1e-9) and np.all(q <= model.upperPositionLimit + 1e-9)
    return q if inside else None


def simulate_cross_pixels(robot: Robot, camera_frame: str, board_frame: str, n_train: int, n_test: int = 0,
                          board: str | Board = BOARD_DEFAULT, perturb: float = 1e-3, noise: float = 0.2,
                          seed: int = 0, intrinsics: tuple[float, ...] = DEFAULT_INTRINSICS,
                          image_size: tuple[int, int] = DEFAULT_IMAGE_SIZE) -> PixelSimulation:
    """Simulate a campaign of a camera on ``camera_frame`` seeing a board on ``board_frame`` of the same robot.

    Args:
        robot: The nominal robot (a tree: the views are reached by its joints).
        camera_frame: The frame carrying the camera.
        board_frame: The frame carrying the board (on another chain: the two must move apart).
        n_train: Images to calibrate from.
        n_test: Images held out.
        board: The board (``charuco:COLSxROWS:SQUARE:MARKER:DICT``).
        perturb: σ of the robot's true geometric errors [m and rad].
        noise: σ of the corners' pixel noise [px].
        seed: Random seed (same seed, same campaign).
        intrinsics: The true intrinsics (fx, fy, cx, cy [px], k1, k2, p1, p2, k3).
        image_size: The image's (width, height) [px].

    Raises:
        DataError: a bad board, counts, intrinsics, frames (the same, or a robot with loops).
        ConvergenceError: views the robot cannot reach.
    """
    check_campaign(n_train, n_test, intrinsics, noise, perturb)
    if camera_frame == board_frame:
        raise DataError(f"cross_pixel:{camera_frame}-{board_frame}: the camera and the board are on the same frame "
                        "(nothing moves between them): give two frames on different chains")
    if robot.is_closed_loop:
        raise DataError(f"'{robot.name}' has closed loops: a cross_pixel simulation needs a robot without loops")
    plate = parse_board(board) if isinstance(board, str) else board
    rng = np.random.default_rng(seed)
    meta = {"board": plate.spec}
    models = [cross_pixel(camera_frame, board_frame, k, max(noise, 1e-3)).with_metadata(meta)
              for k in range(plate.n_corners)]
    pset = parameters_for(robot, models)
    x_true = perturbation(pset, perturb, rng)
    x_true[[k for k, p in enumerate(pset) if p.kind in ("camera", "target", "intrinsics")]] = 0.0
    q0 = robot.q_reference.copy()
    frame_a, frame_b = robot.placement(q0, camera_frame), robot.placement(q0, board_frame)
    gap = frame_a.actInv(frame_b.translation)
    if np.linalg.norm(gap) < 0.05:
        raise DataError(f"frames '{camera_frame}' and '{board_frame}' are {np.linalg.norm(gap):.3g} m apart at the "
                        "reference: a camera cannot see a board that close")
    axis = gap / np.linalg.norm(gap)  # the camera's z, in A: towards B's origin
    side = np.cross(axis, [1.0, 0.0, 0.0] if abs(axis[0]) < 0.9 else [0.0, 1.0, 0.0])
    side /= np.linalg.norm(side)
    camera = pin.SE3(np.c_[np.cross(side, axis), side, axis], np.zeros(3))  # A ← camera
    centre = np.array([plate.extent[0] / 2, plate.extent[1] / 2, 0.0])
    seen_at_reference = pin.SE3(np.eye(3), np.array([0.0, 0.0, float(np.linalg.norm(gap))]) - centre)
    on_frame = frame_b.actInv(frame_a * camera * seen_at_reference)  # B ← board
    set_placement_values(pset, x_true, "camera", camera_frame, camera)
    set_placement_values(pset, x_true, "target", f"{board_frame}@{BOARD}", on_frame)
    for k, p in enumerate(pset):
        if p.kind == "intrinsics":
            x_true[k] = intrinsics[p.component]
    qs = []
    for _ in range(n_train + n_test):
        for _ in range(TRIES):
            goal = camera * random_view(plate, rng) * on_frame.inverse()  # A ← B
            start = pin.integrate(robot.model, q0, rng.normal(scale=IK_START, size=robot.model.nv))
            q = relative_ik(robot, camera_frame, board_frame, goal, start)
            if q is not None:
                break
        else:
            raise ConvergenceError(f"'{robot.name}' cannot show a board on '{board_frame}' to a camera on "
                                   f"'{camera_frame}' in {TRIES} draws: give other frames")
        qs.append(q)
    actuated = np.array([robot.actuated_values(q) for q in qs])
    problem = CalibrationProblem(robot, pset, list(models), Observations.neutral(list(models), actuated))
    truth = problem.robot_at(x_true)
    views = []
    for qa in problem.actuated_values(x_true):
        q = truth.solve_fk(qa)
        views.append((truth.placement(q, camera_frame) * camera).actInv(truth.placement(q, board_frame) * on_frame))
    return pixel_campaign(problem, x_true, f"cross_pixel:{camera_frame}-{board_frame}", camera_frame, tuple(views),
                          plate, n_train, n_test, perturb, noise, seed, rng, intrinsics, image_size)
