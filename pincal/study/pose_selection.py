"""Experiment design: which poses to measure, chosen from a candidate set.

The identification Jacobian of a pose set is the stack of each pose's row block. Computed once for
every candidate (:func:`jacobian_blocks`), the blocks make any pose set's information matrix
``M = Σ B_kᵀ B_k`` a sum, so a greedy search can score thousands of candidates per step.

Columns are scaled by each parameter's typical size before anything is compared (as in
:mod:`pincal.identification.identifiability`: ``J_s = J diag(s)``), so metres and radians compare. Criteria:

- ``condition``: minimise the condition number ``κ = σ_max / σ_min`` of the scaled Jacobian
  (study 001 §4.2, study 003 §5: "selected ... by minimising the condition number of the
  identification Jacobian matrix");
- ``d-optimal``: maximise ``log det(J_sᵀ J_s)`` (the volume of the confidence ellipsoid shrinks).

Search: greedy forward selection (while the set cannot yet identify every column, candidates are
ranked by a slightly regularised ``log det``), then exchange passes that swap a chosen pose for a
candidate whenever that improves the criterion (Fedorov's exchange, first improvement per position),
until a pass changes nothing.

Incremental measurements (a scale reset after each reading, study 003) see only differences of
consecutive poses: pass the blocks of the *absolute* measurement and ``difference=True``; the rows of
a set are then ``B_{k+1} − B_k`` in selection order.
"""

from __future__ import annotations

import concurrent.futures
import itertools
from collections.abc import Callable, Sequence
from dataclasses import field
from pathlib import Path
from typing import Any

import numpy as np
import numpy.typing as npt

from pincal import linalg
from pincal.errors import DataError
from pincal.identification.identifiability import base_parameters
from pincal.identification.problem import CalibrationProblem
from pincal.progress import Progress
from pincal.records import record
from pincal.study.criteria import CRITERIA

Array = npt.NDArray[np.float64]
Indices = Sequence[int] | npt.NDArray[np.int_]

#: Relative eigenvalue floor: below ``FULL_RANK · λ_max`` the information matrix counts as singular.
FULL_RANK = 1e-12
#: Ridge added (relative to the pool's mean eigenvalue) while a partial set is still singular.
PARTIAL_RIDGE = 1e-9


def jacobian_blocks(problem: CalibrationProblem, x: Array | None = None, weighted: bool = True,
                    executor: concurrent.futures.Executor | None = None, chunk: int = 200) -> Array:
    """Each sample's rows of the identification Jacobian, (N, rows per sample, p).

    Args:
        problem: A problem over the candidate poses (its measured values are not used).
        x: Parameter estimate to linearise at [m, rad]; nominal (zero) by default.
        weighted: Rows divided by each measurement's σ (as in the residual); otherwise in measurement
            units per parameter unit [m/m, rad/m, ...].
        executor: Any ``concurrent.futures.Executor`` (a process pool, a Dask client's
            ``get_executor()``) to compute chunks of ``chunk`` candidates in parallel; each worker rebuilds
            the robot from its URDF file, so the robot must come from one.
        chunk: Candidates per parallel job (with ``executor``).

    Raises:
        DataError: the problem has an incremental measurement (rows of pairs, not of poses).
    """
    incremental = [m.key for m in problem.measurements if m.incremental]
    if incremental:
        raise DataError(f"measurement(s) {', '.join(incremental)} are incremental: their rows belong to pairs of "
                        "poses. Build the candidate problem with the absolute measurement (e.g. "
                        "distance(a, b, increment=False)) and select with difference=True")
    p = len(problem.parameters)
    n_all = problem.observations.n_samples
    if executor is not None and n_all > chunk:
        if problem.robot.source is None:
            raise DataError(f"robot '{problem.robot.name}' was not loaded from a file: parallel Jacobian blocks "
                            "rebuild it in each worker from its URDF")
        text = Path(problem.robot.source).read_text(encoding="utf-8")
        jobs = [(text, problem.parameters, problem.measurements, problem.observations.subset(np.arange(a, min(a + chunk,
                n_all))), x, weighted) for a in range(0, n_all, chunk)]
        return np.concatenate(list(executor.map(_blocks_job, jobs)), axis=0)
    pred = problem.evaluate(np.zeros(p) if x is None else np.asarray(x, dtype=float))
    assert pred.jacobian is not None
    n = problem.observations.n_samples
    parts, start = [], 0
    for m in problem.measurements:
        rows = n * m.size
        block = pred.jacobian[start:start + rows].reshape(n, m.size, p)
        if not weighted:
            block = block * m.row_sigmas()[None, :, None]
        parts.append(block)
        start += rows
    return np.concatenate(parts, axis=1)


