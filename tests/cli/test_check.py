"""``pincal check MODEL DATA``: a calibrated model predicts new measurements, beside the nominal robot (docs/check.md).

A simulated Delta is calibrated; a second simulation of the *same* truth (same seed: the truth is drawn before the
postures, so ``truth.json`` is the same file) on other postures is the new data. The calibrated model predicts them
to the noise (σ 10 µm per coordinate) where the nominal robot is off by a millimetre; moving the tracker (a rigid
motion of the new positions) spoils the model as it stands, and ``--register`` recovers it.
"""

from __future__ import annotations

import hashlib
import html
import json
import math
import re
from pathlib import Path
from typing import Any

import numpy as np
import pinocchio as pin
import pytest
from conftest import run_pincal

import pincal
from pincal.io.dataset import dataset_text
from pincal.io.dataset_reader import read_dataset

NOISE = 1e-5  # [m] per coordinate: a 3D error of about √3 · 10 µm
EXAMPLES = Path(__file__).resolve().parents[2] / "examples" / "data"


def _ok(done: object, *codes: int) -> None:
    assert done.returncode in (codes or (0,)), done.stderr  # type: ignore[attr-defined]


@pytest.fixture(scope="module")
def delta(tmp_path_factory: pytest.TempPathFactory) -> Path:
    """D/: a Delta simulated (40 + 20 postures, seed 1) and calibrated (cal.urdf, r.json); N/: 90 postures of the
    same truth, new.csv: 30 of them the calibration did not see; moved.csv: their positions in a tracker frame moved
    by 0.3 rad and 0.2 m."""
    root = tmp_path_factory.mktemp("check")
    _ok(run_pincal("simulate", "delta", "--measure", "position", "--samples", "40", "--test-samples", "20", "--seed",
                   "1", "--out", str(root / "D"), "--quiet"))
    _ok(run_pincal("calibrate", "delta", str(root / "D" / "measurements.csv"), "--out", str(root / "D" / "cal.urdf"),
                   "--report", str(root / "D" / "r.json")))
    _ok(run_pincal("simulate", "delta", "--measure", "position", "--samples", "90", "--seed", "1", "--out",
                   str(root / "N"), "--quiet"))
    assert (root / "N" / "truth.json").read_bytes() == (root / "D" / "truth.json").read_bytes()  # the same robot
    old, drawn = (read_dataset(root / d / "measurements.csv") for d in ("D", "N"))
    other = [k for k, row in enumerate(drawn.joints) if not any(np.allclose(row, seen) for seen in old.joints)]
    new = drawn.subset(other[:30])  # postures the calibration did not see
    assert new.n_samples == 30
    (root / "new.csv").write_text(dataset_text(new), encoding="utf-8")
    rotation, shift = pin.rpy.rpyToMatrix(0.1, -0.05, 0.3), np.array([0.2, -0.1, 0.05])
    new.measurements = {key: values @ rotation.T + shift for key, values in new.measurements.items()}
    (root / "moved.csv").write_text(dataset_text(new), encoding="utf-8")
    return root


def _check(*args: str, code: int | None = 0, where: Path | None = None) -> dict:
    """``pincal check ARGS --report`` (the report in ``where``, default beside DATA): its exit status checked (None:
    0 or 1), its report read."""
    folder = where or Path(args[1]).parent
    report = folder / f"check-{hashlib.sha1(' '.join(args).encode()).hexdigest()[:8]}.json"
    done = run_pincal("check", *args, "--report", str(report))
    assert done.returncode in ((0, 1) if code is None else (code,)), done.stdout + done.stderr
    content = json.loads(report.read_text(encoding="utf-8"))
    content["stdout"] = done.stdout
    return content


def test_the_calibrated_model_predicts_new_postures_to_the_noise(delta: Path) -> None:
    out = _check(str(delta / "D" / "cal.urdf"), str(delta / "new.csv"), "--nominal", "delta")
    assert out["rms"] < 3 * NOISE and out["max"] < 10 * NOISE  # [m]
    assert 3e-4 < out["nominal_rms"] < 5e-3  # the nominal robot: about a millimetre off
    assert out["registered"] is False and out["worse_than_nominal"] is False
    assert out["n_samples"] == out["n_samples_in_file"] == 30 and len(out["samples"]) == 30
    (quantity,) = out["quantities"]
    assert quantity["measurement"] == "position:end_effector" and quantity["unit"] == "m" and quantity["n"] == 30
    assert quantity["rms"] == pytest.approx(out["rms"], rel=1e-12)
    errors = np.array([s["error"] for s in out["samples"]])
    assert math.sqrt(np.mean(errors**2)) == pytest.approx(out["rms"], rel=1e-9)
    assert max(s["nominal_error"] for s in out["samples"]) == pytest.approx(out["nominal_max"], rel=1e-12)
    assert "nothing estimated" in out["model_means"]
    assert "registered for it on its own data" in out["nominal_means"]  # calibrate's "before", as MODEL records it
    assert "position:end_effector" in out["stdout"] and " mm" in out["stdout"]


