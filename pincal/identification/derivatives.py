"""Analytic derivatives of frame placements and loop residuals w.r.t. the kinematic parameters.

A *probe* is a frame rigidly attached to a joint: a measured frame or a loop anchor. Its local
twist per unit parameter comes from Pinocchio's kinematic regressor (the adjoint of a virtual
6-DOF joint at each joint placement, the ``M · exp6(δ)`` convention), chained with the right
Jacobian of ``exp6`` at the current deviation. Fixed-joint origins move their subtree: joints
below them get the perturbation carried by an adjoint, frames on the same joint a direct term.

Through the loops (implicit-function theorem, actuated joints held): with closure ``c(q, θ) = 0``,
``dv_p/dθ = -C_p⁺ ∂c/∂θ``, where ``∂c/∂θ`` comes from the anchors' relative twist.
"""

from __future__ import annotations

from typing import Any

import numpy as np
import numpy.typing as npt
import pinocchio as pin

from pincal.identification.measurements import (
    AttachedPlacement,
    IntrinsicTerms,
    MarkerPoint,
    intrinsics_name,
    split_target,
)
from pincal.identification.parameters import AnchorPlacement, MarkerOffset, ParameterSet, attached_name, kinds_where
from pincal.identification.parameters.candidates import _descends
from pincal.identification.parameters.kinds import CameraIntrinsics
from pincal.model.robot import Robot
from pincal.records import record

Array = npt.NDArray[np.float64]


@record(frozen=True)
class Probe:
    """A frame rigidly attached to ``joint`` at ``placement`` (relative to the joint), on link frame
    ``link_frame`` (for the frame-tree descent test of fixed-joint parameters)."""

    joint: int
    placement: pin.SE3
    link_frame: int


def frame_probe(robot: Robot, frame_id: int) -> Probe:
    """The probe of Pinocchio frame ``frame_id``: its parent joint and its placement relative to that joint."""
    frame = robot.model.frames[frame_id]
    return Probe(int(frame.parentJoint), frame.placement.copy(), frame_id)


def right_jacobian(delta: Array, components: list[int]) -> Array:
    """Columns of ``Jexp6(δ)`` for the given components: local motion per unit parameter change."""
    return np.asarray(pin.Jexp6(pin.Motion(delta)))[:, components]


def marker_points(pset: ParameterSet, x: Array, nominal: dict[str, Array]) -> dict[str, MarkerPoint]:
    """Each marker key's point on its frame at ``x``, with its derivative (:class:`MarkerPoint`).

    A target's point [m] in its frame is ``p = exp6(δ_c) · n``, ``n = nominal + δ_m``: ``δ_m`` its offset
    parameters ``marker.<key>.*`` (components without a parameter are zero), ``δ_c`` the placement of its
    frame's cluster ``cluster.<frame>.*`` for a declared marker ``<frame>@<marker>`` (identity without one). Then
    ``∂p/∂δ_m = R_c`` and ``∂p/∂δ_c = R_c [I, −n̂] Jexp6(δ_c)`` (the right Jacobian of ``exp6``).

    Args:
        pset: The parameter set ``x`` refers to.
        x: (p,) parameter vector [m, rad].
        nominal: Marker target -> (3,) nominal offset [m] in its frame, for every target a measurement reads
            (targets with offset parameters only may be left out: zero).

    Returns:
        Every target of ``nominal`` and every target with offset parameters -> its point and derivative.
    """
    offsets: dict[str, list[int]] = {}
    for k in pset.indices_of(MarkerOffset):
        offsets.setdefault(pset.parameters[k].owner, []).append(k)
    clusters = {target: idx for (_, target, _), idx in pset.groups("cluster").items()}
    out: dict[str, MarkerPoint] = {}
    for target in dict.fromkeys([*nominal, *offsets]):
        point = np.array(nominal.get(target, np.zeros(3)), dtype=float)
        own = offsets.get(target, [])
        for k in own:
            point[pset.parameters[k].component] += x[k]
        frame, marker = split_target(target)
        cluster = clusters.get(frame, []) if marker else []
        delta = pset.placement_delta(x, cluster) if cluster else np.zeros(6)
        placement = pin.exp6(delta)
        derivative = placement.rotation[:, [pset.parameters[k].component for k in own]]
        if cluster:
            comps = [pset.parameters[k].component for k in cluster]
            motion = np.hstack([np.eye(3), -pin.skew(point)]) @ right_jacobian(delta, comps)
            derivative = np.hstack([derivative, placement.rotation @ motion])
        out[target] = MarkerPoint(placement.act(point), own + cluster, derivative)
    return out


