"""The dense kernels of one Levenberg–Marquardt iteration and of the predicted bounds, side by side with what they
replaced or what SciPy offers.

Run: ``python benchmarks/bench_qr.py`` (``--repeats K``, default 300). One BLAS thread, CPU time, medians of K calls
made in turns (A, B, A, B, ...) in one process:

- the Householder QR of a weighted, scaled Jacobian with its residual appended and ``Q_tᵀ y`` of one vector (what
  :class:`pincal.identification.steps.Steps` does once per iteration and per geodesic-acceleration trial): LAPACK
  ``geqrf`` + ``ormqr`` (``scipy.linalg.qr(mode="raw")``, pincal before issue 27's fourth round) against the compact
  WY form ``geqrt`` + ``gemqrt`` of :func:`pincal.linalg.householder`, at the sizes of the UR10 of ``bench_library``
  (1000 positions, 40 parameters, 40 prior rows), the Delta's (60 positions, 24 parameters) and the TIAGo's three
  markers (306 rows, 74 parameters);
- the 95 % χ² quantiles of a hundred workspace postures (Welch–Satterthwaite degrees of freedom between 1 and 3):
  :func:`pincal.identification.chi2.chi2_upper` against ``scipy.special.chdtri`` (compiled; pincal does not import
  ``scipy.special``, a tenth of a second of every command's start).
"""

from __future__ import annotations

import argparse
import statistics
import time
from collections.abc import Callable

import numpy as np
import scipy.linalg
import scipy.linalg.lapack
from threadpoolctl import threadpool_limits

from pincal import linalg
from pincal.identification.chi2 import chi2_upper

SIZES = {"UR10, 1000 positions": (3040, 41), "Delta, 60 positions": (204, 25), "TIAGo, 3 markers": (306, 75)}


def unblocked(augmented: np.ndarray, vector: np.ndarray) -> np.ndarray:
    """``geqrf`` then ``ormqr``: Q_tᵀ y with the first t = n − 1 reflectors."""
    (reflectors, tau), _ = scipy.linalg.qr(augmented, overwrite_a=True, mode="raw", check_finite=False)
    t = augmented.shape[1] - 1
    projected, _, _ = scipy.linalg.lapack.dormqr("L", "T", reflectors[:, :t], tau[:t], vector, 64)
    return np.asarray(projected)


def blocked(augmented: np.ndarray, vector: np.ndarray) -> np.ndarray:
    """:func:`pincal.linalg.householder` then :func:`pincal.linalg.apply_householder`, the same product."""
    reflectors, factors = linalg.householder(augmented, "the benchmark matrix")
    t = augmented.shape[1] - 1
    return linalg.apply_householder(reflectors[:, :t], factors[:t, :t], vector, "the benchmark matrix")


def paired(first: Callable[[], object], second: Callable[[], object], repeats: int) -> tuple[float, float]:
    """Median CPU time [s] of each of two calls made in turns."""
    times: tuple[list[float], list[float]] = ([], [])
    for _ in range(repeats):
        for call, out in ((first, times[0]), (second, times[1])):
            start = time.process_time()
            call()
            out.append(time.process_time() - start)
    return statistics.median(times[0]), statistics.median(times[1])


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--repeats", type=int, default=300, help="calls of each, in turns")
    args = parser.parse_args()
    rng = np.random.default_rng(0)
    print(f"one BLAS thread, CPU time, medians of {args.repeats} calls of each made in turns")
    print("| kernel | size | before / SciPy [ms] | pincal [ms] | pincal / before |")
    print("|---|---|---|---|---|")
    with threadpool_limits(limits=1, user_api="blas"):
        for name, (rows, columns) in SIZES.items():
            matrix = np.asfortranarray(rng.normal(size=(rows, columns)))
            vector = np.asfortranarray(rng.normal(size=(rows, 1)))
            old, new = paired(lambda m=matrix, v=vector: unblocked(m.copy(order="F"), v),
                              lambda m=matrix, v=vector: blocked(m.copy(order="F"), v), args.repeats)
            assert np.allclose(np.abs(unblocked(matrix.copy(order="F"), vector)),
                               np.abs(blocked(matrix.copy(order="F"), vector)), atol=1e-10)
            print(f"| QR + Q_tᵀy | {name} ({rows} × {columns}) | {old * 1e3:.3f} (`geqrf`) | {new * 1e3:.3f} | "
                  f"{new / old:.2f} |")
        from scipy.special import chdtri

        dofs = rng.uniform(1.0, 3.0, 100)
        old, new = paired(lambda: chdtri(dofs, 0.05), lambda: chi2_upper(0.05, dofs), max(args.repeats // 10, 5))
        print(f"| 95 % χ² quantiles | 100 ν in [1, 3] | {old * 1e3:.3f} (`scipy.special.chdtri`) | {new * 1e3:.3f} | "
              f"{new / old:.1f} |")


if __name__ == "__main__":
    main()
