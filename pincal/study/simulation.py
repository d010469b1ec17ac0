"""Simulated calibration data: a true robot (nominal + known errors), reachable postures, noisy readings.

Units: perturbation and noise scales are standard deviations in metres for lengths and radians for
angles (``perturb=1e-3`` means 1 mm and 1 mrad).
"""

from __future__ import annotations

from collections.abc import Sequence

import numpy as np
import numpy.typing as npt

from pincal.errors import ConvergenceError, DataError
from pincal.identification.corrections import Payload
from pincal.identification.measurements import Measurement
from pincal.identification.parameters import ParameterSet
from pincal.identification.problem import CalibrationProblem, Observations
from pincal.model.assemblable import assemble
from pincal.model.robot import Robot
from pincal.progress import Progress

Array = npt.NDArray[np.float64]

#: Half-range of random actuated values about the reference [rad or m] for the robots whose URDF limits do not
#: describe the workspace: drawn within those limits, most hexapod (77 %) and 3-UCR (90 %) postures cannot be
#: assembled, and most five-bar ones (55 %) put a passive joint outside its own limits.
SPREAD = {"five_bar": 0.35, "hexapod": 0.12, "hexapod_device": 0.12, "ucr3": 0.04}
#: Random postures judged at once while drawing (at least; twice the number still needed when that is more).
DRAWS_AT_ONCE = 16
#: Half-range about the reference [rad or m] of an actuated joint without finite URDF limits (a continuous
#: joint), on a closed-loop robot and on a serial one.
UNBOUNDED_SPREAD = {"closed": 0.5, "serial": float(np.pi)}


def perturbation(parameters: ParameterSet, scale: float, rng: np.random.Generator) -> Array:
    """Random true deviations: normal with standard deviation ``scale`` [m or rad] per length or angle parameter;
    a compliance draws ``scale`` relative to its typical size (``scale`` = 1e-3: 1 mrad under 10 N m)."""
    draws = rng.normal(scale=scale, size=len(parameters))
    relative = np.array([1.0 if p.unit in ("m", "rad") else p.scale / 1e-3 for p in parameters])
    return np.asarray(draws * relative, dtype=np.float64)


def actuated_ranges(robot: Robot, spread: float | None = None) -> tuple[Array, Array]:
    """The range [lower, upper] (na,) [rad or m] random actuated values are drawn from, per actuated joint.

    By default, a joint's URDF limits; for a joint without finite limits (a continuous joint, or limits whose span
    overflows the floats) and for the robots of :data:`SPREAD`, a half-range about the reference
    (:data:`UNBOUNDED_SPREAD`, :data:`SPREAD`) within its limits. A ``spread`` [rad or m] gives every joint the
    range ``reference ± spread`` within its limits.

    Raises:
        DataError: a negative or non-finite ``spread``, or one that leaves a joint no value within its limits.
    """
    if spread is not None and not 0.0 <= spread < np.inf:
        raise DataError(f"spread is {spread}: a half-range [rad or m] must be a finite number ≥ 0")
    model = robot.model
    reference = robot.actuated_values(robot.q_reference)
    default = SPREAD.get(robot.name, UNBOUNDED_SPREAD["closed" if robot.loops else "serial"])
    lower, upper = np.empty(robot.n_actuated), np.empty(robot.n_actuated)
    for k, joint in enumerate(robot.kinematics.actuated):
        limits = (float(model.lowerPositionLimit[joint.idx_q]), float(model.upperPositionLimit[joint.idx_q]))
        lo, hi = limits if joint.nq == 1 else (-np.pi, np.pi)
        with np.errstate(over="ignore"):  # limits of ±1e308: a span beyond the floats is no bound to draw within
            bounded = joint.nq == 1 and bool(np.isfinite(hi - lo)) and lo < hi
        half: float | None = default
        if spread is not None:
            half = spread
        elif bounded and robot.name not in SPREAD:
            half = None  # the URDF limits as they are
        if half is not None:
            lo, hi = max(lo, reference[k] - half), min(hi, reference[k] + half)
        if lo > hi:
            raise DataError(f"spread ±{half:g} about the reference ({reference[k]:.6g}) of actuated joint "
                            f"'{joint.name}' leaves no value within its URDF limits [{limits[0]:.6g}, {limits[1]:.6g}]")
        lower[k], upper[k] = lo, hi
    return lower, upper


