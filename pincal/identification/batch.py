"""What a measurement model predicts every sample of a tree from at once: the batched counterpart of
:class:`~pincal.identification.measurements.SampleContext`.

:mod:`pincal.identification.tree_batch` computes, for a block of samples, each measured frame's placement and its
*spatial* twists per unit parameter, factored as :class:`SpatialJacobian`; a model's ``predict_batch`` turns them into
its Jacobian rows with one product per model (:meth:`BatchContext.derivative`). The intermediates live in a
:class:`Workspace`, kept from one evaluation to the next.
"""

from __future__ import annotations

from dataclasses import field
from typing import TYPE_CHECKING

import numpy as np
import numpy.typing as npt
import pinocchio as pin

from pincal.model.per_thread import per_thread
from pincal.model.rotations import skew
from pincal.records import record

if TYPE_CHECKING:
    from pincal.identification.measurements.context import SampleContext

Array = npt.NDArray[np.float64]


@record(frozen=True)
class SpatialJacobian:
    """A frame's spatial twists per unit parameter for every sample, factored as ``W = left · right``.

    A *spatial* twist is, per unit parameter, the velocity [m] of the robot-world point at the origin moving with the
    frame and the frame's angular velocity [rad], both in the robot's world frame (``Ad(oMf) ν``, ν the local twist
    of :attr:`~pincal.identification.measurements.SampleContext.twists`): a point ``p`` [m] fixed on the frame
    moves by ``W_v − p × W_ω``. The factors keep the work per sample small: the K generators' spatial twists vary by
    sample, the map to the parameters does not, so a model applies its own per-sample rows to ``left`` and one
    matrix product gives its Jacobian rows.

    Attributes:
        left: (N, 6, K) the spatial twists of K generators (joint origins' local directions, joint axes times the
            terms' regressors, the frame's own local directions).
        right: (K, p) each generator's share of each parameter.
        scratch: Where the intermediates are kept between evaluations.
    """

    left: Array
    right: Array
    scratch: Workspace = field(default_factory=lambda: Workspace())

    def apply(self, rows: Array, out: Array | None = None) -> Array:
        """(N, r, p) ``rows · W`` for per-sample rows (N, r, 6) or rows shared by all samples (r, 6), written into
        ``out`` when given (a C-contiguous (N, r, p) array)."""
        n, _, k = self.left.shape
        r, p = rows.shape[-2], self.right.shape[1]
        left = np.matmul(rows, self.left, out=self.scratch.array(("rows", r, k), (n, r, k)))
        if out is None or not out.flags.c_contiguous:
            product: Array = (left.reshape(n * r, k) @ self.right).reshape(n, r, p)
            if out is not None:
                out[...] = product
            return product
        np.matmul(left.reshape(n * r, k), self.right, out=out.reshape(n * r, p))
        return out

    def full(self) -> Array:
        """(N, 6, p) ``W`` itself."""
        n, _, k = self.left.shape
        product: Array = (self.left.reshape(n * 6, k) @ self.right).reshape(n, 6, self.right.shape[1])
        return product


#: Most scratch arrays a :class:`Workspace` keeps.
WORKSPACE_ARRAYS = 512


class Workspace:
    """Scratch arrays kept from one evaluation to the next.

    A fresh array of megabytes costs a page fault per 4 kB page each time it is first written (about as much as
    the arithmetic done on it, more on a virtual machine); the batched evaluation's intermediates (N × 6 × p and
    the like) are therefore kept, keyed by what they hold, and handed out again while their shape is unchanged. An
    array from :meth:`array` is overwritten by the next evaluation: nothing returned to a caller may be one. At most
    :data:`WORKSPACE_ARRAYS` are kept (a robot's workspace serves problems of many sizes): past that, all are dropped.
    The arrays are one set per thread (:mod:`pincal.model.per_thread`): a robot's workspace serves each thread that
    evaluates on it with arrays of its own.
    """

    @per_thread
    def _arrays(self) -> dict[tuple[object, tuple[int, ...]], Array]:
        """This thread's arrays, by key and shape."""
        return {}

    def array(self, key: object, shape: tuple[int, ...]) -> Array:
        """An array of ``shape`` for ``key``: the same memory as the last one for ``key`` and this shape in this thread
        (its contents as the thread's last user left them), else a new one filled with zeros."""
        arrays = self._arrays
        held = arrays.get((key, shape))
        if held is None:
            if len(arrays) >= WORKSPACE_ARRAYS:
                arrays.clear()
            held = np.zeros(shape)
            arrays[(key, shape)] = held
        return held


