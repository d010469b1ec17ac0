"""Cameras fixed on the robot (eye-in-hand) that see a pose target or a point fixed in the world."""

from __future__ import annotations

from typing import ClassVar

import numpy as np
import numpy.typing as npt
import pinocchio as pin

from pincal.identification import handeye
from pincal.identification.batch import BatchContext
from pincal.identification.measurements.base import PLACEMENT_COMPONENTS, Attachment, Measurement
from pincal.identification.measurements.context import WORLD_TARGET, SampleContext, camera_name
from pincal.identification.measurements.poses import Pose, _orientation_rows, _orientation_rows_batch
from pincal.model.rotations import cross_columns, rotate
from pincal.records import record

Array = npt.NDArray[np.float64]


@record(frozen=True)
class CameraPose(Pose):
    """Eye-in-hand: a camera fixed on ``frame`` sees a pose target fixed in the world; the values are the target's
    pose in the camera's frame, position [m] then orientation (quaternion columns, the rotation vector
    ``log3(R_measᵀ R)`` [rad] as residual). Key ``camera:<frame>``.

    The camera's placement on the frame (``camera.<frame>.*``) and the target's in the robot's world frame
    (``target.*``) are unknowns, estimated with the robot; the robot's own measurement frame plays no part (no
    ``base.*``). A sample in which the camera did not see the target has all seven values empty (NaN).
    """

    kinds: ClassVar[tuple[str, ...]] = ("camera",)

    @classmethod
    def from_key(cls, kind: str, rest: str, sigma: float | None) -> Measurement:
        """The model of key ``camera:<frame>``; σ defaults to 1e-5 for the position [m] and the orientation [rad]."""
        return camera_pose(rest, sigma or 1e-5, sigma or 1e-5)

    @property
    def locates_point(self) -> bool:
        """False: the camera moves with the robot; its values place no point in a fixed measurement frame."""
        return False

    @property
    def attachments(self) -> tuple[Attachment, ...]:
        """The camera on the frame (``camera.<frame>.*``) and the pose target in the world (``target.*``)."""
        return (Attachment("camera", self.frame), Attachment("target", ""))

    def closed_form(self, frame_poses: list[pin.SE3], values: Array, translating: bool = False
                    ) -> tuple[pin.SE3, pin.SE3, tuple[str, str]]:
        """The camera X on the frame and the target Y in the world: ``A_i X = Y B_i⁻¹`` (A_i the frame's nominal
        poses, B_i the targets seen; :mod:`~pincal.identification.handeye`)."""
        solve = handeye.solve_ax_yb_translating if translating else handeye.solve_ax_yb
        own, world = solve(frame_poses, [pin.XYZQUATToSE3(v).inverse() for v in values])
        return own, world, (camera_name(self.frame), WORLD_TARGET)

    def predict(self, ctx: SampleContext, out: Array, jac: Array | None) -> None:
        """``T = C⁻¹ F⁻¹ G`` (C the camera on frame F, G the world target): position ``p_T``, orientation
        ``log3(R_measᵀ R_T)``. T's local twist per parameter: ``−Ad(G⁻¹F) ξ_F`` for the robot's,
        ``−Ad(T⁻¹) J_C`` for the camera's, ``J_G`` for the target's (J: right Jacobians of ``exp6``)."""
        frame = ctx.placement(self.frame)
        camera = ctx.attached_placement(camera_name(self.frame))
        target = ctx.attached_placement(WORLD_TARGET)
        seen = camera.placement.inverse() * frame.inverse() * target.placement
        out[:3] = seen.translation
        rel = _orientation_rows(ctx.measured(self.key), seen.rotation, out[3:])
        if jac is None:
            return
        twist = -(target.placement.inverse() * frame).action @ ctx.twists[self.frame]
        twist[:, camera.columns] -= seen.inverse().action @ camera.jacobian
        twist[:, target.columns] += target.jacobian
        jac[:3] = seen.rotation @ twist[:3]
        jac[3:] = pin.Jlog3(rel) @ twist[3:]

    def predict_batch(self, batch: BatchContext, out: Array, jac: Array | None) -> None:
        """:meth:`predict` for every sample; the robot's columns of T's local twist are ``−Ad(G⁻¹) W`` (W the frame's
        spatial twist), the camera's ``−Ad(T⁻¹) J_C``."""
        rot_f, pos_f = batch.rotations[self.frame], batch.translations[self.frame]
        camera = batch.shared.attached_placement(camera_name(self.frame))
        target = batch.shared.attached_placement(WORLD_TARGET)
        rot_fc = rotate(rot_f, camera.placement.rotation)  # world ← camera
        pos_fc = (rot_f.reshape(-1, 3) @ camera.placement.translation).reshape(-1, 3) + pos_f
        inverse = rot_fc.transpose(0, 2, 1)
        seen_rot = rotate(inverse, target.placement.rotation)
        seen_pos = np.matmul(inverse, (target.placement.translation - pos_fc)[:, :, None])[:, :, 0]
        out[:, :3] = seen_pos
        jlog = _orientation_rows_batch(batch.measured(self.key), seen_rot, out[:, 3:])
        if jac is None:
            return
        rows = np.zeros((len(seen_pos), 6, 6))
        rows[:, :3, :3] = seen_rot
        rows[:, 3:, 3:] = jlog
        batch.derivative(self.frame, np.matmul(rows, -target.placement.inverse().action), out=jac)
        if camera.columns:  # −Ad(T⁻¹) J_C = −(R_Tᵀ (J_v − p_T × J_ω), R_Tᵀ J_ω)
            jc = np.broadcast_to(camera.jacobian, (len(seen_pos), 6, len(camera.columns)))
            jac[:, :3, camera.columns] -= jc[:, :3] - cross_columns(seen_pos, jc[:, 3:])
            jac[:, 3:, camera.columns] -= rotate(np.matmul(rows[:, 3:, 3:], seen_rot.transpose(0, 2, 1)),
                                                 camera.jacobian[3:])
        if target.columns:
            jac[:, :, target.columns] += np.matmul(rows, target.jacobian)



