"""Job files: the TOML schema and every error it names (pincal.calibration.job), and the user's columns read into a
Dataset in SI units (pincal.calibration.job_data)."""

from __future__ import annotations

import csv
import json
import math
from pathlib import Path

import numpy as np
import pytest
from conftest import ROOT, run_pincal

import pincal
from pincal.calibration.job import Job, read_job
from pincal.calibration.job_data import job_dataset
from pincal.calibration.options import GivenOption, GivenOptions
from pincal.errors import DataError, NotFoundError, PincalError
from pincal.identification.corrections import Payload
from pincal.io.dataset_reader import read_dataset

RAW = ROOT / "examples" / "data" / "tiago_mocap_raw.csv"
CONVERTED = ROOT / "examples" / "data" / "tiago_mocap_marker1.csv"
EXAMPLE = ROOT / "examples" / "tiago_job.toml"
JOB = """robot = "tiago_no_hand"
{top}
[data]
file = "{file}"
held_out = "every 5th from 4"
ignore = ["x2", "y2", "z2", "x3", "y3", "z3", "x4", "y4", "z4"]
{data}
[[measure]]
kind = "position"
frame = "wrist_ft_tool_link"
columns = ["x1", "y1", "z1"]
sigma = 1e-3
{measure}
"""


@pytest.fixture(scope="module")
def tiago() -> pincal.Robot:
    return pincal.load_robot("tiago_no_hand")


def write_job(folder: Path, top: str = "", data: str = "", measure: str = "", file: str | Path = RAW,
              text: str | None = None, joints: str = "") -> Path:
    """A job for the raw TIAGo file (or ``text`` as it is) in ``folder``; ``joints``: lines of a [joints] table."""
    path = folder / "job.toml"
    table = f"[joints]\n{joints}" if joints else ""
    path.write_text(text if text is not None else JOB.format(top=top, data=data, measure=measure, file=file) + table,
                    encoding="utf-8")
    return path


def raw_rows() -> tuple[list[str], list[list[str]]]:
    rows = list(csv.reader(RAW.read_text(encoding="utf-8").splitlines()))
    return rows[0], rows[1:]


def write_csv(path: Path, header: list[str], rows: list[list[str]], preamble: str = "") -> Path:
    path.write_text(preamble + "\n".join(",".join(row) for row in [header, *rows]) + "\n", encoding="utf-8")
    return path


# --- what the job reads --------------------------------------------------------------------------------------------
def test_the_example_job_reads_the_raw_file_as_the_converted_one(tiago: pincal.Robot) -> None:
    """examples/tiago_job.toml on the raw file gives, bit for bit, the samples the converted CSV holds."""
    job = read_job(EXAMPLE)
    assert job.files == (EXAMPLE.parent / "data" / "tiago_mocap_raw.csv",) and job.options.calibration.select == "auto"
    ours, theirs = job_dataset(job, tiago), read_dataset(CONVERTED)
    assert ours.sample_ids == theirs.sample_ids and ours.sets == theirs.sets
    assert sorted(ours.joint_names) == sorted(theirs.joint_names)
    for name in theirs.joint_names:
        assert np.array_equal(ours.joint_column(name), theirs.joint_column(name))
    assert list(ours.measurements) == list(theirs.measurements)
    for key, values in theirs.measurements.items():
        assert np.array_equal(ours.measurements[key], values)
    assert ours.metadata["sigma position wrist_ft_tool_link"] == "0.001"  # the converted file's '# sigma position'


