"""Which samples a calibration can use, and checks of the data against the robot.

Every command reads data through :func:`read_robot_dataset`; :func:`usable_part` drops (and names) the samples
that cannot be used; :func:`held_out_outside_range` names held-out readings outside the fitted range;
:func:`check_length_scale` refuses lengths read in the wrong unit and gives the data's length scale;
:func:`check_moving_frames` refuses a measurement of frames no actuated joint moves. SI units: m, rad.
"""

from __future__ import annotations

import math
import re
from collections.abc import Mapping, Sequence
from pathlib import Path
from typing import Any

import numpy as np
import numpy.typing as npt

from pincal import linalg, validation
from pincal.errors import DataError
from pincal.identification.measurements import Measurement
from pincal.identification.metrics import length_columns
from pincal.identification.parameters import (
    joint_unit,
)
from pincal.identification.problem import CalibrationProblem
from pincal.io.dataset import OCCLUDABLE_KINDS, Dataset
from pincal.io.dataset_reader import read_dataset
from pincal.model.assemblable import assemble
from pincal.model.measured_frame import MOTION_TOLERANCE, frame_motion
from pincal.model.robot import Robot

Array = npt.NDArray[np.float64]

def joint_kinds(robot: Robot) -> dict[str, str]:
    """``revolute`` or ``prismatic`` for each one-DOF joint of ``robot`` (the kinds whose readings
    :func:`~pincal.io.dataset_reader.read_dataset` checks for degrees and millimetres; continuous joints are left
    out)."""
    model = robot.model
    names = [str(model.names[jid]) for jid in range(1, model.njoints) if model.joints[jid].nq == 1]
    return {name: "prismatic" if joint_unit(robot, name) == "m" else "revolute" for name in names}


def read_robot_dataset(path: str | Path, robot: Robot, min_samples: int = 2) -> Dataset:
    """:func:`~pincal.io.dataset_reader.read_dataset` for ``robot``, the readings of its revolute and prismatic joints
    checked for degrees and millimetres. Every command reads data through here. A file whose ``# robot:`` line
    names another robot is refused. The actuated joints that move a measured frame must have a column; that is
    checked with the measurement models (:func:`~pincal.io.adapters.joints_at_reference`)."""
    validation.instance("robot", robot, Robot, "a Robot (pincal.load_robot)")
    dataset = read_dataset(path, None, min_samples, joint_kinds=joint_kinds(robot),
                           joint_like=[str(n) for n in robot.model.names[1:]])
    check_recorded_robot(dataset.metadata, robot, path)
    return dataset


def check_recorded_robot(metadata: Mapping[str, str], robot: Robot, path: str | Path) -> None:
    """Refuse a file whose ``# robot:`` line names another robot than ``robot`` (its URDF's ``<robot name>`` or file
    name, or for a calibrated URDF the robot it was calibrated from, as its provenance records it).

    Raises:
        DataError: naming the file and both robots.
    """
    from pincal.calibration.provenance import read_provenance

    recorded = metadata.get("robot")
    names = {robot.name} | ({robot.source.stem} if robot.source is not None else set())
    calibrated_from = (read_provenance(robot.source).robot
                       if recorded is not None and recorded not in names and robot.source else None)
    if calibrated_from:  # a calibrated URDF: the data of the robot it was calibrated from are its own
        names |= {calibrated_from, Path(calibrated_from).stem}
    if recorded is not None and recorded not in names:
        raise DataError(f"{path}: its '# robot: {recorded}' line says the data are of robot '{recorded}', not of "
                        f"{' or '.join(repr(n) for n in sorted(names))} (the URDF's <robot name> or file name"
                        f"{', or the robot it was calibrated from' if calibrated_from else ''}); give the robot the "
                        "data were taken on, or correct that line")


