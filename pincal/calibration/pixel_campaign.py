"""Simulated camera campaigns: a ChArUco board seen by a camera on the robot (eye-in-hand) or by a camera fixed in
the cell (eye-to-hand), the corners' pixels of the true robot and camera (OpenCV's model), and their files.

The views are drawn, not the postures: each image places the camera ``0.3–1.0 m`` from the board, looking at a
point near its centre from up to 50° off its normal and turned up to 25° about its axis; the nominal robot's inverse
kinematics gives the joint readings (views it cannot reach within its limits are drawn again). The true robot (the
nominal one with random errors) then sees the board at those readings; the corners outside the image, or behind the
camera, are not seen (empty cells). SI units: m, rad; pixels [px].
"""

from __future__ import annotations

import json
from collections.abc import Sequence
from pathlib import Path

import numpy as np
import numpy.typing as npt
import pinocchio as pin

from pincal.calibration.campaign import Simulation, check_sample_counts, simulation_options
from pincal.calibration.provenance import sha256, version
from pincal.calibration.setup import parameters_for
from pincal.errors import ConvergenceError, DataError, PincalError
from pincal.identification.measurements import (
    BOARD_DEFAULT,
    INTRINSICS,
    Board,
    Pixel,
    parse_board,
    parse_key,
    pixel,
)
from pincal.identification.measurements.pixels import BOARD
from pincal.identification.parameters import ParameterSet
from pincal.identification.problem import CalibrationProblem, Observations
from pincal.io.dataset import Dataset, dataset_text
from pincal.io.files import check_directory, check_outputs, make_directory, write_texts
from pincal.model.robot import Robot
from pincal.records import record
from pincal.study.simulation import perturbation

Array = npt.NDArray[np.float64]

#: The simulated camera: 1280 × 960 px, focal length 1000 px, a mild barrel distortion (OpenCV's model, INTRINSICS).
DEFAULT_INTRINSICS = (1000.0, 1002.0, 645.0, 478.0, -0.12, 0.08, 4e-4, -3e-4, 0.0)
DEFAULT_IMAGE_SIZE = (1280, 960)
#: The camera's distance to the board [m] and the largest tilt off its normal and turn about its axis [rad].
DISTANCES = (0.3, 1.0)
TILT = np.radians(50.0)
ROLL = np.radians(25.0)
#: Draws of a view per image before the simulation gives up.
TRIES = 200


@record
class PixelSimulation(Simulation):
    """A simulated camera campaign: a :class:`~pincal.calibration.campaign.Simulation` with its camera.

    Attributes:
        board: The board.
        image_size: (width, height) [px].
        intrinsics: The true intrinsics (:data:`~pincal.identification.measurements.INTRINSICS`).
        views: Each sample's true board placement in the camera (camera ← board) [m, rad]: the true robot's.
    """

    board: Board | None = None
    image_size: tuple[int, int] = DEFAULT_IMAGE_SIZE
    intrinsics: tuple[float, ...] = DEFAULT_INTRINSICS
    views: tuple[pin.SE3, ...] = ()


def pixel_models(board: Board, frame: str, eye_to_hand: bool, sigma: float) -> list[Pixel]:
    """One model per corner of ``board`` (intrinsics estimated, no nominal), σ [px]."""
    meta = {"board": board.spec}
    return [pixel(frame, k, sigma, eye_to_hand).with_metadata(meta)  # type: ignore[misc]
            for k in range(board.n_corners)]


def _rotation(tilt_x: float, tilt_y: float, roll: float) -> Array:
    """The rotation ``Rz(roll) Ry(tilt_y) Rx(tilt_x)``."""
    return np.asarray(pin.rpy.rpyToMatrix(tilt_x, tilt_y, roll), dtype=float)


def random_view(board: Board, rng: np.random.Generator) -> pin.SE3:
    """A random placement of the board in the camera (camera ← board): the camera looks at a point near the board's
    centre from a random distance, tilt and turn."""
    centre = np.array([board.extent[0] / 2, board.extent[1] / 2, 0.0])
    aim = centre + np.r_[rng.uniform(-0.25, 0.25, 2) * board.square * 2, 0.0]
    tilt = rng.uniform(-TILT, TILT, 2)
    rot = _rotation(tilt[0], tilt[1], rng.uniform(-ROLL, ROLL))  # board ← camera
    position = aim - rng.uniform(*DISTANCES) * rot[:, 2]
    return pin.SE3(rot, position).inverse()


def _reach(robot: Robot, frame: str, goal: pin.SE3, start: Array) -> Array | None:
    """The nominal robot's configuration placing ``frame`` at ``goal`` within its joint limits (None: not
    reached)."""
    try:
        q = robot.solve_ik(goal, frame, start)
    except PincalError:
        return None
    model = robot.model
    inside = np.all(q >= model.lowerPositionLimit - 1e-9) and np.all(q <= model.upperPositionLimit + 1e-9)
    return q if inside else None


