"""Contact with a plane as a user runs it: ``pincal simulate`` and ``pincal calibrate`` on a CSV with ``plane:``
columns, a job file that reads a file with a defective header by column position, and one-line errors."""

from __future__ import annotations

import json
import re
from pathlib import Path
from typing import Any

import pytest
from conftest import ROOT, run_pincal

DATASET_DOC = (ROOT / "docs" / "dataset.md").read_text(encoding="utf-8")

#: A job for the simulated UR10 campaign; {data}, {header} and the column references are filled in per test.
JOB = """robot = "ur10"
[data]
file = "{data}"
header = "{header}"
held_out = "every 4th from 1"
ignore = [{ignore}]
[joints]
{joints}
[[measure]]
kind = "plane"
frame = "tool0"
columns = [{columns}]
sigma = 1e-5
"""
JOINTS = ("shoulder_pan_joint", "shoulder_lift_joint", "elbow_joint", "wrist_1_joint", "wrist_2_joint",
          "wrist_3_joint")


@pytest.fixture(scope="module")
def campaign(tmp_path_factory: pytest.TempPathFactory) -> Path:
    """``pincal simulate ur10 --measure plane:tool0``: 40 postures read against a plane (distance, two tilts)."""
    out = tmp_path_factory.mktemp("plane")
    done = run_pincal("simulate", "ur10", "--measure", "plane:tool0", "--samples", "40", "--seed", "3", "--out",
                      str(out))
    assert done.returncode == 0, done.stderr
    return out / "measurements.csv"


def report_of(*args: str, report: Path) -> dict[str, Any]:
    done = run_pincal(*args, "--report", str(report))
    assert done.returncode == 0, done.stderr
    data: dict[str, Any] = json.loads(report.read_text(encoding="utf-8"))
    return data


def one_line_error(*args: str) -> str:
    done = run_pincal(*args)
    assert done.returncode == 2, (done.stdout, done.stderr)
    lines = done.stderr.splitlines()
    assert len(lines) == 1 and lines[0].startswith("pincal: error: "), done.stderr
    return lines[0]


def write_job(folder: Path, data: Path, header: str, by_position: bool) -> Path:
    """A job reading ``data`` by header names or by positions (columns: sample, set, 6 joints, 3 plane values)."""
    if by_position:
        joints = "\n".join(f"{j} = {k + 3}" for k, j in enumerate(JOINTS))
        columns, ignore = "9, 10, 11", "1, 2"
    else:
        joints = ""
        columns = ", ".join(f'"plane:tool0:{c}"' for c in ("distance", "tilt_x", "tilt_y"))
        ignore = '"sample", "set"'
    path = folder / f"job_{header}.toml"
    path.write_text(JOB.format(data=data.name, header=header, ignore=ignore, joints=joints, columns=columns),
                    encoding="utf-8")
    return path


def test_a_plane_contact_campaign_calibrates_from_its_csv(campaign: Path, tmp_path: Path) -> None:
    """The command of docs/dataset.md ("Contact with a plane"), with the figures it quotes."""
    report = report_of("calibrate", "ur10", str(campaign), report=tmp_path / "r.json")
    assert {"plane.tz", "plane.rx", "plane.ry"} <= set(report["parameters"])
    assert report["rms_after"] < 3e-5 < 1e-3 < report["rms_before"]  # to the noise (10 µm), from millimetres
    quoted = re.search(r"RMS distance\s+([\d.]+) → ([\d.]+) mm, RMS tilt ([\d.]+) → ([\d.]+) mrad, (\d+) of (\d+) "
                       "candidates identifiable", DATASET_DOC)
    assert quoted is not None
    assert quoted.groups() == (f"{report['rms_before'] * 1e3:.2f}", f"{report['rms_after'] * 1e3:.3f}",
                               f"{report['rms_angle_before'] * 1e3:.2f}", f"{report['rms_angle_after'] * 1e3:.3f}",
                               str(report["n_identifiable"]), str(report["n_parameters"]))


def test_a_job_reads_a_defective_header_by_position_as_it_reads_names(campaign: Path, tmp_path: Path) -> None:
    """The campaign's file with its header's names blanked ("header (line 1): column 1 has no name" for the CSV
    reader): read by position with ``header = "skip"``, the very calibration of the job that reads the names."""
    lines = campaign.read_text(encoding="utf-8").splitlines()
    header = next(k for k, line in enumerate(lines) if not line.startswith("#"))
    lines[header] = ",,,," + ",".join(lines[header].split(",")[4:])
    defective = tmp_path / "defective.csv"
    defective.write_text("\n".join(lines) + "\n", encoding="utf-8")
    assert "column 1 has no name" in one_line_error("calibrate", "ur10", str(defective))
    (tmp_path / campaign.name).write_bytes(campaign.read_bytes())
    named = report_of("calibrate", str(write_job(tmp_path, campaign, "names", False)), report=tmp_path / "a.json")
    positional = report_of("calibrate", str(write_job(tmp_path, defective, "skip", True)),
                           report=tmp_path / "b.json")
    for key in ("rms_after", "test_rms_after", "n_samples", "n_test_samples", "parameters"):
        assert positional[key] == named[key], key
    assert named["n_test_samples"] == 10  # rows 1, 5, ..., 37


