"""Dataset columns to measurement models and observations: σ per channel from the metadata, joint readings of
instrumented passive joints."""

from __future__ import annotations

import math
import re
from collections.abc import Sequence

import numpy as np
import numpy.typing as npt

from pincal.errors import DataError, listing
from pincal.identification.measurements import (
    KIND_CLASSES,
    MARKER_NAME,
    Measurement,
    joint_reading,
    parse_key,
    split_target,
)
from pincal.identification.parameters import influencing_joints, read_joints
from pincal.identification.problem import Observations
from pincal.model.robot import Robot

Array = npt.NDArray[np.float64]

#: A marker declaration in a dataset's metadata: ``# marker <marker> on <frame>: x y z`` (nominal offset [m]).
MARKER_DECLARATION = re.compile(r"marker\s+(\S+)\s+on\s+(\S+)")
#: Largest plausible marker offset [m]: beyond it the numbers look like millimetres.
MAX_MARKER_OFFSET = 20.0


def declared_marker_offsets(metadata: dict[str, str]) -> dict[str, tuple[float, float, float]]:
    """The nominal marker offsets a dataset declares: ``# marker m1 on tool0: 0.01 0 0.05`` gives
    ``{"tool0@m1": (0.01, 0.0, 0.05)}`` [m, in the frame].

    Raises:
        DataError: a ``marker ...`` key not of the form ``marker <marker> on <frame>``, a marker name other than
            letters, digits and ``_``, or a value that is not three finite numbers [m] below 20 m.
    """
    out: dict[str, tuple[float, float, float]] = {}
    for key, value in metadata.items():
        if not key.startswith("marker ") and key != "marker":
            continue
        match = MARKER_DECLARATION.fullmatch(key)
        if match is None or not MARKER_NAME.fullmatch(match.group(1)):
            raise DataError(f"metadata '{key}' is not '# marker <marker> on <frame>: x y z' (the marker in letters, "
                            "digits and '_'; x y z its nominal offset [m] in the frame)")
        try:
            numbers = tuple(float(v) for v in value.replace(",", " ").split())
        except ValueError:
            numbers = ()
        if len(numbers) != 3 or not all(math.isfinite(v) for v in numbers):
            raise DataError(f"metadata '{key}' is '{value}'; a marker's nominal offset is three numbers x y z [m] in "
                            "its frame")
        if max(abs(v) for v in numbers) > MAX_MARKER_OFFSET:
            raise DataError(f"metadata '{key}': {value} looks like millimetres; pincal expects metres")
        out[f"{match.group(2)}@{match.group(1)}"] = (numbers[0], numbers[1], numbers[2])
    return out


#: What a σ is: one value [m or rad] for every row of a measurement, or one per residual row.
Sigma = float | tuple[float, ...]


def channel_sigma(key: str, metadata: dict[str, str], default: Sigma | None, angle: bool = False) -> Sigma | None:
    """σ of a measurement channel from dataset metadata: ``# sigma <kind> <name>: value`` (e.g.
    ``# sigma position end_effector: 1e-5``, ``# sigma joint device_lvdt: 1e-6``), else
    ``# sigma <kind>: value``; ``# sigma pose angle: ...`` (``# sigma camera angle: ...``) for pose orientations [m or
    rad]. A value may be one σ per residual row, ``[1e-3, 1e-3, 3e-3]`` (a tuple)."""
    kind, _, name = key.partition(":")
    candidates = [f"sigma {kind} angle"] if angle else [f"sigma {kind} {name}", f"sigma {kind}"]
    for candidate in candidates:
        if candidate in metadata:
            return _sigma_value(candidate, metadata[candidate])
    return default


def _sigma_value(key: str, text: str) -> Sigma:
    """The σ of a ``# sigma ...: value`` metadata line [m or rad]: one number, or one per residual row written
    ``[a, b, c]`` or ``a b c`` (DataError naming the line's key)."""
    words = text.strip().strip("[]()").replace(",", " ").split()
    try:
        values = [float(word) for word in words]
    except ValueError:
        raise DataError(f"metadata '{key}' is '{text}', not a number (or one number per residual row, "
                        "[a, b, c])") from None
    if not values or not all(1e-15 <= value <= 1e3 for value in values):
        raise DataError(f"metadata '{key}' is {text.strip()!r}: a standard deviation [m or rad] must lie between "
                        "1e-15 and 1e3")
    return values[0] if len(values) == 1 else tuple(values)


def one_sigma(sigma: Sigma | None) -> float | None:
    """The single σ a model keeps beside per-row ones (their RMS) [m or rad]; None stays None."""
    if sigma is None or isinstance(sigma, int | float):
        return sigma
    return float(np.sqrt(np.mean(np.square(sigma))))


