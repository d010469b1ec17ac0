"""Identifiability analysis: rank, base parameters and their named combinations, covariance, indices."""

from __future__ import annotations

import numpy as np
import pytest
from null_directions import assert_null, random_matrix

from pincal.errors import DataError, IdentifiabilityError
from pincal.identification.combinations import LINE_WIDTH, Combination
from pincal.identification.identifiability import (
    RANK_TOLERANCE,
    analyse,
    base_parameters,
    correlations,
    covariance,
)

NAMES6 = ["a.tx", "a.ty", "a.rz", "b.offset", "base.tz", "device.psi"]




def _null_matrix(names: list[str], combinations: list[Combination]) -> np.ndarray:
    """The combinations' null directions as columns of a p × k matrix."""
    N = np.zeros((len(names), len(combinations)))
    for k, combination in enumerate(combinations):
        N[[names.index(name) for name in combination.names], k] = combination.null_direction
    return N


def test_full_rank_random_jacobian() -> None:
    J = random_matrix(60, 6, seed=1)
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
    J = random_matrix(40, 3, seed=2)
    J = np.column_stack([J[:, 0], J[:, 1], 2.0 * J[:, 1], J[:, 2]])
    names = ["a", "b", "d", "e"]
    result = analyse(J, names, [1e-3, scale_b, scale_d, 1e-3])
    assert result.rank == 3
    assert base in result.base_names and dependent not in result.base_names
    (combination,) = result.unidentifiable
    assert combination.names == [dependent, base]
    np.testing.assert_allclose(combination.coefficients, [1.0, coefficient], rtol=1e-10)
    # J[:, dependent] = k J[:, base]: the data sees J[:, base] (x_base + k x_dependent)
    assert combination.description == (f"{dependent} acts as {coefficient:g} × {base}: "
                                       f"only {base} + {coefficient:g} × {dependent} is seen")
    assert_null(J, names, combination)


def test_zero_column_is_invisible() -> None:
    J = random_matrix(30, 4, seed=3)
    J[:, 2] = 0.0
    names = ["arm.tx", "arm.ty", "base.tz", "arm.rz"]
    result = analyse(J, names, np.full(4, 1e-3))
    assert result.rank == 3 and result.base_names == ["arm.tx", "arm.ty", "arm.rz"]
    (combination,) = result.unidentifiable
    assert combination.names == ["base.tz"]
    assert combination.description == "base.tz has no effect on the measurements"
    np.testing.assert_array_equal(combination.coefficients, [1.0])


def test_column_sum_of_two_others() -> None:
    """J[:, c] = J[:, a] + J[:, b]: c is tied to both, with coefficients 1 and 1; moving c by +1 and a and b
    by -1 each changes nothing."""
    J = random_matrix(50, 4, seed=4)
    J[:, 3] = J[:, 0] + J[:, 1]
    names = ["a", "b", "x", "c"]
    result = analyse(J, names, [1e-3, 1e-3, 1e-3, 1e-4])  # c's small scale makes it the dependent one
    assert result.rank == 3 and result.base_names == ["a", "b", "x"]
    (combination,) = result.unidentifiable
    assert combination.names == ["c", "a", "b"]
    np.testing.assert_allclose(combination.coefficients, [1.0, 1.0, 1.0], rtol=1e-10)
    assert combination.description == "moving c by +1, a by -1 and b by -1 changes no measurement"
    assert_null(J, names, combination)


def test_combinations_sorted_and_each_a_null_direction() -> None:
    """Rank r = 3 of p = 7 with mixed units: four combinations, fewest parameters first, then by name, each
    invisible to J and together spanning its null space."""
    rng = np.random.default_rng(5)
    scales = np.array([1e-3, 1e-3, 1e-2, 1e-3, 1e-1, 1e-3, 1e-3])
    J = (rng.normal(size=(40, 3)) @ rng.normal(size=(3, 7))) / scales
    names = ["g", "f", "e", "d", "c", "b", "a"]
    result = analyse(J, names, scales)
    assert result.rank == 3 and len(result.unidentifiable) == 4
    keys = [(len(c.names), c.names) for c in result.unidentifiable]
    assert keys == sorted(keys)
    for combination in result.unidentifiable:
        assert_null(J, names, combination)
    assert np.linalg.matrix_rank(_null_matrix(names, result.unidentifiable)) == 4


