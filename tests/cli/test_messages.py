"""Messages that name what went wrong, as a user meets them on the command line: joint columns exchanged or read with
the other sign named before the fit (and after it, as the likely cause), the samples dropped outside the joint limits
named when too few remain, a σ line for readings the file lacks, a negative σ in scientific notation, the joints left at
their reference listed to the end, and every summary line within 120 columns."""

from __future__ import annotations

from pathlib import Path

import pytest
from conftest import ROOT, run_pincal


def _simulate(folder: Path, robot: str, samples: int, seed: int, *extra: str) -> Path:
    done = run_pincal("simulate", robot, "--samples", str(samples), "--seed", str(seed), "--quiet", "--out",
                      str(folder), *extra)
    assert done.returncode == 0, done.stderr
    return folder / "measurements.csv"


def _edited(source: Path, target: Path, header: dict[str, str] | None = None,
            cells: dict[str, tuple[str, int]] | None = None, negate: str | None = None,
            keep: tuple[str, ...] | None = None, extra_line: str | None = None) -> Path:
    """``source`` with header names replaced (``header``: old -> new, at once), a column's cells from a row on set to a
    value (``cells``: column -> (value, first row)), a column negated, only the columns starting with ``keep`` (and
    sample, set), and a comment line added before the header."""
    lines = source.read_text(encoding="utf-8").splitlines()
    start = next(k for k, line in enumerate(lines) if not line.startswith("#"))
    names = lines[start].split(",")
    rows = [line.split(",") for line in lines[start + 1:]]
    for k, row in enumerate(rows):
        for column, (value, first) in (cells or {}).items():
            if k >= first:
                row[names.index(column)] = value
        if negate is not None:
            row[names.index(negate)] = repr(-float(row[names.index(negate)]))
    names = [(header or {}).get(name, name) for name in names]
    chosen = [c for c, name in enumerate(names) if keep is None or name in ("sample", "set") or name.startswith(keep)]
    table = [",".join(row[c] for c in chosen) for row in [names, *rows]]
    comments = lines[:start] + ([extra_line] if extra_line else [])
    target.write_text("\n".join([*comments, *table]) + "\n", encoding="utf-8")
    return target


def _one_line(done: object) -> str:
    assert done.returncode == 2 and done.stdout == "", (done.stdout, done.stderr)  # type: ignore[attr-defined]
    lines = done.stderr.splitlines()  # type: ignore[attr-defined]
    assert len(lines) == 1 and "Traceback" not in done.stderr, done.stderr  # type: ignore[attr-defined]
    return str(lines[0])


def test_two_joint_columns_exchanged_are_named_not_the_sample_count(tmp_path: Path) -> None:
    """A Panda file with the columns of joints 2 and 4 exchanged: 35 of 40 rows lie outside the joint limits; once
    the run said '15 residuals cannot identify 46 parameters ... add samples'."""
    data = _simulate(tmp_path / "sim", "panda", 40, 4)
    swapped = _edited(data, tmp_path / "swapped.csv", header={"panda_joint2": "panda_joint4",
                                                               "panda_joint4": "panda_joint2"})
    line = _one_line(run_pincal("calibrate", "panda", str(swapped)))
    assert line.startswith("pincal: error: the columns of joints 'panda_joint2' and 'panda_joint4' look exchanged: "
                           "with the two exchanged, 40 of 40 samples are usable (5 as read) and the nominal robot's "
                           "RMS position error at the start falls from "), line
    assert line.endswith("; exchange the two columns' names, or give --plausible off to fit the readings as they are")
    assert "residuals cannot identify" not in line


def test_too_few_samples_left_within_the_joint_limits_names_the_drop(tmp_path: Path) -> None:
    """Readings of panda_joint4 outside its limits in 35 of 40 rows (and no exchange or sign explains them): the 15
    residuals left cannot identify 46 parameters, and the line says where the other 35 samples went."""
    data = _simulate(tmp_path / "sim", "panda", 40, 4)
    outside = _edited(data, tmp_path / "outside.csv", cells={"panda_joint4": ("1.0", 5)})
    line = _one_line(run_pincal("calibrate", "panda", str(outside)))
    assert "15 residuals cannot identify 46 parameters" in line, line
    assert line.endswith("or correct those dropped: 35 of the 40 samples were dropped before the fit: 35 with a "
                         "reading outside the URDF joint limits (panda_joint4 in 35)"), line


