"""Identifiability analysis: rank, base parameters and their named combinations, covariance, indices."""

from __future__ import annotations

import numpy as np
import pytest

from pincal.errors import DataError, IdentifiabilityError
from pincal.identification.identifiability import (
    RANK_TOLERANCE,
    Combination,
    analyse,
    base_parameters,
    correlations,
    covariance,
)

NAMES6 = ["a.tx", "a.ty", "a.rz", "b.offset", "base.tz", "device.psi"]


def _random(m: int, p: int, seed: int) -> np.ndarray:
    return np.random.default_rng(seed).normal(size=(m, p))


def _assert_null(J: np.ndarray, names: list[str], combination: Combination) -> None:
    """The combination's direction, in physical units, is invisible to J."""
    columns = [names.index(name) for name in combination.names]
    seen = J[:, columns] @ combination.null_direction
    assert np.linalg.norm(seen) <= 1e-9 * np.linalg.norm(J[:, columns[0]]) + 1e-300


def test_full_rank_random_jacobian() -> None:
    J = _random(60, 6, seed=1)
    scales = np.array([1e-3, 1e-3, 1e-3, 2e-3, 5e-4, 1e-2])
    result = analyse(J, NAMES6, scales)
    assert result.rank == 6 and result.n_parameters == 6
    assert result.unidentifiable == []
    assert result.base_indices == list(range(6)) and result.base_names == NAMES6
    np.testing.assert_allclose(result.condition_number, np.linalg.cond(J * scales), rtol=1e-12)
    np.testing.assert_allclose(result.singular_values, np.linalg.svd(J * scales, compute_uv=False), rtol=1e-12)
    assert np.all(np.diff(result.singular_values) <= 0)


@pytest.mark.parametrize(
    ("scale_b", "scale_d", "dependent", "base", "coefficient"),
    [
        (1e-2, 1e-3, "d", "b", 2.0),  # b dominates once scaled: d = 2 b is the dependent one
        (1e-3, 1e-2, "b", "d", 0.5),  # d dominates: b = 0.5 d
        (1e-3, 1e-3, "b", "d", 0.5),  # equal scales: the larger column d is kept
    ],
)
def test_column_twice_another_is_named_in_physical_units(
    scale_b: float, scale_d: float, dependent: str, base: str, coefficient: float
) -> None:
    """J[:, d] = 2 J[:, b] in physical units, whatever the scales and whichever is kept."""
    J = _random(40, 3, seed=2)
    J = np.column_stack([J[:, 0], J[:, 1], 2.0 * J[:, 1], J[:, 2]])
    names = ["a", "b", "d", "e"]
    result = analyse(J, names, [1e-3, scale_b, scale_d, 1e-3])
    assert result.rank == 3
    assert base in result.base_names and dependent not in result.base_names
    (combination,) = result.unidentifiable
    assert combination.names == [dependent, base]
    np.testing.assert_allclose(combination.coefficients, [1.0, coefficient], rtol=1e-10)
    assert f"only {base} + {coefficient:.3f} {dependent} is seen by the data" in combination.description
    _assert_null(J, names, combination)


def test_zero_column_is_invisible() -> None:
    J = _random(30, 4, seed=3)
    J[:, 2] = 0.0
    names = ["arm.tx", "arm.ty", "base.tz", "arm.rz"]
    result = analyse(J, names, np.full(4, 1e-3))
    assert result.rank == 3 and result.base_names == ["arm.tx", "arm.ty", "arm.rz"]
    (combination,) = result.unidentifiable
    assert combination.names == ["base.tz"]
    assert combination.description == "base.tz is invisible to the data (no measurement depends on it)"


