"""Malformed and extreme inputs as a new user makes them, through the ``pincal`` command: each gives one line naming
the culprit (exit 2) or a correct result, never a traceback, a crash or a hang. The files are made here."""

from __future__ import annotations

import os
import subprocess
from pathlib import Path

import pytest
from conftest import run_pincal


def one_line_error(done: subprocess.CompletedProcess[str]) -> str:
    """The single stderr line of a refused command (exit 2, no traceback)."""
    assert done.returncode == 2, (done.returncode, done.stdout[-2000:], done.stderr[-2000:])
    assert "Traceback" not in done.stderr
    lines = [line for line in done.stderr.splitlines() if line.strip()]
    assert len(lines) == 1, done.stderr
    assert lines[0].startswith("pincal: error: ")
    return lines[0]


def chain_urdf(joints: int, limit: str = "1.5", joint_type: str = "revolute", visual: str = "",
               name: str = "j") -> str:
    """A serial chain of ``joints`` joints about y, 0.1 m apart, limits ±``limit`` [rad]; ``visual`` (URDF
    ``<visual>`` elements) on link l1; joint k named ``{name}{k}``."""
    links = "".join(f'<link name="l{k}">{visual if k == 1 else ""}</link>' for k in range(joints + 1))
    body = "".join(f'<joint name="{name}{k}" type="{joint_type}"><parent link="l{k}"/><child link="l{k + 1}"/>'
                   f'<origin xyz="0 0 0.1"/><axis xyz="0 1 0"/>'
                   f'<limit lower="-{limit}" upper="{limit}" effort="1" velocity="1"/></joint>' for k in range(joints))
    return f'<?xml version="1.0"?>\n<robot name="chain{joints}">{links}{body}</robot>\n'


def write(folder: Path, name: str, text: str) -> Path:
    path = folder / name
    path.write_text(text, encoding="utf-8")
    return path


def test_joint_limits_beyond_the_floats_span_are_drawn_as_unbounded(tmp_path: Path) -> None:
    """Limits of ±1e308 (their span overflows): simulate draws about the reference, and calibrate reads the file."""
    urdf = write(tmp_path, "wide.urdf", chain_urdf(3, limit="1e308"))
    done = run_pincal("simulate", str(urdf), "--samples", "20", "--seed", "1", "--out", str(tmp_path / "sim"))
    assert done.returncode == 0, done.stderr
    assert "Overflow" not in done.stderr
    done = run_pincal("calibrate", str(urdf), str(tmp_path / "sim" / "measurements.csv"))
    assert done.returncode == 0, done.stderr


@pytest.mark.parametrize(("joint_type", "expected"), [
    ("revolute", "has 5000 joints; pincal takes at most 200"),
    ("fixed", "has 5000 <joint> elements; pincal takes at most 2000, fixed ones included"),
])
def test_a_chain_of_thousands_of_joints_is_refused_before_pinocchio_builds_it(tmp_path: Path, joint_type: str,
                                                                              expected: str) -> None:
    """Pinocchio's parser overflows the stack (SIGSEGV, no output) on a 5000-joint chain: counted in the XML first."""
    urdf = write(tmp_path, "long.urdf", chain_urdf(5000, joint_type=joint_type))
    assert expected in one_line_error(run_pincal("info", str(urdf)))


def test_a_chain_of_the_most_joints_pincal_takes_simulates(tmp_path: Path) -> None:
    """A 200-joint chain (the maximum) simulates in seconds (a long chain's Pinocchio data, 0.6 GB each, are made
    once, not once per joint: minutes and 1.2 GB before). About 10 s."""
    urdf = write(tmp_path, "c200.urdf", chain_urdf(200))
    done = run_pincal("simulate", str(urdf), "--samples", "3", "--quiet", "--out", str(tmp_path / "sim"), timeout=120)
    assert done.returncode == 0, done.stderr
    assert 'name="j199"' in (tmp_path / "sim" / "truth.urdf").read_text(encoding="utf-8")


def test_design_candidates_are_capped_like_samples() -> None:
    line = one_line_error(run_pincal("design", "five_bar", "--candidates", "100000000", "--poses", "3"))
    assert "--candidates 100000000: pincal draws at most 20000 candidate postures" in line


