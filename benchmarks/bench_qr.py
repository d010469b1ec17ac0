"""The dense kernels of one Levenberg–Marquardt iteration and of the predicted bounds, side by side with what they
replaced or what SciPy offers.

Run: ``python benchmarks/bench_qr.py`` (``--repeats K``, default 300). One BLAS thread, CPU time, medians of K calls
made in turns in one process:

- the Householder QR of a weighted, scaled Jacobian with its residual appended and ``Q_tᵀ y`` of one vector (what
  :class:`pincal.identification.steps.Steps` does once per iteration and per geodesic-acceleration trial), three ways
  side by side: LAPACK ``geqrf`` + ``ormqr`` (pincal before issue 27's fourth round), the compact WY form ``geqrt`` +
  ``gemqrt``, numpy's QR (Q formed, then ``Q_tᵀ y``), and pincal's own (:func:`pincal.linalg.householder`), at the
  sizes of the UR10 of ``bench_library`` (1000 positions, 40 parameters, 40 prior rows), the Delta's (60 positions,
  24 parameters) and the TIAGo's three markers (306 rows, 74 parameters); each call on a copy made before its clock
  starts, the order of the calls rotated every round;
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


def with_geqrf(augmented: np.ndarray, vector: np.ndarray) -> np.ndarray:
    """LAPACK ``geqrf`` (workspace 64 × n) then ``ormqr`` (workspace: the vector's columns): Q_tᵀ y with the first
    t = n − 1 reflectors."""
    n = augmented.shape[1]
    reflectors, tau, _, info = scipy.linalg.lapack.dgeqrf(augmented, lwork=64 * n, overwrite_a=1)
    assert info == 0
    t = n - 1
    projected, _, info = scipy.linalg.lapack.dormqr("L", "T", reflectors[:, :t], tau[:t], vector, vector.shape[1],
                                                    overwrite_c=0)
    assert info == 0
    return np.asarray(projected[:t])


def with_geqrt(augmented: np.ndarray, vector: np.ndarray) -> np.ndarray:
    """LAPACK ``geqrt`` (compact WY, blocks of 8, 16 past 64 columns) then ``gemqrt``, the same product."""
    m, n = augmented.shape
    block = min(m, n, 8 if n < 64 else 16)
    reflectors, factors, info = scipy.linalg.lapack.dgeqrt(block, augmented, overwrite_a=1)
    assert info == 0
    t = n - 1
    projected, info = scipy.linalg.lapack.dgemqrt(reflectors[:, :t], factors[:t, :t], vector, side="L", trans="T")
    assert info == 0
    return np.asarray(projected[:t])


def with_numpy(augmented: np.ndarray, vector: np.ndarray) -> np.ndarray:
    """numpy's QR (``geqrf`` and ``orgqr``: the m × n Q formed) then ``Q_tᵀ y``, the same product."""
    q, _ = np.linalg.qr(augmented)
    return np.asarray(q[:, :augmented.shape[1] - 1].T @ vector)


def in_pincal(augmented: np.ndarray, vector: np.ndarray) -> np.ndarray:
    """:func:`pincal.linalg.householder` then :func:`pincal.linalg.apply_householder`, the same product."""
    reflectors, factors = linalg.householder(augmented, "the benchmark matrix")
    t = augmented.shape[1] - 1
    return linalg.apply_householder(reflectors[:, :t], factors[:t, :t], vector, "the benchmark matrix")[:t]


#: The QR kernels compared, each called in turn with its own copy of the matrix.
KERNELS = {"geqrf + ormqr": with_geqrf, "geqrt + gemqrt": with_geqrt, "numpy": with_numpy, "pincal": in_pincal}


def in_turns(calls: list[Callable[[np.ndarray], object]], matrix: np.ndarray, repeats: int) -> list[float]:
    """Median CPU time [s] of each call on its own copy of ``matrix`` (made before the clock starts: a fresh array's
    page faults are not the kernel's), the calls made in turns, their order rotated each round (A, B, C, then B, C,
    A, ...): a call that evicts the caches (numpy's QR forms an m × n Q) slows whichever follows it, each in turn."""
    times: list[list[float]] = [[] for _ in calls]
    for round_ in range(repeats):
        for k in range(len(calls)):
            which = (round_ + k) % len(calls)
            copy = matrix.copy(order="F")
            start = time.process_time()
            calls[which](copy)
            times[which].append(time.process_time() - start)
    return [statistics.median(t) for t in times]


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--repeats", type=int, default=300, help="calls of each, in turns")
    args = parser.parse_args()
    rng = np.random.default_rng(0)
    print(f"one BLAS thread, CPU time, medians of {args.repeats} calls of each made in turns")
    print("| size | " + " | ".join(f"`{name}` [ms]" for name in KERNELS) + " | `geqrt` / `geqrf` | numpy / `geqrf` |")
    print("|---|" + "---|" * (len(KERNELS) + 2))
    fastest: dict[str, int] = {}
    with threadpool_limits(limits=1, user_api="blas"):
        for name, (rows, columns) in SIZES.items():
            matrix = np.asfortranarray(rng.normal(size=(rows, columns)))
            vector = np.asfortranarray(rng.normal(size=(rows, 1)))
            reference = np.abs(with_geqrf(matrix.copy(order="F"), vector))
            for kernel in KERNELS.values():
                assert np.allclose(np.abs(kernel(matrix.copy(order="F"), vector)), reference, atol=1e-10)
            medians = dict(zip(KERNELS, in_turns([lambda m, k=kernel, v=vector: k(m, v) for kernel in KERNELS.values()],
                                                 matrix, args.repeats), strict=True))
            winner = min(("geqrf + ormqr", "geqrt + gemqrt", "numpy"), key=lambda k: medians[k])
            fastest[winner] = fastest.get(winner, 0) + 1
            print(f"| {name} ({rows} × {columns}) | " + " | ".join(f"{t * 1e3:.3f}" for t in medians.values())
                  + f" | {medians['geqrt + gemqrt'] / medians['geqrf + ormqr']:.2f} | "
                  f"{medians['numpy'] / medians['geqrf + ormqr']:.2f} |")
        print("\nfastest of the three: " + ", ".join(f"`{k}` at {v} of {len(SIZES)} sizes" for k, v in fastest.items()))
        from scipy.special import chdtri

        dofs = rng.uniform(1.0, 3.0, 100)
        old, new = in_turns([lambda _: chdtri(dofs, 0.05), lambda _: chi2_upper(0.05, dofs)], dofs,
                            max(args.repeats // 10, 5))
        print(f"\n95 % χ² quantiles of 100 ν in [1, 3]: `scipy.special.chdtri` {old * 1e3:.3f} ms, pincal's "
              f"`chi2_upper` {new * 1e3:.3f} ms ({new / old:.1f} ×)")


if __name__ == "__main__":
    main()