def check_moving_frames(robot: Robot, models: Sequence[Measurement]) -> None:
    """Refuse, before any fit, a measurement of frames no actuated joint moves (a camera declared on the robot's base,
    a point on a link the joints do not carry): its readings are the same in every posture, whatever the robot's
    geometry, so they can calibrate nothing, and a fit of them explains nothing. Measurements that read only joints
    (``joint:``) are not judged here.

    Raises:
        DataError: naming the measurement, the frame and the robot's default measured frame.
    """
    frames = sorted({frame for model in models for frame in model.frames})
    if not frames or robot.n_actuated == 0:
        return
    moving = dict(zip(frames, (m > MOTION_TOLERANCE for m in frame_motion(robot, [robot.frame_id(f) for f in frames])),
                      strict=True))
    for model in models:
        if model.frames and not any(moving[frame] for frame in model.frames):
            still = " and ".join(f"'{frame}'" for frame in model.frames)
            default = robot.measured_frame_choice.frame
            instead = f" (e.g. '{default}', the default measured frame)" if default is not None else ""
            raise DataError(f"measurement '{model.key}' reads frame{'s' if len(model.frames) > 1 else ''} {still}, "
                            f"which no actuated joint of '{robot.name}' moves: its readings are the same in every "
                            f"posture and can calibrate nothing; measure a frame the joints move{instead}")


def usable_part(robot: Robot, part: Dataset) -> tuple[Dataset, list[dict[str, str]], Array | None]:
    """The samples of ``part`` that can be used, each dropped one with its reason, and the usable samples'
    configurations (N, nq) the nominal robot closes them in (None for a robot without loops: nothing is solved).

    Dropped: samples with no reading at all (every marker's cells empty, and nothing else measured),
    readings outside the URDF joint limits (a reading the robot cannot have is a wrong
    reading), and postures the nominal robot cannot assemble or that sit at a singularity
    (:func:`~pincal.model.assemblable.assemble`).
    """
    validation.instance("robot", robot, Robot, "a Robot (pincal.load_robot)")
    validation.instance("part", part, Dataset, "a Dataset (pincal.read_dataset)")
    reasons: dict[int, str] = dict(unseen_samples(robot, part))
    for k, reason in out_of_limits(robot, part):
        reasons[k] = f"{reasons[k]}; {reason}" if k in reasons else reason
    reference = robot.actuated_values(robot.q_reference)  # a joint with no column stays at its reference value
    actuated = np.column_stack([part.joints[:, part.joint_names.index(j)] if j in part.joint_names
                                else np.full(part.n_samples, reference[k])
                                for k, j in enumerate(robot.actuated_joints)])
    inside = [k for k in range(part.n_samples) if k not in reasons]
    solved = assemble(robot, actuated[inside]) if robot.loops else None
    for k, reason in solved.reasons.items() if solved is not None else ():
        reasons[inside[k]] = reason
    dropped = [{"sample": part.sample_ids[k], "reason": reasons[k]} for k in sorted(reasons)]
    usable = [k for k in range(part.n_samples) if k not in reasons]
    return part.subset(usable), dropped, None if solved is None else solved.q[solved.usable]


def dropped_account(dropped: Sequence[Mapping[str, str]], total: int) -> str:
    """Why the samples ``dropped`` (``{"sample", "reason"}``, of ``total``) were dropped, in one sentence: how many lay
    outside the joint limits and which joints read outside them how often, then how many for other reasons."""
    outside: dict[str, int] = {}
    others = []
    for entry in dropped:
        joints = re.findall(r"joint '([^']+)' reads [^,;]*, outside its URDF limits", entry["reason"])
        for joint in joints:
            outside[joint] = outside.get(joint, 0) + 1
        if not joints:
            others.append(entry["reason"])
    parts = []
    if outside:
        n = len(dropped) - len(others)
        counts = ", ".join(f"{joint} in {count}" for joint, count in sorted(outside.items(), key=lambda kv: -kv[1]))
        parts.append(f"{n} with a reading outside the URDF joint limits ({counts})")
    if others:
        parts.append(f"{len(others)} for other reasons (first: {others[0]})")
    return f"{len(dropped)} of the {total} samples were dropped before the fit: {'; '.join(parts)}"


def unseen_samples(robot: Robot, part: Dataset) -> list[tuple[int, str]]:
    """Samples of ``part`` that hold no reading: every measurement is a position whose cells are all empty (no
    marker seen), and no passive joint is read. Each with its reason."""
    keys = list(part.measurements)
    read = [j for j in part.joint_names if j not in robot.actuated_joints]
    if not keys or read or any(key.partition(":")[0] not in OCCLUDABLE_KINDS for key in keys):
        return []
    seen = np.zeros(part.n_samples, dtype=bool)
    for key in keys:
        seen |= np.all(np.isfinite(part.measurements[key]), axis=1)
    what = f"'{keys[0]}'" if len(keys) == 1 else f"any of the {len(keys)} markers"
    return [(int(k), f"no reading: the cells of {what} are all empty (not seen)") for k in np.flatnonzero(~seen)]


