"""docs/results/extrapolation.md, written by ``examples/extrapolation.py``: its quick run writes a page of the same
form elsewhere, and the TIAGo file's range hold-outs, rerun, give the published row (RMS and coverage) exactly."""

from __future__ import annotations

import re
import sys
from pathlib import Path

from conftest import ROOT, page_elsewhere

PAGE = ROOT / "docs" / "results" / "extrapolation.md"
SCRIPT = ROOT / "examples" / "extrapolation.py"


def test_the_quick_run_writes_the_page_elsewhere(tmp_path: Path) -> None:
    page = page_elsewhere(SCRIPT, PAGE, tmp_path, "--quick")
    row = next(line for line in page.splitlines() if line.startswith("| UR10"))
    assert "| 80 / 80 |" in row  # two seeds of 40 held-out postures inside the band and 40 beyond
    verdicts = re.findall(r"predicts (no worse than|WORSE than) the nominal robot", page)
    assert len(verdicts) == 2  # the campaign and the TIAGo file's hold-outs of one joint, each judged


def test_the_tiago_row_of_the_published_page_is_reproduced() -> None:
    sys.path.insert(0, str(ROOT / "examples"))
    try:
        import extrapolation
    finally:
        sys.path.remove(str(ROOT / "examples"))
    name, robot, data = extrapolation.REAL[0]
    row = extrapolation.run_real(name, robot, data, quick=False)
    line = extrapolation.table([row])[2]
    assert line in PAGE.read_text(encoding="utf-8").splitlines()
    judged = extrapolation.verdicts([row])
    assert all(sentence in PAGE.read_text(encoding="utf-8") for sentence in judged)
