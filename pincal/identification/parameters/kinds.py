"""Parameter kinds: what a parameter is, each a class in one registry that owns what differs between kinds.

A kind says where its parameters act, which is where their derivative comes from (:attr:`ParameterKind.acts_in`),
how their names are formed, their unit, their group for model selection, and how a calibrated URDF holds them, or
that it cannot and the corrections file beside it does. The rest of pincal asks the kind
(:func:`parameter_kind`, :attr:`Parameter.kind_class <pincal.identification.parameters.Parameter.kind_class>`)
instead of comparing names; a new parameter kind is one subclass of :class:`ParameterKind` with its ``name``.
The kinds register in the order they are declared (the order messages list them).

Each kind also says how large a correction of it is plausible (:attr:`ParameterKind.plausible`): a robot's geometry
is off its URDF by millimetres and fractions of a degree, its readings' zeros by a few degrees at most; a correction
far beyond that is the sign of data that do not belong to the model (another robot, another unit, swapped columns).
The setup (the measurement frame, markers, cameras, targets) has no bound: a tracker may stand metres away.
"""

from __future__ import annotations

import math
from collections.abc import Iterable
from typing import Any, ClassVar, Literal, Protocol

from pincal.errors import not_found
from pincal.identification.measurements import (
    INTRINSICS,
    PLANE,
    WORLD_TARGET,
    camera_name,
    intrinsics_name,
    plane_name,
    split_target,
)
from pincal.model.robot import Unit

#: A parameter's unit: a length or an angle, or a compliance (angle per torque, length per force).
ParameterUnit = Literal["m", "rad", "rad/(N m)", "m/N", "px", "1"]
#: Where a kind's parameters act: the robot ``model`` (a placement in the kinematic tree or a loop: its derivative from
#: frame Jacobians through the loops), an actuated joint's ``reading`` (its value moves by the parameter times a
#: regressor of the reading), or the ``measurement`` models (the measurement frame, markers, cameras, targets: the
#: models' own derivatives, through their :class:`~pincal.identification.measurements.SampleContext`).
ActsIn = Literal["model", "reading", "measurement"]



class Termed(Protocol):
    """What a kind reads of one of its parameters (a :class:`~pincal.identification.parameters.Parameter`): its
    ``term`` (``tx`` … ``rz``, ``offset``, …). A parameter has a kind; a kind needs no more of a parameter than this."""

    @property
    def term(self) -> str:
        """The parameter's term: what it is of its owner."""
        ...


#: Kind name -> its class, in the order the kinds were declared.
PARAMETER_KINDS: dict[str, type[ParameterKind]] = {}


