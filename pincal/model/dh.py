"""A serial chain of a URDF as a Denavit–Hartenberg table: classic (``dh``) or modified, Craig's (``mdh``).

The chain runs from a base frame to an end frame through one-coordinate joints (revolute, continuous,
prismatic). Each joint's axis, read from Pinocchio at the all-zero configuration, is a line in the base frame
(a prismatic joint's line passes through its joint frame's origin). Frames are put on those lines:

- frame 0 on the first axis, at the foot of the perpendicular from the base origin, its x the base's x made
  perpendicular to the axis (the base's y when the base's x is along it);
- between consecutive axes, their common normal: ``dh`` puts frame k on axis k + 1 where the normal meets it,
  ``mdh`` puts it on axis k; x along the normal, from axis k to axis k + 1 (``z_k × z_{k+1}`` when they meet);
- axes parallel within :data:`PARALLEL` [rad] have no unique common normal: it is taken through the previous
  frame's foot (``d = 0``, the textbook choice); axes coincident, x is kept. Axes nearly parallel beyond that
  angle (a calibrated arm's nominally parallel axes) have a unique normal, as far off as the axes' distance over
  their angle: the table stays exact, with large ``d`` values of opposite signs (:attr:`DHTable.near_parallel`
  names them; DH is not proportional there, which Hayati's extra parameter, in no plain DH table, would avoid);
- the last frame on the last axis, at the foot of the perpendicular from the end frame's origin, its x the end
  frame's x made perpendicular to the axis.

Then ``end(q) = base · A_1(q_1) ⋯ A_n(q_n) · tool`` in the base frame, with

- ``dh``:  ``A_i = Rz(θ_i) · Tz(d_i) · Tx(a_i) · Rx(α_i)``,
- ``mdh``: ``A_i = Rx(α_{i-1}) · Tx(a_{i-1}) · Rz(θ_i) · Tz(d_i)`` (a row holds α_{i-1}, a_{i-1}, θ_i, d_i),

``θ_i = theta + q_i`` for a revolute joint, ``d_i = d + q_i`` for a prismatic one (the joint's own sense:
z is its axis as the URDF orients it). :func:`conversion_residual` measures how far that is from Pinocchio's
forward kinematics of the URDF. Lengths [m], angles [rad].
"""

from __future__ import annotations

import itertools
import math
from typing import Literal

import numpy as np
import numpy.typing as npt
import pinocchio as pin

from pincal.errors import DataError, NotFoundError, RobotFileError, listing
from pincal.model.jacobians import joint_jacobian
from pincal.model.robot import Robot
from pincal.records import record

Array = npt.NDArray[np.float64]
Convention = Literal["dh", "mdh", "hayati"]
CONVENTIONS: tuple[Convention, ...] = ("dh", "mdh", "hayati")

#: Consecutive axes closer to parallel than this [rad] are taken as parallel (common normal through the previous
#: frame, ``d = 0``); the table then misses the URDF by at most this angle times the chain's reach.
PARALLEL = 1e-7
#: Consecutive axes closer to parallel than this [rad], but not within :data:`PARALLEL`, are named in
#: :attr:`DHTable.near_parallel`: their common normal is far off, their ``d`` values large and cancelling.
NEAR_PARALLEL = 1e-2
#: Two lines closer than this [m] meet (their normal's direction is ``z_k × z_{k+1}``).
MEET = 1e-12


@record(frozen=True)
class DHRow:
    """One joint's row. ``dh``: a_i, α_i, d_i, θ_i; ``mdh``: a_{i-1}, α_{i-1}, d_i, θ_i. [m, rad]

    Attributes:
        joint: The joint's name; prismatic: its value adds to ``d``, else to ``theta``.
    """

    joint: str
    prismatic: bool
    a: float
    alpha: float
    d: float
    theta: float
    beta: float = 0.0

    def transform(self, convention: Convention, q: float) -> pin.SE3:
        """``A_i`` at joint value ``q`` [rad or m] (``hayati``: the ``dh`` form, then ``Ry(beta)``)."""
        theta, d = (self.theta, self.d + q) if self.prismatic else (self.theta + q, self.d)
        rz, tz = pin.SE3(_rot("z", theta), np.zeros(3)), pin.SE3(np.eye(3), np.array([0.0, 0.0, d]))
        rx, tx = pin.SE3(_rot("x", self.alpha), np.zeros(3)), pin.SE3(np.eye(3), np.array([self.a, 0.0, 0.0]))
        if convention == "mdh":
            return rx * tx * rz * tz
        out = rz * tz * tx * rx
        return out * pin.SE3(_rot("y", self.beta), np.zeros(3)) if self.beta else out


