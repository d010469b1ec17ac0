"""Bad or unusual input on the command line, as a user meets it: one line naming the culprit, exit 2, no
traceback; files as spreadsheets write them are read."""

from __future__ import annotations

import json
import os
import re
import signal
import stat
import subprocess
import time
from pathlib import Path

import pytest
from conftest import LIGHT_ARM_OPTIONS, PINCAL, ROOT, run_pincal

import pincal


@pytest.fixture(scope="module")
def five_bar_data(five_bar_csv: Path) -> Path:
    return five_bar_csv


def one_line_error(done: subprocess.CompletedProcess[str]) -> str:
    """The single stderr line of a refused command (exit 2, no traceback)."""
    assert done.returncode == 2, (done.stdout, done.stderr)
    assert "Traceback" not in done.stderr
    lines = [line for line in done.stderr.splitlines() if line.strip() and not line.startswith(("usage:", " "))]
    assert len(lines) == 1, done.stderr
    return lines[0]


@pytest.mark.parametrize(("args", "culprit"), [
    (["simulate", "five_bar", "--seed", "-1", "--out", "unused"], "--seed: -1 is negative"),
    (["simulate", "five_bar", "--samples", "0", "--out", "unused"], "--samples: 0 is not a positive whole number"),
    (["simulate", "five_bar", "--noise=-1e-5", "--out", "unused"], "--noise: -1e-5 is not a finite number ≥ 0"),
    (["simulate", "five_bar", "--perturb", "nan", "--out", "unused"], "--perturb: nan is not a finite number ≥ 0"),
    (["montecarlo", "five_bar", "--trials", "0"], "--trials: 0 is not a positive whole number"),
    (["design", "five_bar", "--poses", "-3"], "--poses: -3 is not a positive whole number"),
])
def test_out_of_range_numbers_are_refused_by_name(args: list[str], culprit: str) -> None:
    assert culprit in one_line_error(run_pincal(*args))


@pytest.mark.parametrize("sigma", ["0", "-1", "inf"])
def test_sigma_must_be_positive(five_bar_data: Path, sigma: str) -> None:
    line = one_line_error(run_pincal("calibrate", "five_bar", str(five_bar_data), f"--sigma={sigma}"))
    assert f"--sigma: {sigma} is not a finite number > 0" in line


@pytest.mark.parametrize("command", ["calibrate", "report", "view"])
def test_a_cv_seed_that_seeds_nothing_is_refused_in_the_flags_words(five_bar_data: Path, tmp_path: Path,
                                                                    command: str) -> None:
    """--cv-seed seeds the shuffles of K-fold plans: refused (before any work) with --cv loo, which has none, and
    without --cv; each message names the flags as typed."""
    page = tmp_path / "page.html"
    out = [] if command == "calibrate" else ["--out", str(page)]
    line = one_line_error(run_pincal(command, "five_bar", str(five_bar_data), "--cv", "loo", "--cv-seed", "5", *out))
    assert line == ("pincal: error: --cv-seed 5 seeds the shuffles of K-fold plans; --cv loo has none (it leaves each "
                    "sample out in turn): drop --cv-seed, or cross-validate by K folds (e.g. --cv 5x4)")
    line = one_line_error(run_pincal(command, "five_bar", str(five_bar_data), "--cv-seed", "5", *out))
    assert line == "pincal: error: --cv-seed 5 seeds the shuffles of --cv; give --cv too (e.g. --cv 5x4)"
    assert not page.exists()


@pytest.mark.parametrize("command", ["calibrate", "report", "view"])
def test_select_cv_cross_validated_by_leave_one_out_or_many_folds_is_refused(five_bar_data: Path, tmp_path: Path,
                                                                             command: str) -> None:
    """--select cv is itself a 5-fold cross-validation of every combination of groups, which each fold of --cv
    repeats: with --cv loo (one fold per sample) or more than 20 folds it would fit for minutes, so it is refused
    before any work, naming the cost and the alternatives (issue 36)."""
    page = tmp_path / "page.html"
    out = [] if command == "calibrate" else ["--out", str(page)]
    refusal = ("pincal: error: --select cv with --cv {cv} would repeat the cv selection (its own 5-fold "
               "cross-validation of every combination of parameter groups) in {folds}: minutes to hours of fitting; "
               "cross-validate by fewer folds (--cv 5 or --cv 5x4), or leave --select at its default")
    for cv, folds in (("loo", "each of its folds (one per sample)"), ("7x3", "each of its 21 folds")):
        line = one_line_error(run_pincal(command, "five_bar", str(five_bar_data), "--select", "cv", "--cv", cv,
                                         *out))
        assert line == refusal.format(cv=cv, folds=folds)
    assert not page.exists()


