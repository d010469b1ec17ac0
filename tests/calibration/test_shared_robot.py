"""``calibrate()`` called from several threads at once on one shared Robot gives each call the single-threaded answer.

A Robot's scratch (Pinocchio's ``Data``, the loops' constraint data, the batched evaluation's arrays, the last Newton
pass) is one per thread (:mod:`pincal.model.per_thread`). Held once for the robot, the threads overwrote each other's:
a false ``DataError`` (a joint column "read with the other sign") or a different report.
"""

from __future__ import annotations

from pathlib import Path

from concurrent_calls import in_threads

import pincal
from pincal.calibration import calibrate
from pincal.calibration.from_files import read_inputs

TIAGO_DATA = Path(__file__).resolve().parents[2] / "examples" / "data" / "tiago_mocap_marker1.csv"


def test_tree_robot_calibrated_from_threads_as_alone() -> None:
    """TIAGo's arm on its motion-capture data (the tree's batched evaluation, the joint columns' sign check): every
    report, byte for byte, the report of the same call made alone."""
    inputs = read_inputs("calibrate", "tiago_no_hand", str(TIAGO_DATA))
    alone = calibrate(inputs.robot, inputs.dataset).report.to_json()
    reports = in_threads(lambda _: calibrate(inputs.robot, inputs.dataset).report.to_json())
    assert [[report == alone for report in thread] for thread in reports] == [[True, True]] * 4


def test_closed_loop_robot_calibrated_from_threads_as_alone() -> None:
    """A Delta with Model 24's errors (the loops closed sample by sample and all at once, warm starts, the last Newton
    pass reused): every report, byte for byte, the report of the same call made alone."""
    robot = pincal.load_robot("delta")
    dataset = pincal.calibration.simulate(robot, ["position"], n_train=30, n_test=5, parameter_spec=["model24"],
                                          seed=4).dataset
    alone = calibrate(robot, dataset, parameter_spec=["model24"]).report.to_json()
    reports = in_threads(lambda _: calibrate(robot, dataset, parameter_spec=["model24"]).report.to_json(), calls=3)
    assert [[report == alone for report in thread] for thread in reports] == [[True, True, True]] * 4
