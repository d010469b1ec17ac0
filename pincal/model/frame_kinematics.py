"""One frame of a robot at many configurations: its placements and Jacobians, the loops' rows, moves on the
configuration space and forward kinematics, for every row at once where the arrays of
:mod:`pincal.model.batch_loops` take the robot, else row by row with Pinocchio (one interface, two ways).

What :mod:`pincal.model.batch_ik` solves with. :class:`BatchFrame` reads the joints' placements and spatial twists of
:class:`~pincal.model.batch_loops.BatchLoops` (the frame's Jacobian is its supporting joints' twists moved to its
origin); :class:`SampleFrame` asks Pinocchio for each row, as :class:`~pincal.model.kinematics.ClosedLoopKinematics`
does (a robot with a continuous or spherical joint, or a ``<mimic>`` follower). Each row's arithmetic reads that row
alone. Units: m, rad.
"""

from __future__ import annotations

import abc
from typing import TYPE_CHECKING

import numpy as np
import pinocchio as pin

from pincal.model.batch_frames import Array, BoolArray, cross, passive_gains
from pincal.model.kinematics import ClosedLoopKinematics
from pincal.records import record

if TYPE_CHECKING:
    from pincal.model.batch_kinematics import BatchKinematics

#: Fewest rows evaluated as one stack; fewer go row by row, where a stacked evaluation's fixed cost (about a
#: millisecond) exceeds that of their Pinocchio calls (measured crossing: 16–32 rows on the Delta, UR10 and hexapod).
SMALL_BATCH = 24


@record(frozen=True)
class FrameState:
    """The frame and the loops at N configurations.

    Attributes:
        rotation: (N, 3, 3) the frame's orientation in the world.
        origin: (N, 3) its origin [m] in the world.
        jacobian: (N, 6, nv) its Jacobian in ``LOCAL_WORLD_ALIGNED``: the velocity [m/s] of its origin and its angular
            velocity [rad/s], in the world frame, per unit joint velocity (the loops open).
        residual: (N, rows) the loops' residual [m, rad].
        closure_jacobian: (N, rows, nv) its Jacobian ``dc/dv``.
    """

    rotation: Array
    origin: Array
    jacobian: Array
    residual: Array
    closure_jacobian: Array

    def actuated_jacobian(self, kinematics: ClosedLoopKinematics) -> Array:
        """(N, 6, na) the frame's twist per unit actuated velocity through the loops, ``v_p = −C_p⁺ C_a v_a`` (as
        :meth:`~pincal.model.kinematics.ClosedLoopKinematics.frame_jacobian_actuated` gives each, at configurations
        where the loops close); NaN where ``C_p`` is singular."""
        actuated, passive = kinematics.actuated_v, kinematics.passive_v
        jacobian: Array = self.jacobian[:, :, actuated]
        if kinematics.closure.rows:
            gains = passive_gains(self.closure_jacobian[:, :, passive])
            with np.errstate(invalid="ignore", over="ignore"):
                jacobian = jacobian - self.jacobian[:, :, passive] @ (gains @ self.closure_jacobian[:, :, actuated])
        return jacobian


class FrameKinematics(abc.ABC):
    """A frame of a robot at many configurations (the interface; :func:`frame_kinematics` gives one).

    Args:
        kinematics: The robot's kinematics (its model, loops, actuated joints and reference configuration).
        frame_id: The frame (Pinocchio id).
        tol: Largest closure residual component [m, rad] of :meth:`forward`'s answers.
    """

    def __init__(self, kinematics: ClosedLoopKinematics, frame_id: int, tol: float) -> None:
        self.kinematics, self.frame_id, self.tol = kinematics, frame_id, tol

    @abc.abstractmethod
    def state(self, q: Array) -> FrameState:
        """The frame and the loops at configurations ``q`` (N, nq)."""

    @abc.abstractmethod
    def integrate(self, q: Array, step: Array) -> Array:
        """(N, nq) ``q ⊕ step`` for joint velocities ``step`` (N, nv) [rad or m]."""

    @abc.abstractmethod
    def forward(self, actuated: Array, guesses: Array | None) -> tuple[Array, BoolArray]:
        """Forward kinematics of actuated values (N, na) [rad or m] on the reference assembly, warm from ``guesses``
        (N, nq) where given (:meth:`~pincal.model.kinematics.ClosedLoopKinematics.solve_fk`): (N, nq) configurations
        and (N,) which closed."""

    @abc.abstractmethod
    def actuated_values(self, q: Array) -> Array:
        """(N, na) the actuated values [rad or m] of configurations ``q`` (N, nq)."""


