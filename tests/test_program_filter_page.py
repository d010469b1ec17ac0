"""docs/results/program_filter.md, written by ``examples/program_filter.py``: the KRL case rerun alone, as the script
runs it, gives the published row (every figure to its three digits), and the figures hold what the page says: the
filtered program within 3× the calibration's held-out RMS, the program as written off by the robot's error."""

from __future__ import annotations

import importlib.util
import sys
from pathlib import Path
from types import ModuleType

from conftest import ROOT

PAGE = ROOT / "docs" / "results" / "program_filter.md"
SCRIPT = ROOT / "examples" / "program_filter.py"


def _script() -> ModuleType:
    """examples/program_filter.py as a module (its folder on the path, for the helpers it imports)."""
    if str(SCRIPT.parent) not in sys.path:
        sys.path.insert(0, str(SCRIPT.parent))
    spec = importlib.util.spec_from_file_location("program_filter_page", SCRIPT)
    assert spec is not None and spec.loader is not None
    module = importlib.util.module_from_spec(spec)
    sys.modules[spec.name] = module
    spec.loader.exec_module(module)
    return module


def test_the_krl_row_reruns_and_holds_what_the_page_says(tmp_path: Path) -> None:
    study = _script()
    case = next(c for c in study.CASES if c.language == "krl")
    row = study.measure(case, study.TARGETS[False], tmp_path)
    assert study.table_row(row) in PAGE.read_text(encoding="utf-8").splitlines()
    assert row["filtered"]["rms"] < 3 * row["held_out_rms"]
    assert row["as_written"]["rms"] > 0.5 * row["uncalibrated_rms"] > 100 * row["filtered"]["rms"]
    assert row["rewritten"] == row["targets"] == row["changed_lines"]