def test_a_payload_on_links_without_mass_is_noted_not_weighed_against_them(light_arm: tuple[Path, Path]) -> None:
    """A URDF whose links carry no <inertial>: "outweighs all the robot's moving links together (0 kg)" would be
    true of any payload and mean nothing, so no such warning; a note says that nothing weighs the payload and that
    the compliances rest on its torque alone."""
    urdf, data = light_arm
    done = run_pincal("calibrate", str(urdf), str(data), *LIGHT_ARM_OPTIONS)
    assert done.returncode == 0, done.stderr
    assert "outweighs" not in done.stdout
    assert ("note: the URDF gives the robot's moving links no mass (no <inertial>), so the payload's 2 kg cannot be "
            "checked against theirs, and the compliances rest on its gravity torque alone: right for a light arm "
            "under a heavy tool, wrong if the URDF merely leaves the masses out") in " ".join(done.stdout.split())
    assert any(line.startswith("note: the URDF gives the robot's moving links no mass") for line in
               done.stdout.splitlines())  # a line of its own, wrapped within 120 columns


def test_a_300_character_robot_name_is_named_not_a_traceback() -> None:
    line = one_line_error(run_pincal("info", "x" * 300))
    assert line.startswith("pincal: error: no robot file or known robot named 'xxx")


def test_a_utf8_bom_as_spreadsheets_write_is_accepted(five_bar_data: Path, tmp_path: Path) -> None:
    with_bom = tmp_path / "bom.csv"
    with_bom.write_bytes(b"\xef\xbb\xbf" + five_bar_data.read_bytes())
    reports = []
    for name, data in (("plain", five_bar_data), ("bom", with_bom)):
        report = tmp_path / f"{name}.json"
        done = run_pincal("calibrate", "five_bar", str(data), "--parameters", "*.offset", "--report", str(report))
        assert done.returncode == 0, done.stderr
        reports.append(json.loads(report.read_text()))
    assert reports[0]["parameters"] == reports[1]["parameters"] and reports[0]["n_samples"] == 12


def test_a_number_with_an_underscore_is_refused(five_bar_data: Path, tmp_path: Path) -> None:
    lines = five_bar_data.read_text().splitlines()
    row = next(k for k, line in enumerate(lines) if line.startswith("3,"))
    cells = lines[row].split(",")
    cells[2] = cells[2].replace(".", "_", 1) if "." in cells[2] else cells[2] + "_0"
    lines[row] = ",".join(cells)
    bad = tmp_path / "underscore.csv"
    bad.write_text("\n".join(lines) + "\n")
    line = one_line_error(run_pincal("calibrate", "five_bar", str(bad)))
    assert f"line {row + 1}: '{cells[2]}' is not a number" in line


def test_a_closed_pipe_ends_quietly(five_bar_data: Path) -> None:
    """``pincal ... | head -1``: the reader leaves early; pincal must not print a BrokenPipeError traceback."""
    done = subprocess.run(["bash", "-c", f"'{PINCAL}' calibrate five_bar '{five_bar_data}' --parameters '*.offset' "
                                         "| head -c 1"], capture_output=True, text=True, timeout=300, check=False)
    assert done.stdout and "Traceback" not in done.stderr and "BrokenPipe" not in done.stderr


def test_a_csv_cell_over_the_field_limit_is_named(tmp_path: Path) -> None:
    big = tmp_path / "big.csv"
    big.write_text("sample,set,arm_1_joint,arm_2_joint,arm_3_joint\n0,train," + "1" * 140_000 + ",0,0\n")
    line = one_line_error(run_pincal("calibrate", "delta", str(big)))
    assert "line 2: field larger than field limit (131072) (a cell of 140000 characters)" in line


