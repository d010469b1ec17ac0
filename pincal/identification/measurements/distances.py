"""The distance between two points on the robot: a ballbar, a linear scale (absolute, or reset between readings)."""

from __future__ import annotations

from typing import ClassVar

import numpy as np
import numpy.typing as npt

from pincal.errors import DataError
from pincal.identification.batch import BatchContext, point_rows
from pincal.identification.measurements.base import Measurement, point_derivative
from pincal.identification.measurements.context import SampleContext
from pincal.model.rotations import rotate
from pincal.records import record

Array = npt.NDArray[np.float64]


@record(frozen=True)
class Distance(Measurement):
    """Distance between two frames' origins [m]; ``increment`` for a scale reset between readings
    (each value is the change since the previous sample, so the scale's zero drops out)."""

    kinds: ClassVar[tuple[str, ...]] = ("distance", "distance_increment")
    components: ClassVar[tuple[str, ...]] = ("d",)
    error_words: ClassVar[tuple[str, str]] = ("distance", "orientation")
    job_frames: ClassVar[int] = 2
    length_rows: ClassVar[int] = 1
    reads_markers: ClassVar[bool] = True

    frame_a: str = ""
    frame_b: str = ""
    increment: bool = False

    @classmethod
    def from_key(cls, kind: str, rest: str, sigma: float | None) -> Measurement:
        """The model of key ``distance:<a>-<b>`` or ``distance_increment:<a>-<b>``; σ [m] defaults to 1e-6."""
        pair = rest.split("-")
        if len(pair) != 2 or not all(pair):
            raise DataError(f"measurement '{kind}:{rest}' must name two frames as '{kind}:<frameA>-<frameB>' "
                            "(frame names containing '-' cannot be used here)")
        return distance(pair[0], pair[1], sigma or 1e-6, increment=kind == "distance_increment")

    @property
    def frames(self) -> tuple[str, ...]:
        """The two frames whose origins (plus marker offsets) the distance joins."""
        return (self.frame_a, self.frame_b)

    @property
    def incremental(self) -> bool:
        """True for a ``distance_increment`` model: each value is the change since the previous sample."""
        return self.increment

    def absolute(self) -> Measurement:
        """The model of the absolute distance (``distance:<a>-<b>``) an incremental one reads the changes of."""
        return distance(self.frame_a, self.frame_b, self.sigma) if self.increment else self

    def predict(self, ctx: SampleContext, out: Array, jac: Array | None) -> None:
        """``d = ‖a − b‖`` with derivative ``uᵀ (∂a − ∂b)``, ``u = (a − b)/d``."""
        pa, ma = ctx.placement(self.frame_a), ctx.marker(self.frame_a)
        pb, mb = ctx.placement(self.frame_b), ctx.marker(self.frame_b)
        diff = pa.act(ma) - pb.act(mb)
        dist = float(np.linalg.norm(diff))
        if dist < 1e-12:
            raise DataError(f"measurement '{self.key}': frames '{self.frame_a}' and '{self.frame_b}' coincide at "
                            f"sample {ctx.sample} (a zero distance has no direction): measure between two distinct "
                            "points")
        out[0] = dist
        if jac is not None:
            u = diff / dist
            jac[0] = u @ (point_derivative(pa, ctx.twists[self.frame_a], ma)
                          - point_derivative(pb, ctx.twists[self.frame_b], mb))
            for frame, placement, sign in ((self.frame_a, pa, 1.0), (self.frame_b, pb, -1.0)):
                columns, derivative = ctx.marker_derivative(frame)
                if columns:
                    jac[0, columns] += sign * (u @ placement.rotation @ derivative)

    def predict_batch(self, batch: BatchContext, out: Array, jac: Array | None) -> None:
        """:meth:`predict` for every sample."""
        ma, mb = batch.shared.marker(self.frame_a), batch.shared.marker(self.frame_b)
        pa, pb = batch.point(self.frame_a, ma), batch.point(self.frame_b, mb)
        diff = pa - pb
        dist = np.linalg.norm(diff, axis=1)
        if np.any(dist < 1e-12):
            raise DataError(f"measurement '{self.key}': frames '{self.frame_a}' and '{self.frame_b}' coincide at "
                            f"sample {batch.samples.start + int(np.flatnonzero(dist < 1e-12)[0])} (a zero distance "
                            "has no direction): measure between two distinct points")
        out[:, 0] = dist
        if jac is None:
            return
        u = diff / dist[:, None]
        jac[:] = (batch.derivative(self.frame_a, np.matmul(u[:, None, :], point_rows(pa)))
                  - batch.derivative(self.frame_b, np.matmul(u[:, None, :], point_rows(pb))))
        for frame, sign in ((self.frame_a, 1.0), (self.frame_b, -1.0)):
            columns, derivative = batch.shared.marker_derivative(frame)
            if columns:
                jac[:, 0, columns] += sign * np.einsum("ni,nip->np", u, rotate(batch.rotations[frame], derivative))



def distance(frame_a: str, frame_b: str, sigma: float = 1e-6, increment: bool = False) -> Distance:
    """The model of the distance [m] between two frames' origins, with σ [m]; ``increment``: each reading is the
    change since the previous sample."""
    kind = "distance_increment" if increment else "distance"
    return Distance(f"{kind}:{frame_a}-{frame_b}", 1, sigma, frame_a, frame_b, increment)
