"""Measurement models: what a sensor reads for a robot configuration, and its parameter derivative.

Each model owns its maths: it predicts a small vector per sample from the sample's closed
configuration and the local twists of the frames it looks at (a :class:`SampleContext`, built by
:mod:`pincal.identification.problem`), writes that prediction's analytic Jacobian rows, and says how its
error is formed from the measured values. The problem stacks whatever models it is given and never
asks which kind: a new sensor is one subclass of :class:`Measurement`. A model may also predict every sample at
once (``predict_batch``, from a :class:`~pincal.identification.batch.BatchContext`, a tree's or a closed-loop
robot's); one without it is predicted sample by sample. All in SI units: positions
[m] in the measurement frame, orientations as rotation vectors [rad], joint readings [rad or m].

Keys (also the dataset column prefixes): ``position:<frame>``, ``position:<frame>@<marker>`` (a marker fixed on
``frame``: several per frame, each with its own offset), ``pose:<frame>``, ``pose:<frame>@<target>`` (a pose target
fixed on ``frame``, seen by a camera fixed in the world: eye-to-hand), ``camera:<frame>`` and ``camera_point:<frame>``
(a camera fixed on ``frame`` that sees a pose target or a point fixed in the world: eye-in-hand),
``distance:<a>-<b>``, ``distance_increment:<a>-<b>``, ``joint:<joint>``.

A measured point on a frame is named by its *marker target*: ``<frame>`` for the frame's own marker,
``<frame>@<marker>`` for a declared marker. Its position in the frame [m] is
``exp6(δ_cluster) · (nominal + δ_marker)``: a nominal offset (declared with the data, zero by default), the
marker's own offset parameters ``marker.<target>.x|y|z`` and, for declared markers, the rigid placement of the
frame's marker cluster ``cluster.<frame>.*`` (each term present only when its parameters are estimated). The
problem evaluates it once per evaluation (:class:`MarkerPoint`); the models read it through
:meth:`SampleContext.marker`.

Cameras and their targets are *attached placements* (:class:`AttachedPlacement`), ``exp6(δ)`` with δ their
parameters: a camera on a frame (``camera.<frame>.*``, frame ← camera), the world target of the eye-in-hand
cameras (``target.*``, world ← target; a point target uses its translation only) and a pose target on a frame
(``target.<frame>@<target>.*``, frame ← target). For eye-to-hand, the fixed camera is the measurement frame
(``base.*``). The models read them through :meth:`SampleContext.attached_placement`.
"""

from __future__ import annotations

import re
from abc import ABC, abstractmethod
from collections.abc import Callable
from dataclasses import dataclass, field
from typing import Any, ClassVar

import numpy as np
import numpy.typing as npt
import pinocchio as pin

from pincal import linalg
from pincal.errors import DataError
from pincal.identification.batch import BatchContext, point_rows
from pincal.identification.rotations import cross_columns, jlog3, log3, quaternion_matrices, rotate
from pincal.model.robot import Robot

Array = npt.NDArray[np.float64]

#: Builds a model from a key's kind, the rest of the key and σ (None: the kind's default).
KeyParser = Callable[[str, str, float | None], "Measurement"]
#: Measurement kind (the key's prefix) -> how to build its model: each subclass's ``from_key``, for its ``kinds``.
KINDS: dict[str, KeyParser] = {}
#: Measurement kind -> its model class (its data columns' ``components``), in the order the kinds were declared.
KIND_CLASSES: dict[str, type[Measurement]] = {}


#: A marker's name in a key (``position:<frame>@<marker>``): letters, digits and ``_`` (it becomes part of a URDF
#: link name).
MARKER_NAME = re.compile(r"[A-Za-z0-9_]+")


@dataclass
class MarkerPoint:
    """A measured point fixed on a frame at one parameter estimate.

    Attributes:
        point: (3,) its position [m] in the frame's coordinates.
        columns: The parameter columns that move it on the frame (marker offset, cluster placement).
        derivative: (3, len(columns)) d(point)/d(parameter) [m per m or rad], in the frame's coordinates.
    """

    point: Array
    columns: list[int] = field(default_factory=list)
    derivative: Array = field(default_factory=lambda: np.zeros((3, 0)))