def test_condition_number_is_over_the_identifiable_set() -> None:
    J = random_matrix(30, 4, seed=6)
    J[:, 3] = 3.0 * J[:, 0]
    scales = np.array([1e-3, 2e-3, 1e-3, 1e-3])
    result = analyse(J, ["a", "b", "c", "d"], scales)
    kept = (J * scales)[:, result.base_indices]
    np.testing.assert_allclose(result.condition_number, np.linalg.cond(kept), rtol=1e-12)
    assert np.isfinite(result.condition_number)


def test_scaling_makes_mixed_units_comparable() -> None:
    """Columns 1e6 apart only because of units are full rank and well conditioned once scaled."""
    J0 = random_matrix(50, 4, seed=7)
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
    J = random_matrix(40, 3, seed=8)
    J[:, 2] = J[:, 0] - J[:, 1] + 1e-12 * random_matrix(40, 1, seed=9)[:, 0]
    assert analyse(J, ["a", "b", "c"], np.ones(3)).rank == 2
    assert analyse(J, ["a", "b", "c"], np.ones(3), tol=1e-15).rank == 3
    assert RANK_TOLERANCE == 1e-8


def test_fewer_rows_than_columns() -> None:
    J = random_matrix(3, 5, seed=10)
    names = ["a", "b", "c", "d", "e"]
    result = analyse(J, names, np.ones(5))
    assert result.rank == 3 and len(result.unidentifiable) == 2
    for combination in result.unidentifiable:
        assert_null(J, names, combination)


def test_base_parameters_agrees_with_analyse() -> None:
    J = random_matrix(30, 4, seed=11)
    J[:, 1] = -0.5 * J[:, 3]
    scales = [1e-3, 1e-3, 1e-3, 1e-3]
    indices, combinations = base_parameters(J, ["a", "b", "c", "d"], scales)
    result = analyse(J, ["a", "b", "c", "d"], scales)
    assert indices == result.base_indices == [0, 2, 3]
    assert [c.description for c in combinations] == [c.description for c in result.unidentifiable]
    # J[:, b] = -0.5 J[:, d]: the data sees J[:, d] (x_d - 0.5 x_b)
    assert combinations[0].description == "b acts as -0.5 × d: only d - 0.5 × b is seen"


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
        "a has no effect on the measurements",
        "b has no effect on the measurements",
    ]


def test_summary_names_rank_and_combinations() -> None:
    J = random_matrix(20, 3, seed=12)
    J[:, 2] = 0.0
    text = analyse(J, ["arm.tx", "arm.ty", "base.tz"], [1e-3] * 3).summary()
    assert "rank 2 of 3 parameters" in text
    assert "base parameters (2): arm.tx, arm.ty" in text
    assert "base.tz has no effect on the measurements" in text
    assert "O1" in text and "condition number" in text


def _block_jacobian(names: list[str], ties: dict[str, tuple[str, float]], invisible: list[str],
                    scales: np.ndarray, seed: int) -> np.ndarray:
    """A Jacobian whose free columns are random (per unit of each parameter: 1/scale) and whose tied column
    ``d`` is ``k`` times column ``b`` for ``ties[d] = (b, k)``; invisible columns are zero."""
    J = random_matrix(60, len(names), seed) / scales
    for dependent, (other, k) in ties.items():
        J[:, names.index(dependent)] = k * J[:, names.index(other)]
    for name in invisible:
        J[:, names.index(name)] = 0.0
    return J