def test_column_sum_of_two_others() -> None:
    """J[:, c] = J[:, a] + J[:, b]: c is tied to both, with coefficients 1 and 1."""
    J = _random(50, 4, seed=4)
    J[:, 3] = J[:, 0] + J[:, 1]
    names = ["a", "b", "x", "c"]
    result = analyse(J, names, [1e-3, 1e-3, 1e-3, 1e-4])  # c's small scale makes it the dependent one
    assert result.rank == 3 and result.base_names == ["a", "b", "x"]
    (combination,) = result.unidentifiable
    assert combination.names == ["c", "a", "b"]
    np.testing.assert_allclose(combination.coefficients, [1.0, 1.0, 1.0], rtol=1e-10)
    assert "only a + 1.000 c, b + 1.000 c are seen" in combination.description
    _assert_null(J, names, combination)


def test_combinations_sorted_and_each_a_null_direction() -> None:
    """Rank r = 3 of p = 7 with mixed units: four combinations, by name, each invisible to J."""
    rng = np.random.default_rng(5)
    scales = np.array([1e-3, 1e-3, 1e-2, 1e-3, 1e-1, 1e-3, 1e-3])
    J = (rng.normal(size=(40, 3)) @ rng.normal(size=(3, 7))) / scales
    names = ["g", "f", "e", "d", "c", "b", "a"]
    result = analyse(J, names, scales)
    assert result.rank == 3 and len(result.unidentifiable) == 4
    dependents = [c.dependent for c in result.unidentifiable]
    assert dependents == sorted(dependents)
    assert set(dependents).isdisjoint(result.base_names)
    for combination in result.unidentifiable:
        _assert_null(J, names, combination)


def test_condition_number_is_over_the_identifiable_set() -> None:
    J = _random(30, 4, seed=6)
    J[:, 3] = 3.0 * J[:, 0]
    scales = np.array([1e-3, 2e-3, 1e-3, 1e-3])
    result = analyse(J, ["a", "b", "c", "d"], scales)
    kept = (J * scales)[:, result.base_indices]
    np.testing.assert_allclose(result.condition_number, np.linalg.cond(kept), rtol=1e-12)
    assert np.isfinite(result.condition_number)


def test_scaling_makes_mixed_units_comparable() -> None:
    """Columns 1e6 apart only because of units are full rank and well conditioned once scaled."""
    J0 = _random(50, 4, seed=7)
    scales = np.array([1e-3, 1e-3, 1e-9, 1e-9])
    J = J0 / scales  # columns 2 and 3 are 1e6 times larger than 0 and 1
    scaled = analyse(J, ["tx", "ty", "rx", "ry"], scales, tol=1e-4)
    assert scaled.rank == 4 and scaled.unidentifiable == []
    np.testing.assert_allclose(scaled.condition_number, np.linalg.cond(J0), rtol=1e-10)
    unscaled = analyse(J, ["tx", "ty", "rx", "ry"], np.ones(4), tol=1e-4)
    assert unscaled.rank == 2  # the small columns would look like noise
    assert {c.dependent for c in unscaled.unidentifiable} == {"tx", "ty"}


def test_default_tolerance_ignores_round_off_but_tol_is_a_parameter() -> None:
    """A dependency blurred at 1e-12 (an FK solve's round-off) is still a dependency by default."""
    J = _random(40, 3, seed=8)
    J[:, 2] = J[:, 0] - J[:, 1] + 1e-12 * _random(40, 1, seed=9)[:, 0]
    assert analyse(J, ["a", "b", "c"], np.ones(3)).rank == 2
    assert analyse(J, ["a", "b", "c"], np.ones(3), tol=1e-15).rank == 3
    assert RANK_TOLERANCE == 1e-8


def test_fewer_rows_than_columns() -> None:
    J = _random(3, 5, seed=10)
    names = ["a", "b", "c", "d", "e"]
    result = analyse(J, names, np.ones(5))
    assert result.rank == 3 and len(result.unidentifiable) == 2
    for combination in result.unidentifiable:
        _assert_null(J, names, combination)


