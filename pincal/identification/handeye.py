"""Closed-form starting values for camera calibration: hand-eye, robot-world and single-point problems.

Three linear solutions, each a relaxation of a problem on SE(3) that is later refined by the nonlinear
calibration: the rotation is solved as an unconstrained 3 × 3 matrix, projected onto SO(3) (nearest in
Frobenius norm, det +1), and the translations are then re-solved by linear least squares given it.

- :func:`solve_ax_yb`: ``A_i X = Y B_i`` (robot-world/hand-eye; Shah 2013, "Solving the robot-world/hand-eye
  calibration problem using the Kronecker product", J. Mechanisms Robotics 5(3)).
- :func:`solve_point_eye_in_hand`: a camera on a link sees one point fixed in the world.
- :func:`solve_ax_yb_translating` and :func:`solve_point_translating`: the same for a link that only translates (a
  Delta's platform), whose rotations cannot separate X from Y.

(A fixed camera seeing a point on a link is a position measurement in the camera's frame: its start is the Kabsch
registration of the measurement frame, :meth:`pincal.identification.problem.CalibrationProblem.initial_guess`.)

Poses are :class:`pinocchio.SE3` (``R`` dimensionless, ``t`` [m]); points are [m]. ``T = a ← b`` means that
``T`` maps coordinates in frame ``b`` to frame ``a`` (``p_a = R p_b + t``).

Every system is checked before it is solved: its columns are scaled to unit norm and a singular value below
``tol · σ_max`` (:data:`DEGENERACY_TOLERANCE`) means the data do not determine the unknowns; a
:class:`~pincal.errors.DataError` then says what is missing (poses, rotation axes, spread of the points).
"""

from __future__ import annotations

from collections.abc import Callable, Sequence

import numpy as np
import numpy.typing as npt
import pinocchio as pin

from pincal import linalg
from pincal.errors import DataError

Array = npt.NDArray[np.float64]

DEGENERACY_TOLERANCE = 1e-3
"""Relative singular value (of a system whose columns are made dimensionless) under which the data count as
not determining the unknowns. Along a direction with singular value ``σ`` a relative error ``e`` in the data
can become ``e · σ_max / σ`` in the solution: 1e-3 caps that amplification at 1000. Exactly degenerate data
sit at round-off (~1e-15); degenerate data with noise ``e`` [rad, or m per unit lever arm] sit at about ``e``
(measured: rotations all about z with 1e-4 noise give 1.1e-4, with 1e-5 noise 1.1e-5), so both are refused
for noise up to ~1e-3. Random poses with rotations of ±30° about all axes sit at 0.04–0.1 for AX = YB and
eye-in-hand. Pass ``tol`` to move it, e.g. 1e-8 to
refuse only exact degeneracy."""

MIN_POSES_AX_YB = 3
MIN_SAMPLES_EYE_IN_HAND = 5  # 15 unknowns, 3 equations a sample


