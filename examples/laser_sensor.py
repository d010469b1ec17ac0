"""A one-axis laser displacement sensor on the robot reading its distance to a fixed plane: a measurement kind that
brings unknowns of its own, in this one file (docs/extending.md).

The sensor sits on a robot frame ``F`` at the placement ``S = exp6(δ_s)`` (frame ← sensor), its beam along the
sensor's z axis; it reads the distance [m] along the beam from its origin to a plane fixed in the robot's world, at
the placement ``G = exp6(δ_g)`` (world ← plane, the plane's normal along its z axis). Its parameters are
``laser.<frame>.tx|ty|tz|rx|ry`` (the sensor: where its origin is [m], which way its beam points [rad]; the turn about
the beam is not seen) and ``laser_plane.tz|rx|ry`` (the plane: its offset along the normal [m] and two tilts [rad];
where on the plane and the turn about the normal are not seen). With ``q = G⁻¹ o`` the sensor's origin ``o = F S 0``
and ``a = R_Gᵀ b`` its beam ``b = R_F R_S e_z`` in the plane's coordinates, the reading is ``d = −q_z / a_z``.

A reading beyond the sensor's range (the beam leaves the plane, or meets it farther than :data:`RANGE`) is not
taken: a simulated one is left empty (NaN), as a missed marker is.

Use it from the command line by naming this file in ``PINCAL_PLUGINS``::

    export PINCAL_PLUGINS=$PWD/examples/laser_sensor.py
    pincal simulate ur10 --measure laser --samples 80 --test-samples 20 --noise 1e-5 --out sim
"""

from __future__ import annotations

from collections.abc import Callable, Sequence
from dataclasses import dataclass
from typing import ClassVar

import numpy as np
import numpy.typing as npt
import pinocchio as pin

from pincal.errors import DataError
from pincal.identification.measurements import (
    Attachment,
    Measurement,
    NominalReadings,
    SampleContext,
    StartPlacements,
)
from pincal.identification.measurements.planes import fit_plane
from pincal.identification.parameters import ParameterKind

Array = npt.NDArray[np.float64]

#: The measurement kind: keys ``laser:<frame>``, columns ``laser:<frame>:distance`` [m].
KIND = "laser"
#: The sensor's placement on its frame: its parameters' prefix is ``laser.<frame>``.
SENSOR = "laser"
#: The plane the sensors read, fixed in the robot's world: its parameters' prefix.
PLANE = "laser_plane"
#: The sensor's estimated components: its origin [m] and its beam's two tilts [rad] (not the turn about the beam).
SENSOR_COMPONENTS = ("tx", "ty", "tz", "rx", "ry")
#: The plane's estimated components: its offset along the normal [m] and its two tilts [rad].
PLANE_COMPONENTS = ("tz", "rx", "ry")
#: The longest distance [m] the sensor reads.
RANGE = 2.0
#: What "before" is: the fit starts from the sensor at nominal and the plane through the nominal beams' hits.
BEFORE = ("the nominal robot, its laser sensors at nominal and the plane they read fitted to where their nominal beams "
          "meet it (least squares), for fit and held-out samples alike")


class LaserPlacement(ParameterKind):
    """``laser.<frame>.<c>``: a laser displacement sensor on a robot frame (frame ← sensor, its beam along z)."""

    name = SENSOR
    urdf = "a laser link on the frame (its z axis the beam)"
    attached = True
    setup_words = "laser sensors"
    before_placed = before_unplaced = BEFORE
    check_words = ("laser", "laser sensors and their plane")

    @classmethod
    def prefix(cls, owner: str, side: str = "") -> str:
        """``laser.<frame>``."""
        return f"{SENSOR}.{owner}"

    @classmethod
    def urdf_link(cls, owner: str) -> str:
        """``<frame>_laser``."""
        return f"{owner}_laser"


class LaserPlane(ParameterKind):
    """``laser_plane.<c>``: the plane the laser sensors read, fixed in the robot's world (its normal along z)."""

    name = PLANE
    urdf = "a plane link (its z axis the normal) on the robot's root link"
    attached = True
    world_anchor = True  # the world is seen only through it: the robot's first placement is left out, as for base.*
    setup_words = "laser plane"
    check_words = ("laser", "laser sensors and their plane")

    @classmethod
    def prefix(cls, owner: str, side: str = "") -> str:
        """``laser_plane``."""
        return PLANE

    @classmethod
    def urdf_link(cls, owner: str) -> str:
        """``laser_plane``."""
        return PLANE


