"""ISO 9283 figures: the standard's formulas on a small example computed by hand, the orientation deviations against
Pinocchio's log3, and simulated runs of known bias and Gaussian repeatability recovered."""

from __future__ import annotations

import math

import numpy as np
import pinocchio as pin
import pytest

from pincal.calibration.iso9283 import evaluate_runs, rotation_deviations
from pincal.errors import DataError
from pincal.io.iso_runs import Runs


def _runs(poses: list[str], cycles: list[int], commanded: list[list[float]], attained: list[list[float]],
          directions: list[str] | None = None, quaternions: tuple[list[list[float]], list[list[float]]] | None = None
          ) -> Runs:
    n = len(poses)
    return Runs(poses, np.array(cycles), directions or [""] * n, np.array(commanded, dtype=float),
                np.array(attained, dtype=float),
                None if quaternions is None else np.array(quaternions[0], dtype=float),
                None if quaternions is None else np.array(quaternions[1], dtype=float), np.arange(2, n + 2))


def _about_z(angle: float) -> list[float]:
    return [math.cos(angle / 2), 0.0, 0.0, math.sin(angle / 2)]


def test_the_standards_formulas_on_an_example_computed_by_hand() -> None:
    """P1 commanded at 0, attained at x = 3, 1, 2 mm: x̄ = 2 mm so AP = 2 mm; l = 1, 1, 0 mm, l̄ = 2/3 mm,
    S_l = √(((1/3)² + (1/3)² + (2/3)²) / 2) = √(1/3) mm, RP = 2/3 + 3 √(1/3) = 2/3 + √3 mm. P2 commanded at x = 100 mm,
    attained at 101, 100, 102 mm: D = 98, 99, 100 mm, D̄ = 99, AD = −1 mm, RD = 3 × 1 mm. P1 turned about z by 2, 4,
    6 mrad: AP_c = 4 mrad, RP_c = 3 × 2 mrad."""
    mm = 1e-3
    runs = _runs(["P1", "P2"] * 3, [0, 0, 1, 1, 2, 2],
                 [[0, 0, 0], [100 * mm, 0, 0]] * 3,
                 [[3 * mm, 0, 0], [101 * mm, 0, 0], [1 * mm, 0, 0], [100 * mm, 0, 0], [2 * mm, 0, 0], [102 * mm, 0, 0]],
                 quaternions=([_about_z(0.0)] * 6,
                              [_about_z(0.002), _about_z(0.0), _about_z(0.004), _about_z(0.0), _about_z(0.006),
                               _about_z(0.0)]))
    figures = evaluate_runs(runs)
    p1 = figures.poses[0]
    assert p1.ap == pytest.approx(2 * mm, abs=1e-15) and p1.ap_xyz == pytest.approx([2 * mm, 0, 0], abs=1e-15)
    assert p1.l_mean == pytest.approx(2 / 3 * mm, abs=1e-15) and p1.s_l == pytest.approx(math.sqrt(1 / 3) * mm)
    assert p1.rp == pytest.approx((2 / 3 + math.sqrt(3)) * mm, rel=1e-12)
    assert p1.ap_abc == pytest.approx([0, 0, 0.004], abs=1e-12) and p1.rp_abc == pytest.approx([0, 0, 0.006], abs=1e-12)
    (distance,) = figures.distances
    assert distance.poses == ["P1", "P2"] and distance.cycles == 3
    assert distance.commanded == pytest.approx(100 * mm) and distance.mean == pytest.approx(99 * mm)
    assert distance.ad == pytest.approx(-1 * mm, abs=1e-12) and distance.ad_xyz == pytest.approx([-1 * mm, 0, 0])
    assert distance.rd == pytest.approx(3 * mm, rel=1e-9)


