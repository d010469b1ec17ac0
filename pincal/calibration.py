"""The calibration workflow: dataset ↔ problem, parameter choice, calibrated URDF, report JSON.

The calibrated URDF is the nominal file with its joint and anchor origins edited, actuated offsets
folded into the actuated joints' origins, and the tree re-assembled: the closed configuration of the
calibrated robot at zero actuated readings becomes the new all-zero configuration (each passive
joint's value is folded into its origin), so the file obeys pincal's convention and loads back.
"""

from __future__ import annotations

import json
import math
from collections.abc import Sequence
from pathlib import Path
from typing import Any

import numpy as np
import numpy.typing as npt
import pinocchio as pin

from pincal.errors import ConvergenceError, DataError, RobotFileError, listing
from pincal.files import write_text
from pincal.identification import CalibrationResult, calibration_gain, error_norms, rms
from pincal.measurements import JointReading, Measurement, Pose, joint_reading, parse_key
from pincal.parameters import KINEMATIC_KINDS, NAMED_SETS, ParameterSet, candidate_parameters
from pincal.problem import CalibrationProblem, Observations
from pincal.robot import Robot, _build_model, check_reference_assembly
from pincal.urdf import origin_to_se3, read_extensions
from pincal.urdf_writer import calibrated_urdf_text

Array = npt.NDArray[np.float64]


# --- dataset <-> problem ---------------------------------------------------------------------------
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


def observations_from(robot: Robot, joint_names: Sequence[str], joints: Array, measurements: dict[str, Array],
                      models: Sequence[Measurement]) -> Observations:
    """Observations for ``models`` from dataset columns."""
    missing = [j for j in robot.actuated_joints if j not in joint_names]
    if missing:
        raise DataError(f"the data has no column for actuated joint(s) {listing(missing)}; joint columns are: "
                        f"{listing(joint_names) or 'none'}")
    cols = [list(joint_names).index(j) for j in robot.actuated_joints]
    values = dict(measurements)
    for m in models:
        if isinstance(m, JointReading):
            values[m.key] = joints[:, [list(joint_names).index(m.joint)]]
    return Observations(np.asarray(joints, dtype=float)[:, cols], values)


def choose_parameters(robot: Robot, models: Sequence[Measurement], spec: Sequence[str] | None = None) -> ParameterSet:
    """The unknowns: a named set (``model24``, ``hexapod42``, ``hexapod44``), shell patterns over the
    candidates, or by default every candidate parameter (the identifiability analysis then keeps the
    identifiable ones).

    Candidates: all joint and anchor placements, fixed joints leading to measured frames, offsets of
    the actuated and of the read passive joints, and the base placement when positions or poses are
    measured in an external frame.
    """
    frames = sorted({f for m in models for f in m.frames})
    read = [m.joint for m in models if isinstance(m, JointReading)]
    external = any(m.key.split(":", 1)[0] in ("position", "pose") for m in models)
    pool = candidate_parameters(robot, frames=frames, offsets=list(robot.actuated_joints) + read, base=external)
    if not spec:
        return pool
    if len(spec) == 1 and spec[0] in NAMED_SETS:
        return NAMED_SETS[spec[0]](robot)
    return pool.select(list(spec))


def unusable_samples(robot: Robot, actuated: Array, max_condition: float = 1e5) -> list[tuple[int, str]]:
    """Samples the nominal robot cannot assemble (FK does not converge) or that sit at a singularity
    (the passive joints are not determined by the actuated readings), with the reason for each."""
    out: list[tuple[int, str]] = []
    for k, qa in enumerate(np.asarray(actuated, dtype=float)):
        report = robot.solve_fk_report(qa)
        if not report.converged:
            out.append((k, f"forward kinematics did not converge (closure residual {report.residual:.3g})"))
            continue
        if robot.loops:
            _, jac = robot.kinematics.closure_jacobian(report.q)
            s = np.linalg.svd(jac[:, robot.kinematics.passive_v], compute_uv=False)
            if s[-1] <= 0.0 or s[0] / s[-1] > max_condition:
                out.append((k, f"singular configuration (passive closure Jacobian condition number "
                               f"{(s[0] / s[-1]) if s[-1] > 0 else float('inf'):.3g})"))
    return out


