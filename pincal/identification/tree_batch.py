"""Every sample of a tree at once: configurations, frame placements and their parameter derivatives.

A robot without loops has nothing to solve: each sample's configuration is the reference with the actuated
values (their offsets and corrections applied) written in. Forward kinematics is then a product over the
joints above the measured frames, ``oMi[j] = oMi[parent] · M_j · S_j · exp6(ξ_j v_j)`` (``M_j`` the joint's
placement at the evaluated parameters, ``v_j`` its value, ``S_j`` the constant start of a ``<mimic>`` follower's
motion), evaluated for all N samples with one array operation per step.

The parameter derivatives are *spatial* twists (:class:`~pincal.identification.measurements.BatchContext`): per
unit parameter, the velocity of the world point at the origin and the angular velocity, in the robot's world frame.
They add up over the supporting joints (the per-sample regressor of
:meth:`~pincal.identification.derivatives.KinematicSensitivity.probe_twist`, carried to the world):

- a joint placement's parameters: ``Ad(oMi[parent] · M_j) · Jexp6`` (the columns of ``joint_map``);
- an actuated joint's offset, harmonic and compliance parameters: the joint's axis ``Ad(oMi[j]) ξ_j`` (and each
  ``<mimic>`` follower's) times the sample's regressor (1, ``sin q_r``, ``τ_g(q_r)``, …);
- a fixed joint's parameters below the frame's joint: ``Ad(oMf)`` times the frame's constant local term.

Joint kinds: any joint of one coordinate (revolute, continuous, prismatic, aligned with an axis or not) and
``<mimic>`` followers of such a joint; the motion of each is read from Pinocchio once and checked. A tree with
another kind above a measured frame (a free-flyer, a spherical joint) is evaluated sample by sample.
"""

from __future__ import annotations

import threading
import weakref

import numpy as np
import numpy.typing as npt
import pinocchio as pin

from pincal.identification.batch import SpatialJacobian, Workspace
from pincal.identification.derivatives import KinematicSensitivity, Probe
from pincal.model.joint_motion import JointMotion, joint_motion, joint_value
from pincal.model.robot import Robot
from pincal.records import record

Array = npt.NDArray[np.float64]


@record(frozen=True)
class Placements:
    """One frame's placement in the world for every sample, kept as the top rows of its adjoint.

    Attributes:
        top: (N, 3, 6) ``[R | p̂ R]``: the rotation, and the translation p [m] crossed with it (a local twist's
            linear part as a spatial one, ``Ad(M) = [[R, p̂ R], [0, R]]``).
        translation: (N, 3) p [m].
    """

    top: Array
    translation: Array

    @property
    def rotation(self) -> Array:
        """(N, 3, 3) R."""
        return self.top[:, :, :3]


