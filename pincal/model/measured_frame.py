"""Which frame a robot's measurements see by default: a frame the actuated joints move.

A frame named like an end effector (:data:`END_EFFECTOR_NAMES`) is taken first, if it moves. Otherwise the default
is the one link frame that the actuated joints move and below which, in the kinematic tree of the file
(the loops cut), no link moves: the end of the one moving branch. A parallel robot's tree ends in each leg and in
the platform; there the moving link on which every loop closes is the platform, whatever its name. A robot with
several ends and no such link (an arm with two fingers) is measured at the one frame whose name says end effector or
tool (Kinova's ``j2s6s200_end_effector``, above its fingers) when its branch holds the only such frames; otherwise (a
two-armed robot, a tool frame on each arm) it has no obvious choice, and none is made: the measured frame must be
named. A frame the actuated joints do not move is never chosen: measuring it identifies nothing but the measurement
frame.

"Moved" is tested on the twist of the frame per unit actuated velocity, through the loops
(:meth:`~pincal.model.kinematics.ClosedLoopKinematics.configuration_jacobian`), at the reference
configuration and at a nearby assembled one (a frame can stand still at one singular posture).
"""

from __future__ import annotations

import itertools
import re
from typing import Protocol, Self

import numpy as np
import numpy.typing as npt
import pinocchio as pin

from pincal.errors import NotFoundError, listing
from pincal.model.jacobians import frame_jacobian
from pincal.model.kinematics import ClosedLoopKinematics, SolveReport
from pincal.model.parts import RobotParts, Whole
from pincal.records import record

Array = npt.NDArray[np.float64]


class Robot(Whole, Protocol):
    """What the rules of this module read of a robot, besides what its parts read (:class:`Whole`). A
    :class:`pincal.model.robot.Robot` is one, and holds its choice
    (:attr:`~pincal.model.robot.Robot.measured_frame_choice`); this module builds on no robot type."""

    @property
    def name(self) -> str:
        """The robot's name."""

    @property
    def n_actuated(self) -> int:
        """The number of actuated joints."""

    @property
    def q_reference(self) -> Array:
        """The reference configuration."""

    @property
    def kinematics(self) -> ClosedLoopKinematics:
        """The closed-loop kinematics."""

    @property
    def parts(self) -> RobotParts[Self]:
        """The independent loop blocks."""

    def frame_id(self, frame: str) -> int:
        """The Pinocchio id of a frame."""

    def actuated_values(self, q: Array) -> Array:
        """The actuated joint values in ``q`` [rad or m]."""

    def solve_fk_report(self, q_actuated: Array) -> SolveReport:
        """The closed-loop FK at the actuated values ``q_actuated`` [rad or m], reported rather than raised."""

#: Names tried, in order, for the default measured frame before any motion test.
END_EFFECTOR_NAMES = ("end_effector", "tool0", "panda_hand", "arm_tool_link", "ee_link")
#: Words of a frame's name that say it is an end effector or a tool (:func:`named_like_a_tool`).
TOOL_WORDS = frozenset({"endeffector", "ee", "eef", "tool", "tcp"})
#: Smallest twist per unit actuated velocity [m/rad, rad/rad, m/m, rad/m] of a frame that moves.
MOTION_TOLERANCE = 1e-9
#: Actuated step [rad or m] from the reference to the second posture the motion is tested at.
MOTION_STEP = 0.01


@record(frozen=True)
class FrameChoice:
    """The default measured frame of a robot, or why there is none.

    Attributes:
        frame: The chosen frame; None when no frame is obvious.
        rule: ``named`` (a name from :data:`END_EFFECTOR_NAMES`), ``moving end`` (the one moving link with
            no moving link below it), ``platform`` (the moving link every loop closes on), ``named like`` (the one
            frame named like an end effector or a tool at a branch's end: :func:`tool_frames`) or ``none``.
        candidates: The moving links with no moving link below them.
        reason: Why no frame was chosen (empty when one was).
    """

    frame: str | None
    rule: str
    candidates: tuple[str, ...] = ()
    reason: str = ""

    @property
    def why(self) -> str:
        """The rule that chose the frame, in words (empty when none was chosen)."""
        return {"named": "named like an end effector", "moving end": "the one moving link with none below it",
                "platform": "the link every loop closes on: the platform",
                "named like": "the one frame named like an end effector or a tool"}.get(self.rule, "")

    def error(self) -> NotFoundError:
        """The refusal as an error that carries the candidates (``choices``)."""
        return NotFoundError(self.reason, "frame", "", self.candidates)


