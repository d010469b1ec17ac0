"""What the data cannot see, in words: each unseen combination's description, the units it is said in, and the
listing of many."""

from __future__ import annotations

import numpy as np
import pytest
from null_directions import assert_null, random_matrix

from pincal.errors import DataError
from pincal.identification.combinations import LINE_WIDTH, describe_unidentifiable, unit_from_name
from pincal.identification.identifiability import analyse


@pytest.mark.parametrize(("k", "words"), [
    (1.0, "move the measurements the same way: only their sum is seen"),
    (-1.0, "move the measurements in opposite ways: only their difference is seen"),
])
def test_equal_or_opposite_columns_say_sum_or_difference(k: float, words: str) -> None:
    """J[:, b] = k J[:, a] with k = ±1: the data sees J_a (x_a + k x_b), the sum or the difference."""
    names = ["base.tz", "arm_1_joint.tz", "arm_1_joint.rx"]
    J = random_matrix(30, 3, seed=22)
    J[:, 0] = k * J[:, 1]
    (combination,) = analyse(J, names, np.full(3, 1e-3)).unidentifiable
    assert combination.names == ["base.tz", "arm_1_joint.tz"]  # equal in scaled size: column order
    assert combination.description == f"base.tz and arm_1_joint.tz {words}"
    seen = J @ np.array([1.0, k, 0.0])  # a change of the seen combination x_a + k x_b changes the data
    unseen = J @ np.array([1.0, -k, 0.0])
    assert np.linalg.norm(unseen) < 1e-12 * np.linalg.norm(seen)


def test_pairs_in_different_units_give_the_ratio_with_its_unit() -> None:
    """J[:, rx] = 0.45 J[:, tz]: moving rx by δ [rad] acts as moving tz by 0.45 δ [m]; the reverse reads in
    rad/m; equal columns in m and rad are not a sum; an offset has no unit unless one is given."""
    J = random_matrix(30, 4, seed=23)
    J[:, 0] = 0.45 * J[:, 1]
    J[:, 3] = 0.1 * J[:, 2]  # z.tz = 0.1 rad/m z.rx: the tz moves most
    names = ["u_1.rx", "u_2.tz", "z.rx", "z.tz"]
    by_lead = {c.dependent: c for c in analyse(J, names, np.full(4, 1e-3)).unidentifiable}
    assert by_lead["u_1.rx"].description == ("u_1.rx acts as 0.45 m/rad × u_2.tz: "
                                             "only u_2.tz + 0.45 m/rad × u_1.rx is seen")
    assert by_lead["z.tz"].description == "z.tz acts as 0.1 rad/m × z.rx: only z.rx + 0.1 rad/m × z.tz is seen"
    J[:, 3] = J[:, 2]
    by_lead = {c.dependent: c for c in analyse(J, names, np.full(4, 1e-3)).unidentifiable}
    assert by_lead["z.rx"].description.startswith("z.rx acts as 1 m/rad × z.tz:")  # equals: column order
    offsets = ["arm_1_joint.offset", "u_2.tz", "z.rx", "z.tz"]
    (unknown, _) = analyse(J, offsets, np.full(4, 1e-3)).unidentifiable
    assert unknown.description.startswith("arm_1_joint.offset acts as 0.45 × u_2.tz:")
    (known, _) = analyse(J, offsets, np.full(4, 1e-3), units=["rad", "m", "rad", "m"]).unidentifiable
    assert known.description.startswith("arm_1_joint.offset acts as 0.45 m/rad × u_2.tz:")
    assert known.units == ["rad", "m"]


def test_units_from_names() -> None:
    assert [unit_from_name(n) for n in ("a.tx", "leg_1_platform.predecessor.tz", "b.ry", "marker.tool0.y",
                                        "arm_7_joint.offset", "scale.zero", "x.y")] == \
        ["m", "m", "rad", "m", "", "", ""]


LONG = ["leg_1_platform.predecessor.tz", "arm_7_joint.offset", "marker.wrist_ft_tool_link.x",
        "leg_2_platform.successor.rx", "forearm_link_joint.ty", "leg_3_platform.predecessor.ry",
        "upper_arm_link_joint.rz", "marker.wrist_ft_tool_link.z", "leg_4_platform.successor.tx",
        "shoulder_lift_joint.offset", "leg_5_platform.predecessor.rz", "wrist_3_link_joint.tz"]


