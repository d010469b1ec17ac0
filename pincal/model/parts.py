"""A robot's independent parts: its loops grouped into blocks no joint couples, each on a model of its own joints.

A loop's **support** is the set of joints that move one of its anchors: those on the path from the root to either
anchor's link. Two loops whose supports share a joint are coupled; the loops fall into **blocks** (the connected
groups of that relation), and the closure Jacobian ``dc/dv`` is block diagonal: a block's rows are zero outside its
support's columns. Each block is then closed, checked and ranked alone, on a model of its support's joints and
frames only (the other joints left out: none of them moves the block), and the robot's figures are the
blocks' together: the residual rows side by side, the closure rank their sum (a block-diagonal matrix's singular
values are its blocks'). The same holds for the frames a command reads: the part that moves a frame is its own
support with the blocks that support touches.

Why: Pinocchio's working data (``pinocchio.Data``) hold four second-derivative tensors of nv³ numbers, 250 MB for 198
velocities of 66 four-bars on one base, whose blocks have 3 each. What a robot of independent loops costs to load,
assemble and describe then grows with its loops, not with their cube. A robot of one block (a Delta, a hexapod: every
loop closes on the platform) or with ``<mimic>`` joints (a follower moves with a leader the support may not hold) is
one part, the robot itself, and is computed as before.
"""

from __future__ import annotations

import functools
from collections.abc import Sequence
from typing import Generic, Protocol, Self, TypeVar

import numpy as np
import numpy.typing as npt
import pinocchio as pin

from pincal.model.urdf import LoopSpec
from pincal.records import record

IntArray = npt.NDArray[np.intp]


class Whole(Protocol):
    """What :class:`RobotParts` reads of a robot, and how it makes a robot of some of its joints. A
    :class:`~pincal.model.robot.Robot` is one; this module builds on no robot type, so that a robot can hold its parts.
    """

    @property
    def model(self) -> pin.Model:
        """The Pinocchio model of the cut tree."""

    @property
    def loops(self) -> list[LoopSpec]:
        """The loop declarations, anchors in link frames [m, rad]."""

    @property
    def actuated_joints(self) -> list[str]:
        """The names of the actuated joints."""

    def reduced(self, model: pin.Model, loops: list[LoopSpec], actuated_joints: list[str]) -> Self:
        """A robot of the same kind on a reduced model of its joints, with those of its loops and actuated joints."""


W = TypeVar("W", bound=Whole)


def joint_support(model: pin.Model, joint: int) -> frozenset[int]:
    """The joints (ids) on the path from the root to ``joint``, ``joint`` included, the root (0) not."""
    out: set[int] = set()
    while joint:
        out.add(joint)
        joint = int(model.parents[joint])
    return frozenset(out)


def loop_support(model: pin.Model, loop: LoopSpec) -> frozenset[int]:
    """The joints that move either anchor of ``loop`` (a link the model lacks moves nothing here: the closure
    names it in its own error)."""
    out: set[int] = set()
    for link in (loop.predecessor, loop.successor):
        if model.existFrame(link):
            out |= joint_support(model, int(model.frames[model.getFrameId(link)].parentJoint))
    return frozenset(out)


def independent_blocks(model: pin.Model, loops: Sequence[LoopSpec]) -> list[tuple[int, ...]]:
    """The loops (indices into ``loops``) grouped so that no joint moves loops of two groups: each group in file
    order, the groups in the order of their first loop."""
    parent = list(range(len(loops)))

    def root(k: int) -> int:
        while parent[k] != k:
            parent[k] = parent[parent[k]]
            k = parent[k]
        return k

    owner: dict[int, int] = {}  # joint -> a loop whose support holds it
    for k, loop in enumerate(loops):
        for joint in loop_support(model, loop):
            if joint in owner:
                a, b = root(owner[joint]), root(k)
                parent[max(a, b)] = min(a, b)
            else:
                owner[joint] = k
    groups: dict[int, list[int]] = {}
    for k in range(len(loops)):
        groups.setdefault(root(k), []).append(k)
    return [tuple(group) for group in groups.values()]


