"""Non-geometric errors as corrections of the joint values: what a URDF cannot hold.

A correction changes the value an actuated joint takes for a given reading ``q_r`` [rad or m]:

    q = q_r + δq,   δq = a₁ sin q_r + b₁ cos q_r + a₂ sin 2q_r + b₂ cos 2q_r + c τ_g(q_r)

- the **harmonics** ``a₁, b₁, a₂, b₂`` (parameters ``<joint>.sin1``, ``.cos1``, ``.sin2``, ``.cos2``, in the joint's
  unit) model an encoder's eccentricity and mounting (once and twice per turn);
- the **compliance** ``c`` (``<joint>.compliance`` [rad/(N m)], or [m/N] for a prismatic joint) a joint's
  elastic deflection under the gravity torque ``τ_g`` [N m or N]: Pinocchio's ``computeGeneralizedGravity`` of
  the *nominal* robot (its URDF masses) at the read configuration, gravity −9.81 m/s² along the root's z, plus
  that of a :class:`Payload` when one is given (a point mass on a named frame: a tool, a load in the gripper).

δq is linear in the parameters with a regressor that depends on the readings only, so its derivative is exact:
``∂q/∂a₁ = sin q_r`` and ``∂q/∂c = τ_g(q_r)`` (the measurement models take ∂q the way they take a reading
offset's). Compliance needs a tree: in a closed loop the joint torques depend on the constraint forces, which
pincal does not model; a robot whose moving links carry no mass is refused too, unless a payload is given: its torque
is then the whole load. The reading offsets (``.offset``)
stay in the calibrated URDF; these corrections go to the corrections file (:mod:`pincal.io.corrections_file`).
"""

from __future__ import annotations

import math
from collections.abc import Sequence
from typing import Any

import numpy as np
import numpy.typing as npt
import pinocchio as pin

from pincal.errors import DataError, listing
from pincal.model.jacobians import computed_frame_jacobian
from pincal.model.robot import Robot
from pincal.records import record

Array = npt.NDArray[np.float64]

#: Harmonic terms, in parameter-name order: (name, order, sine?).
HARMONIC_TERMS = (("sin1", 1, True), ("cos1", 1, False), ("sin2", 2, True), ("cos2", 2, False))
#: Standard gravity [m/s²], along −z of the robot's root (Pinocchio's default).
GRAVITY = 9.81


def harmonic_regressor(readings: Array, term: str) -> Array:
    """The regressor of harmonic ``term`` (``sin1``, ``cos1``, ``sin2``, ``cos2``) at the readings [rad]."""
    for name, order, sine in HARMONIC_TERMS:
        if name == term:
            return np.sin(order * readings) if sine else np.cos(order * readings)
    raise DataError(f"unknown harmonic term '{term}'; terms are: {', '.join(t[0] for t in HARMONIC_TERMS)}")