def probe_postures(robot: Robot, order: list[int] | None = None) -> list[Array]:
    """The reference configuration and, when it can be assembled, one a step of :data:`MOTION_STEP` away
    in every actuated joint (towards the inside of the joint limits). ``order``: each actuated joint's position in
    the whole robot, when ``robot`` is a part of it (:mod:`pincal.model.parts`), so that a joint takes the same step
    in either."""
    postures = [robot.q_reference]
    model = robot.model
    qa = robot.actuated_values(robot.q_reference)
    step = np.empty_like(qa)
    for k, joint in enumerate(robot.kinematics.actuated):
        upper = model.upperPositionLimit[joint.idx_q] if joint.nq == 1 else np.inf
        sign = -1.0 if qa[k] + MOTION_STEP > upper else 1.0
        index = k if order is None else order[k]
        step[k] = sign * MOTION_STEP * (1.0 + 0.1 * index)  # unequal steps: no symmetric special posture
    report = robot.solve_fk_report(qa + step)
    if report.converged:
        postures.append(report.q)
    return postures


def frame_motion(robot: Robot, frame_ids: list[int]) -> Array:
    """Largest norm, over :func:`probe_postures`, of each frame's twist per unit actuated velocity (6 × na), each
    frame computed on the part of the robot that moves it (:mod:`pincal.model.parts`)."""
    motion = np.zeros(len(frame_ids))
    frames = robot.model.frames
    moved = [p for p, fid in enumerate(frame_ids) if frames[fid].parentJoint != 0]  # no joint moves the others
    for part, group in robot.parts.by_part([frame_ids[p] for p in moved]):
        positions = [moved[k] for k in group]
        if not positions:
            continue
        if part.whole:
            motion[positions] = _frame_motion(robot, [frame_ids[p] for p in positions])
            continue
        sub = part.robot
        ids = [int(sub.model.getFrameId(frames[frame_ids[p]].name, frames[frame_ids[p]].type)) for p in positions]
        position_of = {name: k for k, name in enumerate(robot.actuated_joints)}
        order = [position_of[name] for name in sub.actuated_joints]
        motion[positions] = _frame_motion(sub, ids, order)
    return motion


def _frame_motion(robot: Robot, frame_ids: list[int], order: list[int] | None = None) -> Array:
    model, data = robot.model, robot.kinematics.data
    motion = np.zeros(len(frame_ids))
    for q in probe_postures(robot, order):
        tangent = robot.kinematics.configuration_jacobian(q)
        pin.computeJointJacobians(model, data, q)
        for k, fid in enumerate(frame_ids):
            twist = frame_jacobian(model, data, fid, pin.LOCAL_WORLD_ALIGNED) @ tangent
            motion[k] = max(motion[k], float(np.linalg.norm(twist)))
    return motion


def frame_moves(robot: Robot, frame: str) -> bool:
    """Whether the actuated joints move ``frame`` (see the module's docstring)."""
    return bool(frame_motion(robot, [robot.frame_id(frame)])[0] > MOTION_TOLERANCE)


def _ancestors(model: pin.Model, fid: int) -> set[int]:
    out: set[int] = set()
    while fid != 0 and model.frames[fid].parentFrame != fid:
        fid = int(model.frames[fid].parentFrame)
        out.add(fid)
    return out


def moving_ends(robot: Robot) -> list[str]:
    """The link frames the actuated joints move and below which no moving link hangs, in model order."""
    model = robot.model
    links = [fid for fid, f in enumerate(model.frames) if f.type == pin.FrameType.BODY]
    if not links or robot.n_actuated == 0:
        return []
    moving = [fid for fid, m in zip(links, frame_motion(robot, links), strict=True) if m > MOTION_TOLERANCE]
    above: set[int] = set()
    for fid in moving:
        above |= _ancestors(model, fid)
    return [str(model.frames[fid].name) for fid in moving if fid not in above]