@pytest.mark.parametrize(("change", "message"), [
    (("columns = [9, 10, 11]", 'columns = ["plane:tool0:distance", 10, 11]'),
     "[measure 1] columns: 'plane:tool0:distance' names a column by its header, and [data] header = \"skip\" "
     "reads none: name it by its position (1 for the first)"),
    (("columns = [9, 10, 11]", "columns = [9, 10, 12]"),
     "[measure 1] columns: column 12 is beyond the 11 columns of data file 'defective.csv'"),
    (("columns = [9, 10, 11]", "columns = [9, 10, 0]"), "[measure 1] columns (item 3): 0 (int) is not a whole "
                                                        "number ≥ 1"),
    (("ignore = [1, 2]", "ignore = [1, 2, 9]"), "[data] ignore: column '9' is also named by [measure 1] columns"),
    (("ignore = [1, 2]", 'ignore = [1, 2]\nsample = 3'), "[data] sample: column '3' is also named by [joints]"),
    (('frame = "tool0"', 'frame = "tool0"\nsupport = "nowhere"'), "[measure 1] frame: frame 'nowhere'"),
])
def test_a_positional_job_s_mistakes_are_one_line_errors(campaign: Path, tmp_path: Path, change: tuple[str, str],
                                                        message: str) -> None:
    defective = tmp_path / "defective.csv"
    defective.write_bytes(campaign.read_bytes())
    job = write_job(tmp_path, defective, "skip", True)
    text = job.read_text(encoding="utf-8")
    assert change[0] in text
    job.write_text(text.replace(change[0], change[1]), encoding="utf-8")
    assert message in one_line_error("calibrate", str(job))


def test_only_a_plane_contact_goes_without_columns_or_with_a_support(tmp_path: Path, campaign: Path) -> None:
    job = write_job(tmp_path, campaign, "names", False)
    (tmp_path / campaign.name).write_bytes(campaign.read_bytes())
    text = job.read_text(encoding="utf-8").replace('kind = "plane"', 'kind = "position"')
    job.write_text(text.replace("columns = [", 'support = "base_link"\ncolumns = ['), encoding="utf-8")
    assert "[measure 1] support: only a contact with a plane is held by a support; a position is not" in \
        one_line_error("calibrate", str(job))


def test_a_column_named_by_its_name_and_by_its_position_is_refused(tmp_path: Path, campaign: Path) -> None:
    job = write_job(tmp_path, campaign, "names", False)
    (tmp_path / campaign.name).write_bytes(campaign.read_bytes())
    job.write_text(job.read_text(encoding="utf-8").replace('ignore = ["sample", "set"]',
                                                           'ignore = ["sample", "set"]\nsample = 1'),
                   encoding="utf-8")
    assert "column 'sample' is named twice (by its name and by its position, or also under [data] ignore)" in \
        one_line_error("calibrate", str(job))


def test_the_summary_and_the_page_name_the_errors_of_a_plane_contact(campaign: Path, tmp_path: Path) -> None:
    """The before/after table says what was measured: distances to the plane [mm] and tilts [mrad], not positions;
    the page of the TALOS's contact job (no frame named like an end effector) is drawn at its contact frame."""
    done = run_pincal("calibrate", "ur10", str(campaign), "--report", str(tmp_path / "r.json"))
    report = json.loads((tmp_path / "r.json").read_text(encoding="utf-8"))
    rows = {line.split("  ")[0]: line.split() for line in done.stdout.splitlines() if line.startswith(("RMS", "max"))}
    assert set(rows) == {"RMS plane distance error (fit)", "max plane distance error (fit)", "RMS tilt error (fit)",
                         "max tilt error (fit)"}, done.stdout
    assert rows["RMS plane distance error (fit)"][-4:] == [f"{report['rms_before'] * 1e3:.4f}", "mm",
                                                           f"{report['rms_after'] * 1e3:.4f}", "mm"]
    assert rows["RMS tilt error (fit)"][-4:] == [f"{report['rms_angle_before'] * 1e3:.4f}", "mrad",
                                                 f"{report['rms_angle_after'] * 1e3:.4f}", "mrad"]
    job = ROOT / "examples" / "data" / "talos_table_contact" / "left_job.toml"
    page = tmp_path / "talos.html"
    done = run_pincal("report", str(job), "--out", str(page))
    assert done.returncode == 0 and "Traceback" not in done.stderr, done.stderr
    lines = done.stdout.splitlines()  # what it does first, then its figures
    assert lines[0].startswith("calibrating 'talos' from 21 samples") and \
        lines[1].startswith("RMS plane distance error "), done.stdout
    text = page.read_text(encoding="utf-8")
    for label in ("RMS plane distance error (held out)", "RMS tilt error (fit)",
                  'aria-label="histograms of the plane distance errors before and after calibration'):
        assert label in text