def test_units_are_converted_to_si(tmp_path: Path, tiago: pincal.Robot) -> None:
    header, rows = raw_rows()
    lengths = {c for c in header if c[0] in "xyz"} | {"torso_lift_joint"}
    scaled = [[repr(float(v) * (1e3 if c in lengths else 180 / math.pi)) for c, v in zip(header, row, strict=True)]
              for row in rows]
    path = write_csv(tmp_path / "mm_deg.csv", header, scaled)
    si = job_dataset(read_job(write_job(tmp_path)), tiago)
    ours = job_dataset(read_job(write_job(tmp_path, data='units = { length = "mm", angle = "deg" }', file=path)),
                       tiago)
    np.testing.assert_allclose(ours.joints, si.joints, rtol=1e-15, atol=0)
    np.testing.assert_allclose(ours.measurements["position:wrist_ft_tool_link"],
                               si.measurements["position:wrist_ft_tool_link"], rtol=1e-15, atol=0)


def test_a_unit_per_measurement_and_per_joint_over_the_file_wide_one(tmp_path: Path, tiago: pincal.Robot) -> None:
    """Markers in mm, the torso in cm, the arm in mrad, beside a file-wide m and deg: each column read in its own."""
    header, rows = raw_rows()
    factor = {c: 1e3 for c in header if c[0] in "xyz"} | {"torso_lift_joint": 1e2}
    scaled = [[repr(float(v) * factor.get(c, 1e3)) for c, v in zip(header, row, strict=True)] for row in rows]
    path = write_csv(tmp_path / "mixed.csv", header, scaled)
    arm = "".join(f'arm_{k}_joint = {{ units = "mrad" }}\n' for k in range(1, 8))
    si = job_dataset(read_job(write_job(tmp_path)), tiago)
    job = read_job(write_job(tmp_path, data='units = { length = "m", angle = "deg" }', measure='units = "mm"',
                             joints=f'torso_lift_joint = {{ column = "torso_lift_joint", units = "cm" }}\n{arm}',
                             file=path))
    assert job.measures[0].length_unit == "mm" and job.joint_units["torso_lift_joint"] == "cm"
    ours = job_dataset(job, tiago)
    np.testing.assert_allclose(ours.joints, si.joints, rtol=1e-14, atol=0)
    np.testing.assert_allclose(ours.measurements["position:wrist_ft_tool_link"],
                               si.measurements["position:wrist_ft_tool_link"], rtol=1e-14, atol=0)
    assert ours.metadata["unit torso_lift_joint"] == "cm" and ours.metadata["unit arm_1_joint"] == "mrad"
    assert ours.metadata["column position wrist_ft_tool_link"] == "x1, y1, z1"


def test_a_joint_unit_of_the_other_kind_is_refused(tmp_path: Path, tiago: pincal.Robot) -> None:
    job = read_job(write_job(tmp_path, joints='torso_lift_joint = { units = "deg" }'))
    with pytest.raises(DataError, match=r"\[joints\] torso_lift_joint units: 'deg' is not a unit of a prismatic "
                                        "joint's readings; units are: m, cm, mm, um, in"):
        job_dataset(job, tiago)


def test_held_out_rows_by_pattern_by_list_and_by_column(tmp_path: Path, tiago: pincal.Robot) -> None:
    expected = ["test" if k in (4, 9, 14, 19, 24, 29) else "train" for k in range(34)]
    listed = JOB.format(top="", data="", measure="", file=RAW).replace(
        'held_out = "every 5th from 4"', "held_out = [4, 9, 14, 19, 24, 29]")
    assert job_dataset(read_job(write_job(tmp_path, text=listed)), tiago).sets == expected
    header, rows = raw_rows()
    words = ["yes" if s == "test" else "no" for s in expected]
    path = write_csv(tmp_path / "marked.csv", [*header, "holdout"], [[*r, w] for r, w in zip(rows, words, strict=True)])
    marked = JOB.format(top="", data="", measure="", file=path).replace('"every 5th from 4"', '"holdout"')
    assert job_dataset(read_job(write_job(tmp_path, text=marked)), tiago).sets == expected


