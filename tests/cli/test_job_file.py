"""``pincal calibrate JOB.toml`` as a user runs it: the example job, overrides, units, and one-line errors."""

from __future__ import annotations

import csv
import json
import math
import subprocess
from pathlib import Path
from typing import Any

import pytest
from conftest import ROOT, run_pincal

EXAMPLE = ROOT / "examples" / "tiago_job.toml"
RAW = ROOT / "examples" / "data" / "tiago_mocap_raw.csv"
CONVERTED = ROOT / "examples" / "data" / "tiago_mocap_marker1.csv"


def report_of(*args: str, report: Path) -> dict[str, Any]:
    """The report JSON of ``pincal ARGS --report REPORT``, which must succeed."""
    done = run_pincal(*args, "--report", str(report))
    assert done.returncode == 0, done.stderr
    data: dict[str, Any] = json.loads(report.read_text(encoding="utf-8"))
    return data


def one_line_error(done: subprocess.CompletedProcess[str]) -> str:
    """The single stderr line of a refused command (exit 2, no traceback)."""
    assert done.returncode == 2, (done.stdout, done.stderr)
    lines = done.stderr.splitlines()
    assert len(lines) == 1 and lines[0].startswith("pincal: error: "), done.stderr
    return lines[0]


def copy_job(folder: Path, data: str = "data/tiago_mocap_raw.csv", **replace: str) -> Path:
    """The example job in ``folder``, its data file named ``data`` and text replaced as ``replace`` says."""
    text = EXAMPLE.read_text(encoding="utf-8").replace('"data/tiago_mocap_raw.csv"', f'"{data}"')
    for old, new in replace.items():
        assert old in text
        text = text.replace(old, new)
    path = folder / "job.toml"
    path.write_text(text, encoding="utf-8")
    return path


@pytest.fixture(scope="module")
def converted_report(tmp_path_factory: pytest.TempPathFactory) -> dict[str, Any]:
    """``pincal calibrate tiago_no_hand examples/data/tiago_mocap_marker1.csv``: the study from the converted file."""
    report = tmp_path_factory.mktemp("converted") / "report.json"
    return report_of("calibrate", "tiago_no_hand", str(CONVERTED), report=report)


def test_the_example_job_gives_the_studys_figures_from_the_raw_file(tmp_path: Path,
                                                                    converted_report: dict[str, Any]) -> None:
    """examples/tiago_job.toml runs the TIAGo study from the file the mocap wrote: the very figures of the command on
    the converted file."""
    ours = report_of("calibrate", str(EXAMPLE), report=tmp_path / "job.json")
    for key in ("rms_after", "test_rms_after", "rms_before", "test_rms_before", "n_samples", "n_test_samples",
                "n_estimated", "parameters", "down_weighted"):
        assert ours[key] == converted_report[key], key
    assert ours["selection"] == converted_report["selection"]


def test_options_on_the_command_line_override_the_job(tmp_path: Path) -> None:
    job = copy_job(tmp_path, str(RAW), **{"# report = \"tiago_report.json\"": 'report = "job.json"',
                                          'select = "auto"': 'select = "bic"\ncv = "5x4"'})
    other = tmp_path / "elsewhere" / "other.urdf"
    done = run_pincal("calibrate", str(job), "--cv", "3", "--select", "none", "--out", str(other))
    assert done.returncode == 0, done.stderr
    ours = json.loads((tmp_path / "job.json").read_text())  # the job's report, relative to the job file
    assert other.is_file() and f"wrote {other}" in done.stdout and f"wrote {tmp_path / 'job.json'}" in done.stdout
    assert ours["cv"]["plan"] == "3-fold" and ours["selection"]["policy"] == "none"
    theirs = report_of("calibrate", "tiago_no_hand", str(CONVERTED), "--cv", "3", "--select", "none",
                       report=tmp_path / "csv.json")
    assert ours["rms_after"] == theirs["rms_after"] and ours["cv"]["rms"] == theirs["cv"]["rms"]


