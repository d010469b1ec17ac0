"""Images of a ChArUco board through OpenCV (the optional extra ``pincal[vision]``): its corners detected in
images, synthetic images rendered through a camera, and a camera's intrinsics read from a calibration file.

OpenCV is imported here only, inside the functions: without it, each says in one line how to install it. Pixel
coordinates are OpenCV's (the centre of the top-left pixel at (0, 0)); lengths in metres.
"""

from __future__ import annotations

import hashlib
import math
from collections.abc import Sequence
from dataclasses import field
from pathlib import Path
from typing import Any

import numpy as np
import numpy.typing as npt
import pinocchio as pin

from pincal.errors import DataError, PincalError
from pincal.identification.measurements import INTRINSICS, Board
from pincal.records import record

Array = npt.NDArray[np.float64]

#: The least variance of an image's Laplacian (grey levels²) below which it counts as blurred and is left out:
#: a sharp board image is in the hundreds, a board smeared by motion or out of focus in the single digits.
MIN_SHARPNESS = 30.0
#: The fewest corners an image must show to be kept (fewer fix no homography worth the name).
MIN_CORNERS = 6
#: The board image's resolution when rendering: pixels per square.
PIXELS_PER_SQUARE = 100


class VisionUnavailableError(PincalError):
    """OpenCV with its ``aruco`` module is not installed."""


def opencv() -> Any:
    """The ``cv2`` module, with ``cv2.aruco``.

    Raises:
        VisionUnavailableError: OpenCV (its contrib build) is not installed: the message says how to install it.
    """
    try:
        import cv2
    except ImportError:
        raise VisionUnavailableError('images need OpenCV: pip install "pincal[vision]" (opencv-contrib-python-'
                                     'headless)') from None
    if not hasattr(cv2, "aruco") or not hasattr(cv2.aruco, "CharucoDetector"):
        raise VisionUnavailableError(f'OpenCV {cv2.__version__} lacks the aruco module\'s CharucoDetector (4.8 or '
                                     'later): pip install "pincal[vision]"')
    return cv2


def charuco_board(board: Board) -> Any:
    """OpenCV's ``CharucoBoard`` (or ``GridBoard``, for a grid of markers) of ``board``.

    Raises:
        DataError: a dictionary OpenCV does not know (the message lists some).
    """
    cv2 = opencv()
    code = getattr(cv2.aruco, board.dictionary, None)
    if not isinstance(code, int) or not board.dictionary.startswith("DICT_"):
        known = [n for n in dir(cv2.aruco) if n.startswith("DICT_")]
        raise DataError(f"board dictionary '{board.dictionary}' is not one of OpenCV's: {', '.join(known[:8])}, …")
    dictionary = cv2.aruco.getPredefinedDictionary(code)
    markers = board.cols * board.rows if board.kind == "aruco" else (board.cols * board.rows) // 2
    if markers > dictionary.bytesList.shape[0]:
        raise DataError(f"board {board.spec} needs {markers} markers; dictionary {board.dictionary} has "
                        f"{dictionary.bytesList.shape[0]}")
    if board.kind == "aruco":
        return cv2.aruco.GridBoard((board.cols, board.rows), board.marker, board.separation, dictionary)
    return cv2.aruco.CharucoBoard((board.cols, board.rows), board.square, board.marker, dictionary)


def camera_matrix(intrinsics: Sequence[float]) -> tuple[Array, Array]:
    """OpenCV's 3 × 3 camera matrix [px] and its 5 distortion coefficients (k1, k2, p1, p2, k3) from the nine
    :data:`~pincal.identification.measurements.INTRINSICS`."""
    fx, fy, cx, cy = intrinsics[:4]
    return (np.array([[fx, 0.0, cx], [0.0, fy, cy], [0.0, 0.0, 1.0]]),
            np.array(intrinsics[4:], dtype=float))