#: A reading counts as outside a joint's URDF limits beyond this share of its range: URDF limits are nominal,
#: and a real encoder may read a little past them (the TIAGo data's torso reads 0.350184 m against 0.35 m).
LIMIT_MARGIN = 0.01


def out_of_limits(robot: Robot, part: Dataset, margin: float = LIMIT_MARGIN) -> list[tuple[int, str]]:
    """Samples with a joint reading outside that joint's URDF limits by more than ``margin`` of its range
    (one-DOF joints with a range), and why."""
    model = robot.model
    found: list[tuple[int, str]] = []
    for c, name in enumerate(part.joint_names):
        if not model.existJointName(name):
            continue
        joint = model.joints[model.getJointId(name)]
        if joint.nq != 1:
            continue
        lower, upper = float(model.lowerPositionLimit[joint.idx_q]), float(model.upperPositionLimit[joint.idx_q])
        if not (math.isfinite(lower) and math.isfinite(upper) and lower < upper):
            continue
        unit = joint_unit(robot, name)
        tol = margin * (upper - lower)
        for k in np.flatnonzero((part.joints[:, c] < lower - tol) | (part.joints[:, c] > upper + tol)):
            found.append((int(k), f"joint '{name}' reads {part.joints[k, c]:.6g} {unit}, outside its URDF limits "
                                  f"[{lower:.6g}, {upper:.6g}] {unit}"))
    return sorted(found, key=lambda item: item[0])


#: A held-out reading counts as outside the fitted range beyond this share of the training readings' range (10 %:
#: postures drawn like the training ones land a few per cent past its ends, more so where the draw thins out near
#: the workspace's edge, as on a five-bar's cranks; a reading this far out is extrapolation).
RANGE_MARGIN = 0.10


def _outside(fitted: Array, held: Array, angular: bool, margin: float) -> npt.NDArray[np.intp]:
    """The ``held`` readings beyond ``margin`` × the width of the ``fitted`` readings' range [min, max] (``angular``:
    readings [rad] of a revolute joint, which moves the robot alike at q and q ± 2π, compared on the circle: a range
    that spans the circle, margins included, leaves none outside)."""
    low, high = float(np.nanmin(fitted)), float(np.nanmax(fitted))
    tol = margin * (high - low)
    if not angular:
        return np.flatnonzero((held < low - tol) | (held > high + tol))
    if high - low + 2.0 * tol >= 2.0 * np.pi:
        return np.flatnonzero(np.zeros(len(held), dtype=bool))
    past = np.remainder(held - (low - tol), 2.0 * np.pi)  # how far round from the margin's start [rad], in [0, 2π)
    return np.flatnonzero(np.isfinite(held) & (past > high - low + 2.0 * tol))


def held_out_outside_range(robot: Robot, train: Dataset, test: Dataset, margin: float = RANGE_MARGIN,
                           joints: Sequence[str] | None = None) -> list[dict[str, Any]]:
    """The held-out readings of actuated joints outside the range the training readings cover.

    For each actuated joint, a ``test`` sample whose reading lies beyond the training readings' range by more than
    ``margin`` × its width is listed: its error measures how the calibrated model extrapolates, not how it fits. A
    revolute joint's readings are compared as angles on the circle (a held-out 6 rad lies within a fitted range
    [−6.1, 4.5] rad, which spans the circle); an unbounded (continuous) joint's readings, as angles in [−π, π).

    ``joints`` limits the check to those joints (the ones that move what is measured; default: every actuated one).

    Returns:
        One dict per sample and joint, in sample order: ``sample`` (its id), ``joint``, ``value`` [rad or m] and
        ``range`` ([min, max] of the training readings [rad or m]).
    """
    if train.n_samples == 0 or test.n_samples == 0:
        return []
    found: list[tuple[int, int, dict[str, Any]]] = []
    for order, joint in enumerate(robot.actuated_joints):
        if joint not in train.joint_names or joint not in test.joint_names or (joints is not None
                                                                              and joint not in joints):
            continue
        fitted, held = train.joints[:, train.joint_names.index(joint)], test.joints[:, test.joint_names.index(joint)]
        if not np.any(np.isfinite(fitted)):
            continue
        if robot.model.joints[robot.joint_id(joint)].nq == 2:  # unbounded: its readings as angles in [−π, π)
            fitted, held = linalg.wrap_angle(fitted), linalg.wrap_angle(held)
        range_ = [float(np.nanmin(fitted)), float(np.nanmax(fitted))]
        for k in _outside(fitted, held, joint_unit(robot, joint) == "rad", margin):
            found.append((int(k), order, {"sample": test.sample_ids[k], "joint": joint, "value": float(held[k]),
                                          "range": range_}))
    return [entry for _, _, entry in sorted(found, key=lambda item: item[:2])]


