"""Outputs are written whole or not at all, and never over an input — through the API and the CLI."""

from __future__ import annotations

import errno
import os
import re
import signal
import subprocess
import sys
from pathlib import Path

import pytest
from conftest import ROBOTS, run_pincal

from pincal.errors import OutputError
from pincal.io.files import check_outputs, write_text, write_texts


@pytest.fixture(scope="module")
def data(five_bar_csv: Path) -> Path:
    return five_bar_csv


def test_a_failed_write_keeps_the_old_file_and_leaves_no_debris(tmp_path: Path,
                                                               monkeypatch: pytest.MonkeyPatch) -> None:
    target = tmp_path / "report.json"
    target.write_text('{"good": true}\n')

    def disk_full(fd: int) -> None:
        raise OSError(errno.ENOSPC, os.strerror(errno.ENOSPC))

    monkeypatch.setattr(os, "fsync", disk_full)
    with pytest.raises(OutputError, match="No space left on device; every previous output is unchanged"):
        write_text(target, '{"new": ' + "1" * 100_000 + "}\n")
    assert target.read_text() == '{"good": true}\n'
    assert sorted(p.name for p in tmp_path.iterdir()) == ["report.json"]


def test_a_new_file_gets_ordinary_permissions_and_an_old_one_keeps_its_own(tmp_path: Path) -> None:
    umask = os.umask(0o022)
    try:
        fresh = write_text(tmp_path / "new.txt", "x")
        kept = tmp_path / "kept.txt"
        kept.write_text("old")
        kept.chmod(0o600)
        write_text(kept, "new")
    finally:
        os.umask(umask)
    assert fresh.stat().st_mode & 0o777 == 0o644
    assert kept.stat().st_mode & 0o777 == 0o600 and kept.read_text() == "new"


def test_outputs_are_checked_against_inputs_and_each_other(tmp_path: Path) -> None:
    data = tmp_path / "data.csv"
    data.write_text("x")
    with pytest.raises(OutputError, match="is the input file"):
        check_outputs([("--out", tmp_path / "." / "data.csv")], [data])
    with pytest.raises(OutputError, match="is the same file as --out"):
        check_outputs([("--out", tmp_path / "a"), ("--report", tmp_path / "sub" / ".." / "a")], [data])
    check_outputs([("--out", tmp_path / "new" / "deeper" / "cal.urdf")], [data])
    assert not (tmp_path / "new").exists()  # made when the file is written: a refused command leaves none


@pytest.mark.parametrize(("out", "culprit"), [
    ("DATA", "--out '{out}' is the input file"),
    ("/proc/pincal/cal.urdf", "cannot create directory '/proc/pincal'"),
    ("DIR", "is a directory; give a file name"),
])
def test_calibrate_refuses_unusable_outputs_before_fitting(data: Path, out: str, culprit: str) -> None:
    out = {"DATA": str(data), "DIR": str(data.parent)}.get(out, out)
    before = data.read_bytes()
    done = run_pincal("calibrate", "five_bar", str(data), "--parameters", "*.offset", "--out", out)
    assert done.returncode == 2 and "Traceback" not in done.stderr
    assert culprit.format(out=out) in done.stderr and done.stdout == ""  # refused before any fit
    assert data.read_bytes() == before


def test_calibrate_creates_missing_directories_and_refuses_one_file_for_two_outputs(data: Path,
                                                                                    tmp_path: Path) -> None:
    same = tmp_path / "same.json"
    done = run_pincal("calibrate", "five_bar", str(data), "--parameters", "*.offset", "--out", str(same),
                      "--report", str(same))
    assert done.returncode == 2 and "is the same file as --out" in done.stderr and not same.exists()
    deep = tmp_path / "a" / "b" / "cal.urdf"
    done = run_pincal("calibrate", "five_bar", str(data), "--parameters", "*.offset", "--out", str(deep))
    assert done.returncode == 0, done.stderr
    assert deep.read_text().startswith("<?xml") and [p.name for p in deep.parent.iterdir()] == ["cal.urdf"]


def test_view_report_and_design_never_write_over_their_inputs(data: Path, tmp_path: Path) -> None:
    robot_copy = tmp_path / "five_bar.urdf"
    robot_copy.write_text((ROBOTS / "five_bar.urdf").read_text())
    before = robot_copy.read_bytes(), data.read_bytes()
    for args in (("view", str(robot_copy), str(data), "--out", str(data)),
                 ("report", str(robot_copy), str(data), "--out", str(robot_copy)),
                 ("design", str(robot_copy), "--poses", "3", "--candidates", "20", "--out", str(robot_copy))):
        done = run_pincal(*args)
        assert done.returncode == 2 and "is the input file" in done.stderr, args
    assert (robot_copy.read_bytes(), data.read_bytes()) == before