@record(frozen=True)
class Payload:
    """A point mass the robot carries: ``mass`` [kg] on frame ``frame``, at ``offset`` [m] in that frame.

    Its gravity torque adds to the links' in the compliance regressor (:func:`gravity_torques`):
    ``τ_p(q) = J_p(q)ᵀ · m · (0, 0, 9.81)``, with ``J_p`` the (3, nv) Jacobian of the point's position in the root's
    axes, i.e. the gradient of its potential energy ``m g z_p(q)``. A payload is known, not fitted: its mass and place
    are the user's (a tool's data sheet, a weighed load), and the fitted compliances are per unit of torque.

    Raises:
        DataError: a negative, infinite or NaN mass, an empty frame name, or an offset that is not three finite
            numbers (each named).
    """

    mass: float
    frame: str
    offset: tuple[float, float, float] = (0.0, 0.0, 0.0)

    def __post_init__(self) -> None:
        try:
            mass = float(self.mass)
        except (TypeError, ValueError):
            raise DataError(f"payload mass {self.mass!r} is not a number [kg]") from None
        if not math.isfinite(mass) or mass < 0.0:
            raise DataError(f"payload mass {mass:g} kg: a mass is a finite number ≥ 0 [kg]")
        if not isinstance(self.frame, str) or not self.frame.strip():
            raise DataError(f"payload frame {self.frame!r}: name the frame the mass is on (a link or frame of the "
                            "URDF)")
        try:
            offset = tuple(float(v) for v in self.offset)
        except (TypeError, ValueError):
            raise DataError(f"payload offset {self.offset!r} is not three numbers x, y, z [m]") from None
        if len(offset) != 3 or not all(math.isfinite(v) for v in offset):
            raise DataError(f"payload offset {listing(f'{v:g}' for v in offset)}: give three finite numbers x, y, z "
                            f"[m] in frame '{self.frame}'")
        object.__setattr__(self, "mass", mass)
        object.__setattr__(self, "frame", self.frame.strip())
        object.__setattr__(self, "offset", offset)

    def __str__(self) -> str:
        """``1.5 kg on tool0`` (``at (0, 0, 0.1) m`` when offset)."""
        at = f" at ({', '.join(f'{v:g}' for v in self.offset)}) m" if any(self.offset) else ""
        return f"{self.mass:g} kg on {self.frame}{at}"

    def as_dict(self) -> dict[str, Any]:
        """``{"mass": [kg], "frame": name, "offset": [x, y, z] [m]}``: how the corrections file and the report hold
        it (:func:`payload_from_dict` reads it back)."""
        return {"mass": self.mass, "frame": self.frame, "offset": list(self.offset)}

    def check(self, robot: Robot) -> int:
        """The payload frame's Pinocchio id in ``robot``.

        Raises:
            NotFoundError: the frame does not exist; the message lists the robot's frames.
        """
        return robot.frame_id(self.frame, "payload: ")


def moving_mass(robot: Robot) -> float:
    """The mass [kg] of every link a joint moves, together (the URDF's inertias): what a payload's mass is weighed
    against for plausibility."""
    return float(sum(inertia.mass for inertia in robot.model.inertias[1:]))


def payload_from_dict(value: Any, context: str = "") -> Payload | None:
    """A :class:`Payload` from ``{"mass": ..., "frame": ..., "offset": [...]}`` (offset optional), None from None.

    Raises:
        DataError: not such a mapping, or a bad value; ``context`` (``job.toml: ``) starts the message.
    """
    if value is None:
        return None
    keys = ("mass", "frame", "offset")
    if not isinstance(value, dict) or not {"mass", "frame"} <= set(value) or not set(value) <= set(keys):
        raise DataError(f"{context}payload {value!r} is not {{mass = KG, frame = \"NAME\", offset = [X, Y, Z]}} "
                        "(offset optional, in metres in the frame)")
    offset = value.get("offset", (0.0, 0.0, 0.0))
    numbers = [value["mass"], *offset] if isinstance(offset, list | tuple) else None
    if numbers is None or any(isinstance(v, bool) or not isinstance(v, int | float) for v in numbers):
        raise DataError(f"{context}payload {value!r}: mass is a number [kg], offset a list of three numbers [m]")
    try:
        return Payload(value["mass"], value["frame"], tuple(offset))
    except DataError as exc:
        raise DataError(f"{context}{exc}") from None


