"""The worked examples of docs/iso9283.md and docs/drift.md: their commands run as written in an empty folder, and the
output they quote is what the commands print (each figure to one unit of its last printed digit)."""

from __future__ import annotations

import json
import os
import re
import shlex
import subprocess
from pathlib import Path

from conftest import PINCAL, ROOT, run_pincal

NUMBER = re.compile(r"[-+]?\d+\.\d+|[-+]?\d+")


def _blocks(page: str) -> tuple[list[str], list[list[str]]]:
    """The worked example's commands (its bash block) and the output blocks quoted after it."""
    section = page[page.index("```bash\n"):]
    commands = section[len("```bash\n"):section.index("```", 8)]
    quoted = re.findall(r"\n```\n(.*?)```", section[section.index("```", 8) + 3:], re.DOTALL)
    return [line.split("  #")[0].strip() for line in commands.splitlines() if line.strip()], \
        [block.strip("\n").splitlines() for block in quoted]


def _run(lines: list[str], folder: Path) -> str:
    """Each line in ``folder``, as in a clone's root (``examples/`` there); their standard output."""
    (folder / "examples").symlink_to(ROOT / "examples", target_is_directory=True)
    printed = []
    path = f"{PINCAL.parent}{os.pathsep}{os.environ['PATH']}"  # the pincal under test first
    for line in lines:
        if line.startswith("pincal "):  # as a user runs it, forked from the tests' command server (conftest)
            done = run_pincal(*shlex.split(line)[1:], cwd=folder)
        else:
            done = subprocess.run(line, shell=True, cwd=folder, capture_output=True, text=True, timeout=600,
                                  check=False, env={**os.environ, "PATH": path})
        assert done.returncode in (0, 1), (line, done.stderr)
        printed.append(done.stdout)
    return "".join(printed)


def _same(quoted: str, printed: str) -> bool:
    """The same words, and each number within one unit of the quoted one's last digit."""
    if NUMBER.sub("#", quoted).split() != NUMBER.sub("#", printed).split():
        return False
    for a, b in zip(NUMBER.findall(quoted), NUMBER.findall(printed), strict=True):
        unit = 10.0 ** -len(a.partition(".")[2]) if "." in a else 0.0
        if abs(float(a) - float(b)) > 1.01 * unit:
            return False
    return True


def _check_quoted(page: str, folder: Path) -> str:
    commands, quoted = _blocks(page)
    printed = _run(commands, folder)
    lines = printed.splitlines()
    for block in quoted:
        for line in block:
            assert any(_same(line, candidate) for candidate in lines), (line, printed)
    return printed


def test_the_iso9283_worked_example_prints_what_the_page_quotes(tmp_path: Path) -> None:
    _check_quoted((ROOT / "docs" / "iso9283.md").read_text(encoding="utf-8"), tmp_path)
    report = json.loads((tmp_path / "iso.json").read_text(encoding="utf-8"))
    assert [p["pose"] for p in report["poses"]] == ["P1", "P2", "P3", "P4", "P5"] and len(report["distances"]) == 10
    assert (tmp_path / "iso.html").read_text(encoding="utf-8").count("<tr>") == 1 + 5 + 1 + 10 + 1 + 3


def test_the_drift_worked_example_prints_what_the_page_quotes(tmp_path: Path) -> None:
    page = (ROOT / "docs" / "drift.md").read_text(encoding="utf-8")
    printed = _check_quoted(page, tmp_path)
    shift = re.search(r"offset \+(\d\.\d+) ± (\d\.\d+)\)", printed)
    assert shift is not None and "its estimate within one σ of it" in page
    assert abs(float(shift.group(1)) - 2.0) < float(shift.group(2))
    assert (tmp_path / "drift.html").is_file()
