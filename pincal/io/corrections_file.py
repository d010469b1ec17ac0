"""The corrections file: the non-geometric estimates a URDF cannot hold, beside the calibrated URDF.

``pincal calibrate --out cal.urdf`` writes ``cal.corrections.json`` when joint harmonics or compliances were
estimated (:mod:`pincal.identification.corrections` has the model). A controller feeds the calibrated URDF the
*corrected* joint values instead of the raw readings ``q_r`` [rad or m]:

    q = q_r + a₁ sin q_r + b₁ cos q_r + a₂ sin 2q_r + b₂ cos 2q_r + c τ_g(q_r)

per actuated joint, with the coefficients of the file (missing ones are zero) and τ_g the gravity torque of the
*nominal* robot (the URDF given to ``pincal calibrate``) at the readings, plus that of the payload the file records
(``payload``: mass [kg], frame, offset [m] in the frame), the one the calibration was run with. A controller whose
robot carries another load must not reuse the compliance terms as they are: the torque they multiply is another.
:func:`corrected_readings` does it.
"""

from __future__ import annotations

import json
import os
from pathlib import Path
from typing import Any

import numpy as np
import numpy.typing as npt

from pincal.errors import DataError, listing
from pincal.identification.corrections import HARMONIC_TERMS, Payload, correction_regressors, payload_from_dict
from pincal.identification.parameters import ParameterSet
from pincal.model.catalog import known_robot_names, robot_path
from pincal.model.robot import Robot
from pincal.records import record

Array = npt.NDArray[np.float64]

FORMAT = "pincal joint corrections 1"
TERMS = (*(t[0] for t in HARMONIC_TERMS), "compliance")
FORMULA = "q = q_r + sin1 sin(q_r) + cos1 cos(q_r) + sin2 sin(2 q_r) + cos2 cos(2 q_r) + compliance tau_g(q_r)"


@record(frozen=True)
class Corrections:
    """Per actuated joint, its correction coefficients: term (``sin1``, ``cos1``, ``sin2``, ``cos2`` [rad or m],
    ``compliance`` [rad/(N m) or m/N]) -> value; the payload whose torque the compliances multiply with the
    links' (None: the links' alone); the nominal URDF (path or robot name) the file names, ``""`` when unknown."""

    robot: str
    joints: dict[str, dict[str, float]]
    payload: Payload | None = None
    nominal_urdf: str = ""


def corrections_path(urdf: str | Path) -> Path:
    """Where the corrections of a calibrated URDF go: ``cal.urdf`` -> ``cal.corrections.json``; a name without the
    ``.urdf`` suffix keeps its own (``cal.xml`` -> ``cal.xml.corrections.json``), so that ``cal.urdf`` and
    ``cal.urdf2`` do not share one (a name with no suffix, ``cal``, still shares ``cal.urdf``'s)."""
    path = Path(urdf)
    return path.with_name(f"{path.stem if path.suffix.lower() == '.urdf' else path.name}.corrections.json")


def corrections_of(robot: Robot, parameters: ParameterSet, x: Array,
                   payload: Payload | None = None) -> Corrections | None:
    """The correction estimates among ``parameters`` (values ``x``), with the ``payload`` they were estimated under,
    or None when there are none."""
    joints: dict[str, dict[str, float]] = {}
    for p, value in zip(parameters, x, strict=True):
        if p.kind_class.in_corrections:
            joints.setdefault(p.owner, {})[p.term] = float(value)
    return Corrections(robot.name, joints, payload) if joints else None


def robot_files(robot: Robot) -> list[Path]:
    """The files a robot was read from: its URDF and the corrections file beside it, if there is one (inputs no
    output may replace)."""
    if robot.source is None:
        return []
    beside = corrections_path(robot.source)
    return [Path(robot.source), *([beside] if beside.is_file() else [])]


def corrections_dict(corrections: Corrections, nominal: Robot, folder: Path | None = None) -> dict[str, Any]:
    """The file's content: format, formula, units, where τ_g comes from (the nominal URDF, by its path relative to
    ``folder``, the corrections file's, when given), the payload (None: none) and the coefficients."""
    return {
        "format": FORMAT,
        "robot": corrections.robot,
        "formula": FORMULA,
        "units": {"sin1, cos1, sin2, cos2": "the joint's unit (rad, or m for a prismatic joint)",
                  "compliance": "rad/(N m), or m/N for a prismatic joint", "q_r, q": "rad or m",
                  "payload": "mass kg, offset m in the payload's frame"},
        "tau_g": "gravity torque [N m or N] of the nominal robot at the readings q_r (Pinocchio "
                 "computeGeneralizedGravity, 9.81 m/s^2 along -z of the root), plus J_p(q_r)^T m (0, 0, 9.81) of "
                 "the payload's point p when there is one",
        "nominal_urdf": _named_from(nominal, folder),
        "payload": corrections.payload.as_dict() if corrections.payload is not None else None,
        "joints": corrections.joints,
    }