class TreeBatch:
    """Batched kinematics of a tree for a fixed set of measured frames (built once per problem).

    Args:
        robot: The nominal robot (no loops); its structure, not its placements, is kept.
        frame_ids: Measured frame name -> Pinocchio frame id.

    Attributes:
        unsupported: Why the batched evaluation cannot take this robot (a joint kind it does not evaluate), or None.
    """

    def __init__(self, robot: Robot, frame_ids: dict[str, int]) -> None:
        model = robot.model
        self.reference = robot.q_reference.copy()
        self.actuated = robot.kinematics.actuated
        self.frame_ids = dict(frame_ids)
        #: frame -> the id of the joint that carries it
        self.parent = {f: int(model.frames[fid].parentJoint) for f, fid in frame_ids.items()}
        self.supports = {f: [int(j) for j in model.supports[joint] if j > 0] for f, joint in self.parent.items()}
        self.joints = sorted({j for chain in self.supports.values() for j in chain})
        #: frame -> where its supporting joints are in :attr:`joints`
        self.columns = {f: np.array([self.joints.index(j) for j in chain], dtype=int)
                        for f, chain in self.supports.items()}
        self.motions: dict[int, JointMotion] = {}
        self.unsupported: str | None = None
        for j in self.joints:
            motion = joint_motion(model, j)
            if motion is None:
                self.unsupported = f"joint '{model.names[j]}' ({model.joints[j].shortname()})"
                break
            self.motions[j] = motion
        #: joint -> its turn Q (:attr:`JointMotion.turn`): the batched kinematics places each joint's frame turned by Q,
        #: so that every motion is about or along z (0: the root, not turned)
        self.turns = {0: pin.SE3.Identity(), **{j: m.turn for j, m in self.motions.items()}}
        self._unturn = {j: turn.inverse() for j, turn in self.turns.items()}  # Q_jᵀ
        self._starts = {j: m.start * self.turns[j] for j, m in self.motions.items()}  # start_j Q_j
        #: The intermediates kept from one evaluation to the next (see :class:`Workspace`).
        self.scratch = Workspace()
        self.rates = np.array([m.rate for m in self.motions.values()])
        sources = [model.joints[m.source] for m in self.motions.values()]
        self._value_columns = (np.array([jm.idx_q for jm in sources], dtype=int)
                               if all(jm.nq == 1 for jm in sources) else None)
        actuated_ids = {a.joint_id: k for k, a in enumerate(self.actuated)}
        #: joint -> index of the actuated joint whose value drives it (its own, or its leader's)
        self.driver = {j: actuated_ids[m.source] for j, m in self.motions.items() if m.source in actuated_ids}

    def configurations(self, qa: Array) -> Array:
        """(N, nq) the configurations of actuated values ``qa`` (N, na) [rad or m]: the reference with them written
        in (the per-sample solve of a tree)."""
        q = np.tile(self.reference, (len(qa), 1))
        for k, a in enumerate(self.actuated):
            if a.nq == 1:
                q[:, a.idx_q] = qa[:, k]
            else:
                q[:, a.idx_q], q[:, a.idx_q + 1] = np.cos(qa[:, k]), np.sin(qa[:, k])
        return q

    def forward(self, model: pin.Model, q: Array) -> tuple[dict[int, Placements], Array]:
        """Every sample's placement of each needed joint's turned frame ``oMi[j] · Q_j`` (its motion about or along
        z), and the adjoint's top rows of each joint's origin ``oMi[parent] · M_j`` (before its motion), at the
        evaluated parameters.

        The adjoint's top rows ``[R | p̂ R]`` propagate by one product with constants per joint (``Ad(oMi[j] Q_j) =
        Ad(oMi[parent] Q_parent) Ad(Q_parentᵀ M_j start_j Q_j) Ad(exp6(θ e_z))``); a rotation by θ about z then turns
        the column pairs (x, y) of R and of p̂ R, done as one complex product ``(c_x + i c_y) e^{−iθ}``; a slide by d
        along z adds ``d R e_z`` to p and ``d (R e_y, −R e_x)`` to the first two columns of p̂ R.

        Returns:
            Joint -> its turned frame's placements; and (N, 3, J, 6) the origins' ``[R | p̂ R]``, the joints in
            :attr:`joints` order (kept between evaluations: read it before the next one).
        """
        n = len(q)
        placed: dict[int, Placements] = {}
        origins = self.scratch.array("origins", (n, 3, len(self.joints), 6))
        if self._value_columns is not None:  # every source a joint of one coordinate: its column of q
            values = self.rates * q[:, self._value_columns]
        else:
            values = self.rates * np.stack([joint_value(model, self.motions[j].source, q) for j in self.joints],
                                           axis=1)
        phases = np.empty(values.shape, dtype=np.complex128)  # e^{−iθ}
        np.cos(values, out=phases.real)
        np.sin(-values, out=phases.imag)
        for b, j in enumerate(self.joints):
            motion = self.motions[j]
            parent = int(model.parents[j])
            origin = self._unturn[parent] * model.jointPlacements[j]
            moving = origin * self._starts[j]
            top = self.scratch.array(("top", j), (n, 3, 6))
            if parent == 0:
                origins[:, :, b] = origin.action[:3]
                top[...] = moving.action[:3]
                pos = np.tile(moving.translation, (n, 1))
            else:
                above = placed[parent]
                flat = above.top.reshape(-1, 6)
                np.matmul(flat, origin.action, out=origins[:, :, b].reshape(3 * n, 6))
                np.matmul(flat, moving.action, out=top.reshape(3 * n, 6))
                pos = (flat[:, :3] @ moving.translation).reshape(n, 3) + above.translation
            pairs = top.reshape(n, 3, 2, 3)[..., :2].view(np.complex128)[..., 0]  # (N, 3, 2): R and p̂R, x + i y
            if motion.revolute:
                pairs *= phases[:, b, None, None]
            else:
                pos += top[:, :, 2] * values[:, b, None]
                pairs[:, :, 1] += (-1j * values[:, b, None]) * pairs[:, :, 0]
            placed[j] = Placements(top, pos)
        return placed, origins

    def frame_placement(self, model: pin.Model, placed: dict[int, Placements], frame: str, n: int) -> Placements:
        """The placement of a measured frame in the world for every sample."""
        joint = self.parent[frame]
        local = self._unturn[joint] * model.frames[self.frame_ids[frame]].placement
        if joint == 0:
            return Placements(np.tile(local.action[:3], (n, 1, 1)), np.tile(local.translation, (n, 1)))
        above = placed[joint]
        flat = above.top.reshape(-1, 6)
        return Placements((flat @ local.action).reshape(n, 3, 6),
                          (flat[:, :3] @ local.translation).reshape(n, 3) + above.translation)

    def twist(self, frame: str, probe: Probe, sens: KinematicSensitivity, placed: dict[int, Placements],
              origins: Array, placement: Placements, terms: list[tuple[int, int, Array]]) -> SpatialJacobian:
        """The spatial twist of ``frame`` per unit parameter, factored (see the module docstring).

        Its generators: the six local directions at each supporting joint's origin (right factor: the joint's rows
        of ``joint_map``, zero for a joint without placement parameters), the six local directions of the frame
        itself when fixed joints above it have parameters (right factor: their constant local twists), each actuated
        joint's axis (with its ``<mimic>`` followers'; right factor: the columns of its offset terms, whose regressor
        is 1) and that axis times each other term's regressor (right factor: the term's column).

        Args:
            frame: The measured frame.
            probe: Its probe at this estimate (:func:`~pincal.identification.derivatives.frame_probe` of the robot
                at the evaluated parameters), alive for the evaluation (``sens`` caches its terms by identity).
            sens: The parameter derivatives at this estimate (its ``joint_map`` and the frame's fixed-joint terms).
            placed: Each joint's placement in the world, from :meth:`forward`.
            origins: The joints' origins, from :meth:`forward`.
            placement: The frame's placement, from :meth:`frame_placement`.
            terms: (actuated joint index, column, (N,) regressor): the actuated joint's value moves by the regressor
                per unit of that column's parameter.
        """
        n = len(placement.translation)
        chain = self.supports[frame]
        drivers: dict[int, list[int]] = {}  # actuated joint -> the joints of the chain its value moves
        for j in chain:
            if j in self.driver:
                drivers.setdefault(self.driver[j], []).append(j)
        moving = [(k, column, regressor) for k, column, regressor in terms if k in drivers]
        axes = list(dict.fromkeys(k for k, _, _ in moving))  # the actuated joints with terms
        unit = [bool(np.all(regressor == 1.0)) for _, _, regressor in moving]  # an offset: the axis itself
        scaled = [term for term, one in zip(moving, unit, strict=True) if not one]
        fixed = sens.fixed_terms(probe)
        adjoints = 6 * len(chain) + (6 if fixed else 0)
        width = adjoints + len(axes) + len(scaled)
        # kept for this layout of blocks, whose lower left corners (zero) are never written
        left = self.scratch.array(("left", frame, len(axes), len(scaled), bool(fixed)), (n, 6, width))
        right = np.zeros((width, sens.n))
        if chain:
            own = origins if len(chain) == len(self.joints) else np.take(origins, self.columns[frame], axis=2)
            left[:, :3, :6 * len(chain)] = own.reshape(n, 3, -1)
            left[:, 3:, :6 * len(chain)].reshape(n, 3, len(chain), 6)[..., 3:] = own[..., :3]
            for b, j in enumerate(chain):
                right[6 * b:6 * b + 6] = sens.joint_map[6 * (j - 1):6 * j]
        if fixed:
            _write_adjoint(left[:, :, adjoints - 6:adjoints], placement)
            for idx, term in fixed:
                right[adjoints - 6:adjoints, idx] += term
        for a, k in enumerate(axes, start=adjoints):  # the axis as a spatial twist, Ad(oMi[j] Q_j) · rate · e_z
            for m, j in enumerate(drivers[k]):
                motion, top = self.motions[j], placed[j].top
                linear, angular = (top[:, :, 5], top[:, :, 2]) if motion.revolute else (top[:, :, 2], None)
                if m == 0:
                    np.multiply(linear, motion.rate, out=left[:, :3, a])
                    left[:, 3:, a] = 0.0 if angular is None else motion.rate * angular
                else:  # a <mimic> follower moves with its leader
                    left[:, :3, a] += motion.rate * linear
                    if angular is not None:
                        left[:, 3:, a] += motion.rate * angular
        row = {k: adjoints + a for a, k in enumerate(axes)}
        for (k, column, _), one in zip(moving, unit, strict=True):
            if one:
                right[row[k], column] = 1.0
        if scaled:
            first = adjoints + len(axes)
            which = np.array([row[k] for k, _, _ in scaled])
            regressors = np.stack([regressor for _, _, regressor in scaled], axis=1)
            np.multiply(np.take(left, which, axis=2), regressors[:, None, :], out=left[:, :, first:])
            right[np.arange(first, width), [column for _, column, _ in scaled]] = 1.0
        return SpatialJacobian(left, right, self.scratch)