def test_data_written_in_millimetres_and_degrees_give_the_same_result(tmp_path: Path) -> None:
    rows = list(csv.reader(RAW.read_text(encoding="utf-8").splitlines()))
    lengths = {c for c in rows[0] if c[0] in "xyz"} | {"torso_lift_joint"}
    with (tmp_path / "mm_deg.csv").open("w", newline="", encoding="utf-8") as stream:
        writer = csv.writer(stream)
        writer.writerow(rows[0])
        for row in rows[1:]:
            writer.writerow([repr(float(v) * (1e3 if c in lengths else 180 / math.pi))
                             for c, v in zip(rows[0], row, strict=True)])
    job = copy_job(tmp_path, "mm_deg.csv", **{'length = "m", angle = "rad"': 'length = "mm", angle = "deg"'})
    ours = report_of("calibrate", str(job), report=tmp_path / "mm.json")
    si = report_of("calibrate", str(EXAMPLE), report=tmp_path / "si.json")
    for key in ("rms_before", "rms_after", "test_rms_after"):
        assert ours[key] == pytest.approx(si[key], rel=1e-9), key
    assert ours["n_estimated"] == si["n_estimated"]
    factors = [report["selection"].pop("prior_factors") for report in (ours, si)]  # the evidence's, to round-off
    guards = [report["selection"].pop("guard") for report in (ours, si)]  # the range guard's scores, to round-off
    assert ours["selection"] == si["selection"] and factors[0].keys() == factors[1].keys()
    assert list(factors[0].values()) == pytest.approx(list(factors[1].values()), rel=1e-9)
    assert guards[0]["firmer"] == guards[1]["firmer"]
    for key in ("beyond", "inside", "nominal_beyond"):
        assert guards[0][key] == pytest.approx(guards[1][key], rel=1e-9), key


def test_an_unknown_key_is_named_with_the_valid_ones(tmp_path: Path) -> None:
    job = copy_job(tmp_path, str(RAW), **{'solver = "lm"': 'slover = "lm"'})
    line = one_line_error(run_pincal("calibrate", str(job)))
    assert line == (f"pincal: error: {job}: key 'slover' does not exist at the top level; keys are: robot, data, "
                    "joints, measure, out, report, parameters, select, loss, solver, sigma, max_iter, formulation, cv, "
                    "cv_seed, payload, plausible, prior")


def test_a_cv_seed_that_seeds_nothing_names_the_job_file_or_the_flag(tmp_path: Path) -> None:
    """A job's cv_seed with no cv, or with cv = "loo" (leave-one-out has no shuffle), is refused before any fit,
    naming the job file and the key; an option given on the command line in place of the job's is named as the flag
    it is."""
    seed_alone = copy_job(tmp_path, str(RAW), **{'# cv = "5x4"': "cv_seed = 5"})
    line = one_line_error(run_pincal("calibrate", str(seed_alone)))
    assert line == (f"pincal: error: {seed_alone}: cv_seed: 5 seeds the shuffles of a K-fold cross-validation, and "
                    'no cv is given; give cv too (e.g. cv = "5x4")')
    line = one_line_error(run_pincal("calibrate", str(seed_alone), "--cv", "loo"))
    assert line == (f"pincal: error: {seed_alone}: cv_seed: 5 seeds the shuffles of K-fold plans; --cv loo has none "
                    "(it leaves each sample out in turn): drop cv_seed, or cross-validate by K folds (e.g. --cv 5x4)")
    both = copy_job(tmp_path, str(RAW), **{'# cv = "5x4"': 'cv = "loo"\ncv_seed = 5'})
    line = one_line_error(run_pincal("calibrate", str(both)))
    assert line == (f'pincal: error: {both}: cv_seed: 5 seeds the shuffles of K-fold plans; cv = "loo" has none (it '
                    'leaves each sample out in turn): drop cv_seed, or cross-validate by K folds (e.g. cv = "5x4")')
    loo = copy_job(tmp_path, str(RAW), **{'# cv = "5x4"': 'cv = "loo"'})
    line = one_line_error(run_pincal("calibrate", str(loo), "--cv-seed", "4"))
    assert line == (f'pincal: error: --cv-seed 4 seeds the shuffles of K-fold plans; cv = "loo" in {loo} has none (it '
                    'leaves each sample out in turn): drop --cv-seed, or cross-validate by K folds (e.g. cv = "5x4")')


def test_select_cv_by_leave_one_out_names_the_job_file_or_the_flag(tmp_path: Path) -> None:
    """A job's select = "cv" with cv = "loo" repeats the selection's own 5-fold cross-validation in every fold, one per
    sample: refused before any fit, naming the job file's keys, or the flag given on the command line in their place
    (issue 36)."""
    cost = ("would repeat the cv selection (its own 5-fold cross-validation of every combination of parameter groups) "
            "in each of its folds (one per sample): minutes to hours of fitting; cross-validate by fewer folds ")
    both = copy_job(tmp_path, str(RAW), **{'# cv = "5x4"': 'cv = "loo"', 'select = "auto"': 'select = "cv"'})
    line = one_line_error(run_pincal("calibrate", str(both)))
    assert line == (f'pincal: error: select = "cv" with cv = "loo" in {both} {cost}(cv = "5" or cv = "5x4"), or leave '
                    "select at its default")
    line = one_line_error(run_pincal("calibrate", str(both), "--select", "cv"))
    assert line == (f'pincal: error: --select cv with cv = "loo" in {both} {cost}(cv = "5" or cv = "5x4"), or leave '
                    "--select at its default")


