"""Every sample of a closed-loop robot at once: the measured frames' placements and their parameter derivatives
through the loops.

With the loops closed (:class:`~pincal.model.batch_kinematics.BatchKinematics`), the derivatives follow the
implicit-function theorem for all N samples together:

1. the spatial twists per unit parameter at fixed passive joints (per unit parameter, the velocity of the world
   point at the origin moving with the body and its angular velocity, in the world frame: the same for every point
   of a body), accumulated down the tree (:meth:`LoopBatch.body_twists`: each joint's placement parameters, fixed
   joints' included, carried by the adjoint of the joint's origin; each actuated joint's axis times its offset and
   correction terms' regressors), plus, for a measured frame or a loop anchor, the local terms of the fixed joints
   above it and of its own placement (:meth:`LoopBatch.probe_twist`);
2. the loops' residual per unit parameter ``∂c/∂θ`` (N, rows, p), from each loop's relative anchor twist
   (:meth:`~pincal.model.batch_kinematics.BatchKinematics.solver_rows`, the spherical loops' rows in the world
   frame, as ``C_p``'s);
3. ``dv_p/dθ = −C_p⁺ ∂c/∂θ``: N stacked solves with the passive closure Jacobians (N, rows, n_passive);
4. each measured frame's twist: step 1's plus its passive joints' spatial twists times ``dv_p/dθ``.

The per-sample path (:meth:`~pincal.identification.problem.CalibrationProblem._predict_samples`) computes the same
numbers one sample at a time with Pinocchio; tests/identification/test_loop_batch.py holds them together.
"""

from __future__ import annotations

import numpy as np
import numpy.typing as npt
import pinocchio as pin

from pincal.errors import ConvergenceError
from pincal.identification.batch import SpatialJacobian, Workspace
from pincal.identification.derivatives import KinematicSensitivity, Probe
from pincal.model.batch_frames import JointPlacements, LoopSystem, passive_gains
from pincal.model.batch_kinematics import BatchKinematics
from pincal.model.robot import Robot
from pincal.records import record

Array = npt.NDArray[np.float64]


@record(frozen=True)
class LoopDerivatives:
    """A block of samples' configurations' response to the parameters.

    Attributes:
        velocities: (N, nv, p) ``dv/dθ``: the actuated joints' rows from their offset and correction terms, the
            passive joints' through the loops.
        joint_twists: (N, 6, nv) each velocity coordinate's spatial twist.
    """

    velocities: Array
    joint_twists: Array


