"""docs/results/selection.md, written by ``examples/selection.py``: its quick run writes a page of the same form
elsewhere (never into docs/), and every judgment on it follows from the figures printed beside it."""

from __future__ import annotations

import re
from pathlib import Path

from conftest import ROOT, page_elsewhere

PAGE = ROOT / "docs" / "results" / "selection.md"
SCRIPT = ROOT / "examples" / "selection.py"
#: A row of the main table: the benchmark, four held-out RMS [mm], the loss [%] and its judgment, four CPU times [s],
#: their ratio and its judgment.
ROW = re.compile(r"^\| (?P<name>[^|]+) \| (?P<held>[0-9.]+ / [0-9.]+ / [0-9.]+ / [0-9.]+)"
                 r"(?: \(fold fits failed: [^)]+\))? \| (?P<loss>[+-][0-9.]+) % \| (?P<met>met|NOT met) \| "
                 r"(?P<cpu>[0-9.e+-]+ / [0-9.e+-]+ / [0-9.e+-]+ / [0-9.e+-]+) \| (?P<ratio>[0-9.]+) \| "
                 r"(?P<fast>met|NOT met) \|$")


def rows(page: str) -> list[re.Match[str]]:
    return [m for m in map(ROW.match, page.splitlines()) if m]


def check_judgments(page: str) -> list[re.Match[str]]:
    """Each row's loss and ratio recomputed from its own printed figures (to their printed precision), each judgment
    from them, and the summary sentences from the rows."""
    found = rows(page)
    assert found
    for row in found:
        default, bic, cv, _ = (float(v) for v in row["held"].split(" / "))
        best = min(bic, cv)
        loss = 100 * (default / best - 1)
        rounding = 0.05 + 100 * (default / best) * (0.0005 / default + 0.0005 / best)  # figures printed to 1 µm
        assert abs(loss - float(row["loss"])) <= rounding
        assert (row["met"] == "met") == (float(row["loss"]) <= 3.0) or abs(float(row["loss"]) - 3.0) < 0.05
        cpu_default, cpu_before, _, _ = (float(v) for v in row["cpu"].split(" / "))
        assert abs(cpu_default / cpu_before - float(row["ratio"])) <= 0.1 * float(row["ratio"])  # 2 digits printed
        assert (row["fast"] == "met") == (float(row["ratio"]) <= 2.0) or abs(float(row["ratio"]) - 2.0) < 0.01
    lost = sum(r["met"] == "NOT met" for r in found)
    assert f"more than 3 % to the better of bic and cv on {lost} of {len(found)} benchmarks" in page
    assert ("**Held-out error: met.**" if lost == 0 else "**Held-out error: NOT met.**") in page
    slow = sum(r["fast"] == "NOT met" for r in found)
    assert f"above 2× on {slow} of {len(found)} benchmarks" in page
    assert ("**Time: met.**" if slow == 0 else "**Time: NOT met.**") in page
    return found


def test_the_quick_run_writes_a_page_whose_judgments_follow_from_its_figures(tmp_path: Path) -> None:
    page = page_elsewhere(SCRIPT, PAGE, tmp_path, "--quick")
    assert "**a quick run**" in page
    found = check_judgments(page)
    assert [r["name"] for r in found] == ["TIAGo, one marker (34 postures)", "UR10, eye-in-hand, seed 1"]
    assert "| TIAGo, one marker (34 postures) | stated: `# sigma position: 1e-3` |" in page
    assert "`pincal calibrate tiago_no_hand examples/data/tiago_mocap_marker1.csv --cv 5`" in page


def test_the_published_page_judges_its_own_figures() -> None:
    page = PAGE.read_text(encoding="utf-8")
    assert "**a quick run**" not in page
    found = check_judgments(page)
    names = [r["name"] for r in found]
    assert len(names) == len(set(names))
    for benchmark in ("TIAGo", "TALOS, left", "TALOS, right", "UR10", "Panda"):
        assert any(name.startswith(benchmark) for name in names)
    # every benchmark also appears in the σ table, its estimate (or the data's stated σ) beside it
    assert all(re.search(rf"^\| {re.escape(name)} \| (stated: |`)", page, re.M) for name in names)