def test_a_moved_tracker_spoils_the_model_as_it_stands_and_register_recovers_it(delta: Path) -> None:
    model, moved = str(delta / "D" / "cal.urdf"), str(delta / "moved.csv")
    as_is = _check(model, moved, "--nominal", "delta", code=None)
    assert as_is["rms"] > 0.05 and as_is["nominal_rms"] > 0.05  # both sides in the setup the calibration found
    assert re.search(r"hint: (\d+) of 30 errors of MODEL exceed their predicted bound: .* check with --register",
                     as_is["stdout"])  # the hint
    registered = _check(model, moved, "--nominal", "delta", "--register")
    assert registered["rms"] < 3 * NOISE and registered["nominal_rms"] > 3e-4
    assert registered["registered"] is True and registered["setup"]["model_converged"] is True
    base = registered["setup"]["model"]
    assert math.hypot(base["base.tx"], base["base.ty"], base["base.tz"]) > 0.1  # the tracker's motion, found


def test_a_wrong_model_is_worse_than_nominal(delta: Path) -> None:
    """A Delta with 5 mm / 5 mrad errors of its own (another simulation's truth) is not this robot."""
    _ok(run_pincal("simulate", "delta", "--measure", "position", "--samples", "2", "--perturb", "5e-3", "--seed",
                   "7", "--out", str(delta / "W"), "--quiet"))
    for register in ((), ("--register",)):
        out = _check(str(delta / "W" / "truth.urdf"), str(delta / "new.csv"), "--nominal", "delta",
                     *register, code=1)
        assert out["rms"] > out["nominal_rms"] and out["worse_than_nominal"] is True
        assert "WORSE" in out["stdout"]


def test_a_report_json_is_the_same_model_as_its_urdf(delta: Path) -> None:
    data = str(delta / "new.csv")
    from_urdf = _check(str(delta / "D" / "cal.urdf"), data, "--nominal", "delta", "--register")
    from_json = _check(str(delta / "D" / "r.json"), data, "--nominal", "delta", "--register")
    for key in ("rms", "max", "nominal_rms", "nominal_max"):
        assert from_json[key] == pytest.approx(from_urdf[key], rel=1e-9, abs=1e-12), key
    assert [s["error"] for s in from_json["samples"]] == pytest.approx([s["error"] for s in from_urdf["samples"]],
                                                                       rel=1e-9, abs=1e-12)


def _sha(path: Path) -> str:
    return hashlib.sha256(path.read_bytes()).hexdigest()


def test_the_recorded_nominal_and_the_fitted_range(delta: Path, tmp_path: Path) -> None:
    """A calibrated URDF and a report JSON that record their nominal robot and data need no --nominal. The same
    Delta calibrated on postures within ±0.4 rad: the new postures outside the range of the fitted (set=train) ones,
    by more than 5 % of it, are flagged and have figures of their own."""
    folder = tmp_path / "cal"
    _ok(run_pincal("simulate", "delta", "--measure", "position", "--samples", "40", "--spread", "0.4", "--seed", "1",
                   "--out", str(folder / "sim"), "--quiet"))
    assert (folder / "sim" / "truth.json").read_bytes() == (delta / "D" / "truth.json").read_bytes()
    data = folder / "sim" / "measurements.csv"
    _ok(run_pincal("calibrate", "delta", str(data), "--out", str(folder / "cal.urdf"), "--report",
                   str(folder / "r.json")))  # both record their nominal robot and data (docs/calibrated_urdf.md)
    text = (folder / "cal.urdf").read_text(encoding="utf-8")
    assert f'data="sim/measurements.csv" data_sha256="{_sha(data)}"' in text
    plain = re.sub(r"\n\s*<pincal_calibration>.*?</pincal_calibration>", "", text, flags=re.S)
    (folder / "plain.urdf").write_text(re.sub(r"\n\s*<pincal_provenance[^>]*/>", "", plain), encoding="utf-8")
    fitted = read_dataset(data).of_set("train")
    new = read_dataset(delta / "new.csv")
    low, high = fitted.joints.min(axis=0), fitted.joints.max(axis=0)
    margin = 0.05 * (high - low)
    expected = [new.sample_ids[k] for k in range(new.n_samples)
                if np.any((new.joints[k] < low - margin) | (new.joints[k] > high + margin))]
    assert 5 <= len(expected) < 30
    for model in ("cal.urdf", "r.json"):
        out = _check(str(folder / model), str(delta / "new.csv"))
        assert out["nominal"] == "delta" and out["nominal_given"] is False  # the recorded name
        assert out["outside_range"]["known"] is True
        assert out["outside_range"]["samples"] == expected
        assert [s["sample"] for s in out["samples"] if s["outside_range"]] == expected
        outside = [s["error"] for s in out["samples"] if s["outside_range"]]
        assert out["outside_range"]["n_samples"] == len(expected)
        assert out["outside_range"]["rms"] == pytest.approx(math.sqrt(np.mean(np.square(outside))), rel=1e-9)
        assert out["inside_range"]["n_samples"] == 30 - len(expected)
        assert "outside the joint ranges the calibration fitted" in out["stdout"]
    unrecorded = _check(str(folder / "plain.urdf"), str(delta / "new.csv"), "--nominal", "delta")
    assert unrecorded["outside_range"]["known"] is False and "cannot be flagged" in unrecorded["stdout"]


