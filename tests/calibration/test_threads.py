"""Library ``calibrate()`` holds BLAS at one thread for its whole work, not only while ``identify`` fits."""

from __future__ import annotations

from typing import Any

import pytest

import pincal
from pincal.calibration import CalibrationOptions, pipeline


def test_model_selection_runs_on_one_blas_thread_in_a_library_call(monkeypatch: pytest.MonkeyPatch) -> None:
    """A script's process starts its BLAS with several threads; model selection and the range guard (outside
    ``identify``) then see one, the caller's own limit is back after the call, and the bound's growth, computed when
    the report's field is first read, sees one too."""
    from threadpoolctl import threadpool_info, threadpool_limits

    from pincal.identification import solver

    def blas_threads() -> set[int]:
        return {pool["num_threads"] for pool in threadpool_info() if pool["user_api"] == "blas"}

    for name in solver.ONE_THREAD:
        monkeypatch.delenv(name, raising=False)
    solver._threadpools.cache_clear()
    seen: list[set[int]] = []
    def watched(original: Any) -> Any:
        def call(*args: Any, **kwargs: Any) -> Any:
            seen.append(blas_threads())
            return original(*args, **kwargs)
        return call

    monkeypatch.setattr(pipeline, "select_and_fit", watched(pipeline.select_and_fit))
    monkeypatch.setattr(pipeline, "estimate_growth", watched(pipeline.estimate_growth))
    robot = pincal.load_robot("ur10")
    dataset = pincal.calibration.simulate(robot, ["position"], n_train=30, seed=3).dataset
    with threadpool_limits(limits=2, user_api="blas"):
        assert blas_threads() == {2}
        done = pipeline.calibrate(robot, dataset, CalibrationOptions())
        assert blas_threads() == {2}
        assert done.report.error_growth is not None  # read: computed now, after the call
        assert blas_threads() == {2}
    assert seen == [{1}, {1}]