def solve_ax_yb(a: Sequence[pin.SE3], b: Sequence[pin.SE3], tol: float = DEGENERACY_TOLERANCE
                ) -> tuple[pin.SE3, pin.SE3]:
    """X and Y with ``A_i X ≈ Y B_i`` for all ``i``, in closed form (Shah 2013).

    Frames: ``A_i = w ← f`` and ``B_i = o ← c`` are known, ``X = f ← c`` and ``Y = w ← o`` are constant; both
    sides map the camera ``c`` to the world ``w``. Eye in hand: ``A_i`` the link's pose (world ← link),
    ``X`` link ← camera, ``B_i`` target ← camera (the inverse of the target's pose seen by the camera),
    ``Y`` world ← target.

    Rotations: ``R_Ai R_X = R_Y R_Bi`` reads, with column-major ``vec``, ``(I₃ ⊗ R_Ai) vec R_X −
    (R_Biᵀ ⊗ I₃) vec R_Y = 0``; the stack of these (9n × 18) has a one-dimensional null space for
    consistent, non-degenerate data: its last right singular vector, rescaled to det +1 and projected
    onto SO(3). Translations: ``R_Ai t_X − t_Y = R_Y t_Bi − t_Ai``, by linear least squares (3n × 6) given
    the rotations. This separable solution minimises the rotation and translation residuals one after the
    other, not ``Σ‖A_i X − Y B_i‖`` jointly: it is a starting value.

    Args:
        a: ``A_i`` (w ← f), translations [m].
        b: ``B_i`` (o ← c), translations [m]; as many as ``a``.
        tol: Relative singular value under which the data count as degenerate (:data:`DEGENERACY_TOLERANCE`).

    Returns:
        ``(X, Y)``: ``X = f ← c`` and ``Y = w ← o``, translations [m].

    Raises:
        DataError: fewer than 3 poses, ``a`` and ``b`` of different lengths, or rotations that do not
            determine ``X`` and ``Y`` (e.g. all about one axis).
    """
    n = len(a)
    if len(b) != n:
        raise DataError(f"AX = YB needs one B per A; got {n} A and {len(b)} B")
    if n < MIN_POSES_AX_YB:
        raise DataError(f"AX = YB needs at least {MIN_POSES_AX_YB} poses rotated about non-parallel axes to "
                        f"determine X and Y; got {n}")
    ra, ta = _rotations(a), _translations(a)
    rb, tb = _rotations(b), _translations(b)
    eye = np.eye(3)
    kron = np.concatenate([np.hstack([np.kron(eye, ra[i]), -np.kron(rb[i].T, eye)]) for i in range(n)])
    _, s, vt = linalg.svd(kron, "the AX = YB rotation system")
    if s[-2] <= tol * s[0]:
        raise DataError(_rotation_problem("AX = YB", "X and Y", ra, tol, s[-2] / s[0]))
    null = vt[-1]
    mx, my = null[:9].reshape(3, 3, order="F"), null[9:].reshape(3, 3, order="F")
    # The null vector has a free scale and sign; the true one has det(R_X) = det(R_Y) = 1.
    det = np.linalg.det(mx) + np.linalg.det(my)
    scale = np.sign(det) / np.cbrt(abs(det) / 2.0)
    rx = _nearest_rotation(scale * mx, "R_X of AX = YB")
    ry = _nearest_rotation(scale * my, "R_Y of AX = YB")
    lhs = np.concatenate([np.hstack([ra[i], -eye]) for i in range(n)])
    rhs = np.concatenate([ry @ tb[i] - ta[i] for i in range(n)])
    t = _least_squares(lhs, rhs, "the AX = YB translation system", tol,
                       lambda ratio: _rotation_problem("AX = YB", "t_X and t_Y", ra, tol, ratio))
    return pin.SE3(rx, t[:3]), pin.SE3(ry, t[3:])