def _blocks_job(job: tuple[str, Any, Any, Any, Array | None, bool]) -> Array:
    """A worker's share of :func:`jacobian_blocks` (top level, so it pickles)."""
    from pincal.model.robot import robot_from_urdf_text

    text, parameters, measurements, observations, x, weighted = job
    robot = robot_from_urdf_text(text)
    return jacobian_blocks(CalibrationProblem(robot, parameters, measurements, observations), x, weighted)


@record
class PoseSelection:
    """The chosen poses and how well they condition the identification.

    Attributes:
        indices: Candidate indices in selection order (the measuring order when ``difference``).
        criterion: ``condition`` or ``d-optimal``.
        condition_number: κ of the scaled Jacobian of the chosen set (SVD), on ``columns``.
        log_det: ``log det(J_sᵀ J_s)`` of the chosen set, on ``columns``.
        columns: Parameter columns the design was made for (the pool's identifiable ones by default).
        dropped: Names of the columns left out because no candidate set can identify them.
        history: Criterion value after each greedy addition (``inf``/``-inf`` while singular).
        exchanges: Swaps made by the exchange passes.
    """

    indices: list[int]
    criterion: str
    condition_number: float
    log_det: float
    columns: list[int]
    dropped: list[str] = field(default_factory=list)
    history: list[float] = field(default_factory=list)
    exchanges: int = 0


def _as_blocks(candidates: CalibrationProblem | npt.ArrayLike, scales: npt.ArrayLike | None,
               names: Sequence[str] | None,
               executor: concurrent.futures.Executor | None = None) -> tuple[Array, Array, list[str]]:
    if isinstance(candidates, CalibrationProblem):
        blocks = jacobian_blocks(candidates, executor=executor)
        s = candidates.parameters.scales if scales is None else np.asarray(scales, dtype=float)
        labels = list(candidates.parameters.names) if names is None else list(names)
    else:
        blocks = np.asarray(candidates, dtype=float)
        if blocks.ndim == 2:
            blocks = blocks[:, None, :]
        if blocks.ndim != 3 or blocks.shape[0] == 0:
            raise DataError(f"candidate blocks must be (N, rows, p) with N > 0; got shape {blocks.shape}")
        s = np.ones(blocks.shape[2]) if scales is None else np.asarray(scales, dtype=float)
        labels = [f"p{j}" for j in range(blocks.shape[2])] if names is None else list(names)
    if s.shape != (blocks.shape[2],) or not np.all(s > 0):
        raise DataError(f"scales must be ({blocks.shape[2]},) positive values [m or rad]; got shape {s.shape}")
    if len(labels) != blocks.shape[2]:
        raise DataError(f"{len(labels)} names for {blocks.shape[2]} parameter columns")
    if not np.all(np.isfinite(blocks)):
        raise DataError("candidate Jacobian blocks contain NaN or infinity")
    return blocks, s, labels


def _pair_information(a: Array, b: Array) -> Array:
    """``(b − a)ᵀ(b − a)`` for blocks a (r, p) or (N, r, p) and b (r, p) or (N, r, p)."""
    d = b - a
    return np.asarray(np.einsum("...ri,...rj->...ij", d, d), dtype=np.float64)


