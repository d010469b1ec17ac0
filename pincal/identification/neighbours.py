"""The actuated values each sample was last solved for, and the solved sample nearest to a new input.

A first forward-kinematics solve of a closed-loop robot solved sample by sample warm-starts from the solved sample
nearest in actuated values (max-abs gap, continuous joints the short way round) if it is within one continuation
step (:meth:`pincal.identification.problem.CalibrationProblem._solve`; the batched path closes its first solves by
continuation from the reference, all together, with no search). Scanning every solved sample for each of N
cold starts is O(N²) over a first evaluation (3.5 s of 12.7 s at N = 6000 on the Delta). Here the solved inputs
sit in one static k-d tree (SciPy's ``cKDTree``, Chebyshev metric, periodic in the continuous joints) plus a list
of the latest ones, scanned directly, that is folded into a new tree once it holds ``max(LEAF, √(16 N))``
samples: a query costs O(√N + log N), and a first evaluation O(N^1.5 log N) instead of O(N²). The answer is the
brute-force scan's: the tree only proposes candidates, and the gap that decides is computed by the caller's own
difference of actuated values.
"""

from __future__ import annotations

import math
from collections.abc import Callable
from typing import TYPE_CHECKING

import numpy as np
import numpy.typing as npt

if TYPE_CHECKING:
    from scipy.spatial import cKDTree

Array = npt.NDArray[np.float64]
IntArray = npt.NDArray[np.int64]

#: Fewest solved inputs in the tree: below this many, the directly scanned list is the whole index (a scan costs
#: less than a tree query).
LEAF = 512
#: Relative slack on the tree's distances: it only proposes candidates, the caller's gap decides, so a candidate
#: within rounding of the nearest or of the reach is never missed.
SLACK = 1e-9


class SolvedInputs:
    """Per sample, the actuated values [rad or m] it was last solved for (NaN: never solved), searchable for the
    nearest within ``reach``.

    Args:
        n_samples: N.
        continuous: (na,) which actuated joints are unbounded revolutes (values compared modulo 2π).
        reach: Largest max-abs gap [rad or m] at which a solved sample counts as a neighbour.
    """

    def __init__(self, n_samples: int, continuous: npt.NDArray[np.bool_], reach: float) -> None:
        self.values = np.full((n_samples, continuous.size), np.nan)
        self.reach = reach
        self._period = np.where(continuous, 2.0 * math.pi, 0.0)  # cKDTree's boxsize: 0 is not periodic
        self._dirty = np.zeros(n_samples, dtype=bool)
        self._changed: list[int] = []  # recorded since the last query, each once
        self._tree: cKDTree | None = None
        self._tree_samples = np.zeros(0, dtype=np.int64)
        self._in_tree = np.zeros(n_samples, dtype=bool)  # the tree's entry for the sample is its current values
        self._stale = 0  # tree entries recorded anew since the tree was built
        self._tail = np.zeros(n_samples, dtype=np.int64)  # the samples scanned directly: _tail[:_tail_size]
        self._tail_size = 0
        self._in_tail = np.zeros(n_samples, dtype=bool)

    def record(self, sample: int, values: Array) -> None:
        """Sample ``sample`` was solved for actuated values ``values`` [rad or m]."""
        self.values[sample] = values
        if not self._dirty[sample]:
            self._dirty[sample] = True
            self._changed.append(sample)

    def nearest(self, query: Array, delta: Callable[[Array, Array], Array]) -> int:
        """The solved sample whose values are nearest to ``query`` by ``max|delta(query, values)|``, the lowest
        index among equals, if within ``reach``; -1 otherwise. ``delta(target, rows)`` is the caller's difference
        of actuated values (continuous joints wrapped), the one that decides: the answer is a scan's over every
        solved sample."""
        self._update()
        pool = self._tail[:self._tail_size]
        if self._tree is not None:
            pool = np.concatenate([pool, self._from_tree(np.asarray(query, dtype=float))])
        if not pool.size:
            return -1
        gaps = np.max(np.abs(delta(query, self.values[pool])), axis=1)
        close = gaps <= self.reach
        if not np.any(close):
            return -1
        best = np.min(gaps[close])
        return int(np.min(pool[close & (gaps == best)]))  # each sample once in the pool: tree or tail

    def _update(self) -> None:
        """Index what was recorded since the last query: each changed sample joins the scanned list (its tree
        entry, if any, turns stale); one new tree over everything when that list or the stale entries grow long."""
        if not self._changed:
            return
        changed = self._changed
        self._changed = []
        self._dirty[changed] = False
        if any(self._in_tail[k] for k in changed):  # recorded again before being folded into the tree
            again = np.zeros(self._in_tail.size, dtype=bool)
            again[changed] = True
            kept = self._tail[:self._tail_size][~again[self._tail[:self._tail_size]]]
            self._tail_size = kept.size
            self._tail[:kept.size] = kept
        self._stale += int(np.count_nonzero(self._in_tree[changed]))
        self._in_tree[changed] = False
        self._tail[self._tail_size:self._tail_size + len(changed)] = changed
        self._tail_size += len(changed)
        self._in_tail[changed] = True
        entries = self._tree_samples.size - self._stale + self._tail_size
        if self._tail_size >= max(LEAF, math.sqrt(16.0 * entries)) or self._stale > entries:
            self._rebuild()

    def _rebuild(self) -> None:
        """One tree over every solved sample; the scanned list empty. SciPy's spatial package loads here, with the
        first tree (over :data:`LEAF` solved samples): a smaller dataset never needs it, and a command's start
        spares its import."""
        from scipy.spatial import cKDTree

        solved = np.flatnonzero(~np.any(np.isnan(self.values), axis=1)).astype(np.int64)
        self._tree = cKDTree(self._coordinates(self.values[solved]), boxsize=self._period)
        self._tree_samples = solved
        self._in_tree[:] = False
        self._in_tree[solved] = True
        self._stale = 0
        self._in_tail[self._tail[:self._tail_size]] = False
        self._tail_size = 0

    def _coordinates(self, values: Array) -> Array:
        """Tree coordinates: continuous joints' values reduced into [0, 2π) (the tree's periodic box)."""
        wrap = self._period > 0.0
        if not np.any(wrap):
            return values
        out = np.array(values, dtype=float)
        reduced = np.mod(out[..., wrap], 2.0 * math.pi)
        out[..., wrap] = np.where(reduced >= 2.0 * math.pi, 0.0, reduced)
        return out

    def _from_tree(self, query: Array) -> IntArray:
        """The tree's current samples within the reach of ``query`` and within slack of the nearest of them."""
        assert self._tree is not None
        point = self._coordinates(query)
        bound = self.reach * (1.0 + SLACK) + SLACK
        size = self._tree_samples.size
        k = min(2, size)  # the nearest and the next: a tie shows as equal distances
        while True:
            distances, rows = self._tree.query(point, k=k, p=math.inf, distance_upper_bound=bound)
            distances, rows = np.atleast_1d(distances), np.atleast_1d(rows)
            found = rows < size
            samples = self._tree_samples[rows[found]]
            live = self._in_tree[samples]
            if np.any(live):
                window = float(np.min(distances[found][live])) * (1.0 + SLACK) + SLACK
                if not found[-1] or distances[-1] > window or k == size:
                    return np.asarray(samples[live & (distances[found] <= window)], dtype=np.int64)
            elif not found[-1] or k == size:  # nothing current within the bound
                return np.zeros(0, dtype=np.int64)
            k = min(4 * k, size)