def has_mimic_joints(model: pin.Model) -> bool:
    """Whether a joint of ``model`` follows another (``<mimic>``)."""
    return any(model.joints[j].shortname().startswith("JointModelMimic") for j in range(1, model.njoints))


@record(frozen=True)
class ReducedModel:
    """The model of some joints of a robot and of their frames, the other joints left out.

    Attributes:
        model: The reduced model (the robot's own model when every joint is kept).
        joints: The kept joints' ids in the robot's model, in its order (the reduced model's order).
        q_index: For each coordinate of the reduced model's configuration, its index in the robot's (nq_part,).
        v_index: The same for the velocities (nv_part,).
        whole: Whether every joint is kept (``model`` is the robot's).
    """

    model: pin.Model
    joints: tuple[int, ...]
    q_index: IntArray
    v_index: IntArray
    whole: bool


def frames_by_joint(model: pin.Model) -> dict[int, list[int]]:
    """Each joint's frames (ids, in the model's order), the root's (0) included."""
    out: dict[int, list[int]] = {}
    for fid, frame in enumerate(model.frames):
        out.setdefault(int(frame.parentJoint), []).append(fid)
    return out


def reduced_model(model: pin.Model, joints: frozenset[int],
                  frames: dict[int, list[int]] | None = None) -> ReducedModel:
    """The model of ``joints`` (a set closed towards the root: every kept joint's parent is kept) and of the frames
    they and the root carry, the other joints and their frames left out (nothing kept hangs below them). Built joint by
    joint, as Pinocchio's ``buildReducedModel`` would but without copying every frame of the robot into every block.

    Args:
        model: The robot's model.
        joints: The joints to keep (ids).
        frames: :func:`frames_by_joint` of ``model``, when already known.
    """
    kept = tuple(sorted(joints))
    if len(kept) == model.njoints - 1:
        return ReducedModel(model, kept, np.arange(model.nq), np.arange(model.nv), True)
    frames = frames_by_joint(model) if frames is None else frames
    out = pin.Model()
    out.name = model.name
    new_joint = {0: 0}
    for old in kept:
        jm = model.joints[old]
        q, v = slice(jm.idx_q, jm.idx_q + jm.nq), slice(jm.idx_v, jm.idx_v + jm.nv)
        new_joint[old] = out.addJoint(
            new_joint[int(model.parents[old])], jm, model.jointPlacements[old], model.names[old],
            model.lowerEffortLimit[v], model.upperEffortLimit[v], model.lowerVelocityLimit[v],
            model.upperVelocityLimit[v], model.lowerPositionLimit[q], model.upperPositionLimit[q],
            model.positionLimitMargin[q], model.lowerDryFrictionLimit[v], model.upperDryFrictionLimit[v],
            model.damping[v])
        out.appendBodyToJoint(new_joint[old], model.inertias[old], pin.SE3.Identity())
    new_frame = {0: 0}
    for fid in sorted(f for joint in (0, *kept) for f in frames.get(joint, []) if f):  # a parent frame comes first
        frame = model.frames[fid]
        new_frame[fid] = out.addFrame(pin.Frame(frame.name, new_joint[int(frame.parentJoint)],
                                                new_frame[int(frame.parentFrame)], frame.placement, frame.type,
                                                frame.inertia), False)
    q_index = [i for j in kept for i in range(model.joints[j].idx_q, model.joints[j].idx_q + model.joints[j].nq)]
    v_index = [i for j in kept for i in range(model.joints[j].idx_v, model.joints[j].idx_v + model.joints[j].nv)]
    return ReducedModel(out, kept, np.array(q_index, dtype=np.intp), np.array(v_index, dtype=np.intp), False)