@record(frozen=True)
class DHTable:
    """A chain as a DH table (module docstring).

    Attributes:
        convention: ``dh`` or ``mdh``.
        base_frame, end_frame: The chain's ends (frames of the URDF).
        base: Frame 0 in the base frame.
        rows: One per joint, from the base.
        tool: The end frame in the last DH frame.
        near_parallel: (joint, next joint, angle between their axes [rad], distance [m] along the first axis from
            the previous frame to their common normal) for axes within :data:`NEAR_PARALLEL` but not parallel.
        parallel: (joint, next joint) pairs taken as parallel (:data:`PARALLEL`).
        hayati: (joint, next joint, the classic ``d`` [m] it replaces) for the rows written in Hayati's form
            (``hayati`` convention: :func:`dh_table`).
        size: The chain's size [m]: the length of the polyline through its joint frames' origins and the end frame's
            at the zero posture.
    """

    convention: Convention
    base_frame: str
    end_frame: str
    base: pin.SE3
    rows: tuple[DHRow, ...]
    tool: pin.SE3
    near_parallel: tuple[tuple[str, str, float, float], ...] = ()
    parallel: tuple[tuple[str, str], ...] = ()
    hayati: tuple[tuple[str, str, float], ...] = ()
    size: float = 0.0

    def placement(self, q: Array) -> pin.SE3:
        """The end frame in the base frame at joint values ``q`` (one per row) [rad or m]."""
        out = self.base
        for row, value in zip(self.rows, q, strict=True):
            out = out * row.transform(self.convention, float(value))
        return out * self.tool


def _rot(axis: str, angle: float) -> Array:
    c, s = math.cos(angle), math.sin(angle)
    if axis == "x":
        return np.array([[1.0, 0.0, 0.0], [0.0, c, -s], [0.0, s, c]])
    if axis == "y":
        return np.array([[c, 0.0, s], [0.0, 1.0, 0.0], [-s, 0.0, c]])
    return np.array([[c, -s, 0.0], [s, c, 0.0], [0.0, 0.0, 1.0]])


def _unit(v: Array) -> Array:
    return v / np.linalg.norm(v)


def _across(v: Array, z: Array, fallback: Array) -> Array:
    """``v`` made perpendicular to unit ``z`` and of unit length; ``fallback`` so made if ``v`` is along ``z``."""
    w = v - (v @ z) * z
    if np.linalg.norm(w) < 1e-6:
        w = fallback - (fallback @ z) * z
    return _unit(w)


def _frame(origin: Array, x: Array, z: Array) -> pin.SE3:
    x = _across(x, z, np.array([1.0, 0.0, 0.0]))
    return pin.SE3(np.column_stack([x, np.cross(z, x), z]), origin)


def _foot(point: Array, p: Array, z: Array) -> Array:
    """The foot of the perpendicular from ``point`` to the line through ``p`` along unit ``z``."""
    return p + ((point - p) @ z) * z


def chain_joints(robot: Robot, base: str, end: str) -> list[int]:
    """The Pinocchio ids of the joints from frame ``base`` to frame ``end``, from the base.

    Raises:
        NotFoundError: a frame does not exist.
        RobotFileError: ``base`` is not on the path from the root to ``end``, or no joint moves ``end`` from it.
    """
    model = robot.model
    names = [f.name for f in model.frames]
    for frame in (base, end):
        if not model.existFrame(frame):
            raise NotFoundError(f"frame '{frame}' does not exist in robot '{robot.name}'; frames are: "
                                f"{listing(names)}", "frame", frame, names)
    top = model.frames[model.getFrameId(base)].parentJoint
    path, j = [], model.frames[model.getFrameId(end)].parentJoint
    while j not in (top, 0):
        path.append(j)
        j = model.parents[j]
    if j != top:
        raise RobotFileError(f"frame '{base}' is not on the path from the root to '{end}': a DH table is one chain "
                             "from its base to its end")
    if not path:
        raise RobotFileError(f"no movable joint between '{base}' and '{end}': nothing to tabulate")
    return path[::-1]