def test_a_data_file_is_looked_for_beside_the_job(tmp_path: Path) -> None:
    (tmp_path / "jobs").mkdir()
    (tmp_path / "raw.csv").write_bytes(RAW.read_bytes())
    job = copy_job(tmp_path / "jobs", "raw.csv")
    line = one_line_error(run_pincal("calibrate", str(job)))
    assert line == (f"pincal: error: {job}: [data] file: 'raw.csv' does not exist (looked for "
                    f"'{(tmp_path / 'jobs' / 'raw.csv').absolute()}': paths in a job file are relative to its "
                    "directory)")
    copy_job(tmp_path / "jobs", "../raw.csv")
    assert run_pincal("calibrate", str(job)).returncode == 0


def test_a_column_the_csv_lacks_is_named(tmp_path: Path) -> None:
    job = copy_job(tmp_path, str(RAW), **{'columns = ["x1", "y1", "z1"]': 'columns = ["x1", "y1", "z5"]'})
    line = one_line_error(run_pincal("calibrate", str(job)))
    assert line.startswith(f"pincal: error: {job}: [measure 1] columns: column 'z5' does not exist in data file "
                           f"'{RAW}'; columns are: x1, y1, z1, x2, y2, z2, x3")


def test_calibrate_takes_robot_and_data_or_a_job(tmp_path: Path) -> None:
    assert one_line_error(run_pincal("calibrate", "delta")) == (
        "pincal: error: calibrate: DATA is missing: give pincal calibrate ROBOT DATA.csv, or a job file JOB.toml "
        "(docs/job_file.md); got only 'delta'")
    assert "is a job file, which names its own data; give no DATA (got 'data.csv')" in one_line_error(
        run_pincal("calibrate", str(EXAMPLE), "data.csv"))
    assert one_line_error(run_pincal("calibrate", str(tmp_path / "none.toml"))) == (
        f"pincal: error: cannot read job file '{tmp_path / 'none.toml'}': No such file or directory")


def test_a_job_declares_markers_on_a_body_and_reads_an_unseen_marker(tmp_path: Path) -> None:
    """Three markers of the raw mocap file on the hand, as the measuring system wrote them: the same fit as the
    converted three-marker file; a marker whose three cells are empty in a row was not seen (the sample keeps the
    others), one or two empty cells are refused by name."""
    rows = list(csv.reader(RAW.open(encoding="utf-8")))
    header = rows[0]
    raw = tmp_path / "raw.csv"

    def write(table: list[list[str]]) -> None:
        with raw.open("w", newline="", encoding="utf-8") as handle:
            csv.writer(handle).writerows(table)

    measures = "".join(f'[[measure]]\nkind = "position"\nframe = "wrist_ft_tool_link@m{m}"\n'
                       f'columns = ["x{m}", "y{m}", "z{m}"]\nsigma = 1e-3\n' for m in (1, 2, 3))
    job = tmp_path / "job.toml"
    job.write_text(f'robot = "tiago_no_hand"\n[data]\nfile = "{raw.name}"\nheld_out = "every 5th from 4"\n'
                   f'ignore = ["x4", "y4", "z4"]\n{measures}', encoding="utf-8")
    write(rows)
    from_job = report_of("calibrate", str(job), report=tmp_path / "job.json")
    converted = report_of("calibrate", "tiago_no_hand", str(ROOT / "examples" / "data" / "tiago_mocap_markers.csv"),
                          report=tmp_path / "converted.json")
    assert from_job["rms_after"] == pytest.approx(converted["rms_after"], rel=1e-9)
    for column in ("x2", "y2", "z2"):
        rows[3][header.index(column)] = ""  # data row 2: marker 2 not seen
    write(rows)
    done = run_pincal("calibrate", str(job))
    assert done.returncode == 0, done.stderr
    assert "fitted 83 (wrist_ft_tool_link: m1 28, m2 27, m3 28), not seen 1; held out 18" in done.stdout
    rows[3][header.index("y2")] = "0.5"  # one cell back: a half-seen marker
    write(rows)
    error = one_line_error(run_pincal("calibrate", str(job)))
    assert "column 'x2', line 4: the cell is empty but y2 hold numbers" in error