def set_placement_values(pset: ParameterSet, x: Array, kind: str, owner: str, placement: pin.SE3) -> None:
    """Write ``log6(placement)`` into the parameters of placement group (kind, owner) (those present)."""
    delta = pin.log6(placement).vector
    for k in pset.groups(kind).get((kind, owner, ""), []):
        x[k] = delta[pset.parameters[k].component]



def check_campaign(n_train: int, n_test: int, intrinsics: Sequence[float], noise: float, perturb: float) -> None:
    """A camera campaign's counts, true intrinsics (nine finite numbers: fx, fy, cx, cy [px], k1, k2, p1, p2, k3),
    pixel noise [px] and robot errors [m, rad] checked; :class:`~pincal.errors.DataError` naming the culprit."""
    check_sample_counts(n_train, n_test)
    if len(intrinsics) != len(INTRINSICS) or not np.all(np.isfinite(intrinsics)):
        raise DataError(f"intrinsics {intrinsics}: need nine finite numbers {' '.join(INTRINSICS)}")
    if noise < 0 or perturb < 0:
        raise DataError(f"noise {noise} px and perturb {perturb} must be non-negative")

def simulate_pixels(robot: Robot, frame: str, n_train: int, n_test: int = 0, eye_to_hand: bool = False,
                    board: str | Board = BOARD_DEFAULT, perturb: float = 1e-3, noise: float = 0.2, seed: int = 0,
                    intrinsics: tuple[float, ...] = DEFAULT_INTRINSICS,
                    image_size: tuple[int, int] = DEFAULT_IMAGE_SIZE) -> PixelSimulation:
    """Simulate a camera campaign on ``robot``: the corners' pixels of a board seen from random views.

    Args:
        robot: The nominal robot (a serial chain: the views are reached by its inverse kinematics).
        frame: The frame carrying the camera (eye-in-hand) or the board (``eye_to_hand``).
        n_train: Images to calibrate from.
        n_test: Images held out.
        eye_to_hand: A fixed camera sees a board on ``frame`` (default: a camera on ``frame`` sees a board fixed in
            the world).
        board: The board (``charuco:COLSxROWS:SQUARE:MARKER:DICT``).
        perturb: σ of the robot's true geometric errors [m and rad].
        noise: σ of the corners' pixel noise [px].
        seed: Random seed (same seed, same campaign).
        intrinsics: The true intrinsics (fx, fy, cx, cy [px], k1, k2, p1, p2, k3).
        image_size: The image's (width, height) [px].

    Raises:
        DataError: a bad board, counts, or intrinsics.
        ConvergenceError: views the robot cannot reach.
    """
    check_campaign(n_train, n_test, intrinsics, noise, perturb)
    plate = parse_board(board) if isinstance(board, str) else board
    rng = np.random.default_rng(seed)
    models = pixel_models(plate, frame, eye_to_hand, max(noise, 1e-3))
    pset = parameters_for(robot, models)
    x_true = perturbation(pset, perturb, rng)
    x_true[[k for k, p in enumerate(pset) if p.kind in ("camera", "target", "base", "intrinsics")]] = 0.0
    q0 = robot.q_reference.copy()
    placed = robot.placement(q0, frame)
    centre = np.array([plate.extent[0] / 2, plate.extent[1] / 2, 0.0])
    if eye_to_hand:  # the board across the flange, facing out; the camera 0.55 m in front of it
        on_frame = pin.SE3(_rotation(np.pi, 0.0, 0.0), np.zeros(3))
        on_frame.translation = np.array([0.0, 0.0, 0.01]) - on_frame.rotation @ centre
        camera = placed * on_frame * pin.SE3(np.eye(3), centre - np.array([0.0, 0.0, 0.55]))
        set_placement_values(pset, x_true, "target", f"{frame}@{BOARD}", on_frame)
        set_placement_values(pset, x_true, "base", "base", camera.inverse())
    else:  # the camera on the flange looking along it; the board 0.55 m in front of it at the reference
        on_frame = pin.SE3(_rotation(0.0, 0.0, np.pi / 2), np.array([0.06, 0.0, 0.04]))
        camera = placed * on_frame
        world_board = camera * pin.SE3(np.eye(3), np.array([0.0, 0.0, 0.55]) - centre)
        set_placement_values(pset, x_true, "camera", frame, on_frame)
        set_placement_values(pset, x_true, "target", "", world_board)
    for k, p in enumerate(pset):
        if p.kind == "intrinsics":
            x_true[k] = intrinsics[p.component]
    qs = []
    for _ in range(n_train + n_test):
        for _ in range(TRIES):
            view = random_view(plate, rng)  # camera ← board
            goal = (camera * view * on_frame.inverse() if eye_to_hand
                    else world_board * view.inverse() * on_frame.inverse())
            q = _reach(robot, frame, goal, q0)
            if q is not None:
                break
        else:
            raise ConvergenceError(f"'{robot.name}' cannot reach views of the board from '{frame}' in {TRIES} "
                                   "draws: give another frame")
        qs.append(q)
    actuated = np.array([robot.actuated_values(q) for q in qs])
    problem = CalibrationProblem(robot, pset, models, Observations.neutral(models, actuated))
    seen_by = parse_key(f"pose:{frame}@{BOARD}" if eye_to_hand else f"camera:{frame}")
    poses = CalibrationProblem(robot, pset, [seen_by], Observations.neutral([seen_by], actuated))
    true_views = tuple(pin.SE3(pin.exp3(row[3:]), row[:3])
                       for row in poses.evaluate(x_true, jacobian=False).predicted[seen_by.key])
    kind = "board_pixel" if eye_to_hand else "pixel"
    return pixel_campaign(problem, x_true, f"{kind}:{frame}", frame, true_views, plate, n_train, n_test, perturb,
                          noise, seed, rng, intrinsics, image_size)


