"""``pincal filter`` on files a user may hand it by mistake or in a form the examples do not show: an empty or a
binary file is one error line (exit 2, nothing written); a Latin-1 program (KUKA's and ABB's editors write one, with
``ä``, ``ö`` in comments) is written back in Latin-1 with its Windows line endings, every line not rewritten
byte-identical. The robot's own URDF as the model: nothing moves, so these tests need no calibration."""

from __future__ import annotations

from pathlib import Path

import pytest
from conftest import ROOT, run_pincal

PROGRAMS = ROOT / "examples" / "data" / "programs"
KR16 = ROOT / "examples" / "data" / "robots" / "kr16_like.urdf"


@pytest.mark.parametrize(("content", "says"), [(b"", "is empty"), (b" \r\n\t\r\n", "is empty"),
                                                (b"def p():\x00\x01\x9e\xff", "is not a text file (byte 0x00")])
def test_an_empty_or_binary_program_is_an_error(tmp_path: Path, content: bytes, says: str) -> None:
    program = tmp_path / "cell.script"
    program.write_bytes(content)
    done = run_pincal("filter", str(program), "--model", "ur10", "--out", str(tmp_path / "out.script"))
    assert done.returncode == 2
    assert done.stderr.strip().splitlines() == [done.stderr.strip()]
    assert done.stderr.startswith("pincal: error: PROGRAM") and str(program) in done.stderr and says in done.stderr
    assert "Traceback" not in done.stderr and not (tmp_path / "out.script").exists()


def test_a_latin1_program_is_written_back_in_latin1_byte_for_byte(tmp_path: Path) -> None:
    source = tmp_path / "in"
    source.mkdir()
    for name in ("palletize.src", "palletize.dat"):
        text = (PROGRAMS / name).read_text(encoding="utf-8").replace("\n", "\r\n")
        if name.endswith(".src"):
            text = "; Greifer öffnen, Maß in mm\r\n" + text
        (source / name).write_bytes(text.encode("latin-1"))
    out = tmp_path / "out" / "palletize.src"
    done = run_pincal("filter", str(source / "palletize.src"), "--model", str(KR16), "--config",
                      str(PROGRAMS / "config_excerpt.dat"), "--out", str(out))
    assert done.returncode in (0, 1), done.stderr
    for name in ("palletize.src", "palletize.dat"):
        before = (source / name).read_bytes().split(b"\r\n")
        after = (out.parent / name).read_bytes().split(b"\r\n")
        assert len(after) == len(before)
        assert b"\n" not in b"".join(after)  # every line ending kept as \r\n
        if name.endswith(".src"):
            assert after[0] == "; Greifer öffnen, Maß in mm".encode("latin-1")
        targets = [k for k, line in enumerate(before) if b"{X " in line]
        assert targets  # the lines with Cartesian targets; every other line is byte-identical
        assert [a for k, a in enumerate(after) if k not in targets] == [
            b for k, b in enumerate(before) if k not in targets]


def test_a_robtarget_of_five_parts_is_named_not_rewritten(tmp_path: Path) -> None:
    text = (PROGRAMS / "glue.mod").read_text(encoding="utf-8")
    declared = "CONST robtarget pApproach:=[[100,200,150],[0.086824,0.492404,0.852869,-0.150384],[0,0,-1,0],[9E9,9E9,"
    assert declared in text
    end = "9E9,9E9,9E9,9E9]];\n    CONST robtarget pStart"
    bad = text.replace(end, end.replace("]];", "],[1,2]];"), 1)
    assert bad != text
    program = tmp_path / "glue.mod"
    program.write_text(bad, encoding="utf-8")
    out = tmp_path / "out.mod"
    done = run_pincal("filter", str(program), "--model", str(KR16), "--out", str(out))
    assert done.returncode == 1, done.stderr
    line = 1 + bad[:bad.index(declared)].count("\n")
    assert f"warning: {program} line {line}: 'pApproach': a robtarget has 4 parts" in done.stdout
    before, after = bad.splitlines(), out.read_text(encoding="utf-8").splitlines()
    assert after[line - 1] == before[line - 1]


def test_krl_points_at_b_90_keep_their_angles_when_nothing_moves(tmp_path: Path) -> None:
    """The example's points are written at ``B 90`` (the tool pointing down), where only ``A − C`` is defined: the
    robot's own URDF as the model moves nothing, and each point's numbers read back as written (before, ``A`` and ``C``
    came back as ``-79.69772`` each)."""
    import re

    out = tmp_path / "out" / "palletize.src"
    done = run_pincal("filter", str(PROGRAMS / "palletize.src"), "--model", str(KR16), "--config",
                      str(PROGRAMS / "config_excerpt.dat"), "--out", str(out))
    assert done.returncode in (0, 1), done.stderr
    aggregate = re.compile(r"\{X [^}]*\}")
    checked = 0
    for name in ("palletize.src", "palletize.dat"):
        before = (PROGRAMS / name).read_text(encoding="utf-8").splitlines()
        after = (out.parent / name).read_text(encoding="utf-8").splitlines()
        for was, now in zip(before, after, strict=True):
            if was == now:
                continue
            old, new = aggregate.search(was), aggregate.search(now)
            assert old is not None and new is not None
            values = [re.findall(r"([A-Z]\w*) (-?[\d.]+)", m.group(0)) for m in (old, new)]
            assert [k for k, _ in values[0]] == [k for k, _ in values[1]]
            for (key, a), (_, b) in zip(*values, strict=True):
                assert abs(float(a) - float(b)) < 1e-3, (now, key)
            checked += 1
    assert checked >= 6