def test_a_file_with_too_many_rows_is_refused_at_once_with_the_size_it_can_take(tmp_path: Path) -> None:
    from pincal.io.dataset import MAX_SAMPLES

    rows = MAX_SAMPLES + 1
    big = tmp_path / "big.csv"
    big.write_text("# robot: delta\nsample,set,arm_1_joint,arm_2_joint,arm_3_joint,position:end_effector:x,"
                   "position:end_effector:y,position:end_effector:z\n"
                   + "".join(f"{k},train,0.1,0.2,0.3,0.0,0.0,-0.5\n" for k in range(rows)))
    line = one_line_error(run_pincal("calibrate", "delta", str(big)))
    assert f"has {rows} rows; pincal calibrates at most {MAX_SAMPLES} samples in one run" in line


def test_view_open_without_a_terminal_is_refused_before_any_work(five_bar_data: Path, tmp_path: Path) -> None:
    done = subprocess.run([str(PINCAL), "view", "five_bar", str(five_bar_data), "--out", str(tmp_path / "v.html"),
                           "--open"], stdin=subprocess.DEVNULL, capture_output=True, text=True, timeout=300,
                          check=False)
    line = one_line_error(done)
    assert "--open without a ZMQ_URL starts a meshcat server" in line and not (tmp_path / "v.html").exists()


def test_an_unexpected_exception_is_one_line_and_exit_3(monkeypatch: pytest.MonkeyPatch,
                                                        capsys: pytest.CaptureFixture[str]) -> None:
    import pincal.cli.app

    def broken(args: object) -> int:
        raise RuntimeError("something pincal did not foresee")

    monkeypatch.setattr(pincal.cli.app, "cmd_info", broken)
    assert pincal.cli.app.main(["info", "delta"]) == pincal.cli.app.EXIT_BUG == 3
    err = capsys.readouterr().err.strip().splitlines()
    assert err == ["pincal: internal error: RuntimeError: something pincal did not foresee (a bug in pincal: run "
                   "again with --debug and report the traceback)"]
    with pytest.raises(RuntimeError):
        pincal.cli.app.main(["--debug", "info", "delta"])


def test_a_joint_reading_of_a_missing_joint_is_named_by_simulate(tmp_path: Path) -> None:
    line = one_line_error(run_pincal("simulate", "delta", "--samples", "5", "--measure", "joint:nojoint", "--out",
                                     str(tmp_path / "sim")))
    assert "measurement 'joint:nojoint': joint 'nojoint' does not exist in robot 'delta'; joints are: arm_1_joint" \
        in line


@pytest.mark.parametrize("content", ["[]", '{"parameters": 1.5}', '{"parameters": {"a": {"value": "abc"}}}'])
def test_a_result_json_that_is_not_a_report_is_named(five_bar_data: Path, tmp_path: Path, content: str) -> None:
    result = tmp_path / "result.json"
    result.write_text(content)
    line = one_line_error(run_pincal("view", "five_bar", str(five_bar_data), "--result", str(result), "--out",
                                     str(tmp_path / "v.html")))
    assert f"the result JSON '{result}' has no 'parameters' of the form" in line


@pytest.mark.parametrize("command", ["view", "report"])
def test_a_fits_options_that_contradict_the_result_are_refused(five_bar_data: Path, tmp_path: Path,
                                                               command: str) -> None:
    """--result draws a finished fit: the calibrate command repeated with --result works, and a fit's option that
    says otherwise than the result (another solver, loss, selection, cross-validation or payload) is refused by name,
    before anything is written, instead of being silently dropped."""
    result, page = tmp_path / "result.json", tmp_path / "page.html"
    fit = ["five_bar", str(five_bar_data), "--parameters", "*.offset", "--loss", "linear"]
    assert run_pincal("calibrate", *fit, "--report", str(result)).returncode == 0
    fit.append("--quiet")
    done = run_pincal(command, *fit, "--result", str(result), "--out", str(page))
    assert done.returncode == 0, done.stderr
    page.unlink()
    for option, culprit, fitted in ((["--solver", "tsvd"], "--solver tsvd", "'lm'"),
                                    (["--loss", "cauchy"], "--loss cauchy", "'linear'"),
                                    (["--select", "bic"], "--select bic", "'none'"),
                                    (["--cv", "5x2", "--cv-seed", "3"], "--cv 5x2", "none"),
                                    (["--payload", "1@tool:0,0,0.1"], "--payload 1@tool:0,0,0.1", "none")):
        line = one_line_error(run_pincal(command, *fit, *option, "--result", str(result), "--out", str(page)))
        assert line == (f"pincal: error: {culprit}: the result JSON '{result}' was fitted with {fitted}; --result "
                        "draws that fit as it is: give the options it was made with, or calibrate again without "
                        "--result")
        assert not page.exists()