def test_a_delta_arm_read_with_the_other_sign_is_named_before_the_fit(tmp_path: Path) -> None:
    """Once the fit ran for a minute of CPU (285 iterations, bad-reading searches and model selection's refits, forward
    kinematics by continuation) to an implausible result or a forward kinematics that did not converge."""
    data = _simulate(tmp_path / "sim", "delta", 30, 1)
    flipped = _edited(data, tmp_path / "flipped.csv", negate="arm_1_joint")
    line = _one_line(run_pincal("calibrate", "delta", str(flipped), "--out", str(tmp_path / "cal.urdf")))
    assert line.startswith("pincal: error: joint 'arm_1_joint' looks read with the other sign: with it negated, 30 of "
                           "30 samples are usable (28 as read) and the nominal robot's RMS position error at the start "
                           "falls from "), line
    assert line.endswith("; negate that column, or give --plausible off to fit the readings as they are")
    assert not (tmp_path / "cal.urdf").exists()


def test_a_ur10_wrist_read_with_the_other_sign_is_the_likely_cause(tmp_path: Path) -> None:
    """The start does not look wrong enough to stop before the fit (130 mm over a 0.8 m workspace); the prior keeps
    the fit from turning the wrist over, so it explains nothing (exit 1), and names the cause: the joint read with the
    other sign, not 'a wrong robot model'."""
    data = _simulate(tmp_path / "sim", "ur10", 40, 1)
    flipped = _edited(data, tmp_path / "flipped.csv", negate="wrist_2_joint")
    done = run_pincal("calibrate", "ur10", str(flipped))
    assert done.returncode == 1, done.stderr
    summary = " ".join(line.strip() for line in done.stdout.splitlines())
    assert "likely cause: joint 'wrist_2_joint' looks read with the other sign: with it negated, the nominal robot's " \
           "RMS position error at the start falls from " in summary, done.stdout
    assert "negate that column" in summary and "wrong robot model" not in summary


@pytest.mark.parametrize(("line", "missing"), [("# sigma camera: 1e-4", "camera"),
                                               ("# sigma position elbow: 1e-4", "position:elbow")])
def test_a_sigma_line_for_readings_the_file_lacks_is_refused(tmp_path: Path, line: str, missing: str) -> None:
    """Once ignored, the summary then saying σ was estimated from the data."""
    data = _simulate(tmp_path / "sim", "ur10", 12, 1)
    stray = _edited(data, tmp_path / "stray.csv", extra_line=line)
    refused = _one_line(run_pincal("calibrate", "ur10", str(stray)))
    assert refused == (f"pincal: error: metadata '{line}' states a σ for readings the file does not have (no "
                       f"{missing} columns; its measurements are position:tool0): remove the line, or name a kind or "
                       "frame of those")


def test_a_negative_sigma_in_scientific_notation_is_refused_as_negative(tmp_path: Path) -> None:
    """argparse took '-1e-5' for an option: 'expected one argument'."""
    line = _one_line(run_pincal("calibrate", "ur10", str(tmp_path / "absent.csv"), "--sigma", "-1e-5"))
    assert line == ("pincal: error: calibrate: argument --sigma: -1e-5 is not a finite number > 0 (see 'pincal "
                    "calibrate --help')")
    line = _one_line(run_pincal("simulate", "ur10", "--noise", "-2E-3", "--out", str(tmp_path / "sim")))
    assert line == "pincal: error: simulate: argument --noise: -2E-3 is not a finite number ≥ 0 (see 'pincal " \
                   "simulate --help')"


def test_the_joints_left_at_their_reference_are_counted_to_the_end(tmp_path: Path) -> None:
    """A TALOS file with the torso and left arm only: 23 joints stay at their reference; the line stopped after 14
    of them on a trailing comma."""
    data = _simulate(tmp_path / "sim", "talos", 20, 1, "--frame", "gripper_left_base_link")
    left = _edited(data, tmp_path / "left.csv", keep=("torso", "arm_left", "position"))
    done = run_pincal("calibrate", "talos", str(left))
    assert done.returncode == 0, done.stderr
    lines = done.stdout.splitlines()
    start = next(k for k, line in enumerate(lines) if line.startswith("not in the file, at their reference"))
    listed = " ".join(line.strip() for line in lines[start:start + 3])
    assert lines[start + 3].strip() == "" or not lines[start + 3].startswith("  "), lines[start:start + 4]
    shown = listed.partition(": ")[2].partition(", and ")[0].split(", ")
    more = int(listed.rpartition(", and ")[2].split()[0])
    assert len(shown) + more == 23 and listed.endswith("more (the report's joints_at_reference)"), listed
    assert shown[0] == "gripper_left_joint" and not listed.rstrip().endswith(",")