class BatchFrame(FrameKinematics):
    """Every row at once, on the arrays of :class:`~pincal.model.batch_loops.BatchLoops` (a robot whose joints it
    takes: :func:`frame_kinematics` checks); fewer than :data:`SMALL_BATCH` rows row by row (:class:`SampleFrame`)."""

    def __init__(self, batch: BatchKinematics, frame_id: int, tol: float) -> None:
        kinematics = batch.kinematics
        super().__init__(kinematics, frame_id, tol)
        self.rows = SampleFrame(kinematics, frame_id, tol)
        self.batch = batch
        frame = kinematics.model.frames[frame_id]
        self.joint = int(frame.parentJoint)
        local = self.batch.unturn[self.joint] * frame.placement  # on the joint's turned frame
        self.local_rotation, self.local_translation = local.rotation.copy(), local.translation.copy()
        # a tree's constant placements, read once: the model is not changed while its frame is solved for
        self._tree = None if kinematics.closure.rows else self.batch.geometry(kinematics.model, kinematics.closure)

    def state(self, q: Array) -> FrameState:
        """The frame and the loops at ``q`` (N, nq): the frame's Jacobian is its supporting joints' spatial twists
        moved to its origin."""
        kin, batch = self.kinematics, self.batch
        n = len(q)
        if n < SMALL_BATCH:
            return self.rows.state(q)
        if kin.closure.rows:
            loops = batch.state(kin.model, kin.closure, q)
            assert loops.jacobian is not None and loops.axes is not None
            placements, axes, residual, closure = loops.placements, loops.axes, loops.residual, loops.jacobian
        else:  # a tree: no loop rows
            assert self._tree is not None
            placements = batch.forward(self._tree, q)
            axes = batch.joint_twists(placements)
            residual, closure = np.zeros((n, 0)), np.zeros((n, 0, batch.nv))
        above = placements.frames[self.joint]
        rotation = (above[:, :, :3].reshape(3 * n, 3) @ self.local_rotation).reshape(n, 3, 3)
        origin = (above[:, :, :3].reshape(3 * n, 3) @ self.local_translation).reshape(n, 3) + above[:, :, 3]
        twists = axes * batch.support[self.joint]  # the joints that move the frame
        jacobian = np.empty_like(twists)
        jacobian[:, 3:] = twists[:, 3:]
        # the velocity of the frame's origin p: that of the world point at the world's origin, plus ω × p
        angular = twists[:, 3:].transpose(0, 2, 1)
        jacobian[:, :3] = twists[:, :3] + cross(angular, origin[:, None, :]).transpose(0, 2, 1)
        return FrameState(rotation, origin, jacobian, residual, closure)

    def integrate(self, q: Array, step: Array) -> Array:
        """The actuated joints' values (one coordinate each) plus their steps; the passive joints moved by
        :meth:`~pincal.model.batch_loops.BatchLoops.retract` (a free-flyer to first order, where Pinocchio's
        ``integrate`` is exact: the iterates differ at second order, the solutions they converge to do not)."""
        kin = self.kinematics
        if len(q) < SMALL_BATCH:
            return self.rows.integrate(q, step)
        moved = self.batch.retract(q, step[:, kin.passive_v]) if len(kin.passive_v) else np.array(q, dtype=float)
        moved[:, self.batch.actuated_q] += step[:, kin.actuated_v]
        return moved

    def forward(self, actuated: Array, guesses: Array | None) -> tuple[Array, BoolArray]:
        """Every row's loops closed at once (:meth:`~pincal.model.batch_kinematics.BatchKinematics.solve`), those it
        does not close alone; a tree's actuated values written in."""
        kin = self.kinematics
        n = len(actuated)
        if n < SMALL_BATCH and kin.closure.rows:
            return self.rows.forward(actuated, guesses)
        if not kin.closure.rows:  # a tree: the actuated values written into the guesses (default the reference)
            q = np.tile(kin.reference, (n, 1)) if guesses is None else np.array(guesses, dtype=float)
            q[:, self.batch.actuated_q] = actuated
            return q, np.all(np.isfinite(actuated), axis=1)
        finite = np.all(np.isfinite(actuated), axis=1)
        q = np.tile(kin.reference, (n, 1))
        ok = np.zeros(n, dtype=bool)
        rows = np.flatnonzero(finite)
        if rows.size:
            q[rows], ok[rows] = self.batch.solve(kin.model, kin.closure, actuated[rows],
                                                 None if guesses is None else guesses[rows], self.tol)
        for k in np.flatnonzero(finite & ~ok).tolist():  # what the stacked solves did not close, alone
            report = kin.solve_fk(actuated[k], None if guesses is None else guesses[k], self.tol)
            q[k], ok[k] = report.q, report.converged
        return q, ok

    def actuated_values(self, q: Array) -> Array:
        """The actuated values, read from ``q`` (N, nq)."""
        return self.batch.actuated_values(q).copy()