def test_krl_files_in_upper_case_are_written_as_a_pair(tmp_path: Path) -> None:
    """``PALLETIZE.SRC`` with ``PALLETIZE.DAT`` (as a controller's backup may name them): both read and both written;
    before, the ``.DAT`` was read but not planned as an output, and the run ended in an error after the work."""
    for name in ("palletize.src", "palletize.dat"):
        (tmp_path / name.upper()).write_bytes((PROGRAMS / name).read_bytes())
    out = tmp_path / "out" / "PALLETIZE.SRC"
    done = run_pincal("filter", str(tmp_path / "PALLETIZE.SRC"), "--model", str(KR16), "--config",
                      str(PROGRAMS / "config_excerpt.dat"), "--out", str(out))
    assert done.returncode in (0, 1), done.stderr
    assert sorted(p.name for p in out.parent.iterdir()) == ["PALLETIZE.DAT", "PALLETIZE.SRC"]
    assert f"wrote {out.parent / 'PALLETIZE.DAT'}" in done.stdout
    assert "XP1" in done.stdout and "rewritten" in done.stdout


def test_krl_written_under_another_name_is_told_it_keeps_its_module_name(tmp_path: Path) -> None:
    out = tmp_path / "palletize_cal.src"
    done = run_pincal("filter", str(PROGRAMS / "palletize.src"), "--model", str(KR16), "--config",
                      str(PROGRAMS / "config_excerpt.dat"), "--out", str(out))
    assert done.returncode in (0, 1), done.stderr
    assert "note: KRL names a module by its files: palletize_cal.src still declares the module 'palletize'" in \
        done.stdout
    assert (tmp_path / "palletize_cal.dat").is_file()
    same = run_pincal("filter", str(PROGRAMS / "palletize.src"), "--model", str(KR16), "--config",
                      str(PROGRAMS / "config_excerpt.dat"), "--out", str(tmp_path / "kept" / "palletize.src"))
    assert same.returncode in (0, 1), same.stderr
    assert "note: KRL names" not in same.stdout


def test_a_model_of_another_robot_is_refused(tmp_path: Path) -> None:
    """The UR10 as MODEL for a controller that keeps a UR5 (``--nominal ur5``): one error line naming both, nothing
    written; before, every target was 'left as written' for being 'on another branch', exit 0 or 1."""
    out = tmp_path / "out.script"
    done = run_pincal("filter", str(PROGRAMS / "pick_place.script"), "--model", "ur10", "--nominal", "ur5", "--out",
                      str(out))
    assert done.returncode == 2
    assert done.stderr.startswith("pincal: error: MODEL (ur10) puts the flange ")
    assert "the nominal robot 'ur5'" in done.stderr and "Traceback" not in done.stderr
    assert len(done.stderr.strip().splitlines()) == 1 and not out.exists()


def test_old_mac_line_ends_are_read_as_lines_and_kept(tmp_path: Path) -> None:
    """Carriage returns alone end the lines: the targets are found on their lines, every byte but their numbers kept;
    ``p [`` with a space is a pose literal, as URScript reads it."""
    text = (PROGRAMS / "pick_place.script").read_text(encoding="utf-8")
    assert text.count("p[") >= 6 and "\r" not in text
    spaced = text.replace("p[", "p [")
    program = tmp_path / "cell.script"
    program.write_bytes(spaced.replace("\n", "\r").encode("utf-8"))
    out = tmp_path / "out.script"
    (tmp_path / "sub").mkdir()
    done = run_pincal("filter", "./sub/../cell.script", "--model", "ur10", "--out", "out.script", cwd=tmp_path)
    assert done.returncode == 0, done.stdout + done.stderr
    assert done.stdout.startswith("filter: cell.script (urscript), 6 Cartesian and 2 joint targets")  # normalised
    assert "warning" not in done.stdout
    listed = [line.split()[0] for line in done.stdout.splitlines()[2:8]]
    lines = spaced.split("\n")
    assert listed == ["6", "7", "14", "15", "15", "16"]
    assert all("p [" in lines[int(k) - 1] for k in listed)  # the lines (1-based) holding the targets
    before, after = program.read_bytes().split(b"\r"), out.read_bytes().split(b"\r")
    assert len(after) == len(before) and b"\n" not in out.read_bytes()
    changed = {k for k, (a, b) in enumerate(zip(before, after, strict=True)) if a != b}
    assert changed <= {int(k) - 1 for k in listed} | {k for k, line in enumerate(lines) if "=p [" in line
                                                      or "= p [" in line}
    assert all(b"p [" in after[k] for k in changed)


def test_a_lone_src_names_its_missing_dat(tmp_path: Path) -> None:
    program = tmp_path / "palletize.src"
    program.write_bytes((PROGRAMS / "palletize.src").read_bytes())
    done = run_pincal("filter", str(program), "--model", str(KR16), "--config", str(PROGRAMS / "config_excerpt.dat"),
                      "--out", str(tmp_path / "out" / "palletize.src"))
    assert done.returncode == 1
    missing = [line for line in done.stdout.splitlines() if "is missing" in line]
    assert missing and all(f"the .src has no .dat beside it: {tmp_path / 'palletize.dat'} is missing" in line
                           for line in missing)
    assert any("point 'XP1': never declared" in line for line in missing)


def test_a_program_of_one_maker_on_a_robot_named_for_another_is_warned(tmp_path: Path) -> None:
    done = run_pincal("filter", str(PROGRAMS / "pick_place.script"), "--model", str(KR16), "--out",
                      str(tmp_path / "out.script"))
    assert done.returncode == 0  # the KUKA-like arm reaches the UR program's poses: nothing else tells
    assert ("warning: the program is URScript (the language of Universal Robots) but robot 'kr16_like' is named like "
            "a KUKA arm") in done.stdout