def loops_platform(robot: Robot) -> str | None:
    """The one link every loop closes on (as predecessor or successor) when the actuated joints move it: a parallel
    robot's platform, whatever its name; None for a robot without loops, or without such a link."""
    if not robot.loops:
        return None
    common = set.intersection(*({loop.predecessor, loop.successor} for loop in robot.loops))
    if len(common) != 1:
        return None
    link = common.pop()
    return link if frame_moves(robot, link) else None


def named_like_a_tool(name: str) -> bool:
    """Whether a frame's name says it is an end effector or a tool: one of its words (split at underscores, digits
    and case changes) is one of :data:`TOOL_WORDS`, or two are ``end effector``
    (``j2s6s200_end_effector``, ``wrist_left_ft_tool_link``, ``EE``, ``link_eef``)."""
    words = [word.lower() for word in re.findall(r"[A-Z]+(?![a-z])|[A-Z]?[a-z]+", name)]
    return bool(TOOL_WORDS.intersection(words)) or ("end", "effector") in itertools.pairwise(words)


def tool_frames(robot: Robot) -> list[str]:
    """The link and operational frames named like an end effector or a tool (:func:`named_like_a_tool`) that the
    actuated joints move, each the last of such frames on its branch, in model order."""
    model = robot.model
    named = [fid for fid, frame in enumerate(model.frames)
             if frame.type in (pin.FrameType.BODY, pin.FrameType.OP_FRAME) and named_like_a_tool(str(frame.name))]
    if not named or robot.n_actuated == 0:
        return []
    moving = [fid for fid, m in zip(named, frame_motion(robot, named), strict=True) if m > MOTION_TOLERANCE]
    above: set[int] = set()
    for fid in moving:
        above |= _ancestors(model, fid)
    return [str(model.frames[fid].name) for fid in moving if fid not in above]


def default_measured_frame(robot: Robot) -> FrameChoice:
    """The frame measured when none is named: the first name of :data:`END_EFFECTOR_NAMES` that the actuated
    joints move, else the one moving end of the tree (:func:`moving_ends`), else the link every loop closes on
    (:func:`loops_platform`), else the one branch's last frame named like an end effector or a tool
    (:func:`tool_frames`: Kinova's ``j2s6s200_end_effector``); no choice when there are several ends and no such
    link or frame (a two-armed robot: one tool frame on each arm), or no end."""
    still = []
    for name in END_EFFECTOR_NAMES:
        if robot.model.existFrame(name):
            if frame_moves(robot, name):
                return FrameChoice(name, "named")
            still.append(name)
    ends = tuple(moving_ends(robot))
    if len(ends) == 1:
        return FrameChoice(ends[0], "moving end", ends)
    platform = loops_platform(robot)
    if platform is not None:
        return FrameChoice(platform, "platform", ends)
    tools = tool_frames(robot) if ends else []
    if len(tools) == 1:
        return FrameChoice(tools[0], "named like", ends)
    if len(tools) > 1:
        return FrameChoice(None, "none", ends, f"robot '{robot.name}' has {len(tools)} frames named like an end "
                                               f"effector or a tool, on different branches: {listing(tools)}; none "
                                               "of them is the obvious measured frame: name it (--frame, or the "
                                               "frame in the measurement keys)")
    if still:
        named = f"robot '{robot.name}': its actuated joints do not move {listing(still)} (named like an end effector)"
    else:
        named = f"robot '{robot.name}' has no frame named like an end effector ({listing(END_EFFECTOR_NAMES)})"
    if not ends:
        rest = "they move none of its links" if still else "its actuated joints move none of its links"
        return FrameChoice(None, "none", ends, f"{named}, and {rest}: there is no frame to measure by default")
    return FrameChoice(None, "none", ends, f"{named}; {len(ends)} moving links have no moving link below them: "
                                           f"{listing(ends)}; none of them is the obvious measured frame: name it "
                                           "(--frame, or the frame in the measurement keys)")