def pixel_rays(intrinsics: Sequence[float], size: tuple[int, int]) -> Array:
    """(height · width, 2) each pixel's ray, ``(X/Z, Y/Z)`` in the camera's frame, the distortion undone: what
    :func:`render` warps the board through (the same for every image of one camera)."""
    cv2 = opencv()
    width, height = size
    k, dist = camera_matrix(intrinsics)
    u, v = np.meshgrid(np.arange(width, dtype=float), np.arange(height, dtype=float))
    pixels = np.stack([u.ravel(), v.ravel()], axis=1)[:, None, :]
    rays: Array = cv2.undistortPointsIter(pixels, k, dist, None, None,
                                          (cv2.TERM_CRITERIA_COUNT | cv2.TERM_CRITERIA_EPS, 30, 1e-10))
    return rays.reshape(-1, 2)


def render(board: Board, view: pin.SE3, rays: Array, size: tuple[int, int], blur: float,
           noise: float, rng: np.random.Generator) -> npt.NDArray[np.uint8]:
    """A grey image of ``board`` seen by the camera: OpenCV's image of the board warped through the camera.

    Args:
        board: The board.
        view: Its placement in the camera (camera ← board) [m, rad].
        rays: The camera's :func:`pixel_rays`.
        size: (width, height) [px].
        blur: σ of the Gaussian blur [px] (0: none).
        noise: σ of the Gaussian noise [grey levels].
        rng: Random generator (the noise).
    """
    cv2 = opencv()
    plate = charuco_board(board)
    pixels = (round(board.extent[0] / board.square * PIXELS_PER_SQUARE),
              round(board.extent[1] / board.square * PIXELS_PER_SQUARE))
    image = plate.generateImage(pixels, marginSize=0)
    width, height = size
    plane = np.c_[view.rotation[:, 0], view.rotation[:, 1], view.translation]  # (x, y, 1) ~ plane (X, Y, 1)
    on_board = np.linalg.solve(plane, np.c_[rays, np.ones(len(rays))].T).T
    w = on_board[:, 2]
    scale_x, scale_y = pixels[0] / board.extent[0], pixels[1] / board.extent[1]  # board image px per m
    with np.errstate(divide="ignore", invalid="ignore"):
        xs = np.where(w > 0, on_board[:, 0] / w * scale_x - 0.5, -1e6).astype(np.float32).reshape(height, width)
        ys = np.where(w > 0, on_board[:, 1] / w * scale_y - 0.5, -1e6).astype(np.float32).reshape(height, width)
    seen = cv2.remap(image, xs, ys, cv2.INTER_LINEAR, borderMode=cv2.BORDER_CONSTANT, borderValue=235)
    out = seen.astype(float)
    if blur > 0:
        out = cv2.GaussianBlur(out, (0, 0), blur)
    out += rng.normal(scale=noise, size=out.shape)
    grey: npt.NDArray[np.uint8] = np.clip(np.rint(out), 0, 255).astype(np.uint8)
    return grey


def write_image(path: Path, image: npt.NDArray[np.uint8]) -> None:
    """Write ``image`` to ``path`` (PNG).

    Raises:
        DataError: OpenCV could not write it.
    """
    cv2 = opencv()
    if not cv2.imwrite(str(path), image):
        raise DataError(f"could not write image {path}")


@record
class Detections:
    """The corners found in images.

    Attributes:
        corners: Image name (its file's stem) -> (ids (n,), pixels (n, 2) [px]) of the corners found.
        left_out: Image file -> why it was left out (too few corners, blurred, a duplicate, unreadable).
        size: (width, height) [px] of the images (the first one's).
    """

    corners: dict[str, tuple[npt.NDArray[np.intp], Array]] = field(default_factory=dict)
    left_out: dict[str, str] = field(default_factory=dict)
    size: tuple[int, int] = (0, 0)


def sharpness(image: npt.NDArray[np.uint8]) -> float:
    """The variance of the image's Laplacian [grey levels²]: small for a blurred image."""
    cv2 = opencv()
    return float(cv2.Laplacian(image, cv2.CV_64F).var())