def test_descriptions_of_long_names_fit_a_line() -> None:
    """Four pairs, a group of four and a group of nine, with realistic long names: every description fits a
    listing line (after the bullet) with its units, the group of nine shows at most five terms and counts the
    rest."""
    names = [*LONG, *(f"leg_{k}_platform.predecessor.{c}" for k in range(6, 9) for c in ("tx", "ty", "rx", "ry"))]
    p = len(names)
    rng = np.random.default_rng(24)
    J = random_matrix(80, p, seed=24)
    J[:, 1] = 0.3 * J[:, 0]  # arm_7_joint.offset: no unit
    J[:, 3] = 0.3 * J[:, 4]  # leg_2_platform.successor.rx acts as 0.3 m/rad × forearm_link_joint.ty
    J[:, 8] = J[:, 6]  # the same column in m and in rad: not a sum
    J[:, 10] = 1.5 * J[:, 9]
    J[:, 2] = -J[:, 5] + 0.2 * J[:, 20] + 0.7 * J[:, 21]  # group of four
    J[:, 11] = J[:, 12:20] @ rng.uniform(0.5, 1.0, 8)  # group of nine
    result = analyse(J, names, np.full(p, 1e-3))
    assert [len(c.names) for c in result.unidentifiable] == [2, 2, 2, 2, 4, 9]
    for combination in result.unidentifiable:
        assert_null(J, names, combination)
        assert len(combination.description) <= LINE_WIDTH - 4, combination.description
    by_lead = {c.dependent: c.description for c in result.unidentifiable}
    assert by_lead["leg_2_platform.successor.rx"].startswith("leg_2_platform.successor.rx acts as 0.3 m/rad × ")
    assert by_lead["arm_7_joint.offset"] == "arm_7_joint.offset acts as 0.3 × leg_1_platform.predecessor.tz"
    assert by_lead["upper_arm_link_joint.rz"] == "upper_arm_link_joint.rz acts as 1 m/rad × leg_4_platform.successor.tx"
    nine = result.unidentifiable[-1]
    assert nine.description.endswith(" more)")
    shown = [name for name in nine.names if name in nine.description]
    assert 1 <= len(shown) <= 5 and nine.names[0] in shown
    assert f"(+{9 - len(shown)} more)" in nine.description
    lines = result.summary().splitlines()
    assert all(len(line) <= LINE_WIDTH for line in lines), max(lines, key=len)
    assert all(len(line) <= LINE_WIDTH for line in describe_unidentifiable(result.unidentifiable))


def test_describe_unidentifiable_limits_and_counts() -> None:
    J = random_matrix(30, 6, seed=26)
    J[:, 3] = 2.0 * J[:, 0]
    J[:, 4] = -J[:, 1]
    J[:, 5] = 0.0
    names = ["a.tx", "b.tx", "c.tx", "d.tx", "e.tx", "f.tx"]
    combinations = analyse(J, names, np.full(6, 1e-3)).unidentifiable
    assert describe_unidentifiable(combinations) == ["  - " + c.description for c in combinations]
    assert describe_unidentifiable(combinations, limit=1) == ["  - f.tx has no effect on the measurements",
                                                              "  … and 2 more"]
    assert describe_unidentifiable(combinations, limit=0) == ["  … and 3 more"]
    assert describe_unidentifiable([]) == []
    with pytest.raises(DataError, match="limit must be >= 0"):
        describe_unidentifiable(combinations, limit=-1)


def test_the_words_do_not_depend_on_which_basis_of_the_null_space_the_svd_returns() -> None:
    """A null space of dimension 3 on six parameters, two of its directions symmetric (equal sizes on two legs, as
    a hexapod's are): every rotation of its basis, as another BLAS may return it, is described in the same words."""
    from pincal.identification.combinations import sparse_combinations

    directions = np.array([[1.0, 0.879, 0.0, 0.0, 0.0, 0.0],
                           [0.0, 0.0, 1.0, -0.879, 0.0, 0.0],
                           [0.0, 0.0, 0.0, 0.0, 1.0, 1.0],
                           [1.0, 0.0, 1.0, 0.0, 0.5, 0.0]])[[0, 1, 3]]  # a fourth row mixes the groups
    basis = np.linalg.qr(directions.T)[0].T  # orthonormal rows spanning the same space
    names = ["leg_1.tz", "leg_2.tz", "leg_3.tz", "leg_4.tz", "leg_5.ty", "leg_6.ty"]
    scales, units = np.full(6, 1e-3), ["m"] * 6
    expected = [(c.names, c.description) for c in sparse_combinations(basis, names, scales, units)]
    rng = np.random.default_rng(4)
    for _ in range(20):
        rotation = np.linalg.qr(rng.standard_normal((3, 3)))[0]
        again = sparse_combinations(rotation @ basis, names, scales, units)
        assert [(c.names, c.description) for c in again] == expected
    for combination in sparse_combinations(basis, names, scales, units):  # each is a direction of the space
        step = np.zeros(6)
        step[[names.index(n) for n in combination.names]] = combination.null_direction
        assert np.linalg.norm(step - basis.T @ (basis @ step)) < 1e-12 * np.linalg.norm(step)