def test_tiago_calibrated_on_some_postures_checked_on_the_others(tmp_path: Path) -> None:
    """Real data: the TIAGo calibrated on its set=train postures and checked on its six set=test ones. As it
    stands, the model's errors are the calibration's own held-out figure; re-registering the mocap frame and the
    marker on those six can only lower them, and the nominal robot stays worse."""
    source = EXAMPLES / "tiago_mocap_marker1.csv"
    _ok(run_pincal("calibrate", "tiago_no_hand", str(source), "--out", str(tmp_path / "cal.urdf"), "--report",
                   str(tmp_path / "r.json")))
    lines = source.read_text(encoding="utf-8").splitlines()
    rows = [line for line in lines if not line.startswith("#")]
    column = rows[0].split(",").index("set")
    held = [row for row in rows[1:] if row.split(",")[column] == "test"]
    (tmp_path / "test.csv").write_text("\n".join([*(line for line in lines if line.startswith("#")), rows[0], *held])
                                       + "\n", encoding="utf-8")
    calibration = json.loads((tmp_path / "r.json").read_text(encoding="utf-8"))
    as_is = _check(str(tmp_path / "cal.urdf"), str(tmp_path / "test.csv"), "--nominal", "tiago_no_hand")
    assert as_is["n_samples"] == calibration["n_test_samples"] == 6
    assert as_is["rms"] == pytest.approx(calibration["test_rms_after"], rel=1e-9)
    assert as_is["max"] == pytest.approx(calibration["test_max_after"], rel=1e-9)
    registered = _check(str(tmp_path / "cal.urdf"), str(tmp_path / "test.csv"), "--nominal", "tiago_no_hand",
                        "--register")
    assert registered["rms"] <= as_is["rms"]
    assert 1e-3 < registered["rms"] < registered["nominal_rms"] < 0.01
    cut = _check(str(tmp_path / "cal.urdf"), str(tmp_path / "test.csv"), "--nominal", "tiago_no_hand", "--register",
                 "--max-iter", "1", code=1)  # a registration stopped before it converged: exit 1, said
    assert cut["setup"]["nominal_converged"] is False and "NOT CONVERGED" in cut["stdout"]
    # the job file of the same data (the raw mocap file, read as the job says): every row, the same figures as the CSV
    job = _check(str(tmp_path / "cal.urdf"), str(EXAMPLES.parent / "tiago_job.toml"), "--nominal", "tiago_no_hand",
                 where=tmp_path)
    csv = _check(str(tmp_path / "cal.urdf"), str(source), "--nominal", "tiago_no_hand", where=tmp_path)
    assert job["n_samples"] == csv["n_samples"] == 34
    for key in ("rms", "max", "nominal_rms", "nominal_max"):
        assert job[key] == pytest.approx(csv[key], rel=1e-6), key


def test_the_html_page_states_the_figures(delta: Path) -> None:
    page = delta / "check.html"
    done = run_pincal("check", str(delta / "D" / "cal.urdf"), str(delta / "new.csv"), "--nominal",
                      "delta", "--html", str(page))
    assert done.returncode == 0, done.stderr
    text = page.read_text(encoding="utf-8")
    assert "<table>" in text and "position:end_effector" in text and "http" not in text.replace("http-equiv", "")
    alt = text.split('alt="', 1)[1].split('"', 1)[0]
    assert "30 samples" in alt and "MODEL RMS" in alt and "nominal robot RMS" in alt and " mm" in alt