@dataclass
class AttachedPlacement:
    """A placement the measurement models carry (a camera, a target) at one parameter estimate.

    Attributes:
        placement: The placement, ``exp6(δ)`` (camera on its frame, target in the world or on its frame).
        columns: Its parameter columns (empty: known, the identity).
        jacobian: (6, len(columns)) its local twist per unit parameter (right Jacobian of ``exp6``).
    """

    placement: pin.SE3 = field(default_factory=pin.SE3.Identity)
    columns: list[int] = field(default_factory=list)
    jacobian: Array = field(default_factory=lambda: np.zeros((6, 0)))


def camera_name(frame: str) -> str:
    """The attached placement (and parameter prefix) of the camera fixed on ``frame``: ``camera.<frame>``."""
    return f"camera.{frame}"


#: The attached placement (and parameter prefix) of the target fixed in the world that eye-in-hand cameras see.
WORLD_TARGET = "target"


def target_name(frame: str, target: str) -> str:
    """The attached placement (and parameter prefix) of pose target ``target`` on ``frame``:
    ``target.<frame>@<target>``."""
    return f"{WORLD_TARGET}.{frame}@{target}"


def split_target(target: str) -> tuple[str, str]:
    """``(frame, marker)`` of a marker target: ``tool0@m1`` -> ``("tool0", "m1")``, ``tool0`` -> ``("tool0", "")``."""
    frame, at, marker = target.rpartition("@")
    return (frame, marker) if at else (target, "")


@dataclass
class SampleContext:
    """What a measurement model predicts from: one sample's kinematic state and the parameter columns.

    The problem builds one per evaluation and sets the per-sample fields (``sample``, ``q``,
    ``twists``, ``dv``) before each sample's predictions.

    Attributes:
        model: The robot model at the evaluated parameters.
        data: Its data, frame placements (``oMf``) at ``q``.
        x: (p,) parameter vector [m, rad], Jacobian columns in this order.
        base: The placement of the robot in the measurement frame (world ← robot).
        base_jacobian: (6, len(base_columns)) right Jacobian of ``base`` w.r.t. its parameters.
        base_columns: Columns of the base parameters (empty: the base is known).
        markers: Marker target (``<frame>`` or ``<frame>@<marker>``) -> its point on the frame and the point's
            parameter derivative (targets with a nominal offset or offset parameters only).
        reading_offsets: Joint -> the column of the zero offset of its (non-actuated) reading.
        frame_ids: Frame name -> Pinocchio frame id, for every frame a model looks at.
        values: Measurement key -> (N, width) measured values (row ``sample`` is this sample's).
        sample: The sample's index.
        q: (nq,) the sample's closed configuration.
        twists: Frame -> (6, p) its local twist per unit parameter (empty without Jacobian).
        dv: (nv, p) the configuration's velocity per unit parameter (None without Jacobian).
        attached: Attached placement name (``camera.<frame>``, ``target``, ``target.<frame>@<target>``) -> its
            placement and parameter derivative (those with parameters only).
    """

    model: pin.Model
    data: pin.Data
    x: Array
    base: pin.SE3
    base_jacobian: Array
    base_columns: list[int]
    markers: dict[str, MarkerPoint]
    reading_offsets: dict[str, int]
    frame_ids: dict[str, int]
    values: dict[str, Array]
    sample: int = 0
    q: Array = field(default_factory=lambda: np.zeros(0))
    twists: dict[str, Array] = field(default_factory=dict)
    dv: Array | None = None
    attached: dict[str, AttachedPlacement] = field(default_factory=dict)

    def placement(self, frame: str) -> pin.SE3:
        """The frame's placement in the robot's world frame at ``q``."""
        return self.data.oMf[self.frame_ids[frame]]

    def marker(self, target: str) -> Array:
        """The point [m] of marker target ``target`` (``<frame>`` or ``<frame>@<marker>``) in its frame (zero
        for a target with neither a nominal offset nor parameters)."""
        point = self.markers.get(target)
        return point.point if point is not None else np.zeros(3)

    def marker_derivative(self, target: str) -> tuple[list[int], Array]:
        """The parameter columns that move marker target ``target`` on its frame, and the (3, k) derivative of its
        point [m] in the frame's coordinates w.r.t. them (no columns: the marker is fixed on its frame)."""
        point = self.markers.get(target)
        return (point.columns, point.derivative) if point is not None else ([], np.zeros((3, 0)))

    def attached_placement(self, name: str) -> AttachedPlacement:
        """Attached placement ``name`` (a camera, a target) at this estimate: the identity with no columns when it
        has no parameters (known)."""
        return self.attached.get(name) or AttachedPlacement()

    def measured(self, key: str) -> Array:
        """This sample's measured values of measurement ``key``."""
        values: Array = self.values[key][self.sample]
        return values


