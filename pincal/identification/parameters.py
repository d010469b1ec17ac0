"""Calibration parameters: which placements, offsets and constants are unknown, and vector ↔ model.

Every chosen placement M becomes ``M · exp6(δ)``, δ = (tx, ty, tz, rx, ry, rz) in M's own frame
([m] and [rad]; the convention of Pinocchio's ``computeFrameKinematicRegressor(LOCAL)``). Names:

- ``<joint>.<c>``: the URDF origin of a joint (movable or fixed), c in tx, ty, tz, rx, ry, rz;
- ``<loop>.predecessor.<c>`` / ``<loop>.successor.<c>``: a loop anchor's origin;
- ``<joint>.offset``: a joint reading offset, ``q_true = q_read + δq`` [rad or m];
- ``base.<c>``: the robot base in the measurement frame (``world = base · exp6(δ) · robot``);
- ``marker.<frame>.<x|y|z>``: a measured point's offset in ``frame`` [m]; ``marker.<frame>@<marker>.<x|y|z>``: the
  offset of declared marker ``marker`` on ``frame`` [m], from its nominal offset;
- ``cluster.<frame>.<c>``: the rigid placement of the cluster of declared markers on ``frame``, ``exp6(δ)`` applied
  to their nominal offsets (in ``frame``);
- ``camera.<frame>.<c>``: the placement of a camera fixed on ``frame`` (frame ← camera, ``exp6(δ)``; eye-in-hand);
- ``target.<c>``: the placement of the target the eye-in-hand cameras see, in the robot's world frame (world ←
  target; a point target: its translation ``tx, ty, tz``); ``target.<frame>@<target>.<c>``: a pose target fixed on
  ``frame`` (frame ← target; eye-to-hand, the camera being the measurement frame ``base.*``);
- device constants named by their measurement model (e.g. ``scale.zero``).

The values of a :class:`ParameterSet` are deviations from the nominal robot (zero = nominal).
"""

from __future__ import annotations

import fnmatch
from collections.abc import Callable, Iterable, Iterator, Sequence
from dataclasses import dataclass, field
from typing import Literal

import numpy as np
import numpy.typing as npt
import pinocchio as pin

from pincal.errors import DataError, NotFoundError, listing, not_found
from pincal.identification.measurements import WORLD_TARGET, Measurement, camera_name, split_target
from pincal.model.robot import Robot
from pincal.model.robot import Unit as Unit
from pincal.model.robot import joint_unit as joint_unit
from pincal.model.urdf import LoopSpec

Array = npt.NDArray[np.float64]

COMPONENTS = ("tx", "ty", "tz", "rx", "ry", "rz")
AXES = ("x", "y", "z")
#: Default parameter scales: the typical size of a geometric error [m] and [rad].
LENGTH_SCALE = 1e-3
ANGLE_SCALE = 1e-3
#: Typical gravity torque [N m] and force [N] on a joint, for the scale of a compliance.
TORQUE_SCALE = 10.0
FORCE_SCALE = 100.0
#: What a parameter is: a joint origin's placement component, a loop anchor's, a joint reading's offset, the
#: measurement frame's placement component, a marker's offset component, a marker cluster's placement component, a
#: camera's or a target's placement component, or a correction of an actuated joint's value that a URDF cannot hold
#: (a harmonic of its reading, its compliance: :mod:`pincal.identification.corrections`).
ParameterKind = Literal["joint", "anchor", "offset", "base", "marker", "cluster", "camera", "target", "harmonic",
                        "compliance"]
#: How the declared markers of a frame (``position:<frame>@<marker>``) are fitted: ``each`` marker's offset on its
#: own (``marker.<frame>@<marker>.*``), or one rigid placement of the frame's ``cluster`` of markers, whose nominal
#: offsets the data declare (``cluster.<frame>.*``).
MarkerFit = Literal["each", "cluster"]
MARKER_FITS: tuple[MarkerFit, ...] = ("each", "cluster")
#: Parameter kinds that change the robot model itself (the others act in the measurement models).
KINEMATIC_KINDS: tuple[ParameterKind, ...] = ("joint", "anchor")
#: Parameter kinds that correct an actuated joint's value as a function of its reading (the corrections file).
CORRECTION_KINDS: tuple[ParameterKind, ...] = ("harmonic", "compliance")
#: A parameter's unit: a length or an angle, or a compliance (angle per torque, length per force).
ParameterUnit = Literal["m", "rad", "rad/(N m)", "m/N"]


