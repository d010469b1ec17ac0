"""Contact with a plane: a frame of the robot lies on a flat plate or table whose pose is unknown (no external
sensor, only the joint readings).

The plane is fixed in the robot's world, or on a robot frame (its *support*: the sole a humanoid stands on). Its
placement ``G = exp6(δ)`` in the support's frame has the plane's normal along its z axis; its parameters
``plane[.<support>].tz|rx|ry`` are the offset along the normal [m] and two tilts [rad]. Where on the plane the frame
touches, and the rotation about the normal, are not parameters: contact cannot see them.

Two kinds, both with the contact frame ``F`` expressed in the support's frame, ``C = S⁻¹ F``:

- ``plane_point:<frame>[@<support>]``: the frame's origin on the plane; one row, the signed distance
  ``e_zᵀ G⁻¹ p_C`` [m] (a touch probe reads 0; a dial gauge reads its displacement);
- ``plane:<frame>[@<support>]``: the frame flush on the plane, its z axis along the plane's normal (either way); the
  distance, then the x and y components of the frame's z axis in the plane's coordinates, ``(R_Gᵀ R_C e_z)_{x,y}``
  [rad, small angles] (0 when flush).
"""

from __future__ import annotations

from collections.abc import Callable, Mapping, Sequence
from dataclasses import replace
from typing import ClassVar

import numpy as np
import numpy.typing as npt
import pinocchio as pin

from pincal import linalg
from pincal.errors import DataError
from pincal.identification.batch import BatchContext
from pincal.identification.measurements.base import Attachment, Measurement, NominalReadings, StartPlacements
from pincal.identification.measurements.context import AttachedPlacement, SampleContext, split_target
from pincal.model.rotations import rotate, skew
from pincal.records import record

Array = npt.NDArray[np.float64]

#: The attached placement (and parameter prefix) of a plane fixed in the robot's world.
PLANE = "plane"
#: The plane's estimated placement components: the offset along its normal [m] and its two tilts [rad].
PLANE_COMPONENTS = ("tz", "rx", "ry")
_EZ = np.array([0.0, 0.0, 1.0])


def plane_name(support: str) -> str:
    """The attached placement (and parameter prefix) of the plane fixed on ``support``: ``plane.<support>``, or
    ``plane`` for the plane fixed in the robot's world (``support`` empty)."""
    return f"{PLANE}.{support}" if support else PLANE


@record(frozen=True)
class PlanePoint(Measurement):
    """A frame's origin lies on an unknown plane: the signed distance [m] from the plane (key
    ``plane_point:<frame>`` for a plane fixed in the world, ``plane_point:<frame>@<support>`` for one fixed on the
    robot frame ``support``). The plane's offset and tilts (``plane[.<support>].tz|rx|ry``) are estimated with the
    robot."""

    kinds: ClassVar[tuple[str, ...]] = ("plane_point",)
    components: ClassVar[tuple[str, ...]] = ("distance",)
    error_words: ClassVar[tuple[str, str]] = ("plane distance", "tilt")
    length_rows: ClassVar[int] = 1
    zero_when_unwritten: ClassVar[bool] = True
    job_keys: ClassVar[dict[str, str]] = {"support": "a contact with a plane is held by a support"}

    frame: str = ""
    support: str = ""

    @classmethod
    def job_key(cls, kind: str, frames: Sequence[str], keys: Mapping[str, str]) -> str:
        """``<kind>:<frame>``, or ``<kind>:<frame>@<support>`` when the job gives the plane's ``support``."""
        key = super().job_key(kind, frames, keys)
        return f"{key}@{keys['support']}" if "support" in keys else key

    @classmethod
    def from_key(cls, kind: str, rest: str, sigma: float | None) -> Measurement:
        """The model of key ``plane_point:<frame>[@<support>]``; σ [m] defaults to 1e-4."""
        frame, support = _frames(kind, rest)
        return plane_point(frame, support, sigma or 1e-4)

    @property
    def frames(self) -> tuple[str, ...]:
        """The contact frame, then the support (if the plane is fixed on a robot frame)."""
        return (self.frame, self.support) if self.support else (self.frame,)

    @property
    def attachments(self) -> tuple[Attachment, ...]:
        """The plane (``plane[.<support>].tz|rx|ry``)."""
        return (Attachment(PLANE, self.support, PLANE_COMPONENTS),)

    @classmethod
    def start_placements(cls, models: Sequence[Measurement],
                         nominal: Callable[[Measurement], NominalReadings]) -> StartPlacements:
        """Each plane a frame touches (its support's, in sorted order): the plane through the contact frames' nominal
        origins (in the support's frame; the readings' distances taken off along the normal), fitted by SVD, its
        normal the direction of least spread turned toward the support's +z (the mean of the frames' z axes when the
        points are nearly on a line and the frames' axes are read); why not, when the points do not determine it."""
        contacts = [m for m in models if isinstance(m, PlanePoint)]
        out: StartPlacements = {}
        for support in sorted({m.support for m in contacts}):
            points, axes, distances = _contact_points([m for m in contacts if m.support == support], nominal)
            try:
                out[plane_name(support)] = fit_plane(points, distances, axes)
            except DataError as why:
                out[plane_name(support)] = str(why)
        return out

    def predict(self, ctx: SampleContext, out: Array, jac: Array | None) -> None:
        """``d = e_zᵀ G⁻¹ S⁻¹ p_F``. With ``ΔW = W_F − W_S`` (the spatial twists ``Ad(F) ξ_F``, ``Ad(S) ξ_S``), the
        robot's columns are ``n_wᵀ (ΔW_v − p̂_F ΔW_ω)``, ``n_w = R_S R_G e_z`` the normal in the world; the plane's
        ``e_zᵀ (−J_v + q̂ J_ω)``, ``q = G⁻¹ p_C`` (J: the right Jacobian of ``exp6``)."""
        state = _ContactState.of(ctx, self.frame, self.support)
        out[:] = state.rows(self.size)
        if jac is not None:
            state.jacobian(ctx, self.frame, self.support, jac)

    def predict_batch(self, batch: BatchContext, out: Array, jac: Array | None) -> None:
        """:meth:`predict` for every sample."""
        _predict_batch(self, batch, out, jac)