@dataclass(frozen=True)
class Measurement(ABC):
    """Base class: ``key`` names the data columns, ``size`` the values per sample, ``sigma`` the
    standard deviation of each value (same units) used to weight the residual.

    A subclass implements :meth:`predict` (the prediction and its Jacobian rows), optionally
    :meth:`predict_batch` (the same for every sample of a tree at once), and, where they
    differ from the defaults, the data columns, the error, the row units and σ. A subclass that declares
    the key ``kinds`` it parses also defines ``from_key(kind, rest, sigma)``, a classmethod building its
    model from a key.
    """

    kinds: ClassVar[tuple[str, ...]] = ()
    #: Names of the data columns' components (``<key>:<component>``); empty: one per row, numbered.
    components: ClassVar[tuple[str, ...]] = ()
    #: Leading error columns that are lengths [m] (a point's position, a distance), then the columns that are
    #: angles [rad] (an orientation's rotation vector): what the reports' error sizes are made of.
    length_rows: ClassVar[int] = 0
    angle_rows: ClassVar[int] = 0
    #: Whether a sample may lack this reading (all its values NaN: an occluded marker); the problem leaves the
    #: missing rows out. Other kinds need every value.
    occludable: ClassVar[bool] = False

    key: str
    size: int
    sigma: float

    def __init_subclass__(cls, **kwargs: Any) -> None:
        super().__init_subclass__(**kwargs)
        kinds = cls.__dict__.get("kinds", ())
        if kinds and "from_key" not in cls.__dict__:
            raise TypeError(f"{cls.__name__} declares the key kinds {kinds} but no from_key to build itself from a key")
        for kind in kinds:
            KINDS[kind] = cls.__dict__["from_key"].__get__(None, cls)
            KIND_CLASSES[kind] = cls

    @property
    def frames(self) -> tuple[str, ...]:
        """The robot frames this model looks at (each must exist; the problem gives each its twist)."""
        return ()

    @property
    def incremental(self) -> bool:
        """Whether each value is the change since the previous sample (the first sample's row is ignored)."""
        return False

    @property
    def locates_point(self) -> bool:
        """Whether the first three values are a point's position [m] in the measurement frame (what
        registers an unknown measurement frame, and what the IKM formulation holds fixed)."""
        return False

    @property
    def columns(self) -> tuple[str, ...]:
        """The dataset's column names of this measurement, in the order of its values."""
        names = self.components or tuple(str(i) for i in range(self.size))
        return tuple(f"{self.key}:{c}" for c in names)

    def row_units(self) -> list[str]:
        """The unit of each residual row: ``m`` unless a subclass says otherwise."""
        return ["m"] * self.size

    def row_sigmas(self) -> Array:
        """σ of each residual row (same units as the row)."""
        return np.full(self.size, self.sigma)

    def check(self, robot: Robot) -> None:
        """Raise NotFoundError if the robot lacks what this model looks at."""
        for f in self.frames:
            robot.frame_id(f)

    @abstractmethod
    def predict(self, ctx: SampleContext, out: Array, jac: Array | None) -> None:
        """Write the sample's prediction into ``out`` (size,) and, if ``jac`` is given, its derivative
        w.r.t. the parameters into ``jac`` (size, p), which arrives zeroed."""

    def predict_batch(self, batch: BatchContext, out: Array, jac: Array | None) -> None:
        """Write every sample's prediction into ``out`` (N, size) and, if ``jac`` is given, its derivative into
        ``jac`` (N, size, p), which arrives zeroed: what :meth:`predict` writes, for all samples at once (a tree's
        batched evaluation). Optional: a model without it is predicted sample by sample (see :attr:`batched`)."""
        raise NotImplementedError(f"{type(self).__name__} predicts one sample at a time")

    @property
    def batched(self) -> bool:
        """Whether :meth:`predict_batch` predicts what :meth:`predict` does: defined by the class that defines
        :meth:`predict`, or by a subclass of it (a subclass that overrides only :meth:`predict` is predicted sample
        by sample, never with its parent's batched prediction)."""
        def owner(name: str) -> type:
            return next(c for c in type(self).__mro__ if name in c.__dict__)
        batch = owner("predict_batch")
        return batch is not Measurement and issubclass(batch, owner("predict"))

    def error(self, predicted: Array, measured: Array, model: pin.Model) -> Array:
        """Predicted − measured, (N, size), from the predictions (N, size) and the data (N, width)."""
        return predicted - measured


