"""The default parameter set, minimal by construction, the pool ``--parameters`` patterns choose from, and the
choice itself: what the measurements read decides which parameters exist (each model says which frames, markers,
cameras, targets and joints it reads)."""

from __future__ import annotations

import fnmatch
from collections.abc import Sequence

import numpy as np
import numpy.typing as npt
import pinocchio as pin

from pincal.errors import DataError, NotFoundError, listing
from pincal.identification.choices import MARKER_FITS, MarkerFit
from pincal.identification.measurements import Measurement, split_target
from pincal.identification.parameters.candidates import (
    NAMED_SETS,
    _in_plane,
    candidate_parameters,
    planar_normal,
)
from pincal.identification.parameters.kinds import CameraIntrinsics, CameraPlacement, parameter_kind
from pincal.identification.parameters.parameter import (
    AXES,
    COMPONENTS,
    Parameter,
    ParameterSet,
    cluster_parameters,
    compliance_parameter,
    harmonic_parameters,
    intrinsics_parameters,
    marker_parameters,
    offset_parameter,
    placement_parameters,
)
from pincal.model.jacobians import joint_jacobian
from pincal.model.robot import Robot, joint_unit
from pincal.model.urdf import LoopSpec

Array = npt.NDArray[np.float64]



def camera_parameters(models: Sequence[Measurement]) -> list[Parameter]:
    """The unknown placements the cameras bring (each model's ``attachments``): each eye-in-hand camera on its frame
    (``camera.<frame>.*``), the world target they see (``target.*``; its translation only when every camera sees a
    point), and each pose target on a frame (``target.<frame>@<target>.*``, eye-to-hand)."""
    components: dict[tuple[str, str], set[str]] = {}
    for m in models:
        for a in m.attachments:
            components.setdefault((a.kind, a.owner), set()).update(a.components)
    order = sorted(components, key=lambda name: (name[0] == CameraIntrinsics.name, name[0] != "camera",
                                                 name[1] != "", name[1]))
    return [p for kind, owner in order
            for p in (intrinsics_parameters(owner) if kind == CameraIntrinsics.name else
                      placement_parameters(kind, owner, components=[c for c in COMPONENTS
                                                                    if c in components[(kind, owner)]]))]


def sees_world_target(models: Sequence[Measurement]) -> bool:
    """Whether the measurements see the world frame only through a placement fixed in it, of a kind that says so
    (:attr:`~pincal.identification.parameters.ParameterKind.world_anchor`: a target an eye-in-hand camera sees, a
    plugin's plane a sensor reads), as an external measurement frame is seen through ``base.*``."""
    return any(not a.owner and parameter_kind(a.kind).world_anchor for m in models for a in m.attachments)


def marker_keys(models: Sequence[Measurement]) -> list[str]:
    """The points the measurements read on frames (``<frame>`` or ``<frame>@<marker>``: each a position's
    :attr:`~pincal.identification.measurements.Position.marker_key`), sorted."""
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
    frames |= {a.owner if a.kind == CameraPlacement.name else split_target(a.owner)[0]
               for m in models for a in m.attachments if a.owner}
    return sorted(frames)


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


def _own_motion(robot: Robot, joint: str, data: pin.Data) -> str | None:
    """The placement component that duplicates a one-DOF joint's own motion (rotation about a revolute axis
    along x, y or z of the joint frame is a change of its angle; translation along a prismatic axis, of its
    position), or None (an axis not along x, y or z, a mimic follower, a multi-DOF joint). ``data`` holds the
    joint Jacobians at the reference (``pin.computeJointJacobians``): one for all joints, as a long chain's data
    take seconds to make."""
    model = robot.model
    jid = robot.joint_id(joint)
    if model.joints[jid].nv != 1:
        return None
    twist = joint_jacobian(model, data, jid, pin.LOCAL)[:, model.joints[jid].idx_v]
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
      offset (``marker.<key>.*``) for each marker key whose position is measured (``<frame>``, and each
      declared marker ``<frame>@<marker>``); with ``markers="cluster"``, the declared markers of a frame get one
      cluster placement (``cluster.<frame>.*``) instead, and need their nominal offsets (:func:`check_marker_fit`);
    - the cameras and targets (:func:`camera_parameters`); a world target seen by an eye-in-hand camera leaves the
      first joint's placement out as an estimated measurement frame does.
    """
    check_marker_fit(markers, models)
    frames = sorted({f for m in models for f in m.frames})
    read = read_joints(models)
    external = any(m.in_measurement_frame for m in models)
    marked = _estimated_on_frames(models)
    joints = influencing_joints(robot, frames, read)
    model = robot.model
    normal = planar_normal(robot)
    data = model.createData()
    pin.framesForwardKinematics(model, data, robot.q_reference)
    pin.computeJointJacobians(model, data, robot.q_reference)
    firsts = [j for j in joints if model.parents[robot.joint_id(j)] == 0]
    params: list[Parameter] = []
    for joint in joints:
        if (external or sees_world_target(models)) and firsts == [joint]:
            continue  # one chain from the root: its first placement and the base (or world target) are one and the same
        jid = robot.joint_id(joint)
        own = _own_motion(robot, joint, data)
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
    for key in marker_keys(models):
        frame, marker = split_target(key)
        if not (marker and frame in clustered):  # a marker of a cluster moves with the cluster's placement
            params += marker_parameters(key)
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
        raise DataError("markers='cluster' fits the placement of the markers declared on a frame "
                        "(position:<frame>@<marker> columns), and the data declare none", option="markers")
    missing = [t for t, nominal in declared.items() if nominal is None]
    if missing:
        frame, marker = split_target(missing[0])
        raise DataError(f"markers='cluster' needs each marker's nominal offset on its frame; "
                        f"{listing(missing)} have none: add '# marker <marker> on <frame>: x y z' "
                        f"lines [m] (e.g. '# marker {marker} on {frame}: 0 0 0.05')", option="markers")


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
    are measured in an external frame, the marker offsets of the measured marker keys, the cluster placement of
    each frame carrying declared markers, and the harmonics (``<joint>.sin1`` …) and compliance
    (``<joint>.compliance``) of the actuated joints that move a measured frame."""
    frames = sorted({f for m in models for f in m.frames})
    read = read_joints(models)
    external = any(m.in_measurement_frame for m in models)
    pool = candidate_parameters(robot, frames=frames, offsets=list(robot.actuated_joints) + read, base=external)
    moving = set(influencing_joints(robot, frames, read))
    corrections = [p for j in robot.actuated_joints if j in moving
                   for p in (*harmonic_parameters(j, joint_unit(robot, j)),
                             compliance_parameter(j, joint_unit(robot, j)))]
    return ParameterSet(pool.parameters + [p for key in marker_keys(models) for p in marker_parameters(key)]
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