def test_several_files_are_concatenated_with_ids_made_unique(tmp_path: Path, tiago: pincal.Robot) -> None:
    header, rows = raw_rows()
    (tmp_path / "day1").mkdir()
    write_csv(tmp_path / "day1" / "a.csv", header, rows[:20])
    write_csv(tmp_path / "b.csv", header, rows[20:])
    text = JOB.format(top="", data="", measure="", file="").replace('file = ""', 'files = ["day1/a.csv", "b.csv"]')
    data = job_dataset(read_job(write_job(tmp_path, text=text)), tiago)
    single = job_dataset(read_job(write_job(tmp_path / "day1", text=JOB.format(top="", data="", measure="",
                                                                               file=RAW))), tiago)
    assert data.sample_ids == [f"day1/a.csv:{k}" for k in range(20)] + [f"b.csv:{k}" for k in range(14)]
    assert data.sets == single.sets  # 'every 5th from 4' counts over the files in order
    assert np.array_equal(data.joints, single.joints)


def test_joint_columns_named_otherwise_are_mapped(tmp_path: Path, tiago: pincal.Robot) -> None:
    header, rows = raw_rows()
    path = write_csv(tmp_path / "renamed.csv", ["q_torso" if c == "torso_lift_joint" else c for c in header], rows)
    job = read_job(write_job(tmp_path, data='[joints]\ntorso_lift_joint = "q_torso"', file=path))
    assert job.joints == {"torso_lift_joint": "q_torso"}
    np.testing.assert_array_equal(job_dataset(job, tiago).joint_column("torso_lift_joint"),
                                  read_dataset(CONVERTED).joint_column("torso_lift_joint"))


def test_options_given_elsewhere_override_the_job(tmp_path: Path) -> None:
    job = read_job(write_job(tmp_path, top='cv = "5x4"\nselect = "bic"\nout = "cal.urdf"'))
    assert job.options.given == (GivenOption("select", "bic", job.path), GivenOption("cv", "5x4", job.path))
    assert job.out == tmp_path / "cal.urdf"
    command_line = GivenOptions.of({"cv": "loo", "select": None, "solver": "tsvd"}, "command line")
    again = job.overridden("other.urdf", None, command_line)
    made = again.options.calibration
    assert (made.cv, made.select, made.solver, made.loss) == ("loo", "bic", "tsvd", "auto")
    assert [again.options.source(name) for name in ("cv", "select", "solver", "loss")] == [
        "command line", job.path, "command line", "keyword"]
    assert again.out == Path("other.urdf") and again.report is None
    with pytest.raises(NotFoundError, match=r"option 'colour' does not exist of calibrate\(\); options are: param"):
        GivenOptions.of({"colour": "red"}, "command line")


def test_a_payload_is_read_and_overridden(tmp_path: Path) -> None:
    job = read_job(write_job(tmp_path, top='payload = { mass = 1.5, frame = "arm_7_link", offset = [0, 0, 0.1] }'))
    assert job.options.given == (GivenOption("payload", Payload(1.5, "arm_7_link", (0.0, 0.0, 0.1)), job.path),)
    again = read_job(write_job(tmp_path, top='payload = { mass = 2, frame = "arm_7_link" }'))
    assert again.options.calibration.payload == Payload(2.0, "arm_7_link")
    heavier = GivenOptions.of({"payload": Payload(3.0, "arm_6_link")}, "command line")
    assert job.overridden(options=heavier).options == heavier
    assert job.overridden(options=GivenOptions.of({"payload": None}, "command line")).options == job.options