#: Largest ratio between the spread of measured positions and the nominal robot's at the same joint readings (either
#: way) at which the data are fitted whatever ``--plausible`` says: a nominal robot is off by millimetres, not by its
#: size.
LENGTH_SCALE_RATIO = 30.0
#: Length units a data file may be written in: their size in metres (the keys of a job's ``units``).
LENGTH_UNIT_SIZES = {"m": 1.0, "cm": 1e-2, "mm": 1e-3, "um": 1e-6, "in": 0.0254}
#: Angle units a data file may be written in: their size in radians.
ANGLE_UNIT_SIZES = {"rad": 1.0, "mrad": 1e-3, "deg": math.pi / 180.0}
#: A unit explains a scale when their sizes agree within this factor (the spread ratio of right data lies within
#: 15 % of 1 on the TIAGo mocap data).
UNIT_MATCH = 1.3


def likely_unit(stated: str, factor: float, units: Mapping[str, float]) -> str | None:
    """The unit the values were most likely written in, when read in ``stated`` they come out ``factor`` times too
    large: the unit of ``units`` (name → size in SI) whose size is ``size(stated) / factor`` within
    :data:`UNIT_MATCH`; None when no unit is."""
    wanted = units[stated] / factor
    best = min(units, key=lambda u: abs(math.log(units[u] / wanted)))
    return best if best != stated and abs(math.log(units[best] / wanted)) <= math.log(UNIT_MATCH) else None


def check_length_scale(problem: CalibrationProblem, metadata: Mapping[str, str] | None = None,
                       limit: float = LENGTH_SCALE_RATIO) -> dict[str, float]:
    """Refuse positions read in the wrong unit, before any fit, and give the length scale of each measured position:
    the ratio of its spread (the median distance [m] from the median point, indifferent to a frame's placement and to
    gross outliers) to the nominal robot's at the same joint readings, from the calibration's start. Data in metres
    read as millimetres shrink 1000× (the fit would squash the robot onto them): beyond ``limit`` either way
    (default :data:`LENGTH_SCALE_RATIO`; the pipeline gives the plausible band of ``--plausible``) they are refused,
    naming the columns, the unit they were read in and the unit that explains the scale (``metadata``: a job's
    ``column KEY`` and ``unit KEY`` entries; a CSV is in metres). A frame that barely moves (a spread under 1 mm) is not
    judged and has no scale.

    Raises:
        DataError: the measurement, its columns, both spreads [mm] and the likely unit.
    """
    predicted = problem.evaluate(problem.initial_guess(), jacobian=False).predicted
    scales: dict[str, float] = {}
    for m in problem.measurements:
        if length_columns(m.key) != 3 or m.key not in predicted:
            continue
        measured, nominal = problem.observations.values[m.key][:, :3], predicted[m.key][:, :3]
        rows = np.all(np.isfinite(measured), axis=1) & np.all(np.isfinite(nominal), axis=1)
        if np.count_nonzero(rows) < 3:
            continue
        spread_measured, spread_nominal = (float(linalg.median(np.linalg.norm(a[rows] - linalg.median(a[rows], axis=0),
                                                                          axis=1))) for a in (measured, nominal))
        if spread_nominal < 1e-3:
            continue
        ratio = spread_nominal / spread_measured if spread_measured > 0.0 else math.inf
        if not 1.0 / limit <= ratio <= limit:
            raise DataError(_scale_message(m.key, spread_measured, spread_nominal, metadata or {}, limit))
        scales[m.key] = 1.0 / ratio
    return scales