def _error_line(done: object) -> str:
    lines = done.stderr.strip().splitlines()  # type: ignore[attr-defined]
    assert done.returncode == 2 and len(lines) == 1, done.stderr  # type: ignore[attr-defined]
    assert lines[0].startswith("pincal: error: ")
    return lines[0]


def test_errors_are_one_line(delta: Path, tmp_path: Path) -> None:
    model, data = str(delta / "D" / "cal.urdf"), delta / "new.csv"
    bare = tmp_path / "bare.urdf"  # a calibrated URDF that records nothing of its inputs
    text = (delta / "D" / "cal.urdf").read_text(encoding="utf-8")
    bare.write_text(re.sub(r"\n\s*<pincal_provenance[^>]*/>", "", text), encoding="utf-8")
    assert "--nominal" in _error_line(run_pincal("check", str(bare), str(data)))  # no provenance, no --nominal
    cut = tmp_path / "cut.json"  # a report JSON cut short is named so, not as one that records no robot
    cut.write_text((delta / "D" / "r.json").read_text(encoding="utf-8")[:500], encoding="utf-8")
    assert "is not a readable report JSON" in _error_line(run_pincal("check", str(cut), str(data)))
    other = tmp_path / "other.csv"
    other.write_text(data.read_text(encoding="utf-8").replace("position:end_effector:", "position:tool9:"),
                     encoding="utf-8")
    assert "tool9" in _error_line(run_pincal("check", model, str(other), "--nominal", "delta"))
    line = _error_line(run_pincal("check", model, str(data), "--nominal", "delta", "--set", "test"))
    assert "no set=test row (train 30)" in line  # a set with no row is said, not checked as an empty set
    before = data.read_bytes()
    line = _error_line(run_pincal("check", model, str(data), "--nominal", "delta", "--report", str(data)))
    assert "input" in line and data.read_bytes() == before


@pytest.mark.parametrize(("robot", "kinds", "quantities"), [
    ("hexapod_device", ["pose", "joint:device_lvdt"], {("pose:end_effector", "length"), ("pose:end_effector", "angle"),
                                                        ("joint:device_lvdt", "reading")}),
    ("ur10", ["camera:tool0"], {("camera:tool0", "length"), ("camera:tool0", "angle")}),
])
def test_other_kinds_to_the_noise(robot: str, kinds: list[str], quantities: set, tmp_path: Path) -> None:
    """A closed-loop robot read by poses and an instrumented passive joint (its <joint_sensor> zero applied), and an
    eye-in-hand camera (read from the file's camera and target links): the same truth on other postures is predicted
    to the noise as the model stands, and the nominal robot is not."""
    for out, samples in (("fit", "30"), ("new", "60")):
        _ok(run_pincal("simulate", robot, "--measure", *kinds, "--samples", samples, "--seed", "3", "--out",
                       str(tmp_path / out), "--quiet"))
    assert (tmp_path / "fit" / "truth.json").read_bytes() == (tmp_path / "new" / "truth.json").read_bytes()
    _ok(run_pincal("calibrate", robot, str(tmp_path / "fit" / "measurements.csv"), "--out", str(tmp_path / "cal.urdf")))
    out = _check(str(tmp_path / "cal.urdf"), str(tmp_path / "new" / "measurements.csv"), "--nominal", robot)
    assert {(q["measurement"], q["quantity"]) for q in out["quantities"]} == quantities
    for q in out["quantities"]:
        assert q["rms"] < 3 * NOISE and q["nominal_rms"] > 10 * q["rms"], q
    assert out["rms_angle"] < 3 * NOISE and out["nominal_rms_angle"] > 1e-3  # [rad]