# --- what the job refuses: its own keys and values -----------------------------------------------------------------
@pytest.mark.parametrize(("change", "message"), [
    ({"top": 'slover = "lm"'}, "job.toml: key 'slover' does not exist at the top level; keys are: robot, data, joints"),
    ({"data": 'held_ot = "x"'}, "job.toml: key 'held_ot' does not exist in [data]; keys are: file, files, units"),
    ({"data": 'units = { angel = "deg" }'}, "key 'angel' does not exist in [data] units; keys are: length, angle"),
    ({"measure": 'frme = "x"'}, "key 'frme' does not exist in [measure 1]; keys are: kind, frame, frames, columns"),
    ({"measure": 'cv = "5"'}, "key 'cv' does not exist in [measure 1]; keys are: kind, frame, frames, columns, units, "
                              "sigma, sigma_angle, support ('cv' is a top-level key: write it above the first "
                              "[table])"),
    ({"data": 'units = { length = "furlong" }'}, "job.toml: [data] units: length: 'furlong' is not one of: m, cm, mm"),
    ({"measure": 'units = "deg"'}, "job.toml: [measure 1] units: 'deg' is not one of: m, cm, mm, um, in"),
    ({"joints": 'torso_lift_joint = { unit = "m" }'},
     "job.toml: key 'unit' does not exist in [joints] torso_lift_joint; keys are: column, units"),
    ({"joints": 'torso_lift_joint = { units = "furlong" }'},
     "job.toml: [joints] torso_lift_joint units: 'furlong' is not one of: m, cm, mm, um, in, rad, mrad, deg"),
    ({"top": "max_iter = 0"}, "job.toml: max_iter: 0 (int) is not a whole number ≥ 1"),
    ({"top": 'max_iter = "100"'}, "max_iter: '100' is not a whole number ≥ 1"),
    ({"top": "sigma = -1e-3"}, "sigma: -0.001 (float) is not a number > 0"),
    ({"top": 'select = "aic"'}, "select: 'aic' is not one of: auto, evidence, bic, cv, none"),
    ({"top": 'loss = "huber"'}, "loss: 'huber' is not one of: auto, linear, cauchy"),
    ({"top": 'cv = "5y"'}, "cv: '5y' is not K (folds), KxR"),
    ({"top": "cv_seed = -2"}, "cv_seed: -2 (int) is not a whole number ≥ 0"),
    ({"top": "parameters = 3"}, "parameters: 3 (int) is not a string nor a non-empty list of strings"),
    ({"data": 'files = ["b.csv"]'}, "[data]: give the data as file = "),
    ({"measure": 'sigma_angle = 1e-3'},
     "[measure 1] sigma_angle: only a pose or a camera's pose target has an orientation"),
    ({"measure": 'frames = ["a", "b"]'}, '[measure 1]: a position measurement names its frame as frame = "NAME"'),
    ({"top": 'payload = { mass = -1.5, frame = "arm_7_link" }'}, "job.toml: payload mass -1.5 kg: a mass is a "
                                                                 "finite number ≥ 0 [kg]"),
    ({"top": 'payload = { mass = 1.5, frame = "arm_7_link", offset = [0, 0.1] }'},
     "payload offset 0, 0.1: give three finite numbers x, y, z [m] in frame 'arm_7_link'"),
    ({"top": 'payload = { mass = "1.5", frame = "arm_7_link" }'}, "mass is a number [kg], offset a list of three"),
    ({"top": 'payload = { mass = 1.5 }'}, "payload {'mass': 1.5} is not {mass = KG, frame = \"NAME\""),
    ({"top": 'payload = { mass = 1.5, frame = "arm_7_link", ofset = [0, 0, 1] }'},
     "key 'ofset' does not exist in payload; keys are: mass, frame, offset"),
    ({"top": 'payload = "1.5@arm_7_link"'}, "payload: '1.5@arm_7_link' is not a table"),
    ({"data": '[joints]\narm_1_joint = "x1"'},
     "[joints] arm_1_joint: column 'x1' is also named by [measure 1] columns"),
])
def test_a_key_or_value_the_job_cannot_take_is_named(tmp_path: Path, change: dict[str, str], message: str) -> None:
    job = write_job(tmp_path, **change)
    with pytest.raises(PincalError) as caught:
        read_job(job)
    assert message in str(caught.value) and str(caught.value).startswith(f"{job}: ")