def _axes(robot: Robot, joints: list[int], base: pin.SE3, q0: Array) -> list[tuple[Array, Array, bool]]:
    """Each joint's axis line in the base frame at ``q0``: (a point, the unit direction, prismatic)."""
    model, data = robot.model, robot.model.createData()
    pin.computeJointJacobians(model, data, q0)
    out = []
    for j in joints:
        jm, name = model.joints[j], model.names[j]
        if jm.nv != 1:
            what = "a <mimic> follower" if jm.nv == 0 else f"a {jm.shortname()} joint of {jm.nv} coordinates"
            raise RobotFileError(f"joint '{name}' is {what}: a DH table holds revolute and prismatic joints only")
        twist = base.inverse().act(pin.Motion(joint_jacobian(model, data, j, pin.WORLD)[:, jm.idx_v]))
        v, w = twist.linear, twist.angular
        if np.linalg.norm(w) < 1e-9:
            out.append(((base.inverse() * data.oMi[j]).translation, _unit(v), True))
            continue
        n = float(np.linalg.norm(w))
        v, w = v / n, w / n
        if abs(v @ w) > 1e-9:
            raise RobotFileError(f"joint '{name}' is helical (it translates along its axis as it turns): a DH table "
                                 "holds revolute and prismatic joints only")
        out.append((np.cross(w, v), w, False))
    return out


def _normal(p1: Array, z1: Array, p2: Array, z2: Array, at: Array, x_before: Array) -> tuple[Array, Array, Array,
                                                                                             bool]:
    """The common normal of two lines: (its foot on the first, its foot on the second, its unit direction,
    parallel). Lines parallel within :data:`PARALLEL`: the normal through ``at`` (a point of the first line);
    coincident: direction ``x_before``."""
    cross = np.cross(z1, z2)
    sin = float(np.linalg.norm(cross))
    if sin > PARALLEL:
        w, b = p1 - p2, float(z1 @ z2)
        t1 = (b * (z2 @ w) - (z1 @ w)) / sin**2
        t2 = ((z2 @ w) - b * (z1 @ w)) / sin**2
        f1, f2 = p1 + t1 * z1, p2 + t2 * z2
        x = cross / sin
        return f1, f2, (-x if (f2 - f1) @ x < -MEET else x), False
    f1 = _foot(at, p1, z1)
    f2 = _foot(f1, p2, z2)
    gap = f2 - f1 - ((f2 - f1) @ z1) * z1
    x = _unit(gap) if np.linalg.norm(gap) > MEET else _across(x_before, z1, np.array([0.0, 1.0, 0.0]))
    return f1, f2, x, True


def _row(convention: Convention, a: pin.SE3, b: pin.SE3, joint: str, prismatic: bool) -> DHRow:
    """The row taking frame ``a`` to frame ``b`` (both on the table's lines, module docstring)."""
    xa, za, xb, zb = a.rotation[:, 0], a.rotation[:, 2], b.rotation[:, 0], b.rotation[:, 2]
    step = b.translation - a.translation
    if convention != "mdh":
        return DHRow(joint, prismatic, a=float(step @ xb), alpha=math.atan2(np.cross(za, zb) @ xb, za @ zb),
                     d=float(step @ za), theta=math.atan2(np.cross(xa, xb) @ za, xa @ xb))
    return DHRow(joint, prismatic, a=float(step @ xa), alpha=math.atan2(np.cross(za, zb) @ xa, za @ zb),
                 d=float(step @ zb), theta=math.atan2(np.cross(xa, xb) @ zb, xa @ xb))


