"""Figures the README and the results pages quote, checked against the commands written next to them."""

from __future__ import annotations

import json
import os
import re
import statistics
import subprocess
import sys
from pathlib import Path

import pytest
from conftest import PINCAL, ROOT, run_pincal

README = (ROOT / "README.md").read_text(encoding="utf-8")
TIAGO_PAGE = (ROOT / "docs" / "results" / "tiago_mocap.md").read_text(encoding="utf-8")
TIAGO_DATA = ROOT / "examples" / "data" / "tiago_mocap_marker1.csv"


def _mm(value: float, digits: int) -> str:
    return f"{value * 1e3:.{digits}f}"


def test_the_demo_figure_of_the_readme(tmp_path: Path) -> None:
    row = re.search(r"\(`pincal demo`\) \| held-out RMS ([\d.]+) mm → ([\d.]+) mm \|", README)
    assert row is not None
    before, after = row.groups()
    demo = tmp_path / "demo"
    with subprocess.Popen([str(PINCAL), "demo", "--out", str(demo)], stdout=subprocess.PIPE, stderr=subprocess.PIPE,
                          text=True) as process:
        assert process.stdout is not None and process.stderr is not None
        first = process.stdout.readline()
        # the demo says what it does before doing it: nothing written yet when its first line arrives
        assert first.startswith("pincal demo: geometric calibration") and not (demo / "measurements.csv").exists()
        stdout, stderr = first + process.stdout.read(), process.stderr.read()
    assert process.returncode == 0, stderr
    report = json.loads((demo / "report.json").read_text())
    assert _mm(report["test_rms_before"], len(before.split(".")[1])) == before
    assert _mm(report["test_rms_after"], len(after.split(".")[1])) == after
    assert "RMS position error (held out)" in stdout
    assert (demo / "report.html").stat().st_size <= 1_000_000  # the viewer packed, numbers in single precision


def test_the_tiago_cross_validation_figure(tmp_path: Path) -> None:
    """docs/results/tiago_mocap.md (written by examples/tiago_mocap.py) and the README quote the default command's
    figures; the command, run here, gives them."""
    row = re.search(r"\| 1 marker \| geometric \(default\) \| (\d+) \(of (\d+)\) \| [^|]+ \| ([\d.]+) \| ([\d.]+) \| "
                    r"([\d.]+) \| ([\d.]+) \|", TIAGO_PAGE)
    readme = re.search(r"5-fold × 4 cross-validated RMS ([\d.]+) mm \|", README)
    assert row is not None and readme is not None
    estimated, identifiable, fit, held_out, _, folds = row.groups()
    report = tmp_path / "r.json"
    done = run_pincal("calibrate", "tiago_no_hand", str(TIAGO_DATA), "--cv", "5x4", "--report", str(report))
    assert done.returncode == 0, done.stderr
    data = json.loads(report.read_text())
    assert (data["n_estimated"], data["n_identifiable"]) == (int(estimated), int(identifiable))
    assert (_mm(data["rms_after"], 3), _mm(data["test_rms_after"], 3)) == (fit, held_out)
    assert _mm(data["cv"]["rms"], 3) == folds and _mm(data["cv"]["rms"], 2) == readme.group(1)
    assert data["cv"]["rms"] <= 4.2e-3  # the target of issue 12


def test_the_figaroh_comparison_is_quoted_as_measured() -> None:
    """The README's and the TIAGo page's pincal-against-FIGAROH figures are the benchmark's, as
    benchmarks/RESULTS.md records them (the medians over the five fold plans, the ratios)."""
    sys.path.insert(0, str(ROOT / "examples"))
    try:
        import tiago_mocap
    finally:
        sys.path.remove(str(ROOT / "examples"))
    results = (ROOT / "benchmarks" / "RESULTS.md").read_text(encoding="utf-8")
    for markers, plans in tiago_mocap.SIDE_BY_SIDE.items():
        for name, (ours, theirs) in plans.items():
            label = name if name == "leave-one-out" else f"5-fold × 4, {name}"
            assert f"| {markers} | {label} | {ours:.3f} | {theirs:.3f} | {theirs / ours:.2f} |" in results
            assert f"| {markers} | {label} | {ours:.3f} | {theirs:.3f} | {theirs / ours:.2f} |" in TIAGO_PAGE
    medians = {m: [statistics.median(p[n][k] for n in p if n.startswith("seeds")) for k in (0, 1)]
               for m, p in tiago_mocap.SIDE_BY_SIDE.items()}
    quoted = re.search(r"median ([\d.]+) vs ([\d.]+) mm \(1 marker\), ([\d.]+) vs ([\d.]+) mm \(3 markers\)", README)
    assert quoted is not None
    assert list(quoted.groups()) == [f"{v:.2f}" for m in ("1 marker", "3 markers") for v in medians[m]]