@dataclass(frozen=True)
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
    def target(self) -> str:
        """The marker target measured: ``<frame>@<marker>`` for a declared marker, else ``<frame>``."""
        return f"{self.frame}@{self.marker}" if self.marker else self.frame

    @property
    def frames(self) -> tuple[str, ...]:
        """The measured frame."""
        return (self.frame,)

    @property
    def locates_point(self) -> bool:
        """True: the values are the position [m] of the frame's origin (plus its marker offset)."""
        return True

    def predict(self, ctx: SampleContext, out: Array, jac: Array | None) -> None:
        """The marker's position [m] in the measurement frame, and its derivative (its marker and cluster columns
        ``R_base R_frame ∂p/∂θ`` included)."""
        _predict_point(ctx, self.frame, ctx.marker(self.target), out, jac)
        columns, derivative = ctx.marker_derivative(self.target)
        if jac is not None and columns:
            jac[:3, columns] += ctx.base.rotation @ ctx.placement(self.frame).rotation @ derivative

    def predict_batch(self, batch: BatchContext, out: Array, jac: Array | None) -> None:
        """:meth:`predict` for every sample: ``R_base p + t_base``, ``p = R_F m + t_F``."""
        _predict_points(batch, self.frame, batch.shared.marker(self.target), out, jac)
        columns, derivative = batch.shared.marker_derivative(self.target)
        if jac is not None and columns:
            jac[:, :, columns] += rotate(batch.base.rotation, rotate(batch.rotations[self.frame], derivative))


@dataclass(frozen=True)
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

    def row_units(self) -> list[str]:
        """Three position rows [m], then three orientation rows [rad]."""
        return ["m", "m", "m", "rad", "rad", "rad"]

    def row_sigmas(self) -> Array:
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


@dataclass(frozen=True)
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


@dataclass(frozen=True)
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

    frame: str = ""

    @classmethod
    def from_key(cls, kind: str, rest: str, sigma: float | None) -> Measurement:
        """The model of key ``camera_point:<frame>``; σ [m] defaults to 1e-5."""
        return camera_point(rest, sigma or 1e-5)

    @property
    def frames(self) -> tuple[str, ...]:
        """The frame carrying the camera."""
        return (self.frame,)

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


@dataclass(frozen=True)
class Distance(Measurement):
    """Distance between two frames' origins [m]; ``increment`` for a scale reset between readings
    (each value is the change since the previous sample, so the scale's zero drops out)."""

    kinds: ClassVar[tuple[str, ...]] = ("distance", "distance_increment")
    components: ClassVar[tuple[str, ...]] = ("d",)
    length_rows: ClassVar[int] = 1

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


