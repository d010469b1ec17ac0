"""What a measurement model predicts from: one sample's kinematic state, the measured points on the frames (markers)
and the placements the models carry (cameras, targets), with their parameter derivatives.

A measured point on a frame is named by its *marker key*: ``<frame>`` for the frame's own marker,
``<frame>@<marker>`` for a declared marker. Its position in the frame [m] is
``exp6(δ_cluster) · (nominal + δ_marker)``: a nominal offset (declared with the data, zero by default), the
marker's own offset parameters ``marker.<key>.x|y|z`` and, for declared markers, the rigid placement of the
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

from dataclasses import field

import numpy as np
import numpy.typing as npt
import pinocchio as pin

from pincal.records import record

Array = npt.NDArray[np.float64]

@record
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


@record
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

    def point_columns(self, point: Array) -> Array:
        """(3, len(columns)) how a point fixed on the placement (``point`` [m] in its own frame) moves per unit
        parameter, in the frame the placement is expressed in: ``R (J_v − p̂ J_ω)``."""
        return np.asarray(self.placement.rotation @ (self.jacobian[:3] - pin.skew(point) @ self.jacobian[3:]),
                          dtype=np.float64)


@record
class IntrinsicTerms:
    """A camera's intrinsics parameters at one estimate.

    Attributes:
        delta: (k,) the parameters' values [px, or 1 for the distortion], added to the nominal intrinsics.
        columns: Their parameter columns.
        components: The intrinsic each column is (index in fx, fy, cx, cy, k1, k2, p1, p2, k3).
    """

    delta: Array
    columns: list[int]
    components: list[int]


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
    """``(frame, marker)`` of a marker key: ``tool0@m1`` -> ``("tool0", "m1")``, ``tool0`` -> ``("tool0", "")``."""
    frame, at, marker = target.rpartition("@")
    return (frame, marker) if at else (target, "")


@record
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
        intrinsics: A camera's intrinsics name (``intrinsics.<frame>``, ``intrinsics``) -> its parameters (those
            with parameters only).
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
    intrinsics: dict[str, IntrinsicTerms] = field(default_factory=dict)

    def placement(self, frame: str) -> pin.SE3:
        """The frame's placement in the robot's world frame at ``q``."""
        return self.data.oMf[self.frame_ids[frame]]

    def marker(self, key: str) -> Array:
        """The point [m] of marker key ``key`` (``<frame>`` or ``<frame>@<marker>``) in its frame (zero
        for a point with neither a nominal offset nor parameters)."""
        point = self.markers.get(key)
        return point.point if point is not None else np.zeros(3)

    def marker_derivative(self, key: str) -> tuple[list[int], Array]:
        """The parameter columns that move marker key ``key`` on its frame, and the (3, k) derivative of its
        point [m] in the frame's coordinates w.r.t. them (no columns: the marker is fixed on its frame)."""
        point = self.markers.get(key)
        return (point.columns, point.derivative) if point is not None else ([], np.zeros((3, 0)))

    def attached_placement(self, name: str) -> AttachedPlacement:
        """Attached placement ``name`` (a camera, a target) at this estimate: the identity with no columns when it
        has no parameters (known)."""
        return self.attached.get(name) or AttachedPlacement()

    def measured(self, key: str) -> Array:
        """This sample's measured values of measurement ``key``."""
        values: Array = self.values[key][self.sample]
        return values
