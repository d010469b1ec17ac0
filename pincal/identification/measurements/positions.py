"""The position of a point on a frame: a laser tracker's reflector, a mocap marker."""

from __future__ import annotations

from collections.abc import Mapping
from dataclasses import replace
from typing import ClassVar

import numpy as np
import numpy.typing as npt
import pinocchio as pin

from pincal.errors import DataError
from pincal.identification.batch import BatchContext, point_rows
from pincal.identification.measurements.base import MARKER_NAME, Measurement, point_derivative
from pincal.identification.measurements.context import SampleContext, split_target
from pincal.model.rotations import rotate
from pincal.records import record

Array = npt.NDArray[np.float64]


@record(frozen=True)
class Position(Measurement):
    """3D position of a point on a frame, e.g. a laser tracker's reflector or a mocap marker: the frame's origin
    plus its marker offset (key ``position:<frame>``), or declared marker ``marker`` fixed on the frame (key
    ``position:<frame>@<marker>``; several per frame) at ``nominal`` [m] in the frame plus its offset parameters.

    A reading may be missing (an occluded marker): its values are NaN, and the problem leaves its rows out.
    """

    kinds: ClassVar[tuple[str, ...]] = ("position",)
    components: ClassVar[tuple[str, ...]] = ("x", "y", "z")
    length_rows: ClassVar[int] = 3
    occludable: ClassVar[bool] = True
    units: ClassVar[tuple[str, ...]] = ("m", "m", "m")
    sighted: ClassVar[str] = "marker"
    reads_markers: ClassVar[bool] = True

    frame: str = ""
    marker: str = ""
    #: The marker's nominal offset [m] in the frame, as declared with the data (None: not declared, zero).
    nominal: tuple[float, float, float] | None = None

    @classmethod
    def from_key(cls, kind: str, rest: str, sigma: float | None) -> Measurement:
        """The model of key ``position:<frame>`` or ``position:<frame>@<marker>``; σ [m] defaults to 1e-5."""
        frame, marker = split_target(rest)
        if "@" in rest and (not frame or not MARKER_NAME.fullmatch(marker)):
            raise DataError(f"measurement '{kind}:{rest}' must name a frame and a marker as "
                            f"'{kind}:<frame>@<marker>', the marker in letters, digits and '_'")
        return position(frame, sigma or 1e-5, marker)

    @property
    def marker_key(self) -> str:
        """The point measured: ``<frame>@<marker>`` for a declared marker, else ``<frame>``."""
        return f"{self.frame}@{self.marker}" if self.marker else self.frame

    @property
    def frames(self) -> tuple[str, ...]:
        """The measured frame."""
        return (self.frame,)

    @property
    def locates_point(self) -> bool:
        """True: the values are the position [m] of the frame's origin (plus its marker offset)."""
        return True

    @property
    def markers(self) -> Mapping[str, tuple[float, float, float] | None]:
        """Its point (:attr:`marker_key`) -> the nominal offset [m] the data declare for it (None: not declared)."""
        return {self.marker_key: self.nominal}

    def with_markers(self, nominals: Mapping[str, tuple[float, float, float]]) -> Measurement:
        """This model with its marker's declared nominal offset [m], if ``nominals`` holds one."""
        return replace(self, nominal=nominals[self.marker_key]) if self.marker_key in nominals else self

    def predict(self, ctx: SampleContext, out: Array, jac: Array | None) -> None:
        """The marker's position [m] in the measurement frame, and its derivative (its marker and cluster columns
        ``R_base R_frame ∂p/∂θ`` included)."""
        _predict_point(ctx, self.frame, ctx.marker(self.marker_key), out, jac)
        columns, derivative = ctx.marker_derivative(self.marker_key)
        if jac is not None and columns:
            jac[:3, columns] += ctx.base.rotation @ ctx.placement(self.frame).rotation @ derivative

    def predict_batch(self, batch: BatchContext, out: Array, jac: Array | None) -> None:
        """:meth:`predict` for every sample: ``R_base p + t_base``, ``p = R_F m + t_F``."""
        _predict_points(batch, self.frame, batch.shared.marker(self.marker_key), out, jac)
        columns, derivative = batch.shared.marker_derivative(self.marker_key)
        if jac is not None and columns:
            jac[:, :, columns] += rotate(batch.base.rotation, rotate(batch.rotations[self.frame], derivative))



def _predict_point(ctx: SampleContext, frame: str, marker: Array, out: Array, jac: Array | None) -> None:
    """Rows 0–2: the world position [m] of ``marker`` fixed in ``frame``, and its derivative (the
    point's motion, then the base's ``R_base [I, −p̂] J_r``)."""
    placement = ctx.placement(frame)
    local_point = placement.act(marker)
    out[:3] = ctx.base.act(local_point)
    if jac is not None:
        jac[:3] = ctx.base.rotation @ point_derivative(placement, ctx.twists[frame], marker)
        if ctx.base_columns:
            jac[:3, ctx.base_columns] = (ctx.base.rotation @ np.hstack([np.eye(3), -pin.skew(local_point)])
                                         @ ctx.base_jacobian)


def _predict_points(batch: BatchContext, frame: str, marker: Array, out: Array, jac: Array | None) -> Array:
    """:func:`_predict_point` for every sample: columns 0–2 of ``out`` (N, ≥3) and ``jac`` (N, ≥3, p); returns the
    points (N, 3) [m] in the robot's world frame."""
    world = batch.point(frame, marker)
    base = batch.base
    out[:, :3] = world @ base.rotation.T + base.translation
    if jac is not None:
        batch.derivative(frame, point_rows(world, base.rotation), out=jac[:, :3])
        if batch.shared.base_columns:
            jac[:, :3, batch.shared.base_columns] = batch.base_columns(world)
    return world


def position(frame: str, sigma: float = 1e-5, marker: str = "",
             nominal: tuple[float, float, float] | None = None) -> Position:
    """The model of the position [m] of ``frame``'s origin (plus its marker offset), or with ``marker`` of that
    marker fixed on ``frame`` at ``nominal`` [m] in the frame (None: zero, not declared); σ [m]."""
    key = f"position:{frame}@{marker}" if marker else f"position:{frame}"
    return Position(key, 3, sigma, frame, marker, nominal)