def random_actuated(robot: Robot, n: int, rng: np.random.Generator, spread: float | None = None,
                    max_condition: float = 1e4, progress: bool = False) -> tuple[Array, Array]:
    """``n`` random reachable actuated inputs (N, na) and their closed configurations (N, nq).

    Inputs are uniform within :func:`actuated_ranges` (by default the URDF joint limits; with ``spread``
    [rad or m], ``±spread`` about the reference within the limits); samples whose FK fails or whose passive
    closure Jacobian is ill-conditioned (near a singularity) are redrawn. The draws are judged many at once
    (:func:`~pincal.model.assemblable.assemble`), and ``rng`` is left exactly as if they had been drawn and judged
    one by one: the postures and the draws after them do not depend on how many were judged together.
    ``progress`` shows a bar on stderr (when it is a terminal), one tick per accepted sample.

    Raises:
        ConvergenceError: too few draws could be assembled (says the ranges).
        DataError: a bad ``spread`` (see :func:`actuated_ranges`).
    """
    lo, hi = actuated_ranges(robot, spread)
    budget = 50 * n + 100
    qa_out: list[Array] = []
    q_out: list[Array] = []
    attempts = 0
    with Progress(f"postures of '{robot.name}'", n, quiet=not progress) as bar:
        while len(qa_out) < n:
            if attempts >= budget:
                ranges = ", ".join(f"{j.name} [{a:.4g}, {b:.4g}]"
                                   for j, a, b in zip(robot.kinematics.actuated, lo, hi, strict=True))
                raise ConvergenceError(f"only {len(qa_out)} of {n} random postures of '{robot.name}' could be "
                                       f"assembled in {attempts} draws within {ranges} [rad or m]; give a smaller "
                                       "spread about the reference (--spread)")
            need = n - len(qa_out)
            state = rng.bit_generator.state
            draws = rng.uniform(lo, hi, size=(min(budget - attempts, max(DRAWS_AT_ONCE, 2 * need)), len(lo)))
            solved = assemble(robot, draws, max_condition)
            ok, q = solved.usable, solved.q
            kept = np.flatnonzero(ok)[:need]
            used = int(kept[-1]) + 1 if len(kept) == need else len(draws)
            if used < len(draws):  # the generator as if only the draws used had been made
                rng.bit_generator.state = state
                rng.uniform(lo, hi, size=(used, len(lo)))
            attempts += used
            qa_out.extend(draws[kept])
            q_out.extend(q[kept])
            bar.advance(len(kept))
    return np.array(qa_out), np.array(q_out)


def simulate_observations(robot: Robot, parameters: ParameterSet, x_true: Array, measurements: Sequence[Measurement],
                          actuated: Array, rng: np.random.Generator, noise: float | dict[str, float] = 0.0,
                          joint_noise: float = 0.0, payload: Payload | None = None) -> Observations:
    """Readings and measurements of the true robot (nominal + ``x_true``) at the given actuated values.

    Args:
        robot: Nominal robot.
        parameters: The parameters ``x_true`` refers to.
        x_true: True deviations [m, rad].
        measurements: What is measured.
        actuated: Actuated readings (N, na) [rad or m]; the true robot adds its offsets from ``x_true``.
        rng: Random generator (noise).
        noise: Measurement noise σ [m] (and [rad] for pose angles and angle readings), or one σ per
            measurement key (``{"joint:device_lvdt": 1e-6, "joint:device_incl_x": 2e-5}``; missing keys 0).
        joint_noise: Noise σ on the actuated readings [rad or m].
        payload: A point mass the true robot carries (its torque deflects the joints that have a compliance).
    """
    sigmas = noise if isinstance(noise, dict) else {m.key: noise for m in measurements}
    unknown = sorted(set(sigmas) - {m.key for m in measurements})
    if unknown:
        raise DataError(f"noise given for {', '.join(unknown)}, which is not measured; measurements are: "
                        f"{', '.join(m.key for m in measurements)}")
    if any(v < 0 for v in sigmas.values()) or joint_noise < 0:
        raise DataError("noise must be non-negative")
    problem = CalibrationProblem(robot, parameters, measurements, Observations.neutral(measurements, actuated),
                                 payload=payload)
    pred = problem.evaluate(x_true, jacobian=False)
    # each model's reading from its absolute prediction (the neutral readings give the absolute predictions)
    values = {m.key: m.simulate(pred.predicted[m.key], sigmas.get(m.key, 0.0), rng) for m in measurements}
    readings = actuated + rng.normal(scale=joint_noise, size=actuated.shape) if joint_noise else actuated.copy()
    return Observations(readings, values)