def test_the_tiago_study_runs(tmp_path: Path) -> None:
    """``examples/tiago_mocap.py --quick``: its one case is the default command's, with 5 folds once."""
    import subprocess

    out = tmp_path / "numbers.json"
    done = subprocess.run([sys.executable, str(ROOT / "examples" / "tiago_mocap.py"), "--quick", "--out",
                           str(tmp_path / "page"), "--json", str(out)], capture_output=True, text=True, timeout=600)
    assert done.returncode == 0, done.stderr
    (row,) = json.loads(out.read_text())["rows"]
    assert row["model"] == "geometric (default)" and row["cv_plan"] == "5-fold"
    assert _mm(row["held_out"], 3) in TIAGO_PAGE  # the same fit as the published full run
    assert (tmp_path / "page" / "tiago_mocap.md").read_text().startswith("# Real data — TIAGo arm")


def test_nothing_points_outside_the_repository() -> None:
    """A clone has no folder beside it: the papers are cited by title and DOI, the data are in examples/data with
    their public source named, so no tracked file of the README, docs, examples, tests or package points at one."""
    import subprocess

    beside = ".." + "/shared"  # built here so that this file does not match itself
    parts = ["README.md", "docs", "examples", "tests", "pincal"]
    try:
        tracked = subprocess.run(["git", "ls-files", "-z", "--", *parts], cwd=ROOT, capture_output=True,
                                 check=True).stdout.decode().split("\0")
    except (OSError, subprocess.CalledProcessError):  # not a git checkout: every file there but caches
        tracked = ["README.md"] + [p.relative_to(ROOT).as_posix() for part in parts[1:]
                                   for p in sorted((ROOT / part).rglob("*"))
                                   if p.is_file() and "__pycache__" not in p.parts]
    assert "README.md" in tracked and "tests/test_docs.py" in tracked
    found = [name for name in tracked if name and beside.encode() in (ROOT / name).read_bytes()]
    assert not found, f"{beside} in {found}"


def test_the_readme_s_python_runs_as_written(tmp_path: Path, monkeypatch: pytest.MonkeyPatch) -> None:
    """The README's library and calibration snippets, run in order as a reader pastes them: no stale name."""
    blocks = re.findall(r"```python\n(.*?)```", README, re.DOTALL)
    assert len(blocks) >= 2 and "from pincal.calibration import" in blocks[1]
    monkeypatch.chdir(tmp_path)
    namespace: dict[str, object] = {}
    exec(compile("\n".join(blocks[:2]), "README.md", "exec"), namespace)
    assert (tmp_path / "delta_calibrated.urdf").is_file()
    report = namespace["cal"].report  # type: ignore[attr-defined]
    assert report.cv is not None and report.cv.plan == "5-fold × 4"
    assert report.test_rms_after < 0.1 * report.test_rms_before


def test_the_readme_lifecycle_runs_as_written(tmp_path: Path) -> None:
    """The README's 'After the calibration' lines, run in order in an empty folder, and the figures it quotes."""
    block = re.search(r"## After the calibration.*?```bash\n(.*?)```", README, re.DOTALL)
    assert block is not None
    lines = [line.split("  #")[0].strip() for line in block.group(1).splitlines() if line.strip()]
    assert [line.split()[1] for line in lines if line.startswith("pincal")] == [
        "design", "simulate", "calibrate", "simulate", "check", "compensate", "export"]
    for line in lines:
        path = f"{PINCAL.parent}{os.pathsep}{os.environ['PATH']}"  # the pincal under test first
        done = subprocess.run(line, shell=True, cwd=tmp_path, capture_output=True, text=True, timeout=300,
                              check=False, env={**os.environ, "PATH": path})
        assert done.returncode == 0, (line, done.stderr)
    check = json.loads((tmp_path / "check.json").read_text(encoding="utf-8"))
    quoted = re.search(r"RMS\s+([\d.]+) mm against ([\d.]+) mm for the nominal robot", README)
    assert quoted is not None
    assert f"{check['rms'] * 1e3:.2g}" == quoted.group(1) and f"{check['nominal_rms'] * 1e3:.3g}" == quoted.group(2)
    commands = (tmp_path / "commands.csv").read_text(encoding="utf-8")
    assert commands.count(",ok\n") == 2 and (tmp_path / "joints.yaml").read_text(encoding="utf-8").count("x: ") > 3


def test_the_readme_example_output_is_what_pincal_demo_prints(tmp_path: Path) -> None:
    """README's "Example output" is ``pincal demo``'s summary: every line but the solver's (its time varies) as printed,
    the figures to the 0.1 µm the summary shows."""
    readme = (ROOT / "README.md").read_text(encoding="utf-8")
    start = readme.index("## Example output\n\n```\n") + len("## Example output\n\n```\n")
    block = readme[start:readme.index("\n```", start)]
    quoted = [line for line in block.splitlines() if not line.startswith("solver ")]
    done = run_pincal("demo", cwd=tmp_path)
    assert done.returncode == 0, done.stderr
    printed = done.stdout.splitlines()
    assert all(line in printed for line in quoted), [line for line in quoted if line not in printed]