@dataclass(frozen=True)
class JointReading(Measurement):
    """A passive joint's encoder (or an instrumented measuring chain's sensor) [rad or m]."""

    kinds: ClassVar[tuple[str, ...]] = ("joint",)

    joint: str = ""

    @classmethod
    def from_key(cls, kind: str, rest: str, sigma: float | None) -> Measurement:
        """The model of key ``joint:<joint>``; σ [rad or m] defaults to 1e-5."""
        return joint_reading(rest, sigma or 1e-5)

    @property
    def columns(self) -> tuple[str, ...]:
        """The dataset column: the joint's name."""
        return (self.joint,)

    def check(self, robot: Robot) -> None:
        """Raise NotFoundError if the robot lacks the joint, DataError if it is a ``<mimic>`` joint (no reading)."""
        jid = robot.joint_id(self.joint, f"measurement '{self.key}': ")
        if robot.model.joints[jid].nv == 0:
            raise DataError(f"measurement '{self.key}': joint '{self.joint}' is a <mimic> joint, which follows its "
                            "leader and has no reading of its own; remove its column")

    def predict(self, ctx: SampleContext, out: Array, jac: Array | None) -> None:
        """The joint's value (a continuous joint's angle from its cos, sin); with a zero offset δq the
        sensor reads ``q_true − δq`` (``q_true = q_read + δq``)."""
        jm = ctx.model.joints[ctx.model.getJointId(self.joint)]
        q = ctx.q
        value = q[jm.idx_q] if jm.nq == 1 else np.arctan2(q[jm.idx_q + 1], q[jm.idx_q])
        out[0] = value
        if jac is not None and ctx.dv is not None:
            jac[0] = ctx.dv[jm.idx_v]
        offset = ctx.reading_offsets.get(self.joint)
        if offset is not None:
            out[0] = value - ctx.x[offset]
            if jac is not None:
                jac[0, offset] -= 1.0

    def predict_batch(self, batch: BatchContext, out: Array, jac: Array | None) -> None:
        """:meth:`predict` for every sample (a tree: the joint moves with the parameters only through its own
        offset and correction columns when it is actuated; closed loops: through ``batch.velocities``)."""
        jm = batch.shared.model.joints[batch.shared.model.getJointId(self.joint)]
        q = batch.q
        out[:, 0] = q[:, jm.idx_q] if jm.nq == 1 else np.arctan2(q[:, jm.idx_q + 1], q[:, jm.idx_q])
        if jac is not None and batch.velocities is not None:  # closed loops: dv/dθ, actuated terms included
            jac[:, 0] = batch.velocities[:, jm.idx_v]
        elif jac is not None:
            for column, regressor in batch.joint_terms.get(self.joint, []):
                jac[:, 0, column] = regressor
        offset = batch.shared.reading_offsets.get(self.joint)
        if offset is not None:
            out[:, 0] -= batch.shared.x[offset]
            if jac is not None:
                jac[:, 0, offset] -= 1.0

    def error(self, predicted: Array, measured: Array, model: pin.Model) -> Array:
        """Predicted − measured [rad or m]; a continuous joint's is wrapped to [−π, π)."""
        err = predicted - measured
        if model.joints[model.getJointId(self.joint)].nq == 2:  # a continuous joint's reading wraps
            err = linalg.wrap_angle(err)
        return err


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


def pose(frame: str, sigma: float = 1e-5, sigma_angle: float = 1e-5, target: str = "") -> Pose:
    """The model of ``frame``'s pose, or with ``target`` of that pose target fixed on ``frame`` (seen by a camera
    fixed in the world): position with σ [m], orientation with ``sigma_angle`` [rad]."""
    key = f"pose:{frame}@{target}" if target else f"pose:{frame}"
    return Pose(key, 6, sigma, frame, sigma_angle, target)


def camera_pose(frame: str, sigma: float = 1e-5, sigma_angle: float = 1e-5) -> CameraPose:
    """The model of a camera fixed on ``frame`` reading the pose of a target fixed in the world (eye-in-hand):
    position with σ [m], orientation with ``sigma_angle`` [rad]."""
    return CameraPose(f"camera:{frame}", 6, sigma, frame, sigma_angle)


def camera_point(frame: str, sigma: float = 1e-5) -> CameraPoint:
    """The model of a camera fixed on ``frame`` reading the position [m] of a point fixed in the world
    (eye-in-hand), with σ [m]."""
    return CameraPoint(f"camera_point:{frame}", 3, sigma, frame)


def distance(frame_a: str, frame_b: str, sigma: float = 1e-6, increment: bool = False) -> Distance:
    """The model of the distance [m] between two frames' origins, with σ [m]; ``increment``: each reading is the
    change since the previous sample."""
    kind = "distance_increment" if increment else "distance"
    return Distance(f"{kind}:{frame_a}-{frame_b}", 1, sigma, frame_a, frame_b, increment)


def joint_reading(joint: str, sigma: float = 1e-5) -> JointReading:
    """The model of a non-actuated joint's sensor reading [rad or m], with σ in the joint's unit."""
    return JointReading(f"joint:{joint}", 1, sigma, joint)


def parse_key(key: str, sigma: float | None = None) -> Measurement:
    """A measurement model from its key, e.g. ``position:end_effector`` or ``distance:o1-o2``."""
    kind, _, rest = key.partition(":")
    if not rest:
        raise DataError(f"measurement '{key}' is not of the form kind:frame; kinds are {', '.join(KINDS)}")
    if kind not in KINDS:
        raise DataError(f"unknown measurement kind '{kind}' in '{key}'; kinds are {', '.join(KINDS)}")
    return KINDS[kind](kind, rest, sigma)


def point_derivative(placement: pin.SE3, twist: Array, point: Array) -> Array:
    """d(world position of ``point`` fixed in a frame)/dθ from the frame's local twist (6 × n)."""
    rot = placement.rotation
    derivative: Array = rot @ (twist[:3] - pin.skew(point) @ twist[3:])
    return derivative