def _hayati_frame(previous: pin.SE3, p2: Array, z2: Array) -> tuple[pin.SE3, Array]:
    """Hayati's frame on the line through ``p2`` along ``z2``, after ``previous`` (whose z is the axis before it): its
    origin where the line crosses the plane through ``previous``'s origin normal to that axis (``d = 0``), x from
    ``previous``'s origin to it, then ``Rx(alpha) Ry(beta)`` bring z onto the line. Returns the frame and
    (theta, a, alpha, beta) [rad, m]."""
    o1, x1, z1 = previous.translation, previous.rotation[:, 0], previous.rotation[:, 2]
    origin = p2 + ((o1 - p2) @ z1) / (z2 @ z1) * z2
    step = origin - o1
    a = float(np.linalg.norm(step))
    x = step / a if a > MEET else x1
    y = np.cross(z1, x)
    beta = math.asin(max(-1.0, min(1.0, float(z2 @ x))))
    alpha = math.atan2(-float(z2 @ y), float(z2 @ z1))
    rotation = np.column_stack([x, y, z1]) @ _rot("x", alpha) @ _rot("y", beta)
    theta = math.atan2(float(np.cross(x1, x) @ z1), float(x1 @ x))
    return pin.SE3(rotation, origin), np.array([theta, a if a > MEET else 0.0, alpha, beta])


def chain_size(robot: Robot, joints: list[int], base: pin.SE3, end: pin.SE3) -> float:
    """The length [m] of the polyline through the chain's joint frames' origins and the end frame's, from the base
    frame's, at the zero posture (``base``, ``end``: those frames' placements there)."""
    data = robot.model.createData()
    pin.forwardKinematics(robot.model, data, pin.neutral(robot.model))
    points = [base.translation, *(data.oMi[j].translation for j in joints), end.translation]
    return float(sum(np.linalg.norm(b - a) for a, b in itertools.pairwise(points)))


def dh_table(robot: Robot, end: str, base: str, convention: Convention = "dh") -> DHTable:
    """The DH table of the chain from frame ``base`` to frame ``end`` (module docstring). ``hayati``: the classic
    table, but each row whose classic ``d`` would be longer than the chain (:func:`chain_size`), nearly parallel axes,
    in Hayati's form, ``Rz(theta) Tx(a) Rx(alpha) Ry(beta)`` (``d = 0``).

    Raises:
        RobotFileError: a closed-loop robot; a joint of the chain that is neither revolute nor prismatic (a
            ``<mimic>`` follower, a floating, planar, spherical or helical joint); ``base`` not above ``end``.
        NotFoundError: a frame does not exist.
    """
    if robot.is_closed_loop:
        raise RobotFileError(f"robot '{robot.name}' has closed loops ({listing([lp.name for lp in robot.loops])}): a "
                             "DH table describes a serial chain; export its joint origins with --format yaml")
    joints = chain_joints(robot, base, end)
    model, data = robot.model, robot.model.createData()
    q0 = pin.neutral(model)
    pin.framesForwardKinematics(model, data, q0)
    base_placement = data.oMf[model.getFrameId(base)].copy()
    end_placement = base_placement.inverse() * data.oMf[model.getFrameId(end)]
    axes = _axes(robot, joints, base_placement, q0)
    names = [str(model.names[j]) for j in joints]
    p0, z0, _ = axes[0]
    first = _frame(_foot(np.zeros(3), p0, z0), _across(np.eye(3)[0], z0, np.eye(3)[1]), z0)
    p_last, z_last, _ = axes[-1]
    last = _frame(_foot(end_placement.translation, p_last, z_last),
                  _across(end_placement.rotation[:, 0], z_last, end_placement.rotation[:, 1]), z_last)
    size = chain_size(robot, joints, base_placement, data.oMf[model.getFrameId(end)])
    frames, at, x, near, parallel = [first], first.translation, first.rotation[:, 0], [], []
    hayati: dict[int, Array] = {}
    replaced: dict[int, float] = {}
    for k in range(len(axes) - 1):
        (p1, z1, _), (p2, z2, prismatic) = axes[k], axes[k + 1]
        f1, f2, x, is_parallel = _normal(p1, z1, p2, z2, at, x)
        if is_parallel:
            parallel.append((names[k], names[k + 1]))
        angle = math.atan2(float(np.linalg.norm(np.cross(z1, z2))), abs(float(z1 @ z2)))
        d = float(np.linalg.norm(f1 - at))
        if not is_parallel and angle < NEAR_PARALLEL:
            near.append((names[k], names[k + 1], angle, d))
        if convention == "hayati" and not is_parallel and d > size and not axes[k][2] and not prismatic:
            frame, hayati[k] = _hayati_frame(frames[-1], p2, z2)
            replaced[k] = d
            frames.append(frame)
            at, x = frame.translation, frame.rotation[:, 0]
            continue
        frames.append(_frame(f1, x, z1) if convention == "mdh" else _frame(f2, x, z2))
        at = f2
    frames.append(last)
    rows = tuple(_hayati_row(names[k], hayati[k]) if k in hayati else
                 _row(convention, frames[k], frames[k + 1], names[k], axes[k][2]) for k in range(len(axes)))
    swapped = tuple((names[k], names[k + 1], replaced[k]) for k in sorted(hayati))
    return DHTable(convention, base, end, first, rows, last.inverse() * end_placement, tuple(near), tuple(parallel),
                   swapped, size)