def solve_point_eye_in_hand(a: Sequence[pin.SE3], p: npt.ArrayLike, tol: float = DEGENERACY_TOLERANCE
                            ) -> tuple[pin.SE3, Array]:
    """Camera pose on a link and a world point, from the camera's sightings of that point.

    A camera fixed on a link at ``X`` (link ← camera) sees a point fixed in the world at ``y`` [m]:
    ``p_i = X⁻¹ A_i⁻¹ y`` with ``A_i`` the link's pose (world ← link). Written as
    ``R_i R_X p_i + R_i t_X − y = −t_i`` (``A_i = (R_i, t_i)``) it is linear in ``(vec R_X, t_X, y)``,
    15 unknowns solved by least squares (3n × 15); ``R_X`` is projected onto SO(3), then ``t_X`` and ``y``
    re-solved given it (``R_i t_X − y = −t_i − R_i R_X p_i``, 3n × 6).

    Args:
        a: ``A_i``, the link's poses (world ← link), translations [m].
        p: (n, 3) point seen by the camera [m] in the camera frame, one row per pose.
        tol: Relative singular value under which the data count as degenerate (:data:`DEGENERACY_TOLERANCE`).

    Returns:
        ``(X, y)``: ``X`` link ← camera (translation [m]); ``y`` (3,) the point [m] in the world frame.

    Raises:
        DataError: fewer than 5 samples, ``p`` not (n, 3) or not finite, or motions that do not determine
            ``X`` and ``y``: rotations all about one axis, or points coplanar in the camera frame (the linear
            relaxation needs them to span space).
    """
    points = _points(p, len(a), "eye-in-hand", MIN_SAMPLES_EYE_IN_HAND)
    n = len(a)
    r, t = _rotations(a), _translations(a)
    eye = np.eye(3)
    # Centred points: t_X absorbs R_X p̄, leaving R_X alone in the first 9 unknowns and the columns
    # independent of where the camera frame's origin is; their common length scale makes them dimensionless.
    centred = points - points.mean(axis=0)
    length = _rms_norm(centred)
    lhs = np.concatenate([np.hstack([np.kron(centred[i][None, :], r[i]), r[i], -eye]) for i in range(n)])
    rhs = -t.reshape(-1)

    def problem(ratio: float) -> str:
        return _point_problem("the eye-in-hand point system", "X and y", r, points, tol, ratio)

    theta = _least_squares(lhs, rhs, "the eye-in-hand point system", tol, problem,
                           np.r_[np.full(9, 1.0 / length), np.ones(6)])
    rx = _nearest_rotation(theta[:9].reshape(3, 3, order="F"), "R_X of the eye-in-hand point system")
    lhs = np.concatenate([np.hstack([r[i], -eye]) for i in range(n)])
    rhs = np.concatenate([-t[i] - r[i] @ rx @ points[i] for i in range(n)])
    u = _least_squares(lhs, rhs, "the eye-in-hand translation system", tol, problem)
    return pin.SE3(rx, u[:3]), u[3:]


def solve_ax_yb_translating(a: Sequence[pin.SE3], b: Sequence[pin.SE3], tol: float = DEGENERACY_TOLERANCE
                            ) -> tuple[pin.SE3, pin.SE3]:
    """:func:`solve_ax_yb` for a link that only translates (a Delta's platform): ``A_i`` all of one rotation.

    ``R_A R_X = R_Y R_Bi`` then holds one equation, and ``R_A t_X + t_Ai = R_Y t_Bi + t_Y`` reads
    ``t_Ai = R_Y t_Bi + c``, ``c = t_Y − R_A t_X``: ``R_Y`` and ``c`` by Kabsch registration of the ``t_Bi`` onto the
    ``t_Ai`` (they must span a plane), then ``R_X = R_Aᵀ R_Y R_B``. The data see ``t_X`` and ``t_Y`` only through
    ``c``: the start takes ``t_X = 0``, ``t_Y = c`` (the identifiability analysis names what stays unseen).

    Args:
        a: ``A_i`` (w ← f), one rotation, translations [m].
        b: ``B_i`` (o ← c), translations [m]; as many as ``a``.
        tol: Relative singular value under which the translations count as not spanning a plane.

    Returns:
        ``(X, Y)`` as :func:`solve_ax_yb`, with ``t_X = 0``.

    Raises:
        DataError: fewer than 3 poses, rotations of ``A_i`` that differ, or translations in a line.
    """
    ra, ta = _rotations(a), _translations(a)
    rb, tb = _rotations(b), _translations(b)
    if len(b) != len(a) or len(a) < MIN_POSES_AX_YB:
        raise DataError(f"AX = YB for a translating link needs at least {MIN_POSES_AX_YB} poses, one B per A; got "
                        f"{len(a)} A and {len(b)} B")
    if _axis_spread(ra, tol)[0] != 0:
        raise DataError("AX = YB for a translating link needs the poses A_i of one rotation; they turn")
    rotation = _kabsch(tb, ta, tol, "the translations of B_i")
    rx = _nearest_rotation(ra[0].T @ rotation @ _mean_rotation(rb), "R_X of AX = YB, translating")
    return pin.SE3(rx, np.zeros(3)), pin.SE3(rotation, ta.mean(axis=0) - rotation @ tb.mean(axis=0))