def detect_corners(paths: Sequence[str | Path], board: Board, min_corners: int = MIN_CORNERS,
                   min_sharpness: float = MIN_SHARPNESS) -> Detections:
    """The ChArUco corners of ``board`` in each image (OpenCV's ``CharucoDetector``), every image accounted for:
    those unreadable, of another size than the first, duplicated (the same name twice, or the same content as an
    earlier one), blurred (:func:`sharpness` below ``min_sharpness``) or showing fewer than ``min_corners`` corners
    are left out, with the reason.

    Raises:
        DataError: no image given.
    """
    if not paths:
        raise DataError("no image given")
    cv2 = opencv()
    plate = charuco_board(board)
    if board.kind == "aruco":
        parameters = cv2.aruco.DetectorParameters()
        parameters.cornerRefinementMethod = cv2.aruco.CORNER_REFINE_SUBPIX
        markers = cv2.aruco.ArucoDetector(plate.getDictionary(), parameters)
    else:
        detector = cv2.aruco.CharucoDetector(plate)
    out = Detections()
    stems: dict[str, list[Path]] = {}
    for path in map(Path, paths):
        stems.setdefault(path.stem, []).append(path)
    hashes: dict[str, str] = {}
    for stem, same in stems.items():
        if len(same) > 1:
            for path in same:
                out.left_out[str(path)] = (f"its name '{stem}' is shared by {len(same)} images "
                                           f"({', '.join(str(p) for p in same)}): which joint row it pairs with is "
                                           "ambiguous")
            continue
        path = same[0]
        if path.is_dir():
            out.left_out[str(path)] = f"a directory, not an image: give its images ({path}/*.png)"
            continue
        try:
            content = path.read_bytes()
        except OSError as exc:
            out.left_out[str(path)] = f"unreadable: {exc.strerror or exc}"
            continue
        digest = hashlib.sha256(content).hexdigest()
        if digest in hashes:
            out.left_out[str(path)] = f"the same image as {hashes[digest]}"
            continue
        hashes[digest] = str(path)
        image = cv2.imdecode(np.frombuffer(content, np.uint8), cv2.IMREAD_GRAYSCALE) if content else None
        if image is None:
            out.left_out[str(path)] = "not an image OpenCV reads"
            continue
        size = (int(image.shape[1]), int(image.shape[0]))
        if out.size == (0, 0):
            out.size = size
        elif size != out.size:
            out.left_out[str(path)] = f"its size {size[0]}x{size[1]} px differs from the first image's " \
                                      f"{out.size[0]}x{out.size[1]}"
            continue
        sharp = sharpness(image)
        if sharp < min_sharpness:
            out.left_out[str(path)] = (f"blurred: the variance of its Laplacian is {sharp:.3g}, below "
                                       f"{min_sharpness:g}")
            continue
        if board.kind == "aruco":
            corners, ids = _grid_corners(markers, image, board)
        else:
            corners, ids, _, _ = detector.detectBoard(image)
        found = 0 if ids is None else len(ids)
        if found < min_corners:
            out.left_out[str(path)] = f"{found} corners found, fewer than {min_corners}"
            continue
        order = np.argsort(ids.ravel())
        out.corners[stem] = (ids.ravel()[order].astype(np.intp), corners.reshape(-1, 2)[order].astype(float))
    return out


def _grid_corners(detector: Any, image: npt.NDArray[np.uint8], board: Board) -> tuple[Array, Any]:
    """The corners (n, 1, 2) [px] of a grid's markers found in ``image``, and their corner numbers (n, 1): marker
    ``i``'s corner ``j`` is ``4 i + j``; markers of other ids are ignored."""
    found, ids, _ = detector.detectMarkers(image)
    if ids is None:
        return np.zeros((0, 1, 2)), None
    points, numbers = [], []
    for quad, marker in zip(found, ids.ravel().tolist(), strict=True):
        if marker < board.cols * board.rows:
            points += list(quad.reshape(4, 2))
            numbers += [4 * marker + j for j in range(4)]
    if not numbers:
        return np.zeros((0, 1, 2)), None
    return np.array(points).reshape(-1, 1, 2), np.array(numbers).reshape(-1, 1)


