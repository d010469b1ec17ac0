"""Start values of the pixel measurements (:mod:`pincal.identification.measurements.pixels`), from nothing but the
images' corners and the nominal robot.

1. Each image's homography board plane → image (the direct linear transform on normalised points, Hartley 1997).
2. The intrinsics the data do not declare: ``fx, fy, cx, cy`` [px] in closed form from the homographies (Zhang 2000,
   "A flexible new technique for camera calibration", with zero skew), the distortion at zero.
3. Each image's board pose in the camera from its homography and the intrinsics.
4. The placements in closed form on the nominal robot, ``A_i X = Y B_i`` (Shah 2013,
   :func:`~pincal.identification.handeye.solve_ax_yb`): eye-in-hand, X the camera on its frame and Y the board in
   the world (``B_i`` the camera in the board's frame); eye-to-hand, X the board on its frame and Y the camera in the
   world (``B_i`` the board in the camera's frame), the measurement frame ``base`` its inverse; a camera on frame A
   seeing a board on frame B (``cross_pixel``), X the board on B and Y the camera on A (``A_i = A⁻¹ B`` the two
   frames' relative placement, ``B_i`` the board in the camera's frame).
"""

from __future__ import annotations

from collections import defaultdict
from typing import TYPE_CHECKING

import numpy as np
import numpy.typing as npt
import pinocchio as pin

from pincal import linalg
from pincal.errors import DataError
from pincal.identification import handeye
from pincal.identification.measurements import BoardPixel, CrossPixel, Pixel, intrinsics_name
from pincal.identification.measurements.pixels import BOARD

if TYPE_CHECKING:
    from pincal.identification.evaluation import Evaluated

Array = npt.NDArray[np.float64]

#: Fewest corners an image needs to give a homography (four points fix one; more average the noise).
MIN_CORNERS = 6
#: Fewest images that fix the pinhole intrinsics by Zhang's method (each image gives two equations on five unknowns
#: less the skew).
MIN_IMAGES = 3


def homography(board: Array, image: Array) -> Array:
    """The 3 × 3 homography H with ``image ~ H (x, y, 1)`` from board points (n, 2) [m] to image points (n, 2) [px],
    by the normalised direct linear transform (n ≥ 4).

    Raises:
        DataError: fewer than four points, or points that do not fix it (on a line).
    """
    if len(board) < 4:
        raise DataError(f"{len(board)} corners do not fix a homography (four or more do)")

    def normaliser(points: Array) -> Array:
        centre = points.mean(axis=0)
        scale = np.sqrt(2.0) / max(float(np.mean(np.linalg.norm(points - centre, axis=1))), 1e-12)
        return np.array([[scale, 0.0, -scale * centre[0]], [0.0, scale, -scale * centre[1]], [0.0, 0.0, 1.0]])

    ta, tb = normaliser(board), normaliser(image)
    a = np.c_[board, np.ones(len(board))] @ ta.T
    b = np.c_[image, np.ones(len(image))] @ tb.T
    rows = np.zeros((2 * len(a), 9))
    rows[0::2, 0:3], rows[0::2, 6:9] = a, -b[:, [0]] * a
    rows[1::2, 3:6], rows[1::2, 6:9] = a, -b[:, [1]] * a
    _, s, vt = linalg.svd(rows, "the homography's linear system")
    if s[-2] <= 1e-9 * s[0]:
        raise DataError("the corners lie on a line: they do not fix the image's homography")
    h: Array = np.linalg.solve(tb, vt[-1].reshape(3, 3) @ ta)
    scaled: Array = h / h[2, 2]
    return scaled


def zhang_intrinsics(homographies: list[Array]) -> Array:
    """(4,) ``fx, fy, cx, cy`` [px] from three or more homographies of a plane (Zhang 2000, zero skew).

    Raises:
        DataError: fewer than three homographies, or views that do not fix them (all parallel to each other).
    """
    if len(homographies) < MIN_IMAGES:
        raise DataError(f"{len(homographies)} images with {MIN_CORNERS} or more corners do not fix the camera's "
                        f"intrinsics ({MIN_IMAGES} or more do)")

    def v(h: Array, i: int, j: int) -> Array:
        a, b = h[:, i], h[:, j]
        return np.array([a[0] * b[0], a[0] * b[1] + a[1] * b[0], a[1] * b[1], a[2] * b[0] + a[0] * b[2],
                         a[2] * b[1] + a[1] * b[2], a[2] * b[2]])

    rows = []
    for h in homographies:
        h = h / np.linalg.norm(h[:, 0])
        rows += [v(h, 0, 1), v(h, 0, 0) - v(h, 1, 1)]
    system = np.array(rows)
    system = np.vstack([system, [0.0, np.abs(system).max(), 0.0, 0.0, 0.0, 0.0]])  # zero skew: B12 = 0
    _, _, vt = linalg.svd(system, "Zhang's system of the intrinsics")
    b11, b12, b22, b13, b23, b33 = vt[-1] * np.sign(vt[-1][0] or 1.0)
    det = b11 * b22 - b12 ** 2
    cy = (b12 * b13 - b11 * b23) / det
    lam = b33 - (b13 ** 2 + cy * (b12 * b13 - b11 * b23)) / b11
    if det <= 0 or lam / b11 <= 0 or lam * b11 / det <= 0:
        raise DataError("the images' views do not fix the camera's intrinsics (tilt the board differently between "
                        "images)")
    fx = np.sqrt(lam / b11)
    fy = np.sqrt(lam * b11 / det)
    cx = -b13 * fx ** 2 / lam
    return np.array([fx, fy, cx, cy])