class SampleFrame(FrameKinematics):
    """Row by row with Pinocchio (any robot)."""

    def state(self, q: Array) -> FrameState:
        """The frame and the loops at ``q`` (N, nq), Pinocchio's Jacobians row by row."""
        kin = self.kinematics
        n, nv, rows = len(q), kin.model.nv, kin.closure.rows
        rotation, origin = np.empty((n, 3, 3)), np.empty((n, 3))
        jacobian, residual, closure = np.empty((n, 6, nv)), np.empty((n, rows)), np.empty((n, rows, nv))
        for k in range(n):
            jacobian[k] = kin.frame_jacobian(q[k], self.frame_id, pin.LOCAL_WORLD_ALIGNED)  # leaves the data there
            placement = kin.data.oMf[self.frame_id]
            rotation[k], origin[k] = placement.rotation, placement.translation
            if rows:
                residual[k], closure[k] = kin.closure.residual_and_jacobian(kin.data)
        return FrameState(rotation, origin, jacobian, residual, closure)

    def integrate(self, q: Array, step: Array) -> Array:
        """Pinocchio's ``integrate``, row by row."""
        return np.array([pin.integrate(self.kinematics.model, qk, vk) for qk, vk in zip(q, step, strict=True)])

    def forward(self, actuated: Array, guesses: Array | None) -> tuple[Array, BoolArray]:
        """:meth:`~pincal.model.kinematics.ClosedLoopKinematics.solve_fk`, row by row."""
        kin = self.kinematics
        q = np.tile(kin.reference, (len(actuated), 1))
        ok = np.zeros(len(actuated), dtype=bool)
        for k in np.flatnonzero(np.all(np.isfinite(actuated), axis=1)).tolist():
            report = kin.solve_fk(actuated[k], None if guesses is None else guesses[k], self.tol)
            q[k], ok[k] = report.q, report.converged
        return q, ok

    def actuated_values(self, q: Array) -> Array:
        """The actuated values, row by row (a continuous joint's angle from its cosine and sine)."""
        values = [self.kinematics.actuated_values(qk) for qk in q]
        return np.array(values).reshape(len(q), len(self.kinematics.actuated))


def frame_kinematics(batch: BatchKinematics, frame_id: int, tol: float) -> FrameKinematics:
    """The frame at many configurations of a robot whose batched kinematics is ``batch`` (``Robot.batch``): every
    row at once where :mod:`pincal.model.batch_loops` takes the robot, else row by row."""
    if batch.unsupported is None:
        return BatchFrame(batch, frame_id, tol)
    return SampleFrame(batch.kinematics, frame_id, tol)