class ParameterKind:
    """Base class of the parameter kinds; a subclass with a ``name`` registers itself in :data:`PARAMETER_KINDS`."""

    #: The kind's name: :attr:`Parameter.kind <pincal.identification.parameters.Parameter.kind>` of its parameters.
    name: ClassVar[str] = ""
    #: Where its parameters act (:data:`ActsIn`).
    acts_in: ClassVar[ActsIn] = "measurement"
    #: How a calibrated URDF holds its parameters; empty: a URDF cannot (:attr:`in_corrections` says where they go).
    urdf: ClassVar[str] = ""
    #: Whether the corrections file beside a calibrated URDF holds them (what a URDF cannot express).
    in_corrections: ClassVar[bool] = False
    #: Whether the report alone holds them (a camera's intrinsics): a calibrated URDF leaves them out.
    in_report: ClassVar[bool] = False
    #: The largest plausible correction of one of its parameters, by unit (``m``: a length [m], ``rad``: an angle
    #: [rad]); a unit left out, or an empty mapping, has no bound (the setup's kinds, the compliances).
    plausible: ClassVar[dict[str, float]] = {}
    #: The standard deviation of its parameters about nominal that the calibration assumes before the data
    #: (:mod:`pincal.identification.prior`), by unit; a unit left out, or an empty mapping, has no prior.
    prior: ClassVar[dict[str, float]] = {}
    #: Whether it is a placement a measurement model carries (:class:`~pincal.identification.measurements.Attachment`:
    #: a camera, a target, a plane): estimated as ``exp6(δ)`` of its components, its derivative the right Jacobian
    #: of ``exp6``, held by a calibrated URDF as a link of its own (:meth:`urdf_link`).
    attached: ClassVar[bool] = False
    #: What the reports call the kind among the measurement setup ("before" names what it registered).
    setup_words: ClassVar[str] = "device constants"
    #: What "before" is when the fit starts from its closed-form placement, and when the data did not give one
    #: (an attached kind; empty: its start does not change what "before" is).
    before_placed: ClassVar[str] = ""
    before_unplaced: ClassVar[str] = ""
    #: Whether a placement of the kind fixed in the world (owned by no frame) is all the data see of the world frame
    #: (a world target, a plane a sensor reads): the first joint's placement then moves every reading as it does, and
    #: the default set leaves it out, as it does for an estimated measurement frame (``base``).
    world_anchor: ClassVar[bool] = False
    #: The readings it predicts and what ``pincal check --register`` places on the data (an attached kind), for the
    #: message on a model without its link.
    check_words: ClassVar[tuple[str, str]] = ("camera", "cameras and targets")

    def __init_subclass__(cls, **kwargs: Any) -> None:
        super().__init_subclass__(**kwargs)
        if "name" in cls.__dict__:
            PARAMETER_KINDS[cls.name] = cls

    @classmethod
    def kinematic(cls) -> bool:
        """Whether its parameters change the robot model itself (the others act in the readings or the models)."""
        return cls.acts_in == "model"

    @classmethod
    def plausible_limit(cls, unit: str) -> float | None:
        """The largest plausible correction [``unit``] of one of its parameters in ``unit``; None: no bound."""
        return cls.plausible.get(unit)

    @classmethod
    def prefix(cls, owner: str, side: str = "") -> str:
        """The prefix of its parameters' names (``<prefix>.<component>``) for ``owner`` (and a loop's ``side``)."""
        return owner

    @classmethod
    def unit(cls, term: str, joint_unit: Unit = "rad") -> ParameterUnit:
        """The unit of its parameter ``term`` (a placement's ``tx`` … ``rz``, a marker's ``x``, ``offset``, …), of a
        joint whose values are in ``joint_unit``: [m] for translations, [rad] for rotations."""
        return "rad" if term.startswith("r") else "m"

    @classmethod
    def selection_group(cls, parameter: Termed) -> str | None:
        """The group model selection may leave out that ``parameter`` belongs to; None: it always stays."""
        return None

    @classmethod
    def urdf_link(cls, owner: str) -> str:
        """The name of the link a calibrated URDF gives the placement of this kind on ``owner``: only the kinds
        held as a link of their own (cameras, targets, planes) have one; TypeError for the others."""
        raise TypeError(f"a calibrated URDF holds {cls.name} parameters as {cls.urdf or 'no link'}, not as a link "
                        "of their own")

    @classmethod
    def before_means(cls, placed: bool) -> str:
        """What "before" is when the fit starts from this kind's closed-form placement (``placed``) or from where it
        starts (the data did not give one); empty: its start does not change what "before" is."""
        return cls.before_placed if placed else cls.before_unplaced


def parameter_kind(name: str) -> type[ParameterKind]:
    """The kind named ``name``; NotFoundError lists the kinds otherwise."""
    try:
        return PARAMETER_KINDS[name]
    except KeyError:
        raise not_found("parameter kind", name, list(PARAMETER_KINDS)) from None