@record(frozen=True)
class PlaneContact(PlanePoint):
    """A frame lies flush on an unknown plane, its z axis along the plane's normal (key ``plane:<frame>`` or
    ``plane:<frame>@<support>``): the signed distance [m], then the x and y components of the frame's z axis in the
    plane's coordinates [rad] (the two tilts; 0 when flush, whichever way the axis points)."""

    kinds: ClassVar[tuple[str, ...]] = ("plane",)
    components: ClassVar[tuple[str, ...]] = ("distance", "tilt_x", "tilt_y")
    length_rows: ClassVar[int] = 1
    angle_rows: ClassVar[int] = 2
    units: ClassVar[tuple[str, ...]] = ("m", "rad", "rad")

    sigma_angle: float = 1e-3

    @classmethod
    def from_key(cls, kind: str, rest: str, sigma: float | None) -> Measurement:
        """The model of key ``plane:<frame>[@<support>]``; σ defaults to 1e-4 m for the distance and 1e-3 rad for
        the tilts (one σ given: both)."""
        frame, support = _frames(kind, rest)
        return plane_contact(frame, support, sigma or 1e-4, sigma or 1e-3)

    def with_angle_sigma(self, sigma_angle: float) -> Measurement:
        """This model with σ ``sigma_angle`` [rad] on its tilt rows."""
        return replace(self, sigma_angle=sigma_angle)

    def row_units(self) -> list[str]:
        """The distance [m], then the two tilts [rad]."""
        return ["m", "rad", "rad"]

    def uniform_row_sigmas(self) -> Array:
        """``sigma`` [m] for the distance, ``sigma_angle`` [rad] for the tilts."""
        return np.array([self.sigma, self.sigma_angle, self.sigma_angle])


@record
class _ContactState:
    """One sample's contact frame against its plane: what the rows and their derivatives are made of."""

    frame: pin.SE3  # F in the robot's world
    support: pin.SE3  # S in the robot's world (the identity for a plane fixed in the world)
    plane: AttachedPlacement  # G in the support's frame

    @classmethod
    def of(cls, ctx: SampleContext, frame: str, support: str) -> _ContactState:
        """The state of ``frame`` against the plane on ``support`` at this sample."""
        held = ctx.placement(support) if support else pin.SE3.Identity()
        return cls(ctx.placement(frame), held, ctx.attached_placement(plane_name(support)))

    @property
    def local_point(self) -> Array:
        """``q = G⁻¹ S⁻¹ p_F`` [m]: the frame's origin in the plane's coordinates."""
        point: Array = self.plane.placement.actInv(self.support.actInv(self.frame.translation))
        return point

    @property
    def local_axis(self) -> Array:
        """``a = R_Gᵀ R_Sᵀ R_F e_z``: the frame's z axis in the plane's coordinates."""
        axis: Array = self.plane.placement.rotation.T @ self.support.rotation.T @ self.frame.rotation[:, 2]
        return axis

    def rows(self, size: int) -> Array:
        """The distance [m] and (size 3) the two tilts [rad]."""
        return np.concatenate([self.local_point[2:], self.local_axis[:2]])[:size]

    def jacobian(self, ctx: SampleContext, frame: str, support: str, jac: Array) -> None:
        """Write the rows' derivatives into ``jac`` (size, p)."""
        spatial = self.frame.action @ ctx.twists[frame]
        if support:
            spatial = spatial - self.support.action @ ctx.twists[support]
        to_plane = self.plane.placement.rotation.T @ self.support.rotation.T  # world -> plane coordinates
        normal = to_plane[2]
        jac[0] = normal @ (spatial[:3] - pin.skew(self.frame.translation) @ spatial[3:])
        if len(jac) == 3:
            jac[1:] = (-to_plane @ pin.skew(self.frame.rotation[:, 2]) @ spatial[3:])[:2]
        plane = self.plane
        if plane.columns:
            jac[0, plane.columns] += -plane.jacobian[2] + (pin.skew(self.local_point) @ plane.jacobian[3:])[2]
            if len(jac) == 3:
                jac[1:, plane.columns] += (pin.skew(self.local_axis) @ plane.jacobian[3:])[:2]


