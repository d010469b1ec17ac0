"""The robust linear algebra: numpy's driver first, SciPy's gesvd when it fails, a PincalError otherwise."""

from __future__ import annotations

import subprocess
import sys
import warnings
from collections.abc import Iterator

import numpy as np
import pytest
import scipy.linalg
from threadpoolctl import threadpool_limits

from pincal import linalg
from pincal.errors import ConvergenceError, DataError, IdentifiabilityError
from pincal.identification.identifiability import analyse, covariance


@pytest.fixture(autouse=True)
def _single_threaded_blas() -> Iterator[None]:
    """As ``identify`` runs: multi-threaded BLAS on these small matrices is only overhead (40× on 2 cores)."""
    with threadpool_limits(limits=1, user_api="blas"):
        yield


def _rank_deficient(m: int = 306, n: int = 74, rank: int = 39, seed: int = 5) -> np.ndarray:
    """An m × n matrix of the given rank (n − rank exactly zero singular values), like the TIAGo
    three-marker Jacobian that made numpy's SVD fail (306 × 74, 35 near-zero singular values)."""
    rng = np.random.default_rng(seed)
    return rng.normal(size=(m, rank)) @ rng.normal(size=(rank, n))


def _numpy_svd_fails(monkeypatch: pytest.MonkeyPatch) -> list[int]:
    calls: list[int] = []

    def failing(*args: object, **kwargs: object) -> None:
        calls.append(1)
        raise np.linalg.LinAlgError("SVD did not converge")

    monkeypatch.setattr(np.linalg, "svd", failing)
    return calls


def test_fallback_equals_scipy_gesvd(monkeypatch: pytest.MonkeyPatch) -> None:
    a = _rank_deficient()
    u_ref, s_ref, vt_ref = scipy.linalg.svd(a, full_matrices=False, lapack_driver="gesvd")
    calls = _numpy_svd_fails(monkeypatch)
    u, s, vt = linalg.svd(a, "a test matrix")
    assert calls, "numpy's SVD was not tried first"
    np.testing.assert_array_equal(s, s_ref)
    np.testing.assert_array_equal(u, u_ref)
    np.testing.assert_array_equal(vt, vt_ref)
    np.testing.assert_array_equal(linalg.singular_values(a, "a test matrix"),
                                  scipy.linalg.svd(a, compute_uv=False, lapack_driver="gesvd"))
    u_full, _, vt_full = linalg.svd(a, "a test matrix", full_matrices=True)
    assert u_full.shape == (306, 306) and vt_full.shape == (74, 74)


def test_rank_deficient_matrix_with_many_zero_singular_values(monkeypatch: pytest.MonkeyPatch) -> None:
    a = _rank_deficient()
    for patched in (False, True):
        if patched:
            _numpy_svd_fails(monkeypatch)
        u, s, vt = linalg.svd(a, "a test matrix")
        np.testing.assert_allclose((u * s) @ vt, a, atol=1e-10 * np.abs(a).max())
        assert np.count_nonzero(s > 1e-10 * s[0]) == 39  # 35 of 74 are zero
        pinv = linalg.pseudo_inverse(a, "a test matrix", rcond=1e-10)
        np.testing.assert_allclose(a @ pinv @ a, a, atol=1e-9 * np.abs(a).max())
        # the identifiability analysis sees the rank and names every dependent column
        ident = analyse(a, [f"p{k}" for k in range(74)], np.ones(74))
        assert ident.rank == 39 and len(ident.base_indices) == 39 and len(ident.unidentifiable) == 35
        with pytest.raises(IdentifiabilityError, match="singular on the chosen columns"):
            covariance(a, 1.0)


def test_non_finite_matrix_is_a_data_error_naming_it(monkeypatch: pytest.MonkeyPatch) -> None:
    a = _rank_deficient(12, 5, 3)
    a[4, 2] = np.nan
    _numpy_svd_fails(monkeypatch)
    with pytest.raises(DataError, match=r"the widget Jacobian has 1 NaN/inf entries \(first at index \(4, 2\)\)"):
        linalg.svd(a, "the widget Jacobian")


def test_both_drivers_failing_is_a_convergence_error(monkeypatch: pytest.MonkeyPatch) -> None:
    _numpy_svd_fails(monkeypatch)

    def also_failing(*args: object, **kwargs: object) -> None:
        raise np.linalg.LinAlgError("SVD did not converge")

    monkeypatch.setattr(scipy.linalg, "svd", also_failing)
    with pytest.raises(ConvergenceError, match=r"SVD of the widget Jacobian \(6 × 4\) did not converge"):
        linalg.svd(np.ones((6, 4)), "the widget Jacobian")
    with pytest.raises(ConvergenceError, match=r"singular values of the widget Jacobian"):
        linalg.singular_values(np.ones((6, 4)), "the widget Jacobian")