def kinds_where(*, kinematic: bool | None = None, in_urdf: bool | None = None,
                in_corrections: bool | None = None, attached: bool | None = None,
                setup: bool | None = None) -> tuple[str, ...]:
    """The names of the registered kinds with the given properties, in declaration order (``setup``: acting in the
    measurement models, the measurement setup a day's measurements may have moved, not the robot)."""
    return tuple(name for name, kind in PARAMETER_KINDS.items()
                 if (kinematic is None or kind.kinematic() == kinematic)
                 and (attached is None or kind.attached == attached)
                 and (setup is None or (kind.acts_in == "measurement") == setup)
                 and (in_urdf is None or bool(kind.urdf) == in_urdf)
                 and (in_corrections is None or kind.in_corrections == in_corrections))



def setup_phrase(kinds: Iterable[str]) -> str:
    """The :attr:`ParameterKind.setup_words` of the kinds named (``kinds``, e.g. of a problem's parameters), each
    once, in the kinds' order of declaration, listed as a sentence lists them: ``measurement frame, markers and laser
    sensors``; ``nothing`` for none."""
    order = list(PARAMETER_KINDS)
    named = sorted(set(kinds), key=lambda name: order.index(name) if name in order else len(order))
    words = list(dict.fromkeys(parameter_kind(name).setup_words for name in named))
    if len(words) < 2:
        return words[0] if words else "nothing"
    return ", ".join(words[:-1]) + f" and {words[-1]}"

#: A placement of the robot's geometry: 20 mm and 2°. Calibrations of industrial arms correct their joint placements by
#: well under 5 mm and 1° (the TIAGo arm of docs/results/tiago_mocap.md by a few mm once its setup is set apart); a
#: robot of another model differs by tens to hundreds of millimetres (a UR5 from a UR10: 187 mm in the upper arm).
PLACEMENT_PLAUSIBLE = {"m": 0.020, "rad": math.radians(2.0)}
#: A joint reading's zero: 5° (20 mm for a prismatic joint). Encoder zeros and mastering are off by well under a
#: degree; 5° leaves room for a coarse zeroing, and a wrong sign or a swapped column is off by far more.
OFFSET_PLAUSIBLE = {"m": 0.020, "rad": math.radians(5.0)}
#: A harmonic of a reading: 1° (5 mm for a prismatic joint). Transmission errors are arcminutes.
HARMONIC_PLAUSIBLE = {"m": 0.005, "rad": math.radians(1.0)}
#: The prior of a placement: 5 mm and 0.5° about nominal, a quarter of the plausible size: machining and assembly
#: leave a geometry within a few millimetres and tenths of a degree of its drawing.
PLACEMENT_PRIOR = {"m": 0.005, "rad": math.radians(0.5)}
#: The prior of a reading's zero: 1° (5 mm): a zeroed encoder is off by tenths of a degree.
OFFSET_PRIOR = {"m": 0.005, "rad": math.radians(1.0)}
#: The prior of a harmonic: 0.2° (1 mm).
HARMONIC_PRIOR = {"m": 0.001, "rad": math.radians(0.2)}

#: What "before" is when the cameras and targets start where the hand-eye closed form puts them, and when it did not.
BEFORE_MEANS_PLACED = ("the nominal robot, with its cameras and targets placed to the training data in closed form "
                       "(hand-eye), for fit and held-out samples alike")
BEFORE_MEANS_UNPLACED = ("the nominal robot, with its cameras and targets at the identity (the training data did not "
                         "determine them in closed form), for fit and held-out samples alike")
#: What "before" is when each contact plane starts fitted to its contact points.
BEFORE_MEANS_PLANES = ("the nominal robot, with each contact plane fitted to its training contact points in closed "
                       "form (least squares), for fit and held-out samples alike")


class _Placement(ParameterKind):
    """A placement of the kinematic tree: translations and rotations are selected as groups."""

    plausible = PLACEMENT_PLAUSIBLE
    prior = PLACEMENT_PRIOR

    @classmethod
    def selection_group(cls, parameter: Termed) -> str | None:
        """``translations`` or ``rotations``."""
        return "translations" if parameter.term.startswith("t") else "rotations"