def read_corrections(path: str | Path) -> Corrections:
    """Read a corrections file; its ``nominal_urdf``, a path relative to the file, is resolved against the file's
    folder (a known robot's name stays a name).

    Raises:
        DataError: unreadable, not JSON, another format, an unknown term (named), or a malformed payload.
    """
    try:
        content = json.loads(Path(path).read_text(encoding="utf-8"))
    except (OSError, json.JSONDecodeError) as exc:
        raise DataError(f"cannot read the corrections file '{path}': {exc}") from None
    if not isinstance(content, dict) or content.get("format") != FORMAT:
        raise DataError(f"'{path}' is not a pincal corrections file (its 'format' must be '{FORMAT}')")
    joints = content.get("joints")
    if not isinstance(joints, dict):
        raise DataError(f"'{path}': 'joints' must map joint names to their coefficients")
    out: dict[str, dict[str, float]] = {}
    for joint, terms in joints.items():
        unknown = [t for t in terms if t not in TERMS] if isinstance(terms, dict) else ["(not a mapping)"]
        if unknown:
            raise DataError(f"'{path}': joint '{joint}' has unknown terms {listing(unknown)}; terms are: "
                            f"{listing(TERMS)}")
        out[str(joint)] = {str(t): float(v) for t, v in terms.items()}
    payload = payload_from_dict(content.get("payload"), f"'{path}': ")
    nominal = str(content.get("nominal_urdf") or "")
    beside = Path(path).parent / nominal  # a path relative to the file (a known robot: its name)
    return Corrections(str(content.get("robot", "")), out, payload, str(beside) if nominal and beside.is_file()
                       else nominal)


def corrected_readings(corrections: Corrections, nominal: Robot, actuated: npt.ArrayLike) -> Array:
    """The joint values [rad or m] to give the calibrated URDF for raw readings ``actuated`` (N, na) or (na,), in
    ``nominal.actuated_joints`` order; ``nominal`` is the robot the calibration started from (for τ_g, with the
    payload of the corrections).

    Raises:
        DataError: a joint of the corrections that is not an actuated joint of ``nominal``.
        NotFoundError: the payload's frame is not one of ``nominal``'s.
    """
    readings = np.asarray(actuated, dtype=float)
    rows = readings.reshape(-1, nominal.n_actuated)
    strays = [j for j in corrections.joints if j not in nominal.actuated_joints]
    if strays:
        raise DataError(f"the corrections name {listing(strays)}, which are not actuated joints of '{nominal.name}'")
    kinds = [(joint, term) for joint, terms in corrections.joints.items() for term in terms]
    out = rows.copy()
    index = {name: k for k, name in enumerate(nominal.actuated_joints)}
    regressors = correction_regressors(nominal, kinds, rows, corrections.payload)
    for (joint, term), regressor in zip(kinds, regressors, strict=True):
        out[:, index[joint]] += corrections.joints[joint][term] * regressor
    return out.reshape(readings.shape)


def _named_from(robot: Robot, folder: Path | None) -> str:
    """The robot's URDF as a file in ``folder`` names it: a known robot by its name (:mod:`pincal.model.catalog`),
    another relative to ``folder`` (absolute with no folder, or where no relative path leads)."""
    if robot.source is None or _is_catalog(robot):
        return robot.name
    if folder is None:
        return str(robot.source)
    try:
        return Path(os.path.relpath(Path(robot.source).resolve(), folder.resolve())).as_posix()
    except ValueError:
        return Path(robot.source).resolve().as_posix()


def _is_catalog(robot: Robot) -> bool:
    """Whether ``robot`` was loaded by its name from pincal's catalog of known robots."""
    if robot.name not in known_robot_names() or robot.source is None:
        return False
    return Path(robot.source).resolve() == robot_path(robot.name).resolve()


#: Most fixed-point iterations of :func:`raw_commands`.
MAX_INVERSION_ITERATIONS = 50


def raw_commands(corrections: Corrections, nominal: Robot, wanted: npt.ArrayLike,
                 tol: float = 1e-13) -> tuple[Array, Array]:
    """The raw commands ``q_r`` [rad or m] whose corrected values are ``wanted``: the inverse of
    :func:`corrected_readings`, ``q_r + δq(q_r) = q``, for rows ``wanted`` (N, na) or one (na,).

    Fixed-point iteration ``q_r ← q − δq(q_r)`` from ``q_r = q``: it contracts by ``|∂δq/∂q_r|`` per step (of the order
    of the coefficients, 1e-3 for a millimetre-sized robot), so a few steps reach ``tol``.

    Returns:
        ``q_r`` (the shape of ``wanted``) and, per row, the largest ``|q_r + δq(q_r) − q|`` [rad or m] left.
    """
    target = np.asarray(wanted, dtype=float)
    rows = target.reshape(-1, nominal.n_actuated)
    raw = rows.copy()
    residual = np.zeros(len(rows))
    for _ in range(MAX_INVERSION_ITERATIONS):
        gap = corrected_readings(corrections, nominal, raw) - rows
        residual = np.abs(gap).max(axis=1, initial=0.0)
        if not residual.max(initial=0.0) > tol:
            break
        raw -= gap
    return raw.reshape(target.shape), residual