def test_an_unknown_key_lists_the_valid_ones_as_a_lookup_does(tmp_path: Path) -> None:
    with pytest.raises(NotFoundError) as caught:
        read_job(write_job(tmp_path, top="max_iters = 50"))
    assert caught.value.name == "max_iters" and "max_iter" in caught.value.choices


@pytest.mark.parametrize(("top", "option"), [("max_iter = 0", "max_iter"), ('loss = "lorentz"', "loss"),
                                           ('cv = "fivefold"', "cv"), ("sigma = -1.0", "sigma"),
                                           ('prior = "strong"', "prior"), ("payload = { mass = -1.0 }", "payload")])
def test_a_bad_option_names_the_job_file_and_the_option_as_fields(tmp_path: Path, top: str, option: str) -> None:
    job = write_job(tmp_path, top=top)
    with pytest.raises(DataError) as caught:
        read_job(job)
    assert (caught.value.file, caught.value.option, caught.value.line) == (str(job), option, None)


def test_a_fault_of_the_job_names_its_file_and_a_toml_fault_its_line(tmp_path: Path) -> None:
    text = JOB.format(top="", data="", measure="", file=RAW)
    with pytest.raises(DataError) as caught:
        read_job(write_job(tmp_path, text=text.replace('kind = "position"', 'kind = "temperature"')))
    assert (caught.value.file, caught.value.option) == (str(tmp_path / "job.toml"), None)
    with pytest.raises(NotFoundError) as missing:
        read_job(write_job(tmp_path, top="max_iters = 50"))
    assert (missing.value.file, missing.value.name) == (str(tmp_path / "job.toml"), "max_iters")
    lines = text.splitlines()
    broken = lines.index('kind = "position"')
    lines[broken] = 'kind = "position'
    with pytest.raises(DataError) as toml:
        read_job(write_job(tmp_path, text="\n".join(lines)))
    assert (toml.value.file, toml.value.line) == (str(tmp_path / "job.toml"), broken + 1)


@pytest.mark.parametrize(("old", "new", "message"), [
    ('columns = ["x1", "y1", "z1"]', 'columns = ["x1", "y1"]', "[measure 1] columns: 2 columns; a position needs 3, "
                                                               "one per component in this order: x, y, z"),
    ('kind = "position"', 'kind = "temperature"', "[measure 1] kind: 'temperature' is not one of: position, pose"),
    ('held_out = "every 5th from 4"', 'held_out = "every fifth"', "is not of the form 'every K[th] [from S]'"),
    ('held_out = "every 5th from 4"', 'held_out = "every 1st"', "[data] held_out: 'every 1st' holds out every row"),
    ('held_out = "every 5th from 4"', "held_out = [4, 4]", "[data] held_out: a row is listed twice"),
    ('robot = "tiago_no_hand"', 'robot = "robots/tiago.urdf"', "robot: 'robots/tiago.urdf' does not exist (looked "
                                                               "for '"),
    ('robot = "tiago_no_hand"', "", "'robot' is missing: a job names its robot, and its data"),
    ('robot = "tiago_no_hand"', 'robot = "tiago_no_hand', "not a valid TOML file: "),
    ("[[measure]]", "[other]", "key 'other' does not exist at the top level"),
])
def test_a_malformed_job_is_named(tmp_path: Path, old: str, new: str, message: str) -> None:
    text = JOB.format(top="", data="", measure="", file=RAW)
    assert old in text
    with pytest.raises(PincalError) as caught:
        read_job(write_job(tmp_path, text=text.replace(old, new)))
    assert message in str(caught.value)


def test_a_job_without_measurements_says_how_to_declare_them(tmp_path: Path) -> None:
    text = JOB.format(top="", data="", measure="", file=RAW).split("[[measure]]")[0]
    with pytest.raises(DataError, match=r"job.toml: measure: declare each measurement as a \[\[measure\]\] table"):
        read_job(write_job(tmp_path, text=text))