class JointPlacement(_Placement):
    """``<joint>.<c>``: the URDF origin of a joint, movable or fixed (c in tx, ty, tz, rx, ry, rz)."""

    name = "joint"
    acts_in = "model"
    urdf = "the joint's origin"


class AnchorPlacement(_Placement):
    """``<loop>.predecessor.<c>``, ``<loop>.successor.<c>``: the origin of a loop's anchor on one side."""

    name = "anchor"
    acts_in = "model"
    urdf = "the loop anchor's origin"

    @classmethod
    def prefix(cls, owner: str, side: str = "") -> str:
        """``<loop>.<side>``."""
        return f"{owner}.{side}"


class ReadingOffset(ParameterKind):
    """``<joint>.offset``: a joint reading's offset, ``q_true = q_read + δq`` [rad or m]."""

    name = "offset"
    acts_in = "reading"
    plausible = OFFSET_PLAUSIBLE
    prior = OFFSET_PRIOR
    urdf = "folded into the joint's origin (a read joint's: its <joint_sensor> zero)"

    @classmethod
    def unit(cls, term: str, joint_unit: Unit = "rad") -> ParameterUnit:
        """The joint's unit."""
        return joint_unit

    @classmethod
    def selection_group(cls, parameter: Termed) -> str | None:
        """``offsets``."""
        return "offsets"


class BasePlacement(ParameterKind):
    """``base.<c>``: the robot's base in the measurement frame, ``world = base · exp6(δ) · robot``."""

    name = "base"
    setup_words = "measurement frame"
    urdf = "the measurement frame's link, the file's new root"

    @classmethod
    def prefix(cls, owner: str, side: str = "") -> str:
        """``base``."""
        return "base"


class MarkerOffset(ParameterKind):
    """``marker.<key>.<x|y|z>``: a measured point's offset on its frame [m]."""

    name = "marker"
    urdf = "a marker link on the frame"
    setup_words = "markers"

    @classmethod
    def prefix(cls, owner: str, side: str = "") -> str:
        """``marker.<key>``."""
        return f"marker.{owner}"

    @classmethod
    def unit(cls, term: str, joint_unit: Unit = "rad") -> ParameterUnit:
        """[m]."""
        return "m"


class ClusterPlacement(ParameterKind):
    """``cluster.<frame>.<c>``: the rigid placement of the declared markers on a frame."""

    name = "cluster"
    urdf = "the cluster's marker links on the frame"
    setup_words = "markers"

    @classmethod
    def prefix(cls, owner: str, side: str = "") -> str:
        """``cluster.<frame>``."""
        return f"cluster.{owner}"


class CameraPlacement(ParameterKind):
    """``camera.<frame>.<c>``: a camera fixed on a frame (frame ← camera; eye-in-hand)."""

    name = "camera"
    urdf = "a camera link on the frame"
    attached = True
    setup_words = "cameras"
    before_placed = BEFORE_MEANS_PLACED
    before_unplaced = BEFORE_MEANS_UNPLACED

    @classmethod
    def prefix(cls, owner: str, side: str = "") -> str:
        """``camera.<frame>``."""
        return camera_name(owner)

    @classmethod
    def urdf_link(cls, owner: str) -> str:
        """``<frame>_camera``."""
        return f"{owner}_camera"


class TargetPlacement(ParameterKind):
    """``target.<c>``: the target the eye-in-hand cameras see, in the world; ``target.<frame>@<target>.<c>``: a pose
    target fixed on a frame."""

    name = "target"
    urdf = "a target link (on the robot's root link, or on the frame)"
    attached = True
    world_anchor = True
    setup_words = "targets"
    before_placed = BEFORE_MEANS_PLACED
    before_unplaced = BEFORE_MEANS_UNPLACED

    @classmethod
    def prefix(cls, owner: str, side: str = "") -> str:
        """``target`` (the world target, ``owner`` empty) or ``target.<frame>@<target>``."""
        return f"{WORLD_TARGET}.{owner}" if owner else WORLD_TARGET

    @classmethod
    def urdf_link(cls, owner: str) -> str:
        """``camera_target`` (the world target, ``owner`` empty) or ``<frame>_target_<target>``."""
        frame, name = split_target(owner)
        return f"{frame}_target_{name}" if owner else "camera_target"