def test_eigenvalues_fall_back_matrix_by_matrix(monkeypatch: pytest.MonkeyPatch) -> None:
    rng = np.random.default_rng(2)
    b = rng.normal(size=(3, 8, 5))
    info = np.einsum("nri,nrj->nij", b, b)
    expected = np.linalg.eigvalsh(info)

    def failing(*args: object, **kwargs: object) -> None:
        raise np.linalg.LinAlgError("Eigenvalues did not converge")

    monkeypatch.setattr(np.linalg, "eigvalsh", failing)
    np.testing.assert_allclose(linalg.eigvalsh(info, "information matrices"), expected, rtol=1e-10, atol=1e-12)


def test_singular_inverse_names_the_matrix() -> None:
    with pytest.raises(IdentifiabilityError, match="the widget information matrix is singular"):
        linalg.inverse(np.zeros((3, 3)), "the widget information matrix")
    np.testing.assert_allclose(linalg.inverse(np.diag([2.0, 4.0]), "a diagonal matrix"), np.diag([0.5, 0.25]))


def test_wrap_angle_takes_the_short_way_round() -> None:
    angles = np.array([-7.0, -np.pi, -0.1, 0.0, 3.0, np.pi, 9.5])
    wrapped = linalg.wrap_angle(angles)
    assert np.all((wrapped >= -np.pi) & (wrapped < np.pi))
    np.testing.assert_allclose(np.round((angles - wrapped) / (2 * np.pi)) * 2 * np.pi, angles - wrapped, atol=1e-12)
    np.testing.assert_allclose(wrapped[[2, 3, 4]], angles[[2, 3, 4]])


@pytest.mark.parametrize("shape", [(3000, 40), (50, 40), (10, 20)])
def test_right_svd_is_the_svd_without_u(shape: tuple[int, int]) -> None:
    """Tall matrices go through the triangle of their QR: the same singular values and right vectors (up to sign),
    rank deficiency included; a wide one keeps every right vector (the null space's)."""
    rng = np.random.default_rng(3)
    a = rng.normal(size=shape)
    a[:, 1] = 2.0 * a[:, 0]  # one exact dependency
    s, vt = linalg.right_svd(a, "a test matrix")
    _, s_ref, vt_ref = np.linalg.svd(a, full_matrices=shape[0] < shape[1])
    assert vt.shape == (shape[1], shape[1]) and np.allclose(s, s_ref, rtol=1e-12, atol=1e-12 * s_ref[0])
    rank = int(np.count_nonzero(s_ref > 1e-10 * s_ref[0]))
    assert np.allclose(np.abs(vt[:rank] @ vt_ref[:rank].T), np.eye(rank), atol=1e-8)  # same vectors, signs aside
    null = vt[rank:]  # the right vectors beyond the rank span the null space
    assert np.allclose(a @ null.T, 0.0, atol=1e-9 * s_ref[0])
    bad = a.copy()
    bad[2, 3] = np.nan
    with pytest.raises(DataError, match="a test matrix has 1 NaN/inf entries"):
        linalg.right_svd(bad, "a test matrix")


@pytest.mark.parametrize("rows", [10, 4096, 9000])
def test_the_triangle_by_row_blocks_has_the_matrix_s_gram_matrix(rows: int, monkeypatch: pytest.MonkeyPatch) -> None:
    """``triangle``: RᵀR = AᵀA for A the row-scaled, column-chosen, column-scaled matrix, over one block of rows, a
    block exactly, and several (blocks of 1000 here); the matrix itself is left untouched."""
    monkeypatch.setattr(linalg, "TRIANGLE_ROWS", 1000 if rows == 9000 else linalg.TRIANGLE_ROWS)
    rng = np.random.default_rng(7)
    j = rng.normal(size=(rows, 12))
    kept = j.copy()
    columns, w, d = [0, 3, 4, 7, 11], rng.uniform(0.5, 2.0, rows), rng.uniform(1e-3, 1.0, 5)
    r = linalg.triangle(j, columns, w, d)
    a = w[:, None] * j[:, columns] * d
    assert r.shape == (5, 5) and np.allclose(np.tril(r, -1), 0.0)
    np.testing.assert_allclose(r.T @ r, a.T @ a, rtol=1e-11, atol=1e-11 * np.abs(a.T @ a).max())
    assert np.array_equal(j, kept)


