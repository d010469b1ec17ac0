"""Pinocchio's Jacobians as 6 × nv matrices, whatever nv.

Pinocchio's Python bindings return a 6 × 1 Jacobian as a vector of 6 (a robot of one velocity coordinate: a
pendulum, a gripper whose fingers mimic one motor); every Jacobian pincal reads goes through here, so a product
with an nv × k matrix keeps its meaning for every robot. Rows: linear [m] then angular [rad] velocity.
"""

from __future__ import annotations

import numpy as np
import numpy.typing as npt
import pinocchio as pin

Array = npt.NDArray[np.float64]


def frame_jacobian(model: pin.Model, data: pin.Data, frame_id: int, reference: pin.ReferenceFrame) -> Array:
    """``pin.getFrameJacobian`` (after ``computeJointJacobians``) as 6 × nv."""
    return np.reshape(pin.getFrameJacobian(model, data, frame_id, reference), (6, model.nv))


def joint_jacobian(model: pin.Model, data: pin.Data, joint_id: int, reference: pin.ReferenceFrame) -> Array:
    """``pin.getJointJacobian`` (after ``computeJointJacobians``) as 6 × nv."""
    return np.reshape(pin.getJointJacobian(model, data, joint_id, reference), (6, model.nv))


def computed_frame_jacobian(model: pin.Model, data: pin.Data, q: Array, frame_id: int,
                            reference: pin.ReferenceFrame) -> Array:
    """``pin.computeFrameJacobian`` at ``q`` as 6 × nv."""
    return np.reshape(pin.computeFrameJacobian(model, data, q, frame_id, reference), (6, model.nv))