@pytest.mark.parametrize("case", ["a file", "the robot's own URDF", "an unwritable place"])
def test_simulate_refuses_unusable_outputs_before_simulating(tmp_path: Path, case: str) -> None:
    robot = tmp_path / "truth.urdf"
    robot.write_text((ROBOTS / "five_bar.urdf").read_text())
    before = robot.read_bytes()
    out, culprit = {"a file": (str(robot), "is a file, not a directory"),
                    "the robot's own URDF": (str(tmp_path), "is the input file"),
                    "an unwritable place": ("/proc/pincal-sim", "cannot create directory")}[case]
    done = run_pincal("simulate", str(robot), "--samples", "3", "--quiet", "--out", out)
    assert done.returncode == 2 and culprit in done.stderr and "Traceback" not in done.stderr
    assert robot.read_bytes() == before and done.stdout == ""


def test_a_set_of_outputs_is_written_all_or_none(tmp_path: Path, monkeypatch: pytest.MonkeyPatch) -> None:
    """simulate's three files and calibrate's URDF and report go together: a disk that fills up on the second
    leaves the first one old as well (no new CSV beside an old truth.urdf)."""
    first, second = tmp_path / "measurements.csv", tmp_path / "truth.urdf"
    first.write_text("old csv\n")
    second.write_text("old urdf\n")
    calls = []

    def fills_up(fd: int) -> None:
        calls.append(fd)
        if len(calls) == 2:
            raise OSError(errno.ENOSPC, os.strerror(errno.ENOSPC))

    monkeypatch.setattr(os, "fsync", fills_up)
    with pytest.raises(OutputError, match=f"cannot write '{second}'.*every previous output is unchanged"):
        write_texts([(first, "new csv\n"), (second, "new urdf\n")])
    assert (first.read_text(), second.read_text()) == ("old csv\n", "old urdf\n")
    assert sorted(p.name for p in tmp_path.iterdir()) == ["measurements.csv", "truth.urdf"]
    monkeypatch.undo()
    assert write_texts([(first, "new csv\n"), (second, "new urdf\n")]) == [first, second]
    assert (first.read_text(), second.read_text()) == ("new csv\n", "new urdf\n")


def test_bytes_are_written_as_they_are(tmp_path: Path) -> None:
    """A mesh copy is bytes: written unchanged, beside a text written as UTF-8 with its line ends kept."""
    mesh, text = tmp_path / "m.stl", tmp_path / "t.urdf"
    data = bytes(range(256)) + b"\r\n"
    assert write_texts([(mesh, data), (text, "é\r\n")]) == [mesh, text]
    assert mesh.read_bytes() == data and text.read_bytes() == "é\r\n".encode()


#: A pincal write stopped at the instant of its rename, in a process of its own: ``kill`` (SIGKILL there, as a kill at
#: the worst moment would) or ``wait`` (say ``staged`` and rename only when a line comes on stdin: a live writer).
_WRITER = """
import os, signal, sys
from pincal.io import files
rename = os.replace
def stopped(source, target):
    if sys.argv[1] == "kill":
        os.kill(os.getpid(), signal.SIGKILL)
    print("staged", flush=True)
    sys.stdin.readline()
    rename(source, target)
os.replace = stopped
files.write_text(sys.argv[2], sys.argv[3])
"""


def _temporaries(folder: Path) -> list[str]:
    return sorted(p.name for p in folder.iterdir() if p.name.endswith(".part"))


def test_the_next_write_removes_a_killed_writes_temporary_and_keeps_a_live_one(tmp_path: Path) -> None:
    """A write killed at its rename leaves ``.NAME.XXXXXXXX.part`` (the old file intact); the next ``pincal`` that
    writes into the folder removes it, and keeps the temporary another pincal is writing at that moment, which that
    writer then renames as usual. Files of other naming stay."""
    folder = tmp_path / "out"
    folder.mkdir()
    (folder / "kinematics.yaml").write_text("old\n")
    killed = subprocess.run([sys.executable, "-c", _WRITER, "kill", str(folder / "kinematics.yaml"), "new\n"],
                            capture_output=True, text=True, timeout=120, check=False)
    assert killed.returncode == -signal.SIGKILL, killed.stderr
    stale = _temporaries(folder)
    assert len(stale) == 1 and re.fullmatch(r"\.kinematics\.yaml\.[a-z0-9_]{8}\.part", stale[0])
    assert (folder / "kinematics.yaml").read_text() == "old\n"
    others = [".notes.part", "kinematics.yaml.abcdefgh.part", ".kinematics.yaml.ABCDEFGH.part", ".x.abcdefg.part"]
    for name in others:
        (folder / name).write_text("not pincal's\n")
    with subprocess.Popen([sys.executable, "-c", _WRITER, "wait", str(folder / "live.csv"), "live\n"],
                          stdin=subprocess.PIPE, stdout=subprocess.PIPE, text=True) as live:
        assert live.stdout is not None and live.stdin is not None
        assert live.stdout.readline() == "staged\n"
        writing = [name for name in _temporaries(folder) if name.startswith(".live.csv.")]
        assert len(writing) == 1
        done = run_pincal("export", "ur10", "--out", str(folder / "ur10.yaml"))
        assert done.returncode == 0, done.stderr
        assert sorted(_temporaries(folder)) == sorted([*writing, *others])
        live.stdin.write("\n")
        live.stdin.close()
        assert live.wait(timeout=120) == 0
    assert (folder / "live.csv").read_text() == "live\n"
    assert sorted(_temporaries(folder)) == sorted(others)
    assert (folder / "kinematics.yaml").read_text() == "old\n"
