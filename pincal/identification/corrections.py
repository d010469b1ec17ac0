"""Non-geometric errors as corrections of the joint values: what a URDF cannot hold.

A correction changes the value an actuated joint takes for a given reading ``q_r`` [rad or m]:

    q = q_r + δq,   δq = a₁ sin q_r + b₁ cos q_r + a₂ sin 2q_r + b₂ cos 2q_r + c τ_g(q_r)

- the **harmonics** ``a₁, b₁, a₂, b₂`` (parameters ``<joint>.sin1``, ``.cos1``, ``.sin2``, ``.cos2``, in the joint's
  unit) model an encoder's eccentricity and mounting (once and twice per turn);
- the **compliance** ``c`` (``<joint>.compliance`` [rad/(N m)], or [m/N] for a prismatic joint) a joint's
  elastic deflection under the gravity torque ``τ_g`` [N m or N]: Pinocchio's ``computeGeneralizedGravity`` of
  the *nominal* robot (its URDF masses) at the read configuration, gravity −9.81 m/s² along the root's z.

δq is linear in the parameters with a regressor that depends on the readings only, so its derivative is exact:
``∂q/∂a₁ = sin q_r`` and ``∂q/∂c = τ_g(q_r)`` (the measurement models take ∂q the way they take a reading
offset's). Compliance needs a tree: in a closed loop the joint torques depend on the constraint forces, which
pincal does not model; a robot whose moving links carry no mass is refused too. The reading offsets (``.offset``)
stay in the calibrated URDF; these corrections go to the corrections file (:mod:`pincal.io.corrections`).
"""

from __future__ import annotations

from collections.abc import Sequence

import numpy as np
import numpy.typing as npt
import pinocchio as pin

from pincal.errors import DataError
from pincal.model.robot import Robot

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


def gravity_torques(robot: Robot, actuated: Array) -> Array:
    """(N, na) gravity torques [N m or N] on the actuated joints of the robot at each row of readings [rad or m].

    Raises:
        DataError: the robot has loops (the torques then depend on the constraint forces), or its moving links
            carry no mass (no gravity torque to deflect the joints).
    """
    if robot.loops:
        raise DataError(f"joint compliance needs gravity torques, which pincal computes for trees only; robot "
                        f"'{robot.name}' has loops (their constraint forces are not modelled): fit harmonics or "
                        "offsets instead")
    model = robot.model
    if sum(float(model.inertias[j].mass) for j in range(1, model.njoints)) <= 0.0:
        raise DataError(f"joint compliance needs the links' masses, and the links of robot '{robot.name}' carry no "
                        "<inertial> mass in the URDF")
    data = model.createData()
    columns = [model.joints[robot.joint_id(j)].idx_v for j in robot.actuated_joints]
    rows = np.asarray(actuated, dtype=float).reshape(-1, robot.n_actuated)
    out = np.empty_like(rows)
    for k, qa in enumerate(rows):
        q = robot.solve_fk(qa)
        out[k] = pin.computeGeneralizedGravity(model, data, q)[columns]
    return out


def correction_regressors(robot: Robot, kinds: Sequence[tuple[str, str]], actuated: Array) -> list[Array]:
    """One (N,) regressor per correction parameter, for readings ``actuated`` (N, na) [rad or m].

    Args:
        robot: The nominal robot.
        kinds: Per parameter, its joint and its term: ``sin1``, ``cos1``, ``sin2``, ``cos2`` or ``compliance``.
        actuated: The actuated readings, in ``robot.actuated_joints`` order.
    """
    index = {name: k for k, name in enumerate(robot.actuated_joints)}
    torques = gravity_torques(robot, actuated) if any(term == "compliance" for _, term in kinds) else None
    out = []
    for joint, term in kinds:
        readings = actuated[:, index[joint]]
        if term == "compliance":
            assert torques is not None
            out.append(torques[:, index[joint]])
        else:
            out.append(harmonic_regressor(readings, term))
    return out
