"""Stacked rotations against Pinocchio's one-at-a-time functions: log3 and Jlog3 from tiny angles to near π."""

from __future__ import annotations

import numpy as np
import pinocchio as pin
from hypothesis import given, settings
from hypothesis import strategies as st

from pincal.model import rotations

#: Rotation angles [rad] across the series' thresholds, the middle of the range and the neighbourhood of π.
ANGLES = (0.0, 1e-9, 1e-6, 9e-5, 1.1e-4, 1e-2, 1.0, 3.0, np.pi - 2e-3, np.pi - 1e-4)


def _rotations(seed: int) -> tuple[np.ndarray, np.ndarray]:
    rng = np.random.default_rng(seed)
    axes = rng.normal(size=(len(ANGLES), 3))
    vectors = axes / np.linalg.norm(axes, axis=1)[:, None] * np.array(ANGLES)[:, None]
    return vectors, np.array([pin.exp3(v) for v in vectors])


def test_log3_is_pinocchio_s() -> None:
    vectors, matrices = _rotations(0)
    expected = np.array([pin.log3(r) for r in matrices])
    np.testing.assert_allclose(rotations.log3(matrices), expected, rtol=0, atol=1e-12)
    np.testing.assert_allclose(rotations.log3(matrices), vectors, rtol=0, atol=1e-12)


def test_jlog3_is_pinocchio_s_and_the_derivative_of_log3() -> None:
    """Pinocchio's own Jlog3 loses up to ε/θ² just above its series threshold (1.2e-4 rad): compared there to the
    derivative of log3 by central differences of a right perturbation instead."""
    _, matrices = _rotations(1)
    ours = rotations.jlog3(rotations.log3(matrices))
    for k, theta in enumerate(ANGLES):
        if not 1e-4 < theta < 1e-3:
            np.testing.assert_allclose(ours[k], pin.Jlog3(matrices[k]), rtol=0, atol=1e-12)
        if theta < np.pi - 1e-2:
            eps = 1e-6
            turned = [(pin.log3(matrices[k] @ pin.exp3(eps * e)), pin.log3(matrices[k] @ pin.exp3(-eps * e)))
                      for e in np.eye(3)]
            fd = np.column_stack([(plus - minus) / (2 * eps) for plus, minus in turned])
            np.testing.assert_allclose(ours[k], fd, rtol=0, atol=1e-8)


@settings(max_examples=30, deadline=None)
@given(st.lists(st.floats(-3.0, 3.0), min_size=3, max_size=3), st.floats(-np.pi, np.pi))
def test_the_stacked_helpers_agree_with_single_products(axis: list[float], angle: float) -> None:
    vector = np.array(axis)
    columns = np.random.default_rng(2).normal(size=(4, 3, 5))
    stacked = np.repeat(pin.exp3(angle * np.array([0.0, 0.6, 0.8]))[None], 4, axis=0)
    np.testing.assert_allclose(rotations.skew(vector), pin.skew(vector), atol=0)
    np.testing.assert_allclose(rotations.cross_columns(np.tile(vector, (4, 1)), columns),
                               np.cross(vector[None, :, None], columns, axis=1), atol=1e-12)
    np.testing.assert_allclose(rotations.rotate(stacked[0], columns), stacked[0] @ columns, atol=1e-12)
    np.testing.assert_allclose(rotations.rotate(stacked, columns[0]), stacked @ columns[0], atol=1e-12)
    np.testing.assert_allclose(rotations.rotate(stacked, columns), stacked @ columns, atol=1e-12)


def test_jlog3_keeps_full_precision_where_the_cosine_form_loses_it() -> None:
    """Against the closed form in extended precision: the residual angles of a pose fit (1e-4 to 1e-3 rad) are where
    ``1 − cos θ`` cancels (Pinocchio's Jlog3 errs there by up to 2e-9); the half-angle form stays at rounding."""
    rng = np.random.default_rng(4)
    axes = rng.normal(size=(40, 3))
    vectors = axes / np.linalg.norm(axes, axis=1)[:, None] * np.geomspace(1.3e-4, 3e-3, 40)[:, None]
    ours = rotations.jlog3(vectors)
    for vector, jacobian in zip(vectors.astype(np.longdouble), ours, strict=True):
        theta = np.sqrt(np.sum(vector * vector))
        beta = theta / 2 / np.tan(theta / 2)
        hat = np.array([[0, -vector[2], vector[1]], [vector[2], 0, -vector[0]], [-vector[1], vector[0], 0]])
        exact = (1 - beta) / theta**2 * np.outer(vector, vector) + beta * np.eye(3) + hat / 2
        assert float(np.abs(jacobian - exact).max()) < 1e-15