def test_data_files_are_found_relative_to_the_job(tmp_path: Path) -> None:
    (tmp_path / "jobs").mkdir()
    (tmp_path / "raw.csv").write_bytes(RAW.read_bytes())
    with pytest.raises(DataError) as caught:
        read_job(write_job(tmp_path / "jobs", file="raw.csv"))
    assert f"[data] file: 'raw.csv' does not exist (looked for '{(tmp_path / 'jobs' / 'raw.csv').absolute()}': " \
           "paths in a job file are relative to its directory)" in str(caught.value)
    assert read_job(write_job(tmp_path / "jobs", file="../raw.csv")).files == (tmp_path / "jobs" / ".." / "raw.csv",)


def test_a_missing_job_file_is_named(tmp_path: Path) -> None:
    with pytest.raises(DataError, match=r"cannot read job file '.*nope\.toml': No such file"):
        read_job(tmp_path / "nope.toml")


# --- what the job refuses: the data as the job maps it -------------------------------------------------------------
def test_columns_the_job_does_not_account_for_are_named(tmp_path: Path, tiago: pincal.Robot) -> None:
    job = read_job(write_job(tmp_path, text=JOB.format(top="", data="", measure="", file=RAW).replace(
        'ignore = ["x2", "y2", "z2", "x3", "y3", "z3", "x4", "y4", "z4"]', 'ignore = ["x2", "y2", "z2"]')))
    with pytest.raises(DataError) as caught:
        job_dataset(job, tiago)
    assert ("job.toml: [data] file '" in str(caught.value) and "columns x3, y3, z3, x4, y4, z4 are not joints of robot "
            "'tiago' and the job does not name them: list them under [data] ignore" in str(caught.value))


@pytest.mark.parametrize(("change", "error", "message"), [
    ({"measure": ""}, None, ""),  # the reference: reads
    ({"data": "[joints]\narm_9_joint = \"q9\""}, NotFoundError,
     "job.toml: [joints] arm_9_joint: joint 'arm_9_joint' does not exist in robot 'tiago'; joints are: torso_lift"),
    ({"data": "[joints]\narm_1_joint = \"q1\""}, NotFoundError,
     "job.toml: [joints] arm_1_joint: column 'q1' does not exist in data file '"),
    ({"data": 'sample = "id"'}, NotFoundError, "job.toml: [data] sample: column 'id' does not exist in data file '"),
])
def test_what_the_data_lacks_is_named(tmp_path: Path, tiago: pincal.Robot, change: dict[str, str],
                                      error: type[Exception] | None, message: str) -> None:
    job = read_job(write_job(tmp_path, text=JOB.format(top="", file=RAW, **{"data": "", "measure": "", **change})))
    if error is None:
        assert job_dataset(job, tiago).n_samples == 34
        return
    with pytest.raises(error) as caught:
        job_dataset(job, tiago)
    assert message in str(caught.value)


def test_a_column_the_csv_lacks_is_named_with_the_columns_it_has(tmp_path: Path, tiago: pincal.Robot) -> None:
    job = read_job(write_job(tmp_path, text=JOB.format(top="", data="", measure="", file=RAW).replace('"z1"', '"z9"')))
    with pytest.raises(NotFoundError) as caught:
        job_dataset(job, tiago)
    assert str(caught.value).startswith(f"{tmp_path / 'job.toml'}: [measure 1] columns: column 'z9' does not exist in "
                                        f"data file '{RAW}'; columns are: x1, y1, z1, x2")


def test_a_frame_the_robot_lacks_is_named(tmp_path: Path, tiago: pincal.Robot) -> None:
    text = JOB.format(top="", data="", measure="", file=RAW).replace('"wrist_ft_tool_link"', '"wrist"')
    with pytest.raises(NotFoundError, match=r"\[measure 1\] frame: frame 'wrist' does not exist in robot 'tiago'"):
        job_dataset(read_job(write_job(tmp_path, text=text)), tiago)


