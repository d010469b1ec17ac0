"""What the identification methods share: the steps of each method from one reduced Jacobian, and the exact-fit
floors."""

from __future__ import annotations

import numpy as np
import pytest

from pincal.identification import measurements as ms
from pincal.identification.ridge import Ridge
from pincal.identification.steps import FLOOR_SIGMA_FRACTION, StepOptions, Steps, at_floor, exact_fit_floors
from pincal.identification.tsvd import TruncatedSVD


def _problem(m: int, n: int, rank: int, seed: int) -> tuple[np.ndarray, np.ndarray, np.ndarray, np.ndarray]:
    rng = np.random.default_rng(seed)
    jacobian = rng.normal(size=(m, rank)) @ rng.normal(size=(rank, n)) * np.logspace(0, -3, n)
    return jacobian, rng.uniform(0.5, 2.0, n), rng.uniform(0.2, 1.0, m), rng.normal(size=m)


def test_tsvd_steps_are_the_undamped_truncated_gauss_newton_step() -> None:
    """TSVD keeps the singular values above tsvd_rcond · s₁ and does not damp them, whatever λ."""
    jacobian, scales, weights, residual = _problem(60, 10, 6, 1)
    js, r = jacobian * scales * weights[:, None], weights * residual
    u, s, vt = np.linalg.svd(js, full_matrices=False)
    keep = s > 1e-8 * s[0]
    steps = Steps(jacobian, scales, weights, residual, TruncatedSVD.configured(StepOptions(tsvd_rcond=1e-8)))
    assert steps.kept == int(keep.sum()) == 6
    expected = -(vt[keep].T @ ((u[:, keep].T @ r) / s[keep]))
    for lam in (0.0, 1e-3, 10.0):
        np.testing.assert_allclose(steps.solve(lam), expected, rtol=1e-9, atol=1e-12)


def test_ridge_steps_keep_every_direction_damped_by_the_ridge_parameter() -> None:
    """Ridge solves (J_sᵀJ_s + μI) δz = -J_sᵀ r over every parameter, whatever λ."""
    jacobian, scales, weights, residual = _problem(60, 10, 10, 2)
    js, r = jacobian * scales * weights[:, None], weights * residual
    steps = Steps(jacobian, scales, weights, residual, Ridge.configured(StepOptions(ridge=1e-4)))
    assert steps.kept == 10
    expected = np.linalg.solve(js.T @ js + 1e-4 * np.eye(10), -js.T @ r)
    for lam in (0.0, 10.0):
        np.testing.assert_allclose(steps.solve(lam), expected, rtol=1e-8, atol=1e-12)


class _Stated:
    """A stand-in problem carrying only the measurement models (their stated σ)."""

    def __init__(self, models: list) -> None:
        self.measurements = models


@pytest.mark.parametrize(("sigma", "error", "exact"), [
    (1e-9, 1.5e-9, True),  # a 1.5 nm fit of noise-free data stated at σ = 1 nm: the FK floor (1e-8) holds it
    (1e-9, 5e-8, False),  # 50 nm is above both floors
    (1e-5, 5e-7, True),  # below a tenth of the stated σ: no such instrument could tell it from zero
    (1e-5, 5e-6, False),
])
def test_exact_fit_floor_follows_the_stated_sigma_and_the_fk_tolerance(sigma: float, error: float,
                                                                        exact: bool) -> None:
    problem = _Stated([ms.position("tool0", sigma), ms.pose("flange", sigma, 10 * sigma)])
    floors = exact_fit_floors(problem, FLOOR_SIGMA_FRACTION)  # type: ignore[arg-type]
    errors = {"position:tool0": np.full((4, 3), 0.1 * error), "pose:flange": np.zeros((4, 6))}
    errors["position:tool0"][2, 1] = -error
    assert at_floor(errors, floors) is exact
    # the orientation rows of the pose are held to their own σ (10 × here)
    errors["pose:flange"][1, 4] = 5.0 * error
    assert at_floor(errors, floors) is (exact and 5.0 * error <= max(FLOOR_SIGMA_FRACTION * 10 * sigma, 1e-8))
