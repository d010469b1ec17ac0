"""docs/results/compensation.md, written by ``examples/compensation.py``: each of its robots rerun alone, as the
script runs it, gives the published row (every figure the page prints, to its three digits), and the figures hold what
the page says. The UR10 aimed by a point, a six-axis arm with a posture free for each target, is rerun twice: with the
stacked arithmetic of a batch of targets, and row by row with Pinocchio's (another machine's round-off, in effect):
each target's commands are a function of the target and the model alone, so the published figures come back either
way."""

from __future__ import annotations

import importlib.util
import sys
from pathlib import Path
from types import ModuleType
from typing import Any

import pytest
from conftest import ROOT

PAGE = ROOT / "docs" / "results" / "compensation.md"
SCRIPT = ROOT / "examples" / "compensation.py"


def _script() -> ModuleType:
    """examples/compensation.py as a module (its folder on the path, for the helpers it imports)."""
    if str(SCRIPT.parent) not in sys.path:
        sys.path.insert(0, str(SCRIPT.parent))
    spec = importlib.util.spec_from_file_location("compensation_page", SCRIPT)
    assert spec is not None and spec.loader is not None
    module = importlib.util.module_from_spec(spec)
    sys.modules[spec.name] = module
    spec.loader.exec_module(module)
    return module


STUDY = _script()
ROWS = {f"{case.name} ({case.kind})": case for case in STUDY.CASES}


def _row_by_row(monkeypatch: pytest.MonkeyPatch) -> None:
    """Every stacked evaluation of ``pincal compensate`` made row by row, with Pinocchio's arithmetic."""
    import pincal.model.batch_ik
    import pincal.model.frame_kinematics

    for module in (pincal.model.frame_kinematics, pincal.model.batch_ik):
        monkeypatch.setattr(module, "SMALL_BATCH", 10**9)


def _check_figures(row: dict[str, Any]) -> None:
    """The truth, driven with the compensated commands, is as close as the calibration's held-out accuracy; with the
    nominal robot's commands, even registered, it misses by millimetres."""
    assert row["compensated"]["reached"] >= row["targets"] - 1
    assert row["compensated"]["rms"] < 2 * row["held_out_rms"]
    assert row["registered"]["rms"] > 1e-3 and row["nominal"]["rms"] > 1e-3


@pytest.mark.parametrize(("label", "arithmetic"), [(label, "stacked") for label in ROWS]
                         + [("UR10 (position)", "row by row")])
def test_each_robot_of_the_page_is_reproduced(label: str, arithmetic: str, tmp_path: Path,
                                              monkeypatch: pytest.MonkeyPatch) -> None:
    if arithmetic == "row by row":
        _row_by_row(monkeypatch)
    row = STUDY.measure(ROWS[label], STUDY.TARGETS[False], tmp_path)
    published = PAGE.read_text(encoding="utf-8").splitlines()
    assert STUDY.table_row(row) in published, "\n".join(line for line in published if line.startswith("| "))
    _check_figures(row)


def test_the_corrections_table_of_the_page_is_reproduced(tmp_path: Path) -> None:
    harmonics = STUDY.measure(STUDY.HARMONICS, STUDY.TARGETS[False], tmp_path)
    published = PAGE.read_text(encoding="utf-8").splitlines()
    for line in STUDY.harmonics_rows(harmonics):
        assert line in published, line
    assert harmonics["compensated"]["rms"] < 2 * harmonics["held_out_rms"]
    assert harmonics["without corrections"]["rms"] > 10 * harmonics["compensated"]["rms"]