@record
class BatchContext:
    """What a measurement model predicts every sample from at once (a tree's batched evaluation).

    The problem builds one per evaluation of a robot without loops (:mod:`pincal.identification.tree_batch`) or with
    loops (:mod:`pincal.identification.loop_batch`); the frames' parameter derivatives are spatial twists
    (:class:`SpatialJacobian`).

    Attributes:
        shared: The evaluation's per-sample context (parameters, base, markers, attached placements, data), whose
            per-sample fields are unused here.
        q: (N, nq) each sample's configuration.
        rotations: Frame -> (N, 3, 3) its orientation in the robot's world frame.
        translations: Frame -> (N, 3) its origin [m] in the robot's world frame.
        twists: Frame -> its spatial twists per unit parameter (empty without Jacobian).
        samples: The block of the dataset's samples these are (the batched evaluation goes block by block); every
            array here holds one row per sample of the block.
        joint_terms: Joint -> its value's terms, (column, (N,) regressor): the joint's value moves by the regressor
            [rad or m] per unit of the column's parameter (the actuated joints' offsets and corrections; a joint not
            listed does not move with the parameters).
        velocities: (N, nv, p) every joint's velocity per unit parameter, ``dv/dθ`` (a closed-loop robot: the passive
            joints move with the parameters through the loops; then ``joint_terms`` are in its actuated rows), or None
            (a tree: ``joint_terms`` say it all).
    """

    shared: SampleContext
    q: Array
    rotations: dict[str, Array]
    translations: dict[str, Array]
    twists: dict[str, SpatialJacobian] = field(default_factory=dict)
    joint_terms: dict[str, list[tuple[int, Array]]] = field(default_factory=dict)
    samples: slice = field(default_factory=lambda: slice(0, None))
    velocities: Array | None = None

    @property
    def base(self) -> pin.SE3:
        """The placement of the robot in the measurement frame (world ← robot)."""
        return self.shared.base

    def point(self, frame: str, point: Array) -> Array:
        """(N, 3) the robot-world position [m] of ``point`` (3,) [m] fixed in ``frame``."""
        rotations = self.rotations[frame]
        moved: Array = (rotations.reshape(-1, 3) @ point).reshape(-1, 3) + self.translations[frame]
        return moved

    def derivative(self, frame: str, rows: Array, out: Array | None = None) -> Array:
        """(N, r, p) ``rows · W``: per-sample rows (N, r, 6) (or shared ones, (r, 6)) applied to ``frame``'s spatial
        twists per unit parameter, written into ``out`` when given."""
        return self.twists[frame].apply(rows, out)

    def base_columns(self, world_point: Array) -> Array:
        """(N, 3, len(base columns)) the derivative [m per unit parameter] of points at ``world_point`` (N, 3) [m]
        (robot world) in the measurement frame w.r.t. the base parameters: ``R_base [I, −p̂] J_base``."""
        return rotate_rows(point_rows(world_point, self.shared.base.rotation), self.shared.base_jacobian)

    def measured(self, key: str) -> Array:
        """(N, width) the measured values of measurement ``key`` in this block."""
        return self.shared.values[key][self.samples]


def point_rows(world_point: Array, rotation: Array | None = None) -> Array:
    """(N, 3, 6) ``R [I, −p̂]``: the rows that turn a spatial twist into the velocity of points at ``world_point``
    (N, 3) [m], rotated by ``rotation`` (3, 3), shared by the samples (None: not rotated); ``R [I, −p̂] = [R,
    −(R p)^ R]``."""
    n = len(world_point)
    rows = np.empty((n, 3, 6))
    if rotation is None:
        rows[:, :, :3] = np.eye(3)
        rows[:, :, 3:] = -skew(world_point)
        return rows
    rows[:, :, :3] = rotation
    rows[:, :, 3:] = (-skew(world_point @ rotation.T).reshape(3 * n, 3) @ rotation).reshape(n, 3, 3)
    return rows


def rotate_rows(rows: Array, columns: Array) -> Array:
    """(N, r, k) ``rows · columns`` for per-sample rows (N, r, 6) and shared columns (6, k): one matrix product."""
    n, r, _ = rows.shape
    product: Array = (rows.reshape(n * r, 6) @ columns).reshape(n, r, columns.shape[1])
    return product