def _score(info: Array, criterion: str, ridge: float) -> tuple[Array, Array]:
    """(regular, value) of information matrices (..., p, p); better = regular first, then smaller value.

    ``value`` is κ (condition) or ``-log det`` (d-optimal) for a regular set; a singular set is ranked
    by its regularised ``-log det`` (how close it comes to identifying every column).
    """
    eig: Any = linalg.eigvalsh(info, "the information matrix of a candidate pose set")  # regular below is boolean
    top = np.maximum(eig[..., -1], 1e-300)
    regular = eig[..., 0] > FULL_RANK * top
    neg_logdet = -np.sum(np.log(np.maximum(eig, 0.0) + ridge), axis=-1)
    if criterion == "d-optimal":  # ranked by (regularised) log det alone
        return np.ones_like(regular), np.asarray(neg_logdet)
    kappa = np.sqrt(top / np.maximum(eig[..., 0], 1e-300))
    return regular, np.asarray(np.where(regular, kappa, neg_logdet))


def _best(regular: Array, value: Array, exclude: Sequence[int]) -> int:
    """Index of the best candidate (regular first, then the smallest value), skipping ``exclude``."""
    value = value.copy()
    value[list(exclude)] = np.inf
    key = np.where(regular, 0, 1)
    key[list(exclude)] = 2
    return int(np.lexsort((value, key))[0])


def _stacked(blocks: Array, indices: Indices, difference: bool) -> Array:
    chosen = blocks[list(indices)]
    if difference:
        chosen = np.diff(chosen, axis=0)
    return chosen.reshape(-1, blocks.shape[2])


def condition_number(blocks: npt.ArrayLike, indices: Indices, scales: npt.ArrayLike | None = None,
                     columns: Sequence[int] | None = None, difference: bool = False) -> float:
    """κ = σ_max/σ_min of the scaled Jacobian of a pose set (SVD); ``inf`` if rank-deficient.

    Args:
        blocks: (N, rows, p) candidate row blocks (see :func:`jacobian_blocks`).
        indices: The poses, in measuring order.
        scales: (p,) typical parameter sizes [m or rad]; ones by default.
        columns: Parameter columns to keep; all by default.
        difference: Rows are differences of consecutive poses (reset scale).
    """
    jac = _scaled_subset(blocks, indices, scales, columns, difference)
    sv = linalg.singular_values(jac, "the scaled Jacobian of the pose set")
    if sv.size < jac.shape[1] or sv[-1] <= 1e-14 * sv[0]:
        return float("inf")
    return float(sv[0] / sv[-1])


def log_det(blocks: npt.ArrayLike, indices: Indices, scales: npt.ArrayLike | None = None,
            columns: Sequence[int] | None = None, difference: bool = False) -> float:
    """``log det(J_sᵀ J_s)`` of a pose set (``-inf`` if singular); arguments as :func:`condition_number`."""
    jac = _scaled_subset(blocks, indices, scales, columns, difference)
    sv = linalg.singular_values(jac, "the scaled Jacobian of the pose set")
    if sv.size < jac.shape[1] or sv[-1] == 0.0:
        return float("-inf")
    return float(2.0 * np.sum(np.log(sv)))


def _scaled_subset(blocks: npt.ArrayLike, indices: Indices, scales: npt.ArrayLike | None,
                   columns: Sequence[int] | None, difference: bool) -> Array:
    b = np.asarray(blocks, dtype=float)
    if b.ndim == 2:
        b = b[:, None, :]
    s = np.ones(b.shape[2]) if scales is None else np.asarray(scales, dtype=float)
    cols = list(range(b.shape[2])) if columns is None else list(columns)
    return _stacked(b * s, indices, difference)[:, cols]


def pool_columns(scaled: Array, names: Sequence[str], difference: bool = False) -> list[int]:
    """The parameters (column indices) the whole candidate pool can identify, from its scaled row blocks
    (N, rows, p); ``difference``: rows are differences of consecutive poses."""
    pool = scaled - scaled.mean(axis=0) if difference else scaled
    # R of an unpivoted QR has the pool's singular values and column geometry, in p × p
    factor = np.linalg.qr(pool.reshape(-1, scaled.shape[2]), mode="r")
    cols, _ = base_parameters(factor, list(names), np.ones(len(names)))
    return cols