def test_tiago_job_calibrated_then_checked_on_its_held_out_rows(tmp_path: Path) -> None:
    """The lifecycle on real data as a user runs it: the job file calibrates on its rows but the held-out ones, and
    ``check --set test`` takes those rows of the same job file. As it stands the model's figures are the calibration's
    own held-out ones; with ``--register`` (the mocap frame and the marker re-estimated on the six) they can only be
    lower, and the nominal robot, registered the same way, stays worse."""
    job = EXAMPLES.parent / "tiago_job.toml"
    _ok(run_pincal("calibrate", str(job), "--out", str(tmp_path / "cal.urdf"), "--report", str(tmp_path / "r.json")))
    calibration = json.loads((tmp_path / "r.json").read_text(encoding="utf-8"))
    as_is = _check(str(tmp_path / "cal.urdf"), str(job), "--set", "test", where=tmp_path)
    assert (as_is["rows"], as_is["n_samples"], as_is["n_samples_in_file"]) == ("test", 6, 34)
    assert "its set=test rows" in as_is["stdout"]
    assert as_is["rms"] == pytest.approx(calibration["test_rms_after"], rel=1e-9)
    registered = _check(str(tmp_path / "cal.urdf"), str(job), "--set", "test", "--register", where=tmp_path)
    assert registered["provenance"]["options"]["register"] is True
    assert registered["setup"]["model_converged"] is True
    assert registered["rms"] <= as_is["rms"] and registered["rms"] < registered["nominal_rms"]
    assert registered["outside_range"]["known"] is True  # the job file the calibration recorded gives the range
    raw = EXAMPLES / "tiago_mocap_raw.csv"  # no set column: every row is train
    line = _error_line(run_pincal("check", str(tmp_path / "cal.urdf"), str(job), "--set", "train", "--report",
                                  str(raw)))
    assert "input" in line


@pytest.mark.parametrize("key", ["plane:tool0", "plane_point:tool0"])
def test_contact_with_a_plane_is_checked_against_the_calibrated_plane(key: str, tmp_path: Path) -> None:
    """Contact data: MODEL's calibrated plane (its ``contact_plane`` link) predicts other postures of the same truth to
    the noise, the nominal robot with the plane calibrate registered for it does not; ``--register`` re-estimates the
    plane (the table may have moved), and a MODEL without the plane link is refused without it."""
    for out, samples in (("fit", "40"), ("new", "80")):
        _ok(run_pincal("simulate", "ur10", "--measure", key, "--samples", samples, "--seed", "3", "--out",
                       str(tmp_path / out), "--quiet"))
    _ok(run_pincal("calibrate", "ur10", str(tmp_path / "fit" / "measurements.csv"), "--out",
                   str(tmp_path / "cal.urdf")))
    new = str(tmp_path / "new" / "measurements.csv")
    for extra in ((), ("--register",)):
        out = _check(str(tmp_path / "cal.urdf"), new, *extra, where=tmp_path)
        assert any(name.startswith("plane.") for name in out["setup"]["parameters"])
        assert out["rms"] < 3 * NOISE < 0.1 * out["nominal_rms"], out["stdout"]
    text = (tmp_path / "cal.urdf").read_text(encoding="utf-8")
    (tmp_path / "bare.urdf").write_text(text.replace('"contact_plane"', '"other_plane"'), encoding="utf-8")
    line = _error_line(run_pincal("check", str(tmp_path / "bare.urdf"), new, "--nominal", "ur10"))
    assert "contact_plane" in line and "--register" in line


@pytest.mark.parametrize(("model", "data", "culprit", "words"), [
    ("passwd", "new.csv", "MODEL", "is text that is neither XML nor a measurement CSV, where a model was expected"),
    ("folder", "new.csv", "MODEL", "is a directory, where a model was expected"),
    ("new.csv", "new.csv", "MODEL", "is a measurement CSV, where a model was expected"),
    ("D/cal.urdf", "D/cal.urdf", "DATA", "is a URDF, where data were expected"),
    ("D/cal.urdf", "D/r.json", "DATA", "is a JSON file (a report?), where data were expected"),
    ("D/cal.urdf", "folder", "DATA", "is a directory, where data were expected"),
    ("no_such_robot", "new.csv", "MODEL", "does not exist (no such file, and no known robot of that name)"),
])
def test_a_model_or_data_of_the_wrong_kind_is_named_in_one_line(delta: Path, model: str, data: str, culprit: str,
                                                                words: str) -> None:
    """MODEL and DATA that are not what check reads: the argument, what it is, and what MODEL and DATA should be."""
    (delta / "passwd").write_text("root:x:0:0:root:/root:/bin/bash\n", encoding="utf-8")  # a system's text file
    (delta / "folder").mkdir(exist_ok=True)
    given = {"MODEL": model if model == "no_such_robot" else str(delta / model), "DATA": str(delta / data)}
    line = _error_line(run_pincal("check", given["MODEL"], given["DATA"]))
    assert f"{culprit} '{given[culprit]}' {words}: " in line
    assert "MODEL is a calibrated URDF, a known robot name or a report JSON" in line
    assert "DATA a measurement CSV or a job file" in line


