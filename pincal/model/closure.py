"""Loop-closure residuals and their exact Jacobians, on Pinocchio 4.1 anchor constraints.

For a loop with anchor frames c1 (on the predecessor) and c2 (on the successor), let
``c1Mc2 = (R, p)`` be the placement of c2 seen from c1. The residual rows are, in the c1 frame:

- ``spherical``: ``p`` (3 rows, [m]) — the anchor points coincide;
- ``revolute`` about ``a``: ``p`` and ``Eᵀ R a`` (5 rows, [m] and [rad]) — the axes stay aligned;
- ``prismatic`` along ``a``: ``Eᵀ p`` and ``log3(R)`` (5 rows) — no rotation, no drift across ``a``;
- ``fixed``: ``p`` and ``log3(R)`` (6 rows).

``E`` is a 3×2 orthonormal basis of the plane normal to ``a``. The Jacobians are exact (not only at
closure): Pinocchio's frame-anchor Jacobian ``J`` is the relative twist in c1, ``Ad(c2Mc1) J`` the
body twist ``(v_b, ω_b)`` of c2, and ``dp = R v_b``, ``dR = R [ω_b]×``.
"""

from __future__ import annotations

import functools
from typing import Any

import numpy as np
import numpy.typing as npt
import pinocchio as pin

from pincal.errors import LoopError, listing
from pincal.model.per_thread import per_thread
from pincal.model.urdf import LoopSpec
from pincal.records import record

Array = npt.NDArray[np.float64]


def normal_basis(axis: Array) -> Array:
    """A 3×2 orthonormal basis of the plane normal to the unit vector ``axis``."""
    return _normal_basis(tuple(float(a) for a in axis)).copy()


@functools.lru_cache(maxsize=256)
def _normal_basis(axis: tuple[float, ...]) -> Array:
    # remembered by axis: a robot at new parameters (one per identification step) rebuilds its loops
    helper = np.array([1.0, 0.0, 0.0]) if abs(axis[0]) < 0.9 else np.array([0.0, 1.0, 0.0])
    e1 = np.cross(axis, helper)
    e1 /= np.linalg.norm(e1)
    e2 = np.cross(axis, e1)
    return np.column_stack([e1, e2])


def link_anchor(model: pin.Model, link: str, origin: pin.SE3, loop: str) -> tuple[int, pin.SE3]:
    """Parent joint id and placement relative to that joint of an anchor given in a link frame."""
    if not model.existFrame(link):
        bodies = [f.name for f in model.frames if f.type == pin.FrameType.BODY]
        raise LoopError(f"loop '{loop}' names link '{link}'; links are: {listing(bodies)}")
    frame = model.frames[model.getFrameId(link)]
    return int(frame.parentJoint), frame.placement * origin


@record
class _Loop:
    spec: LoopSpec
    model: pin.Model
    anchors: tuple[int, pin.SE3, int, pin.SE3]  # predecessor joint, placement in it; successor joint, placement
    start: int
    basis: Array  # 3×2 basis normal to the axis (revolute, prismatic)
    axis_cross: Array  # [a]×
    stop: int = 0
    spherical: bool = False

    def __post_init__(self) -> None:
        self.stop = self.start + self.spec.rows
        self.spherical = self.spec.type == "spherical"

    # Pinocchio's constraint model and data, made on first use: the batched kinematics reads only the anchors, and a
    # robot at new parameters (one per identification step) need not pay for them. The data, which each evaluation
    # writes, are one per thread (:mod:`pincal.model.per_thread`)
    @functools.cached_property
    def cmodel(self) -> Any:
        kind = pin.PointAnchorConstraintModel if self.spherical else pin.FrameAnchorConstraintModel
        return kind(self.model, *self.anchors)

    @per_thread
    def cdata(self) -> Any:
        return self.cmodel.createData()