class PlanePlacement(ParameterKind):
    """``plane.<c>``: the plane a frame touches, fixed in the robot's world; ``plane.<support>.<c>``: fixed on the
    robot frame ``support`` (the sole a humanoid stands on). Its placement ``exp6(δ)`` (support ← plane) has the
    plane's normal along its z axis; only ``tz`` [m] (the offset along the normal) and ``rx``, ``ry`` [rad] (the
    tilts) are parameters: what the plane's points cannot tell (where on the plane, the rotation about the
    normal) is not one."""

    name = PLANE
    urdf = "a plane link (its z axis the normal) on the support's link, or on the robot's root link"
    attached = True
    setup_words = "contact planes"
    before_placed = before_unplaced = BEFORE_MEANS_PLANES
    check_words = ("contact", "planes")

    @classmethod
    def prefix(cls, owner: str, side: str = "") -> str:
        """``plane`` (fixed in the world, ``owner`` empty) or ``plane.<support>``."""
        return plane_name(owner)

    @classmethod
    def urdf_link(cls, owner: str) -> str:
        """``contact_plane`` (a plane in the world, ``owner`` empty) or ``<support>_plane``."""
        return f"{owner}_plane" if owner else "contact_plane"


class CameraIntrinsics(ParameterKind):
    """``intrinsics.<frame>.<c>``: the intrinsics of the camera on a frame (``intrinsics.<c>``: of the fixed camera),
    added to the nominal values the data declare: ``fx, fy, cx, cy`` [px], ``k1, k2, p1, p2, k3`` [1] (OpenCV's
    model, :mod:`pincal.identification.measurements.pixels`)."""

    name = "intrinsics"
    in_report = True
    setup_words = "camera intrinsics"

    @classmethod
    def prefix(cls, owner: str, side: str = "") -> str:
        """``intrinsics.<frame>``, or ``intrinsics`` for the fixed camera (``owner`` empty)."""
        return intrinsics_name(owner)

    @classmethod
    def unit(cls, term: str, joint_unit: Unit = "rad") -> ParameterUnit:
        """[px] for ``fx, fy, cx, cy``, [1] for the distortion."""
        return "px" if term in INTRINSICS[:4] else "1"


class Harmonic(ParameterKind):
    """``<joint>.sin1|cos1|sin2|cos2``: harmonics of an actuated joint's reading [rad or m]."""

    name = "harmonic"
    acts_in = "reading"
    plausible = HARMONIC_PLAUSIBLE
    prior = HARMONIC_PRIOR
    in_corrections = True

    @classmethod
    def unit(cls, term: str, joint_unit: Unit = "rad") -> ParameterUnit:
        """The joint's unit."""
        return joint_unit

    @classmethod
    def selection_group(cls, parameter: Termed) -> str | None:
        """``harmonics``."""
        return "harmonics"


class Compliance(ParameterKind):
    """``<joint>.compliance``: an actuated joint's compliance, ``δq = c τ_g(q_r)`` [rad/(N m) or m/N]."""

    name = "compliance"
    acts_in = "reading"
    in_corrections = True

    @classmethod
    def unit(cls, term: str, joint_unit: Unit = "rad") -> ParameterUnit:
        """[rad/(N m)], or [m/N] for a prismatic joint."""
        return "rad/(N m)" if joint_unit == "rad" else "m/N"

    @classmethod
    def selection_group(cls, parameter: Termed) -> str | None:
        """``compliance``."""
        return "compliance"