def attached_placements(pset: ParameterSet, x: Array) -> dict[str, AttachedPlacement]:
    """Each attached placement with parameters at ``x`` (a camera, a target, a plane: a kind that says it is
    :attr:`~pincal.identification.parameters.ParameterKind.attached`): its placement ``exp6(δ)`` and right Jacobian.

    Args:
        pset: The parameter set ``x`` refers to.
        x: (p,) parameter vector [m, rad].

    Returns:
        Attached placement name (:func:`pincal.identification.parameters.attached_name`: ``camera.<frame>``,
        ``target``, ``target.<frame>@<target>``) -> its :class:`AttachedPlacement`.
    """
    out: dict[str, AttachedPlacement] = {}
    for (kind, owner, _), idx in pset.groups(*kinds_where(attached=True)).items():
        delta = pset.placement_delta(x, idx)
        jacobian = right_jacobian(delta, [pset.parameters[k].component for k in idx])
        out[attached_name(kind, owner)] = AttachedPlacement(pin.exp6(delta), list(idx), jacobian)
    return out


def intrinsic_terms(pset: ParameterSet, x: Array) -> dict[str, IntrinsicTerms]:
    """Each camera's intrinsics parameters at ``x`` [px, 1]: name (``intrinsics.<frame>``, ``intrinsics``) -> their
    values, columns and components."""
    return {intrinsics_name(owner): IntrinsicTerms(x[idx], list(idx), [pset.parameters[k].component for k in idx])
            for (_, owner, _), idx in pset.groups(CameraIntrinsics.name).items()}


def attached_terms(pset: ParameterSet, x: Array) -> dict[str, Any]:
    """What the measurement models carry at ``x``, as :class:`~pincal.identification.measurements.SampleContext`'s
    keywords: ``attached`` (:func:`attached_placements`) and ``intrinsics`` (:func:`intrinsic_terms`)."""
    return {"attached": attached_placements(pset, x), "intrinsics": intrinsic_terms(pset, x)}