@dataclass(frozen=True)
class Parameter:
    """One scalar unknown.

    Attributes:
        name: Unique name (see module docstring).
        kind: ``joint``, ``anchor``, ``offset``, ``base``, ``marker``, ``cluster``, ``camera``, ``target``,
            ``harmonic`` or ``compliance``.
        target: Joint name, loop name, frame name (marker target ``<frame>@<marker>`` for a declared marker, pose
            target ``<frame>@<target>``; empty for the world target), or device constant name.
        component: Index in (tx, ty, tz, rx, ry, rz) for placements, in (x, y, z) for markers, in
            (sin1, cos1, sin2, cos2) for harmonics.
        side: ``predecessor`` or ``successor`` for anchors.
        unit: ``m`` or ``rad``; a compliance ``rad/(N m)`` or ``m/N``.
    """

    name: str
    kind: ParameterKind
    target: str
    component: int = 0
    side: str = ""
    unit: ParameterUnit = "m"

    @property
    def scale(self) -> float:
        """Typical size [m, rad, rad/(N m) or m/N], used to scale the identification problem: 1 mm, 1 mrad, and
        for a compliance the deflection of 1 mrad under 10 N m (1 mm under 100 N)."""
        return {"m": LENGTH_SCALE, "rad": ANGLE_SCALE, "rad/(N m)": ANGLE_SCALE / TORQUE_SCALE,
                "m/N": LENGTH_SCALE / FORCE_SCALE}[self.unit]

    @property
    def term(self) -> str:
        """The last part of the name: a placement component, ``offset``, a harmonic term or ``compliance``."""
        return self.name.rsplit(".", 1)[-1]

    @property
    def group(self) -> tuple[str, str, str]:
        """The placement this parameter belongs to: (kind, target, side)."""
        return (self.kind, self.target, self.side)


def placement_parameters(kind: ParameterKind, target: str, side: str = "",
                         components: Sequence[str] = COMPONENTS) -> list[Parameter]:
    """The parameters of one placement (a joint origin, a loop anchor, the base, a marker cluster, a camera, a
    target)."""
    prefix = {"joint": target, "anchor": f"{target}.{side}", "base": "base", "cluster": f"cluster.{target}"}.get(
        kind) or attached_name(kind, target)
    return [Parameter(f"{prefix}.{c}", kind, target, COMPONENTS.index(c), side,
                      "m" if c.startswith("t") else "rad") for c in components]


def offset_parameter(joint: str, unit: Unit) -> Parameter:
    """The reading offset ``δq`` of a joint [m or rad]: ``q_true = q_read + δq``."""
    return Parameter(f"{joint}.offset", "offset", joint, 0, "", unit)


def harmonic_parameters(joint: str, unit: Unit, orders: int = 2) -> list[Parameter]:
    """The harmonics of an actuated joint's reading, ``<joint>.sin1``, ``.cos1`` (and ``.sin2``, ``.cos2`` for
    ``orders=2``) [rad or m]: ``δq = a₁ sin q_r + b₁ cos q_r + a₂ sin 2q_r + b₂ cos 2q_r``."""
    terms = ("sin1", "cos1", "sin2", "cos2")[:2 * orders]
    return [Parameter(f"{joint}.{t}", "harmonic", joint, k, "", unit) for k, t in enumerate(terms)]


def compliance_parameter(joint: str, unit: Unit) -> Parameter:
    """An actuated joint's compliance ``<joint>.compliance`` [rad/(N m), or m/N for a prismatic joint]:
    ``δq = c τ_g(q_r)``, τ_g the gravity torque on the joint."""
    return Parameter(f"{joint}.compliance", "compliance", joint, 0, "", "rad/(N m)" if unit == "rad" else "m/N")


def marker_parameters(target: str) -> list[Parameter]:
    """The marker offset [m] of marker target ``target`` (``<frame>`` or ``<frame>@<marker>``): its x, y, z
    components in the frame."""
    return [Parameter(f"marker.{target}.{a}", "marker", target, k, "", "m") for k, a in enumerate(AXES)]


def cluster_parameters(frame: str) -> list[Parameter]:
    """The placement of the cluster of declared markers on ``frame`` (tx, ty, tz [m], rx, ry, rz [rad])."""
    return placement_parameters("cluster", frame)


def attached_name(kind: str, target: str) -> str:
    """The name of a camera's or a target's placement (its parameters' prefix): ``camera.<frame>``, ``target`` (the
    world target, ``target`` empty) or ``target.<frame>@<target>``."""
    if kind == "camera":
        return camera_name(target)
    return f"{WORLD_TARGET}.{target}" if target else WORLD_TARGET


def camera_parameters(models: Sequence[Measurement]) -> list[Parameter]:
    """The unknown placements the cameras bring (each model's ``attachments``): each eye-in-hand camera on its frame
    (``camera.<frame>.*``), the world target they see (``target.*``; its translation only when every camera sees a
    point), and each pose target on a frame (``target.<frame>@<target>.*``, eye-to-hand)."""
    components: dict[tuple[str, str], set[str]] = {}
    for m in models:
        for a in m.attachments:
            components.setdefault((a.kind, a.target), set()).update(a.components)
    order = sorted(components, key=lambda name: (name[0] != "camera", name[1] != "", name[1]))
    return [p for kind, target in order
            for p in placement_parameters(kind, target, components=[c for c in COMPONENTS  # type: ignore[arg-type]
                                                                    if c in components[(kind, target)]])]