def solve_point_translating(a: Sequence[pin.SE3], p: npt.ArrayLike, tol: float = DEGENERACY_TOLERANCE
                            ) -> tuple[pin.SE3, Array]:
    """:func:`solve_point_eye_in_hand` for a link that only translates: ``A_i`` all of one rotation ``R_A``.

    ``A_i X p_i = y`` reads ``t_Ai = −R_A R_X p_i + c``, ``c = y − R_A t_X``: ``R_A R_X`` by Kabsch registration of
    the ``−p_i`` onto the ``t_Ai`` (the points must span a plane). The data see ``t_X`` and ``y`` only through ``c``:
    the start takes ``t_X = 0``, ``y = c``.

    Returns:
        ``(X, y)`` as :func:`solve_point_eye_in_hand`, with ``t_X = 0``.

    Raises:
        DataError: fewer than 3 samples, rotations of ``A_i`` that differ, or points in a line.
    """
    ra, ta = _rotations(a), _translations(a)
    points = _points(p, len(a), "translating eye-in-hand", MIN_POSES_AX_YB)
    if _axis_spread(ra, tol)[0] != 0:
        raise DataError("the eye-in-hand point problem for a translating link needs the poses A_i of one rotation; "
                        "they turn")
    rotation = _kabsch(-points, ta, tol, "the points seen")
    return pin.SE3(_nearest_rotation(ra[0].T @ rotation, "R_X, translating"), np.zeros(3)), \
        ta.mean(axis=0) + rotation @ points.mean(axis=0)


def _kabsch(source: Array, target: Array, tol: float, what: str) -> Array:
    """The rotation R minimising ``Σ‖target_i − R source_i − c‖`` (Kabsch); DataError when ``source`` or ``target``
    lie in a line (R then turns freely about it)."""
    a, b = source - source.mean(axis=0), target - target.mean(axis=0)
    for points, name in ((a, what), (b, "the translations of A_i")):
        s = linalg.singular_values(points, name) if len(points) >= 2 else np.zeros(1)
        if len(s) < 2 or s[1] <= tol * max(s[0], 1e-300):
            raise DataError(f"{name} lie in a line: a translating link needs them to span a plane")
    u, _, vt = linalg.svd(a.T @ b, f"the Kabsch cross-covariance of {what}")
    flip = np.diag([1.0, 1.0, np.sign(np.linalg.det(vt.T @ u.T)) or 1.0])
    return np.asarray(vt.T @ flip @ u.T, np.float64)


def _mean_rotation(rotations: Array) -> Array:
    """The rotation nearest to the mean of ``rotations`` (chordal mean)."""
    return _nearest_rotation(rotations.mean(axis=0), "the mean rotation")


def _rotations(poses: Sequence[pin.SE3]) -> Array:
    return np.array([np.asarray(m.rotation, dtype=np.float64) for m in poses]).reshape(-1, 3, 3)


def _translations(poses: Sequence[pin.SE3]) -> Array:
    return np.array([np.asarray(m.translation, dtype=np.float64) for m in poses]).reshape(-1, 3)


def _points(p: npt.ArrayLike, n: int, problem: str, minimum: int) -> Array:
    points = np.asarray(p, dtype=np.float64)
    if points.ndim != 2 or points.shape[1] != 3 or len(points) != n:
        raise DataError(f"the {problem} point problem needs p as ({n}, 3), one point a pose; got shape "
                        f"{points.shape}")
    if not np.all(np.isfinite(points)):
        rows = sorted({int(i) for i in np.argwhere(~np.isfinite(points))[:, 0]})
        raise DataError(f"the {problem} points have NaN/inf entries in samples {rows}")
    if n < minimum:
        raise DataError(f"the {problem} point problem needs at least {minimum} samples ({3 * minimum} equations "
                        f"for {3 * minimum} unknowns of its linear form); got {n}")
    return points


def _rms_norm(vectors: Array) -> float:
    """Root-mean-square norm of the rows [m], 1 m when they are all zero (the rank check then refuses)."""
    rms = float(np.sqrt(np.mean(np.sum(vectors**2, axis=1))))
    return rms if rms > 0.0 else 1.0


def _nearest_rotation(matrix: Array, what: str) -> Array:
    """The rotation nearest to ``matrix`` in Frobenius norm, det +1 (Horn 1988's SVD projection)."""
    u, _, vt = linalg.svd(matrix, what)
    flip = np.diag([1.0, 1.0, np.sign(np.linalg.det(u @ vt)) or 1.0])
    return np.asarray(u @ flip @ vt, np.float64)