def _predict_batch(model: PlanePoint, batch: BatchContext, out: Array, jac: Array | None) -> None:
    """:meth:`PlanePoint.predict` for every sample (``out`` (N, size), ``jac`` (N, size, p)): the rows applied to
    the frame's spatial twists less the support's."""
    plane = batch.shared.attached_placement(plane_name(model.support))
    rot_f, pos_f = batch.rotations[model.frame], batch.translations[model.frame]
    n = len(pos_f)
    if model.support:
        rot_s, pos_s = batch.rotations[model.support], batch.translations[model.support]
    else:
        rot_s, pos_s = np.broadcast_to(np.eye(3), (n, 3, 3)), np.zeros((n, 3))
    to_plane = rotate(plane.placement.rotation.T, rot_s.transpose(0, 2, 1))  # (N, 3, 3) world -> plane
    point = np.matmul(to_plane, (pos_f - pos_s)[:, :, None])[:, :, 0] - plane.placement.rotation.T @ \
        plane.placement.translation
    axis = np.matmul(to_plane, rot_f[:, :, 2:])[:, :, 0]
    out[:, 0] = point[:, 2]
    if model.size == 3:
        out[:, 1:] = axis[:, :2]
    if jac is None:
        return
    rows = np.zeros((n, model.size, 6))
    normal = to_plane[:, 2]
    rows[:, 0, :3] = normal
    rows[:, 0, 3:] = np.cross(pos_f, normal)  # nᵀ(−p̂ w) = (p × n)ᵀ w
    if model.size == 3:
        rows[:, 1:, 3:] = -np.matmul(to_plane, skew(rot_f[:, :, 2]))[:, :2]
    batch.derivative(model.frame, rows, out=jac)
    if model.support:
        jac -= batch.derivative(model.support, rows)
    if plane.columns:
        jp = plane.jacobian
        jac[:, 0, plane.columns] += -jp[2] + np.matmul(skew(point), jp[3:])[:, 2]
        if model.size == 3:
            jac[:, 1:, plane.columns] += np.matmul(skew(axis), jp[3:])[:, :2]


def _contact_points(models: list[PlanePoint], nominal: Callable[[Measurement], NominalReadings]
                    ) -> tuple[Array, Array, Array]:
    """The contact frames' origins [m] and z axes in their support's frame at the nominal robot, (n, 3) each, and
    the distances [m] read there (n,)."""
    points, axes, distances = [], [], []
    for m in models:
        seen = nominal(m)
        held = seen.placements[m.support] if m.support else [pin.SE3.Identity()] * len(seen.values)
        for frame, support, value in zip(seen.placements[m.frame], held, seen.values, strict=True):
            contact = support.actInv(frame)
            points.append(contact.translation)
            axes.append(contact.rotation[:, 2] if m.angle_rows else np.full(3, np.nan))
            distances.append(value[0])
    return np.array(points).reshape(-1, 3), np.array(axes).reshape(-1, 3), np.array(distances)


#: Smallest ratio of the second to the first spread of contact points that still fixes a plane's tilt about
#: their line.
PLANE_SPREAD = 1e-3


def fit_plane(points: Array, distances: Array, axes: Array | None = None) -> pin.SE3:
    """The plane ``G`` (its normal along its z axis) through ``points`` (n, 3) [m] at the signed ``distances`` (n,)
    [m] they read (the normal by SVD when they are all 0, else by least squares under a unit norm), as a placement
    whose ``log6`` is ``(0, 0, tz, rx, ry, 0)``: the offset along the normal and two tilts, the plane's parameters.
    Points at equal heights (contacts) turn the normal toward +z; ``axes`` (n, 3) (rows NaN where not read) give it
    when the points are nearly on a line.

    Raises:
        DataError: fewer than three points, or points on a line without axes to give the normal.
    """
    if len(points) < 3:
        raise DataError(f"{len(points)} contact points do not fix a plane (three or more do)")
    centre = points.mean(axis=0)
    _, spread, vt = linalg.svd(points - centre, "the contact points about their centre")
    if spread[1] <= PLANE_SPREAD * spread[0]:
        read = axes[np.all(np.isfinite(axes), axis=1)] if axes is not None else np.zeros((0, 3))
        if not len(read):
            raise DataError("the contact points lie on a line: their plane's tilt about it is not determined")
        normal = (read * np.sign(read @ read[0])[:, None]).mean(axis=0)
        normal = _upward(normal / np.linalg.norm(normal))
    else:
        normal = _unit_normal(points - centre, distances - distances.mean(), spread, vt)
    offset = float(np.mean(points @ normal - distances))
    return plane_placement(normal, offset)