def sees_world_target(models: Sequence[Measurement]) -> bool:
    """Whether a camera on the robot sees a target fixed in the world (eye-in-hand): the world frame is then
    seen only through that target, as an external measurement frame is through ``base.*``."""
    return any(a.kind == "target" and not a.target for m in models for a in m.attachments)


def marker_targets(models: Sequence[Measurement]) -> list[str]:
    """The marker targets the measurements read (``<frame>`` or ``<frame>@<marker>``), sorted."""
    return sorted({t for m in models for t in m.markers})


def clustered_frames(models: Sequence[Measurement]) -> list[str]:
    """The frames carrying declared markers (``position:<frame>@<marker>``), sorted."""
    return sorted({split_target(t)[0] for m in models for t in m.markers if split_target(t)[1]})


def read_joints(models: Sequence[Measurement]) -> list[str]:
    """The joints whose own readings the measurements are (instrumented passive joints), in the models' order."""
    return [j for m in models for j in m.read_joints]


def _estimated_on_frames(models: Sequence[Measurement]) -> list[str]:
    """The frames whose measured point or placement on the frame is estimated (a marker, a camera, a pose target):
    a tool placement on them would duplicate it."""
    frames = {split_target(t)[0] for m in models for t in m.markers}
    frames |= {a.target if a.kind == "camera" else split_target(a.target)[0]
               for m in models for a in m.attachments if a.target}
    return sorted(frames)


@dataclass
class ParameterSet:
    """An ordered set of parameters; its vectors hold deviations from the nominal robot."""

    parameters: list[Parameter] = field(default_factory=list)

    def __post_init__(self) -> None:
        names = [p.name for p in self.parameters]
        if len(set(names)) != len(names):
            dup = sorted({n for n in names if names.count(n) > 1})
            raise DataError(f"duplicate parameters: {listing(dup)}")
        self._index = {p.name: k for k, p in enumerate(self.parameters)}

    def __len__(self) -> int:
        return len(self.parameters)

    def __iter__(self) -> Iterator[Parameter]:
        return iter(self.parameters)

    def __contains__(self, name: object) -> bool:
        return name in self._index

    @property
    def names(self) -> list[str]:
        """The parameter names, in vector order."""
        return [p.name for p in self.parameters]

    @property
    def scales(self) -> Array:
        """Typical sizes [m or rad], one per parameter."""
        return np.array([p.scale for p in self.parameters])

    def index(self, name: str) -> int:
        """The position of parameter ``name`` in the vector; NotFoundError lists the names otherwise."""
        try:
            return self._index[name]
        except KeyError:
            raise not_found("parameter", name, self.names) from None

    def of_kind(self, *kinds: str) -> list[int]:
        """Indices of the parameters of the given kinds."""
        return [k for k, p in enumerate(self.parameters) if p.kind in kinds]

    def groups(self, *kinds: str) -> dict[tuple[str, str, str], list[int]]:
        """Indices per placement (kind, target, side), for the given kinds."""
        out: dict[tuple[str, str, str], list[int]] = {}
        for k, p in enumerate(self.parameters):
            if p.kind in kinds:
                out.setdefault(p.group, []).append(k)
        return out

    def subset(self, indices: Iterable[int]) -> ParameterSet:
        """The parameters at ``indices``, in that order."""
        return ParameterSet([self.parameters[k] for k in indices])

    def select(self, patterns: Sequence[str]) -> ParameterSet:
        """The parameters whose names match any shell-style pattern (``arm_*.t?``, ``*.offset``).

        A pattern starting with ``!`` removes what it matches; patterns that are all exclusions start
        from every parameter. Raises NotFoundError for a pattern matching nothing, or when nothing is left.
        """
        only_exclusions = all(pattern.startswith("!") for pattern in patterns)
        keep: list[bool] = [only_exclusions] * len(self.parameters)  # "!base.*" alone: everything but the base
        for pattern in patterns:
            negate = pattern.startswith("!")
            pat = pattern[1:] if negate else pattern
            hits = [k for k, p in enumerate(self.parameters) if fnmatch.fnmatchcase(p.name, pat)]
            if not hits:
                raise NotFoundError(f"parameter pattern '{pattern}' matches nothing; parameters are: "
                                    f"{listing(self.names)}")
            for k in hits:
                keep[k] = not negate
        chosen = [p for p, k in zip(self.parameters, keep, strict=True) if k]
        if not chosen:
            raise NotFoundError(f"the patterns {' '.join(patterns)} leave no parameter to identify")
        return ParameterSet(chosen)

    def vector(self, values: dict[str, float] | None = None) -> Array:
        """A parameter vector, zero (nominal) except for the given ``{name: value}``."""
        x = np.zeros(len(self))
        for name, value in (values or {}).items():
            x[self.index(name)] = value
        return x

    def as_dict(self, x: Array) -> dict[str, float]:
        """Parameter name -> its value [m or rad] in the vector ``x``."""
        return {p.name: float(v) for p, v in zip(self.parameters, x, strict=True)}

    def placement_delta(self, x: Array, indices: list[int]) -> Array:
        """The 6-vector δ of one placement group from the parameter vector."""
        delta = np.zeros(6)
        for k in indices:
            delta[self.parameters[k].component] = x[k]
        return delta