@pytest.mark.parametrize(("rows", "columns"), [(50, 3), (50, 9), (100, 17), (3040, 41), (300, 80), (6, 9)])
def test_the_first_reflectors_of_the_blocked_qr_project_as_lapack_s_unblocked_ones(rows: int, columns: int) -> None:
    """``householder`` (compact WY, blocks of 8 or 16) gives LAPACK ``geqrf``'s triangle, and ``apply_householder``
    with its first k reflectors ``Q_kᵀ y`` as ``ormqr`` does, for every k: fewer than a block, a block and a part,
    all of them, and a matrix wider than tall."""
    rng = np.random.default_rng(columns)
    a, y = rng.normal(size=(rows, columns)), rng.normal(size=(rows, 2))
    factored, factors = linalg.householder(np.asfortranarray(a), "the test matrix")
    unblocked, tau, _, _ = scipy.linalg.lapack.dgeqrf(np.asfortranarray(a))
    t = min(rows, columns)
    np.testing.assert_allclose(np.triu(factored[:t]), np.triu(unblocked[:t]), rtol=0.0, atol=1e-12 * np.abs(a).max())
    for k in sorted({1, 2, 7, 8, 9, 17, t} & set(range(1, t + 1))):
        projected = linalg.apply_householder(factored[:, :k], factors[:k, :k], y, "the test matrix")
        expected = scipy.linalg.lapack.dormqr("L", "T", unblocked[:, :k], tau[:k], np.asfortranarray(y), 64)[0]
        np.testing.assert_allclose(projected, expected, rtol=0.0, atol=1e-12 * np.abs(y).max() * rows)


def test_a_matrix_without_rows_or_columns_reduces_to_nothing() -> None:
    """No column (an empty parameter set) or no row: an empty triangle, as LAPACK's unblocked QR gave, not LAPACK's
    refusal of a block of 0 columns."""
    assert linalg.triangle(np.ones((10, 0))).shape == (0, 0)
    for shape in ((10, 0), (0, 4)):
        factored, factors = linalg.householder(np.asfortranarray(np.ones(shape)), "the test matrix")
        assert factored.shape == shape and factors.size == 0


def test_the_largest_singular_value_from_the_gram_matrix() -> None:
    rng = np.random.default_rng(8)
    a = rng.normal(size=(5000, 30)) * np.logspace(0, -6, 30)
    d = rng.uniform(0.1, 10.0, 30)
    assert linalg.largest_singular_value(a, d) == pytest.approx(np.linalg.svd(a * d, compute_uv=False)[0], rel=1e-12)
    assert linalg.largest_singular_value(np.zeros((0, 3))) == 0.0


@pytest.mark.parametrize("size", [1e-200, 1e-150, 1.0, 1e150, 1e200, 1e300])
def test_the_largest_singular_value_neither_overflows_nor_underflows(size: float,
                                                                     monkeypatch: pytest.MonkeyPatch) -> None:
    """Entries far from 1, where the Gram matrix AᵀA of the matrix itself would overflow (past about 1e154) or lose
    its digits to underflow: σ₁ to round-off, the matrix read in blocks of rows (one block holding an entry
    10⁶ times the others: the Gram matrix so far is rescaled) and left untouched."""
    monkeypatch.setattr(linalg, "TRIANGLE_ROWS", 100)
    rng = np.random.default_rng(9)
    unit = rng.normal(size=(450, 6))
    unit[420, 2] = 1e6
    d = rng.uniform(0.5, 2.0, 6)
    expected = np.linalg.svd(unit * d, compute_uv=False)[0] * size
    a = unit * size
    kept = a.copy()
    assert linalg.largest_singular_value(a, d) == pytest.approx(expected, rel=1e-13, abs=0.0)
    assert np.array_equal(a, kept)
    assert linalg.largest_singular_value(np.zeros((4, 3))) == 0.0


def test_the_largest_singular_value_does_not_copy_the_matrix(monkeypatch: pytest.MonkeyPatch) -> None:
    """Its working memory is a block of rows and the Gram matrix, whatever the matrix's height (a copy of a
    100 MB Jacobian is what it exists to avoid)."""
    import tracemalloc

    monkeypatch.setattr(linalg, "TRIANGLE_ROWS", 100)
    a = np.random.default_rng(11).normal(size=(20000, 10)) * 1e200
    tracemalloc.start()
    try:
        linalg.largest_singular_value(a, np.full(10, 0.5))
        peak = tracemalloc.get_traced_memory()[1]
    finally:
        tracemalloc.stop()
    assert peak < a.nbytes / 20


