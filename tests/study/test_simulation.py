"""Random postures: drawn within the URDF joint limits by default, within ±spread of the reference when asked."""

from __future__ import annotations

import math
from pathlib import Path

import numpy as np
import pytest
from conftest import run_pincal
from mechanisms import crank_rocker_urdf, four_bar_urdf

import pincal
from pincal.io.dataset_reader import read_dataset
from pincal.study.simulation import SPREAD, actuated_ranges, random_actuated

#: URDF limits [rad] of the crank in the tests below: narrow, and not centred on the reference (0).
NARROW = (-0.3, 0.8)


@pytest.fixture
def narrow_crank(tmp_path: Path) -> Path:
    path = tmp_path / "crank_rocker.urdf"
    path.write_text(crank_rocker_urdf(NARROW))
    return path


def test_by_default_postures_cover_the_urdf_limits(narrow_crank: Path) -> None:
    robot = pincal.load_robot(narrow_crank)
    np.testing.assert_array_equal(np.column_stack(actuated_ranges(robot)), [NARROW])
    qa, q = random_actuated(robot, 200, np.random.default_rng(0))
    assert NARROW[0] <= qa.min() and qa.max() <= NARROW[1]
    assert qa.min() < NARROW[0] + 0.05 and qa.max() > NARROW[1] - 0.05  # uniform over all of it
    assert np.abs(robot.closure_residual(q[-1])).max() < 1e-9


def test_a_spread_is_about_the_reference_and_within_the_limits(narrow_crank: Path) -> None:
    robot = pincal.load_robot(narrow_crank)
    np.testing.assert_allclose(np.column_stack(actuated_ranges(robot, 0.1)), [[-0.1, 0.1]])
    np.testing.assert_allclose(np.column_stack(actuated_ranges(robot, 0.5)), [[-0.3, 0.5]])  # clipped below
    qa, _ = random_actuated(robot, 50, np.random.default_rng(0), spread=0.1)
    assert np.abs(qa).max() <= 0.1


def test_a_spread_that_leaves_no_room_within_the_limits_is_refused(tmp_path: Path) -> None:
    path = tmp_path / "offset.urdf"
    path.write_text(crank_rocker_urdf((0.2, 0.8)))  # the reference (0) lies outside the limits
    robot = pincal.load_robot(path)
    with pytest.raises(pincal.DataError, match=r"spread ±0.1 about the reference \(0\) of actuated joint "
                                               r"'crank_joint' leaves no value within its URDF limits \[0.2, 0.8\]"):
        actuated_ranges(robot, 0.1)
    with pytest.raises(pincal.DataError, match="must be a finite number ≥ 0"):
        actuated_ranges(robot, -1.0)


@pytest.mark.parametrize("name", sorted(SPREAD))
def test_robots_whose_limits_are_not_their_workspace_keep_their_spread(name: str) -> None:
    robot = pincal.load_robot(name)
    lower, upper = actuated_ranges(robot)
    np.testing.assert_allclose(upper, SPREAD[name])
    np.testing.assert_allclose(lower, -SPREAD[name])


@pytest.mark.parametrize(("name", "lower", "upper"), [("delta", -1.2, 1.6), ("ur10", -2 * math.pi, 2 * math.pi)])
def test_other_robots_are_drawn_within_their_limits(name: str, lower: float, upper: float) -> None:
    robot = pincal.load_robot(name)
    lo, hi = actuated_ranges(robot)
    assert lo[0] == pytest.approx(lower) and hi[0] == pytest.approx(upper)
    model = robot.model
    np.testing.assert_array_equal(lo, [model.lowerPositionLimit[a.idx_q] for a in robot.kinematics.actuated])
    np.testing.assert_array_equal(hi, [model.upperPositionLimit[a.idx_q] for a in robot.kinematics.actuated])


SPINNER = ('<robot name="spinner"><link name="base"/><link name="wheel"/><joint name="spin" type="continuous">'
           '<parent link="base"/><child link="wheel"/><origin xyz="0 0 0.1"/><axis xyz="0 0 1"/></joint></robot>')


@pytest.mark.parametrize(("text", "half"), [(four_bar_urdf(crank="continuous"), 0.5), (SPINNER, math.pi)],
                         ids=["closed loop", "serial"])
def test_a_joint_without_limits_keeps_the_former_half_range(tmp_path: Path, text: str, half: float) -> None:
    path = tmp_path / "continuous.urdf"
    path.write_text(text)
    robot = pincal.load_robot(path)
    reference = robot.actuated_values(robot.q_reference)
    np.testing.assert_allclose(np.column_stack(actuated_ranges(robot)), np.column_stack([reference - half,
                                                                                         reference + half]))


def test_simulate_draws_within_the_limits_and_spread_narrows_it(narrow_crank: Path, tmp_path: Path) -> None:
    readings = {}
    for label, extra in (("limits", []), ("spread", ["--spread", "0.1"])):
        out = tmp_path / label
        done = run_pincal("simulate", str(narrow_crank), "--samples", "40", "--test-samples", "20", "--seed", "3",
                          "--noise", "0", "--quiet", "--out", str(out), *extra)
        assert done.returncode == 0, done.stderr
        readings[label] = read_dataset(out / "measurements.csv", ["crank_joint"]).joints[:, 0]
    assert NARROW[0] <= readings["limits"].min() < -0.2 and 0.7 < readings["limits"].max() <= NARROW[1]
    assert np.abs(readings["spread"]).max() <= 0.1


def test_the_spread_option_says_its_units_and_refuses_nonsense(narrow_crank: Path, tmp_path: Path) -> None:
    done = run_pincal("simulate", "--help")
    assert "--spread S" in done.stdout and "[rad for revolute, m for prismatic joints]" in " ".join(done.stdout.split())
    done = run_pincal("simulate", str(narrow_crank), "--spread", "-1", "--out", str(tmp_path / "x"))
    assert done.returncode == 2 and "--spread: -1 is not a finite number > 0" in done.stderr


@pytest.mark.parametrize("name", ["delta", "hexapod", "ur10"])
def test_postures_judged_at_once_leave_the_generator_as_one_by_one(name: str) -> None:
    """Draws are judged many at once, but the generator moves only past the draws used: thirty postures drawn at once
    are ten, ten and ten drawn in turn, and the generator's next number is the same after both."""
    robot = pincal.load_robot(name)
    together, apart = np.random.default_rng(11), np.random.default_rng(11)
    qa, q = random_actuated(robot, 30, together)
    parts = [random_actuated(robot, 10, apart) for _ in range(3)]
    assert np.array_equal(qa, np.vstack([p[0] for p in parts]))
    assert np.allclose(q, np.vstack([p[1] for p in parts]), atol=1e-9)
    assert together.uniform() == apart.uniform()