# --- candidate parameters of a robot ---------------------------------------------------------------
def movable_joints(robot: Robot) -> list[str]:
    """Names of the model's movable joints (every Pinocchio joint but the universe)."""
    return [str(n) for n in robot.model.names[1:]]


def fixed_joints(robot: Robot) -> list[str]:
    """Names of the fixed joints (Pinocchio ``FIXED_JOINT`` frames)."""
    return [f.name for f in robot.model.frames if f.type == pin.FrameType.FIXED_JOINT and f.name != "universe"]


def planar_normal(robot: Robot, tol: float = 1e-9) -> Array | None:
    """The plane normal if the robot is planar (all revolute axes along n, prismatic axes across it,
    loops revolute about n), else None. Evaluated at the reference configuration, world frame."""
    if not robot.loops:
        return None
    model, data = robot.model, robot.model.createData()
    pin.computeJointJacobians(model, data, robot.q_reference)
    normal: Array | None = None
    across: list[Array] = []
    for jid in range(1, model.njoints):
        joint = model.joints[jid]
        if joint.nv != 1:
            return None
        col = pin.getJointJacobian(model, data, jid, pin.LOCAL_WORLD_ALIGNED)[:, joint.idx_v]
        if np.linalg.norm(col[3:]) > tol:
            axis = col[3:] / np.linalg.norm(col[3:])
            if normal is None:
                normal = axis
            elif abs(abs(float(axis @ normal)) - 1.0) > tol:
                return None
        else:
            across.append(col[:3] / np.linalg.norm(col[:3]))
    if normal is None or any(abs(float(a @ normal)) > tol for a in across):
        return None
    for loop in robot.loops:
        if loop.type != "revolute":
            return None
        frame = model.frames[model.getFrameId(loop.predecessor)]
        world = data.oMi[frame.parentJoint] * frame.placement * loop.predecessor_origin
        if abs(abs(float((world.rotation @ loop.axis) @ normal)) - 1.0) > tol:
            return None
    return normal


def _in_plane(placement_world: pin.SE3, normal: Array | None, tol: float = 1e-9) -> Sequence[str]:
    """Components of a placement that keep a planar robot planar (tx, ty, rz when its z is the normal)."""
    if normal is None or abs(abs(float(placement_world.rotation[:, 2] @ normal)) - 1.0) > tol:
        return COMPONENTS
    return ("tx", "ty", "rz")


def candidate_parameters(robot: Robot, frames: Sequence[str] = (), offsets: Sequence[str] | None = None,
                         base: bool = False, markers: bool = False) -> ParameterSet:
    """Every geometric parameter that could matter: a superset the identifiability analysis prunes.

    Args:
        robot: The robot.
        frames: Measured frames; fixed joints on their path (tool, marker frames) are included.
        offsets: Joints whose reading offsets are unknown; default: the actuated joints.
        base: Include the base placement in the measurement frame (6 parameters).
        markers: Include a point offset for each measured frame (3 parameters each).
    """
    for f in frames:
        robot.frame_id(f)  # NotFoundError naming the frame and listing the valid ones
    params: list[Parameter] = []
    model = robot.model
    normal = planar_normal(robot)
    data = model.createData()
    pin.framesForwardKinematics(model, data, robot.q_reference)
    for joint in movable_joints(robot):
        jid = model.getJointId(joint)
        params += placement_parameters("joint", joint, components=_in_plane(data.oMi[jid], normal))
    for name in fixed_joints(robot):
        fid = model.getFrameId(name, pin.FrameType.FIXED_JOINT)
        if any(_descends(model, model.getFrameId(f), fid) for f in frames):
            params += placement_parameters("joint", name, components=_in_plane(data.oMf[fid], normal))
    for loop in robot.loops:
        for side, link, origin in (("predecessor", loop.predecessor, loop.predecessor_origin),
                                   ("successor", loop.successor, loop.successor_origin)):
            comps = _in_plane(data.oMf[model.getFrameId(link)] * origin, normal)
            if loop.type == "spherical":
                comps = COMPONENTS[:3]
            params += placement_parameters("anchor", loop.name, side, comps)
    for joint in robot.actuated_joints if offsets is None else offsets:
        params.append(offset_parameter(joint, joint_unit(robot, joint)))
    if base:
        params += placement_parameters("base", "base")
    if markers:
        for f in frames:
            params += marker_parameters(f)
    return ParameterSet(params)