def test_null_space_of_separate_groups_is_named_group_by_group() -> None:
    """Two redundant pairs and one invisible parameter among 20: the SVD's null basis mixes them, its
    sparse form names each group alone, in physical units, with the right count p - rank."""
    names = [f"link_{k}.{c}" for k in range(4) for c in ("tx", "ty", "tz", "rx", "ry")]
    scales = np.where([n.endswith(("tx", "ty", "tz")) for n in names], 1e-3, 2e-3)
    ties = {"link_3.tz": ("link_0.tz", 1.0), "link_1.rx": ("link_2.ty", -0.3)}
    J = _block_jacobian(names, ties, ["link_2.ry"], scales, seed=20)
    result = analyse(J, names, scales)
    assert result.rank == 17 and len(result.unidentifiable) == 20 - 17
    assert [set(c.names) for c in result.unidentifiable] == [{"link_2.ry"}, {"link_0.tz", "link_3.tz"},
                                                             {"link_1.rx", "link_2.ty"}]
    for combination in result.unidentifiable:
        assert len(combination.names) <= 2
        assert_null(J, names, combination)
    by_lead = {c.dependent: c for c in result.unidentifiable}
    # link_1.rx = -0.3 m/rad link_2.ty; scaled: 2e-3 x 1 against 1e-3 x 0.3, so link_1.rx moves most
    np.testing.assert_allclose(by_lead["link_1.rx"].coefficients, [1.0, -0.3], rtol=1e-10)
    assert by_lead["link_1.rx"].units == ["rad", "m"]
    # the base set is still the pivoted QR's: one of each pair and none of the invisible column
    assert len(result.base_names) == 17 and "link_2.ry" not in result.base_names
    assert len({"link_0.tz", "link_3.tz"} & set(result.base_names)) == 1


def test_a_larger_group_is_one_sparse_row_beside_the_pairs() -> None:
    """A column that is the sum of three others, beside a pair: the group of four stays apart from the pair."""
    names = [f"p{k}.tx" for k in range(12)]
    J = random_matrix(40, 12, seed=21)
    J[:, 9] = J[:, 1] - 2.0 * J[:, 4] + 0.5 * J[:, 6]
    J[:, 11] = 3.0 * J[:, 2]
    result = analyse(J, names, np.full(12, 1e-3))
    assert result.rank == 10
    assert [set(c.names) for c in result.unidentifiable] == [{"p2.tx", "p11.tx"},
                                                             {"p1.tx", "p4.tx", "p6.tx", "p9.tx"}]
    for combination in result.unidentifiable:
        assert_null(J, names, combination)
    group = result.unidentifiable[1]
    assert group.dependent == "p4.tx"  # it moves most along the direction, (-1, 2, -0.5, 1) over p1, p4, p6, p9
    direction = dict(zip(group.names, group.null_direction, strict=True))
    np.testing.assert_allclose([direction[n] for n in ("p1.tx", "p4.tx", "p6.tx", "p9.tx")], [-0.5, 1, -0.25, 0.5],
                               rtol=1e-10)
    # largest first, equal ones in column order
    # (said per millimetre: the steps of a direction, at the size of a geometric error)
    assert group.description == "moving p4.tx by +1 mm, p1.tx by -0.5 mm, p9.tx by +0.5 mm and p6.tx by -0.25 mm " \
                                "changes no measurement"