def read_camera_file(path: str | Path) -> tuple[float, ...]:
    """A camera's nine intrinsics (fx, fy, cx, cy [px], k1, k2, p1, p2, k3) from an OpenCV calibration file (YAML
    or XML: ``camera_matrix`` and ``distortion_coefficients``) or a ROS ``camera_info`` YAML (``camera_matrix`` and
    ``distortion_coefficients`` with ``data`` lists, or a ``CameraInfo`` message's ``k`` and ``d``).

    Raises:
        DataError: unreadable, or without a 3 × 3 camera matrix and 4, 5 or more distortion coefficients.
    """
    path = Path(path)
    try:
        text = path.read_text(encoding="utf-8")
    except (OSError, UnicodeDecodeError) as exc:
        raise DataError(f"camera file {path}: cannot be read ({exc})") from None
    matrix, dist = (_opencv_file(path) if text.lstrip().startswith(("%YAML", "<?xml", "<opencv_storage"))
                    else _ros_file(path, text))
    if matrix.size != 9 or dist.size < 4 or not np.all(np.isfinite(matrix)) or not np.all(np.isfinite(dist)):
        raise DataError(f"camera file {path}: needs a 3x3 camera matrix and 4 or 5 distortion coefficients (k1 k2 "
                        f"p1 p2 [k3]); found {matrix.size} and {dist.size} numbers")
    m = matrix.reshape(3, 3)
    d = np.r_[dist.ravel()[:5], np.zeros(max(0, 5 - dist.size))]
    if dist.size > 5 and np.any(dist.ravel()[5:] != 0):
        raise DataError(f"camera file {path}: distortion coefficients beyond k3 ({dist.size} given) are not "
                        "OpenCV's five-coefficient model pincal estimates")
    return tuple(float(v) for v in (m[0, 0], m[1, 1], m[0, 2], m[1, 2], *d))


def _opencv_file(path: Path) -> tuple[Array, Array]:
    """The camera matrix and distortion of an OpenCV ``FileStorage`` file."""
    cv2 = opencv()
    storage = cv2.FileStorage(str(path), cv2.FILE_STORAGE_READ)
    try:
        matrix, dist = storage.getNode("camera_matrix").mat(), storage.getNode("distortion_coefficients").mat()
    finally:
        storage.release()
    if matrix is None or dist is None:
        raise DataError(f"camera file {path}: no camera_matrix and distortion_coefficients (OpenCV's names)")
    return np.asarray(matrix, dtype=float), np.asarray(dist, dtype=float)


def _ros_file(path: Path, text: str) -> tuple[Array, Array]:
    """The camera matrix and distortion of a ROS ``camera_info`` YAML."""
    import yaml

    try:
        data = yaml.safe_load(text)
    except yaml.YAMLError as exc:
        raise DataError(f"camera file {path}: not YAML ({str(exc).splitlines()[0]})") from None
    if not isinstance(data, dict):
        raise DataError(f"camera file {path}: not a camera_info YAML (a mapping)")

    def numbers(*names: str) -> Array:
        for name in names:
            value = data.get(name)
            if isinstance(value, dict):
                value = value.get("data")
            if isinstance(value, list):
                try:
                    return np.array([float(v) for v in value])
                except (TypeError, ValueError):
                    break
        raise DataError(f"camera file {path}: no {' or '.join(names)} list of numbers")

    return numbers("camera_matrix", "k", "K"), numbers("distortion_coefficients", "d", "D")


def intrinsics_text(values: Sequence[float]) -> str:
    """The nine intrinsics as a metadata value (``# intrinsics …: fx fy cx cy k1 k2 p1 p2 k3``)."""
    if len(values) != len(INTRINSICS) or not all(math.isfinite(v) for v in values):
        raise DataError(f"intrinsics {list(values)}: need nine finite numbers")
    return " ".join(repr(float(v)) for v in values)
