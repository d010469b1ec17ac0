"""Closed-loop kinematics of many samples at once: forward kinematics, loop residuals and their Jacobians.

The per-sample solvers of :mod:`pincal.model.kinematics` spend most of their time in Python around small Pinocchio
calls. Here every sample of a batch moves together: forward kinematics is a product over the joints,
``oMi[j] = oMi[parent] · M_j · exp6(ξ_j v_j)``, a few array operations per joint for all N samples (the joint placements
``M_j`` read from the model at each call, so one instance serves every parameter estimate); each loop's residual and
exact Jacobian follow from its anchors' placements and the joints' *spatial* twists (per unit velocity, the velocity
of the world point at the origin moving with the joint's child and its angular velocity, in the world frame).
:mod:`pincal.model.batch_kinematics` closes the loops with these (stacked Newton steps, continuation).

The rows, for a loop with anchors c1 (predecessor) and c2 (successor), ``c1Mc2 = (R, p)`` and a relative spatial
twist ``ΔW = W₂ − W₁`` of the anchors' bodies (:mod:`pincal.model.closure` gives the same rows from Pinocchio's
anchor Jacobians): ``dp = R₁ᵀ (ΔW_v − p₂ × ΔW_ω)``, and the body angular velocity of c2 relative to c1,
``ω_b = R₂ᵀ ΔW_ω``, enters as ``Jlog3(R) ω_b`` (fixed, prismatic) or ``−Eᵀ R [a]× ω_b`` (revolute).

Joint kinds: joints of one coordinate and one velocity (revolute, prismatic, aligned with an axis or not) and
free-flyers (a platform: its placement from its quaternion and translation, its six local velocities, moved by
``t + R v`` and ``R exp3(ω)``); a robot with another kind (a spherical joint, a continuous joint, a ``<mimic>``
follower) reports it in :attr:`BatchLoops.unsupported` and is solved sample by sample.
"""

from __future__ import annotations

import numpy as np
import pinocchio as pin

from pincal.model.batch_frames import (
    Array,
    Geometry,
    IntArray,
    JointPlacements,
    LoopFrames,
    LoopState,
    cross,
    inverse_left_jacobian,
    turn_quaternion,
)
from pincal.model.closure import LoopClosure, normal_basis
from pincal.model.joint_motion import joint_motion
from pincal.model.kinematics import ClosedLoopKinematics
from pincal.model.rotations import cross_columns, jlog3, log3, quaternion_matrices


class BatchLoops:
    """Batched forward kinematics and loop rows for one robot structure (built once; placements read at each call).

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
        linear = np.where(revolute, cross(frames[self.column_joint[chosen], :, :, 3], direction), direction)
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
            q[:, start + 3:start + 7] = turn_quaternion(quaternion, step[:, column + 3:column + 6])
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
            out[:, column:column + 3] = inverse_left_jacobian(angular, moved[..., 0])
            out[:, column + 3:column + 6] = angular
        return out

    def actuated_values(self, q: Array) -> Array:
        """(N, na) actuated values [rad or m] of configurations ``q`` (N, nq)."""
        values: Array = q[:, self.actuated_q]
        return values
