"""Pixels: the image coordinates of a calibration board's corners seen by a camera, with the camera's intrinsics.

A reading is one corner of a board (a ChArUco board's inner chessboard corners) seen in one image: its column
``u`` and row ``v`` [px]. Two set-ups:

- eye-in-hand, key ``pixel:<frame>@<corner>``: a camera fixed on robot frame ``<frame>`` (``camera.<frame>.*``)
  sees a board fixed in the robot's world (``target.*``); the camera's intrinsics are ``intrinsics.<frame>.*``;
- eye-to-hand, key ``board_pixel:<frame>@<corner>``: a camera fixed in the cell, the measurement frame
  (``base.*``: the robot's world in the camera's frame), sees a board fixed on ``<frame>``
  (``target.<frame>@board.*``); its intrinsics are ``intrinsics.*``.

The projection is OpenCV's: with ``x = X/Z``, ``y = Y/Z``, ``r² = x² + y²``,
``x'' = x (1 + k1 r² + k2 r⁴ + k3 r⁶) + 2 p1 x y + p2 (r² + 2x²)`` (and ``y''`` alike with ``p1``, ``p2``
exchanged), ``u = fx x'' + cx``, ``v = fy y'' + cy``. The intrinsics ``fx, fy, cx, cy`` [px] and ``k1, k2, p1,
p2, k3`` [1] are the nominal values the data declare (``# intrinsics <frame>: fx fy cx cy k1 k2 p1 p2 k3``; zero
where not declared: the start estimates them) plus their parameters. ``# intrinsics <frame> held: …`` holds them at
the values given (no parameters). The board's corners come from ``# board: charuco:COLSxROWS:SQUARE:MARKER:DICT``
(corner ``k`` at ``((k mod (COLS−1)) + 1, (k div (COLS−1)) + 1) · SQUARE`` [m] in the board's frame, OpenCV's) or
``# board: aruco:COLSxROWS:MARKER:SEPARATION:DICT`` (a grid of ArUco or AprilTag markers: four corners each).

What the pixels cannot tell apart: a focal length against the camera's distance to the board (images from one
distance and straight on confuse the two; tilted views and varied distances separate them) and the principal
point against the camera's rotation (a shift of ``cx`` looks like a turn about the camera's y axis unless views
from several directions disagree).
"""

from __future__ import annotations

import re
from collections.abc import Mapping
from dataclasses import replace
from typing import ClassVar, NamedTuple

import numpy as np
import numpy.typing as npt
import pinocchio as pin

from pincal.errors import DataError
from pincal.identification.batch import BatchContext, point_rows
from pincal.identification.measurements.base import Attachment, Measurement
from pincal.identification.measurements.context import (
    WORLD_TARGET,
    AttachedPlacement,
    SampleContext,
    camera_name,
    target_name,
)
from pincal.model.rotations import cross_columns, rotate
from pincal.records import record

Array = npt.NDArray[np.float64]

#: The intrinsics of a camera, OpenCV's order: the pinhole fx, fy, cx, cy [px], then the distortion k1, k2, p1, p2,
#: k3 [1].
INTRINSICS = ("fx", "fy", "cx", "cy", "k1", "k2", "p1", "p2", "k3")
#: The name of the pose target a fixed camera sees on a frame (``target.<frame>@board``).
BOARD = "board"
#: The board a simulation shows when none is given: 8 × 6 squares of 30 mm, markers of 22 mm (35 corners).
BOARD_DEFAULT = "charuco:8x6:0.03:0.022:DICT_4X4_50"
_BOARD = re.compile(r"(charuco|aruco):(\d+)x(\d+):([0-9.eE+-]+):([0-9.eE+-]+):(\w+)")


