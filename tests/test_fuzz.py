"""Fuzzing: mutated URDF and CSV files give a result or a PincalError, never another exception."""

from __future__ import annotations

import re
from pathlib import Path

import numpy as np
from conftest import ROBOTS
from hypothesis import HealthCheck, given, settings
from hypothesis import strategies as st

import pincal
from pincal.calibration.pipeline import calibrate
from pincal.io.dataset import Dataset, write_dataset
from pincal.io.dataset_reader import read_dataset
from pincal.model.robot import robot_from_urdf_text

NUMBER = re.compile(r"-?\d+\.?\d*(?:e-?\d+)?")
JUNK = ["nan", "inf", "-inf", "1e400", "abc", "", "0x10", "1,5", "--1", "1e-400", "9" * 40, "0.0.0", " "]
TEXTS = {p.stem: p.read_text() for p in sorted(ROBOTS.glob("*.urdf")) if p.stem in ("delta", "five_bar", "hexapod")}


def _mutate(text: str, data: st.DataObject) -> str:
    kind = data.draw(st.sampled_from(["number", "delete_line", "duplicate_line", "truncate", "rename", "swap"]))
    lines = text.splitlines()
    if kind == "number":
        spans = [m.span() for m in NUMBER.finditer(text)]
        start, end = data.draw(st.sampled_from(spans))
        replacement = data.draw(st.one_of(st.sampled_from(JUNK), st.floats(allow_nan=True).map(repr)))
        return text[:start] + replacement + text[end:]
    if kind == "delete_line":
        k = data.draw(st.integers(0, len(lines) - 1))
        return "\n".join(lines[:k] + lines[k + 1:])
    if kind == "duplicate_line":
        k = data.draw(st.integers(0, len(lines) - 1))
        return "\n".join(lines[:k + 1] + lines[k:])
    if kind == "truncate":
        return text[: data.draw(st.integers(0, len(text)))]
    if kind == "rename":
        names = sorted(set(re.findall(r'(?:link|name)="([^"]+)"', text)))
        if names:
            old = data.draw(st.sampled_from(names))
            return text.replace(f'"{old}"', f'"{old}_x"', data.draw(st.integers(1, 3)))
        header = next(line for line in lines if not line.startswith("#"))  # a CSV: rename a column
        cells = header.split(",")
        k = data.draw(st.integers(0, len(cells) - 1))
        cells[k] = data.draw(st.sampled_from([cells[k] + "_x", "", cells[0], cells[k].upper()]))
        return text.replace(header, ",".join(cells), 1)
    a, b = data.draw(st.sampled_from([("spherical", "fixed"), ("revolute", "prismatic"), ("prismatic", "continuous"),
                                      ("fixed", "floating"), ("revolute", "planar")]))
    return text.replace(f'"{a}"', f'"{b}"', 1)


@settings(max_examples=600, deadline=None, suppress_health_check=[HealthCheck.too_slow])
@given(name=st.sampled_from(sorted(TEXTS)), data=st.data())
def test_mutated_urdf_loads_or_raises_a_pincal_error(name: str, data: st.DataObject) -> None:
    text = _mutate(TEXTS[name], data)
    try:
        robot = robot_from_urdf_text(text)
    except pincal.PincalError:
        return
    # what loads must work: a reference FK and a placement
    q = robot.solve_fk_report(robot.actuated_values(robot.q_reference)).q
    try:
        frame = robot.end_effector
    except pincal.NotFoundError as refusal:  # no obvious measured frame (end_effector renamed): the candidates named
        assert refusal.choices or "move none of its links" in str(refusal)
        frame = str(robot.model.frames[len(robot.model.frames) - 1].name)
    assert np.all(np.isfinite(robot.placement(q, frame).translation))


_BASE: dict[str, Dataset] = {}


def _base_dataset() -> Dataset:
    if not _BASE:
        from pincal.calibration.campaign import simulate

        sim = simulate(pincal.load_robot("five_bar"), ["position"], 12, 3, perturb=1e-4, noise=1e-6, seed=0,
                       parameter_spec=["*.offset"])
        _BASE["ds"] = sim.dataset
    return _BASE["ds"]


@settings(max_examples=500, deadline=None, suppress_health_check=[HealthCheck.too_slow,
                                                                   HealthCheck.function_scoped_fixture])
@given(data=st.data())
def test_mutated_csv_reads_and_calibrates_or_raises_a_pincal_error(tmp_path: Path, data: st.DataObject) -> None:
    path = tmp_path / "m.csv"
    write_dataset(_base_dataset(), path)
    path.write_text(_mutate(path.read_text(), data))
    robot = pincal.load_robot("five_bar")
    try:
        dataset = read_dataset(path, robot.actuated_joints, min_samples=2)
        if data.draw(st.booleans()):  # the full job on a share of the cases (it is the slow part)
            cal = calibrate(robot, dataset, parameter_spec=["*.offset"])
            assert np.all(np.isfinite(cal.result.x))
    except pincal.PincalError:
        return


def test_cases_fuzzing_found(tmp_path: Path) -> None:
    """Kept as plain tests: a σ of 2e-192 in the metadata (weights of 1e191 overflowed the observability
    indices) and a reading of 5.6e158 (LM steps went to NaN and hit a plain ValueError)."""
    robot = pincal.load_robot("five_bar")
    path = tmp_path / "m.csv"
    for old, new in (("# sigma position end_effector: 1e-06", "# sigma position end_effector: 2.088823138205281e-192"),
                     (None, "5.6040353164045e+158")):
        write_dataset(_base_dataset(), path)
        text = path.read_text()
        if old is None:  # replace the first reading of the first motor
            header, first, *_ = [line for line in text.splitlines() if not line.startswith("#")]
            cells = first.split(",")
            cells[header.split(",").index("theta_1_joint")] = new
            text = text.replace(first, ",".join(cells))
        else:
            assert old in text
            text = text.replace(old, new)
        path.write_text(text)
        try:
            dataset = read_dataset(path, robot.actuated_joints, min_samples=2)
            cal = calibrate(robot, dataset, parameter_spec=["*.offset"])
        except pincal.PincalError:
            continue
        assert np.all(np.isfinite(cal.result.x))
