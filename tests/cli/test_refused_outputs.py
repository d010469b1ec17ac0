"""A refused command creates nothing: the output's missing directories are made only when the files are written,
so a command refused after its outputs were checked (a robot file missing, a parameter pattern matching nothing,
a data folder without data) leaves no empty directory behind."""

from __future__ import annotations

from pathlib import Path

import pytest
from conftest import ROOT, run_pincal

from pincal.errors import OutputError
from pincal.io.files import check_directory, check_outputs, write_texts

PROGRAMS = ROOT / "examples" / "data" / "programs"


def _refused(tmp_path: Path, *args: str) -> str:
    """The error line of ``pincal args`` run in ``tmp_path``, asserted refused (exit 2, one line, no traceback)."""
    done = run_pincal(*args, cwd=tmp_path)
    assert done.returncode == 2 and "Traceback" not in done.stderr, done.stderr
    assert done.stderr.strip().splitlines() == [done.stderr.strip()]
    return done.stderr.strip()


@pytest.mark.parametrize("command", ["filter", "fleet", "simulate"])
def test_a_refused_command_leaves_no_output_directory(tmp_path: Path, command: str) -> None:
    (tmp_path / "empty").mkdir()
    args, culprit = {
        "filter": (("filter", str(PROGRAMS / "palletize.src"), "--model", str(tmp_path / "missing.urdf"),
                    "--config", str(PROGRAMS / "config_excerpt.dat"), "--out", "out/x.src"), "missing.urdf"),
        "fleet": (("fleet", "five_bar", "empty", "--out", "out"), "'empty'"),
        "simulate": (("simulate", "five_bar", "--samples", "3", "--parameters", "nothing.*", "--quiet",
                      "--out", "out/sim"), "'nothing.*'"),
    }[command]
    line = _refused(tmp_path, *args)
    assert line.startswith("pincal: error: ") and culprit in line
    assert sorted(p.name for p in tmp_path.iterdir()) == ["empty"]


def test_the_outputs_are_checked_without_creating_their_directories(tmp_path: Path) -> None:
    deep = tmp_path / "a" / "b" / "cal.urdf"
    check_outputs([("--out", deep)])
    assert check_directory(tmp_path / "c" / "d", "--out") == tmp_path / "c" / "d"
    assert list(tmp_path.iterdir()) == []
    assert write_texts([(deep, "x\n")]) == [deep] and deep.read_text() == "x\n"


def test_a_directory_below_a_file_is_refused_before_any_work(tmp_path: Path) -> None:
    (tmp_path / "a").write_text("a file\n")
    with pytest.raises(OutputError, match=r"--out: cannot create directory '.*a/b': '.*a' is a file"):
        check_directory(tmp_path / "a" / "b", "--out")
    with pytest.raises(OutputError, match="cannot create directory '/proc/pincal/x'"):
        check_outputs([("--out", "/proc/pincal/x/cal.urdf")])


def test_a_failed_write_takes_back_the_directories_it_made(tmp_path: Path) -> None:
    """A second file that cannot be written (its name is an existing directory) fails the whole set: the folder
    made for the first is removed again."""
    (tmp_path / "dir").mkdir()
    with pytest.raises(OutputError, match="is a directory"):
        write_texts([(tmp_path / "new" / "deeper" / "a.txt", "a\n"), (tmp_path / "dir", "b\n")])
    assert sorted(p.name for p in tmp_path.iterdir()) == ["dir"]