def test_summary_is_short_with_many_combinations() -> None:
    """30 dependent columns (20 pairs, 10 invisible) and 70 base parameters: a few header lines, at most ten
    listing lines (the invisible parameters share one), and how many more there are."""
    names = [f"arm_{k // 6}_link_joint.{('tx', 'ty', 'tz', 'rx', 'ry', 'rz')[k % 6]}" for k in range(100)]
    J = random_matrix(300, 100, seed=25)
    for k in range(20):
        J[:, 70 + k] = (k + 2.0) * J[:, k]
    J[:, 90:] = 0.0
    result = analyse(J, names, np.full(100, 1e-3))
    assert result.rank == 70 and len(result.unidentifiable) == 30
    lines = result.summary(limit=10).splitlines()
    assert len(lines) <= 4 + 2 + 1 + 10 + 1
    assert all(len(line) <= LINE_WIDTH for line in lines), max(lines, key=len)
    assert lines[-1] == "  … and 11 more (Identifiability.unidentifiable has them all)"  # 10 + 9 pairs shown
    assert "no effect on the measurements (10 parameters): " in result.summary()
    base_lines = lines[lines.index(next(line for line in lines if line.startswith("base parameters (70): "))):]
    assert base_lines[1].startswith("  ") and base_lines[1].endswith(" more)")  # two lines, then counted
    assert base_lines[2].startswith("not identifiable (30 ")


@pytest.mark.parametrize(("units", "message"), [
    (["m", "rad"], r"2 units for 3 parameters"),
    (["m", "deg", "rad"], r"units must be 'm', 'rad' or '' \(unknown\); bad: b \('deg'\)"),
])
def test_bad_units_raise_data_error(units: list[str], message: str) -> None:
    with pytest.raises(DataError, match=message):
        analyse(np.eye(3), ["a", "b", "c"], np.ones(3), units=units)
    with pytest.raises(DataError, match=message):
        base_parameters(np.eye(3), ["a", "b", "c"], np.ones(3), units=units)


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
    J = random_matrix(25, 4, seed=14)
    J[:, 3] = 2.0 * J[:, 1]
    names = ["a", "b", "c", "d"]
    chosen = analyse(J, names, np.ones(4)).base_indices
    sub = J[:, chosen]
    np.testing.assert_allclose(covariance(J, 0.5, chosen), 0.5 * np.linalg.inv(sub.T @ sub), rtol=1e-10)
    with pytest.raises(IdentifiabilityError, match=r"singular.*rank 3 of 4") as error:
        covariance(J, 1.0, names=names)
    # b and d tie once equilibrated: the first leads
    assert "b (column 1) acts as 0.5 × d (column 3): only d (column 3) + 0.5 × b (column 1) is seen" in str(error.value)
    J[:, 3] = 0.0
    with pytest.raises(IdentifiabilityError, match=r"d \(column 3\) is invisible"):
        covariance(J, 1.0, names=names)


def test_covariance_with_row_weights_is_that_of_the_weighted_rows() -> None:
    """``row_weights`` w: the covariance of diag(w) J (the robust fit's), on tall and short Jacobians alike."""
    for rows in (3, 9000):
        J = random_matrix(rows, 3, seed=15)
        w = np.random.default_rng(16).uniform(0.2, 1.0, rows)
        weighted = w[:, None] * J
        np.testing.assert_allclose(covariance(J, 2.0, [0, 2], row_weights=w),
                                   2.0 * np.linalg.inv(weighted[:, [0, 2]].T @ weighted[:, [0, 2]]), rtol=1e-10)
    with pytest.raises(DataError, match=r"row_weights has shape \(2,\); expected \(9000,\)"):
        covariance(J, 1.0, row_weights=[1.0, 2.0])


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


def test_the_unseen_combinations_do_not_follow_the_callers_arrays_after_the_analysis() -> None:
    """The combinations are worked out when first read, from copies: scales changed by the caller after the analysis
    leave them as they were at it."""
    rng = np.random.default_rng(4)
    jac = rng.normal(size=(40, 3))
    jac = np.column_stack([jac, jac[:, 0] + 2.0 * jac[:, 1]])  # d moves the rows as a + 2 b: one unseen direction
    names = ["a.tx", "b.tx", "c.tx", "d.tx"]
    scales = np.full(4, 1e-3)
    at_once = analyse(jac, names, scales).unidentifiable[0].description
    later = analyse(jac, names, scales)
    scales[0] = 5.0
    assert later.unidentifiable[0].description == at_once