def payload_torque(robot: Robot, payload: Payload, q: Array, data: pin.Data | None = None) -> Array:
    """(nv,) generalized gravity torque [N m or N] of ``payload`` at configuration ``q`` (nq,).

    ``τ_p = −J_pᵀ m g``, ``g`` the model's gravity (0, 0, −9.81) m/s²: the gradient of the potential energy
    ``m g z_p(q)``, the sign of Pinocchio's ``computeGeneralizedGravity`` (the torque that holds the mass still).
    ``J_p = J_v − [R o]× J_ω`` from the frame's Jacobian in ``LOCAL_WORLD_ALIGNED`` (the frame origin's velocity,
    root axes) and the offset ``o`` turned into root axes by the frame's rotation ``R``.
    """
    model = robot.model
    data = data if data is not None else model.createData()
    frame = payload.check(robot)
    jacobian = computed_frame_jacobian(model, data, q, frame, pin.LOCAL_WORLD_ALIGNED)
    lever = pin.updateFramePlacement(model, data, frame).rotation @ np.asarray(payload.offset)
    point = jacobian[:3] - pin.skew(lever) @ jacobian[3:]
    return np.asarray(-payload.mass * (point.T @ model.gravity.linear), dtype=float)


def gravity_torques(robot: Robot, actuated: Array, payload: Payload | None = None) -> Array:
    """(N, na) gravity torques [N m or N] on the actuated joints of the robot at each row of readings [rad or m]:
    the links' (their URDF ``<inertial>`` masses) plus the ``payload``'s, if given (:func:`payload_torque`).

    A robot whose links carry no mass may still have compliance fitted when a payload of positive mass is given: the
    torques are then the payload's alone (a light arm under a heavy tool; wrong when the URDF merely leaves out the
    real masses).

    Raises:
        DataError: the robot has loops (the torques then depend on the constraint forces), or neither its moving links
            nor a payload carry mass (no gravity torque to deflect the joints).
        NotFoundError: the payload's frame is not one of the robot's (the frames are listed).
    """
    if robot.loops:
        raise DataError(f"joint compliance needs gravity torques, which pincal computes for trees only; robot "
                        f"'{robot.name}' has loops (their constraint forces are not modelled): fit harmonics or "
                        "offsets instead")
    model = robot.model
    if payload is not None:
        payload.check(robot)
    loaded = payload is not None and payload.mass > 0.0
    if not loaded and sum(float(model.inertias[j].mass) for j in range(1, model.njoints)) <= 0.0:
        raise DataError(f"joint compliance needs the links' masses, and the links of robot '{robot.name}' carry no "
                        "<inertial> mass in the URDF" + (f" (the payload, {payload}, has none either)" if payload
                                                         else "; when the load is a payload alone, give it "
                                                              "(--payload MASS@FRAME)"))
    data = model.createData()
    columns = [model.joints[robot.joint_id(j)].idx_v for j in robot.actuated_joints]
    rows = np.asarray(actuated, dtype=float).reshape(-1, robot.n_actuated)
    out = np.empty_like(rows)
    for k, qa in enumerate(rows):
        q = robot.solve_fk(qa)
        torque = pin.computeGeneralizedGravity(model, data, q).copy()
        if loaded:
            assert payload is not None
            torque += payload_torque(robot, payload, q, data)
        out[k] = torque[columns]
    return out


def correction_regressors(robot: Robot, kinds: Sequence[tuple[str, str]], actuated: Array,
                          payload: Payload | None = None) -> list[Array]:
    """One (N,) regressor per correction parameter, for readings ``actuated`` (N, na) [rad or m].

    Args:
        robot: The nominal robot.
        kinds: Per parameter, its joint and its term: ``sin1``, ``cos1``, ``sin2``, ``cos2`` or ``compliance``.
        actuated: The actuated readings, in ``robot.actuated_joints`` order.
        payload: A point mass whose gravity torque adds to the links' in the compliance regressors (unused without
            a compliance term).
    """
    index = {name: k for k, name in enumerate(robot.actuated_joints)}
    torques = (gravity_torques(robot, actuated, payload) if any(term == "compliance" for _, term in kinds)
               else None)
    out = []
    for joint, term in kinds:
        readings = actuated[:, index[joint]]
        if term == "compliance":
            assert torques is not None
            out.append(torques[:, index[joint]])
        else:
            out.append(harmonic_regressor(readings, term))
    return out