@pytest.mark.parametrize(("edit", "message"), [
    (lambda h, r: (h, [r[0], [*r[1][:1], "abc", *r[1][2:]], *r[2:]]), "column 'y1', line 3: 'abc' is not a number"),
    (lambda h, r: (h, [r[0], [*r[1][:-1], ""], *r[2:]]), "column 'arm_7_joint', line 3: the cell is empty"),
    (lambda h, r: (h, [r[0], r[0], *r[2:]]), "duplicated samples (identical joint readings and measurements): line 3 "
                                             "repeats line 2"),
    (lambda h, r: (h, [[repr(float(v) * 1e3) if c == "x1" else v for c, v in zip(h, row, strict=True)] for row in r]),
     "looks like millimetres; pincal expects metres (|value| > 20 m on 34 of 34 rows) (the job reads lengths in m "
     "and angles in rad: state the file's units under [data] units, or a column's own as [[measure]] units or "
     "[joints] NAME = { units = ... })"),
])
def test_a_bad_cell_is_named_with_the_file_the_column_and_the_line(tmp_path: Path, tiago: pincal.Robot,
                                                                   edit: object, message: str) -> None:
    header, rows = edit(*raw_rows())  # type: ignore[operator]
    path = write_csv(tmp_path / "bad.csv", header, rows)
    with pytest.raises(DataError) as caught:
        job_dataset(read_job(write_job(tmp_path, file=path)), tiago)
    assert str(caught.value).startswith(f"{tmp_path / 'job.toml'}: [data] file '{path}': ") and message in \
        str(caught.value)


def test_a_file_recorded_on_another_robot_is_refused(tmp_path: Path, tiago: pincal.Robot) -> None:
    path = write_csv(tmp_path / "ur5.csv", *raw_rows(), preamble="# robot: ur5\n")
    with pytest.raises(DataError, match="its '# robot: ur5' line says the data are of robot 'ur5', not of 'tiago'"):
        job_dataset(read_job(write_job(tmp_path, file=path)), tiago)


def test_held_out_rows_beyond_the_data_and_bad_held_out_cells_are_named(tmp_path: Path, tiago: pincal.Robot) -> None:
    text = JOB.format(top="", data="", measure="", file=RAW)
    job = read_job(write_job(tmp_path, text=text.replace('"every 5th from 4"', "[3, 40]")))
    with pytest.raises(DataError, match=r"\[data\] held_out: 'rows 3, 40' names rows 40, beyond the last row \(33\)"):
        job_dataset(job, tiago)
    header, rows = raw_rows()
    path = write_csv(tmp_path / "marked.csv", [*header, "use"], [[*r, "maybe"] for r in rows])
    job = read_job(write_job(tmp_path, text=text.replace(str(RAW), str(path)).replace('"every 5th from 4"', '"use"')))
    with pytest.raises(DataError, match="column 'use', line 2: 'maybe' does not say whether the row is held out; "
                                        "cells are: test, true, yes, 1, train"):
        job_dataset(job, tiago)


def test_an_ignored_column_no_file_has_is_named(tmp_path: Path, tiago: pincal.Robot) -> None:
    text = JOB.format(top="", data="", measure="", file=RAW).replace('"z4"]', '"z4", "x5"]')
    with pytest.raises(DataError, match=r"\[data\] ignore: x5 is a column of no data file; columns are: x1, y1, z1"):
        job_dataset(read_job(write_job(tmp_path, text=text)), tiago)


def test_a_distance_increment_needs_one_file(tmp_path: Path) -> None:
    text = JOB.format(top="", data="", measure="", file=RAW)
    text = text.replace(f'file = "{RAW}"', f'files = ["{RAW}", "{CONVERTED}"]')
    text += ('[[measure]]\nkind = "distance_increment"\nframes = ["arm_1_link", "arm_7_link"]\n'
             'columns = ["arm_7_joint"]\n')
    with pytest.raises(DataError, match="a distance_increment measurement needs a single data file"):
        read_job(write_job(tmp_path, text=text))


