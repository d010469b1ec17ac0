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
from pincal.identification.measurements import PLANE, Measurement, Pixel, plane_name
from pincal.identification.parameters import attached_name
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
    - planes (their offset and tilts): the plane fitted to the contact points of the nominal robot
      (:func:`plane_starts`);
    - otherwise an unknown measurement frame (all six ``base.*``) registered in closed form to the measured
      positions (Kabsch: measured ≈ R · predicted + t, least squares).
    """
    x = np.zeros(len(problem.parameters)) if start is None else np.array(start, dtype=float)
    x[[k for k in problem.base if k < len(x)]] = 0.0  # the registration below is of the robot as it stands at x
    located = camera_starts(problem, x)
    plane_starts(problem, x)
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
               if any(a.kind != PLANE for a in m.attachments) and not isinstance(m, Pixel)]
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



def plane_starts(problem: Evaluated, x: Array) -> None:
    """Write into ``x`` the start of each plane a frame touches: the plane through the contact frames' nominal
    origins (in the support's frame; the readings' distances taken off along the normal), fitted by SVD, its normal
    the direction of least spread turned toward the support's +z (the mean of the frames' z axes when the points are
    nearly on a line and the frames' axes are read). Planes the points do not determine stay where they start (the
    summary says why)."""
    groups = problem.parameters.groups(PLANE)
    for support in sorted({owner for (_, owner, _) in groups}):
        models = [m for m in problem.measurements if any(a.kind == PLANE and a.owner == support
                                                         for a in m.attachments)]
        points, axes, distances = _contact_points(problem, models)
        try:
            plane = fit_plane(points, distances, axes)
        except DataError as why:
            problem.not_in_closed_form.append(f"{plane_name(support)}: {why}")
            continue
        set_placement(problem, x, groups[(PLANE, support, "")], plane)
        problem.placed_in_closed_form.append(plane_name(support))


def _contact_points(problem: Evaluated, models: list[Measurement]) -> tuple[Array, Array, Array]:
    """The contact frames' origins [m] and z axes in their support's frame at the nominal robot, (n, 3) each, and
    the distances [m] read there (n,)."""
    nominal = problem.robot.model.createData()
    points, axes, distances = [], [], []
    for m in models:
        frames = [problem.frame_ids[f] for f in m.frames]
        values = problem.observations.values[m.key]
        for k in np.flatnonzero(problem.seen(m.key)):
            q = problem.solves.solve(problem.robot, int(k), problem.observations.actuated[k])
            pin.framesForwardKinematics(problem.robot.model, nominal, q)
            held = nominal.oMf[frames[1]] if len(frames) > 1 else pin.SE3.Identity()
            contact = held.actInv(nominal.oMf[frames[0]])
            points.append(contact.translation)
            axes.append(contact.rotation[:, 2] if m.angle_rows else np.full(3, np.nan))
            distances.append(values[k, 0])
    return np.array(points).reshape(-1, 3), np.array(axes).reshape(-1, 3), np.array(distances)


#: Smallest ratio of the second to the first spread of contact points that still fixes a plane's tilt about
#: their line.
PLANE_SPREAD = 1e-3


def fit_plane(points: Array, distances: Array, axes: Array | None = None) -> pin.SE3:
    """The plane ``G`` (its normal along its z axis) through ``points`` (n, 3) [m] at the signed ``distances`` (n,)
    [m] they read (the normal by SVD when they are all 0, else by least squares under a unit norm), as a placement
    whose ``log6`` is ``(0, 0, tz, rx, ry, 0)``: the offset along the normal and two tilts, the plane's parameters.
    Points at equal heights (contacts) turn the normal toward +z; ``axes`` (n, 3) (rows NaN where not read) give it
    when the points are nearly on a line.

    Raises:
        DataError: fewer than three points, or points on a line without axes to give the normal.
    """
    if len(points) < 3:
        raise DataError(f"{len(points)} contact points do not fix a plane (three or more do)")
    centre = points.mean(axis=0)
    _, spread, vt = linalg.svd(points - centre, "the contact points about their centre")
    if spread[1] <= PLANE_SPREAD * spread[0]:
        read = axes[np.all(np.isfinite(axes), axis=1)] if axes is not None else np.zeros((0, 3))
        if not len(read):
            raise DataError("the contact points lie on a line: their plane's tilt about it is not determined")
        normal = (read * np.sign(read @ read[0])[:, None]).mean(axis=0)
        normal = _upward(normal / np.linalg.norm(normal))
    else:
        normal = _unit_normal(points - centre, distances - distances.mean(), spread, vt)
    offset = float(np.mean(points @ normal - distances))
    return plane_placement(normal, offset)


def _upward(normal: Array) -> Array:
    """The unit ``normal`` (3,) turned toward +z (where the data do not tell its sign)."""
    return normal if normal[2] >= 0 else -normal


def _unit_normal(centred: Array, heights: Array, spread: Array, vt: Array) -> Array:
    """The unit ``n`` minimising ``Σ (n·p_i − h_i)²`` over the centred points ``p_i`` (n, 3) [m] and centred heights
    ``h_i`` (n,) [m] (least squares under a unit-norm constraint, Gander 1980): ``n = (AᵀA − λI)⁻¹ Aᵀh`` with the
    λ below the smallest ``σ²`` that makes it a unit vector, found by bisection; the direction of least spread when
    every height is 0 (``spread``, ``vt``: the SVD of the points)."""
    g = vt @ (centred.T @ heights)
    squares = spread ** 2
    if not np.any(heights) or abs(g[2]) <= 1e-12 * max(np.abs(g).max(), 1e-300):
        return _upward(vt[2])  # equal heights do not tell up from down

    def length(lam: float) -> float:
        return float(np.sum((g / (squares - lam)) ** 2))

    high, low = squares[2], squares[2] - max(np.abs(g).sum(), 1.0)
    while length(low) > 1.0:
        low = squares[2] - 2.0 * (squares[2] - low)
    for _ in range(200):  # length is increasing in λ on (−∞, σ²_min)
        mid = 0.5 * (low + high)
        low, high = (mid, high) if length(mid) < 1.0 else (low, mid)
    normal: Array = vt.T @ (g / (squares - low))
    normal /= np.linalg.norm(normal)
    level = _upward(vt[2])  # the heights' sign, unless it fits them no better than the plane of least spread does

    def misfit(n: Array) -> float:
        return float(np.sum((centred @ n - heights) ** 2))

    return normal if misfit(normal) < 0.5 * misfit(level) else level


def plane_placement(normal: Array, offset: float) -> pin.SE3:
    """The placement ``exp6((0, 0, tz, rx, ry, 0))`` of the plane ``{p : n·p = offset}`` (``normal`` (3,) a unit
    vector with ``n_z > −1``, ``offset`` [m]): the rotation about an axis in the xy plane that takes z to the normal,
    and ``tz`` such that its origin lies on the plane."""
    axis = np.cross([0.0, 0.0, 1.0], normal)
    angle = float(np.arctan2(np.linalg.norm(axis), normal[2]))
    rotation = axis / np.linalg.norm(axis) * angle if angle > 1e-12 else np.zeros(3)
    along = pin.exp6(pin.Motion(np.array([0.0, 0.0, 1.0]), rotation)).translation @ normal  # per unit tz
    return pin.exp6(pin.Motion(np.array([0.0, 0.0, offset / along]), rotation))