def _descends(model: pin.Model, frame_id: int, ancestor_id: int) -> bool:
    """True if ``frame_id`` is ``ancestor_id`` or below it in the frame tree."""
    f = frame_id
    while True:
        if f == ancestor_id:
            return True
        parent = int(model.frames[f].parentFrame)
        if parent == f or f == 0:
            return False
        f = parent


# --- named physical parameter sets -----------------------------------------------------------------
def model24(robot: Robot) -> ParameterSet:
    """The Delta's "Model 24" of study 000, Eq. 3.6: per leg i, P_i = [Dx, Dy, Dz, θ, α, Lax, Lay, Lb].

    Mapping onto pincal's placements (delta.urdf): Dx, Dy, Dz = ``arm_i_joint.tx/ty/tz`` (motor axis
    position A_i); θ = ``arm_i_joint.rz`` (leg direction about z); α = ``arm_i_joint.offset`` (arm
    angle zero); Lax, Lay = ``rod_i_pitch.tx/tz`` (the elbow's position in the arm's plane of motion: along the
    arm, and across it);
    Lb = ``leg_i_platform.predecessor.tz`` (rod length: the rod runs along its frame's -z).

    With position data, Lay_i and α_i act only through one combination (turning the elbow about the
    motor axis is an arm-angle offset): 21 of the 24 are identifiable, and the analysis says so.
    """
    return _named(robot, _model24_names("rod_{i}_pitch.tz"), "model24")


def _model24_names(lay: str) -> list[str]:
    """Model 24's names per leg i = 1, 2, 3, with ``lay`` (a format string in i) as the seventh."""
    names = []
    for i in (1, 2, 3):
        names += [f"arm_{i}_joint.tx", f"arm_{i}_joint.ty", f"arm_{i}_joint.tz", f"arm_{i}_joint.rz",
                  f"arm_{i}_joint.offset", f"rod_{i}_pitch.tx", lay.format(i=i), f"leg_{i}_platform.predecessor.tz"]
    return names


def model24_identifiable(robot: Robot) -> ParameterSet:
    """Model 24 with Lay_i replaced by the motor axis' tilt ``arm_i_joint.rx`` [rad].

    Per leg, position data see exactly eight independent errors: the motor axis' position (3) and
    direction (2), the arm length, the arm-angle zero and the rod length. Every reading of Lay as a
    length duplicates one of them; the axis tilt is the eighth. All 24 are identifiable.
    """
    return _named(robot, _model24_names("arm_{i}_joint.rx"), "model24i")


def hexapod42(robot: Robot, device: bool = False) -> ParameterSet:
    """The 42 parameters of study 001 (per leg: base U centre 3, platform S centre 3, length offset 1).

    With ``device=True``, the measuring device's D0 (``device_lvdt.tz``: the link's fixed length) and
    ψ (``device_incl_x.rz``: the inclinometer's second axis turned in the first axis' normal plane).
    """
    names = []
    for i in range(1, 7):
        names += [f"leg_{i}_u1.tx", f"leg_{i}_u1.ty", f"leg_{i}_u1.tz",
                  f"leg_{i}_platform.successor.tx", f"leg_{i}_platform.successor.ty",
                  f"leg_{i}_platform.successor.tz", f"leg_{i}_prismatic.offset"]
    if device:
        names += ["device_lvdt.tz", "device_incl_x.rz"]
    return _named(robot, names, "hexapod44" if device else "hexapod42")


def _named(robot: Robot, names: list[str], set_name: str) -> ParameterSet:
    pool = candidate_parameters(robot, offsets=movable_joints(robot))
    missing = [n for n in names if n not in pool]
    if missing:
        raise NotFoundError(f"parameter set '{set_name}' needs {listing(missing)}, which robot "
                            f"'{robot.name}' does not have")
    return ParameterSet([pool.parameters[pool.index(n)] for n in names])


NAMED_SETS: dict[str, Callable[[Robot], ParameterSet]] = {
    "model24": model24, "model24i": model24_identifiable, "hexapod42": hexapod42,
    "hexapod44": lambda robot: hexapod42(robot, device=True)}