def test_every_summary_line_fits_a_120_column_terminal(tmp_path: Path) -> None:
    """The TIAGo CSV and job, the TALOS contact jobs, a simulated UR10 camera: none wraps on a 120-column terminal
    (the note under G and the 'before:' line once ran to 147 and 157 characters)."""
    camera = _simulate(tmp_path / "camera", "ur10", 20, 1, "--measure", "camera:tool0", "--test-samples", "5")
    runs = [("tiago_no_hand", str(ROOT / "examples" / "data" / "tiago_mocap_marker1.csv")),
            (str(ROOT / "examples" / "tiago_job.toml"),),
            (str(ROOT / "examples" / "data" / "talos_table_contact" / "left_job.toml"),),
            (str(ROOT / "examples" / "data" / "talos_table_contact" / "right_job.toml"),),
            ("ur10", str(camera))]
    for run in runs:
        done = run_pincal("calibrate", *run)
        assert done.returncode in (0, 1) and done.stdout, done.stderr
        wide = [line for line in done.stdout.splitlines() if len(line) > 120]
        assert not wide, (run, wide)
    done = run_pincal("demo", "--samples", "20", "--test-samples", "5", "--out", str(tmp_path / "demo"))
    assert done.returncode == 0, done.stderr
    assert "calibration gain G" in done.stdout
    assert not [line for line in done.stdout.splitlines() if len(line) > 120 and not line.startswith("wrote ")]


def test_the_report_page_names_the_robot_as_the_user_gave_it_and_no_none(tmp_path: Path) -> None:
    """From a job file the page's subtitle ended in a literal 'None' (no DATA on the command line), and the page and
    the terminal named the robot 'tiago' (its URDF's <robot name>) where the user gave tiago_no_hand."""
    page = tmp_path / "r.html"
    job = ROOT / "examples" / "tiago_job.toml"
    done = run_pincal("report", str(job), "--out", str(page))
    assert done.returncode == 0, done.stderr
    assert "calibrating 'tiago_no_hand' (URDF <robot name=\"tiago\">) from 34 samples ..." in done.stdout
    text = page.read_text(encoding="utf-8")
    title = text.partition("<h1>")[2].partition("</h1>")[0]
    subtitle = text.partition('<p class="sub">')[2].partition("</p>")[0]
    assert title == "Calibration of tiago_no_hand", title
    assert subtitle.endswith(f"{job} · URDF &lt;robot name=&quot;tiago&quot;&gt;") and "None" not in subtitle, subtitle
    done = run_pincal("simulate", "tiago_no_hand", "--samples", "3", "--quiet", "--out", str(tmp_path / "sim"))
    assert done.returncode == 0, done.stderr
    assert done.stdout.startswith("simulated 3 + 0 postures of 'tiago_no_hand' (URDF <robot name=\"tiago\">) with ")
    done = run_pincal("simulate", "ur10", "--samples", "3", "--quiet", "--out", str(tmp_path / "ur10"))
    assert done.stdout.startswith("simulated 3 + 0 postures of 'ur10' with "), done.stdout  # one name: said once


def test_a_deltas_swapped_arms_name_every_pair_the_data_cannot_tell_apart(tmp_path: Path) -> None:
    """The Delta's three arms are alike: arms 1 and 2 exchanged start as well as any other pair exchanged (the
    measurement frame turned by a third of a turn) or the positions mirrored. The refusal names them all and says the
    data cannot tell which, rather than one pair a user would then fix wrongly."""
    data = _simulate(tmp_path / "sim", "delta", 60, 1)
    swapped = _edited(data, tmp_path / "swapped.csv",
                      header={"arm_1_joint": "arm_2_joint", "arm_2_joint": "arm_1_joint"})
    done = run_pincal("calibrate", "delta", str(swapped))
    line = _one_line(done)
    assert done.returncode == 2 and line.startswith("pincal: error: "), line
    for a, b in (("arm_1_joint", "arm_2_joint"), ("arm_1_joint", "arm_3_joint"), ("arm_2_joint", "arm_3_joint")):
        assert f"'{a}' and '{b}'" in line, line
    assert "the data cannot tell which" in line and "check which of them it is" in line
