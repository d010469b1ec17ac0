"""Bad joint readings: samples whose residual one wrong actuated-joint reading explains.

A sample whose joint reading is wrong (one joint off, a digit lost) has a residual that a single change of that
reading removes. For each candidate sample (one the outlier test of ``auto`` finds implausible) and each actuated
joint ``i``, the reading change ``δ`` [rad or m] that best explains the sample's weighted residual is found by
Gauss–Newton on ``r_k(q_k + δ e_i)``, with ``∂r_k/∂q_i`` the analytic column of that joint's reading offset
(the same derivative the ``<joint>.offset`` parameters have), iterated on the full prediction: a five-bar crank read
0.3 rad off moves the tool ~0.1 m, and one linear step leaves hundreds of times the noise (the second-order term).
The sample is judged at a fit without it (:func:`find_bad_readings`; only when its prediction error, linearised at the
robust fit, could reach the gross error below: :data:`SCREEN_MARGIN`), and its reading is taken for wrong when

- the error it removes is gross: ``‖r‖² − ‖r(δ)‖² ≥ G² · s² · d`` (G = :data:`GROSS_FACTOR`, ``d`` the sample's
  rows): at least ten times the norm the noise gives a sample's readings;
- what remains is noise: ``‖r(δ)‖² ≤ s² · χ²_{d−1}(1 − α)``, α = :data:`READING_FALSE_ALARM`;
- it explains at least :data:`EXPLAINED_SHARE` of the sample's squared residual;
- no other joint does as well (one reading is named, or none).

A residual merely large, as real data have, is none of this: real motion-capture data (the TIAGo files) hold a sample
whose error of ~10 mm is 98 % one joint's, but only a few noise norms: the Cauchy weight handles such a sample. Only a
gross error needs leaving out: its pull along the directions the other samples hardly see moves even a robust
estimate by degrees (a Delta's rod pitches). ``s²`` is the noise scale the data show
(:func:`~pincal.identification.losses.noise_scale`).
"""

from __future__ import annotations

from collections.abc import Callable, Sequence

import numpy as np
import numpy.typing as npt

from pincal import linalg
from pincal.errors import ConvergenceError, DataError
from pincal.identification.chi2 import chi2_upper
from pincal.identification.losses import noise_scale, outlier_samples, sample_squares
from pincal.identification.parameters import ParameterSet, ReadingOffset, joint_unit, offset_parameter
from pincal.identification.problem import CalibrationProblem, Observations, Prediction, Problem
from pincal.identification.result import CalibrationResult
from pincal.records import record

Array = npt.NDArray[np.float64]
IntArray = npt.NDArray[np.intp]

#: False-alarm level of the test that what a reading's change leaves is noise.
READING_FALSE_ALARM = 1e-3
#: How many times the norm of a sample's noise the error a wrong reading explains must be, at least.
GROSS_FACTOR = 10.0
#: Least share of a sample's squared weighted residual that one reading's change must explain.
EXPLAINED_SHARE = 0.95
#: Least share of a flagged sample's squared residual, at the robust fit, that one reading's change must explain for
#: the sample to be judged at a fit without it.
LIKELY_SHARE = 0.5
#: Most flagged samples judged at a fit without them (each costs one robust fit), the largest first.
MAX_CANDIDATES = 5
#: Gauss–Newton iterations on one reading's change (each one evaluation of the candidate samples).
READING_ITERATIONS = 8
#: How far below the gross error a flagged sample's squared prediction error, linearised at the robust fit, may be for
#: the sample still to be judged at a refit without it: that error at the refit came within 0.6–1.25 × its linearised
#: estimate on the TIAGo data and on simulated wrong readings of every robot tried; a sample whose estimate is below
#: 1 / SCREEN_MARGIN of the gross error cannot be named at the refit, which is not made.
SCREEN_MARGIN = 4.0


@record(frozen=True)
class BadReading:
    """One sample's wrong joint reading.

    Attributes:
        sample: The sample's index in the problem.
        joint: The actuated joint whose reading is wrong.
        off: How far the reading is off [rad or m]: the reading minus the value that explains the measurement.
        unit: ``rad`` or ``m``.
        explained: The share (0–1) of the sample's squared weighted residual that the change explains.
    """

    sample: int
    joint: str
    off: float
    unit: str
    explained: float


