"""A passive joint's own sensor: an encoder, an LVDT, an instrumented measuring chain's reading."""

from __future__ import annotations

from typing import ClassVar

import numpy as np
import numpy.typing as npt
import pinocchio as pin

from pincal import linalg
from pincal.errors import DataError
from pincal.identification.batch import BatchContext
from pincal.identification.measurements.base import Measurement
from pincal.identification.measurements.context import SampleContext
from pincal.model.robot import Robot
from pincal.records import record

Array = npt.NDArray[np.float64]


@record(frozen=True)
class JointReading(Measurement):
    """A passive joint's encoder (or an instrumented measuring chain's sensor) [rad or m]."""

    kinds: ClassVar[tuple[str, ...]] = ("joint",)
    units: ClassVar[tuple[str, ...]] = ("rad or m",)

    joint: str = ""

    @classmethod
    def from_key(cls, kind: str, rest: str, sigma: float | None) -> Measurement:
        """The model of key ``joint:<joint>``; σ [rad or m] defaults to 1e-5."""
        return joint_reading(rest, sigma or 1e-5)

    @property
    def columns(self) -> tuple[str, ...]:
        """The dataset column: the joint's name."""
        return (self.joint,)

    @property
    def read_joints(self) -> tuple[str, ...]:
        """The joint whose reading this is."""
        return (self.joint,)

    def check(self, robot: Robot) -> None:
        """Raise NotFoundError if the robot lacks the joint, DataError if it is a ``<mimic>`` joint (no reading)."""
        jid = robot.joint_id(self.joint, f"measurement '{self.key}': ")
        if robot.model.joints[jid].nv == 0:
            raise DataError(f"measurement '{self.key}': joint '{self.joint}' is a <mimic> joint, which follows its "
                            "leader and has no reading of its own; remove its column")

    def predict(self, ctx: SampleContext, out: Array, jac: Array | None) -> None:
        """The joint's value (a continuous joint's angle from its cos, sin); with a zero offset δq the
        sensor reads ``q_true − δq`` (``q_true = q_read + δq``)."""
        jm = ctx.model.joints[ctx.model.getJointId(self.joint)]
        q = ctx.q
        value = q[jm.idx_q] if jm.nq == 1 else np.arctan2(q[jm.idx_q + 1], q[jm.idx_q])
        out[0] = value
        if jac is not None and ctx.dv is not None:
            jac[0] = ctx.dv[jm.idx_v]
        offset = ctx.reading_offsets.get(self.joint)
        if offset is not None:
            out[0] = value - ctx.x[offset]
            if jac is not None:
                jac[0, offset] -= 1.0

    def predict_batch(self, batch: BatchContext, out: Array, jac: Array | None) -> None:
        """:meth:`predict` for every sample (a tree: the joint moves with the parameters only through its own
        offset and correction columns when it is actuated; closed loops: through ``batch.velocities``)."""
        jm = batch.shared.model.joints[batch.shared.model.getJointId(self.joint)]
        q = batch.q
        out[:, 0] = q[:, jm.idx_q] if jm.nq == 1 else np.arctan2(q[:, jm.idx_q + 1], q[:, jm.idx_q])
        if jac is not None and batch.velocities is not None:  # closed loops: dv/dθ, actuated terms included
            jac[:, 0] = batch.velocities[:, jm.idx_v]
        elif jac is not None:
            for column, regressor in batch.joint_terms.get(self.joint, []):
                jac[:, 0, column] = regressor
        offset = batch.shared.reading_offsets.get(self.joint)
        if offset is not None:
            out[:, 0] -= batch.shared.x[offset]
            if jac is not None:
                jac[:, 0, offset] -= 1.0

    def error(self, predicted: Array, measured: Array, model: pin.Model) -> Array:
        """Predicted − measured [rad or m]; a continuous joint's is wrapped to [−π, π)."""
        err = predicted - measured
        if model.joints[model.getJointId(self.joint)].nq == 2:  # a continuous joint's reading wraps
            err = linalg.wrap_angle(err)
        return err



def joint_reading(joint: str, sigma: float = 1e-5) -> JointReading:
    """The model of a non-actuated joint's sensor reading [rad or m], with σ in the joint's unit."""
    return JointReading(f"joint:{joint}", 1, sigma, joint)