@record(frozen=True)
class CameraPoint(Measurement):
    """Eye-in-hand with a point target: a camera fixed on ``frame`` sees a point fixed in the world; the values are
    the point's position [m] in the camera's frame. Key ``camera_point:<frame>``.

    Unknowns: the camera's placement on the frame (``camera.<frame>.*``) and the point in the robot's world frame
    (the translation of the world target, ``target.tx|ty|tz``). A sample in which the camera did not see the point
    has its three values empty (NaN).
    """

    kinds: ClassVar[tuple[str, ...]] = ("camera_point",)
    components: ClassVar[tuple[str, ...]] = ("x", "y", "z")
    length_rows: ClassVar[int] = 3
    occludable: ClassVar[bool] = True
    units: ClassVar[tuple[str, ...]] = ("m", "m", "m")

    frame: str = ""

    @classmethod
    def from_key(cls, kind: str, rest: str, sigma: float | None) -> Measurement:
        """The model of key ``camera_point:<frame>``; σ [m] defaults to 1e-5."""
        return camera_point(rest, sigma or 1e-5)

    @property
    def frames(self) -> tuple[str, ...]:
        """The frame carrying the camera."""
        return (self.frame,)

    @property
    def attachments(self) -> tuple[Attachment, ...]:
        """The camera on the frame (``camera.<frame>.*``) and the point in the world (``target.tx|ty|tz``)."""
        return (Attachment("camera", self.frame), Attachment("target", "", PLACEMENT_COMPONENTS[:3]))

    def closed_form(self, frame_poses: list[pin.SE3], values: Array, translating: bool = False
                    ) -> tuple[pin.SE3, pin.SE3, tuple[str, str]]:
        """The camera X on the frame and the world point y: ``p_i = X⁻¹ A_i⁻¹ y`` (A_i the frame's nominal poses,
        p_i the points seen; :mod:`~pincal.identification.handeye`)."""
        solve_point = handeye.solve_point_translating if translating else handeye.solve_point_eye_in_hand
        camera, point = solve_point(frame_poses, values[:, :3])
        return camera, pin.SE3(np.eye(3), point), (camera_name(self.frame), WORLD_TARGET)

    def predict(self, ctx: SampleContext, out: Array, jac: Array | None) -> None:
        """``y = C⁻¹ F⁻¹ g`` (C the camera on frame F, g the world point): with ``z = F⁻¹ g``, the derivatives are
        ``R_Cᵀ (−ξ_v + ẑ ξ_ω)`` for the robot's parameters, ``(−I, ŷ) J_C`` for the camera's and
        ``R_Cᵀ R_Fᵀ R_G J_G,v`` for the point's."""
        frame = ctx.placement(self.frame)
        camera = ctx.attached_placement(camera_name(self.frame))
        target = ctx.attached_placement(WORLD_TARGET)
        local = frame.actInv(target.placement.translation)
        seen = camera.placement.actInv(local)
        out[:3] = seen
        if jac is None:
            return
        twist = ctx.twists[self.frame]
        rot_c = camera.placement.rotation
        jac[:3] = rot_c.T @ (-twist[:3] + pin.skew(local) @ twist[3:])
        jac[:3, camera.columns] += -camera.jacobian[:3] + pin.skew(seen) @ camera.jacobian[3:]
        jac[:3, target.columns] += rot_c.T @ frame.rotation.T @ target.placement.rotation @ target.jacobian[:3]

    def predict_batch(self, batch: BatchContext, out: Array, jac: Array | None) -> None:
        """:meth:`predict` for every sample: the robot's columns are ``−R_Cᵀ R_Fᵀ (W_v − g × W_ω)``, W the frame's
        spatial twist."""
        rot_f, pos_f = batch.rotations[self.frame], batch.translations[self.frame]
        camera = batch.shared.attached_placement(camera_name(self.frame))
        target = batch.shared.attached_placement(WORLD_TARGET)
        point = target.placement.translation
        local = np.matmul(rot_f.transpose(0, 2, 1), (point - pos_f)[:, :, None])[:, :, 0]
        seen = (local - camera.placement.translation) @ camera.placement.rotation
        out[:, :3] = seen
        if jac is None:
            return
        back = rotate(camera.placement.rotation.T, rot_f.transpose(0, 2, 1))  # R_Cᵀ R_Fᵀ
        at_point = np.hstack([-np.eye(3), pin.skew(point)])  # −[I, −ĝ]
        batch.derivative(self.frame, (back.reshape(-1, 3) @ at_point).reshape(len(seen), 3, 6), out=jac)
        if camera.columns:
            jc = np.broadcast_to(camera.jacobian, (len(seen), 6, len(camera.columns)))
            jac[:, :3, camera.columns] += -jc[:, :3] + cross_columns(seen, jc[:, 3:])
        if target.columns:
            jac[:, :3, target.columns] += rotate(back, target.placement.rotation @ target.jacobian[:3])



def camera_pose(frame: str, sigma: float = 1e-5, sigma_angle: float = 1e-5) -> CameraPose:
    """The model of a camera fixed on ``frame`` reading the pose of a target fixed in the world (eye-in-hand):
    position with σ [m], orientation with ``sigma_angle`` [rad]."""
    return CameraPose(f"camera:{frame}", 6, sigma, frame, sigma_angle)


def camera_point(frame: str, sigma: float = 1e-5) -> CameraPoint:
    """The model of a camera fixed on ``frame`` reading the position [m] of a point fixed in the world
    (eye-in-hand), with σ [m]."""
    return CameraPoint(f"camera_point:{frame}", 3, sigma, frame)