class KinematicSensitivity:
    """Parameter derivatives for one estimate ``x`` (the robot with ``x`` applied).

    Args:
        robot: The robot with the kinematic deviations of ``x`` already applied.
        pset: The full parameter set (non-kinematic parameters get zero columns here).
        x: The parameter vector (deviations from nominal).
    """

    def __init__(self, robot: Robot, pset: ParameterSet, x: Array) -> None:
        self.robot = robot
        model = robot.model
        self.model = model
        n = len(pset)
        self.n = n
        self.joint_map = np.zeros((6 * (model.njoints - 1), n))
        self.has_mimic = any(model.joints[j].nv == 0 for j in range(1, model.njoints))  # <mimic> joints
        self.fixed: list[tuple[int, pin.SE3, int, list[int], Array]] = []
        self.anchor_terms: dict[tuple[str, str], tuple[list[int], Array]] = {}
        self._fixed_cache: dict[int, list[tuple[list[int], Array]]] = {}  # id(probe) -> its fixed-joint terms
        for (kind, owner, side), idx in pset.groups("joint", "anchor").items():
            comps = [pset.parameters[k].component for k in idx]
            jexp = right_jacobian(pset.placement_delta(x, idx), comps)
            if kind == AnchorPlacement.name:
                self.anchor_terms[(owner, side)] = (idx, jexp)
            elif model.existJointName(owner):
                jid = model.getJointId(owner)
                self.joint_map[6 * (jid - 1):6 * jid, idx] += jexp
            else:
                fid = model.getFrameId(owner, pin.FrameType.FIXED_JOINT)
                frame = model.frames[fid]
                parent = int(frame.parentJoint)
                placement = frame.placement.copy()
                for jid in range(1, model.njoints):
                    jframe = model.getFrameId(model.names[jid], pin.FrameType.JOINT)
                    if model.parents[jid] == parent and _descends(model, jframe, fid):
                        local = placement.inverse() * model.jointPlacements[jid]
                        self.joint_map[6 * (jid - 1):6 * jid, idx] += local.inverse().action @ jexp
                self.fixed.append((fid, placement, parent, idx, jexp))
        anchors = robot.closure.anchors()
        self.anchor_probes = []
        for loop, (j1, m1, j2, m2) in zip(robot.loops, anchors, strict=True):
            l1 = model.getFrameId(loop.predecessor)
            l2 = model.getFrameId(loop.successor)
            self.anchor_probes.append((Probe(j1, m1, l1), Probe(j2, m2, l2)))

    def probe_twist(self, data: pin.Data, probe: Probe) -> Array:
        """Local twist (6 × n) of a probe per unit parameter; needs forward kinematics on ``data``."""
        if probe.joint == 0:  # on the base: only fixed-joint origins there can move it
            twist = np.zeros((6, self.n))
        else:
            twist = self._regressor(data, probe) @ self.joint_map
        for idx, term in self.fixed_terms(probe):
            twist[:, idx] += term
        return twist

    def fixed_terms(self, probe: Probe) -> list[tuple[list[int], Array]]:
        """The probe's twist per unit fixed-joint parameter, for the fixed joints on its link chain: constant
        over samples (a placement relative to the probe), so built once per probe."""
        terms = self._fixed_cache.get(id(probe))
        if terms is None:
            terms = [(idx, (placement.inverse() * probe.placement).inverse().action @ jexp)
                     for fid, placement, parent, idx, jexp in self.fixed
                     if parent == probe.joint and _descends(self.model, probe.link_frame, fid)]
            self._fixed_cache[id(probe)] = terms
        return terms

    def _regressor(self, data: pin.Data, probe: Probe) -> Array:
        """Local twist of a probe (6 × 6(njoints - 1)) per unit local motion of each joint placement."""
        if not self.has_mimic:
            return np.asarray(pin.computeJointKinematicRegressor(self.model, data, probe.joint, pin.LOCAL,
                                                                  probe.placement))
        # Pinocchio's regressor refuses mimic joints; it is the adjoint from each supporting joint's
        # placement (before its motion) to the probe
        model = self.model
        regressor = np.zeros((6, 6 * (model.njoints - 1)))
        probe_inverse = (data.oMi[probe.joint] * probe.placement).inverse()
        for jid in list(model.supports[probe.joint])[1:]:
            origin = data.oMi[model.parents[jid]] * model.jointPlacements[jid]
            regressor[:, 6 * (jid - 1):6 * jid] = (probe_inverse * origin).action
        return regressor

    def closure_derivative(self, data: pin.Data) -> Array:
        """``∂c/∂θ`` (rows × n) at the configuration last evaluated by the robot's closure."""
        closure = self.robot.closure
        twists = []
        for loop, (p1, p2), c1c2 in zip(self.robot.loops, self.anchor_probes, closure.relative_placements(),
                                         strict=True):
            nu1 = self.probe_twist(data, p1)
            nu2 = self.probe_twist(data, p2)
            for side, nu in (("predecessor", nu1), ("successor", nu2)):
                term = self.anchor_terms.get((loop.name, side))
                if term is not None:
                    nu[:, term[0]] += term[1]
            twists.append(c1c2.action @ nu2 - nu1)
        return closure.rows_from_relative_twist(data, twists)
