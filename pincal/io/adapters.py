"""Dataset columns to measurement models and observations: σ per channel from the metadata, joint readings of
instrumented passive joints."""

from __future__ import annotations

from collections.abc import Sequence

import numpy as np
import numpy.typing as npt

from pincal.errors import DataError, listing
from pincal.identification.measurements import JointReading, Measurement, Pose, joint_reading, parse_key
from pincal.identification.parameters import influencing_joints
from pincal.identification.problem import Observations
from pincal.model.robot import Robot

Array = npt.NDArray[np.float64]



def channel_sigma(key: str, metadata: dict[str, str], default: float | None, angle: bool = False) -> float | None:
    """σ of a measurement channel from dataset metadata: ``# sigma <kind> <name>: value`` (e.g.
    ``# sigma position end_effector: 1e-5``, ``# sigma joint device_lvdt: 1e-6``), else
    ``# sigma <kind>: value``; ``# sigma pose angle: ...`` for pose orientations [m or rad]."""
    kind, _, name = key.partition(":")
    candidates = [f"sigma {kind} angle"] if angle else [f"sigma {kind} {name}", f"sigma {kind}"]
    for candidate in candidates:
        if candidate in metadata:
            try:
                value = float(metadata[candidate])
            except ValueError:
                raise DataError(f"metadata '{candidate}' is '{metadata[candidate]}', not a number") from None
            if not 1e-15 <= value <= 1e3:
                raise DataError(f"metadata '{candidate}' is {value!r}: a standard deviation [m or rad] must lie "
                                "between 1e-15 and 1e3")
            return value
    return default


def measurements_for(robot: Robot, measurement_keys: Sequence[str], joint_columns: Sequence[str],
                     sigma: float | None = None, metadata: dict[str, str] | None = None) -> list[Measurement]:
    """Measurement models for a dataset: its measurement columns, plus a joint reading for every
    non-actuated joint column (instrumented passive joints: encoders, LVDTs, scales).

    Weights: ``sigma`` [m, rad] if given (overrides everything), else per-channel σ from the
    dataset's metadata (:func:`channel_sigma`), else the models' defaults.
    """
    meta = metadata or {}
    models = []
    for key in measurement_keys:
        model = parse_key(key, sigma or channel_sigma(key, meta, None))
        if isinstance(model, Pose):
            angle = sigma or channel_sigma(key, meta, None, angle=True)
            if angle:
                model = Pose(model.key, model.size, model.sigma, model.frame, angle)
        models.append(model)
    for joint in joint_columns:
        if joint not in robot.actuated_joints:
            if not robot.model.existJointName(joint):
                raise DataError(f"column '{joint}' is not a joint of '{robot.name}'; joints are: "
                                f"{listing(robot.model.names[1:])}")
            models.append(joint_reading(joint, sigma or channel_sigma(f"joint:{joint}", meta, None) or 1e-5))
    return models


def joints_at_reference(robot: Robot, joint_names: Sequence[str], models: Sequence[Measurement]) -> list[str]:
    """The actuated joints the data has no column for, which then stay at their reference value [rad or m]: allowed
    only for joints that cannot move what ``models`` measure (a TIAGo's head and wheels when its hand is measured).

    Raises:
        DataError: a joint that moves a measured frame or a read joint has no column (they are listed).
    """
    missing = [j for j in robot.actuated_joints if j not in joint_names]
    if not missing:
        return []
    if not models:  # nothing measured: nothing tells which joints matter
        raise DataError(f"the data has no column for actuated joint(s) {listing(missing)}; joint columns are: "
                        f"{listing(joint_names) or 'none'}")
    frames = sorted({f for m in models for f in m.frames})
    read = [m.joint for m in models if isinstance(m, JointReading)]
    moving = set(influencing_joints(robot, frames, read))
    needed = [j for j in missing if j in moving]
    if needed:
        raise DataError(f"the data has no column for actuated joint(s) {listing(needed)}, which move the measured "
                        f"{listing(frames)}; joint columns are: {listing(joint_names) or 'none'}")
    return missing


def actuated_readings(robot: Robot, joint_names: Sequence[str], joints: Array,
                      models: Sequence[Measurement]) -> Array:
    """(N, n_actuated) readings of the actuated joints [rad or m] from dataset columns, in the robot's order; a joint
    with no column (:func:`joints_at_reference`) reads its reference value."""
    names = list(joint_names)
    reference = robot.actuated_values(robot.q_reference)
    joints_at_reference(robot, names, models)
    out = np.empty((np.asarray(joints).shape[0], robot.n_actuated))
    for k, joint in enumerate(robot.actuated_joints):
        out[:, k] = np.asarray(joints, dtype=float)[:, names.index(joint)] if joint in names else reference[k]
    return out


def observations_from(robot: Robot, joint_names: Sequence[str], joints: Array, measurements: dict[str, Array],
                      models: Sequence[Measurement]) -> Observations:
    """Observations for ``models`` from dataset columns (actuated joints without a column: see
    :func:`actuated_readings`)."""
    values = dict(measurements)
    for m in models:
        if isinstance(m, JointReading):
            values[m.key] = joints[:, [list(joint_names).index(m.joint)]]
    return Observations(actuated_readings(robot, joint_names, joints, models), values)