class LoopClosure:
    """The stacked closure equations ``c(q) = 0`` of a robot's loops.

    Args:
        model: The Pinocchio model of the cut tree.
        loops: The loop declarations; anchors are resolved against ``model``'s link frames.
    """

    def __init__(self, model: pin.Model, loops: list[LoopSpec]) -> None:
        self.model = model
        self.specs = list(loops)
        self._loops: list[_Loop] = []
        start = 0
        for spec in self.specs:
            j1, m1 = link_anchor(model, spec.predecessor, spec.predecessor_origin, spec.name)
            j2, m2 = link_anchor(model, spec.successor, spec.successor_origin, spec.name)
            if j1 == j2:
                raise LoopError(f"loop '{spec.name}' joins links '{spec.predecessor}' and "
                                f"'{spec.successor}', which are rigidly attached to each other")
            self._loops.append(_Loop(spec, model, (j1, m1, j2, m2), start, normal_basis(spec.axis),
                                     pin.skew(spec.axis)))
            start += spec.rows
        self.rows = start

    def row_names(self) -> list[str]:
        """A label per residual row, e.g. ``leg1/x`` (for reports)."""
        labels = {"spherical": ["x", "y", "z"], "fixed": ["x", "y", "z", "rx", "ry", "rz"],
                  "revolute": ["x", "y", "z", "r1", "r2"], "prismatic": ["t1", "t2", "rx", "ry", "rz"]}
        return [f"{lp.spec.name}/{s}" for lp in self._loops for s in labels[lp.spec.type]]

    def loop_slices(self) -> dict[str, slice]:
        """Rows of each loop in the stacked residual."""
        return {lp.spec.name: slice(lp.start, lp.start + lp.spec.rows) for lp in self._loops}

    def residual(self, data: pin.Data) -> Array:
        """Stacked residual [m, rad]; requires ``forwardKinematics`` on ``data`` first."""
        r = np.empty(self.rows)
        model = self.model
        for lp in self._loops:
            cdata = lp.cdata  # this thread's, read once
            lp.cmodel.calc(model, data, cdata)
            if lp.spherical:
                r[lp.start:lp.stop] = cdata.c1Mc2.translation
            else:
                r[lp.start:lp.stop] = self._rows(lp, cdata.c1Mc2)
        return r

    def _rows(self, lp: _Loop, m: pin.SE3) -> Array:
        kind = lp.spec.type
        if kind == "spherical":
            translation: Array = m.translation
            return translation
        if kind == "fixed":
            return np.concatenate([m.translation, pin.log3(m.rotation)])
        if kind == "revolute":
            return np.concatenate([m.translation, lp.basis.T @ (m.rotation @ lp.spec.axis)])
        return np.concatenate([lp.basis.T @ m.translation, pin.log3(m.rotation)])  # prismatic

    def residual_and_jacobian(self, data: pin.Data) -> tuple[Array, Array]:
        """Residual and its exact Jacobian ``dc/dv`` (rows × nv).

        Requires ``computeJointJacobians(model, data, q)`` on ``data`` first.
        """
        r = np.empty(self.rows)
        jac = np.empty((self.rows, self.model.nv))
        for lp in self._loops:
            cdata = lp.cdata  # this thread's, read once
            lp.cmodel.calc(self.model, data, cdata)
            m = cdata.c1Mc2
            rows = slice(lp.start, lp.stop)
            j = lp.cmodel.jacobian(self.model, data, cdata)
            if lp.spherical:
                r[rows] = m.translation
                jac[rows] = j
            else:
                r[rows] = self._rows(lp, m)
                jac[rows] = self._rows_from_twist(lp, m, j)
        return r, jac

    def _rows_from_twist(self, lp: _Loop, m: pin.SE3, twist: Array) -> Array:
        if lp.spherical:  # velocity of c2's origin in c1: v + ω × p
            velocity: Array = twist[:3] - pin.skew(m.translation) @ twist[3:]
            return velocity
        body = m.inverse().action @ twist  # body twist of c2 relative to c1, in c2
        rot = m.rotation
        lin: Array = rot @ body[:3]
        kind = lp.spec.type
        if kind == "spherical":
            return lin
        if kind == "fixed":
            return np.vstack([lin, pin.Jlog3(rot) @ body[3:]])
        if kind == "revolute":
            return np.vstack([lin, -lp.basis.T @ rot @ lp.axis_cross @ body[3:]])
        return np.vstack([lp.basis.T @ lin, pin.Jlog3(rot) @ body[3:]])

    def anchors(self) -> list[tuple[int, pin.SE3, int, pin.SE3]]:
        """Per loop: (joint id, placement in that joint) of the predecessor and successor anchors."""
        return [(lp.anchors[0], lp.anchors[1].copy(), lp.anchors[2], lp.anchors[3].copy()) for lp in self._loops]

    def rows_from_relative_twist(self, data: pin.Data, twists: list[Array]) -> Array:
        """Residual derivative (rows × k) from each loop's relative twist of c2 w.r.t. c1, in c1 (6 × k).

        Requires :meth:`residual` or :meth:`residual_and_jacobian` at the current configuration.
        """
        out = np.empty((self.rows, twists[0].shape[1] if twists else 0))
        for lp, twist in zip(self._loops, twists, strict=True):
            out[lp.start:lp.stop] = self._rows_from_twist(lp, lp.cdata.c1Mc2, twist)
        return out

    def relative_placements(self) -> list[pin.SE3]:
        """``c1Mc2`` of each loop at the last evaluated configuration."""
        return [lp.cdata.c1Mc2.copy() for lp in self._loops]