class LoopBatch:
    """Batched evaluation of a closed-loop robot for a fixed set of measured frames (built once per problem).

    Args:
        robot: The nominal robot; its structure, not its placements, is kept.
        frame_ids: Measured frame name -> Pinocchio frame id.

    Attributes:
        unsupported: Why the batched evaluation cannot take this robot (a joint kind it does not evaluate), or None.
    """

    def __init__(self, robot: Robot, frame_ids: dict[str, int]) -> None:
        self.kinematics: BatchKinematics = robot.batch
        self.unsupported = self.kinematics.unsupported
        self.frame_ids = dict(frame_ids)
        self.scratch = Workspace()
        #: actuated joint id -> its index in the actuated values
        self.actuated = {a.joint_id: k for k, a in enumerate(robot.kinematics.actuated)}

    def gain(self, system: LoopSystem, first: int, singular_gain: float) -> Array:
        """(N, n_passive, rows) ``C_p⁺``, the passive joints' response to the loops' residual (the spherical loops'
        rows in the world frame), for samples numbered from ``first``; ConvergenceError naming the first sample where
        an entry exceeds ``singular_gain`` (the per-sample check, up to the rotation of those rows).

        Square ``C_p`` (most parallel robots) are inverted by LU, others by the damped normal equations of
        :func:`~pincal.model.kinematics.damped_pseudo_inverse` (:func:`~pincal.model.batch_kinematics.passive_gains`).
        """
        gain = passive_gains(system.passive)
        with np.errstate(invalid="ignore"):
            largest = np.abs(gain).max(axis=(1, 2), initial=0.0)
        singular = ~(largest <= singular_gain)
        if np.any(singular):
            k = first + int(np.flatnonzero(singular)[0])
            raise ConvergenceError(f"sample {k} is at a singular configuration: the passive joints are not "
                                   "determined by the actuated ones (with these parameters)")
        return gain

    def placement(self, placements: JointPlacements, joint: int, local: pin.SE3) -> tuple[Array, Array]:
        """The rotations (N, 3, 3) and origins (N, 3) [m] in the world of a frame at ``local`` relative to joint
        ``joint`` (a measured frame, a loop's anchor), from the joints' turned frames."""
        frame = placements.frames[joint]
        n = frame.shape[0]
        local = self.kinematics.unturn[joint] * local
        above = frame[:, :, :3].reshape(3 * n, 3)
        rotation = (above @ local.rotation).reshape(n, 3, 3)
        origin = (above @ local.translation).reshape(n, 3) + frame[:, :, 3]
        return rotation, origin

    def body_twists(self, model: pin.Model, sens: KinematicSensitivity, placements: JointPlacements,
                    joint_twists: Array, terms: list[tuple[int, int, Array]]) -> list[Array | None]:
        """Per joint id, the spatial twists (N, 6, p) per unit parameter of the body it carries, passive joints held
        (None: the body does not move with the parameters). They add up down the tree: each joint's placement
        parameters move its body and those below by ``Ad(oMi[parent] · M_j) · joint_map`` (the rows of
        :class:`~pincal.identification.derivatives.KinematicSensitivity`, fixed joints' included), and an actuated
        joint's offset and correction terms by its axis times their regressor."""
        kin = self.kinematics
        n = placements.frames.shape[1]
        body: list[Array | None] = [None] * kin.njoints
        moving: dict[int, list[tuple[int, Array]]] = {}
        for k, column, regressor in terms:
            moving.setdefault(k, []).append((column, regressor))
        maps = sens.joint_map.reshape(kin.njoints - 1, 6, sens.n)
        used = np.any(maps != 0.0, axis=1)  # (J, p): the parameters each joint's placement has
        placed = set((np.flatnonzero(np.any(used, axis=1)) + 1).tolist())
        for j in range(1, kin.njoints):
            twist = body[kin.parents[j]]
            own = moving.get(self.actuated.get(j, -1), [])
            if j in placed or own:
                twist = np.zeros((n, 6, sens.n)) if twist is None else twist.copy()
            if j in placed:
                assert twist is not None
                columns = np.flatnonzero(used[j - 1])
                rotation, origin = self.placement(placements, kin.parents[j], model.jointPlacements[j])
                twist[:, :, columns] += _spatial(rotation, origin, maps[j - 1][:, columns])
            for column, regressor in own:
                assert twist is not None
                twist[:, :, column] += joint_twists[:, :, kin.idx_v[j - 1]] * regressor[:, None]
            body[j] = twist
        return body

    def probe_twist(self, body: list[Array | None], placements: JointPlacements, probe: Probe,
                    extra: list[tuple[list[int], Array]], width: int) -> Array:
        """(N, 6, p) a probe's spatial twists per unit parameter, passive joints held: its body's, plus its local
        ``extra`` terms (fixed joints above it, its own placement's) carried by ``Ad(oM_probe)``; ``width``: p.
        The body's array itself when there is nothing to add (not to be written to)."""
        twist = body[probe.joint]
        n = placements.frames.shape[1]
        if not extra:
            return np.zeros((n, 6, width)) if twist is None else twist
        out = np.zeros((n, 6, width)) if twist is None else twist.copy()
        rotation, origin = self.placement(placements, probe.joint, probe.placement)
        for idx, term in extra:
            out[:, :, idx] += _spatial(rotation, origin, term)
        return out

    def twists(self, robot: Robot, sens: KinematicSensitivity, q: Array, system: LoopSystem,
               terms: list[tuple[int, int, Array]], probes: dict[str, Probe], first: int, singular_gain: float
               ) -> tuple[dict[str, tuple[Array, Array]], dict[str, SpatialJacobian], LoopDerivatives]:
        """The measured frames' placements and spatial twists per unit parameter through the loops.

        Args:
            robot: The robot at the evaluated parameters.
            sens: The parameter derivatives at this estimate.
            q: (N, nq) the block's closed configurations.
            system: The loops linearised at ``q`` (:meth:`~pincal.model.batch_kinematics.BatchKinematics.linearised`).
            terms: (actuated joint index, column, (N,) regressor) of the block.
            probes: Measured frame -> its probe at this estimate.
            first: The index of the block's first sample (for error messages).
            singular_gain: Largest entry of ``C_p⁺`` before a sample counts as singular (ConvergenceError).

        Returns:
            Frame -> its rotations (N, 3, 3) and origins (N, 3) [m]; frame -> its spatial twists per unit parameter
            (the full (N, 6, p), factored with the identity); and the configurations' response to the parameters.
        """
        kin, model, placements = self.kinematics, robot.model, system.placements
        n = len(q)
        gain = self.gain(system, first, singular_gain)
        joint_twists = kin.joint_twists(placements)
        body = self.body_twists(model, sens, placements, joint_twists, terms)
        # the loops' residual per unit parameter at fixed passive joints (actuated terms included)
        slopes = []
        for index, (loop, ends) in enumerate(zip(robot.loops, sens.anchor_probes, strict=True)):
            twist = []
            for side, probe in zip(("predecessor", "successor"), ends, strict=True):
                extra = list(sens.fixed_terms(probe))
                own = sens.anchor_terms.get((loop.name, side))
                if own is not None:  # the anchor's own placement parameters: Jexp6 at the anchor
                    extra.append(own)
                twist.append(self.probe_twist(body, placements, probe, extra, sens.n))
            slopes.append(kin.solver_rows(index, system.frames[index], twist[1] - twist[0]))
        slope = np.concatenate(slopes, axis=1)  # (N, rows, p)
        passive = kin.passive_v
        velocities = np.zeros((n, kin.nv, sens.n))
        velocities[:, passive] = -(gain @ slope)
        act_v = robot.kinematics.actuated_v
        for joint, column, regressor in terms:
            velocities[:, act_v[joint], column] = regressor
        frames: dict[str, tuple[Array, Array]] = {}
        twists: dict[str, SpatialJacobian] = {}
        identity = np.eye(sens.n)
        for f, probe in probes.items():
            frames[f] = self.placement(placements, probe.joint, probe.placement)
            spatial = self.probe_twist(body, placements, probe, sens.fixed_terms(probe), sens.n)
            chain = passive[kin.support[probe.joint, passive] > 0.0]
            if chain.size:
                spatial = spatial + joint_twists[:, :, chain] @ velocities[:, chain]
            twists[f] = SpatialJacobian(spatial, identity, self.scratch)
        return frames, twists, LoopDerivatives(velocities, joint_twists)


def _spatial(rotation: Array, origin: Array, local: Array) -> Array:
    """(N, 6, k) local twists ``local`` (6, k) of a frame at ``rotation`` (N, 3, 3), ``origin`` (N, 3) [m] as spatial
    ones, ``Ad(M) ν = (R ν_v + p × R ν_ω, R ν_ω)``."""
    n, k = len(rotation), local.shape[1]
    out = np.empty((n, 6, k))
    flat = rotation.reshape(3 * n, 3)
    out[:, :3] = (flat @ local[:3]).reshape(n, 3, k)
    angular = out[:, 3:]
    angular[...] = (flat @ local[3:]).reshape(n, 3, k)
    for i, (a, b) in enumerate(((1, 2), (2, 0), (0, 1))):  # + p × (R ν_ω)
        out[:, i] += origin[:, a, None] * angular[:, b] - origin[:, b, None] * angular[:, a]
    return out
