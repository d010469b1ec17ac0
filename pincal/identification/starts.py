"""The starting point of a calibration: zero (the nominal robot), except the placements closed forms give from the
nominal robot and the data: each model's cameras and targets
(:meth:`~pincal.identification.measurements.Measurement.closed_form`), else an unknown measurement frame registered
to the measured points (Kabsch)."""

from __future__ import annotations

from typing import TYPE_CHECKING

import numpy as np
import numpy.typing as npt
import pinocchio as pin

from pincal import linalg
from pincal.errors import DataError
from pincal.identification.parameters import attached_name

if TYPE_CHECKING:
    from pincal.identification.problem import CalibrationProblem

Array = npt.NDArray[np.float64]


def initial_guess(problem: CalibrationProblem, start: Array | None = None) -> Array:
    """A starting point: zero (or ``start``, the values [m, rad] to start the other parameters from), except the
    placements closed forms give from the nominal robot.

    - cameras and their targets (each with all six placement parameters): an eye-in-hand camera seeing a pose
      target solves ``A_i X = Y B_i⁻¹`` (A_i the camera's frame in the world, B_i the target seen, X the camera on
      the frame, Y the target in the world), a point target ``p_i = X⁻¹ A_i⁻¹ y``; a pose target on a frame
      seen by a fixed camera solves ``A_i X = Y B_i``, Y the inverse of the camera's placement ``base``
      (:mod:`pincal.identification.handeye`). Data that do not determine them leave them where they start;
    - otherwise an unknown measurement frame (all six ``base.*``) registered in closed form to the measured
      positions (Kabsch: measured ≈ R · predicted + t, least squares).
    """
    x = np.zeros(len(problem.parameters)) if start is None else np.array(start, dtype=float)
    x[[k for k in problem.base if k < len(x)]] = 0.0  # the registration below is of the robot as it stands at x
    located = camera_starts(problem, x)
    if located or len(problem.base) != 6 or any(k >= len(problem.parameters) for k in problem.base):
        return x
    from pincal.identification.problem import CalibrationProblem  # (a cycle at import time: problem uses this module)

    pred = CalibrationProblem.evaluate(problem, x, jacobian=False)  # forward predictions, for IKM too
    model, measured = [], []
    for m in problem.measurements:
        if m.locates_point:
            taken = problem.seen(m.key)  # an occluded marker registers nothing
            model.append(pred.predicted[m.key][taken, :3])
            measured.append(problem.observations.values[m.key][taken, :3])
    if not model or sum(len(a) for a in model) < 3:
        return x
    a, b = np.vstack(model), np.vstack(measured)
    ca, cb = a.mean(axis=0), b.mean(axis=0)
    u, _, vt = linalg.svd((a - ca).T @ (b - cb), "the Kabsch cross-covariance of the measured positions")
    d = np.sign(np.linalg.det(vt.T @ u.T))
    rot = vt.T @ np.diag([1.0, 1.0, d]) @ u.T
    set_placement(problem, x, problem.base, pin.SE3(rot, cb - rot @ ca))
    return x


def camera_starts(problem: CalibrationProblem, x: Array) -> bool:
    """Write the closed-form starts of the cameras and targets into ``x``; True if one placed the measurement
    frame (``base``, the fixed camera of a pose target)."""
    groups = {attached_name(kind, target): idx for (kind, target, _), idx
              in problem.parameters.groups("camera", "target").items()}
    cameras = [m for m in problem.measurements if m.attachments]
    problem.placed_in_closed_form, problem.not_in_closed_form = [], []
    if not cameras:
        return False
    nominal = problem.robot.model.createData()
    located = False
    for m in cameras:
        taken = np.flatnonzero(problem.seen(m.key))
        frame = problem.frame_ids[m.frames[0]]  # the frame carrying the camera or the target
        a = []
        for k in taken:
            q = problem._solve(problem.robot, int(k), problem.observations.actuated[k])
            pin.framesForwardKinematics(problem.robot.model, nominal, q)
            a.append(nominal.oMf[frame].copy())
        values = problem.observations.values[m.key][taken]
        try:
            own, world, names = m.closed_form(a, values)
        except DataError as why:
            try:  # a link that only translates (a Delta's platform): its rotations cannot separate X from Y
                own, world, names = m.closed_form(a, values, translating=True)
            except DataError:  # the data do not determine the placements: the summary says why
                problem.not_in_closed_form.append(f"{m.key}: {why}")
                continue
        if len(groups.get(names[0], [])) == 6:
            set_placement(problem, x, groups[names[0]], own)
            problem.placed_in_closed_form.append(names[0])
        if names[1] and len(groups.get(names[1], [])) in (3, 6):
            set_placement(problem, x, groups[names[1]], world)
        elif not names[1] and len(problem.base) == 6:
            set_placement(problem, x, problem.base, world.inverse())
            located = True
    return located


def set_placement(problem: CalibrationProblem, x: Array, indices: list[int], placement: pin.SE3) -> None:
    """Set a placement group's parameters in ``x`` to ``log6(placement)`` (its components that are parameters)."""
    delta = pin.log6(placement).vector
    for k in indices:
        x[k] = delta[problem.parameters.parameters[k].component]