def find_bad_readings(problem: Problem, x: Array, residual: Array, rank: int,
                      refit: Callable[[list[int]], CalibrationResult | None],
                      linearised: tuple[Array, Array, list[int]] | None = None
                      ) -> tuple[list[BadReading], CalibrationResult | None]:
    """The samples of a robust fit (estimate ``x`` [m, rad], weighted ``residual``, ``rank`` directions fitted) whose
    joint reading is wrong, and the fit without them (None when there is none or the refit fails).

    A gross error pulls even a robust fit towards it along the directions the other samples hardly see (a Delta's
    rod pitches, by degrees), so that at the fit a wrong reading's residual is partly absorbed: each sample the
    outlier test flags and one reading's change explains at least :data:`LIKELY_SHARE` of, is judged at ``refit``
    (a fit from the start with that sample at weight 0), where its residual is its prediction error
    (:func:`bad_readings`); the :data:`MAX_CANDIDATES` largest at most. With ``linearised`` (the fit's Jacobian of
    the weighted residual, its sample weights and the columns it estimated), a sample whose prediction error
    linearised at the fit (:func:`deleted_squares`) is below 1 / :data:`SCREEN_MARGIN` of the gross error is
    neither examined nor refitted: no refit could name it."""
    suspects = outlier_samples(problem, _prediction(residual), rank)
    if not suspects or not isinstance(problem, CalibrationProblem) or not _examinable(problem):
        return [], None
    squares, _ = sample_squares(problem, residual)
    suspects = sorted(suspects, key=lambda k: -squares[k])[:MAX_CANDIDATES]
    if linearised is not None:  # first the screen, from the fit's factorisation: no refit could name those below it
        rows = problem.row_samples()
        gross = GROSS_FACTOR**2 * noise_scale(problem, residual, rank) * np.bincount(rows, minlength=len(squares))
        deleted = deleted_squares(rows, residual, *linearised, suspects)
        suspects = [k for k, d in zip(suspects, deleted, strict=True) if not SCREEN_MARGIN * d < gross[k]]
        if not suspects:
            return [], None
    _, before, after = _reading_changes(problem, x, suspects)
    likely = [k for c, k in enumerate(suspects) if np.nanmax(1.0 - after[c] / before[c], initial=0.0) >= LIKELY_SHARE]
    found: list[BadReading] = []
    fits: dict[int, CalibrationResult] = {}
    for k in likely:
        without = refit([k])
        if without is None:
            continue
        left = without.final.residual if without.final is not None else None
        if left is None:
            continue
        named = bad_readings(problem, without.x, [k], noise_scale(problem, left, without.identifiability.rank))
        if named:
            found += named
            fits[k] = without
    if len(found) == 1:
        return found, fits[found[0].sample]
    return found, (refit([b.sample for b in found]) if found else None)


def deleted_squares(rows: IntArray, residual: Array, jacobian: Array, weights: Array, columns: list[int],
                    samples: Sequence[int]) -> Array:
    """Each of ``samples``' squared weighted residual norm at a fit without it [σ² units], linearised at a fit whose
    weighted ``residual`` (its rows' samples ``rows``) has the Jacobian ``jacobian`` [1/m, 1/rad] (a prior's rows
    after the data's ignored) over the estimated ``columns``, with robust sample weights ``weights``: ``‖(I −
    U_k U_kᵀ)⁻¹ r_k‖²``, ``U_k`` sample k's rows of the left singular vectors of ``diag(√w) J`` (``w_k H_kk``, its
    leverage; without the prior's information the leverage, and the estimate, can only be larger); infinity where
    the sample alone determines a direction."""
    m = rows.size
    weighted = jacobian[:m, columns] * np.sqrt(weights[rows])[:, None]
    u, s, _ = linalg.svd(weighted, "the weighted identification Jacobian")
    u = u[:, s > s[0] * 1e-10] if s.size and s[0] > 0.0 else u[:, :0]
    out = np.full(len(samples), np.inf)
    for c, k in enumerate(samples):
        own = rows == k
        block = u[own]
        try:
            change = np.linalg.solve(np.eye(block.shape[0]) - block @ block.T, residual[:m][own])
        except np.linalg.LinAlgError:
            continue
        out[c] = float(change @ change)
    return out