def test_a_nominal_robot_other_than_the_one_model_records_is_refused(tmp_path: Path) -> None:
    """A UR10 calibrated by pincal, checked on its own data (without their '# robot:' line) with ``--nominal ur5``
    (the same joints): the culprit is the nominal robot, not DATA, so one line names both robots; the recorded robot,
    by name or as a copy of its URDF elsewhere, is accepted (issue 36)."""
    _ok(run_pincal("simulate", "ur10", "--samples", "30", "--seed", "2", "--out", str(tmp_path / "sim"), "--quiet"))
    model = tmp_path / "cal.urdf"
    _ok(run_pincal("calibrate", "ur10", str(tmp_path / "sim" / "measurements.csv"), "--out", str(model), "--select",
                   "none"))
    data = tmp_path / "data.csv"
    lines = (tmp_path / "sim" / "measurements.csv").read_text(encoding="utf-8").splitlines(keepends=True)
    data.write_text("".join(line for line in lines if not line.startswith("# robot:")), encoding="utf-8")
    line = _error_line(run_pincal("check", str(model), str(data), "--nominal", "ur5"))
    assert line == (f"pincal: error: --nominal ur5 is not the robot MODEL was calibrated from ('ur10', as '{model}' "
                    "records): leave it out, or give that robot")
    copy = tmp_path / "elsewhere.urdf"
    copy.write_bytes(Path(str(pincal.load_robot("ur10").source)).read_bytes())
    for nominal in ("ur10", str(copy)):
        assert _check(str(model), str(data), "--nominal", nominal, where=tmp_path)["rms"] < 3 * NOISE


_BAD_FIELDS = [  # a calibration's field made what no calibration writes, and the words naming it
    ("sigma2", lambda c: c.update(sigma2="x"), "'sigma2'"),
    ("sigma2", lambda c: c.update(sigma2=-1.0), "'sigma2'"),
    ("fitted_range", lambda c: c["fitted_range"].update(arm_1_joint="wide"), "'fitted_range'"),
    ("fitted_range", lambda c: c["fitted_range"].update(arm_1_joint=[0.5, -0.5]), "'fitted_range'"),
    ("before_parameters", lambda c: c["before_parameters"].update({"base.tx": "x"}), "'before_parameters'"),
    ("covariance", lambda c: c["covariance"].update(matrix="x"), "'covariance'"),
    ("error_growth", lambda c: c["error_growth"].update(nominal0=-1.0), "'error_growth'"),
    ("error_growth", lambda c: c["error_growth"].update(rho0=float("nan")), "'error_growth'"),
    ("error_growth", lambda c: c["error_growth"].update(rho0="1"), "'error_growth'"),
    ("error_growth", lambda c: c["error_growth"].update(rho0=True), "'error_growth'"),
    ("row_sigma", lambda c: c["row_sigma"].update({"position:end_effector": ["x", 1, 1]}), "'row_sigma'"),
]


@pytest.mark.parametrize(("field", "spoil", "named"), _BAD_FIELDS)
def test_a_calibration_with_a_bad_field_is_named_in_one_line(delta: Path, tmp_path: Path, field: str, spoil: Any,
                                                             named: str) -> None:
    """A report JSON, or a calibrated URDF's <pincal_calibration> element, whose field holds what no calibration
    writes (a word for a number, a negative variance, a range upside down, a NaN growth) is refused in one line that
    names the file and the field, by check and compensate: not an internal error, not a bound printed from it (a
    negative one), and not "MODEL carries no calibration"."""
    report = json.loads((delta / "D" / "r.json").read_text(encoding="utf-8"))
    assert field in report and report["covariance"]["matrix"]
    report["provenance"]["data"][0]["file"] = str(delta / "D" / "measurements.csv")
    spoil(report)
    bad_json = tmp_path / "r.json"
    bad_json.write_text(json.dumps(report), encoding="utf-8")
    line = _error_line(run_pincal("check", str(bad_json), str(delta / "new.csv"), "--nominal", "delta"))
    assert str(bad_json) in line and named in line
    text = (delta / "D" / "cal.urdf").read_text(encoding="utf-8")
    held = re.search(r"<pincal_calibration>(.*?)</pincal_calibration>", text, re.DOTALL)
    assert held is not None
    carried = json.loads(held.group(1).replace("&lt;", "<").replace("&gt;", ">").replace("&amp;", "&"))
    spoil(carried)
    escaped = json.dumps(carried).replace("&", "&amp;").replace("<", "&lt;").replace(">", "&gt;")
    bad_urdf = tmp_path / "cal.urdf"
    bad_urdf.write_text(text[:held.start(1)] + escaped + text[held.end(1):], encoding="utf-8")
    line = _error_line(run_pincal("check", str(bad_urdf), str(delta / "new.csv"), "--nominal", "delta"))
    assert "pincal_calibration" in line and str(bad_urdf) in line and named in line
    targets = tmp_path / "targets.csv"
    targets.write_text("position:end_effector:x,position:end_effector:y,position:end_effector:z\n0,0,-0.8\n",
                       encoding="utf-8")
    line = _error_line(run_pincal("compensate", str(bad_urdf), str(targets), "--out", str(tmp_path / "c.csv")))
    assert "pincal_calibration" in line and named in line