@pytest.mark.parametrize("bad", [np.nan, np.inf, -np.inf])
def test_the_largest_singular_value_of_a_non_finite_matrix_is_a_data_error(bad: float,
                                                                           monkeypatch: pytest.MonkeyPatch) -> None:
    """A NaN or infinite entry (in a later block of rows, too) or column scale is refused naming the matrix, never
    answered with NaN."""
    monkeypatch.setattr(linalg, "TRIANGLE_ROWS", 100)
    a = np.random.default_rng(10).normal(size=(250, 4))
    a[230, 1] = bad
    with pytest.raises(DataError, match=r"the test Jacobian has 1 NaN/inf entries \(first at index \(230, 1\)\)"):
        linalg.largest_singular_value(a, what="the test Jacobian")
    with pytest.raises(DataError, match="the column scales of the test Jacobian has 1 NaN/inf entries"):
        linalg.largest_singular_value(a[:200], [1.0, bad, 1.0, 1.0], what="the test Jacobian")


@pytest.mark.parametrize("shape", [(40, 7), (7, 7), (5, 9), (0, 3), (3, 0)])
def test_the_qr_factors_are_scipy_s_bit_for_bit(shape: tuple[int, int]) -> None:
    """Called as ``scipy.linalg.qr`` calls LAPACK (the optimal workspace asked first), the pivoted triangle, its pivots
    and the orthonormal basis are SciPy's to the last bit, of a matrix with two equal columns (a rank to reveal)."""
    a = np.random.default_rng(4).normal(size=shape)
    if shape[1] > 3:
        a[:, 3] = a[:, 1]
    _, r_ref, pivots_ref = scipy.linalg.qr(a, mode="economic", pivoting=True)
    r, pivots = linalg.pivoted_qr(a)
    np.testing.assert_array_equal(r, r_ref)
    np.testing.assert_array_equal(pivots, pivots_ref)
    np.testing.assert_array_equal(linalg.orthonormal_basis(a), scipy.linalg.qr(a, mode="economic")[0])


def _printed_fresh(probe: str) -> list[str]:
    """The words ``probe`` prints, run in an interpreter of its own."""
    done = subprocess.run([sys.executable, "-P", "-c", probe], capture_output=True, text=True, timeout=120,
                          check=False)
    assert done.returncode == 0, done.stderr
    return done.stdout.split()


def test_the_lapack_bindings_load_without_scipy_linalg() -> None:
    """:func:`linalg.lapack` is SciPy's own module of LAPACK routines, loaded without ``scipy.linalg``'s Python layer
    (checked in a fresh interpreter); imported later, ``scipy.linalg`` takes the same module."""
    probe = ("import sys; from pincal import linalg; bindings = linalg.lapack(); "
             "loaded = 'scipy.linalg' in sys.modules; import scipy.linalg.lapack; "
             " print(loaded, bindings.dgeqp3 is scipy.linalg.lapack.dgeqp3)")
    assert _printed_fresh(probe) == ["False", "True"]
    assert linalg.lapack().dgesv is scipy.linalg.lapack.dgesv


@pytest.mark.parametrize("shape", [(0,), (1,), (2,), (5,), (6,), (7, 3), (8, 4), (3, 0), (5, 1)])
@pytest.mark.parametrize("with_nan", [False, True])
def test_median_is_numpys_to_the_bit(shape: tuple[int, ...], with_nan: bool) -> None:
    rng = np.random.default_rng(len(shape) * 10 + sum(shape))
    values = rng.standard_normal(shape)
    if with_nan and values.size:
        values.flat[rng.integers(values.size)] = np.nan
    for axis in [None, *range(-len(shape), len(shape))]:
        with warnings.catch_warnings():  # the mean of an empty slice warns in both
            warnings.simplefilter("ignore", RuntimeWarning)
            expected, got = np.median(values, axis=axis), linalg.median(values, axis=axis)
        assert type(got) is type(expected) and np.asarray(got).tobytes() == np.asarray(expected).tobytes()
    assert linalg.median([3, 1, 2, 4]) == np.median([3, 1, 2, 4]) == 2.5


@pytest.mark.parametrize("n", [0, 1, 5, 12])
def test_complement_is_setdiff1d_of_the_range(n: int) -> None:
    rng = np.random.default_rng(n)
    for size in range(8):
        held = rng.integers(-3, n + 3, size=size)
        expected, got = np.setdiff1d(np.arange(n), held), linalg.complement(n, held)
        assert got.dtype == expected.dtype and np.array_equal(got, expected)
    assert np.array_equal(linalg.complement(n, []), np.arange(n))


def test_median_and_complement_load_no_masked_arrays() -> None:
    probe = ("import sys; import numpy as np; loaded = 'numpy.ma' in sys.modules; "  # numpy 1.x loads it at once
             "from pincal.linalg import complement, median; "
             "print(median(np.array([1.0, np.nan, 2.0])), median(np.ones((3, 2)), axis=0), complement(3, [1]), "
             "'numpy.ma' in sys.modules and not loaded)")
    assert _printed_fresh(probe) == ["nan", "[1.", "1.]", "[0", "2]", "False"]
