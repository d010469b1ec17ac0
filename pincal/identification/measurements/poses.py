"""The pose of a frame, or of a pose target fixed on it: a tracker's 6D body, a fixed camera seeing the robot."""

from __future__ import annotations

from dataclasses import replace
from typing import ClassVar

import numpy as np
import numpy.typing as npt
import pinocchio as pin

from pincal.errors import DataError
from pincal.identification import handeye
from pincal.identification.batch import BatchContext, point_rows
from pincal.identification.measurements.base import MARKER_NAME, QUATERNION, Attachment, Measurement
from pincal.identification.measurements.context import AttachedPlacement, SampleContext, split_target, target_name
from pincal.model.rotations import jlog3, log3, quaternion_matrices, rotate
from pincal.records import record

Array = npt.NDArray[np.float64]


@record(frozen=True)
class Pose(Measurement):
    """6D pose of a frame, or of pose target ``target`` fixed on it (key ``pose:<frame>@<target>``: e.g. a camera
    fixed in the world, the measurement frame, sees a target on the robot, eye-to-hand): position [m] then the
    rotation vector ``log3(R_measᵀ R)`` [rad].

    ``sigma`` weights the position rows; ``sigma_angle`` the orientation rows. A sample may lack the reading (the
    body or the target not seen: all seven values empty, NaN); the problem leaves its rows out.
    """

    kinds: ClassVar[tuple[str, ...]] = ("pose",)
    components: ClassVar[tuple[str, ...]] = ("x", "y", "z", "qx", "qy", "qz", "qw")
    length_rows: ClassVar[int] = 3
    angle_rows: ClassVar[int] = 3
    occludable: ClassVar[bool] = True
    units: ClassVar[tuple[str, ...]] = ("m", "m", "m", QUATERNION, QUATERNION, QUATERNION, QUATERNION)

    frame: str = ""
    sigma_angle: float = 1e-4
    target: str = ""

    @classmethod
    def from_key(cls, kind: str, rest: str, sigma: float | None) -> Measurement:
        """The model of key ``pose:<frame>`` or ``pose:<frame>@<target>``; σ defaults to 1e-5 for the position [m]
        and the orientation [rad]."""
        frame, target = split_target(rest)
        if "@" in rest and (not frame or not MARKER_NAME.fullmatch(target)):
            raise DataError(f"measurement '{kind}:{rest}' must name a frame and a target as "
                            f"'{kind}:<frame>@<target>', the target in letters, digits and '_'")
        return pose(frame, sigma or 1e-5, sigma or 1e-5, target)

    @property
    def frames(self) -> tuple[str, ...]:
        """The measured frame."""
        return (self.frame,)

    @property
    def locates_point(self) -> bool:
        """True: the first three values are the position [m] of the frame's origin (or its target's)."""
        return True

    def with_angle_sigma(self, sigma_angle: float) -> Measurement:
        """This model with σ ``sigma_angle`` [rad] on its orientation rows."""
        return replace(self, sigma_angle=sigma_angle)

    @property
    def attachments(self) -> tuple[Attachment, ...]:
        """The pose target on the frame (``target.<frame>@<target>.*``), if it reads one."""
        return (Attachment("target", f"{self.frame}@{self.target}"),) if self.target else ()

    def closed_form(self, frame_poses: list[pin.SE3], values: Array, translating: bool = False
                    ) -> tuple[pin.SE3, pin.SE3, tuple[str, str]]:
        """A pose target X on the frame seen by the fixed camera: ``A_i X = Y B_i`` (A_i the frame's nominal poses,
        B_i the readings), Y the inverse of the measurement frame's placement
        (:mod:`~pincal.identification.handeye`)."""
        if not self.target:
            return super().closed_form(frame_poses, values, translating)
        solve = handeye.solve_ax_yb_translating if translating else handeye.solve_ax_yb
        own, world = solve(frame_poses, [pin.XYZQUATToSE3(v) for v in values])
        return own, world, (target_name(self.frame, self.target), "")

    def simulate(self, predicted: Array, sigma: float, rng: np.random.Generator) -> Array:
        """Readings from the predictions (position, rotation vector): the position with Gaussian noise σ [m], the
        orientation turned by a rotation vector of Gaussian components σ [rad], as a unit quaternion."""
        n = len(predicted)
        out = np.empty((n, 7))
        out[:, :3] = predicted[:, :3] + rng.normal(scale=sigma, size=(n, 3))
        for k in range(n):
            quat = pin.Quaternion(pin.exp3(predicted[k, 3:]) @ pin.exp3(rng.normal(scale=sigma, size=3)))
            out[k, 3:] = [quat.x, quat.y, quat.z, quat.w]
        return out

    def row_units(self) -> list[str]:
        """Three position rows [m], then three orientation rows [rad]."""
        return ["m", "m", "m", "rad", "rad", "rad"]

    def uniform_row_sigmas(self) -> Array:
        """``sigma`` [m] for the position rows, ``sigma_angle`` [rad] for the orientation rows."""
        return np.array([self.sigma] * 3 + [self.sigma_angle] * 3)

    def predict(self, ctx: SampleContext, out: Array, jac: Array | None) -> None:
        """The pose ``P = F X`` of the frame F's target X (the identity for the frame itself) in the measurement
        frame: position ``base · p_P``, orientation ``log3(R_measᵀ R_base R_P)``. With ν the local twist of P
        (``Ad(X⁻¹) ξ_F``, plus X's own right Jacobian), the rows' derivatives are ``R_base R_P ν_v`` and
        ``Jlog3 · ν_ω``."""
        term = ctx.attached_placement(target_name(self.frame, self.target)) if self.target else AttachedPlacement()
        placement = ctx.placement(self.frame) * term.placement
        out[:3] = ctx.base.act(placement.translation)
        rel = _orientation_rows(ctx.measured(self.key), ctx.base.rotation @ placement.rotation, out[3:])
        if jac is None:
            return
        twist = term.placement.inverse().action @ ctx.twists[self.frame]
        twist[:, term.columns] += term.jacobian
        jlog = pin.Jlog3(rel)
        jac[:3] = ctx.base.rotation @ placement.rotation @ twist[:3]
        jac[3:] = jlog @ twist[3:]
        if ctx.base_columns:
            jac[:3, ctx.base_columns] = (ctx.base.rotation @ np.hstack([np.eye(3), -pin.skew(placement.translation)])
                                         @ ctx.base_jacobian)
            jac[3:, ctx.base_columns] = jlog @ placement.rotation.T @ ctx.base_jacobian[3:]

    def predict_batch(self, batch: BatchContext, out: Array, jac: Array | None) -> None:
        """:meth:`predict` for every sample; with ``W`` the frame's spatial twist, ``R_P ν_v = W_v − p_P × W_ω`` and
        ``ν_ω = R_Pᵀ W_ω``."""
        term = (batch.shared.attached_placement(target_name(self.frame, self.target)) if self.target
                else AttachedPlacement())
        rotation = rotate(batch.rotations[self.frame], term.placement.rotation)
        world = batch.point(self.frame, term.placement.translation)
        base = batch.base
        out[:, :3] = world @ base.rotation.T + base.translation
        jlog = _orientation_rows_batch(batch.measured(self.key), rotate(base.rotation, rotation), out[:, 3:])
        if jac is None:
            return
        to_local = np.matmul(jlog, rotation.transpose(0, 2, 1))  # Jlog3 R_Pᵀ: world angular velocity -> rows
        rows = np.zeros((len(world), 6, 6))
        rows[:, :3] = point_rows(world, base.rotation)
        rows[:, 3:, 3:] = to_local
        batch.derivative(self.frame, rows, out=jac)
        if term.columns:
            jac[:, :3, term.columns] += rotate(base.rotation, rotate(rotation, term.jacobian[:3]))
            jac[:, 3:, term.columns] += rotate(jlog, term.jacobian[3:])
        if batch.shared.base_columns:
            jac[:, :3, batch.shared.base_columns] = batch.base_columns(world)
            jac[:, 3:, batch.shared.base_columns] = rotate(to_local, batch.shared.base_jacobian[3:])

    def error(self, predicted: Array, measured: Array, model: pin.Model) -> Array:
        """The position rows less the measured position; the rotation rows are already relative."""
        err = predicted.copy()
        err[:, :3] -= measured[:, :3]
        return err



