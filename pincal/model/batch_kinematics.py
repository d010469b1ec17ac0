"""Closed-loop kinematics of many samples at once: forward kinematics, loop residuals and Jacobians, Newton steps.

The per-sample solvers of :mod:`pincal.model.kinematics` spend most of their time in Python around small Pinocchio
calls. Here every sample of a batch moves together: forward kinematics is a product over the joints,
``oMi[j] = oMi[parent] · M_j · exp6(ξ_j v_j)``, a few array operations per joint for all N samples (the joint placements
``M_j`` read from the model at each call, so one instance serves every parameter estimate); each loop's residual and
exact Jacobian follow from its anchors' placements and the joints' *spatial* twists (per unit velocity, the velocity
of the world point at the origin moving with the joint's child and its angular velocity, in the world frame); the
Newton step solves N small systems ``C_p δv_p = −c`` at once (stacked LAPACK solves).

The rows, for a loop with anchors c1 (predecessor) and c2 (successor), ``c1Mc2 = (R, p)`` and a relative spatial
twist ``ΔW = W₂ − W₁`` of the anchors' bodies (:mod:`pincal.model.closure` gives the same rows from Pinocchio's
anchor Jacobians): ``dp = R₁ᵀ (ΔW_v − p₂ × ΔW_ω)``, and the body angular velocity of c2 relative to c1,
``ω_b = R₂ᵀ ΔW_ω``, enters as ``Jlog3(R) ω_b`` (fixed, prismatic) or ``−Eᵀ R [a]× ω_b`` (revolute).

The answers are those of the per-sample solvers, on the same assembly: a warm start is kept only when its Newton
iterates move no passive coordinate by more than :data:`~pincal.model.kinematics.CONTINUATION_STEP` (as
:meth:`~pincal.model.kinematics.ClosedLoopKinematics.warm_solve`), a cold start is continuation from the reference
configuration in the same steps as :meth:`~pincal.model.kinematics.ClosedLoopKinematics.continuation`. A sample
these do not close is reported, never dropped: the caller solves it alone (continuation with finer steps).

Joint kinds: joints of one coordinate and one velocity (revolute, prismatic, aligned with an axis or not) and
free-flyers (a platform: its placement from its quaternion and translation, its six local velocities, moved by
``t + R v`` and ``R exp3(ω)``); a robot with another kind (a spherical joint, a continuous joint, a ``<mimic>``
follower) reports it in :attr:`BatchKinematics.unsupported` and is solved sample by sample.
"""

from __future__ import annotations

import math
from dataclasses import dataclass

import numpy as np
import numpy.typing as npt
import pinocchio as pin

from pincal.model.closure import LoopClosure, normal_basis
from pincal.model.joint_motion import joint_motion
from pincal.model.kinematics import CONTINUATION_STEP, MAX_CONTINUATION_STEPS, ClosedLoopKinematics
from pincal.model.rotations import cross_columns, jlog3, log3, quaternion_matrices, skew

Array = npt.NDArray[np.float64]
BoolArray = npt.NDArray[np.bool_]
IntArray = npt.NDArray[np.intp]

#: Largest closure residual component [m, rad] past which a Newton solve gives up (as the per-sample one).
DIVERGED = 1e3
#: Largest closure residual component [m, rad] of the answers of :meth:`BatchKinematics.continuation` (a first solve):
#: closer than the solvers' tolerance, as these answers are the origin of every later warm start and of simulated
#: data (a noise-free study recovers its parameters to 1e-9 from them); Newton's quadratic convergence makes it one
#: more pass at most, and a sample that cannot reach it is solved alone (to the solvers' tolerance).
FIRST_SOLVE_TOLERANCE = 1e-13


@dataclass(frozen=True)
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


@dataclass(frozen=True)
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


@dataclass(frozen=True)
class LoopState:
    """The loops of N samples at their configurations: residual, Jacobian (if asked), anchor frames."""

    placements: JointPlacements
    frames: list[LoopFrames]
    residual: Array  # (N, rows) [m, rad]
    jacobian: Array | None  # (N, rows, nv)
    axes: Array | None  # (N, 6, nv) each velocity coordinate's spatial twist