def _upward(normal: Array) -> Array:
    """The unit ``normal`` (3,) turned toward +z (where the data do not tell its sign)."""
    return normal if normal[2] >= 0 else -normal


def _unit_normal(centred: Array, heights: Array, spread: Array, vt: Array) -> Array:
    """The unit ``n`` minimising ``Σ (n·p_i − h_i)²`` over the centred points ``p_i`` (n, 3) [m] and centred heights
    ``h_i`` (n,) [m] (least squares under a unit-norm constraint, Gander 1980): ``n = (AᵀA − λI)⁻¹ Aᵀh`` with the
    λ below the smallest ``σ²`` that makes it a unit vector, found by bisection; the direction of least spread when
    every height is 0 (``spread``, ``vt``: the SVD of the points)."""
    g = vt @ (centred.T @ heights)
    squares = spread ** 2
    if not np.any(heights) or abs(g[2]) <= 1e-12 * max(np.abs(g).max(), 1e-300):
        return _upward(vt[2])  # equal heights do not tell up from down

    def length(lam: float) -> float:
        return float(np.sum((g / (squares - lam)) ** 2))

    high, low = squares[2], squares[2] - max(np.abs(g).sum(), 1.0)
    while length(low) > 1.0:
        low = squares[2] - 2.0 * (squares[2] - low)
    for _ in range(200):  # length is increasing in λ on (−∞, σ²_min)
        mid = 0.5 * (low + high)
        low, high = (mid, high) if length(mid) < 1.0 else (low, mid)
    normal: Array = vt.T @ (g / (squares - low))
    normal /= np.linalg.norm(normal)
    level = _upward(vt[2])  # the heights' sign, unless it fits them no better than the plane of least spread does

    def misfit(n: Array) -> float:
        return float(np.sum((centred @ n - heights) ** 2))

    return normal if misfit(normal) < 0.5 * misfit(level) else level


def plane_placement(normal: Array, offset: float) -> pin.SE3:
    """The placement ``exp6((0, 0, tz, rx, ry, 0))`` of the plane ``{p : n·p = offset}`` (``normal`` (3,) a unit
    vector with ``n_z > −1``, ``offset`` [m]): the rotation about an axis in the xy plane that takes z to the normal,
    and ``tz`` such that its origin lies on the plane."""
    axis = np.cross([0.0, 0.0, 1.0], normal)
    angle = float(np.arctan2(np.linalg.norm(axis), normal[2]))
    rotation = axis / np.linalg.norm(axis) * angle if angle > 1e-12 else np.zeros(3)
    along = pin.exp6(pin.Motion(np.array([0.0, 0.0, 1.0]), rotation)).translation @ normal  # per unit tz
    return pin.exp6(pin.Motion(np.array([0.0, 0.0, offset / along]), rotation))


def _frames(kind: str, rest: str) -> tuple[str, str]:
    """``(frame, support)`` of a key's rest ``<frame>`` or ``<frame>@<support>``."""
    frame, support = split_target(rest)
    if not frame or ("@" in rest and not support):
        raise DataError(f"measurement '{kind}:{rest}' must name a frame as '{kind}:<frame>', or a frame and the "
                        f"robot frame the plane is fixed on as '{kind}:<frame>@<support>'")
    return frame, support


def plane_point(frame: str, support: str = "", sigma: float = 1e-4) -> PlanePoint:
    """The model of ``frame``'s origin on an unknown plane fixed in the world (``support`` empty) or on the robot
    frame ``support``, with σ [m]."""
    key = f"plane_point:{frame}@{support}" if support else f"plane_point:{frame}"
    return PlanePoint(key, 1, sigma, frame=frame, support=support)


def plane_contact(frame: str, support: str = "", sigma: float = 1e-4, sigma_angle: float = 1e-3) -> PlaneContact:
    """The model of ``frame`` flush on an unknown plane fixed in the world (``support`` empty) or on the robot frame
    ``support``: the distance with σ [m], the two tilts with ``sigma_angle`` [rad]."""
    key = f"plane:{frame}@{support}" if support else f"plane:{frame}"
    return PlaneContact(key, 3, sigma, frame=frame, support=support, sigma_angle=sigma_angle)
