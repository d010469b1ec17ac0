"""A calibration's extras computed when first read (:mod:`pincal.calibration.on_demand`): the bound's growth, the
workspace prediction and the calibrated URDF wait for a reader, and give what computing them at once gives, to the
byte, whatever was evaluated in between; a closed-loop robot's growth is computed at once."""

from __future__ import annotations

import pickle
from dataclasses import dataclass, replace
from pathlib import Path

import numpy as np
import pytest

import pincal
from pincal.calibration.on_demand import Pending, defer, on_demand, pending_fields
from pincal.calibration.pipeline import Calibration
from pincal.calibration.report import CalibrationReport
from pincal.errors import PincalError


@pytest.fixture(scope="module")
def ur10_campaign() -> tuple[pincal.Robot, pincal.Dataset]:
    robot = pincal.load_robot("ur10")
    return robot, pincal.simulate(robot, ["position"], 40, 0, seed=3).dataset


def test_a_pending_value_is_computed_once() -> None:
    calls: list[int] = []
    pending = Pending(lambda: calls.append(1) or len(calls))
    assert pending.value() == 1
    assert pending.value() == 1
    assert calls == [1]


@on_demand("late")
@dataclass(frozen=True)
class _Record:
    early: int = 0
    late: int | None = None


def test_a_field_given_pending_reads_as_its_value() -> None:
    calls: list[int] = []
    record = _Record(1, Pending(lambda: calls.append(1) or 7))  # type: ignore[arg-type]
    assert pending_fields(record) == ["late"] and not calls
    assert record == _Record(1, 7) and repr(record) == "_Record(early=1, late=7)"
    assert pending_fields(record) == [] and calls == [1]
    assert _Record().late is None and _Record.late is None  # the default, on the class too
    assert replace(_Record(1, Pending(lambda: 8)), early=2) == _Record(2, 8)  # type: ignore[arg-type]
    assert pickle.loads(pickle.dumps(_Record(1, Pending(lambda: 9)))) == _Record(1, 9)  # type: ignore[arg-type]
    with pytest.raises(TypeError, match="early is not a field computed on demand"):
        defer(record, "early", lambda: 3)


def test_the_report_s_extras_wait_for_a_reader_and_give_the_same_bytes(
        ur10_campaign: tuple[pincal.Robot, pincal.Dataset]) -> None:
    robot, dataset = ur10_campaign
    eager = pincal.calibrate(robot, dataset)
    eager_growth, eager_urdf, eager_proof = eager.report.error_growth, eager.urdf_text, eager.proof  # read at once
    lazy = pincal.calibrate(robot, dataset)
    assert pending_fields(lazy.report) == ["error_growth", "predicted_workspace"]
    assert pending_fields(lazy) == ["urdf_text", "proof"]
    x = lazy.result.x
    for scale in (0.5, 2.0, 0.0):  # the problem evaluated elsewhere before the extras are read
        lazy.problem.evaluate(x * scale)
    assert lazy.report.to_json() == eager.report.to_json()
    assert lazy.report.error_growth == eager_growth is not None
    assert lazy.urdf_text == eager_urdf
    assert lazy.proof == eager_proof and lazy.proof in lazy.urdf_text
    assert pending_fields(lazy.report) == [] and pending_fields(lazy) == []


def test_the_urdf_s_proof_refuses_when_the_text_is_read(ur10_campaign: tuple[pincal.Robot, pincal.Dataset],
                                                        monkeypatch: pytest.MonkeyPatch) -> None:
    """A calibrated URDF that does not hold the calibrated model is never handed out: its text raises, once read."""
    from pincal.calibration import export_proof

    def refused(*args: object) -> str:
        raise PincalError("calibrate: Pinocchio reads the calibrated URDF 1e-06 m away: not written")

    monkeypatch.setattr(export_proof, "calibrated_proof", refused)
    calibration = pincal.calibrate(*ur10_campaign)
    assert calibration.report.converged
    for name in ("urdf_text", "proof"):
        with pytest.raises(PincalError, match="not written"):
            getattr(calibration, name)


def test_a_report_pickles_with_its_extras_computed(ur10_campaign: tuple[pincal.Robot, pincal.Dataset]) -> None:
    """What a fleet's worker sends back: the report, its extras computed on the way."""
    report = pincal.calibrate(*ur10_campaign).report
    assert pending_fields(report)
    sent = pickle.loads(pickle.dumps(report))
    assert isinstance(sent, CalibrationReport) and pending_fields(sent) == []
    assert sent.to_json() == report.to_json()


def test_a_closed_loop_robot_s_growth_is_computed_at_once(tmp_path: Path) -> None:
    """Its evaluations follow the samples' warm starts: the growth is estimated where it always was."""
    robot = pincal.load_robot("delta")
    dataset = pincal.simulate(robot, ["position"], 20, 0, seed=1).dataset
    calibration = pincal.calibrate(robot, dataset)
    assert isinstance(calibration, Calibration)
    assert pending_fields(calibration.report) == ["predicted_workspace"]
    assert calibration.report.error_growth is not None
    assert np.isfinite(calibration.report.error_growth.rho0)