@record(frozen=True)
class Part(Generic[W]):
    """Some of a robot's joints with the loops they close, as a robot of its own.

    Attributes:
        robot: The part as a robot of the whole's kind (a :class:`~pincal.model.robot.Robot`: its reduced model, its
            loops, the actuated joints it holds); the robot itself when the part is all of it.
        loops: The part's loops as indices into the robot's ``loops``, in the part robot's order.
        q_index: Where each coordinate of the part's configuration sits in the robot's.
        v_index: The same for the velocities.
        whole: Whether the part is the whole robot.
    """

    robot: W
    loops: tuple[int, ...]
    q_index: IntArray
    v_index: IntArray
    whole: bool


class RobotParts(Generic[W]):
    """A robot's independent loop blocks and the part that moves given frames (module docstring).

    Args:
        robot: The robot.
    """

    def __init__(self, robot: W) -> None:
        self.robot = robot
        model = robot.model
        self._supports = {k: loop_support(model, loop) for k, loop in enumerate(robot.loops)}
        groups = independent_blocks(model, robot.loops) if robot.loops else []
        self.split = len(groups) > 1 and not has_mimic_joints(model)
        self._groups = groups if self.split else [tuple(range(len(robot.loops)))]
        self._cache: dict[frozenset[int], Part[W]] = {}
        self._frames = frames_by_joint(model)

    @functools.cached_property
    def blocks(self) -> list[Part[W]]:
        """One part per block of loops, in the order of their first loop; the robot itself when its loops are one
        block (or it has none, or has mimic joints)."""
        if not self.split:
            return [self._part(frozenset(range(1, self.robot.model.njoints)))]
        return [self._part(frozenset().union(*(self._supports[k] for k in group))) for group in self._groups]

    def moving(self, frames: Sequence[int]) -> Part[W]:
        """The part that moves the frames ``frames`` (ids): their supports and the blocks they touch."""
        model = self.robot.model
        if not self.split:
            return self._part(frozenset(range(1, model.njoints)))
        joints: set[int] = set()
        for fid in frames:
            joints |= joint_support(model, int(model.frames[fid].parentJoint))
        for group in self._groups:
            support = frozenset().union(*(self._supports[k] for k in group))
            if support & joints:
                joints |= support
        return self._part(frozenset(joints))

    def by_part(self, frames: Sequence[int]) -> list[tuple[Part[W], list[int]]]:
        """The frames (ids) grouped by the blocks that move them: each group's part and its frames' positions in
        ``frames``, the groups in the order of their first frame."""
        if not self.split:
            return [(self.moving(frames), list(range(len(frames))))]
        model = self.robot.model
        touched: dict[tuple[int, ...], list[int]] = {}
        for position, fid in enumerate(frames):
            support = joint_support(model, int(model.frames[fid].parentJoint))
            key = tuple(b for b, group in enumerate(self._groups)
                        if any(self._supports[k] & support for k in group))
            touched.setdefault(key, []).append(position)  # () for the frames no loop moves: one part
        return [(self.moving([frames[p] for p in positions]), positions) for positions in touched.values()]

    def _part(self, joints: frozenset[int]) -> Part[W]:
        """The part of the joints ``joints`` (closed towards the root and under the blocks), made once (threads that
        make it at the same time all keep the first one stored)."""
        held = self._cache.get(joints)
        if held is None:
            robot = self.robot
            reduced = reduced_model(robot.model, joints, self._frames)
            loops = tuple(k for k, support in self._supports.items() if support <= joints)
            if reduced.whole:
                part_robot = robot
            else:
                actuated = [name for name in robot.actuated_joints if robot.model.getJointId(name) in joints]
                part_robot = robot.reduced(reduced.model, [robot.loops[k] for k in loops], actuated)
            held = self._cache.setdefault(joints, Part(part_robot, loops, reduced.q_index, reduced.v_index,
                                                       reduced.whole))
        return held
