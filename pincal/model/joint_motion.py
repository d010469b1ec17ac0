"""How a joint of one coordinate moves, read from Pinocchio once: the building block of the batched kinematics.

A joint of one coordinate (revolute, continuous, prismatic, aligned with an axis or not) or a ``<mimic>`` follower of
one moves as ``start · exp6(ξ v)``: ``start`` its motion at v = 0 (the identity but for a follower's offset), ξ its
motion per unit value of its source joint. Batched forward kinematics (:mod:`pincal.model.batch_kinematics`,
:mod:`pincal.identification.tree_batch`) evaluates every sample with one array operation per joint from this.
"""

from __future__ import annotations

from dataclasses import field

import numpy as np
import numpy.typing as npt
import pinocchio as pin

from pincal.records import record

Array = npt.NDArray[np.float64]

#: Largest gap [m, rad] between a joint's motion from Pinocchio and ``start · exp6(ξ v)`` at a test value for the
#: batched forward kinematics to take that joint.
MOTION_TOLERANCE = 1e-12
#: The test values [rad or m] of a joint's coordinate at which its motion is read and checked.
TEST_VALUES = (0.5, -1.3, 2.1)


@record(frozen=True)
class JointMotion:
    """How a joint with one coordinate moves: ``start · exp6(ξ v)``, v the value of joint ``source`` (the joint
    itself, or the leader of a ``<mimic>`` follower, whose scaling is in ξ and offset in ``start``).

    Attributes:
        joint: The joint's Pinocchio id.
        source: The id of the joint whose coordinate v drives it.
        start: Its motion at v = 0 (the identity but for a follower's offset).
        twist: (6,) ξ, its motion per unit v in its own frame [m or rad per rad or m].
    """

    joint: int
    source: int
    start: pin.SE3
    twist: Array
    #: True for a rotation about an axis through the joint's origin, False for a translation.
    revolute: bool = field(init=False)
    #: ``‖ξ‖``: the angle [rad] or distance [m] it moves per unit value of its source.
    rate: float = field(init=False)

    def __post_init__(self) -> None:
        revolute = bool(np.any(self.twist[3:] != 0.0))
        object.__setattr__(self, "revolute", revolute)
        object.__setattr__(self, "rate", float(np.linalg.norm(self.twist[3:] if revolute else self.twist[:3])))

    @property
    def turn(self) -> pin.SE3:
        """A rotation Q taking z to the motion's axis: in the joint's frame turned by Q the motion is about (along)
        z, ``exp6(ξ v) Q = Q exp6(rate · v · e_z)``."""
        direction = self.twist[3:] if self.revolute else self.twist[:3]
        turn = pin.Quaternion.FromTwoVectors(np.array([0.0, 0.0, 1.0]), direction / self.rate).matrix()
        return pin.SE3(turn, np.zeros(3))


def joint_value(model: pin.Model, joint: int, q: Array) -> Array:
    """(N,) the value [rad or m] of a joint with one coordinate in configurations ``q`` (N, nq) (a continuous
    joint's angle from its cos, sin)."""
    jm = model.joints[joint]
    value: Array = q[:, jm.idx_q] if jm.nq == 1 else np.arctan2(q[:, jm.idx_q + 1], q[:, jm.idx_q])
    return value


def joint_motion(model: pin.Model, joint: int) -> JointMotion | None:
    """The motion of ``joint`` read from Pinocchio (its transform at test values), None if it is not one this
    module evaluates: a joint of one coordinate, or a ``<mimic>`` follower of one, rotating about or sliding along
    a fixed axis."""
    jm = model.joints[joint]
    source = joint
    if jm.shortname() == "JointModelMimic":
        followers = list(model.mimicking_joints)
        source = int(model.mimicked_joints[followers.index(joint)]) if joint in followers else 0
    leader = model.joints[source]
    if source == 0 or leader.nv != 1 or leader.nq not in (1, 2):
        return None
    data = jm.createData()

    def transform(value: float) -> pin.SE3:
        q = pin.neutral(model)
        if leader.nq == 1:
            q[leader.idx_q] = value
        else:
            q[leader.idx_q:leader.idx_q + 2] = np.cos(value), np.sin(value)
        jm.calc(data, q)
        return pin.SE3(data.M)

    start = transform(0.0)
    twist = pin.log6(start.inverse() * transform(TEST_VALUES[0])).vector / TEST_VALUES[0]
    if np.abs(twist[:3]).max() > MOTION_TOLERANCE and np.abs(twist[3:]).max() > MOTION_TOLERANCE:
        return None  # a screw motion
    twist[np.abs(twist) <= MOTION_TOLERANCE] = 0.0
    for value in TEST_VALUES[1:]:
        gap = pin.log6((start * pin.exp6(twist * value)).inverse() * transform(value)).vector
        if np.abs(gap).max() > MOTION_TOLERANCE:
            return None
    return JointMotion(joint, source, start, twist)