# --- applying parameters ---------------------------------------------------------------------------
def apply_parameters(robot: Robot, pset: ParameterSet, x: Array) -> Robot:
    """A new Robot with the joint and anchor deviations ``x`` applied; ``robot`` is untouched.

    Offsets, base, markers and device constants do not change the model: the measurement models
    apply them.
    """
    model = pin.Model(robot.model)
    loops = {loop.name: loop for loop in robot.loops}
    for (kind, target, side), idx in pset.groups(*KINEMATIC_KINDS).items():
        exp = pin.exp6(pset.placement_delta(x, idx))
        if kind == "joint":
            if model.existJointName(target):
                jid = model.getJointId(target)
                model.jointPlacements[jid] = model.jointPlacements[jid] * exp
            else:
                move_fixed_joint(model, target, exp)
        else:
            loop = loops[target]
            pred, succ = loop.predecessor_origin, loop.successor_origin
            if side == "predecessor":
                pred = pred * exp
            else:
                succ = succ * exp
            loops[target] = loop.with_origins(pred, succ)
    return Robot(model, [loops[loop.name] for loop in robot.loops], robot.actuated_joints, robot.name,
                 robot.source)


def move_fixed_joint(model: pin.Model, joint: str, exp: pin.SE3) -> None:
    """Right-multiply a fixed joint's origin by ``exp`` and carry its subtree along (in place)."""
    if not model.existFrame(joint, pin.FrameType.FIXED_JOINT):
        raise NotFoundError(f"no joint '{joint}' in the model; joints are: {listing(model.names[1:])}, "
                            f"fixed: {listing(f.name for f in model.frames if f.type == pin.FrameType.FIXED_JOINT)}")
    fid = model.getFrameId(joint, pin.FrameType.FIXED_JOINT)
    frame = model.frames[fid]
    parent_joint = frame.parentJoint
    old = frame.placement.copy()
    new = old * exp
    move = new * old.inverse()
    for g in range(len(model.frames)):
        f = model.frames[g]
        if g == fid or not _descends(model, g, fid):
            continue
        if f.type == pin.FrameType.JOINT:
            jid = model.getJointId(f.name)
            if model.parents[jid] == parent_joint:
                model.jointPlacements[jid] = move * model.jointPlacements[jid]
                f.placement = model.jointPlacements[jid]
        elif f.parentJoint == parent_joint:
            f.placement = move * f.placement
    frame.placement = new


# --- the default set: minimal by construction ----------------------------------------------------
def influencing_joints(robot: Robot, frames: Sequence[str], read: Sequence[str] = ()) -> list[str]:
    """The movable joints whose motion or placement can change a measured quantity, in model order.

    They are the joints above the measured ``frames`` and the ``read`` joints, then every joint of a loop
    that closes through one of them (a loop's closure sets the values of all its joints), repeated until
    nothing is added; a ``<mimic>`` follower brings its leader. The others (a TIAGo's head and wheels when
    its hand is measured) cannot move what is measured.
    """
    model = robot.model
    chosen: set[int] = set()
    for frame in frames:
        chosen |= set(model.supports[model.frames[robot.frame_id(frame)].parentJoint])
    for joint in read:
        chosen |= set(model.supports[robot.joint_id(joint)])
    loop_joints = [_loop_support(robot, loop) for loop in robot.loops]
    grew = True
    while grew:
        grew = False
        for support in loop_joints:
            if (support & chosen) - {0} and not support <= chosen:
                chosen |= support
                grew = True
    leaders = {model.joints[j].idx_v: j for j in range(1, model.njoints) if model.joints[j].nv == 1}
    for j in list(chosen):
        if j and model.joints[j].nv == 0 and model.joints[j].idx_v in leaders:  # a mimic follower
            chosen |= set(model.supports[leaders[model.joints[j].idx_v]])
    return [str(model.names[j]) for j in sorted(chosen - {0})]


def _loop_support(robot: Robot, loop: LoopSpec) -> set[int]:
    """The joints above either side of a loop."""
    model = robot.model
    return {int(j) for link in (loop.predecessor, loop.successor)
            for j in model.supports[model.frames[model.getFrameId(link)].parentJoint]}


def _own_motion(robot: Robot, joint: str) -> str | None:
    """The placement component that duplicates a one-DOF joint's own motion (rotation about a revolute axis
    along x, y or z of the joint frame is a change of its angle; translation along a prismatic axis, of its
    position), or None (an axis not along x, y or z, a mimic follower, a multi-DOF joint)."""
    model = robot.model
    jid = robot.joint_id(joint)
    if model.joints[jid].nv != 1:
        return None
    data = model.createData()
    pin.computeJointJacobians(model, data, robot.q_reference)
    twist = pin.getJointJacobian(model, data, jid, pin.LOCAL)[:, model.joints[jid].idx_v]
    for part, prefix in ((twist[3:], "r"), (twist[:3], "t")):
        if np.linalg.norm(part) > 0.5:
            axis = int(np.argmax(np.abs(part)))
            return f"{prefix}{AXES[axis]}" if abs(abs(part[axis]) - 1.0) < 1e-9 else None
    return None