def pixel_campaign(problem: CalibrationProblem, x_true: Array, measure: str, frame: str, views: tuple[pin.SE3, ...],
                   plate: Board, n_train: int, n_test: int, perturb: float, noise: float, seed: int,
                   rng: np.random.Generator, intrinsics: tuple[float, ...],
                   image_size: tuple[int, int]) -> PixelSimulation:
    """The campaign of a camera ``problem`` (its models at the drawn readings) at the truth ``x_true``: the corners'
    pixels with noise of σ ``noise`` [px], those outside the image or behind the camera left out; ``measure`` the
    simulated ``--measure`` (``<kind>:<frame>``), ``views`` each sample's true camera ← board."""
    robot, models = problem.robot, problem.measurements
    actuated = problem.observations.actuated
    predicted = problem.evaluate(x_true, jacobian=False).predicted
    values = {}
    width, height = image_size
    for m in models:
        uv = predicted[m.key] + rng.normal(scale=noise, size=predicted[m.key].shape)
        outside = ((uv[:, 0] < 0) | (uv[:, 0] > width - 1) | (uv[:, 1] < 0) | (uv[:, 1] > height - 1)
                   | ~np.all(np.isfinite(uv), axis=1))
        uv[outside] = np.nan
        values[m.key] = uv
    n = n_train + n_test
    options = simulation_options([measure], n_train, n_test, frame, perturb, noise, seed, None, None, None, 0.0)
    kind = measure.partition(":")[0]
    metadata = {"robot": robot.name, "pincal": version(), "units": "SI (m, rad), pixels (px)",
                "perturb": repr(perturb), "seed": str(seed),
                **({"robot sha256": sha256(robot.source)} if robot.source is not None else {}),
                "simulate": json.dumps(options), "board": plate.spec,
                "image size": f"{width} {height}", f"sigma {kind}": repr(max(noise, 1e-3))}
    dataset = Dataset(list(robot.actuated_joints), actuated, values, [f"{k:04d}" for k in range(n)],
                      ["train"] * n_train + ["test"] * n_test, metadata)
    return PixelSimulation(robot, problem.parameters, x_true, dataset, list(models), None, plate, image_size,
                           tuple(intrinsics), views)


#: The rendered images' blur [px] and noise [grey levels]: a focused camera's softness and sensor noise.
IMAGE_BLUR = 0.8
IMAGE_NOISE = 2.0


def camera_outputs(out: Path, images: Path) -> list[Path]:
    """The files a camera simulation with images writes besides the simulation's: ``out/joints.csv`` and one PNG
    per image in ``images``; refused before any work (:func:`~pincal.io.files.check_outputs`)."""
    joints = out / "joints.csv"
    check_outputs([("out", joints)], keywords=True)
    check_directory(images, "images", option="images")
    return [joints]


def write_images(sim: PixelSimulation, out: Path, images: Path, seed: int = 0) -> list[Path]:
    """Render every image of ``sim`` into ``images`` (``<sample>.png``: the board warped by the true camera and
    robot, blurred by :data:`IMAGE_BLUR` px, with noise of :data:`IMAGE_NOISE` grey levels) and write the joint
    readings, one row per image, as ``out/joints.csv`` (what ``pincal detect --joints`` pairs them with); returns
    the joints file and the images."""
    from pincal.io.vision import pixel_rays, render, write_image

    if sim.board is None:
        raise DataError("the simulation has no board")
    rng = np.random.default_rng(seed + 1)
    rays = pixel_rays(sim.intrinsics, sim.image_size)
    make_directory(images, "images")
    paths = []
    for sample, view in zip(sim.dataset.sample_ids, sim.views, strict=True):
        path = images / f"{sample}.png"
        write_image(path, render(sim.board, view, rays, sim.image_size, IMAGE_BLUR, IMAGE_NOISE, rng))
        paths.append(path)
    data = sim.dataset
    joints = Dataset(list(data.joint_names), data.joints, {}, list(data.sample_ids), list(data.sets),
                     {"robot": sim.robot.name, "units": "SI (m, rad)"})
    return [*write_texts([(out / "joints.csv", dataset_text(joints))]), *paths]