def _examinable(problem: Problem) -> bool:
    """Whether :func:`bad_readings` examines ``problem``: a forward-kinematics problem without incremental
    measurements (one sample's prediction depends on that sample's readings alone)."""
    return isinstance(problem, CalibrationProblem) and not any(m.incremental for m in problem.measurements)


def _prediction(residual: Array) -> Prediction:
    """A prediction that holds only a weighted residual (what the outlier test reads)."""
    return Prediction(residual, None, {}, {})


def bad_readings(problem: Problem, x: Array, candidates: Sequence[int], scale2: float) -> list[BadReading]:
    """The ``candidates`` (sample indices) whose residual at ``x`` [m, rad] one actuated joint's wrong reading
    explains (module docstring), with ``scale2`` the noise scale ``s²`` of the weighted residual [σ² units].

    Only a forward-kinematics problem (:class:`~pincal.identification.problem.CalibrationProblem`) without
    incremental measurements is examined; for any other, none."""
    if not candidates or scale2 <= 0.0 or not isinstance(problem, CalibrationProblem) or not _examinable(problem):
        return []
    rows = list(candidates)
    changes, before, after = _reading_changes(problem, x, rows)
    robot = problem.robot
    n_joints = robot.n_actuated
    dims = np.bincount(problem.row_samples(), minlength=problem.observations.n_samples)[rows]
    beyond = GROSS_FACTOR**2 * scale2 * dims
    noise = scale2 * chi2_upper(READING_FALSE_ALARM, np.maximum(dims - 1, 1))
    found = []
    for c, k in enumerate(rows):
        explains = [(before[c] - after[c, i] >= beyond[c] and after[c, i] <= noise[c]
                     and after[c, i] <= (1.0 - EXPLAINED_SHARE) * before[c]) for i in range(n_joints)]
        if sum(explains) != 1:
            continue
        i = explains.index(True)
        joint = robot.actuated_joints[i]
        found.append(BadReading(k, joint, -float(changes[c, i]), joint_unit(robot, joint),
                                1.0 - float(after[c, i] / before[c])))
    return found


def _reading_changes(problem: CalibrationProblem, x: Array, rows: list[int]) -> tuple[Array, Array, Array]:
    """For the samples ``rows``: the change of each actuated reading [rad or m] that best explains the sample's
    weighted residual (Gauss–Newton, one joint at a time, keeping the best iterate), the squared residual norm
    without it and with it (NaN where the loops do not close).

    Every (sample, joint) pair steps at once: one evaluation per iteration of the pairs of every joint still
    iterating (:func:`_sample_terms`); a joint stops, as alone, when none of its samples' steps exceeds 1e-9."""
    robot = problem.robot
    present = {p.owner for p in problem.parameters if p.is_a(ReadingOffset)}
    extra = [offset_parameter(j, joint_unit(robot, j)) for j in robot.actuated_joints if j not in present]
    pset = ParameterSet(list(problem.parameters.parameters) + extra)
    columns = np.array([pset.index(f"{j}.offset") for j in robot.actuated_joints], dtype=int)
    full = np.concatenate([np.asarray(x, dtype=float), np.zeros(len(extra))])
    observed = problem.observations.subset(rows)
    n, n_joints = len(rows), robot.n_actuated
    samples = np.arange(n)
    before, slopes, grads = _sample_terms(problem, pset, full, observed, samples, np.zeros((n, n_joints)),
                                          np.broadcast_to(columns, (n, n_joints)))
    changes, after = np.zeros((n, n_joints)), before[:, None].repeat(n_joints, axis=1)
    delta = np.zeros((n, n_joints))  # pair (c, i): joint i of sample c moved by delta[c, i]
    step = _gauss_newton_step(slopes, grads)
    active = np.ones(n_joints, dtype=bool)
    for _ in range(READING_ITERATIONS):
        active &= np.any(np.abs(step) > 1e-9, axis=0)
        if not np.any(active):
            break
        delta[:, active] += step[:, active]
        joints = np.flatnonzero(active)
        pairs, which = np.repeat(samples, joints.size), np.tile(joints, n)  # sample-major: (c, i) for i active
        moved = np.zeros((pairs.size, n_joints))
        moved[np.arange(pairs.size), which] = delta[pairs, which]
        squares, slope, grad = _sample_terms(problem, pset, full, observed, pairs, moved, columns[which][:, None])
        better = squares < after[pairs, which]
        after[pairs[better], which[better]] = squares[better]
        changes[pairs[better], which[better]] = delta[pairs[better], which[better]]
        step[pairs, which] = _gauss_newton_step(slope[:, 0], grad[:, 0])
    return changes, before, after