@dataclass(frozen=True)
class Geometry:
    """The placements one robot's parameters give, read once from its model and loops (the constants of
    :meth:`BatchKinematics.forward` and :meth:`BatchKinematics.loop_frames`).

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


@dataclass(frozen=True)
class LoopSystem:
    """The loops of N samples linearised at closed configurations (:meth:`BatchKinematics.linearised`).

    Attributes:
        placements: The joints' placements.
        frames: Each loop's anchor frames.
        passive: (N, rows, n_passive) ``C_p``, the spherical loops' rows in the world frame
            (:meth:`BatchKinematics.solver_rows`).
    """

    placements: JointPlacements
    frames: list[LoopFrames]
    passive: Array


class BatchKinematics:
    """Batched closed-loop kinematics for one robot structure (built once; placements read at each call).

    Args:
        kinematics: The per-sample kinematics whose structure (joints, loops, actuated joints, reference
            configuration) this batches; any model and closure with the same structure may be passed to the methods
            (a robot at other parameters).

    Attributes:
        unsupported: Why this structure cannot be batched (the first joint of another kind), or None.
    """

    def __init__(self, kinematics: ClosedLoopKinematics) -> None:
        model = kinematics.model
        self.kinematics = kinematics
        self.reference = kinematics.reference.copy()
        self.nq, self.nv, self.njoints = model.nq, model.nv, model.njoints
        self.parents = [int(model.parents[j]) for j in range(model.njoints)]
        self.unsupported: str | None = None
        self.passive_v: IntArray = kinematics.passive_v
        self.actuated_v: IntArray = kinematics.actuated_v
        self.specs = list(kinematics.closure.specs)
        self.bases = [normal_basis(spec.axis) for spec in self.specs]
        self.rows = kinematics.closure.rows
        n = model.njoints - 1
        self.idx_q = np.zeros(n, dtype=np.intp)
        self.idx_v = np.zeros(n, dtype=np.intp)
        self.rates = np.zeros(n)  # a joint of one coordinate's motion per unit value [rad or m per rad or m]
        self.revolute = np.zeros(n, dtype=bool)
        self.free = np.zeros(n, dtype=bool)  # a free-flyer (a parallel robot's platform)
        self.starts: list[pin.SE3] = []
        self.turns: list[pin.SE3] = []
        # per velocity coordinate: the joint (id) it moves, the column of that joint's turned frame along or about
        # which it moves, at what rate, and whether it turns (about that column's axis through the joint's origin)
        self.column_joint = np.zeros(model.nv, dtype=np.intp)
        self.column_axis = np.zeros(model.nv, dtype=np.intp)
        self.column_rate = np.ones(model.nv)
        self.column_revolute = np.zeros(model.nv, dtype=bool)
        for j in range(1, model.njoints):
            jm = model.joints[j]
            self.idx_q[j - 1], self.idx_v[j - 1] = jm.idx_q, jm.idx_v
            if jm.shortname() == "JointModelFreeFlyer":  # local velocity: linear along, angular about the axes
                self.free[j - 1] = True
                self.starts.append(pin.SE3.Identity())
                self.turns.append(pin.SE3.Identity())
                columns = slice(jm.idx_v, jm.idx_v + 6)
                self.column_joint[columns] = j
                self.column_axis[columns] = [0, 1, 2, 0, 1, 2]
                self.column_revolute[columns] = [False, False, False, True, True, True]
                continue
            motion = joint_motion(model, j) if jm.nq == 1 and jm.nv == 1 else None
            if motion is None or motion.source != j:
                self.unsupported = f"joint '{model.names[j]}' ({jm.shortname()})"
                break
            self.rates[j - 1], self.revolute[j - 1] = motion.rate, motion.revolute
            self.starts.append(motion.start)
            self.turns.append(motion.turn)
            self.column_joint[jm.idx_v], self.column_axis[jm.idx_v] = j, 2
            self.column_rate[jm.idx_v], self.column_revolute[jm.idx_v] = motion.rate, motion.revolute
        if self.unsupported is None and not all(a.nq == 1 for a in kinematics.actuated):
            self.unsupported = "a continuous actuated joint"
        self.unturn = [pin.SE3.Identity()] + [turn.inverse() for turn in self.turns]
        if self.unsupported is not None:
            return
        # which velocity coordinates move each joint (its supports)
        self.support = np.zeros((model.njoints, model.nv))
        for j in range(1, model.njoints):
            for s in model.supports[j]:
                if s > 0:
                    self.support[j, self.column_joint == s] = 1.0
        # start_j Q_j; Q_jᵀ by joint id above (the root and a free-flyer not turned)
        self._starts = [start * turn for start, turn in zip(self.starts, self.turns, strict=True)]
        self.actuated_q = np.array([a.idx_q for a in kinematics.actuated], dtype=np.intp)
        self._one = np.flatnonzero(~self.free)  # joints (id − 1) of one coordinate
        self._free = np.flatnonzero(self.free)
        # the passive coordinates: those of joints of one coordinate (q and v alike), and the free-flyers
        passive = set(self.passive_v.tolist())
        scalar = [c for c in self.passive_v.tolist() if not self.free[self.column_joint[c] - 1]]
        self._scalar_q = np.array([self.idx_q[self.column_joint[c] - 1] for c in scalar], dtype=np.intp)
        order: list[int] = self.passive_v.tolist()
        self._scalar_columns = np.array([order.index(c) for c in scalar], dtype=np.intp)
        self._free_passive = [(int(self.idx_q[b]), order.index(int(self.idx_v[b])))
                              for b in np.flatnonzero(self.free) if int(self.idx_v[b]) in passive]
        self._passive_revolute = self.column_revolute[self.passive_v]
        # the kinematics of the last Newton pass, when it closed every sample, and of the last warm solve that did so
        # (its model and loops, held so that they stay the same objects, the answers, the placements and frames)
        self._last_pass: tuple[JointPlacements, list[LoopFrames]] | None = None
        self._closed: tuple[pin.Model, LoopClosure, Array, JointPlacements, list[LoopFrames]] | None = None
        # each loop's motion per unit joint velocity: +1 moving its successor anchor, −1 its predecessor's
        anchors = kinematics.closure.anchors()
        self._signs = np.array([self.support[j2] - self.support[j1] for j1, _, j2, _ in anchors]).reshape(-1, model.nv)
        self._spherical = [k for k, spec in enumerate(self.specs) if spec.type == "spherical"]
        # the (loop, passive joint) pairs of the spherical loops where the joint moves the loop, revolute and
        # prismatic: rows (3, P) and columns (3, P) of C_p, the loop (among the spherical ones), the sign
        pairs: dict[bool, list[tuple[int, int, int, float]]] = {True: [], False: []}
        for rank, index in enumerate(self._spherical):
            start = sum(spec.rows for spec in self.specs[:index])
            for column, v in enumerate(self.passive_v):
                if self._signs[index, v] != 0.0:
                    pairs[bool(self._passive_revolute[column])].append((start, column, rank, self._signs[index, v]))
        self._turning, self._sliding = (
            (np.arange(3)[:, None] + np.array([p[0] for p in pairs[kind]], dtype=np.intp),
             np.broadcast_to(np.array([p[1] for p in pairs[kind]], dtype=np.intp), (3, len(pairs[kind]))),
             np.array([p[2] for p in pairs[kind]], dtype=np.intp), np.array([p[3] for p in pairs[kind]]))
            for kind in (True, False))
        starts = np.cumsum([0] + [spec.rows for spec in self.specs])
        self._spherical_rows = np.concatenate([np.arange(starts[k], starts[k] + 3) for k in self._spherical]
                                              ).astype(np.intp) if self._spherical else np.zeros(0, dtype=np.intp)

    # --- forward kinematics -----------------------------------------------------------------------
    def geometry(self, model: pin.Model, closure: LoopClosure) -> Geometry:
        """The constant placements of ``model`` and ``closure`` (a robot at some parameters) this structure needs."""
        rotations, translations = np.empty((self.njoints - 1, 3, 3)), np.empty((self.njoints - 1, 3))
        for j in range(1, self.njoints):
            fixed = self.unturn[self.parents[j]] * model.jointPlacements[j] * self._starts[j - 1]
            rotations[j - 1], translations[j - 1] = fixed.rotation, fixed.translation
        anchors = []
        for j1, m1, j2, m2 in closure.anchors():
            c1, c2 = self.unturn[j1] * m1, self.unturn[j2] * m2  # the anchors on the turned frames
            anchors.append((j1, c1.rotation, c1.translation, j2, c2.rotation, c2.translation))
        constants = np.zeros((self.njoints - 1, 4, 4))
        constants[:, :3, :3] = rotations
        constants[:, :3, 3] = translations
        constants[:, 3, 3] = 1.0
        return Geometry(rotations, translations, anchors, constants)

    def forward(self, geometry: Geometry, q: Array) -> JointPlacements:
        """Every joint's turned frame in the world at configurations ``q`` (N, nq), with the placements of
        ``geometry`` (:meth:`geometry`).

        ``oMi[j] Q_j = oMi[parent] Q_parent · (Q_parentᵀ M_j start_j Q_j) · exp(θ e_z)``: one matrix product with a
        constant per joint (``[R | p]`` of all samples at once, (3N × 4) · (4 × 4)), then a rotation by θ about z
        turns the first two columns, ``c_x + i c_y ← (c_x + i c_y) e^{−iθ}`` (one complex product); a slide by d along
        z adds ``d · c_z`` to the origin.
        """
        n = len(q)
        frames = np.empty((self.njoints, n, 3, 4))
        frames[0, :, :, :3] = np.eye(3)
        frames[0, :, :, 3] = 0.0
        values = np.zeros((n, self.njoints - 1))
        values[:, self._one] = q[:, self.idx_q[self._one]] * self.rates[self._one]
        phases = np.empty(values.shape, dtype=np.complex128)  # e^{−iθ}
        np.cos(values, out=phases.real)
        np.sin(-values, out=phases.imag)
        constants = geometry.constants  # [R | p] · [[R_c, t_c], [0, 1]] = [R R_c | R t_c + p]: one product per joint
        flat = frames.reshape(self.njoints, 3 * n, 4)  # views into frames
        origins, axes = frames[:, :, :, 3], frames[:, :, :, 2]
        pairs = frames[:, :, :, :2].view(np.complex128)[..., 0]  # (njoints, N, 3): c_x + i c_y
        for j in range(1, self.njoints):
            b = j - 1
            np.matmul(flat[self.parents[j]], constants[b], out=flat[j])
            if self.free[b]:  # · [R(quaternion) | translation], per sample
                start = self.idx_q[b]
                above = frames[j].copy()
                frames[j, :, :, :3] = above[:, :, :3] @ quaternion_matrices(q[:, start + 3:start + 7])
                frames[j, :, :, 3] = (above[:, :, :3] @ q[:, start:start + 3, None])[..., 0] + above[:, :, 3]
            elif self.revolute[b]:
                pairs[j] *= phases[:, b, None]
            else:
                origins[j] += axes[j] * values[:, b, None]
        return JointPlacements(frames)

    def joint_twists(self, placements: JointPlacements, columns: IntArray | None = None) -> Array:
        """(N, 6, k) the spatial twists of velocity coordinates ``columns`` (all nv by default), per unit velocity:
        the velocity [m/s] of the world point at the origin moving with the joint's child, and its angular velocity
        [rad/s], in the world frame. A revolute coordinate turns about its axis ``ω`` through the joint's origin
        ``o`` (``(o × ω, ω)``), a prismatic one slides along it (``(ω, 0)``)."""
        chosen = np.arange(self.nv) if columns is None else columns
        frames = placements.frames
        direction = frames[self.column_joint[chosen], :, :, self.column_axis[chosen]]  # (k, N, 3)
        direction = direction * self.column_rate[chosen][:, None, None]
        revolute = self.column_revolute[chosen][:, None, None]
        linear = np.where(revolute, _cross(frames[self.column_joint[chosen], :, :, 3], direction), direction)
        twists = np.empty((direction.shape[1], 6, len(chosen)))
        twists[:, :3] = linear.transpose(1, 2, 0)
        twists[:, 3:] = np.where(revolute, direction, 0.0).transpose(1, 2, 0)
        return twists

    # --- loops --------------------------------------------------------------------------------------
    def loop_frames(self, geometry: Geometry, placements: JointPlacements) -> list[LoopFrames]:
        """Each loop's anchor frames at ``placements``, with the anchor placements of ``geometry``."""
        result = []
        frames = placements.frames
        n = frames.shape[1]
        for spec, (j1, r1c, t1c, j2, r2c, t2c) in zip(self.specs, geometry.anchors, strict=True):
            above_1, above_2 = frames[j1, :, :, :3].reshape(3 * n, 3), frames[j2, :, :, :3].reshape(3 * n, 3)
            r1 = (above_1 @ r1c).reshape(n, 3, 3)
            gap = (above_2 @ t2c).reshape(n, 3) + frames[j2, :, :, 3]
            p2 = gap.copy()
            gap -= (above_1 @ t1c).reshape(n, 3)
            gap -= frames[j1, :, :, 3]
            offset = np.einsum("nji,nj->ni", r1, gap)
            if spec.type == "spherical":
                result.append(LoopFrames(r1, p2, offset, None, None, None, gap))
                continue
            r2 = (above_2 @ r2c).reshape(n, 3, 3)
            relative = np.einsum("nji,njk->nik", r1, r2)
            result.append(LoopFrames(r1, p2, offset, r2, relative,
                                     log3(relative) if spec.type in ("fixed", "prismatic") else None, gap))
        return result

    def state(self, model: pin.Model, closure: LoopClosure, q: Array, jacobian: bool = True) -> LoopState:
        """Forward kinematics, the loops' residual and (if ``jacobian``) its Jacobian ``dc/dv`` at ``q`` (N, nq)."""
        geometry = self.geometry(model, closure)
        placements = self.forward(geometry, q)
        frames = self.loop_frames(geometry, placements)
        residual = self._residual(frames)
        if not jacobian:
            return LoopState(placements, frames, residual, None, None)
        twists = self.joint_twists(placements)
        jac = np.empty((len(q), self.rows, self.nv))
        start = 0
        for index, (frame, anchor) in enumerate(zip(frames, geometry.anchors, strict=True)):
            relative = twists * (self.support[anchor[3]] - self.support[anchor[0]])
            stop = start + self.specs[index].rows
            jac[:, start:stop] = self.loop_rows(index, frame, relative)
            start = stop
        return LoopState(placements, frames, residual, jac, twists)

    def linearised(self, model: pin.Model, closure: LoopClosure, q: Array) -> LoopSystem:
        """The loops at closed configurations ``q`` (N, nq), for the implicit-function theorem: placements, anchor
        frames, and ``C_p`` with the spherical loops' rows in the world frame (:meth:`solver_rows`)."""
        geometry = self.geometry(model, closure)
        closed, self._closed = self._closed, None
        if closed is not None and closed[0] is model and closed[1] is closure and np.array_equal(closed[2], q):
            placements, frames = closed[3], closed[4]  # the last warm solve's final pass, at these very q
        else:
            placements = self.forward(geometry, q)
            frames = self.loop_frames(geometry, placements)
        return LoopSystem(placements, frames, self._newton_system(geometry, placements, frames))

    def solver_rows(self, index: int, frame: LoopFrames, relative: Array) -> Array:
        """:meth:`loop_rows`, with a spherical loop's in the world frame (``R₁`` times its rows): the rows of the Newton
        steps and of :meth:`linearised`. Rotating a block of rows changes neither ``C_p⁻¹ c`` nor a least-squares
        solution, and spares a product per loop."""
        if self.specs[index].type == "spherical":
            rows: Array = relative[:, :3] - cross_columns(frame.p2, relative[:, 3:])
            return rows
        return self.loop_rows(index, frame, relative)

    def _residual(self, frames: list[LoopFrames]) -> Array:
        """(N, rows) the stacked residual [m, rad] (:mod:`pincal.model.closure`'s rows)."""
        return np.hstack([self._loop_residual(index, frame) for index, frame in enumerate(frames)])

    def _loop_residual(self, index: int, frame: LoopFrames) -> Array:
        """(N, rows) loop ``index``'s residual [m, rad]."""
        spec, basis, p = self.specs[index], self.bases[index], frame.relative_translation
        if spec.type == "spherical":
            return p
        if spec.type == "revolute":
            assert frame.relative_rotation is not None
            return np.hstack([p, (frame.relative_rotation @ spec.axis) @ basis])
        assert frame.log is not None
        return np.hstack([p if spec.type == "fixed" else p @ basis, frame.log])

    def loop_rows(self, index: int, frame: LoopFrames, relative: Array) -> Array:
        """(N, rows, k) loop ``index``'s residual rows per unit of k motions, from the anchors' relative spatial twist
        ``ΔW = W₂ − W₁`` (N, 6, k) (see the module docstring)."""
        world = relative[:, :3] - cross_columns(frame.p2, relative[:, 3:])
        linear: Array = np.einsum("nji,njk->nik", frame.r1, world)
        kind, axis, basis = self.specs[index].type, self.specs[index].axis, self.bases[index]
        if kind == "spherical":
            return linear
        assert frame.r2 is not None and frame.relative_rotation is not None
        body = np.einsum("nji,njk->nik", frame.r2, relative[:, 3:])
        if kind == "revolute":
            turn = basis.T @ frame.relative_rotation @ pin.skew(axis)
            return np.concatenate([linear, -(turn @ body)], axis=1)
        assert frame.log is not None
        angular = jlog3(frame.log) @ body
        if kind == "fixed":
            return np.concatenate([linear, angular], axis=1)
        return np.concatenate([basis.T @ linear, angular], axis=1)  # prismatic

    # --- Newton -------------------------------------------------------------------------------------
    def close_loops(self, model: pin.Model, closure: LoopClosure, q: Array, tol: Array | float,
                    max_iter: int = 30, max_step: float = 0.5, max_move: float = math.inf
                    ) -> tuple[Array, Array, BoolArray]:
        """Newton over the passive joints of every sample from ``q`` (N, nq), actuated values held.

        Each iteration rebuilds every unconverged sample's Jacobian and solves its step (a true Newton step: the
        per-sample solver's chord steps save Pinocchio calls, here the Jacobian costs about as much as the residual).
        A spherical loop's rows enter the step in the world frame (``p₂ − p₁`` and its Jacobian): the same step, as
        rotating a block of rows changes neither the solution of a square system nor a least-squares one.

        Args:
            model: The robot's model (at the parameters to solve for).
            closure: Its loops.
            q: (N, nq) start configurations, actuated values set.
            tol: Largest accepted closure residual component [m, rad], one or one per sample.
            max_iter: Most Newton iterations.
            max_step: Largest norm of one step over the passive velocities [rad or m].
            max_move: Largest change of any passive coordinate from ``q`` [rad or m]; a sample that goes farther
                stops unconverged (a jump).

        Returns:
            The configurations reached (N, nq), the residual reached (N,) (largest component [m, rad]), and which
            samples converged (N,).
        """
        return self._close_loops(self.geometry(model, closure), q, tol, max_iter, max_step, max_move)

    def _close_loops(self, geometry: Geometry, q: Array, tol: Array | float, max_iter: int = 30,
                     max_step: float = 0.5, max_move: float = math.inf, origin: Array | None = None
                     ) -> tuple[Array, Array, BoolArray]:
        q = np.array(q, dtype=float)
        n = len(q)
        tols = np.broadcast_to(np.asarray(tol, dtype=float), (n,))
        norms = np.full(n, math.inf)
        converged = np.zeros(n, dtype=bool)
        start = q.copy() if origin is None else origin  # where max_move is measured from
        active = np.arange(n)
        self._last_pass = None
        for it in range(max_iter + 1):
            if not active.size:
                break
            placements = self.forward(geometry, q[active])
            frames = self.loop_frames(geometry, placements)
            norm = np.abs(self._residual(frames)).max(axis=1)
            norms[active] = norm
            done = norm <= tols[active]
            converged[active[done]] = True
            going = ~done & np.isfinite(norm) & (norm <= DIVERGED) & (it < max_iter)
            if not np.any(going):
                # every sample closed in this pass: its kinematics are the answers' (kept for linearised)
                self._last_pass = (placements, frames) if active.size == n and np.all(done) else None
                break
            if not np.all(going):
                placements = placements.take(going)
                frames = [_take(frame, going) for frame in frames]
            active = active[going]
            # a full Newton step: here a Jacobian costs about one forward kinematics pass, and chord steps (the
            # per-sample solver's, where it costs several) took twice the iterations in continuation
            gains = passive_gains(self._newton_system(geometry, placements, frames))
            step = -np.einsum("nij,nj->ni", gains, self._newton_residual(frames))
            size = np.sqrt(np.einsum("ni,ni->n", step, step))
            step *= np.minimum(1.0, max_step / np.where(size > 0.0, size, 1.0))[:, None]
            finite = np.all(np.isfinite(step), axis=1)
            q[active] = self.retract(q[active], np.where(finite[:, None], step, 0.0))
            if math.isfinite(max_move):
                finite &= np.abs(self.passive_difference(q[active], start[active])).max(axis=1) <= max_move
            active = active[finite]  # a singular step or a jump: stops there, unconverged
        return q, norms, converged

    def _newton_residual(self, frames: list[LoopFrames]) -> Array:
        """(N, rows) the residual in the rows of :meth:`_newton_system` (the spherical loops' in the world frame)."""
        return np.hstack([frame.gap if spec.type == "spherical" else self._loop_residual(index, frame)
                          for index, (spec, frame) in enumerate(zip(self.specs, frames, strict=True))])

    def _newton_system(self, geometry: Geometry, placements: JointPlacements, frames: list[LoopFrames]
                       ) -> Array:
        """``C_p`` (N, rows, n_passive), the closure Jacobian's passive columns, with the spherical loops' rows in
        the world frame: for a revolute joint of unit velocity ``ω`` through ``o``, the
        anchor point ``p₂`` moves (relative to c1's body) by ``± ω × (p₂ − o)``; for a prismatic one by ``± ω``
        (all spherical loops at once)."""
        n = placements.frames.shape[1]
        jacobian = np.zeros((n, self.rows, len(self.passive_v)))
        spherical = self._spherical
        if spherical:
            frames_all = placements.frames
            joints, axes = self.column_joint[self.passive_v], self.column_axis[self.passive_v]
            # ω (revolute) or the slide direction (prismatic), (N, 3, n_passive)
            velocity = (frames_all[joints, :, :, axes] * self.column_rate[self.passive_v][:, None, None]
                        ).transpose(1, 2, 0)
            rows, cols, loops, signs = self._turning
            if cols.size:  # ± ω × (p₂ − o), for the (loop, joint) pairs where the joint moves the loop
                anchors = np.stack([frames[index].p2 for index in spherical], axis=2)  # (N, 3, L)
                turning = velocity[:, :, cols[0]]
                offset = anchors[:, :, loops] - frames_all[joints[cols[0]], :, :, 3].transpose(1, 2, 0)
                moved = np.empty(turning.shape)
                for i, (a, b) in enumerate(((1, 2), (2, 0), (0, 1))):
                    moved[:, i] = turning[:, a] * offset[:, b] - turning[:, b] * offset[:, a]
                jacobian[:, rows, cols] = moved * signs
            rows, cols, _, signs = self._sliding
            if cols.size:
                jacobian[:, rows, cols] = velocity[:, :, cols[0]] * signs
        start, twists = 0, None
        for index, frame in enumerate(frames):
            stop = start + self.specs[index].rows
            if self.specs[index].type != "spherical":
                if twists is None:
                    twists = self.joint_twists(placements, self.passive_v)
                jacobian[:, start:stop] = self.loop_rows(index, frame, twists * self._signs[index, self.passive_v])
            start = stop
        return jacobian

    def retract(self, q: Array, step: Array) -> Array:
        """``q ⊕ step`` for passive velocities ``step`` (N, n_passive) [rad or m]: added to a joint of one coordinate;
        a free-flyer moves by ``t ← t + R v``, ``R ← R exp3(ω)`` (its local velocity, as Pinocchio's ``integrate`` to
        first order: Newton's answers are the same)."""
        q = np.array(q, dtype=float)
        q[:, self._scalar_q] += step[:, self._scalar_columns]
        for start, column in self._free_passive:
            quaternion = q[:, start + 3:start + 7]
            q[:, start:start + 3] += (quaternion_matrices(quaternion) @ step[:, column:column + 3, None])[..., 0]
            q[:, start + 3:start + 7] = _turn_quaternion(quaternion, step[:, column + 3:column + 6])
        return q

    def passive_difference(self, q: Array, origin: Array) -> Array:
        """(N, n_passive) the passive velocities [rad or m] from ``origin`` to ``q`` (N, nq), Pinocchio's
        ``difference``: a joint of one coordinate's change; a free-flyer's ``log6(M_origin⁻¹ M)``."""
        out = np.empty((len(q), len(self.passive_v)))
        out[:, self._scalar_columns] = q[:, self._scalar_q] - origin[:, self._scalar_q]
        for start, column in self._free_passive:
            rotation = quaternion_matrices(origin[:, start + 3:start + 7])
            relative = np.swapaxes(rotation, 1, 2) @ quaternion_matrices(q[:, start + 3:start + 7])
            angular = log3(relative)
            moved = (np.swapaxes(rotation, 1, 2) @ (q[:, start:start + 3] - origin[:, start:start + 3])[..., None])
            out[:, column:column + 3] = _inverse_left_jacobian(angular, moved[..., 0])
            out[:, column + 3:column + 6] = angular
        return out

    def actuated_values(self, q: Array) -> Array:
        """(N, na) actuated values [rad or m] of configurations ``q`` (N, nq)."""
        values: Array = q[:, self.actuated_q]
        return values

    def warm_solve(self, model: pin.Model, closure: LoopClosure, q_actuated: Array, guesses: Array,
                   tol: float, predicted: Array | None = None) -> tuple[Array, BoolArray]:
        """Newton from each guess with its actuated values set (:meth:`ClosedLoopKinematics.warm_solve` for every
        sample): refused (not converged) when the guess is more than one continuation step away in actuated values,
        or when Newton fails or moves a passive coordinate by more than one step from the guess.

        Args:
            model: The robot's model (at the parameters to solve for).
            closure: Its loops.
            q_actuated: (N, na) actuated values [rad or m].
            guesses: (N, nq) closed configurations, each a previous answer near the sample's.
            tol: Largest accepted closure residual component [m, rad].
            predicted: (N, n_passive) a first-order prediction of each sample's passive joints' change from its guess
                [rad or m] (the calibration's: the configuration's response to the parameters times their change), or
                None. Newton starts there; the refusals still measure from the guess.

        Returns:
            (N, nq) configurations and (N,) which are answers (the others: solve them alone).
        """
        span = np.abs(self.kinematics.actuated_delta(q_actuated, self.actuated_values(guesses))).max(axis=1,
                                                                                                    initial=0.0)
        near = span <= CONTINUATION_STEP  # NaN compares False: refused too
        q = np.array(guesses, dtype=float)
        ok = np.zeros(len(q), dtype=bool)
        rows = np.flatnonzero(near)
        if rows.size:
            start = q[rows]
            start[:, self.actuated_q] = q_actuated[rows]
            origin = start.copy()
            if predicted is not None:
                start = self.retract(start, predicted[rows])
            solved, _, converged = self._close_loops(self.geometry(model, closure), start, tol,
                                                     max_move=CONTINUATION_STEP, origin=origin)
            q[rows] = solved
            ok[rows] = converged
            if self._last_pass is not None:
                self._closed = (model, closure, solved, *self._last_pass)
        return q, ok

    def continuation(self, model: pin.Model, closure: LoopClosure, q_actuated: Array, tol: float
                     ) -> tuple[Array, BoolArray]:
        """The reference assembly for every sample: continuation from the reference configuration in
        ``max(1, ⌈max|Δq_a| / CONTINUATION_STEP⌉)`` steps, all samples stepping together
        (:meth:`ClosedLoopKinematics.reference_continuation`'s first try). Newton starts the first step from the
        reference's tangent prediction ``q_ref + (dq_p/dq_a) Δq_a``, the later ones from the secant prediction
        ``2 q_k − q_{k−1}`` of the passive joints (the per-sample solver starts from ``q_k``): the same branch's
        answer, in fewer iterations.

        Returns:
            (N, nq) configurations and (N,) which converged (the others: solve them alone, with finer steps).
        """
        n = len(q_actuated)
        origin = self.actuated_values(self.reference[None, :])[0]
        path = self.kinematics.actuated_delta(q_actuated, np.broadcast_to(origin, q_actuated.shape))
        span = np.abs(path).max(axis=1, initial=0.0)
        reachable = np.isfinite(span) & (span <= MAX_CONTINUATION_STEPS * CONTINUATION_STEP)
        steps = np.maximum(1, np.ceil(np.where(reachable, span, 0.0) / CONTINUATION_STEP)).astype(int)
        q = np.tile(self.reference, (n, 1))
        before = q.copy()  # each sample's configuration one step back
        alive = reachable.copy()
        geometry = self.geometry(model, closure)
        tangent = self._reference_tangent(model, closure)
        for k in range(1, int(steps[alive].max(initial=0)) + 1):
            rows = np.flatnonzero(alive & (steps >= k))
            if not rows.size:
                break
            start = q[rows]
            start[:, self.actuated_q] = origin + path[rows] * (k / steps[rows])[:, None]
            if k > 1:  # a secant predictor along the path (equal steps): Newton starts nearer the same branch
                start = self.retract(start, self.passive_difference(q[rows], before[rows]))
            elif tangent is not None:  # from the reference, its tangent: the same for every sample
                start = self.retract(start, (path[rows] / steps[rows, None]) @ tangent.T)
            last = steps[rows] == k
            tols = np.where(last, min(tol, FIRST_SOLVE_TOLERANCE), max(tol, 1e-8))
            solved, _, converged = self._close_loops(geometry, start, tols, max_iter=20)
            before[rows] = q[rows]
            q[rows] = solved
            alive[rows[~converged]] = False
        return q, alive

    def _reference_tangent(self, model: pin.Model, closure: LoopClosure) -> Array | None:
        """``dq_p/dq_a = −C_p⁺ C_a`` (n_passive × na) at the reference configuration, if it closes the loops (the
        first continuation step's predictor; None: no predictor)."""
        state = self.state(model, closure, self.reference[None, :])
        assert state.jacobian is not None
        if not np.abs(state.residual).max(initial=0.0) <= 1e-6:
            return None
        passive, actuated = state.jacobian[0][:, self.passive_v], state.jacobian[0][:, self.actuated_v]
        tangent, *_ = np.linalg.lstsq(passive, -actuated, rcond=None)
        return np.asarray(tangent, dtype=float) if np.all(np.isfinite(tangent)) else None

    def solve(self, model: pin.Model, closure: LoopClosure, q_actuated: Array, guesses: Array | None,
              tol: float) -> tuple[Array, BoolArray]:
        """Forward kinematics of every sample: warm from ``guesses`` (N, nq) where given (None: cold starts), by
        continuation from the reference for the samples without one or whose warm start was refused.

        Returns:
            (N, nq) configurations and (N,) which are answers (the others: solve them alone).
        """
        q_actuated = np.asarray(q_actuated, dtype=float)
        n = len(q_actuated)
        q = np.empty((n, self.nq))
        ok = np.zeros(n, dtype=bool)
        if guesses is not None:
            q[:], ok[:] = self.warm_solve(model, closure, q_actuated, guesses, tol)
        cold = np.flatnonzero(~ok)
        if cold.size:
            q[cold], ok[cold] = self.continuation(model, closure, q_actuated[cold], tol)
        return q, ok


def _take(frame: LoopFrames, rows: BoolArray) -> LoopFrames:
    """The samples ``rows`` of a loop's frames."""
    return LoopFrames(frame.r1[rows], frame.p2[rows], frame.relative_translation[rows],
                      None if frame.r2 is None else frame.r2[rows],
                      None if frame.relative_rotation is None else frame.relative_rotation[rows],
                      None if frame.log is None else frame.log[rows], frame.gap[rows])


def _cross(a: Array, b: Array) -> Array:
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


def _turn_quaternion(quaternion: Array, angular: Array) -> Array:
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


def _inverse_left_jacobian(angular: Array, translation: Array) -> Array:
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