def weighted(model: Measurement, sigma: Sigma | None) -> Measurement:
    """``model`` with ``sigma``'s per-row values, when it gives one per residual row (itself otherwise)."""
    if sigma is None or isinstance(sigma, int | float):
        return model
    return model.with_component_sigma(sigma)


def check_sigma_metadata(metadata: dict[str, str]) -> None:
    """Every ``# sigma`` metadata line is ``sigma <kind>[ <name>| angle]: number`` (DataError naming the first that is
    not): a line pincal would not read (``# sigma: 1e-3``, a misspelt kind) or a σ that is not a number must not be
    ignored, even where a more specific line would override it."""
    kinds = list(KIND_CLASSES)
    for key, text in metadata.items():
        words = key.split()
        if not words or words[0].lower() != "sigma":
            continue
        if words[0] != "sigma" or len(words) < 2 or words[1] not in kinds:
            raise DataError(f"metadata '{key}' is not a σ line pincal reads: write '# sigma <kind>: value' or "
                            f"'# sigma <kind> <frame>: value' [m or rad] (e.g. '# sigma position: 1e-5'), kinds: "
                            f"{listing(kinds)}")
        _sigma_value(key, text)


def check_sigma_used(metadata: dict[str, str], models: Sequence[Measurement]) -> None:
    """Refuse a ``# sigma`` line that weights none of ``models``: a σ stated for a kind or a frame the file does not
    measure (``# sigma camera: 1e-4`` in a file of positions) would be silently ignored, and the σ the user believes
    stated estimated from the data instead.

    Raises:
        DataError: naming the line and the measurements the file has.
    """
    keys = [m.key for m in models]
    for key, text in metadata.items():
        words = key.split()
        if len(words) < 2 or words[0] != "sigma":
            continue
        kind = words[1]
        if len(words) == 2:
            used = any(k.partition(":")[0] == kind for k in keys)
        elif words[2:] == ["angle"]:
            used = any(m.key.partition(":")[0] == kind and m.angle_rows for m in models)
        else:
            used = f"{kind}:{' '.join(words[2:])}" in keys
        if not used:
            missing = f"{kind}:{' '.join(words[2:])}" if len(words) > 2 and words[2:] != ["angle"] else kind
            raise DataError(f"metadata '# {key}: {text.strip()}' states a σ for readings the file does not have (no "
                            f"{missing} columns; its measurements are {listing(keys) or 'none'}): remove the line, or "
                            "name a kind or frame of those")


def measurements_for(robot: Robot, measurement_keys: Sequence[str], joint_columns: Sequence[str],
                     sigma: Sigma | None = None, metadata: dict[str, str] | None = None) -> list[Measurement]:
    """Measurement models for a dataset: its measurement columns, plus a joint reading for every
    non-actuated joint column (instrumented passive joints: encoders, LVDTs, scales).

    Weights: ``sigma`` [m, rad] if given (overrides everything; one per residual row for every model when a
    sequence), else per-channel σ from the dataset's metadata (:func:`channel_sigma`), else the models' defaults.
    Declared markers (``position:<frame>@<marker>``) take their nominal offsets from the metadata
    (:func:`declared_marker_offsets`); a declaration with no columns is refused (DataError).
    """
    meta = metadata or {}
    if sigma is None:  # --sigma overrides every line
        check_sigma_metadata(meta)
    nominal = declared_marker_offsets(meta)
    models = []
    for key in measurement_keys:
        stated = sigma or channel_sigma(key, meta, None)
        model = weighted(parse_key(key, one_sigma(stated)), stated)
        if model.angle_rows and model.component_sigma is None:
            angle = one_sigma(sigma or channel_sigma(key, meta, None, angle=True))
            if angle:
                model = model.with_angle_sigma(angle)
        models.append(model.with_markers(nominal).with_metadata(meta))
    measured = {t for m in models for t in m.markers if split_target(t)[1]}
    stray = [t for t in nominal if t not in measured]
    if stray:
        frame, marker = stray[0].split("@")
        raise DataError(f"metadata 'marker {marker} on {frame}' declares a marker the data have no columns for (no "
                        f"position:{stray[0]}:x|y|z); markers measured: {listing(sorted(measured)) or 'none'}")
    for joint in joint_columns:
        if joint not in robot.actuated_joints:
            if not robot.model.existJointName(joint):
                raise DataError(f"column '{joint}' is not a joint of '{robot.name}'; joints are: "
                                f"{listing(robot.model.names[1:])}")
            stated = sigma or channel_sigma(f"joint:{joint}", meta, None)
            models.append(weighted(joint_reading(joint, one_sigma(stated) or 1e-5), stated))
    if sigma is None:
        check_sigma_used(meta, models)
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
    read = read_joints(models)
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
        if m.read_joints:  # the model's values are joint columns
            values[m.key] = joints[:, [list(joint_names).index(j) for j in m.read_joints]]
    return Observations(actuated_readings(robot, joint_names, joints, models), values)