def test_a_calibrated_urdf_whose_calibration_is_not_json_is_named_so(delta: Path, tmp_path: Path) -> None:
    """A <pincal_calibration> element cut short is said to be unreadable, naming the element, not taken for a URDF
    written before pincal carried its calibration."""
    text = (delta / "D" / "cal.urdf").read_text(encoding="utf-8")
    cut = tmp_path / "cal.urdf"
    cut.write_text(re.sub(r"<pincal_calibration>(.{200}).*?</pincal_calibration>",
                          r"<pincal_calibration>\1</pincal_calibration>", text, flags=re.DOTALL), encoding="utf-8")
    line = _error_line(run_pincal("check", str(cut), str(delta / "new.csv"), "--nominal", "delta"))
    assert "pincal_calibration" in line and "not" in line and "JSON" in line


def test_a_calibrated_urdf_given_as_the_robot_is_labelled_so(delta: Path, tmp_path: Path) -> None:
    """Calibrating again from a calibrated URDF (ROBOT D/cal.urdf): calibrate's "before" and the fit's start, and
    check's reference robot (the one the new MODEL records), are that calibration, and say so, not "the nominal
    robot" (issue 37, item 4); a nominal URDF keeps its words."""
    again = tmp_path / "again.urdf"
    done = run_pincal("calibrate", str(delta / "D" / "cal.urdf"), str(delta / "D" / "measurements.csv"), "--out",
                      str(again))
    assert done.returncode in (0, 1), done.stderr
    said = " ".join(done.stdout.split())
    before = said.split("(before: ", 1)[1]
    assert before.startswith("the calibrated URDF 'cal.urdf' given as the robot (a calibration, not a nominal "
                             "robot)"), before
    assert "(the fit's start, " in said  # the Delta's measurement frame starts in closed form: a start of its own
    assert said.split("(the fit's start, ", 1)[1].startswith("the calibrated URDF 'cal.urdf' given as the robot")
    content = _check(str(again), str(delta / "new.csv"), where=tmp_path, code=None)
    assert content["nominal_means"].startswith("the calibrated URDF 'cal.urdf' given as the robot")
    assert "nominal: '" in content["stdout"] and ", the calibrated URDF 'cal.urdf' given as the robot" \
        in content["stdout"]
    plain = _check(str(delta / "D" / "cal.urdf"), str(delta / "new.csv"), where=tmp_path, code=None)
    assert plain["nominal_means"].startswith("the nominal robot")
    truth = run_pincal("calibrate", str(delta / "D" / "truth.urdf"), str(delta / "D" / "measurements.csv"))
    assert truth.returncode in (0, 1), truth.stderr  # a simulation's truth records no calibration data: not one
    assert " ".join(truth.stdout.split()).split("(before: ", 1)[1].startswith("the nominal robot")
    page = tmp_path / "again.html"
    done = run_pincal("report", str(delta / "D" / "cal.urdf"), str(delta / "D" / "measurements.csv"), "--out",
                      str(page), "--quiet")
    assert done.returncode in (0, 1), done.stderr
    text = " ".join(html.unescape(page.read_text(encoding="utf-8")).split())
    assert "than the nominal model" not in text and "blue ghost: the nominal one" not in text
    assert "than the calibrated URDF 'cal.urdf' it started from" in text
    assert "blue ghost: the calibrated URDF 'cal.urdf' it started from" in text


