"""The candidate parameters of a robot (every placement, offset and frame that could matter), the named physical
parameter sets, and a parameter vector applied to the robot model."""

from __future__ import annotations

from collections.abc import Callable, Sequence

import numpy as np
import numpy.typing as npt
import pinocchio as pin

from pincal.errors import NotFoundError, listing
from pincal.identification.parameters.kinds import JointPlacement, kinds_where
from pincal.identification.parameters.parameter import (
    COMPONENTS,
    ParameterSet,
    marker_parameters,
    offset_parameter,
    placement_parameters,
)
from pincal.model.jacobians import joint_jacobian
from pincal.model.robot import Robot, joint_unit

Array = npt.NDArray[np.float64]


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
        col = joint_jacobian(model, data, jid, pin.LOCAL_WORLD_ALIGNED)[:, joint.idx_v]
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
    params = []
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
    for (kind, owner, side), idx in pset.groups(*kinds_where(kinematic=True)).items():
        exp = pin.exp6(pset.placement_delta(x, idx))
        if kind == JointPlacement.name:
            if model.existJointName(owner):
                jid = model.getJointId(owner)
                model.jointPlacements[jid] = model.jointPlacements[jid] * exp
            else:
                move_fixed_joint(model, owner, exp)
        else:
            loop = loops[owner]
            pred, succ = loop.predecessor_origin, loop.successor_origin
            if side == "predecessor":
                pred = pred * exp
            else:
                succ = succ * exp
            loops[owner] = loop.with_origins(pred, succ)
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