def test_a_jobs_payload_reaches_the_corrections_file_and_the_command_line_overrides_it(tmp_path: Path) -> None:
    """A job that fits compliances under a payload writes the corrections file beside its calibrated URDF, with the
    payload; --payload replaces the job's; a payload with no compliance to act on is refused in one line."""
    payload = 'payload = { mass = 1.5, frame = "wrist_ft_tool_link", offset = [0, 0, 0.05] }'
    job = copy_job(tmp_path, str(RAW), **{
        '# out = "tiago_calibrated.urdf"': f'out = "cal.urdf"\nparameters = ["default", "*.compliance"]\n{payload}'})
    done = run_pincal("calibrate", str(job))
    assert done.returncode == 0, done.stderr
    beside = tmp_path / "cal.corrections.json"
    assert f"wrote {beside}" in done.stdout
    written = json.loads(beside.read_text(encoding="utf-8"))
    assert written["payload"] == {"mass": 1.5, "frame": "wrist_ft_tool_link", "offset": [0.0, 0.0, 0.05]}
    assert "arm_2_joint" in written["joints"]
    done = run_pincal("calibrate", str(job), "--payload", "2@arm_7_link", "--out", str(tmp_path / "other.urdf"))
    assert done.returncode == 0, done.stderr
    other = json.loads((tmp_path / "other.corrections.json").read_text(encoding="utf-8"))
    assert other["payload"] == {"mass": 2.0, "frame": "arm_7_link", "offset": [0.0, 0.0, 0.0]}
    assert other["joints"] != written["joints"]
    refused = run_pincal("calibrate", str(job), "--parameters", "default")
    assert "the payload (1.5 kg on wrist_ft_tool_link at (0, 0, 0.05) m) enters only the joint compliances" in \
        one_line_error(refused)


def test_a_payload_frame_the_robot_lacks_names_the_job_or_the_option(tmp_path: Path) -> None:
    """The job's own payload on a frame the robot lacks: the error names the job file; the same mistake in --payload
    (which overrides the job's) does not blame the file."""
    job = copy_job(tmp_path, str(RAW), **{
        '# out = "tiago_calibrated.urdf"': 'parameters = ["default", "*.compliance"]\n'
                                           'payload = { mass = 1.5, frame = "no_such_link" }'})
    line = one_line_error(run_pincal("calibrate", str(job)))
    assert line.startswith(f"pincal: error: {job}: payload: frame 'no_such_link' does not exist in robot 'tiago'")
    line = one_line_error(run_pincal("calibrate", str(job), "--payload", "1@nowhere"))
    assert line.startswith("pincal: error: payload: frame 'nowhere' does not exist in robot 'tiago'"), line


def test_a_payload_heavier_than_the_robot_is_flagged_and_outputs_never_share_a_corrections_file(tmp_path: Path) -> None:
    """1000 kg on the TIAGo's wrist (its moving links weigh about 22 kg in the URDF) gets a warning naming both
    masses; a plausible 2 kg none. An output not named .urdf keeps its whole name in its corrections file."""
    job = copy_job(tmp_path, str(RAW), **{
        '# out = "tiago_calibrated.urdf"': 'parameters = ["default", "*.compliance"]\n'
                                           'payload = { mass = 1000.0, frame = "arm_7_link" }'})
    heavy = run_pincal("calibrate", str(job), "--out", str(tmp_path / "cal.urdf2"), "--report",
                       str(tmp_path / "heavy.json"))
    assert heavy.returncode == 0, heavy.stderr
    links = json.loads((tmp_path / "heavy.json").read_text(encoding="utf-8"))["links_mass"]
    assert 15 < links < 30  # kg: the TIAGo's torso, arm, head and wheels in example-robot-data's URDF
    assert (f"warning: the payload (1000 kg) outweighs all the robot's moving links together ({links:.3g} kg, "
            "from the URDF): check its mass [kg] and its frame") in " ".join(heavy.stdout.split())  # wrapped at 120
    assert (tmp_path / "cal.urdf2.corrections.json").is_file() and not (tmp_path / "cal.corrections.json").exists()
    light = run_pincal("calibrate", str(job), "--payload", "2@arm_7_link")
    assert light.returncode == 0 and "outweighs" not in light.stdout, light.stderr


def test_lengths_read_in_the_wrong_unit_are_refused_not_fitted(tmp_path: Path) -> None:
    """The TIAGo job told its file (metres) is in millimetres: every position shrinks 1000×, and the fit used to
    squash the arm onto them (exit 0, 0.3-0.5 m parameter changes, fit RMS 0.003 mm). The measured positions' spread
    against the nominal robot's at the same joint readings names the mistake, before any fit."""
    (tmp_path / "data").mkdir()
    (tmp_path / "data" / "tiago_mocap_raw.csv").write_bytes(RAW.read_bytes())
    job = copy_job(tmp_path, **{'units = { length = "m"': 'units = { length = "mm"'})
    line = one_line_error(run_pincal("calibrate", str(job)))
    assert line.startswith("pincal: error: the measured positions 'position:") and "× less" in line
    assert "(columns x1, y1, z1, read in mm)" in line and "the columns are likely in m, not mm" in line
    # and the right unit still calibrates
    assert run_pincal("calibrate", str(copy_job(tmp_path))).returncode == 0