@record(frozen=True)
class Board:
    """A calibration board, as OpenCV draws it: a ChArUco board (``kind`` ``charuco``: ``cols`` × ``rows`` squares of
    side ``square`` [m] with ArUco markers of side ``marker`` [m]; its corners the inner chessboard corners) or a grid
    of ArUco or AprilTag markers (``aruco``: ``cols`` × ``rows`` markers of side ``marker`` [m] every ``square`` [m];
    its corners each marker's four), from dictionary ``dictionary`` (OpenCV's name, ``DICT_4X4_50``,
    ``DICT_APRILTAG_36h11``)."""

    cols: int
    rows: int
    square: float
    marker: float
    dictionary: str
    kind: str = "charuco"
    #: A grid's gap between markers [m] (its ``square`` is the pitch, marker + gap).
    separation: float = 0.0

    @property
    def spec(self) -> str:
        """The board as ``charuco:COLSxROWS:SQUARE:MARKER:DICT`` or ``aruco:COLSxROWS:MARKER:SEPARATION:DICT``."""
        if self.kind == "aruco":
            return f"aruco:{self.cols}x{self.rows}:{self.marker!r}:{self.separation!r}:{self.dictionary}"
        return f"charuco:{self.cols}x{self.rows}:{self.square!r}:{self.marker!r}:{self.dictionary}"

    @property
    def n_corners(self) -> int:
        """Its corners: ``(cols − 1)(rows − 1)`` inner chessboard corners, or four per marker of a grid."""
        return 4 * self.cols * self.rows if self.kind == "aruco" else (self.cols - 1) * (self.rows - 1)

    @property
    def extent(self) -> tuple[float, float]:
        """Its printed width and height [m]."""
        if self.kind == "aruco":
            return (self.cols * self.square - self.separation, self.rows * self.square - self.separation)
        return (self.cols * self.square, self.rows * self.square)

    def corner(self, k: int) -> Array:
        """(3,) corner ``k`` [m] in the board's frame (z = 0, OpenCV's numbering: a ChArUco board's row by row; a
        grid's marker ``k div 4``'s corner ``k mod 4``, clockwise from its top left)."""
        if self.kind == "aruco":
            cell, which = divmod(k, 4)
            origin = np.array([cell % self.cols, cell // self.cols]) * self.square
            offset = np.array([(0.0, 0.0), (1.0, 0.0), (1.0, 1.0), (0.0, 1.0)][which]) * self.marker
            point: Array = np.r_[origin + offset, 0.0]
            return point
        per_row = self.cols - 1
        return np.array([(k % per_row + 1) * self.square, (k // per_row + 1) * self.square, 0.0])

    def corners(self) -> Array:
        """(n_corners, 3) every corner [m] in the board's frame."""
        return np.array([self.corner(k) for k in range(self.n_corners)])


def parse_board(spec: str) -> Board:
    """The board of ``charuco:COLSxROWS:SQUARE:MARKER:DICT`` or ``aruco:COLSxROWS:MARKER:SEPARATION:DICT`` (lengths
    [m]; an AprilTag grid is an ``aruco`` grid of a ``DICT_APRILTAG_…`` dictionary).

    Raises:
        DataError: another form, fewer than 2 × 2 squares (1 × 1 markers), or a marker not smaller than its square.
    """
    match = _BOARD.fullmatch(spec.strip())
    if not match:
        raise DataError(f"board '{spec}' is not charuco:COLSxROWS:SQUARE:MARKER:DICT nor "
                        "aruco:COLSxROWS:MARKER:SEPARATION:DICT (e.g. charuco:7x5:0.04:0.03:DICT_4X4_50, "
                        "aruco:4x3:0.05:0.01:DICT_APRILTAG_36h11, lengths in metres)")
    kind, cols, rows, first, second = match[1], int(match[2]), int(match[3]), float(match[4]), float(match[5])
    if kind == "aruco":
        if cols < 1 or rows < 1 or not 0 < first <= 1.0 or not 0 <= second <= 1.0:
            raise DataError(f"board '{spec}': needs at least 1x1 markers, 0 < MARKER <= 1 m and 0 <= SEPARATION <= 1 m")
        return Board(cols, rows, first + second, first, match[6], "aruco", second)
    if cols < 2 or rows < 2 or not 0 < second < first or first > 1.0:
        raise DataError(f"board '{spec}': needs at least 2x2 squares and 0 < MARKER < SQUARE <= 1 m")
    return Board(cols, rows, first, second, match[6])


def project(points: Array, k: Array) -> tuple[Array, Array, Array]:
    """OpenCV's projection of points in the camera's frame.

    Args:
        points: (N, 3) points [m] in the camera's frame (z forward).
        k: (9,) intrinsics in :data:`INTRINSICS` order ([px], then [1]).

    Returns:
        ``uv`` (N, 2) [px], ``d uv / d point`` (N, 2, 3) [px/m], ``d uv / d k`` (N, 2, 9) [px per unit].
    """
    fx, fy, _, _, k1, k2, p1, p2, k3 = k
    z = points[:, 2]
    x, y = points[:, 0] / z, points[:, 1] / z
    r2 = x * x + y * y
    radial = 1.0 + r2 * (k1 + r2 * (k2 + r2 * k3))
    dradial = k1 + r2 * (2.0 * k2 + 3.0 * r2 * k3)  # d radial / d r²
    xd = x * radial + 2.0 * p1 * x * y + p2 * (r2 + 2.0 * x * x)
    yd = y * radial + p1 * (r2 + 2.0 * y * y) + 2.0 * p2 * x * y
    uv = np.stack([fx * xd + k[2], fy * yd + k[3]], axis=1)
    dxd = np.empty((len(z), 2, 2))  # d(x'', y'') / d(x, y)
    dxd[:, 0, 0] = radial + 2.0 * x * x * dradial + 2.0 * p1 * y + 6.0 * p2 * x
    dxd[:, 0, 1] = 2.0 * x * y * dradial + 2.0 * p1 * x + 2.0 * p2 * y
    dxd[:, 1, 0] = 2.0 * x * y * dradial + 2.0 * p1 * x + 2.0 * p2 * y
    dxd[:, 1, 1] = radial + 2.0 * y * y * dradial + 6.0 * p1 * y + 2.0 * p2 * x
    dxd[:, 0] *= fx
    dxd[:, 1] *= fy
    dnorm = np.zeros((len(z), 2, 3))  # d(x, y) / d point
    dnorm[:, 0, 0] = dnorm[:, 1, 1] = 1.0 / z
    dnorm[:, 0, 2] = -x / z
    dnorm[:, 1, 2] = -y / z
    dk = np.zeros((len(z), 2, 9))
    dk[:, 0, 0], dk[:, 1, 1], dk[:, 0, 2], dk[:, 1, 3] = xd, yd, 1.0, 1.0
    for c, scale in ((0, fx), (1, fy)):
        own = x if c == 0 else y
        dk[:, c, 4], dk[:, c, 5], dk[:, c, 8] = scale * own * r2, scale * own * r2 ** 2, scale * own * r2 ** 3
    dk[:, 0, 6], dk[:, 0, 7] = fx * 2.0 * x * y, fx * (r2 + 2.0 * x * x)
    dk[:, 1, 6], dk[:, 1, 7] = fy * (r2 + 2.0 * y * y), fy * 2.0 * x * y
    return uv, np.matmul(dxd, dnorm), dk


def intrinsics_name(owner: str) -> str:
    """The intrinsics' parameter prefix of the camera on frame ``owner`` (``intrinsics.<frame>``), or of the fixed
    camera (``owner`` empty: ``intrinsics``)."""
    return f"intrinsics.{owner}" if owner else "intrinsics"


def declared_intrinsics(metadata: Mapping[str, str], owner: str) -> tuple[tuple[float, ...] | None, bool]:
    """The nominal intrinsics a dataset declares for the camera ``owner`` (a frame, or empty: the fixed camera) and
    whether they are held (``# intrinsics <frame> held: …``); None when it declares none.

    Raises:
        DataError: a declaration that is not nine finite numbers.
    """
    name = f"intrinsics {owner}".strip()
    for key, held in ((name, False), (f"{name} held", True)):
        if key in metadata:
            try:
                values = tuple(float(v) for v in metadata[key].split())
            except ValueError:
                values = ()
            if len(values) != len(INTRINSICS) or not all(np.isfinite(values)):
                raise DataError(f"metadata '# {key}: {metadata[key]}' is not nine numbers "
                                f"{' '.join(INTRINSICS)} (px, then dimensionless)")
            return values, held
    return None, False


@record(frozen=True)
class Pixel(Measurement):
    """Eye-in-hand: a camera on ``frame`` sees corner ``corner`` of a board fixed in the world; the values are its
    ``u``, ``v`` [px] (both empty: not seen). Key ``pixel:<frame>@<corner>``."""

    kinds: ClassVar[tuple[str, ...]] = ("pixel",)
    components: ClassVar[tuple[str, ...]] = ("u", "v")
    units: ClassVar[tuple[str, ...]] = ("px", "px")
    occludable: ClassVar[bool] = True
    sighted: ClassVar[str] = "board corner"

    frame: str = ""
    corner: int = 0
    board: Board | None = None
    #: The nominal intrinsics (:data:`INTRINSICS`; zero: not declared) and whether they are held at them.
    intrinsics: tuple[float, ...] = (0.0,) * 9
    held: bool = False

    @classmethod
    def from_key(cls, kind: str, rest: str, sigma: float | None) -> Measurement:
        """The model of key ``pixel:<frame>@<corner>``; σ [px] defaults to 0.5."""
        return _from_key(cls, kind, rest, sigma)

    @property
    def frames(self) -> tuple[str, ...]:
        """The frame carrying the camera (eye-in-hand) or the board (eye-to-hand)."""
        return (self.frame,)

    @property
    def camera(self) -> str:
        """The owner of the camera's intrinsics: its frame (empty: the fixed camera)."""
        return self.frame

    @property
    def attachments(self) -> tuple[Attachment, ...]:
        """The camera on the frame, the board in the world and the intrinsics (unless held)."""
        own = (Attachment("camera", self.frame), Attachment("target", ""))
        return own if self.held else (*own, Attachment("intrinsics", self.camera, INTRINSICS))

    def row_units(self) -> list[str]:
        """Two rows in pixels."""
        return ["px", "px"]

    def with_metadata(self, metadata: Mapping[str, str]) -> Measurement:
        """This model with the board and the intrinsics the dataset declares.

        Raises:
            DataError: no ``# board`` line, or a corner the board lacks.
        """
        if "board" not in metadata:
            raise DataError(f"measurement '{self.key}' needs the board: a metadata line '# board: "
                            "charuco:COLSxROWS:SQUARE:MARKER:DICT' (what pincal detect writes)")
        board = parse_board(metadata["board"])
        if self.corner >= board.n_corners:
            raise DataError(f"measurement '{self.key}': corner {self.corner} is not on board {board.spec} "
                            f"(corners 0 to {board.n_corners - 1})")
        values, held = declared_intrinsics(metadata, self.camera)
        return replace(self, board=board, intrinsics=values or (0.0,) * 9, held=held)

    def point(self) -> Array:
        """(3,) its corner [m] on the board."""
        if self.board is None:
            raise DataError(f"measurement '{self.key}' has no board (a '# board' metadata line)")
        return self.board.corner(self.corner)

    def camera_intrinsics(self, ctx: SampleContext) -> tuple[Array, list[int], list[int]]:
        """The intrinsics at this estimate (9,), their parameter columns and the intrinsics each column is."""
        terms = ctx.intrinsics.get(intrinsics_name(self.camera))
        k = np.array(self.intrinsics, dtype=float)
        if terms is None:
            return k, [], []
        k[terms.components] += terms.delta
        return k, terms.columns, terms.components

    def predict(self, ctx: SampleContext, out: Array, jac: Array | None) -> None:
        """``p = C⁻¹ F⁻¹ G b`` (C the camera on F, G the board, b the corner) projected: with ``z = F⁻¹ G b``, the
        derivatives of p are ``R_Cᵀ (−ξ_v + ẑ ξ_ω)`` (robot), ``−J_v + p̂ J_ω`` (camera) and
        ``R_Cᵀ R_Fᵀ R_G (J_v − b̂ J_ω)`` (board), each through the projection's ``∂uv/∂p``."""
        frame = ctx.placement(self.frame)
        camera = ctx.attached_placement(camera_name(self.frame))
        board = ctx.attached_placement(WORLD_TARGET)
        b = self.point()
        local = frame.actInv(board.placement.act(b))
        seen = camera.placement.actInv(local)
        k, columns, components = self.camera_intrinsics(ctx)
        uv, dp, dk = project(seen[None], k)
        out[:2] = uv[0]
        if jac is None:
            return
        twist = ctx.twists[self.frame]
        rot_c = camera.placement.rotation
        dseen = rot_c.T @ (-twist[:3] + pin.skew(local) @ twist[3:])
        dseen[:, camera.columns] += -camera.jacobian[:3] + pin.skew(seen) @ camera.jacobian[3:]
        dseen[:, board.columns] += rot_c.T @ frame.rotation.T @ board.point_columns(b)
        jac[:2] = dp[0] @ dseen
        jac[:2, columns] += dk[0][:, components]

    def batch_intrinsics(self, batch: BatchContext) -> tuple[Array, list[int], list[int]]:
        """:meth:`camera_intrinsics` of a batch's evaluation."""
        return self.camera_intrinsics(batch.shared)

    def view_batch(self, batch: BatchContext, world: Array, out: Array) -> CameraView:
        """The corner at ``world`` [m] (in the robot's world: (N, 3), one row per sample, or (1, 3), fixed there)
        seen by the camera on :attr:`frame`: its pixels written to ``out[:, :2]`` [px], and what its Jacobian is built
        from."""
        rot_f, pos_f = batch.rotations[self.frame], batch.translations[self.frame]
        camera = batch.shared.attached_placement(camera_name(self.frame))
        local = np.matmul(rot_f.transpose(0, 2, 1), (world - pos_f)[:, :, None])[:, :, 0]
        seen = (local - camera.placement.translation) @ camera.placement.rotation
        k, columns, components = self.batch_intrinsics(batch)
        uv, dp, dk = project(seen, k)
        out[:, :2] = uv
        return CameraView(seen, dp, dk, camera, rot_f, columns, components)

    def predict_batch(self, batch: BatchContext, out: Array, jac: Array | None) -> None:
        """:meth:`predict` for every sample: the robot's columns are ``∂uv/∂p · (−R_Cᵀ R_Fᵀ (W_v − ĝ W_ω))``, W the
        frame's spatial twist, g the corner in the world."""
        board = batch.shared.attached_placement(WORLD_TARGET)
        b = self.point()
        world = board.placement.act(b)
        view = self.view_batch(batch, world[None], out)
        if jac is None:
            return
        dback = view.back()
        at_point = np.hstack([-np.eye(3), pin.skew(world)])
        batch.derivative(self.frame, np.matmul(dback, at_point), out=jac)
        view.add_camera_columns(jac)
        if board.columns:
            moved = board.point_columns(b)
            jac[:, :, board.columns] += np.matmul(dback, moved)
        view.add_intrinsics_columns(jac)


class CameraView(NamedTuple):
    """A corner seen by a camera on a robot frame, every sample of a batch (:meth:`Pixel.view_batch`; a tuple: one
    is made per model and evaluation).

    Attributes:
        seen: (N, 3) the corner [m] in the camera's frame.
        dp: (N, 2, 3) ``∂uv/∂p`` [px/m], the projection's derivative by ``seen``.
        dk: (N, 2, 9) ``∂uv/∂k`` [px per unit], by the intrinsics.
        camera: The camera's placement on its frame, with its parameter columns.
        rot_f: (N, 3, 3) the camera frame's rotation in the world.
        columns: The intrinsics' parameter columns.
        components: The intrinsic (index in :data:`INTRINSICS`) each of ``columns`` is.
    """

    seen: Array
    dp: Array
    dk: Array
    camera: AttachedPlacement
    rot_f: Array
    columns: list[int]
    components: list[int]

    def back(self) -> Array:
        """(N, 2, 3) ``∂uv/∂p · R_Cᵀ R_Fᵀ`` [px/m]: the pixels' derivative by the corner in the world."""
        back: Array = np.matmul(self.dp, rotate(self.camera.placement.rotation.T, self.rot_f.transpose(0, 2, 1)))
        return back

    def add_camera_columns(self, jac: Array) -> None:
        """Adds to ``jac`` (N, 2, n) [px per unit] the columns of the camera's placement on its frame."""
        camera = self.camera
        if camera.columns:
            jc = np.broadcast_to(camera.jacobian, (len(self.seen), 6, len(camera.columns)))
            jac[:, :, camera.columns] += np.matmul(self.dp, -jc[:, :3] + cross_columns(self.seen, jc[:, 3:]))

    def add_intrinsics_columns(self, jac: Array) -> None:
        """Adds to ``jac`` (N, 2, n) [px per unit] the columns of the camera's intrinsics."""
        if self.columns:
            jac[:, :, self.columns] += self.dk[:, :, self.components]


@record(frozen=True)
class BoardPixel(Pixel):
    """Eye-to-hand: a camera fixed in the cell (the measurement frame) sees corner ``corner`` of a board fixed on
    ``frame``; the values are its ``u``, ``v`` [px]. Key ``board_pixel:<frame>@<corner>``."""

    kinds: ClassVar[tuple[str, ...]] = ("board_pixel",)

    @classmethod
    def from_key(cls, kind: str, rest: str, sigma: float | None) -> Measurement:
        """The model of key ``board_pixel:<frame>@<corner>``; σ [px] defaults to 0.5."""
        return _from_key(cls, kind, rest, sigma)

    @property
    def in_measurement_frame(self) -> bool:
        """True: the fixed camera is the measurement frame (``base.*``)."""
        return True

    @property
    def camera(self) -> str:
        """Empty: the fixed camera."""
        return ""

    @property
    def attachments(self) -> tuple[Attachment, ...]:
        """The board on the frame (``target.<frame>@board.*``) and the fixed camera's intrinsics (unless held);
        the camera itself is the measurement frame (``base.*``)."""
        own = (Attachment("target", f"{self.frame}@{BOARD}"),)
        return own if self.held else (*own, Attachment("intrinsics", "", INTRINSICS))

    def predict(self, ctx: SampleContext, out: Array, jac: Array | None) -> None:
        """``p = B F T b`` (B the base, the robot's world in the camera; T the board on F) projected: the
        derivatives of p are ``R_B R_F (ξ_v − (T b)^ ξ_ω)`` (robot), ``R_B R_F R_T (J_v − b̂ J_ω)`` (board) and
        ``R_B [I, −ŵ] J_B`` (base, w the corner in the world)."""
        frame = ctx.placement(self.frame)
        board = ctx.attached_placement(target_name(self.frame, BOARD))
        b = self.point()
        on_frame = board.placement.act(b)
        world = frame.act(on_frame)
        seen = ctx.base.act(world)
        k, columns, components = self.camera_intrinsics(ctx)
        uv, dp, dk = project(seen[None], k)
        out[:2] = uv[0]
        if jac is None:
            return
        twist = ctx.twists[self.frame]
        rot_bf = ctx.base.rotation @ frame.rotation
        dseen = rot_bf @ (twist[:3] - pin.skew(on_frame) @ twist[3:])
        dseen[:, board.columns] += rot_bf @ board.point_columns(b)
        if ctx.base_columns:
            dseen[:, ctx.base_columns] = (ctx.base.rotation @ np.hstack([np.eye(3), -pin.skew(world)])
                                          @ ctx.base_jacobian)
        jac[:2] = dp[0] @ dseen
        jac[:2, columns] += dk[0][:, components]

    def predict_batch(self, batch: BatchContext, out: Array, jac: Array | None) -> None:
        """:meth:`predict` for every sample: the robot's columns are ``∂uv/∂p · R_B [I, −ŵ] W``, W the frame's
        spatial twist."""
        board = batch.shared.attached_placement(target_name(self.frame, BOARD))
        b = self.point()
        on_frame = board.placement.act(b)
        world = batch.point(self.frame, on_frame)
        base = batch.base
        seen = world @ base.rotation.T + base.translation
        k, columns, components = self.batch_intrinsics(batch)
        uv, dp, dk = project(seen, k)
        out[:, :2] = uv
        if jac is None:
            return
        batch.derivative(self.frame, np.matmul(dp, point_rows(world, base.rotation)), out=jac)
        if board.columns:
            moved = board.point_columns(b)
            rot = rotate(base.rotation, batch.rotations[self.frame])  # R_B R_F
            jac[:, :, board.columns] += np.matmul(np.matmul(dp, rot), moved)
        if batch.shared.base_columns:
            jac[:, :, batch.shared.base_columns] = np.matmul(dp, batch.base_columns(world))
        if columns:
            jac[:, :, columns] += dk[:, :, components]


def _from_key(cls: type[Pixel], kind: str, rest: str, sigma: float | None) -> Pixel:
    """A pixel model of class ``cls`` from its key's ``<frame>@<corner>``; σ [px] defaults to 0.5."""
    frame, at, corner = rest.rpartition("@")
    if not at or not frame or not corner.isdigit():
        raise DataError(f"measurement '{kind}:{rest}' is not {kind}:<frame>@<corner> (corner a number)")
    return cls(f"{kind}:{rest}", 2, sigma or 0.5, frame, int(corner))


def pixel(frame: str, corner: int, sigma: float = 0.5, eye_to_hand: bool = False) -> Pixel:
    """The model of corner ``corner`` [px] seen by a camera on ``frame`` (or, ``eye_to_hand``, of a board on
    ``frame`` seen by a fixed camera), σ [px]; give it its board and intrinsics with :meth:`Pixel.with_metadata`."""
    kind = BoardPixel if eye_to_hand else Pixel
    return kind(f"{kind.kinds[0]}:{frame}@{corner}", 2, sigma, frame, corner)
