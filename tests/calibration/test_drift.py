"""The drift test's parts: parameter groups, the forward selection on a linear model of known truth, the
recalibration command, the level's range."""

from __future__ import annotations

import numpy as np
import pytest

from pincal.calibration.drift import (
    _fit,
    _named_groups,
    check_level,
    group_of,
    recalibration_command,
    shift_text,
    statistic_text,
)
from pincal.errors import DataError


def test_a_joints_offset_is_a_group_of_its_own_and_its_placement_another() -> None:
    assert group_of("arm_1_joint.offset") == "arm_1_joint.offset"
    assert group_of("arm_1_joint.tx") == "arm_1_joint" and group_of("leg_1_platform.predecessor.tz") == \
        "leg_1_platform.predecessor"


def test_least_squares_gives_the_residual_sum_and_unit_sigmas() -> None:
    design = np.array([[1.0, 0.0], [0.0, 2.0], [0.0, 0.0]])
    total, rank, estimate, std = _fit(design, np.array([3.0, 4.0, 5.0]))
    assert total == pytest.approx(25.0) and rank == 2
    assert estimate == pytest.approx([3.0, 2.0]) and std == pytest.approx([1.0, 0.5])


def test_forward_selection_names_the_group_that_moved_and_no_other() -> None:
    """y = G_b · 0.5 + unit noise over 200 rows and four groups of random columns; one setup column absorbs an
    offset. Only group b is named, its shift (the opposite of the fitted estimate) within 4 σ of −0.5."""
    rng = np.random.default_rng(5)
    m = 200
    names = ["base.tx", "a.tx", "a.ty", "b.offset", "c.tx", "c.ty", "c.tz"]
    whitened = rng.normal(size=(m, len(names)))
    y = 3.0 * whitened[:, 0] + 0.5 * whitened[:, 3] + rng.normal(size=m)
    statistic, rank, _, _ = _fit(whitened[:, [0]], y)
    (moved,) = _named_groups(names, [0], whitened, y, statistic, rank, 0.01)
    assert moved.group == "b.offset" and moved.parameters == ["b.offset"] and moved.dof == 1
    assert abs(moved.shifts[0] + 0.5) < 4 * moved.std[0]


def test_the_recalibration_command_names_the_groups_and_the_setups_kinds() -> None:
    command = recalibration_command("cal.urdf", "s4.csv", ["arm_2_joint.offset"],
                                    ["base.tx", "base.ry", "marker.end_effector.x"])
    assert command == ("pincal calibrate cal.urdf s4.csv --parameters arm_2_joint.offset 'base.*' 'marker.*' --out "
                       "cal_recalibrated.urdf")


@pytest.mark.parametrize("level", [0.0, 0.5, -0.1])
def test_a_level_outside_0_to_half_is_refused(level: float) -> None:
    with pytest.raises(DataError, match=r"must lie between 0 and 0\.5"):
        check_level(level)


def test_the_statistic_is_printed_to_four_significant_digits() -> None:
    """T as `pincal drift` and its page print it: one decimal below 1000, two significant digits above (a changed
    session's T of thousands varies in its third digit with the BLAS build: 5164 on one kernel, 5168.2 on another);
    a shift and its σ to the micrometre or microradian."""
    assert [statistic_text(t) for t in (95.24, 102.0, 999.94, 5164.0, 5168.2, 51675.0, float("inf"))] == \
        ["95.2", "102.0", "999.9", "5200", "5200", "52000", "inf"]
    assert shift_text(0.0019957, 0.000028) == "+1.996 ± 0.028" and shift_text(-0.0019954, 0.0000281) == "-1.995 ± 0.028"