#: Each robot's batched kinematics, by its measured frames: built once (its joints' motions read from Pinocchio), shared
#: by every problem on the robot (a fit's refits, each fold of a cross-validation, the hold-outs, the searches).
_BUILT: weakref.WeakKeyDictionary[Robot, dict[tuple[tuple[str, int], ...], TreeBatch]] = weakref.WeakKeyDictionary()


_BUILDING = threading.Lock()


def tree_batch(robot: Robot, frame_ids: dict[str, int]) -> TreeBatch:
    """The :class:`TreeBatch` of ``robot`` (the nominal one, no loops) for the measured frames ``frame_ids`` (name ->
    Pinocchio frame id), built on first use and shared afterwards, by every thread: it keeps the robot's structure
    only, and its scratch arrays, one set per thread, are overwritten by each evaluation in that thread, whichever
    problem makes it."""
    key = tuple(sorted(frame_ids.items()))
    with _BUILDING:
        built = _BUILT.setdefault(robot, {})
        if key not in built:
            built[key] = TreeBatch(robot, frame_ids)
        return built[key]


def _write_adjoint(out: Array, placement: Placements) -> None:
    """Write the adjoints ``[[R, p̂ R], [0, R]]`` (N, 6, 6) of ``placement`` into ``out``, whose lower left block is
    zero already."""
    out[:, :3] = placement.top
    out[:, 3:, 3:] = placement.rotation