def _hayati_row(joint: str, values: Array) -> DHRow:
    theta, a, alpha, beta = (float(v) for v in values)
    return DHRow(joint, False, a=a, alpha=alpha, d=0.0, theta=theta, beta=beta)


def random_chain_values(robot: Robot, joints: list[int], count: int, seed: int = 0) -> Array:
    """(count, len(joints)) joint values drawn uniformly within the URDF limits [rad or m]; a joint without finite
    limits (continuous) over [-π, π] (a prismatic one over [-1, 1] m)."""
    model, rng = robot.model, np.random.default_rng(seed)
    out = np.empty((count, len(joints)))
    for k, j in enumerate(joints):
        jm = model.joints[j]
        lo, hi = float(model.lowerPositionLimit[jm.idx_q]), float(model.upperPositionLimit[jm.idx_q])
        if jm.nq != 1 or not (math.isfinite(lo) and math.isfinite(hi)) or hi - lo > 1e3 or hi < lo:
            span = 1.0 if jm.shortname().startswith(("JointModelP", "JointModelPrismatic")) else math.pi
            lo, hi = -span, span
        out[:, k] = rng.uniform(lo, hi, count)
    return out


def chain_configuration(robot: Robot, joints: list[int], values: Array) -> Array:
    """Pinocchio's configuration with the chain's joints at ``values`` [rad or m], the others at zero."""
    q = pin.neutral(robot.model)
    for j, value in zip(joints, values, strict=True):
        jm = robot.model.joints[j]
        if jm.nq == 1:
            q[jm.idx_q] = value
        else:
            q[jm.idx_q:jm.idx_q + 2] = [math.cos(value), math.sin(value)]
    return np.asarray(q, dtype=float)


@record(frozen=True)
class Residual:
    """How far a table's forward kinematics is from the URDF's (Pinocchio's) over random postures.

    Attributes:
        position: Largest distance between the end frame's origins [m].
        orientation: Largest angle between the end frame's orientations [rad].
        postures: How many postures (drawn within the joint limits, :func:`random_chain_values`).
        seed: Their random seed.
    """

    position: float
    orientation: float
    postures: int
    seed: int


def conversion_residual(robot: Robot, table: DHTable, postures: int = 100, seed: int = 0) -> Residual:
    """The table against Pinocchio's forward kinematics of ``robot``, at the zero posture and ``postures`` random
    ones within the joint limits.

    Raises:
        DataError: ``postures`` < 1.
    """
    if postures < 1:
        raise DataError(f"postures is {postures}; at least 1 is needed")
    model, data = robot.model, robot.model.createData()
    joints = chain_joints(robot, table.base_frame, table.end_frame)
    values = np.vstack([np.zeros(len(joints)), random_chain_values(robot, joints, postures, seed)])
    base, end = model.getFrameId(table.base_frame), model.getFrameId(table.end_frame)
    position = orientation = 0.0
    for row in values:
        pin.framesForwardKinematics(model, data, chain_configuration(robot, joints, row))
        gap = table.placement(row).inverse() * (data.oMf[base].inverse() * data.oMf[end])
        position = max(position, float(np.linalg.norm(gap.translation)))
        orientation = max(orientation, float(np.linalg.norm(pin.log3(gap.rotation))))
    return Residual(position, orientation, postures, seed)
