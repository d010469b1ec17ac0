"""The arrays batched closed-loop kinematics pass around (:mod:`pincal.model.batch_loops`,
:mod:`pincal.model.batch_kinematics`): joint placements, loop anchor frames, a robot's constant placements, the loops
linearised, and the small stacked operations they share (C_p⁺, cross products, free-flyer moves). Units: m, rad.
"""

from __future__ import annotations

import numpy as np
import numpy.typing as npt

from pincal.model.rotations import skew
from pincal.records import record

Array = npt.NDArray[np.float64]
BoolArray = npt.NDArray[np.bool_]
IntArray = npt.NDArray[np.intp]


@record(frozen=True)
class JointPlacements:
    """Every joint's turned frame in the world for N samples: ``oMi[j] · Q_j``, Q_j the constant rotation taking z to
    the joint's axis (joint 0, the world, not turned), so that each joint turns about or slides along its frame's z.

    Attributes:
        frames: (njoints, N, 3, 4) each turned frame's ``[R | p]``: its rotation and origin [m] (the joint's origin:
            Q_j is a pure rotation); one contiguous block per joint.
    """

    frames: Array

    def rotation(self, joint: int) -> Array:
        """(N, 3, 3) the turned frame's rotation of ``joint``."""
        rotation: Array = self.frames[joint, :, :, :3]
        return rotation

    def translation(self, joint: int) -> Array:
        """(N, 3) the origin [m] of ``joint``."""
        translation: Array = self.frames[joint, :, :, 3]
        return translation

    def take(self, rows: BoolArray) -> JointPlacements:
        """The samples ``rows``."""
        return JointPlacements(self.frames[:, rows])


@record(frozen=True)
class LoopFrames:
    """One loop's anchor frames for N samples: c1 (predecessor), c2 (successor) in the world, ``c1Mc2 = (R, p)``.

    Attributes:
        r1: (N, 3, 3) c1's rotation in the world.
        p2: (N, 3) c2's origin [m] in the world.
        relative_translation: (N, 3) p of ``c1Mc2`` [m], in c1.
        r2: (N, 3, 3) c2's rotation in the world (None for a spherical loop, whose rows do not need it).
        relative_rotation: (N, 3, 3) R of ``c1Mc2`` (None for a spherical loop).
        log: (N, 3) ``log3(R)`` [rad] (fixed and prismatic loops; else None).
        gap: (N, 3) ``p₂ − p₁`` [m] in the world.
    """

    r1: Array
    p2: Array
    relative_translation: Array
    r2: Array | None
    relative_rotation: Array | None
    log: Array | None
    gap: Array


@record(frozen=True)
class LoopState:
    """The loops of N samples at their configurations: residual, Jacobian (if asked), anchor frames."""

    placements: JointPlacements
    frames: list[LoopFrames]
    residual: Array  # (N, rows) [m, rad]
    jacobian: Array | None  # (N, rows, nv)
    axes: Array | None  # (N, 6, nv) each velocity coordinate's spatial twist


@record(frozen=True)
class Geometry:
    """The placements one robot's parameters give, read once from its model and loops (the constants of
    :meth:`~pincal.model.batch_loops.BatchLoops.forward` and :meth:`~pincal.model.batch_loops.BatchLoops.loop_frames`).

    Attributes:
        rotations: (njoints - 1, 3, 3) per joint (ids 1…), the rotation of ``Q_parentᵀ M_j start_j Q_j``.
        translations: (njoints - 1, 3) its translation [m].
        anchors: Per loop: predecessor joint id, rotation and translation [m] of ``Q_j1ᵀ · M1``, successor joint id,
            rotation and translation of ``Q_j2ᵀ · M2``.
        constants: (njoints - 1, 4, 4) the homogeneous matrices of ``rotations`` and ``translations``.
    """

    rotations: Array
    translations: Array
    anchors: list[tuple[int, Array, Array, int, Array, Array]]
    constants: Array


@record(frozen=True)
class LoopSystem:
    """The loops of N samples linearised at closed configurations
    (:meth:`~pincal.model.batch_kinematics.BatchKinematics.linearised`).

    Attributes:
        placements: The joints' placements.
        frames: Each loop's anchor frames.
        passive: (N, rows, n_passive) ``C_p``, the spherical loops' rows in the world frame
            (:meth:`~pincal.model.batch_loops.BatchLoops.solver_rows`).
    """

    placements: JointPlacements
    frames: list[LoopFrames]
    passive: Array

def take_frames(frame: LoopFrames, rows: BoolArray) -> LoopFrames:
    """The samples ``rows`` of a loop's frames."""
    return LoopFrames(frame.r1[rows], frame.p2[rows], frame.relative_translation[rows],
                      None if frame.r2 is None else frame.r2[rows],
                      None if frame.relative_rotation is None else frame.relative_rotation[rows],
                      None if frame.log is None else frame.log[rows], frame.gap[rows])