def default_parameters(robot: Robot, models: Sequence[Measurement], markers: MarkerFit = "each") -> ParameterSet:
    """The default unknowns: every geometric error that can change a measured quantity, without the ones
    that duplicate another by construction (what remains redundant, the identifiability analysis finds).

    - placements of the :func:`influencing_joints`, except the component along a one-DOF joint's own axis (its
      offset, or for a passive loop joint its free value), and except the first joint's whole placement when
      the measurement frame is estimated (``base`` moves the chain the same way);
    - per measured frame, the fixed joint nearest to it below its last moving joint (the tool): translation for
      a position without a marker, all six for a pose; none when a marker offset, a camera or a target on the frame
      is estimated;
    - the anchors of the loops those joints close;
    - reading offsets of the influencing actuated joints and of the read joints;
    - the measurement frame (``base.*``) when positions or poses are measured in an external frame, and a marker
      offset (``marker.<target>.*``) for each marker target whose position is measured (``<frame>``, and each
      declared marker ``<frame>@<marker>``); with ``markers="cluster"``, the declared markers of a frame get one
      cluster placement (``cluster.<frame>.*``) instead, and need their nominal offsets (:func:`check_marker_fit`);
    - the cameras and targets (:func:`camera_parameters`); a world target seen by an eye-in-hand camera leaves the
      first joint's placement out as an estimated measurement frame does.
    """
    check_marker_fit(markers, models)
    frames = sorted({f for m in models for f in m.frames})
    read = read_joints(models)
    external = any(m.locates_point for m in models)
    marked = _estimated_on_frames(models)
    joints = influencing_joints(robot, frames, read)
    model = robot.model
    normal = planar_normal(robot)
    data = model.createData()
    pin.framesForwardKinematics(model, data, robot.q_reference)
    firsts = [j for j in joints if model.parents[robot.joint_id(j)] == 0]
    params: list[Parameter] = []
    for joint in joints:
        if (external or sees_world_target(models)) and firsts == [joint]:
            continue  # one chain from the root: its first placement and the base (or world target) are one and the same
        jid = robot.joint_id(joint)
        own = _own_motion(robot, joint)
        comps = [c for c in _in_plane(data.oMi[jid], normal) if c != own]
        params += placement_parameters("joint", joint, components=comps)
    for frame in frames:
        tool = _tool_joint(robot, frame)
        if tool is None or frame in marked:
            continue
        fid = model.getFrameId(tool, pin.FrameType.FIXED_JOINT)
        pose = any(m.angle_rows and frame in m.frames for m in models)  # the frame's orientation is read
        tool_comps = [c for c in _in_plane(data.oMf[fid], normal) if pose or c.startswith("t")]
        params += placement_parameters("joint", tool, components=tool_comps)
    chosen = {robot.joint_id(j) for j in joints}
    for loop in robot.loops:
        if not _loop_support(robot, loop) & chosen:
            continue
        for side, link, origin in (("predecessor", loop.predecessor, loop.predecessor_origin),
                                   ("successor", loop.successor, loop.successor_origin)):
            anchor = _in_plane(data.oMf[model.getFrameId(link)] * origin, normal)
            params += placement_parameters("anchor", loop.name, side,
                                           COMPONENTS[:3] if loop.type == "spherical" else anchor)
    for joint in [j for j in robot.actuated_joints if j in joints] + read:
        params.append(offset_parameter(joint, joint_unit(robot, joint)))
    if external:
        params += placement_parameters("base", "base")
    clustered = clustered_frames(models) if markers == "cluster" else []
    for target in marker_targets(models):
        frame, marker = split_target(target)
        if not (marker and frame in clustered):  # a marker of a cluster moves with the cluster's placement
            params += marker_parameters(target)
    for frame in clustered:
        params += cluster_parameters(frame)
    return ParameterSet(params + camera_parameters(models))


def check_marker_fit(markers: str, models: Sequence[Measurement]) -> None:
    """Refuse (DataError) an unknown marker fit, or a ``cluster`` fit of markers without their nominal offsets:
    one rigid placement moves the markers' declared offsets together, so every marker of a cluster needs one."""
    if markers not in MARKER_FITS:
        raise DataError(f"unknown marker fit '{markers}'; marker fits are: {listing(MARKER_FITS)}")
    if markers != "cluster":
        return
    declared = {t: nominal for m in models for t, nominal in m.markers.items() if split_target(t)[1]}
    if not declared:
        raise DataError("--markers cluster fits the placement of the markers declared on a frame "
                        "(position:<frame>@<marker> columns), and the data declare none")
    missing = [t for t, nominal in declared.items() if nominal is None]
    if missing:
        frame, marker = split_target(missing[0])
        raise DataError(f"--markers cluster needs each marker's nominal offset on its frame; "
                        f"{listing(missing)} have none: add '# marker <marker> on <frame>: x y z' "
                        f"lines [m] (e.g. '# marker {marker} on {frame}: 0 0 0.05')")