# --- calibrated URDF -------------------------------------------------------------------------------
def joint_motion(model: pin.Model, jid: int, q: Array) -> pin.SE3:
    """The motion of joint ``jid`` at configuration ``q`` as a placement (``liMi = placement · motion``)."""
    data = model.createData()
    pin.forwardKinematics(model, data, q)
    return model.jointPlacements[jid].inverse() * data.liMi[jid]


def _joint_axis_motion(robot: Robot, joint: str, value: float) -> pin.SE3:
    """A one-DOF joint's motion for ``value`` [rad or m], as a placement."""
    model = robot.model
    jid = model.getJointId(joint)
    q = pin.neutral(model)
    jm = model.joints[jid]
    if jm.nq == 1:
        q[jm.idx_q] = value
    else:
        q[jm.idx_q:jm.idx_q + 2] = [math.cos(value), math.sin(value)]
    return joint_motion(model, jid, q)


def calibrated_robot_text(robot: Robot, source_text: str, parameters: ParameterSet, x: Array,
                          note: str = "") -> tuple[str, dict[str, float]]:
    """URDF text of ``robot`` with deviations ``x`` applied and re-assembled at zero readings.

    Returns:
        The text, and the reference shift of each passive joint [rad or m]: the new zero is the old
        value plus this shift. A reading of an instrumented passive joint in the new file's terms is
        ``reading + δ − shift``, with δ its estimated reading offset (``<joint>.offset``) if any.

    Raises:
        ConvergenceError: the calibrated loops cannot be closed at zero actuated readings.
    """
    ext = read_extensions(source_text)
    root = _xml_joint_origins(source_text)
    joint_origins: dict[str, pin.SE3] = {}
    loop_origins: dict[tuple[str, str], pin.SE3] = {}
    loops = {lp.name: lp for lp in ext.loops}
    for (kind, target, side), idx in parameters.groups(*KINEMATIC_KINDS).items():
        exp = pin.exp6(parameters.placement_delta(x, idx))
        if kind == "joint":
            joint_origins[target] = joint_origins.get(target, root[target]) * exp
        else:
            loop = loops[target]
            base = loop.predecessor_origin if side == "predecessor" else loop.successor_origin
            loop_origins[(target, side)] = base * exp
    for k, p in enumerate(parameters):
        if p.kind == "offset" and p.target in robot.actuated_joints and x[k] != 0.0:
            motion = _joint_axis_motion(robot, p.target, x[k])
            joint_origins[p.target] = joint_origins.get(p.target, root[p.target]) * motion
    text = calibrated_urdf_text(source_text, joint_origins, loop_origins)
    shifts: dict[str, float] = {}
    if ext.loops:
        model = _build_model(text, "calibrated URDF")
        loose = Robot(model, read_extensions(text).loops, robot.actuated_joints, robot.name)
        report = loose.solve_fk_report(np.zeros(loose.n_actuated))
        if not report.converged:
            raise ConvergenceError(f"the calibrated loops do not close at zero actuated readings (residual "
                                   f"{report.residual:.3g}): the estimate is far from the nominal robot")
        q = report.q
        for jid in range(1, model.njoints):
            name = str(model.names[jid])
            jm = model.joints[jid]
            if name in robot.actuated_joints:
                continue
            if jm.nv > 1:  # floating, planar, ...: fold the joint's whole motion into its origin
                joint_origins[name] = joint_origins.get(name, root[name]) * joint_motion(loose.model, jid, q)
                continue
            value = q[jm.idx_q] if jm.nq == 1 else math.atan2(q[jm.idx_q + 1], q[jm.idx_q])
            if value != 0.0:
                shifts[name] = float(value)
                joint_origins[name] = joint_origins.get(name, root[name]) * _joint_axis_motion(loose, name, value)
        text = calibrated_urdf_text(source_text, joint_origins, loop_origins, header_note=note)
        check_reference_assembly(Robot(_build_model(text, "calibrated URDF"), read_extensions(text).loops,
                                       robot.actuated_joints, robot.name), "calibrated URDF")
    elif note:
        text = calibrated_urdf_text(source_text, joint_origins, loop_origins, header_note=note)
    return text, shifts


