"""Every sample of a closed-loop robot at once: the measured frames' placements and their parameter derivatives
through the loops.

With the loops closed (:class:`~pincal.model.batch_kinematics.BatchKinematics`), the derivatives follow the
implicit-function theorem for all N samples together:

1. the spatial twists per unit parameter at fixed passive joints, of the measured frames and of both anchors of
   each loop, from the tree's batched kinematics (:meth:`~pincal.identification.tree_batch.TreeBatch.twist`: joint
   placements, fixed joints, the actuated joints' offsets and corrections) plus each anchor's own placement
   parameters;
2. the loops' residual per unit parameter ``∂c/∂θ`` (N, rows, p), from each loop's relative anchor twist
   (:meth:`~pincal.model.batch_kinematics.BatchKinematics.loop_rows`);
3. ``dv_p/dθ = −C_p⁺ ∂c/∂θ``: N stacked solves with the passive closure Jacobians (N, rows, n_passive);
4. each measured frame's twist: step 1's plus its passive joints' spatial twists times ``dv_p/dθ``.

The per-sample path (:meth:`~pincal.identification.problem.CalibrationProblem._predict_samples`) computes the same
numbers one sample at a time with Pinocchio; tests/identification/test_loop_batch.py holds them together.
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np
import numpy.typing as npt

from pincal.errors import ConvergenceError
from pincal.identification.batch import SpatialJacobian, Workspace
from pincal.identification.derivatives import KinematicSensitivity, Probe
from pincal.identification.tree_batch import Placements, TreeBatch
from pincal.model.batch_kinematics import BatchKinematics, LoopSystem, passive_gains
from pincal.model.robot import Robot

Array = npt.NDArray[np.float64]

#: The name under which each loop anchor is a probe of the tree's batched kinematics: ``<loop>|<side>`` (``|`` is
#: not in a URDF name the loader keeps apart from a frame's).
ANCHOR = "{loop}|{side}"


@dataclass(frozen=True)
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
        model = robot.model
        self.kinematics: BatchKinematics = robot.kinematics.batch
        self.anchor_names = [(ANCHOR.format(loop=loop.name, side="predecessor"),
                              ANCHOR.format(loop=loop.name, side="successor")) for loop in robot.loops]
        probes = dict(frame_ids)
        for loop, (first, second) in zip(robot.loops, self.anchor_names, strict=True):
            probes[first] = model.getFrameId(loop.predecessor)
            probes[second] = model.getFrameId(loop.successor)
        self.tree = TreeBatch(robot, probes, self.kinematics.motions)
        self.unsupported = self.kinematics.unsupported or self.tree.unsupported
        self.frame_ids = dict(frame_ids)
        self.scratch = Workspace()

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

    def twists(self, robot: Robot, sens: KinematicSensitivity, q: Array, system: LoopSystem,
               terms: list[tuple[int, int, Array]], probes: dict[str, Probe], first: int, singular_gain: float
               ) -> tuple[dict[str, Placements], dict[str, SpatialJacobian], LoopDerivatives]:
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
            Frame -> its placements; frame -> its spatial twists per unit parameter (the full (N, 6, p), factored
            with the identity); and the configurations' response to the parameters.
        """
        tree, kin, model = self.tree, self.kinematics, robot.model
        n = len(q)
        placed, origins = tree.forward(model, q)
        placements = {f: tree.frame_placement(model, placed, f, n) for f in self.frame_ids}
        gain = self.gain(system, first, singular_gain)
        # the loops' residual per unit parameter at fixed passive joints (actuated terms included)
        slopes = []
        anchors = robot.closure.anchors()
        for index, (loop, (p1, p2), names) in enumerate(zip(robot.loops, sens.anchor_probes, self.anchor_names,
                                                             strict=True)):
            ends = []
            for side, probe, name, (joint, placement) in zip(("predecessor", "successor"), (p1, p2), names,
                                                             (anchors[index][:2], anchors[index][2:]), strict=True):
                where = tree.probe_placement(placed, joint, placement, n)
                twist = tree.twist(name, probe, sens, placed, origins, where, terms).full()
                own = sens.anchor_terms.get((loop.name, side))
                if own is not None:  # the anchor's own placement parameters: Ad(oMc) · Jexp6
                    idx, jexp = own
                    twist[:, :3, idx] += (where.top.reshape(3 * n, 6) @ jexp).reshape(n, 3, len(idx))
                    twist[:, 3:, idx] += (where.rotation.reshape(3 * n, 3) @ jexp[3:]).reshape(n, 3, len(idx))
                ends.append(twist)
            slopes.append(kin.solver_rows(index, system.frames[index], ends[1] - ends[0]))
        slope = np.concatenate(slopes, axis=1)  # (N, rows, p)
        passive = kin.passive_v
        velocities = np.zeros((n, kin.nv, sens.n))
        velocities[:, passive] = -(gain @ slope)
        act_v = robot.kinematics.actuated_v
        for joint, column, regressor in terms:
            velocities[:, act_v[joint], column] = regressor
        joint_twists = kin.joint_twists(system.placements)
        twists: dict[str, SpatialJacobian] = {}
        identity = np.eye(sens.n)
        for f, probe in probes.items():
            spatial = tree.twist(f, probe, sens, placed, origins, placements[f], terms).full()
            chain = passive[kin.support[probe.joint, passive] > 0.0]
            if chain.size:
                spatial += joint_twists[:, :, chain] @ velocities[:, chain]
            twists[f] = SpatialJacobian(spatial, identity, self.scratch)
        return placements, twists, LoopDerivatives(velocities, joint_twists)