def _drawing(page: Path) -> str:
    """A page's text without its provenance (the folded block, the comment, and the comment escaped in a frame)."""
    text = page.read_text(encoding="utf-8")
    text = re.sub(r'<details class="provenance">.*?</details>', "", text, flags=re.S)
    return re.sub(r"(<|&lt;)!-- pincal provenance: .*? --(>|&gt;)", "", text, flags=re.S)


@pytest.mark.parametrize("command", ["view", "report"])
def test_a_result_is_drawn_over_the_data_it_was_fitted_on_only(five_bar_data: Path, tmp_path: Path,
                                                              command: str) -> None:
    """--result draws a finished fit over its data: a sample the calibration dropped (a reading outside the joint
    limits) stays out of the drawing, as without --result; the same result given with another data file of the same
    robot is refused by name (its numbers would head a page drawn from other samples)."""
    lines = five_bar_data.read_text(encoding="utf-8").splitlines()
    header = next(k for k, line in enumerate(lines) if not line.startswith("#"))
    cells = lines[header + 4].split(",")
    theta = lines[header].split(",").index("theta_1_joint")
    cells[theta] = "3.0"  # outside the limits [-pi/2, pi/2] rad: dropped and listed by calibrate
    data, result, page = tmp_path / "data.csv", tmp_path / "result.json", tmp_path / "page.html"
    data.write_text("\n".join([*lines[:header + 4], ",".join(cells), *lines[header + 5:]]) + "\n", encoding="utf-8")
    done = run_pincal("calibrate", "five_bar", str(data), "--report", str(result))
    assert done.returncode == 0 and "dropped 1" in done.stdout, (done.stdout, done.stderr)
    assert json.loads(result.read_text())["n_samples"] == 11
    done = run_pincal(command, "five_bar", str(data), "--result", str(result), "--out", str(page), "--quiet")
    assert done.returncode == 0, done.stderr
    again = tmp_path / "again.html"
    assert run_pincal(command, "five_bar", str(data), "--out", str(again), "--quiet").returncode == 0
    if command == "view":
        assert "11 samples" in done.stdout
    # the same drawing as a calibration run again, but for the last bits of the forward kinematics' floats and the
    # provenance, which names the result file too
    assert abs(len(_drawing(page)) - len(_drawing(again))) < 100
    page.unlink()
    other = tmp_path / "other"
    assert run_pincal("simulate", "five_bar", "--samples", "12", "--seed", "2", "--quiet", "--out",
                      str(other)).returncode == 0
    line = one_line_error(run_pincal(command, "five_bar", str(other / "measurements.csv"), "--result", str(result),
                                     "--out", str(page), "--quiet"))
    assert line.startswith(f"pincal: error: --result '{result}': the result JSON was not fitted on these data: it "
                           "records 11 fitted samples of 12 in the file, RMS error after ")
    assert "these data give 12 of 12" in line and line.endswith("give the data file the result was calibrated from")
    assert not page.exists()


@pytest.mark.parametrize("command", ["report", "view"])
def test_a_result_of_another_robot_is_refused_by_its_robot(tmp_path: Path, command: str) -> None:
    """A UR5's calibration given to a UR10's page was refused with a 1600-character list of parameters that differ;
    the robot the result records is compared first."""
    for robot in ("ur5", "ur10"):
        done = run_pincal("simulate", robot, "--samples", "30", "--seed", "3", "--quiet", "--out",
                          str(tmp_path / robot))
        assert done.returncode == 0, done.stderr
    result, page = tmp_path / "ur5.json", tmp_path / "page.html"
    done = run_pincal("calibrate", "ur5", str(tmp_path / "ur5" / "measurements.csv"), "--report", str(result))
    assert done.returncode == 0, done.stderr
    line = one_line_error(run_pincal(command, "ur10", str(tmp_path / "ur10" / "measurements.csv"), "--result",
                                     str(result), "--out", str(page)))
    assert line == f"pincal: error: --result '{result}' is a calibration of 'ur5', not of 'ur10'"
    assert not page.exists()