def _scale_message(key: str, measured: float, nominal: float, metadata: Mapping[str, str], limit: float) -> str:
    """Why the positions ``key`` (spread ``measured``, the nominal robot's ``nominal`` [m]) look read in a wrong
    unit: their columns, the unit they were read in, the likely one."""
    name = key.replace(":", " ")
    stated = metadata.get(f"unit {name}", "m")
    columns = metadata.get(f"column {name}", ", ".join(f"{key}:{c}" for c in "xyz"))
    factor = measured / nominal if nominal > 0.0 else math.inf
    shown = f"{factor:.3g}× as much" if factor >= 1.0 else f"{1.0 / factor:.3g}× less"
    unit = likely_unit(stated, factor, LENGTH_UNIT_SIZES) if math.isfinite(factor) and factor > 0.0 else None
    job = "job" in metadata
    state = ("state it as [[measure]] units or [data] units" if job else "convert the file to metres, or describe it "
             "in a job file with its units (docs/job_file.md)")
    cause = (f"the columns are likely in {unit}, not {stated}: {state}" if unit is not None else
             f"no length unit explains a factor of {factor:.3g} (a wrong unit, or a robot of another size; "
             f"plausible=F widens the {limit:.3g}× band, plausible='off' keeps only {LENGTH_SCALE_RATIO:.0f}×)")
    return (f"the measured positions '{key}' (columns {columns}, read in {stated}) spread {measured * 1e3:.4g} mm "
            f"about their median, the nominal robot's at the same joint readings {nominal * 1e3:.4g} mm ({shown}, "
            f"beyond {limit:.3g}× either way): {cause}")


#: A joint's readings look written in a larger unit than read when, as read, they span less than this share of its
#: URDF range, and converted they span at least :data:`SCALED_SPAN` of it within its limits.
NARROW_SPAN = 0.01
SCALED_SPAN = 0.1


def check_joint_scale(robot: Robot, dataset: Dataset) -> None:
    """Refuse a joint's readings read in too small a unit, before any fit: a torso written in metres and read as
    millimetres spans 0.15 mm of its 350 mm range, where in metres it spans 150 mm within its URDF limits. A column
    is refused when, as read, it spans under :data:`NARROW_SPAN` of its joint's range and some unit of the joint's
    kind (m, cm, mm, um, in; rad, mrad, deg) would put every reading within the limits and span at least
    :data:`SCALED_SPAN` of it. The column and the unit come from the dataset's metadata (a job's ``column NAME``
    and ``unit NAME``; a CSV is in m and rad).

    Raises:
        DataError: naming the joint, its column, the span of its readings [m or rad], its range and the likely unit.
    """
    model = robot.model
    for c, name in enumerate(dataset.joint_names):
        if not model.existJointName(name) or model.joints[model.getJointId(name)].nq != 1:
            continue
        idx = model.joints[model.getJointId(name)].idx_q
        lower, upper = float(model.lowerPositionLimit[idx]), float(model.upperPositionLimit[idx])
        values = dataset.joints[:, c][np.isfinite(dataset.joints[:, c])]
        if not (math.isfinite(lower) and math.isfinite(upper) and lower < upper) or len(values) < 2:
            continue
        width, span = upper - lower, float(np.ptp(values))
        if not 0.0 < span < NARROW_SPAN * width:
            continue
        units = LENGTH_UNIT_SIZES if joint_unit(robot, name) == "m" else ANGLE_UNIT_SIZES
        stated = dataset.metadata.get(f"unit {name}", "m" if units is LENGTH_UNIT_SIZES else "rad")
        fits = [u for u, size in units.items() if size > units[stated] and _fits(values * size / units[stated],
                                                                                 lower, upper)]
        if fits:
            unit = max(fits, key=lambda u: units[u])
            column = dataset.metadata.get(f"column {name}", name)
            si = joint_unit(robot, name)
            raise DataError(f"joint '{name}' (column '{column}', read in {stated}) reads {values.min():.4g} to "
                            f"{values.max():.4g} {si}, {span / width:.2%} of its URDF range [{lower:.4g}, "
                            f"{upper:.4g}] {si}: the column is likely in {unit}, not {stated} (in a job file: "
                            f"[joints] {name} = {{ units = \"{unit}\" }}; plausible='off' skips this check)")


def _fits(values: Array, lower: float, upper: float) -> bool:
    """Whether ``values`` lie within [lower, upper] (with :data:`LIMIT_MARGIN` of the range) and span at least
    :data:`SCALED_SPAN` of it."""
    tol = LIMIT_MARGIN * (upper - lower)
    return bool(np.all(values >= lower - tol) and np.all(values <= upper + tol)
                and np.ptp(values) >= SCALED_SPAN * (upper - lower))