def cross(a: Array, b: Array) -> Array:
    """``a × b`` over the last axis (…, 3), without :func:`numpy.cross`'s overhead."""
    out = np.empty(np.broadcast_shapes(a.shape, b.shape))
    out[..., 0] = a[..., 1] * b[..., 2] - a[..., 2] * b[..., 1]
    out[..., 1] = a[..., 2] * b[..., 0] - a[..., 0] * b[..., 2]
    out[..., 2] = a[..., 0] * b[..., 1] - a[..., 1] * b[..., 0]
    return out


def passive_gains(passive: Array) -> Array:
    """(N, n_passive, rows) ``C_p⁺`` for stacked ``C_p`` (N, rows, n_passive), as
    :func:`~pincal.model.kinematics.damped_pseudo_inverse` gives each: the inverse of a square one (LU) unless an
    entry reaches 1e8, else the damped normal equations' ``(C_pᵀC_p + μI)⁻¹ C_pᵀ``, ``μ = 1e-12 · (1 + tr(C_pᵀC_p)/n)``;
    NaN for a singular one."""
    n, rows, cols = passive.shape
    gains: Array = np.full((n, cols, rows), np.nan)
    damped = np.ones(n, dtype=bool)
    if rows == cols:
        with np.errstate(all="ignore"):
            try:
                gains[:] = np.linalg.inv(passive)
            except np.linalg.LinAlgError:  # one singular: each alone
                for k in range(n):
                    try:
                        gains[k] = np.linalg.inv(passive[k])
                    except np.linalg.LinAlgError:
                        continue
        damped = ~(np.abs(gains).max(axis=(1, 2), initial=0.0) < 1e8)
    if np.any(damped):
        chosen = passive[damped]
        transposed = np.swapaxes(chosen, 1, 2)
        normal = transposed @ chosen
        damping = 1e-12 * (1.0 + np.trace(normal, axis1=1, axis2=2) / cols)
        normal[:, np.arange(cols), np.arange(cols)] += damping[:, None]
        solved = np.full(transposed.shape, np.nan)
        with np.errstate(all="ignore"):
            try:
                solved[:] = np.linalg.solve(normal, transposed)
            except np.linalg.LinAlgError:
                for k in range(len(normal)):
                    try:
                        solved[k] = np.linalg.solve(normal[k], transposed[k])
                    except np.linalg.LinAlgError:
                        continue
        gains[damped] = solved
    return gains


def turn_quaternion(quaternion: Array, angular: Array) -> Array:
    """(N, 4) unit quaternions (x, y, z, w) turned by ``exp3(angular)`` (N, 3) [rad] on the right, renormalised."""
    angle = np.linalg.norm(angular, axis=1)
    half = 0.5 * angle
    scale = np.where(angle > 1e-12, np.sin(half) / np.where(angle > 1e-12, angle, 1.0), 0.5)
    b = np.concatenate([angular * scale[:, None], np.cos(half)[:, None]], axis=1)
    a = quaternion
    out = np.stack([a[:, 3] * b[:, 0] + a[:, 0] * b[:, 3] + a[:, 1] * b[:, 2] - a[:, 2] * b[:, 1],
                    a[:, 3] * b[:, 1] - a[:, 0] * b[:, 2] + a[:, 1] * b[:, 3] + a[:, 2] * b[:, 0],
                    a[:, 3] * b[:, 2] + a[:, 0] * b[:, 1] - a[:, 1] * b[:, 0] + a[:, 2] * b[:, 3],
                    a[:, 3] * b[:, 3] - a[:, 0] * b[:, 0] - a[:, 1] * b[:, 1] - a[:, 2] * b[:, 2]], axis=1)
    normalised: Array = out / np.linalg.norm(out, axis=1)[:, None]
    return normalised


def inverse_left_jacobian(angular: Array, translation: Array) -> Array:
    """(N, 3) the linear part of ``log6`` [m] of placements whose rotation vector is ``angular`` (N, 3) [rad] and
    translation ``translation`` (N, 3) [m]: ``V⁻¹(ω) t``, ``V⁻¹ = I − ½ ω̂ + (1 − (θ/2) cot(θ/2)) / θ² · ω̂²``."""
    theta = np.linalg.norm(angular, axis=1)
    small = theta < 1e-4
    safe = np.where(small, 1.0, theta)
    coefficient = np.where(small, 1.0 / 12.0 + theta**2 / 720.0, (1.0 - 0.5 * safe / np.tan(0.5 * safe)) / safe**2)
    hat = skew(angular)
    product = (hat @ translation[..., None])[..., 0]
    twice = (hat @ product[..., None])[..., 0]
    out: Array = translation - 0.5 * product + coefficient[:, None] * twice
    return out