def test_a_design_of_too_few_postures_to_identify_its_parameters_is_refused(tmp_path: Path) -> None:
    """8 Delta postures measure 24 values, fewer than the 27 parameters the candidates identify: every such set has
    an infinite condition number, so there is nothing to design; refused by name with the least --poses that can
    work, and nothing written (it was written, with κ = inf and exit 0)."""
    out = tmp_path / "poses.csv"
    line = one_line_error(run_pincal("design", "delta", "--candidates", "30", "--poses", "8", "--quiet", "--out",
                                     str(out)))
    assert line == ("pincal: error: --poses 8: 8 postures give 24 measured values, fewer than the 27 parameters the "
                    "candidates can identify; choose at least 9 postures (or fewer parameters)")
    assert not out.exists()
    done = run_pincal("design", "delta", "--candidates", "30", "--poses", "9", "--quiet", "--out", str(out))
    assert done.returncode == 0 and out.exists(), done.stderr


@pytest.mark.parametrize(("line", "culprit"), [
    ("# sigma: 1e-3", "metadata 'sigma' is not a σ line pincal reads"),
    ("# Sigma position: 1e-3", "metadata 'Sigma position' is not a σ line pincal reads"),
    ("# sigma postion: 1e-3", "metadata 'sigma postion' is not a σ line pincal reads"),
    ("# sigma position: abc", "metadata 'sigma position' is 'abc', not a number"),
])
def test_a_sigma_line_pincal_would_not_use_is_refused(five_bar_data: Path, tmp_path: Path, line: str,
                                                      culprit: str) -> None:
    """A '# sigma' line of no measurement kind was ignored (the fit then weighted by the default 1e-5 m), and a bad
    σ was ignored where a line for the frame overrides it: both refused by name; --sigma overrides every line."""
    text = five_bar_data.read_text(encoding="utf-8")
    assert "# sigma position end_effector:" in text  # the frame's own line, which overrides '# sigma position'
    data = tmp_path / "sigma.csv"
    data.write_text(line + "\n" + text, encoding="utf-8")
    assert culprit in one_line_error(run_pincal("calibrate", "five_bar", str(data)))
    assert run_pincal("calibrate", "five_bar", str(data), "--sigma", "1e-5").returncode == 0


@pytest.mark.parametrize("command", ["calibrate", "view", "report"])
def test_the_sigma_help_says_the_files_lines_are_the_default(command: str) -> None:
    """--help said '(default 1e-5)' [m] while a file's '# sigma' lines weight its channels when --sigma is not given
    (and, without them, σ is estimated from the data)."""
    done = run_pincal(command, "--help")
    assert done.returncode == 0
    text = " ".join(done.stdout.split())
    assert ("one measurement σ [m, rad] for weighting every channel, or one per residual row as A,B,C (e.g. "
            "1e-3,1e-3,3e-3 for a camera's depth noise three times its lateral noise), over the file's '# sigma' lines "
            "(default: those lines, else estimated from the data: docs/dataset.md 'Noise')") in text


def test_fleet_names_a_data_dir_that_is_missing_or_a_file(tmp_path: Path) -> None:
    """'no *.csv files in X' was said of a directory that does not exist and of a CSV file given as DATA_DIR."""
    data = tmp_path / "robot1.csv"
    data.write_text("sample,arm_1_joint\n0,0.1\n", encoding="utf-8")
    line = one_line_error(run_pincal("fleet", "delta", str(tmp_path / "nowhere"), "--out", str(tmp_path / "out")))
    assert line == f"pincal: error: fleet: DATA_DIR '{tmp_path / 'nowhere'}' does not exist"
    line = one_line_error(run_pincal("fleet", "delta", str(data), "--out", str(tmp_path / "out")))
    assert line == (f"pincal: error: fleet: DATA_DIR '{data}' is a file, not a directory of CSV files (one per "
                    "robot)")
    assert not (tmp_path / "out").exists()