def _least_squares(matrix: Array, rhs: Array, what: str, tol: float, problem: Callable[[float], str],
                   scale: Array | None = None) -> Array:
    """Least-squares solution of ``matrix · x = rhs``; the rank check on ``matrix · diag(scale)``.

    ``scale`` makes the columns dimensionless (a column multiplying metres is scaled by a typical length),
    but is shared by all the columns of one unit, so that a column only noise fills stays small.

    Raises:
        DataError: ``σ_min ≤ tol · σ_max`` of the scaled matrix; the message is ``problem(σ_min / σ_max)``.
    """
    scale = np.ones(matrix.shape[1]) if scale is None else scale
    u, s, vt = linalg.svd(matrix * scale, what)
    if s[-1] <= tol * s[0]:
        raise DataError(problem(float(s[-1] / s[0])))
    solution = vt.T @ ((u.T @ rhs) / (s[:, None] if rhs.ndim == 2 else s))
    return np.asarray(solution * (scale[:, None] if rhs.ndim == 2 else scale), np.float64)


def _axis_spread(rotations: Array, tol: float) -> tuple[int, Array]:
    """How many independent axes the rotations differ about (0, 1 or more), and the main one.

    The axes are those of ``R_i R_0ᵀ`` in the frame the rotations map into (the world for link poses).
    """
    logs = np.array([pin.log3(rotations[i] @ rotations[0].T) for i in range(1, len(rotations))])
    s = linalg.singular_values(logs, "the stacked rotation vectors") if len(logs) else np.zeros(1)
    if s[0] <= tol:  # [rad]: differences of less than ~0.5° carry no axis
        return 0, np.zeros(3)
    _, _, vt = linalg.svd(logs, "the stacked rotation vectors")
    return (1 if len(s) < 2 or s[1] <= tol * s[0] else 2), vt[0]


def _axis_words(axis: Array) -> str:
    words = {0: "x", 1: "y", 2: "z"}
    main = int(np.argmax(np.abs(axis)))
    if abs(axis[main]) > 1.0 - 1e-3:
        return f"only about {words[main]}"
    return "only about one axis, [" + ", ".join(f"{round(c, 3) + 0.0:.3f}" for c in axis * np.sign(axis[main])) + "]"


def _spread_words(rotations: Array, tol: float, poses: str, differ: str) -> str | None:
    """Why the rotations fail to spread, in words: ``"<poses> all have the same rotation"``, or ``differ`` and the
    one axis they turn about; None when they turn about two axes or more."""
    count, axis = _axis_spread(rotations, tol)
    if count == 0:
        return f"{poses} all have the same rotation"
    if count == 1:
        return differ.format(_axis_words(axis))
    return None


def _rotation_problem(system: str, unknowns: str, rotations: Array, tol: float, ratio: float) -> str:
    why = _spread_words(rotations, tol, "the poses A_i", "the rotations of A_i differ {} in their reference frame") or (
        f"the rotations of A_i do not spread over non-parallel axes enough (ratio {ratio:.1e} ≤ tol {tol:g})")
    return (f"{system} cannot determine {unknowns}: {why}; it needs poses rotated about at least two "
            "non-parallel axes")


def _point_problem(system: str, unknowns: str, rotations: Array, points: Array, tol: float, ratio: float) -> str:
    why = _spread_words(rotations, tol, "the link poses A_i", "the link rotations differ {} in the world frame")
    if why is None:
        s = linalg.singular_values(points - points.mean(axis=0), "the centred camera points")
        why = ("the points seen lie in one plane of the camera frame (its linear form needs them to span space)"
               if s[-1] <= tol * s[0] else
               f"the link rotations do not spread over non-parallel axes enough (ratio {ratio:.1e} ≤ tol {tol:g})")
    return (f"{system} cannot determine {unknowns}: {why}; it needs link rotations about at least two non-parallel "
            "axes and points seen that do not lie in one plane")