def _xml_joint_origins(text: str) -> dict[str, pin.SE3]:
    import xml.etree.ElementTree as ET

    root = ET.fromstring(text)
    return {j.get("name", ""): origin_to_se3(j.find("origin"), f"joint '{j.get('name')}'")
            for j in root.findall("joint")}


def source_text(robot: Robot) -> str:
    if robot.source is None:
        raise RobotFileError(f"robot '{robot.name}' has no source file to write a calibrated URDF from")
    return Path(robot.source).read_text(encoding="utf-8")


# --- report ----------------------------------------------------------------------------------------
BEFORE_MEANS_REGISTERED = ("the nominal robot, with the measurement frame registered to the training data in "
                           "closed form (Kabsch), for fit and held-out samples alike")
BEFORE_MEANS_NOMINAL = "the nominal robot in the nominal measurement frame, for fit and held-out samples alike"


def registered_base(parameters: ParameterSet) -> bool:
    """True when the measurement frame is estimated whole (all six ``base.*``), so that the starting point
    registers it in closed form (:meth:`CalibrationProblem.initial_guess`)."""
    return len(parameters.groups("base").get(("base", "base", ""), [])) == 6


def angle_error_norms(errors: dict[str, Array]) -> Array:
    """Per-sample orientation error angles [rad] of the pose measurements (norm of ``log3(R_measᵀ R_pred)``)."""
    parts = [np.linalg.norm(err[:, 3:6], axis=1) for key, err in errors.items() if key.split(":", 1)[0] == "pose"]
    return np.concatenate(parts) if parts else np.zeros(0)


def report_dict(result: CalibrationResult, problem: CalibrationProblem, x_true: Array | None = None,
                shifts: dict[str, float] | None = None) -> dict[str, Any]:
    """The results JSON: errors before/after [m], identifiability, estimates with std, solver account.

    Wall-clock time is left out on purpose: the same inputs and seed give a byte-identical file.
    """
    before = error_norms(result.errors_before)
    after = error_norms(result.errors_after)
    ident = result.identifiability
    angles_before = angle_error_norms(result.errors_before)
    angles_after = angle_error_norms(result.errors_after)

    def clean(v: float) -> float | None:
        return None if not math.isfinite(v) else float(v)

    out: dict[str, Any] = {
        "robot": problem.robot.name,
        "units": "SI: m, rad",
        "n_samples": problem.observations.n_samples,
        "measurements": [m.key for m in problem.measurements],
        "n_parameters": len(result.names),
        "n_identifiable": ident.rank,
        "condition_number": clean(ident.condition_number),
        "rms_before": clean(rms(before)),
        "rms_after": clean(rms(after)),
        "max_before": clean(float(before.max())) if before.size else None,
        "max_after": clean(float(after.max())) if after.size else None,
        "before_means": BEFORE_MEANS_REGISTERED if registered_base(problem.parameters) else BEFORE_MEANS_NOMINAL,
        "iterations": result.iterations,
        "converged": result.converged,
        "message": result.message,
        "solver": result.solver,
        "loss": result.loss,
        "sigma2": clean(result.sigma2),
        "cost_history": [float(c) for c in result.cost_history],
        "parameters": {name: {"value": float(result.x[k]), "std": clean(float(result.std[k])),
                              "identified": k in set(result.identified)}
                       for k, name in enumerate(result.names)},
        "unidentifiable": [c.description for c in ident.unidentifiable],
        "down_weighted_samples": result.down_weighted(),
        "reference_shifts": shifts or {},
    }
    if angles_before.size:
        out.update({"rms_angle_before": clean(rms(angles_before)), "rms_angle_after": clean(rms(angles_after)),
                    "max_angle_before": clean(float(angles_before.max())),
                    "max_angle_after": clean(float(angles_after.max()))})
    if x_true is not None:
        out["calibration_gain"] = clean(calibration_gain(x_true, result.x0, result.x))
        out["parameter_errors_before"] = float(np.linalg.norm(x_true - result.x0))
        out["parameter_errors_after"] = float(np.linalg.norm(x_true - result.x))
    return out


def write_json(path: str | Path, content: dict[str, Any]) -> None:
    write_text(path, json.dumps(content, indent=2, sort_keys=False) + "\n")