@pytest.mark.parametrize("address", ["bogus", "127.0.0.1:notaport", "tcp://127.0.0.1:70000"])
def test_fleet_refuses_a_malformed_scheduler_address_before_connecting(tmp_path: Path, address: str) -> None:
    """Dask's address parser raised a bare ValueError (an internal error, exit 3) for these; no scheduler runs here,
    so the refusal comes before any connection is tried."""
    data = tmp_path / "data"
    data.mkdir()
    (data / "robot1.csv").write_text("sample,arm_1_joint\n0,0.1\n", encoding="utf-8")
    line = one_line_error(run_pincal("fleet", "delta", str(data), "--out", str(tmp_path / "out"), "--workers", "1",
                                     "--scheduler", address))
    assert line == (f"pincal: error: --scheduler '{address}': not a Dask scheduler address (host:port or "
                    "tcp://host:port)")
    assert not (tmp_path / "out").exists()


def test_demo_names_every_file_it_writes(tmp_path: Path) -> None:
    """The demo's last line listed the files of ./pincal-demo/ but truth.json."""
    done = subprocess.run([str(PINCAL), "demo"], cwd=tmp_path, capture_output=True, text=True, timeout=300,
                          check=False)
    assert done.returncode == 0, done.stderr
    written = sorted(path.name for path in (tmp_path / "pincal-demo").iterdir())
    last = done.stdout.strip().splitlines()[-1]
    assert all(name in last for name in written), (written, last)


@pytest.mark.parametrize("command", [["view", "--out", "unused.html"], ["report", "--out", "unused.html"],
                                     ["calibrate"]])
def test_a_data_or_job_file_given_as_the_robot_is_named(five_bar_data: Path, command: list[str]) -> None:
    """Swapped arguments were 'X is not well-formed XML: ... line 1, column 1'; a job file takes no DATA."""
    job = ROOT / "examples" / "tiago_job.toml"  # the repository's (pincal may be installed elsewhere)
    line = one_line_error(run_pincal(command[0], str(five_bar_data), "five_bar", *command[1:]))
    assert line == (f"pincal: error: robot file '{five_bar_data}' is a data file (CSV): the robot comes first, then "
                    "the data (pincal calibrate ROBOT DATA.csv); give a URDF file or a known robot name")
    line = one_line_error(run_pincal(command[0], str(job), str(five_bar_data), *command[1:]))
    assert line == (f"pincal: error: {command[0]}: '{job}' is a job file, which names its own data; give no DATA "
                    f"(got '{five_bar_data}'), or a robot: pincal {command[0]} ROBOT DATA")


def test_argparse_errors_are_one_line_in_pincal_form() -> None:
    done = run_pincal("simulate", "delta")
    assert done.returncode == 2 and done.stderr == (
        "pincal: error: simulate: the following arguments are required: --out (see 'pincal simulate --help')\n")


def test_simulate_refuses_more_samples_than_calibrate_takes(tmp_path: Path) -> None:
    from pincal.io.dataset import MAX_SAMPLES

    line = one_line_error(run_pincal("simulate", "five_bar", "--samples", str(MAX_SAMPLES), "--test-samples", "1",
                                     "--out", str(tmp_path / "sim")))
    assert f"pincal calibrates at most {MAX_SAMPLES} samples in one run" in line and not (tmp_path / "sim").exists()


def test_a_truth_file_of_another_robot_is_refused_by_report(five_bar_data: Path, tmp_path: Path) -> None:
    other = tmp_path / "sim"
    assert run_pincal("simulate", "ucr3", "--samples", "3", "--quiet", "--out", str(other)).returncode == 0
    line = one_line_error(run_pincal("report", "five_bar", str(five_bar_data), "--parameters", "*.offset", "--truth",
                                     str(other / "truth.json"), "--quiet", "--out", str(tmp_path / "r.html")))
    assert f"--truth '{other / 'truth.json'}' holds none of the 2 parameters fitted here" in line
    assert not (tmp_path / "r.html").exists()


def test_view_open_to_an_address_where_no_meshcat_answers_ends_with_one_line(five_bar_data: Path,
                                                                             tmp_path: Path) -> None:
    done = run_pincal("view", "five_bar", str(five_bar_data), "--parameters", "*.offset", "--quiet", "--out",
                      str(tmp_path / "v.html"), "--open", "tcp://127.0.0.1:1", timeout=120)
    line = one_line_error(done)
    assert line == "pincal: error: cannot reach a meshcat server at tcp://127.0.0.1:1: no answer within 10 s"
    assert (tmp_path / "v.html").exists()  # the page was written before meshcat was tried


