"""Pixels across two chains: a camera on one robot frame sees a calibration board on another frame of the same robot
(a camera on TIAGo's head seeing a board in its gripper, a camera on one arm seeing a board on the other).

Key ``cross_pixel:<camera frame>-<board frame>@<corner>``, columns ``…:u`` and ``…:v`` [px] (frame names without
``-``, as for ``distance``). Both placements move with the robot's joints and both are parameters: the camera on
its frame (``camera.<camera frame>.*``, frame ← camera) and the board on its frame
(``target.<board frame>@board.*``, frame ← board), with the camera's intrinsics ``intrinsics.<camera frame>.*``
(declared, held or estimated as for ``pixel``, :mod:`~pincal.identification.measurements.pixels`). The robot's
measurement frame plays no part (no ``base.*``): the camera sees the robot from the robot itself.
"""

from __future__ import annotations

from typing import ClassVar

import numpy as np
import numpy.typing as npt
import pinocchio as pin

from pincal.errors import DataError
from pincal.identification.batch import BatchContext, point_rows
from pincal.identification.measurements.base import Attachment, Measurement
from pincal.identification.measurements.context import SampleContext, camera_name, target_name
from pincal.identification.measurements.pixels import BOARD, INTRINSICS, Pixel, project
from pincal.records import record

Array = npt.NDArray[np.float64]


@record(frozen=True)
class CrossPixel(Pixel):
    """A camera on ``frame`` sees corner ``corner`` of a board on ``board_frame`` (another chain of the same robot);
    the values are its ``u``, ``v`` [px]. Key ``cross_pixel:<frame>-<board_frame>@<corner>``."""

    kinds: ClassVar[tuple[str, ...]] = ("cross_pixel",)

    board_frame: str = ""

    @classmethod
    def from_key(cls, kind: str, rest: str, sigma: float | None) -> Measurement:
        """The model of key ``cross_pixel:<camera frame>-<board frame>@<corner>``; σ [px] defaults to 0.5.

        Raises:
            DataError: another form (two frames joined by one ``-``, then ``@`` and a corner number).
        """
        frames, at, corner = rest.rpartition("@")
        pair = frames.split("-")
        if not at or len(pair) != 2 or not all(pair) or not corner.isdigit():
            raise DataError(f"measurement '{kind}:{rest}' is not {kind}:<camera frame>-<board frame>@<corner> "
                            "(corner a number; frame names containing '-' cannot be used here)")
        return cross_pixel(pair[0], pair[1], int(corner), sigma or 0.5)

    @property
    def frames(self) -> tuple[str, ...]:
        """The frame carrying the camera, then the one carrying the board."""
        return (self.frame, self.board_frame)

    @property
    def attachments(self) -> tuple[Attachment, ...]:
        """The camera on its frame, the board on its frame and the intrinsics (unless held)."""
        own = (Attachment("camera", self.frame), Attachment("target", f"{self.board_frame}@{BOARD}"))
        return own if self.held else (*own, Attachment("intrinsics", self.camera, INTRINSICS))

    def predict(self, ctx: SampleContext, out: Array, jac: Array | None) -> None:
        """``p = C⁻¹ A⁻¹ B T b`` (C the camera on frame A, T the board on frame B, b the corner) projected: with
        ``l = A⁻¹ B T b`` the corner in A, the derivatives of p are ``R_Cᵀ (−ξ_v + l̂ ξ_ω)`` (A's local twist ξ),
        ``R_Cᵀ R_Aᵀ R_B (ξ_v − (T b)^ ξ_ω)`` (B's), ``−J_v + p̂ J_ω`` (camera) and ``R_Cᵀ R_Aᵀ R_B R_T (J_v − b̂ J_ω)``
        (board), each through the projection's ``∂uv/∂p``."""
        frame_a, frame_b = ctx.placement(self.frame), ctx.placement(self.board_frame)
        camera = ctx.attached_placement(camera_name(self.frame))
        board = ctx.attached_placement(target_name(self.board_frame, BOARD))
        b = self.point()
        on_b = board.placement.act(b)
        local = frame_a.actInv(frame_b.act(on_b))
        seen = camera.placement.actInv(local)
        k, columns, components = self.camera_intrinsics(ctx)
        uv, dp, dk = project(seen[None], k)
        out[:2] = uv[0]
        if jac is None:
            return
        rot_c = camera.placement.rotation
        rot_cb = rot_c.T @ frame_a.rotation.T @ frame_b.rotation  # camera ← B
        twist_a, twist_b = ctx.twists[self.frame], ctx.twists[self.board_frame]
        dseen = rot_c.T @ (-twist_a[:3] + pin.skew(local) @ twist_a[3:])
        dseen += rot_cb @ (twist_b[:3] - pin.skew(on_b) @ twist_b[3:])
        dseen[:, camera.columns] += -camera.jacobian[:3] + pin.skew(seen) @ camera.jacobian[3:]
        dseen[:, board.columns] += rot_cb @ board.point_columns(b)
        jac[:2] = dp[0] @ dseen
        jac[:2, columns] += dk[0][:, components]

    def predict_batch(self, batch: BatchContext, out: Array, jac: Array | None) -> None:
        """:meth:`predict` for every sample: the robot's columns are ``∂uv/∂p · R_Cᵀ R_Aᵀ [I, −ŵ] (W_B − W_A)``, W a
        frame's spatial twist, w the corner in the world."""
        board = batch.shared.attached_placement(target_name(self.board_frame, BOARD))
        b = self.point()
        on_b = board.placement.act(b)
        world = batch.point(self.board_frame, on_b)
        view = self.view_batch(batch, world, out)
        if jac is None:
            return
        dback = view.back()  # ∂uv/∂p R_Cᵀ R_Aᵀ
        rows = np.matmul(dback, point_rows(world))
        jac[:] = batch.derivative(self.board_frame, rows) - batch.derivative(self.frame, rows)
        view.add_camera_columns(jac)
        if board.columns:
            moved = board.point_columns(b)
            jac[:, :, board.columns] += np.matmul(np.matmul(dback, batch.rotations[self.board_frame]), moved)
        view.add_intrinsics_columns(jac)


def cross_pixel(frame: str, board_frame: str, corner: int, sigma: float = 0.5) -> CrossPixel:
    """The model of corner ``corner`` [px] of a board on ``board_frame`` seen by a camera on ``frame``, σ [px]; give
    it its board and intrinsics with :meth:`~pincal.identification.measurements.pixels.Pixel.with_metadata`."""
    return CrossPixel(f"cross_pixel:{frame}-{board_frame}@{corner}", 2, sigma, frame, corner,
                      board_frame=board_frame)