def select_poses(candidates: CalibrationProblem | npt.ArrayLike, k: int, criterion: str = "condition",
                 scales: npt.ArrayLike | None = None, columns: Sequence[int] | None = None,
                 names: Sequence[str] | None = None, initial: Sequence[int] = (), exchange: bool = True,
                 max_passes: int = 3, difference: bool = False, screen: int | None = 64,
                 progress: bool = False, executor: concurrent.futures.Executor | None = None) -> PoseSelection:
    """Choose ``k`` poses among the candidates by condition number or D-optimality.

    Args:
        executor: Passed to :func:`jacobian_blocks` when ``candidates`` is a problem (large candidate sets).
        candidates: A :class:`CalibrationProblem` over the candidate poses, or their Jacobian row blocks
            (N, rows, p) as from :func:`jacobian_blocks`.
        k: Number of poses to choose.
        criterion: ``condition`` (minimise κ) or ``d-optimal`` (maximise log det).
        scales: (p,) typical parameter sizes [m or rad]; the problem's by default, else ones.
        columns: Parameters to design for; default: those the whole candidate pool can identify
            (the others are reported in ``dropped``: no pose set can make them identifiable).
        names: Parameter names (for ``dropped``); the problem's by default.
        initial: Poses that must be in the set (they start it and are never exchanged).
        exchange: Run exchange passes after the greedy selection.
        max_passes: Exchange passes at most.
        difference: Rows are differences of consecutive poses (incremental measurement).
        screen: For ``condition``, score exactly only this many candidates per step, those adding the
            most information where the set is weakest (None: all; the search is then slower).
        progress: Show a progress bar on stderr (when it is a terminal): one tick per greedy addition
            and per exchange step (a pose position tried in a pass); passes not needed are skipped.

    Raises:
        DataError: unknown criterion, ``k`` out of range, or malformed blocks.
    """
    if criterion not in CRITERIA:
        raise DataError(f"unknown design criterion '{criterion}'; criteria are: {', '.join(CRITERIA)}")
    blocks, s, labels = _as_blocks(candidates, scales, names, executor)
    n = blocks.shape[0]
    fixed = [int(i) for i in initial]
    if not 1 <= k <= n or len(fixed) > k or any(not 0 <= i < n for i in fixed):
        raise DataError(f"cannot choose {k} of {n} candidates (with {len(fixed)} imposed)")
    scaled = blocks * s
    dropped: list[str] = []
    if columns is None:
        cols = pool_columns(scaled, labels, difference)
        dropped = [labels[j] for j in range(len(labels)) if j not in set(cols)]
    else:
        cols = sorted(int(j) for j in columns)
    b = np.ascontiguousarray(scaled[:, :, cols])
    gram = np.einsum("nri,nrj->nij", b, b)
    ridge = PARTIAL_RIDGE * max(float(np.trace(gram.sum(axis=0))) / (n * len(cols)), 1e-300)

    selected = list(fixed)
    if not selected:
        selected = [int(np.argmax(np.einsum("nii->n", gram)))]
    info = _set_information(b, gram, selected, difference)
    history: list[float] = []
    steps = (k - len(selected)) + (max_passes * (k - len(fixed)) if exchange else 0)
    with Progress("pose selection", steps, quiet=not progress) as bar:
        while len(selected) < k:
            regular, value, info_of = _candidates(b, gram, info, selected, None, criterion, ridge, difference,
                                                  screen)
            best = _best(regular, value, selected)
            selected.append(best)
            info = info_of(best)
            history.append(_reported(bool(regular[best]), float(value[best]), criterion))
            bar.advance()
        exchanges = 0
        for _ in range(max_passes if exchange else 0):
            changed = 0
            for pos in range(len(fixed), len(selected)):
                reg_now, val_now = _score(info, criterion, ridge)
                regular, value, info_of = _candidates(b, gram, info, selected, pos, criterion, ridge, difference,
                                                      screen)
                best = _best(regular, value, selected)
                better = bool(regular[best]) and not bool(reg_now)
                same_class = bool(regular[best]) == bool(reg_now)
                if better or (same_class and value[best] < float(val_now) - 1e-9 * abs(float(val_now))):
                    selected[pos] = best
                    info = info_of(best)
                    changed += 1
                bar.advance()
            exchanges += changed
            if not changed:
                break
        bar.finish()
    return PoseSelection(selected, criterion, condition_number(b, selected, difference=difference),
                         log_det(b, selected, difference=difference), list(cols), dropped, history, exchanges)