@pytest.mark.parametrize("units", ["mm", "mm, deg", "millimetres and degrees"])
def test_a_file_that_says_its_units_are_not_si_is_refused(five_bar_data: Path, tmp_path: Path, units: str) -> None:
    text = five_bar_data.read_text()
    assert "# units: SI (m, rad)" in text
    other = tmp_path / "units.csv"
    other.write_text(text.replace("# units: SI (m, rad)", f"# units: {units}"))
    line = one_line_error(run_pincal("calibrate", "five_bar", str(other)))
    assert f"metadata 'units: {units}' names" in line and "pincal reads metres and radians" in line


def _sigint_as_at_a_terminal() -> None:
    """In a child before it runs the command: SIGINT at its default disposition, as a shell's foreground command has
    it (a disposition "ignored" is inherited through fork and exec)."""
    signal.signal(signal.SIGINT, signal.SIG_DFL)


def _in_the_interpreters_start(err: str) -> bool:
    """Whether ``err`` shows a Ctrl-C that landed before ``pincal.__main__.main`` could take it: in the interpreter's
    ``site`` module, or in its import of the console script's entry point (Python's traceback, from no frame of a
    ``main``)."""
    return "Fatal Python error: init_import_site" in err or ("Traceback" in err and ", in main\n" not in err)


@pytest.mark.parametrize("delay", [0.15, 0.3, 0.5])
def test_ctrl_c_at_any_moment_of_the_start_is_one_line(tmp_path: Path, delay: float) -> None:
    """An interrupt while Pinocchio and NumPy are still importing, or while the data are read, ends with one
    line and exit 130 (once, a Ctrl-C during the imports printed a traceback). Within the interpreter's own
    start, before ``pincal`` runs, Python itself answers; that window is not tested: its ``site`` module, and its
    import of the console script's entry point, which imports nothing more
    (``test_start.py::test_the_console_script_takes_ctrl_c_before_importing_anything``)."""
    # a command that runs for seconds (2000 closed-loop postures), so that the interrupt lands while it runs; on a
    # loaded machine the interpreter's own start can outlast the delay (Python's traceback, from no frame of
    # pincal's main): the interrupt then says nothing about pincal, and the test waits longer and tries again (on 2
    # busy cores, 12 of 60 interrupts between 0.1 and 0.8 s landed there). The command starts with SIGINT at its
    # default, as at a terminal: started from a test run that ignores it (pytest in the background of a shell script,
    # under nohup), it would inherit "ignored", keep ignoring it as every Unix tool does, and run to completion
    for attempt in range(5):
        process = subprocess.Popen([str(PINCAL), "simulate", "delta", "--samples", "2000", "--quiet", "--out",
                                    str(tmp_path / f"sim{attempt}")], stdout=subprocess.PIPE, stderr=subprocess.PIPE,
                                   text=True, preexec_fn=_sigint_as_at_a_terminal)
        time.sleep(delay * (attempt + 1))
        process.send_signal(signal.SIGINT)
        _, err = process.communicate(timeout=60)
        if not _in_the_interpreters_start(err):
            break
    # before the interpreter installs its handler, SIGINT ends the process as it ends any Unix tool: silently
    assert (process.returncode, err) in ((130, "pincal: interrupted\n"), (-signal.SIGINT, ""))


def test_data_recorded_on_another_robot_are_refused_by_name(tmp_path: Path) -> None:
    """A UR10 file has the UR5's joint names: only its '# robot:' line tells them apart."""
    done = run_pincal("simulate", "ur10", "--samples", "12", "--quiet", "--out", str(tmp_path / "sim"))
    assert done.returncode == 0, done.stderr
    line = one_line_error(run_pincal("calibrate", "ur5", str(tmp_path / "sim" / "measurements.csv")))
    assert "its '# robot: ur10' line says the data are of robot 'ur10', not of 'ur5'" in line
    # the robot's file name is its name too (tiago_no_hand.urdf holds <robot name="tiago">)
    data = tmp_path / "sim" / "measurements.csv"
    data.write_text(data.read_text().replace("# robot: ur10\n", "# robot: ur10_robot\n"))
    done = run_pincal("calibrate", "ur10", str(data), "--parameters", "*.offset")
    assert done.returncode == 0, done.stderr


