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
from pincal.identification.measurements import Measurement, NominalReadings, Pixel
from pincal.identification.measurements.planes import fit_plane as fit_plane
from pincal.identification.parameters import attached_name, kinds_where
from pincal.identification.pixel_starts import pixel_starts
from pincal.identification.pixel_starts import set_placement as set_placement

if TYPE_CHECKING:
    from pincal.identification.evaluation import Evaluated

Array = npt.NDArray[np.float64]


def initial_guess(problem: Evaluated, start: Array | None = None) -> Array:
    """A starting point: zero (or ``start``, the values [m, rad] to start the other parameters from), except the
    placements closed forms give from the nominal robot.

    - cameras and their targets (each with all six placement parameters): an eye-in-hand camera seeing a pose
      target solves ``A_i X = Y B_i⁻¹`` (A_i the camera's frame in the world, B_i the target seen, X the camera on
      the frame, Y the target in the world), a point target ``p_i = X⁻¹ A_i⁻¹ y``; a pose target on a frame
      seen by a fixed camera solves ``A_i X = Y B_i``, Y the inverse of the camera's placement ``base``
      (:mod:`pincal.identification.handeye`). Data that do not determine them leave them where they start;
    - the placements a measurement kind starts itself (:func:`attached_starts`): planes (their offset and tilts),
      the plane fitted to the contact points of the nominal robot;
    - otherwise an unknown measurement frame (all six ``base.*``) registered in closed form to the measured
      positions (Kabsch: measured ≈ R · predicted + t, least squares).
    """
    x = np.zeros(len(problem.parameters)) if start is None else np.array(start, dtype=float)
    x[[k for k in problem.base if k < len(x)]] = 0.0  # the registration below is of the robot as it stands at x
    located = camera_starts(problem, x)
    attached_starts(problem, x)
    if located or len(problem.base) != 6 or any(k >= len(problem.parameters) for k in problem.base):
        return x
    pred = problem.forward(x)  # forward predictions, for IKM too
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


def camera_starts(problem: Evaluated, x: Array) -> bool:
    """Write the closed-form starts of the cameras and targets into ``x``; True if one placed the measurement
    frame (``base``, the fixed camera of a pose target)."""
    groups = {attached_name(kind, owner): idx for (kind, owner, _), idx
              in problem.parameters.groups("camera", "target").items()}
    cameras = [m for m in problem.measurements
               if m.attachments and type(m).closed_form is not Measurement.closed_form and not isinstance(m, Pixel)]
    problem.placed_in_closed_form, problem.not_in_closed_form = [], []
    located = pixel_starts(problem, x)
    if not cameras:
        return located
    nominal = problem.robot.model.createData()
    for m in cameras:
        taken = np.flatnonzero(problem.seen(m.key))
        frame = problem.frame_ids[m.frames[0]]  # the frame carrying the camera or the target
        a = []
        for k in taken:
            q = problem.solves.solve(problem.robot, int(k), problem.observations.actuated[k])
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



def attached_starts(problem: Evaluated, x: Array) -> None:
    """Write into ``x`` the closed-form starts the measurement kinds give of the placements they carry
    (:meth:`~pincal.identification.measurements.Measurement.start_placements`: each plane a frame touches, fitted to
    the contact points; a plugin's own), the models that share one hook together. A placement the data do not
    determine stays where it starts (the summary says why)."""
    hooks: dict[object, list[Measurement]] = {}
    for m in problem.measurements:
        hook = type(m).start_placements.__func__  # type: ignore[attr-defined]
        if hook is not Measurement.start_placements.__func__:  # type: ignore[attr-defined]
            hooks.setdefault(hook, []).append(m)
    if not hooks:
        return
    groups = {attached_name(kind, owner): idx for (kind, owner, _), idx
              in problem.parameters.groups(*kinds_where(attached=True)).items()}
    cache: dict[str, NominalReadings] = {}

    def nominal(model: Measurement) -> NominalReadings:
        if model.key not in cache:
            cache[model.key] = _nominal_readings(problem, model)
        return cache[model.key]

    for models in hooks.values():
        for name, start in type(models[0]).start_placements(models, nominal).items():
            if name not in groups:
                continue
            if isinstance(start, str):
                problem.not_in_closed_form.append(f"{name}: {start}")
                continue
            set_placement(problem, x, groups[name], start)
            problem.placed_in_closed_form.append(name)


def _nominal_readings(problem: Evaluated, model: Measurement) -> NominalReadings:
    """The nominal robot's placements [m, rad] of ``model``'s frames in the world at its seen samples, and its
    readings there."""
    nominal = problem.robot.model.createData()
    taken = np.flatnonzero(problem.seen(model.key))
    placements: dict[str, list[pin.SE3]] = {f: [] for f in model.frames}
    for k in taken:
        q = problem.solves.solve(problem.robot, int(k), problem.observations.actuated[k])
        pin.framesForwardKinematics(problem.robot.model, nominal, q)
        for f in model.frames:
            placements[f].append(nominal.oMf[problem.frame_ids[f]].copy())
    return NominalReadings(placements, problem.observations.values[model.key][taken])