def _candidates(b: Array, gram: Array, info: Array, selected: list[int], pos: int | None, criterion: str,
                ridge: float, difference: bool, screen: int | None) -> tuple[Array, Array, Callable[[int], Array]]:
    """Score every candidate as the next pose (``pos`` None) or as the replacement at ``pos``.

    Returns (regular, value) per candidate and a function giving a candidate's information matrix.
    With ``screen``, the condition criterion is evaluated exactly only for the ``screen`` candidates
    that add the most information where the set is weakest (largest ``log det(I + B M⁻¹ Bᵀ)``); the
    others are ranked last. Eigenvalues of every candidate's p × p matrix cost most of the time.
    """
    n = gram.shape[0]
    if difference:
        trial = info + _pair_information(b[selected[-1]], b) if pos is None else \
            _swapped_information(b, gram, info, selected, pos, difference)
        regular, value = _score(trial, criterion, ridge)
        return regular, value, lambda c: np.asarray(trial[c])
    base = info if pos is None else info - gram[selected[pos]]
    if criterion == "d-optimal" or (screen is not None and n > screen):
        count = n if screen is None else screen
        # matrix determinant lemma: log det(M + BᵀB) = log det M + log det(I + B M⁻¹ Bᵀ), r × r per candidate
        regularised = base + ridge * np.eye(base.shape[0])
        inverse = linalg.inverse(regularised, "the regularised information matrix of the chosen poses")
        small = np.matmul(b @ inverse, b.transpose(0, 2, 1)) + np.eye(b.shape[1])
        gain = np.linalg.slogdet(small)[1]
        if criterion == "d-optimal":
            value = -(np.linalg.slogdet(regularised)[1] + gain)
            return np.ones(n, dtype=bool), np.asarray(value), lambda c: np.asarray(base + gram[c])
        gain[selected] = -np.inf
        keep = np.argpartition(-gain, count)[:count]
        regular = np.zeros(n, dtype=bool)
        value = np.full(n, np.inf)
        regular[keep], value[keep] = _score(base + gram[keep], criterion, ridge)
        return regular, value, lambda c: np.asarray(base + gram[c])
    trial = base + gram
    regular, value = _score(trial, criterion, ridge)
    return regular, value, lambda c: np.asarray(trial[c])


def _reported(regular: bool, value: float, criterion: str) -> float:
    """The criterion as reported: κ (``inf`` while singular) or log det."""
    if criterion == "d-optimal":
        return -value
    return value if regular else float("inf")


def _set_information(b: Array, gram: Array, selected: Sequence[int], difference: bool) -> Array:
    if difference:
        return sum((_pair_information(b[i], b[j]) for i, j in itertools.pairwise(selected)),
                   np.zeros(gram.shape[1:]))
    return np.asarray(gram[list(selected)].sum(axis=0))


def _swapped_information(b: Array, gram: Array, info: Array, selected: list[int], pos: int,
                         difference: bool) -> Array:
    """Information matrices (N, p, p) of the set with position ``pos`` replaced by each candidate."""
    old = selected[pos]
    if not difference:
        swapped: Array = info - gram[old] + gram
        return swapped
    out = np.broadcast_to(info, gram.shape).copy()
    if pos > 0:
        prev = b[selected[pos - 1]]
        out += _pair_information(prev, b) - _pair_information(prev, b[old])
    if pos + 1 < len(selected):
        nxt = b[selected[pos + 1]]
        out += _pair_information(b, nxt) - _pair_information(b[old], nxt)
    return out