def test_an_output_onto_a_pipe_or_device_is_refused_and_left_alone(five_bar_data: Path, tmp_path: Path) -> None:
    """A rename over a FIFO or a device node would replace it with a regular file (once, /dev/full)."""
    fifo = tmp_path / "pipe"
    os.mkfifo(fifo)
    line = one_line_error(run_pincal("calibrate", "five_bar", str(five_bar_data), "--report", str(fifo)))
    assert f"--report '{fifo}' is not a regular file" in line
    assert stat.S_ISFIFO(fifo.stat().st_mode)


def test_a_column_for_a_mimic_joint_is_named(tmp_path: Path) -> None:
    sim = tmp_path / "sim"
    assert run_pincal("simulate", "panda", "--samples", "12", "--quiet", "--out", str(sim)).returncode == 0
    text = (sim / "measurements.csv").read_text().splitlines()
    header = next(k for k, line in enumerate(text) if not line.startswith("#"))
    text[header] += ",panda_finger_joint2"
    text[header + 1:] = [line + ",0.01" for line in text[header + 1:]]
    data = tmp_path / "with_mimic.csv"
    data.write_text("\n".join(text) + "\n")
    line = one_line_error(run_pincal("calibrate", "panda", str(data)))
    assert "joint 'panda_finger_joint2' is a <mimic> joint, which follows its leader" in line


def test_a_robot_with_nothing_to_move_is_refused(tmp_path: Path) -> None:
    urdf = tmp_path / "rigid.urdf"
    urdf.write_text('<robot name="rigid"><link name="a"/><link name="b"/><joint name="j" type="fixed"><parent '
                    'link="a"/><child link="b"/></joint></robot>')
    line = one_line_error(run_pincal("simulate", str(urdf), "--out", str(tmp_path / "sim")))
    assert "robot 'rigid' has no actuated joint: nothing moves" in line


def test_a_fit_far_above_the_stated_noise_says_so_first(tmp_path: Path) -> None:
    """Readings with 10 µm noise, stated as 10 nm: the residuals stay ~1000 × σ."""
    assert run_pincal("simulate", "delta", "--samples", "40", "--seed", "1", "--quiet", "--out",
                      str(tmp_path)).returncode == 0
    done = run_pincal("calibrate", "delta", str(tmp_path / "measurements.csv"), "--parameters", "model24",
                      "--sigma", "1e-8")
    assert done.returncode == 0, done.stderr
    assert done.stdout.startswith("THE FIT DOES NOT REACH THE STATED NOISE")


def test_simulation_errors_name_their_cause_and_leave_no_directory(tmp_path: Path) -> None:
    out = tmp_path / "sim"
    line = one_line_error(run_pincal("simulate", "delta", "--perturb", "1000", "--out", str(out)))
    assert "with true errors of σ 1000 (m, rad), cannot be assembled" in line and not out.exists()
    line = one_line_error(run_pincal("simulate", "delta", "--measure", "joint:arm_1_joint", "--out", str(out)))
    assert "reads actuated joint 'arm_1_joint', whose reading is every sample's input" in line


def test_a_joint_name_with_a_colon_survives_the_csv(tmp_path: Path) -> None:
    text = pincal.robot_path("ur5").read_text()
    urdf = tmp_path / "ur5_colon.urdf"
    urdf.write_text(text.replace('"elbow_joint"', '"arm:elbow_joint"'))
    done = run_pincal("simulate", str(urdf), "--samples", "30", "--quiet", "--out", str(tmp_path / "sim"))
    assert done.returncode == 0, done.stderr
    done = run_pincal("calibrate", str(urdf), str(tmp_path / "sim" / "measurements.csv"))
    assert done.returncode == 0, done.stderr


def test_an_unwritable_output_place_is_refused_before_the_fit(five_bar_data: Path) -> None:
    """/proc takes no files, whatever its permission bits say: once the refusal came after the fit."""
    line = one_line_error(run_pincal("calibrate", "five_bar", str(five_bar_data), "--out", "/proc/cal.urdf"))
    assert line == "pincal: error: --out '/proc/cal.urdf': directory '/proc' is not writable"