@dataclass(frozen=True)
class Laser(Measurement):
    """A laser displacement sensor on ``frame`` reading the distance [m] along its beam to the plane (key
    ``laser:<frame>``, one column ``laser:<frame>:distance``)."""

    kinds: ClassVar[tuple[str, ...]] = (KIND,)
    components: ClassVar[tuple[str, ...]] = ("distance",)
    length_rows: ClassVar[int] = 1
    error_words: ClassVar[tuple[str, str]] = ("laser distance", "orientation")
    occludable: ClassVar[bool] = True
    sighted: ClassVar[str] = "plane"

    frame: str = ""

    @classmethod
    def from_key(cls, kind: str, rest: str, sigma: float | None) -> Measurement:
        """The model of key ``laser:<frame>``; σ [m] defaults to 1e-5."""
        if not rest or "@" in rest or "-" in rest:
            raise DataError(f"measurement '{kind}:{rest}' must name the frame the sensor is on as '{kind}:<frame>'")
        return cls(f"{kind}:{rest}", 1, sigma or 1e-5, frame=rest)

    @property
    def frames(self) -> tuple[str, ...]:
        """The frame carrying the sensor."""
        return (self.frame,)

    @property
    def attachments(self) -> tuple[Attachment, ...]:
        """The sensor on its frame and the plane in the world."""
        return (Attachment(SENSOR, self.frame, SENSOR_COMPONENTS), Attachment(PLANE, "", PLANE_COMPONENTS))

    def row_units(self) -> list[str]:
        """The distance [m]."""
        return ["m"]

    def predict(self, ctx: SampleContext, out: Array, jac: Array | None) -> None:
        """``d = −q_z / a_z``. Its derivative ``(−∂q_z − d ∂a_z) / a_z``: the frame's local twist ``(v, ω)`` moves the
        origin by ``R_F (v − t̂ ω)`` and the beam by ``−R_F b̂_F ω`` (``t``, ``b_F``: the sensor's origin and beam in
        the frame); the sensor's right Jacobian ``J_s`` by ``R_F R_S J_v`` and ``−R_F R_S ê_z J_ω``; the plane's
        ``J_g`` moves ``q`` by ``−J_v + q̂ J_ω`` and ``a`` by ``â J_ω``."""
        frame = ctx.placement(self.frame)
        sensor = ctx.attached_placement(LaserPlacement.prefix(self.frame))
        plane = ctx.attached_placement(PLANE)
        on_frame = sensor.placement.rotation[:, 2]  # the beam in the frame's coordinates
        origin = frame.act(sensor.placement.translation)
        beam = frame.rotation @ on_frame
        to_plane = plane.placement.rotation.T  # world -> plane coordinates
        q = plane.placement.actInv(origin)
        a = to_plane @ beam
        if abs(a[2]) < 1e-9:
            raise DataError(f"measurement '{self.key}': the beam is parallel to the plane at sample {ctx.sample}")
        distance = -q[2] / a[2]
        out[0] = distance
        if jac is None:
            return
        normal = to_plane[2]  # the plane's normal in the world
        twist = ctx.twists[self.frame]
        d_origin = frame.rotation @ (twist[:3] - pin.skew(sensor.placement.translation) @ twist[3:])
        d_beam = -frame.rotation @ pin.skew(on_frame) @ twist[3:]
        jac[0] = (-(normal @ d_origin) - distance * (normal @ d_beam)) / a[2]
        if sensor.columns:
            rotation = frame.rotation @ sensor.placement.rotation
            moved = rotation @ sensor.jacobian[:3]
            turned = -rotation @ pin.skew(np.array([0.0, 0.0, 1.0])) @ sensor.jacobian[3:]
            jac[0, sensor.columns] += (-(normal @ moved) - distance * (normal @ turned)) / a[2]
        if plane.columns:
            dq = -plane.jacobian[2] + (pin.skew(q) @ plane.jacobian[3:])[2]
            da = (pin.skew(a) @ plane.jacobian[3:])[2]
            jac[0, plane.columns] += (-dq - distance * da) / a[2]

    def simulate(self, predicted: Array, sigma: float, rng: np.random.Generator) -> Array:
        """The predicted distances with Gaussian noise σ [m]; NaN where the beam does not meet the plane within
        (0, :data:`RANGE`] m (a reading the sensor does not take)."""
        values = super().simulate(predicted, sigma, rng)
        values[(predicted <= 0.0) | (predicted > RANGE)] = np.nan
        return values

    @classmethod
    def start_placements(cls, models: Sequence[Measurement],
                         nominal: Callable[[Measurement], NominalReadings]) -> StartPlacements:
        """The plane through the points the nominal beams meet it at (each frame's origin plus the distance read
        along its z axis), fitted by least squares (why not, when they do not fix a plane); the sensors start at
        nominal."""
        hits = []
        for m in models:
            seen = nominal(m)
            hits += [f.translation + value[0] * f.rotation[:, 2]
                     for f, value in zip(seen.placements[m.frames[0]], seen.values, strict=True)]
        points = np.array(hits).reshape(-1, 3)
        try:
            return {PLANE: fit_plane(points, np.zeros(len(points)))}
        except DataError as why:
            return {PLANE: str(why)}


def laser(frame: str, sigma: float = 1e-5) -> Laser:
    """The model of a laser displacement sensor on ``frame`` reading the plane, with σ [m]."""
    return Laser(f"{KIND}:{frame}", 1, sigma, frame=frame)
