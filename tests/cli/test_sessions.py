"""Sessions of one simulated robot: ``pincal simulate --posture-seed`` keeps the robot of ``--seed`` and draws new
postures; ``--shift`` moves one of its true errors (a robot that changed)."""

from __future__ import annotations

import json
from pathlib import Path

import numpy as np
from conftest import run_pincal

from pincal.io.dataset_reader import read_dataset


def _simulate(tmp_path: Path, name: str, *extra: str) -> Path:
    done = run_pincal("simulate", "delta", "--samples", "6", "--seed", "1", "--quiet", "--out", name, *extra,
                      cwd=tmp_path)
    assert done.returncode == 0, done.stderr
    return tmp_path / name


def test_a_posture_seed_measures_the_same_robot_on_new_postures(tmp_path: Path) -> None:
    day1 = _simulate(tmp_path, "day1")
    week2 = _simulate(tmp_path, "week2", "--posture-seed", "2")
    again = _simulate(tmp_path, "again", "--posture-seed", "2")
    assert (day1 / "truth.json").read_text() == (week2 / "truth.json").read_text()  # the same robot
    first, second = read_dataset(day1 / "measurements.csv"), read_dataset(week2 / "measurements.csv")
    assert not np.isclose(first.joints[:, None, :], second.joints[None, :, :]).all(axis=2).any()  # no posture again
    assert (week2 / "measurements.csv").read_bytes() == (again / "measurements.csv").read_bytes()
    assert second.metadata["posture seed"] == "2"


def test_a_shift_moves_one_true_error_by_its_value(tmp_path: Path) -> None:
    plain = json.loads((_simulate(tmp_path, "plain", "--posture-seed", "3") / "truth.json").read_text())
    moved = json.loads((_simulate(tmp_path, "moved", "--posture-seed", "3", "--shift", "arm_2_joint.offset=0.002")
                        / "truth.json").read_text())
    changed = {k for k, v in plain["parameters"].items() if moved["parameters"][k] != v}
    assert changed == {"arm_2_joint.offset"}
    assert abs(moved["parameters"]["arm_2_joint.offset"] - plain["parameters"]["arm_2_joint.offset"] - 0.002) < 1e-15


def test_a_shift_of_no_parameter_is_refused_in_one_line(tmp_path: Path) -> None:
    done = run_pincal("simulate", "delta", "--samples", "3", "--quiet", "--out", "x", "--shift", "arm_9.offset=1e-3",
                      cwd=tmp_path)
    assert done.returncode == 2 and done.stderr.count("\n") == 1
    assert "parameter 'arm_9.offset' does not exist" in done.stderr and "arm_1_joint.offset" not in done.stdout
    bad = run_pincal("simulate", "delta", "--out", "x", "--shift", "offset", cwd=tmp_path)
    assert bad.returncode == 2 and "NAME=VALUE" in bad.stderr and "Traceback" not in bad.stderr