def test_a_job_file_nested_20000_deep_is_named(tmp_path: Path) -> None:
    job = write(tmp_path, "deep.toml", "robot = 'five_bar'\nx = " + "[" * 20000 + "]" * 20000 + "\n")
    assert one_line_error(run_pincal("calibrate", str(job))) == (
        f"pincal: error: {job}: arrays or tables nested too deeply to read; a job file nests a few levels")


def test_a_job_robot_name_too_long_for_a_file_name_is_named(tmp_path: Path) -> None:
    """A million-character robot name: once an OSError (file name too long) as an internal error."""
    job = write(tmp_path, "job.toml", f'robot = "{"x" * 1_000_000}"\n[data]\nfile = "a.csv"\n')
    assert "'a.csv' does not exist" in one_line_error(run_pincal("calibrate", str(job)))


def job_text(data: str) -> str:
    return (f'robot = "five_bar"\n[data]\nfile = "{data}"\nignore = ["sample", "set"]\n'
            '[[measure]]\nkind = "position"\nframe = "end_effector"\n'
            'columns = ["position:end_effector:x", "position:end_effector:y", "position:end_effector:z"]\n')


def test_a_job_file_with_a_utf8_bom_is_read_as_a_csv_with_one_is(five_bar_csv: Path, tmp_path: Path) -> None:
    job = tmp_path / "job.toml"
    job.write_bytes(b"\xef\xbb\xbf" + job_text(str(five_bar_csv)).encode("utf-8"))
    done = run_pincal("calibrate", str(job))
    assert done.returncode == 0, done.stderr
    assert "RMS" in done.stdout


def test_a_job_file_in_utf16_names_the_encoding(five_bar_csv: Path, tmp_path: Path) -> None:
    job = tmp_path / "job.toml"
    job.write_bytes(job_text(str(five_bar_csv)).encode("utf-16"))
    assert "a TOML job file's encoding is UTF-8" in one_line_error(run_pincal("calibrate", str(job)))


@pytest.mark.parametrize(("place", "expected"), [
    ("/dev/zero", "is not a regular file (a device, a pipe or a socket)"),
    ("loop", "cannot be opened: Too many levels of symbolic links"),
])
def test_a_data_path_that_is_a_device_or_a_link_loop_says_so(tmp_path: Path, place: str, expected: str) -> None:
    """Named as what it is, not "does not exist"; a device is never read (/dev/zero once ran out of memory)."""
    os.symlink("loop", tmp_path / "loop")
    job = write(tmp_path, "job.toml", job_text(place))
    line = one_line_error(run_pincal("calibrate", str(job)))
    assert expected in line and "does not exist" not in line
    line = one_line_error(run_pincal("calibrate", "five_bar", place, cwd=tmp_path, timeout=60))
    assert expected in line and "does not exist" not in line


def test_an_output_behind_a_link_loop_is_named(five_bar_csv: Path, tmp_path: Path) -> None:
    os.symlink("loop", tmp_path / "loop")
    line = one_line_error(run_pincal("calibrate", "five_bar", str(five_bar_csv), "--out", str(tmp_path / "loop")))
    assert "Too many levels of symbolic links" in line


@pytest.mark.parametrize("encoding", ["utf-16-le", "utf-16", "latin-1"])
def test_a_csv_not_in_utf8_names_the_encoding(five_bar_csv: Path, tmp_path: Path, encoding: str) -> None:
    """UTF-16 without its BOM (ASCII text: valid UTF-8 with NULs) once printed NUL bytes; every such file is named,
    without a NUL in the message; latin-1 with an accent is not UTF-8 either."""
    text = five_bar_csv.read_text(encoding="utf-8")
    text = text.replace("# robot", "# é robot", 1) if encoding == "latin-1" else text
    data = tmp_path / "data.csv"
    data.write_bytes(text.encode(encoding))
    line = one_line_error(run_pincal("calibrate", "five_bar", str(data)))
    assert "is not UTF-8 text" in line and "encoding" in line and "\x00" not in line


