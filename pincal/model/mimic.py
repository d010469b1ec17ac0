"""``<mimic>`` joints in a Pinocchio model: each follower at ``multiplier · leader + offset`` [rad or m].

Pinocchio's URDF parser builds sibling branches in the alphabetical order of their joints' names and makes a
follower a mimic joint only when its leader is already built, so a gripper whose fingers sort before their motor
(TALOS: ``gripper_left_fingertip_1_joint`` < ``gripper_left_joint``) does not load with ``mimic=True``. Here the
tree is built without mimics, rebuilt with the branches that hold a leader first where needed, and each follower
made a mimic of its leader with ``pinocchio.transformJointIntoMimic``. Nothing else changes: the joints' names,
placements, limits, bodies and frames are the file's.
"""

from __future__ import annotations

from collections.abc import Mapping

import pinocchio as pin

from pincal.errors import RobotFileError, listing


def with_mimics(model: pin.Model, mimics: Mapping[str, tuple[str, float, float]], source: str) -> pin.Model:
    """The model with each follower made a mimic of its leader.

    Args:
        model: The tree built without mimics (every joint free).
        mimics: Follower joint name -> (leader joint name, multiplier [-], offset [rad or m]).
        source: The file's name, for the errors.

    Raises:
        RobotFileError: a follower and its leader cannot both be ordered leader first (leaders in each other's
            branches).
    """
    if not mimics:
        return model
    leaders = {model.getJointId(leader) for leader, _, _ in mimics.values()}
    if any(model.getJointId(leader) > model.getJointId(name) for name, (leader, _, _) in mimics.items()):
        model = _reordered(model, leaders)
    late = [name for name, (leader, _, _) in mimics.items() if model.getJointId(leader) > model.getJointId(name)]
    if late:
        raise RobotFileError(f"{source}: mimic joint {listing(late)} cannot be built after its leader (leaders and "
                             "followers in each other's branches)")
    for name, (leader, multiplier, offset) in mimics.items():
        model = pin.transformJointIntoMimic(model, model.getJointId(leader), model.getJointId(name), multiplier,
                                            offset)
    return model


def _order(model: pin.Model, leaders: set[int]) -> list[int]:
    """Joint ids depth first from the root, a child whose branch holds a leader before its siblings."""
    order: list[int] = []
    stack = [0]
    while stack:
        joint = stack.pop()
        if joint:
            order.append(joint)
        children = [int(c) for c in model.children[joint]]
        children.sort(key=lambda c: (not leaders.intersection(int(j) for j in model.subtrees[c]), c))
        stack.extend(reversed(children))
    return order


def _reordered(model: pin.Model, leaders: set[int]) -> pin.Model:
    """The same tree, its joints added in :func:`_order`'s order; bodies and frames follow their joints."""
    out = pin.Model()
    out.name = model.name
    out.gravity = model.gravity
    new_id = {0: 0}
    for old in _order(model, leaders):
        jm = model.joints[old]
        q, v = slice(jm.idx_q, jm.idx_q + jm.nq), slice(jm.idx_v, jm.idx_v + jm.nv)
        new_id[old] = out.addJoint(
            new_id[model.parents[old]], jm, model.jointPlacements[old], model.names[old],
            model.lowerEffortLimit[v], model.upperEffortLimit[v], model.lowerVelocityLimit[v],
            model.upperVelocityLimit[v], model.lowerPositionLimit[q], model.upperPositionLimit[q],
            model.positionLimitMargin[q], model.lowerDryFrictionLimit[v], model.upperDryFrictionLimit[v],
            model.damping[v])
        out.appendBodyToJoint(new_id[old], model.inertias[old], pin.SE3.Identity())
        nv = out.joints[new_id[old]]
        out.armature[nv.idx_v:nv.idx_v + nv.nv] = model.armature[v]
        out.rotorInertia[nv.idx_v:nv.idx_v + nv.nv] = model.rotorInertia[v]
        out.rotorGearRatio[nv.idx_v:nv.idx_v + nv.nv] = model.rotorGearRatio[v]
    for frame in list(model.frames)[1:]:  # in the file's order: a frame's parent frame is added before it
        parent_frame = out.getFrameId(model.frames[frame.parentFrame].name, model.frames[frame.parentFrame].type)
        out.addFrame(pin.Frame(frame.name, new_id[frame.parentJoint], parent_frame, frame.placement, frame.type,
                               frame.inertia), False)
    return out