def test_base_parameters_agrees_with_analyse() -> None:
    J = _random(30, 4, seed=11)
    J[:, 1] = -0.5 * J[:, 3]
    scales = [1e-3, 1e-3, 1e-3, 1e-3]
    indices, combinations = base_parameters(J, ["a", "b", "c", "d"], scales)
    result = analyse(J, ["a", "b", "c", "d"], scales)
    assert indices == result.base_indices == [0, 2, 3]
    assert [c.description for c in combinations] == [c.description for c in result.unidentifiable]
    assert combinations[0].description == "b is not identifiable on its own: only d - 0.500 b is seen by the data"


def test_observability_indices_on_a_diagonal_jacobian() -> None:
    """Scaled singular values 3, 2, 0.5 with m = 4 residuals."""
    J = np.zeros((4, 3))
    J[0, 0], J[1, 1], J[2, 2] = 1.5, 2.0, 0.5
    result = analyse(J, ["a", "b", "c"], [2.0, 1.0, 1.0])
    np.testing.assert_allclose(result.singular_values, [3.0, 2.0, 0.5])
    expected = {
        "O1": (3.0 * 2.0 * 0.5) ** (1 / 3) / 2.0,
        "O2": 0.5 / 3.0,
        "O3": 0.5,
        "O4": 0.25 / 3.0,
        "O5": 1.0 / (1 / 3 + 1 / 2 + 2),
    }
    assert result.observability.keys() == expected.keys()
    for key, value in expected.items():
        assert result.observability[key] == pytest.approx(value, rel=1e-12), key
    assert result.condition_number == pytest.approx(6.0)


def test_rank_zero() -> None:
    result = analyse(np.zeros((5, 2)), ["a", "b"], [1.0, 1.0])
    assert result.rank == 0 and result.base_indices == [] and result.condition_number == np.inf
    assert all(value == 0.0 for value in result.observability.values())
    assert [c.description for c in result.unidentifiable] == [
        "a is invisible to the data (no measurement depends on it)",
        "b is invisible to the data (no measurement depends on it)",
    ]


def test_summary_names_rank_and_combinations() -> None:
    J = _random(20, 3, seed=12)
    J[:, 2] = 0.0
    text = analyse(J, ["arm.tx", "arm.ty", "base.tz"], [1e-3] * 3).summary()
    assert "rank 2 of 3 parameters" in text
    assert "base parameters (2): arm.tx, arm.ty" in text
    assert "base.tz is invisible to the data" in text
    assert "O1" in text and "condition number" in text


def test_covariance_matches_linear_least_squares_monte_carlo() -> None:
    """y = A x + e, e ~ N(0, σ²): the spread of the least-squares estimate is σ²(AᵀA)⁻¹."""
    rng = np.random.default_rng(13)
    sigma = 2e-4  # [m]
    A = rng.normal(size=(30, 3)) * np.array([1.0, 0.1, 10.0])  # [m/m], [m/rad], ...
    x_true = np.array([1e-3, -2e-3, 5e-4])
    noise = rng.normal(scale=sigma, size=(30, 20000))
    estimates = np.linalg.pinv(A) @ (A @ x_true[:, None] + noise)
    empirical = np.cov(estimates)
    analytic = sigma**2 * np.linalg.inv(A.T @ A)
    weighted = covariance(A / sigma, 1.0)  # rows weighted by 1/σ, variance factor 1
    np.testing.assert_allclose(weighted, analytic, rtol=1e-10)
    np.testing.assert_allclose(covariance(A, sigma**2), analytic, rtol=1e-10)
    assert np.linalg.norm(empirical - analytic) < 0.05 * np.linalg.norm(analytic)
    np.testing.assert_allclose(correlations(weighted), correlations(empirical), atol=0.03)


def test_covariance_on_chosen_columns_and_singular_culprit() -> None:
    J = _random(25, 4, seed=14)
    J[:, 3] = 2.0 * J[:, 1]
    names = ["a", "b", "c", "d"]
    chosen = analyse(J, names, np.ones(4)).base_indices
    sub = J[:, chosen]
    np.testing.assert_allclose(covariance(J, 0.5, chosen), 0.5 * np.linalg.inv(sub.T @ sub), rtol=1e-10)
    with pytest.raises(IdentifiabilityError, match=r"singular.*rank 3 of 4") as error:
        covariance(J, 1.0, names=names)
    message = str(error.value)  # b and d tie once equilibrated: either may be called the dependent one
    assert "only b (column 1) + 2.000 d (column 3) is seen" in message or "only d (column 3) + 0.500 b" in message
    J[:, 3] = 0.0
    with pytest.raises(IdentifiabilityError, match=r"d \(column 3\) is invisible"):
        covariance(J, 1.0, names=names)