#: Visuals pincal cannot draw, on links l1, l2, l3, and the note each gets.
BAD_VISUALS = [
    ('<box size="a b c"/>', 'visual 0 (box) not drawn: size="a b c" is not 3 finite numbers ≥ 0'),
    ('<cylinder radius="r" length="1"/>', 'visual 0 (cylinder) not drawn: radius="r" is not 1 finite number ≥ 0'),
    ('<mesh filename="m.stl" scale="2 2"/>', 'visual 0 (mesh) not drawn: scale="2 2" is not 3 finite numbers'),
]


def test_visuals_with_bad_geometry_are_left_out_with_a_note(tmp_path: Path) -> None:
    """info, simulate and calibrate take the file (they draw nothing); view and report draw the robot without those
    visuals and say so (view on the terminal and the page, report on the page): report once failed with a ValueError."""
    (tmp_path / "m.stl").write_text("solid m\nendsolid m\n", encoding="utf-8")
    text = chain_urdf(3)
    for k, (geometry, _) in enumerate(BAD_VISUALS, start=1):
        text = text.replace(f'<link name="l{k}"></link>',
                            f'<link name="l{k}"><visual><geometry>{geometry}</geometry></visual></link>')
    urdf = write(tmp_path, "arm.urdf", text)
    done = run_pincal("simulate", str(urdf), "--samples", "12", "--quiet", "--out", str(tmp_path / "sim"))
    assert done.returncode == 0, done.stderr
    data = str(tmp_path / "sim" / "measurements.csv")
    done = run_pincal("view", str(urdf), data, "--out", str(tmp_path / "view.html"))
    assert done.returncode == 0, done.stderr
    for k, (_, note) in enumerate(BAD_VISUALS, start=1):
        assert f"  note: link 'l{k}': {note}" in done.stdout.splitlines()
    done = run_pincal("report", str(urdf), data, "--out", str(tmp_path / "report.html"))
    assert done.returncode == 0, done.stderr
    page = (tmp_path / "report.html").read_text(encoding="utf-8")
    assert all(note.replace('"', "&quot;") in page for _, note in BAD_VISUALS)


def test_simulate_refuses_a_name_its_data_could_not_be_read_back_with(tmp_path: Path) -> None:
    """A 200 000-character joint name: simulate wrote a file calibrate then refused; now simulate refuses it (one
    line, nothing written)."""
    urdf = write(tmp_path, "arm.urdf", chain_urdf(3).replace('name="j1"', f'name="{"J" * 200_000}"'))
    line = one_line_error(run_pincal("simulate", str(urdf), "--samples", "12", "--out", str(tmp_path / "sim")))
    assert "(200000 characters) cannot be read back from a CSV file (at most 131072 characters" in line
    assert not (tmp_path / "sim").exists()


def test_replacing_an_existing_output_is_said(five_bar_csv: Path, tmp_path: Path) -> None:
    out = tmp_path / "sim"
    first = run_pincal("simulate", "five_bar", "--samples", "5", "--out", str(out))
    assert first.returncode == 0 and "replaced" not in first.stdout
    again = run_pincal("simulate", "five_bar", "--samples", "5", "--out", str(out))
    assert again.returncode == 0, again.stderr
    assert again.stdout.splitlines()[-1] == (f"note: replaced the existing files {out / 'measurements.csv'}, "
                                             f"{out / 'truth.urdf'}, {out / 'truth.json'}")
    cal = tmp_path / "cal.urdf"
    for replaced in (False, True):
        done = run_pincal("calibrate", "five_bar", str(five_bar_csv), "--out", str(cal))
        assert done.returncode == 0, done.stderr
        assert (f"note: replaced the existing file {cal}" in done.stdout) is replaced


def test_montecarlo_trials_and_samples_are_capped() -> None:
    """A hundred million trials (or postures) ends at once in one line, as ``design --candidates`` does."""
    line = one_line_error(run_pincal("montecarlo", "five_bar", "--trials", "100000000"))
    assert "--trials 100000000: pincal runs at most 10000 trials per noise level" in line
    line = one_line_error(run_pincal("montecarlo", "five_bar", "--samples", "100000000"))
    assert "pincal simulates at most 20000 postures of each" in line