def _tool_joint(robot: Robot, frame: str) -> str | None:
    """The fixed joint nearest above ``frame`` with no moving joint in between, or None."""
    model = robot.model
    f = robot.frame_id(frame)
    while f != 0:
        current = model.frames[f]
        if current.type == pin.FrameType.FIXED_JOINT:
            return str(current.name)
        if current.type == pin.FrameType.JOINT:
            return None
        f = int(current.parentFrame)
    return None


def parameter_pool(robot: Robot, models: Sequence[Measurement]) -> ParameterSet:
    """Every parameter ``--parameters`` patterns may name: all joint and anchor placements, fixed joints leading
    to measured frames, offsets of the actuated and the read joints, the base placement when positions or poses
    are measured in an external frame, the marker offsets of the measured marker targets, the cluster placement of
    each frame carrying declared markers, and the harmonics (``<joint>.sin1`` …) and compliance
    (``<joint>.compliance``) of the actuated joints that move a measured frame."""
    frames = sorted({f for m in models for f in m.frames})
    read = read_joints(models)
    external = any(m.locates_point for m in models)
    pool = candidate_parameters(robot, frames=frames, offsets=list(robot.actuated_joints) + read, base=external)
    moving = set(influencing_joints(robot, frames, read))
    corrections = [p for j in robot.actuated_joints if j in moving
                   for p in (*harmonic_parameters(j, joint_unit(robot, j)),
                             compliance_parameter(j, joint_unit(robot, j)))]
    return ParameterSet(pool.parameters + [p for t in marker_targets(models) for p in marker_parameters(t)]
                        + [p for f in clustered_frames(models) for p in cluster_parameters(f)]
                        + camera_parameters(models) + corrections)


def _names_in_short(names: Sequence[str], shown: int = 12) -> str:
    """The first ``shown`` names and how many more (a parameter pool can hold hundreds)."""
    head = listing(names[:shown])
    return head + (f" … (+{len(names) - shown} more; 'pincal calibrate … --report' lists the chosen ones)"
                   if len(names) > shown else "")


#: The word for the default set in ``--parameters`` (e.g. ``default '!base.*'``).
DEFAULT_SET = "default"


def choose_parameters(robot: Robot, models: Sequence[Measurement], spec: Sequence[str] | None = None,
                      markers: MarkerFit = "each") -> ParameterSet:
    """The unknowns from ``spec``: by default :func:`default_parameters` (``markers``: how it fits declared
    markers, ``each`` or ``cluster``); otherwise named sets (``default``,
    ``model24``, ``model24i``, ``hexapod42``, ``hexapod44``) and shell patterns over :func:`parameter_pool`,
    combined in order: a set or a pattern adds what it names, ``!pattern`` (or ``!set``) removes what it matches. A
    spec whose first word is an exclusion starts from the default set (``'!base.*' 'base.tz'``: the default set
    without the base but for its z).

    Raises:
        NotFoundError: a pattern that matches nothing (the parameters are listed), or nothing left.
    """
    if not spec:
        return default_parameters(robot, models, markers)
    check_marker_fit(markers, models)
    pool = parameter_pool(robot, models)
    chosen: list[Parameter] = list(default_parameters(robot, models, markers)) if spec[0].startswith("!") else []
    for token in spec:
        negate = token.startswith("!")
        pattern = token[1:] if negate else token
        if pattern == DEFAULT_SET or pattern in NAMED_SETS:
            named = default_parameters(robot, models, markers) if pattern == DEFAULT_SET else NAMED_SETS[pattern](robot)
            names = set(named.names)
            chosen = ([p for p in chosen if p.name not in names] if negate
                      else chosen + [p for p in named if p not in chosen])
            continue
        hits = [p for p in (chosen if negate else pool) if fnmatch.fnmatchcase(p.name, pattern)]
        if not hits and not (negate and any(fnmatch.fnmatchcase(p.name, pattern) for p in pool)):
            raise NotFoundError(f"parameter pattern '{token}' matches nothing; named sets are "
                                f"{listing([DEFAULT_SET, *NAMED_SETS])}, parameters are: {_names_in_short(pool.names)}")
        chosen = [p for p in chosen if p not in hits] if negate else chosen + [p for p in hits if p not in chosen]
    if not chosen:
        raise NotFoundError(f"the parameters {' '.join(spec)} leave no parameter to identify")
    return ParameterSet(chosen)