def test_correlations_of_a_known_covariance() -> None:
    cov = np.array([[4.0, 1.0, 0.0], [1.0, 1.0, -0.5], [0.0, -0.5, 1.0]])
    expected = np.array([[1.0, 0.5, 0.0], [0.5, 1.0, -0.5], [0.0, -0.5, 1.0]])
    np.testing.assert_allclose(correlations(cov), expected)


GOOD_J = np.eye(3)


@pytest.mark.parametrize(
    ("jacobian", "names", "scales", "tol", "message"),
    [
        (np.ones(3), ["a", "b", "c"], [1, 1, 1], None, r"m × p matrix; got shape \(3,\)"),
        (np.zeros((0, 3)), ["a", "b", "c"], [1, 1, 1], None, r"non-empty"),
        (np.diag([1.0, np.nan, 1.0]), ["a", "b", "c"], [1, 1, 1], None, r"NaN/inf .* row 1, column 1"),
        (np.diag([1.0, 1.0, np.inf]), ["a", "b", "c"], [1, 1, 1], None, r"NaN/inf .* row 2, column 2"),
        (GOOD_J, ["a", "b"], [1, 1, 1], None, r"2 parameter names for a Jacobian with 3 columns"),
        (GOOD_J, ["a", "b", "a"], [1, 1, 1], None, r"unique; repeated: a"),
        (GOOD_J, ["a", "b", "c"], [1, 1], None, r"scales has shape \(2,\); expected \(3,\)"),
        (GOOD_J, ["a", "b", "c"], [1, 0, 1], None, r"finite and positive.*bad: b \(0.0\)"),
        (GOOD_J, ["a", "b", "c"], [1, 1, -1e-3], None, r"bad: c \(-0.001\)"),
        (GOOD_J, ["a", "b", "c"], [1, np.nan, 1], None, r"bad: b \(nan\)"),
        (GOOD_J, ["a", "b", "c"], [1, 1, 1], 0.0, r"rank tolerance must lie in \(0, 1\)"),
        (GOOD_J, ["a", "b", "c"], [1, 1, 1], 2.0, r"rank tolerance must lie in \(0, 1\)"),
    ],
)
def test_bad_inputs_raise_data_error(jacobian, names, scales, tol, message) -> None:
    with pytest.raises(DataError, match=message):
        analyse(jacobian, names, scales, tol)
    with pytest.raises(DataError, match=message):
        base_parameters(jacobian, names, scales, tol)


@pytest.mark.parametrize(
    ("call", "message"),
    [
        (lambda: covariance(GOOD_J, -1.0), r"sigma2 must be .* >= 0; got -1.0"),
        (lambda: covariance(GOOD_J, 1.0, [0, 3]), r"indices \[3\] are outside 0..2"),
        (lambda: covariance(GOOD_J, 1.0, [1, 1]), r"column indices repeat"),
        (lambda: covariance(GOOD_J, 1.0, []), r"no columns chosen"),
        (lambda: covariance(GOOD_J, 1.0, names=["a"]), r"1 parameter names for a Jacobian with 3 columns"),
        (lambda: covariance(np.full((2, 2), np.nan), 1.0), r"NaN/inf"),
        (lambda: correlations(np.ones((2, 3))), r"square matrix; got shape \(2, 3\)"),
        (lambda: correlations(np.diag([1.0, 0.0])), r"diagonal entries \[1\]"),
    ],
)
def test_bad_covariance_inputs_raise_data_error(call, message) -> None:
    with pytest.raises(DataError, match=message):
        call()
