"""Rotations of many samples at once: stacked (N, 3, 3) arrays, as Pinocchio computes them one at a time.

The batched kinematics (:mod:`pincal.model.batch_kinematics`: closed loops for many samples), the batched evaluation
of a tree (:mod:`pincal.identification.tree_batch`) and the measurement models' ``predict_batch`` work on every
sample with one array operation each; these are the SO(3) pieces they need: skew matrices, cross products against
stacked columns, the rotation about a fixed axis, the logarithm ``log3`` and its Jacobian ``Jlog3`` (Pinocchio's
formulas, with the same small-angle series, so that the batched predictions equal the per-sample ones to rounding).
"""

from __future__ import annotations

import numpy as np
import numpy.typing as npt
import pinocchio as pin

Array = npt.NDArray[np.float64]

#: Below this angle [rad] ``log3`` and ``Jlog3`` use their Taylor series (the closed forms divide by sin θ and θ²).
SMALL_ANGLE = 1e-4
#: Within this angle [rad] of π the rotation axis is ill-defined in ``(R − Rᵀ)``: those rows go to Pinocchio.
NEAR_PI = 1e-3


def skew(v: Array) -> Array:
    """``v̂`` (…, 3, 3) of vectors ``v`` (…, 3): ``v̂ w = v × w``."""
    out = np.zeros((*v.shape[:-1], 3, 3))
    out[..., 0, 1], out[..., 0, 2] = -v[..., 2], v[..., 1]
    out[..., 1, 0], out[..., 1, 2] = v[..., 2], -v[..., 0]
    out[..., 2, 0], out[..., 2, 1] = -v[..., 1], v[..., 0]
    return out


def cross_columns(a: Array, b: Array) -> Array:
    """``a × b`` column by column: ``a`` (N, 3), ``b`` (N, 3, k) -> (N, 3, k)."""
    ax, ay, az = (a[:, i, None] for i in range(3))
    bx, by, bz = b[:, 0], b[:, 1], b[:, 2]
    return np.stack([ay * bz - az * by, az * bx - ax * bz, ax * by - ay * bx], axis=1)


def rotate(rotation: Array, columns: Array) -> Array:
    """``R · columns`` for stacked or constant operands: ``rotation`` (3, 3) or (N, 3, 3), ``columns`` (3, k) or
    (N, 3, k) -> (N, 3, k) (one matrix product over all samples when either is constant)."""
    if rotation.ndim == 2:
        n, _, k = columns.shape
        flat = rotation @ columns.transpose(1, 0, 2).reshape(3, n * k)
        moved: Array = flat.reshape(3, n, k).transpose(1, 0, 2)
        return moved
    if columns.ndim == 2:
        stacked: Array = (rotation.reshape(-1, 3) @ columns).reshape(len(rotation), 3, columns.shape[1])
        return stacked
    product: Array = np.matmul(rotation, columns)
    return product


def log3(rotation: Array) -> Array:
    """The rotation vectors (N, 3) [rad] of rotations (N, 3, 3): ``θ/sin θ · a``, ``a = (R − Rᵀ)^∨/2 = sin θ · axis``,
    ``θ = atan2(‖a‖, (tr R − 1)/2)`` (series ``1 + θ²/6`` below :data:`SMALL_ANGLE`; Pinocchio's ``log3`` within
    :data:`NEAR_PI` of π, where ``a`` no longer gives the axis)."""
    half = 0.5 * np.stack([rotation[:, 2, 1] - rotation[:, 1, 2], rotation[:, 0, 2] - rotation[:, 2, 0],
                           rotation[:, 1, 0] - rotation[:, 0, 1]], axis=1)
    sine = np.linalg.norm(half, axis=1)
    theta = np.arctan2(sine, 0.5 * (np.trace(rotation, axis1=1, axis2=2) - 1.0))
    small = theta < SMALL_ANGLE
    factor = np.where(small, 1.0 + theta**2 / 6.0, theta / np.where(small, 1.0, sine))
    out: Array = factor[:, None] * half
    for k in np.flatnonzero(theta > np.pi - NEAR_PI):
        out[k] = pin.log3(rotation[k])
    return out


def jlog3(vector: Array) -> Array:
    """``Jlog3`` (N, 3, 3) at rotation vectors ``vector`` (N, 3) [rad] (``log3`` of the rotations): the derivative of
    ``log3(R)`` w.r.t. a local (right) perturbation of R, ``α r rᵀ + β I + ½ r̂`` with ``β = (θ/2) cot(θ/2)`` and
    ``α = (1 − β)/θ²`` (their series ``1/12 + θ²/720 + θ⁴/30240`` and ``1 − θ²/12 − θ⁴/720`` below
    :data:`SMALL_ANGLE`). The same function as Pinocchio's ``Jlog3``; the half-angle form avoids the cancellation in
    ``1 − cos θ`` that costs Pinocchio's up to ``ε/θ²`` in relative accuracy for θ just above 1e-4 rad."""
    theta = np.linalg.norm(vector, axis=1)
    small = theta < SMALL_ANGLE
    safe = np.where(small, 1.0, theta)
    t2 = theta**2
    beta = np.where(small, 1.0 - t2 / 12.0 - t2**2 / 720.0, 0.5 * safe / np.tan(0.5 * safe))
    alpha = np.where(small, 1.0 / 12.0 + t2 / 720.0 + t2**2 / 30240.0, (1.0 - beta) / safe**2)
    out: Array = alpha[:, None, None] * vector[:, :, None] * vector[:, None, :] + 0.5 * skew(vector)
    out[:, [0, 1, 2], [0, 1, 2]] += beta[:, None]
    return out


def quaternion_matrices(quat: Array) -> Array:
    """(N, 3, 3) rotation matrices of unit quaternions (N, 4) in x, y, z, w order."""
    x, y, z, w = quat.T
    return np.stack([1 - 2 * (y * y + z * z), 2 * (x * y - z * w), 2 * (x * z + y * w),
                     2 * (x * y + z * w), 1 - 2 * (x * x + z * z), 2 * (y * z - x * w),
                     2 * (x * z - y * w), 2 * (y * z + x * w), 1 - 2 * (x * x + y * y)], axis=1).reshape(-1, 3, 3)