def _orientation_rows(measured: Array, rotation: Array, out: Array) -> Array:
    """Write the orientation rows ``log3(R_measᵀ R)`` [rad] into ``out`` from a pose reading (x, y, z, qx, qy, qz,
    qw; the quaternion normalized) and return ``R_measᵀ R``; a reading not taken (NaN) gives NaN rows (left out of
    the fit) and returns ``R``."""
    quat = measured[[6, 3, 4, 5]]
    if not np.all(np.isfinite(quat)):
        out[:] = np.nan
        return rotation
    rel: Array = pin.Quaternion(*quat).normalized().matrix().T @ rotation
    out[:] = pin.log3(rel)
    return rel


def _orientation_rows_batch(measured: Array, rotation: Array, out: Array) -> Array:
    """:func:`_orientation_rows` for every sample: ``measured`` (N, 7), ``rotation`` (N, 3, 3), ``out`` (N, 3);
    returns (N, 3, 3) ``Jlog3`` at ``R_measᵀ R`` (at ``R`` for a reading not taken, whose rows are NaN)."""
    quat = measured[:, 3:7]
    taken = np.all(np.isfinite(quat), axis=1)
    unit = np.where(taken[:, None], quat, [0.0, 0.0, 0.0, 1.0])
    unit = unit / np.linalg.norm(unit, axis=1)[:, None]
    rel = np.matmul(quaternion_matrices(unit).transpose(0, 2, 1), rotation)
    rel[~taken] = rotation[~taken]
    vector = log3(rel)
    out[:] = vector
    out[~taken] = np.nan
    return jlog3(vector)



def pose(frame: str, sigma: float = 1e-5, sigma_angle: float = 1e-5, target: str = "") -> Pose:
    """The model of ``frame``'s pose, or with ``target`` of that pose target fixed on ``frame`` (seen by a camera
    fixed in the world): position with σ [m], orientation with ``sigma_angle`` [rad]."""
    key = f"pose:{frame}@{target}" if target else f"pose:{frame}"
    return Pose(key, 6, sigma, frame, sigma_angle, target)