def test_a_job_is_a_plain_value(tmp_path: Path) -> None:
    job = read_job(write_job(tmp_path))
    assert isinstance(job, Job) and job.measures[0].key == "position:wrist_ft_tool_link"
    assert job.measures[0].columns == ("x1", "y1", "z1") and job.measures[0].sigma == 1e-3
    assert job.held_out is not None and (job.held_out.every, job.held_out.start) == (5, 4)


def test_the_fuller_example_of_docs_job_file_is_a_valid_job(tmp_path: Path) -> None:
    page = (ROOT / "docs" / "job_file.md").read_text(encoding="utf-8")
    text = page.split("```toml\n")[1].split("```")[0]
    (tmp_path / "urdf").mkdir()
    for name in ("urdf/my_arm.urdf", "day1.csv", "day2.csv"):
        (tmp_path / name).write_text("", encoding="utf-8")
    job = read_job(write_job(tmp_path, text=text))
    assert job.robot == str(tmp_path / "urdf" / "my_arm.urdf") and job.file_names == ("day1.csv", "day2.csv")
    assert [given.name for given in job.options.given] == ["parameter_spec", "select", "loss", "solver", "max_iter",
                                                           "formulation", "cv", "cv_seed", "plausible", "prior"]
    made = job.options.calibration
    assert (made.parameter_spec, made.select, made.cv, made.cv_seed, made.loss, made.solver, made.formulation,
            made.max_iter, made.plausible, made.prior) == (("default", "!base.*"), "auto", "5x4", 0, "auto", "lm",
                                                           "fkm", 100, 1.0, 1.0)
    assert (job.length_unit, job.angle_unit, job.sample, job.ignore) == ("mm", "deg", "pose_id",
                                                                         ("timestamp", "marker_quality"))
    assert job.joints == {"shoulder_pan_joint": "J1", "shoulder_lift_joint": "J2"}
    assert [m.key for m in job.measures] == ["position:tool0", "distance:base_link-tool0"]
    assert job.out == tmp_path / "out" / "my_arm_calibrated.urdf"


def test_report_and_view_take_a_job_file_as_calibrate_does(tmp_path: Path) -> None:
    job = ROOT / "examples" / "tiago_job.toml"
    done = run_pincal("calibrate", str(job), "--report", str(tmp_path / "r.json"), "--max-iter", "30")
    assert done.returncode == 0, done.stderr
    fitted = json.loads((tmp_path / "r.json").read_text(encoding="utf-8"))
    assert fitted["n_test_samples"] == 6  # the job's held-out rows: every 5th from 4 of 34
    page = tmp_path / "p.html"
    done = run_pincal("report", str(job), "--out", str(page), "--max-iter", "30", "--quiet")
    assert done.returncode == 0, done.stderr
    assert f"{fitted['test_rms_after'] * 1e3:.4f} mm" in page.read_text(encoding="utf-8")  # the job's fit
    scene = tmp_path / "s.html"
    done = run_pincal("view", str(job), "--out", str(scene), "--result", str(tmp_path / "r.json"), "--quiet")
    assert done.returncode == 0, done.stderr
    assert f"{fitted['n_samples']} samples" in done.stdout  # the fitted samples drawn, as with a CSV
    for argv, message in [(("report", str(job), "extra.csv", "--out", str(page)), "is a job file, which names its "
                                                                                  "own data"),
                          (("view", "delta", "--out", str(scene)), "view: DATA is missing")]:
        done = run_pincal(*argv)
        assert done.returncode == 2 and done.stderr.startswith("pincal: error: ") and message in done.stderr
        assert len(done.stderr.splitlines()) == 1
