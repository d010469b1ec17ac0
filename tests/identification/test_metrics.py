"""Error metrics: per-reading and per-sample error sizes, RMS, calibration gain."""

from __future__ import annotations

import math

import numpy as np
import pytest

from pincal.identification.metrics import (
    angle_columns,
    angle_error_norms,
    calibration_gain,
    error_norms,
    length_columns,
    rms,
    sample_length_errors,
)


def test_a_sample_with_no_reading_has_no_error_size() -> None:
    """Per-sample error sizes sum the readings taken; a sample that took none has NaN, not zero."""
    errors = {"position:f@m1": np.array([[3e-3, 0.0, 4e-3], [np.nan] * 3, [np.nan] * 3]),
              "position:f@m2": np.array([[0.0, 0.0, 12e-3], [1e-3, 0.0, 0.0], [np.nan] * 3])}
    sizes = sample_length_errors(errors, 3)
    assert sizes is not None
    np.testing.assert_allclose(sizes[:2], [13e-3, 1e-3], rtol=1e-12)
    assert np.isnan(sizes[2])


def test_columns_follow_the_measurement_kind() -> None:
    """A position has three length columns, a pose three then three angles, a distance one; other keys none."""
    assert length_columns("position:tool0") == 3 and angle_columns("position:tool0") == slice(3, 3)
    assert length_columns("pose:flange") == 3 and angle_columns("pose:flange") == slice(3, 6)
    assert length_columns("distance:a:b") == 1
    assert length_columns("closure") == 0 and angle_columns("closure") == slice(0, 0)


def test_error_norms_are_one_per_reading_taken() -> None:
    """Lengths of positions and poses, angles of poses only; NaN readings have none; no sample-size mixing."""
    errors = {"position:f": np.array([[3e-3, 4e-3, 0.0], [np.nan] * 3]),
              "pose:g": np.array([[0.0, 0.0, 1e-3, 0.0, 0.03, 0.04], [np.nan] * 6])}
    np.testing.assert_allclose(error_norms(errors), [5e-3, 1e-3], rtol=1e-12)
    np.testing.assert_allclose(error_norms(errors, keys=["pose:g"]), [1e-3], rtol=1e-12)
    np.testing.assert_allclose(angle_error_norms(errors), [0.05], rtol=1e-12)
    assert sample_length_errors({"joint:j": np.zeros((2, 1))}, 2) is None


def test_rms_and_calibration_gain() -> None:
    """RMS is NaN when empty; G is 100 % at the truth, 0 % at the nominal, NaN when the nominal is the truth."""
    assert rms(np.array([3.0, 4.0])) == pytest.approx(math.sqrt(12.5))
    assert math.isnan(rms(np.zeros(0)))
    truth, nominal = np.array([1e-3, -2e-3]), np.zeros(2)
    assert calibration_gain(truth, nominal, truth) == pytest.approx(100.0)
    assert calibration_gain(truth, nominal, nominal) == pytest.approx(0.0)
    assert math.isnan(calibration_gain(nominal, nominal, truth))