def test_a_sample_both_robots_leave_out_is_counted_once(delta: Path, tmp_path: Path) -> None:
    """A posture outside the URDF limits is left out by MODEL and by the nominal robot: two reasons, one sample."""
    data = read_dataset(delta / "new.csv")
    data.joints[3, 0] = 100.0  # [rad] far outside arm_1_joint's limits
    bad = tmp_path / "bad.csv"
    bad.write_text(dataset_text(data), encoding="utf-8")
    content = _check(str(delta / "D" / "cal.urdf"), str(bad), "--nominal", "delta", where=tmp_path)
    assert {d["sample"] for d in content["dropped_samples"]} == {data.sample_ids[3]}
    assert len(content["dropped_samples"]) == 2 and content["n_samples"] == 29
    assert "samples left out (1):" in content["stdout"]
    assert sum(line.startswith(f"  {data.sample_ids[3]}: ") for line in content["stdout"].splitlines()) == 1
    data.joints[:12, 0] = 100.0  # twelve samples, each left out by both: ten listed, "2 more", as the header counts
    bad.write_text(dataset_text(data), encoding="utf-8")
    many = _check(str(delta / "D" / "cal.urdf"), str(bad), "--nominal", "delta", where=tmp_path)
    listed = many["stdout"].split("samples left out (12):\n", 1)[1].splitlines()
    assert all(line.startswith("  ") for line in listed[:11]) and listed[10].startswith("  … and 2 more")
    assert len({line.split(":")[0] for line in listed[:10]}) == 10


def test_a_json_that_is_not_a_calibration_s_report_is_named_for_what_it_is(delta: Path, tmp_path: Path) -> None:
    """A corrections file, or the report of a check, given as MODEL is named as such (and the corrections file's
    calibrated URDF is pointed to), not as a report JSON that lacks its parameters."""
    corrections = tmp_path / "cal.corrections.json"
    corrections.write_text(json.dumps({"format": "pincal joint corrections 1", "robot": "delta", "joints": {}}),
                           encoding="utf-8")
    line = _error_line(run_pincal("check", str(corrections), str(delta / "new.csv"), "--nominal", "delta"))
    assert f"MODEL '{corrections}' is a pincal corrections file" in line
    assert f"'{tmp_path / 'cal.urdf'}'" in line and "no 'parameters'" not in line
    checked = _check(str(delta / "D" / "cal.urdf"), str(delta / "new.csv"), where=tmp_path)
    assert checked["format"] == "pincal check 1"
    report = next(tmp_path.glob("check-*.json"))
    line = _error_line(run_pincal("check", str(report), str(delta / "new.csv"), "--nominal", "delta"))
    assert f"MODEL '{report}' is the report of a pincal check" in line and "no 'parameters'" not in line
    for odd in ({"a": 1}, ["pincal check 1"]):  # a format that is no name at all: the report's reader names the file
        other = tmp_path / "odd.json"
        other.write_text(json.dumps({"format": odd}), encoding="utf-8")
        assert str(other) in _error_line(run_pincal("check", str(other), str(delta / "new.csv"), "--nominal", "delta"))


def test_the_demo_s_calibration_is_checked_without_naming_its_robot(tmp_path: Path) -> None:
    """``pincal demo`` then ``pincal check`` on its held-out rows, as a new user runs them: the calibrated URDF and the
    report record the robot and the data (as calibrate's do), so check needs no --nominal, and finds the held-out
    error the demo reported."""
    done = run_pincal("demo", "--samples", "30", "--test-samples", "10", "--out", str(tmp_path / "demo"))
    assert done.returncode == 0, done.stderr
    demo = tmp_path / "demo"
    written = json.loads((demo / "report.json").read_text(encoding="utf-8"))
    assert written["provenance"]["robot"]["file"] == "delta"
    for model in ("delta_calibrated.urdf", "report.json"):
        content = _check(str(demo / model), str(demo / "measurements.csv"), "--set", "test", where=tmp_path)
        assert content["nominal"] == "delta" and not content["nominal_given"]
        assert content["rms"] == pytest.approx(written["test_rms_after"], rel=1e-6)
        assert content["outside_range"]["known"]


def test_a_recorded_nominal_urdf_that_is_not_there_is_named_as_model_s_record(delta: Path, tmp_path: Path) -> None:
    """A calibrated URDF copied to another folder records its nominal URDF relative to its own: when that file is not
    there, the line says that MODEL records it, where it was looked for, and that --nominal gives it."""
    robot = tmp_path / "mydelta.urdf"
    robot.write_bytes(Path(str(pincal.load_robot("delta").source)).read_bytes())
    cal = tmp_path / "cal.urdf"
    _ok(run_pincal("calibrate", str(robot), str(delta / "D" / "measurements.csv"), "--out", str(cal)))
    moved = tmp_path / "a" / "b" / "cal.urdf"
    moved.parent.mkdir(parents=True)
    moved.write_bytes(cal.read_bytes())
    line = _error_line(run_pincal("check", str(moved), str(delta / "new.csv")))
    assert f"MODEL '{moved}' records its nominal robot as" in line and "mydelta.urdf" in line
    assert "--nominal" in line
    _check(str(moved), str(delta / "new.csv"), "--nominal", str(robot), where=tmp_path)