def test_the_multi_directional_variation_is_the_largest_distance_between_the_directions_barycentres() -> None:
    """P1 from +x at 1 mm (twice), from −x at −1 mm, from +y at y = 1 mm: barycentres 2 mm and √2 mm apart:
    vAP = 2 mm."""
    mm = 1e-3
    series = _runs(["P1", "P1"], [0, 1], [[0, 0, 0]] * 2, [[0, 0, 0], [0, 0, 0]])
    runs = Runs([*series.poses, "P1", "P1", "P1", "P1", "P1", "P1"], np.array([0, 1, 0, 1, 0, 1, 0, 1]),
                ["", "", "+x", "+x", "-x", "-x", "+y", "+y"], np.zeros((8, 3)),
                np.array([[0, 0, 0], [0, 0, 0], [mm, 0, 0], [mm, 0, 0], [-mm, 0, 0], [-mm, 0, 0], [0, mm, 0],
                          [0, mm, 0]]), None, None, np.arange(8))
    (variation,) = evaluate_runs(runs).variations
    assert variation.vap == pytest.approx(2 * mm) and variation.directions == {"+x": 2, "-x": 2, "+y": 2}


def test_orientation_deviations_are_the_rotation_vector_of_attained_times_commanded_transposed() -> None:
    rng = np.random.default_rng(3)
    commanded = [pin.Quaternion(pin.exp3(rng.normal(size=3))) for _ in range(5)]
    attained = [pin.Quaternion(pin.exp3(rng.normal(scale=0.3, size=3)) @ c.matrix()) for c in commanded]
    wxyz = [np.array([[q.w, q.x, q.y, q.z] for q in qs]) for qs in (commanded, attained)]
    expected = [pin.log3(a.matrix() @ c.matrix().T) for c, a in zip(commanded, attained, strict=True)]
    assert rotation_deviations(*wxyz) == pytest.approx(np.array(expected), abs=1e-9)


@pytest.mark.parametrize("seed", [0, 1])
def test_simulated_runs_of_known_bias_and_repeatability_are_recovered_within_5_percent(seed: int) -> None:
    """Attained = commanded + bias + N(0, σ² I): AP = |bias|; RP = E[l] + 3 sd(l) = σ (2√(2/π) + 3 √(3 − 8/π)) (the
    distance from the mean of a 3-D isotropic Gaussian follows Maxwell's law); 2000 cycles per pose."""
    rng = np.random.default_rng(seed)
    cycles, sigma = 2000, np.array([5e-6, 2e-5, 4e-5, 1e-5, 3e-5])
    bias = rng.normal(scale=1e-4, size=(5, 3))
    commanded = rng.uniform(-0.5, 0.5, size=(5, 3))
    poses = [f"P{k + 1}" for k in range(5)]
    attained = commanded[None] + bias[None] + rng.normal(size=(cycles, 5, 3)) * sigma[None, :, None]
    runs = _runs(poses * cycles, np.repeat(np.arange(cycles), 5).tolist(), np.tile(commanded, (cycles, 1)).tolist(),
                 attained.reshape(-1, 3).tolist())
    figures = evaluate_runs(runs)
    expected_rp = sigma * (2 * math.sqrt(2 / math.pi) + 3 * math.sqrt(3 - 8 / math.pi))
    for k, pose in enumerate(figures.poses):
        assert abs(pose.ap / np.linalg.norm(bias[k]) - 1) < 0.05
        assert abs(pose.rp / expected_rp[k] - 1) < 0.05


def test_a_pose_of_one_cycle_and_a_pose_commanded_differently_are_refused() -> None:
    with pytest.raises(DataError, match="pose P2 has 1 cycle; RP needs at least 2"):
        evaluate_runs(_runs(["P1", "P1", "P2"], [0, 1, 0], [[0, 0, 0]] * 3, [[0, 0, 0]] * 3))
    with pytest.raises(DataError, match="pose P1: its commanded position") as caught:
        evaluate_runs(_runs(["P1", "P1"], [0, 1], [[0, 0, 0], [1e-3, 0, 0]], [[0, 0, 0]] * 2))
    assert caught.value.line == 3


def test_a_half_turn_is_a_deviation_of_pi_not_zero() -> None:
    """Near a half turn the matrix's skew part vanishes: the deviation is taken from the quaternion instead."""
    identity, half_turn_z = np.array([[1.0, 0.0, 0.0, 0.0]]), np.array([[0.0, 0.0, 0.0, 1.0]])
    assert np.allclose(rotation_deviations(identity, half_turn_z), [[0.0, 0.0, np.pi]], atol=1e-12)
    quarter_x = np.array([[math.cos(math.pi / 4), math.sin(math.pi / 4), 0.0, 0.0]])
    assert np.allclose(rotation_deviations(identity, -quarter_x), [[math.pi / 2, 0.0, 0.0]], atol=1e-12)  # q, -q