def board_pose(h: Array, pinhole: Array) -> pin.SE3:
    """The board's placement in the camera (camera ← board) from its homography and ``fx, fy, cx, cy`` [px]."""
    k = np.array([[pinhole[0], 0.0, pinhole[2]], [0.0, pinhole[1], pinhole[3]], [0.0, 0.0, 1.0]])
    m = np.linalg.solve(k, h)
    m /= np.linalg.norm(m[:, 0]) * (1.0 if m[2, 2] > 0 else -1.0)  # the board in front of the camera
    r = np.c_[m[:, 0], m[:, 1], np.cross(m[:, 0], m[:, 1])]
    u, _, vt = np.linalg.svd(r)
    rot = u @ np.diag([1.0, 1.0, np.linalg.det(u @ vt)]) @ vt
    return pin.SE3(rot, m[:, 2])


def set_placement(problem: Evaluated, x: Array, indices: list[int], placement: pin.SE3) -> None:
    """Set a placement group's parameters in ``x`` to ``log6(placement)`` (its components that are parameters)."""
    delta = pin.log6(placement).vector
    for k in indices:
        x[k] = delta[problem.parameters.parameters[k].component]


def pixel_starts(problem: Evaluated, x: Array) -> bool:
    """Write into ``x`` the start of every camera that pixel measurements read: its intrinsics (those the data do
    not declare), then its placement and its board's; True if one placed the measurement frame (a fixed camera).
    A camera the data do not determine keeps its start (the summary says why)."""
    cameras: dict[tuple[bool, str, str], list[Pixel]] = defaultdict(list)
    for m in problem.measurements:
        if isinstance(m, Pixel):
            cameras[(isinstance(m, BoardPixel), m.frame, m.board_frame if isinstance(m, CrossPixel) else "")
                    ].append(m)
    located = False
    for (fixed, frame, board_frame), models in cameras.items():
        name = intrinsics_name(models[0].camera)
        try:
            located |= _camera_start(problem, x, fixed, frame, models, board_frame)
            problem.placed_in_closed_form.append(name)
        except DataError as why:
            problem.not_in_closed_form.append(f"{name}: {why}")
    return located


def _camera_start(problem: Evaluated, x: Array, fixed: bool, frame: str, models: list[Pixel],
                  board_frame: str = "") -> bool:
    """:func:`pixel_starts` for one camera (``board_frame``: the frame of the board a camera on ``frame`` sees);
    True if it placed the measurement frame."""
    samples = np.flatnonzero(np.any([problem.seen(m.key) for m in models], axis=0))
    images = []
    for k in samples:
        seen = [m for m in models if problem.seen(m.key)[k]]
        if len(seen) >= MIN_CORNERS:
            board = np.array([m.point()[:2] for m in seen])
            uv = np.array([problem.observations.values[m.key][k, :2] for m in seen])
            images.append((int(k), homography(board, uv)))
    groups = problem.parameters.groups("intrinsics")
    owner = models[0].camera
    columns = groups.get(("intrinsics", owner, ""), [])
    nominal = np.array(models[0].intrinsics)
    if not np.any(nominal[:4]) and columns:
        pinhole = zhang_intrinsics([h for _, h in images])
        for c in columns:
            component = problem.parameters.parameters[c].component
            if component < 4:
                x[c] = pinhole[component] - nominal[component]
    pinhole = nominal[:4] + np.array([x[c] for c in columns[:4]]) if len(columns) >= 4 else nominal[:4]
    if len(images) < handeye.MIN_POSES_AX_YB:
        raise DataError(f"{len(images)} images with {MIN_CORNERS} or more corners do not place the camera "
                        f"({handeye.MIN_POSES_AX_YB} or more do)")
    nominal_data = problem.robot.model.createData()
    frame_id = problem.frame_ids[frame]
    a, b = [], []
    for sample, h in images:
        q = problem.solves.solve(problem.robot, sample, problem.observations.actuated[sample])
        pin.framesForwardKinematics(problem.robot.model, nominal_data, q)
        seen = board_pose(h, pinhole)
        if board_frame:
            a.append(nominal_data.oMf[frame_id].actInv(nominal_data.oMf[problem.frame_ids[board_frame]]))
        else:
            a.append(nominal_data.oMf[frame_id].copy())
        b.append(seen if fixed or board_frame else seen.inverse())
    own, world = handeye.solve_ax_yb(a, b)
    places = problem.parameters.groups("camera", "target")
    if board_frame:  # own: the board on its frame; world: the camera on its frame
        for (kind, who), placement in ((("target", f"{board_frame}@{BOARD}"), own), (("camera", frame), world)):
            idx = places.get((kind, who, ""), [])
            if len(idx) == 6:
                set_placement(problem, x, idx, placement)
        return False
    if fixed:
        idx = places.get(("target", f"{frame}@{BOARD}", ""), [])
        if len(idx) == 6:
            set_placement(problem, x, idx, own)
        if len(problem.base) == 6:
            set_placement(problem, x, problem.base, world.inverse())
            return True
        return False
    for (kind, who), placement in ((("camera", frame), own), (("target", ""), world)):
        idx = places.get((kind, who, ""), [])
        if len(idx) == 6:
            set_placement(problem, x, idx, placement)
    return False