def _gauss_newton_step(slopes: Array, grads: Array) -> Array:
    """The Gauss–Newton step ``−(gᵀr)/(gᵀg)`` of one reading per sample [rad or m]; 0 where it is undefined."""
    step = np.zeros(slopes.shape)
    ok = np.isfinite(slopes) & np.isfinite(grads) & (slopes > 0.0)
    step[ok] = -grads[ok] / slopes[ok]
    return step


def _sample_terms(problem: CalibrationProblem, pset: ParameterSet, x: Array, observed: Observations,
                  samples: IntArray, delta: Array, columns: npt.NDArray[np.int_]) -> tuple[Array, Array, Array]:
    """For each evaluated copy ``e`` of sample ``samples[e]`` of ``observed``, its readings changed by ``delta[e]``
    (n_a,) [rad or m]: its squared weighted residual norm ``‖r‖²``, and per column ``columns[e, j]`` of ``pset`` (an
    actuated reading's offset) ``‖g‖²`` and ``gᵀr`` (``g`` = ∂r/∂q of that reading); NaN for a copy whose loops do
    not close there. The copies are evaluated at once (one problem over all of them); should that fail, each alone,
    so that one that cannot be assembled spoils no other."""
    copies = Observations(observed.actuated[samples] + delta, {key: v[samples] for key, v in observed.values.items()})
    try:
        return _terms_at_once(problem, pset, x, copies, columns)
    except (ConvergenceError, DataError):
        if copies.n_samples == 1:
            nan = np.full((1, columns.shape[1]), np.nan)
            return np.full(1, np.nan), nan, nan.copy()
    parts = [_sample_terms(problem, pset, x, copies, np.array([e]), np.zeros((1, delta.shape[1])), columns[e:e + 1])
             for e in range(copies.n_samples)]
    squares, slopes, grads = zip(*parts, strict=True)
    return np.concatenate(squares), np.concatenate(slopes), np.concatenate(grads)


def _terms_at_once(problem: CalibrationProblem, pset: ParameterSet, x: Array, copies: Observations,
                   columns: npt.NDArray[np.int_]) -> tuple[Array, Array, Array]:
    """:func:`_sample_terms` of every copy in one evaluation (ConvergenceError or DataError when one fails)."""
    joint_sigma = None if problem.joint_sigma is None else [float(v) for v in problem.joint_sigma]
    batch = CalibrationProblem(problem.robot, pset, problem.measurements, copies, joint_sigma, problem.payload)
    pred = batch.evaluate(x)
    assert pred.jacobian is not None
    owner, m = batch.row_samples(), copies.n_samples
    g = np.take_along_axis(pred.jacobian, columns[owner], axis=1)  # each row's own columns
    r = pred.residual

    def per_copy(values: Array) -> Array:
        return np.asarray(np.bincount(owner, weights=values, minlength=m), dtype=float)

    slopes = np.stack([per_copy(g[:, j] ** 2) for j in range(columns.shape[1])], axis=1)
    grads = np.stack([per_copy(g[:, j] * r) for j in range(columns.shape[1])], axis=1)
    return per_copy(r * r), slopes, grads
