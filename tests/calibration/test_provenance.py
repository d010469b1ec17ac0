"""Every output records where it came from, and identical inputs give byte-identical outputs
(docs/calibrated_urdf.md, "Provenance"); the report holds per-sample errors and the covariance."""

from __future__ import annotations

import hashlib
import html
import json
import math
import xml.etree.ElementTree as ET
from pathlib import Path

import numpy as np
import pinocchio as pin
import pytest
from conftest import run_pincal

import pincal


def _sha(path: Path) -> str:
    return hashlib.sha256(path.read_bytes()).hexdigest()


def test_outputs_record_their_inputs_and_repeat_byte_for_byte(tmp_path: Path) -> None:
    sim = tmp_path / "sim"
    assert run_pincal("simulate", "delta", "--samples", "30", "--test-samples", "10", "--seed", "4", "--out",
                      str(sim), "--quiet").returncode == 0
    data = sim / "measurements.csv"
    out = tmp_path / "out"
    first = run_pincal("calibrate", "delta", str(data), "--parameters", "model24", "--out", str(out / "cal.urdf"),
                       "--report", str(out / "r.json"))
    assert first.returncode == 0, first.stderr
    # the same run from another working directory, the files named relative to it
    again = run_pincal("calibrate", "delta", "../sim/measurements.csv", "--parameters", "model24", "--out",
                       "cal.urdf", "--report", "r.json", cwd=out.parent / "again")
    assert again.returncode == 0, again.stderr
    for name in ("cal.urdf", "r.json"):
        assert (out / name).read_bytes() == (out.parent / "again" / name).read_bytes(), name

    element = ET.parse(out / "cal.urdf").getroot().find("pincal_provenance")
    assert element is not None
    assert element.get("pincal_version") == pincal.__version__
    assert element.get("robot") == "delta" and element.get("data") == "../sim/measurements.csv"
    assert element.get("data_sha256") == _sha(data)
    assert element.get("robot_sha256") == _sha(Path(pincal.robot_path("delta")))
    assert json.loads(element.get("options", ""))["parameter_spec"] == ["model24"]
    report = json.loads((out / "r.json").read_text(encoding="utf-8"))
    assert report["provenance"]["data"] == [{"file": "../sim/measurements.csv", "sha256": _sha(data)}]
    assert report["provenance"]["options"]["select"] == "auto"  # a default, recorded too
    # the URDF readers still read the file
    pin.buildModelFromUrdf(str(out / "cal.urdf"))
    pincal.load_robot(out / "cal.urdf")


def test_the_report_holds_per_sample_errors_and_the_covariance(tmp_path: Path) -> None:
    sim = tmp_path / "sim"
    assert run_pincal("simulate", "ur10", "--samples", "25", "--test-samples", "8", "--seed", "2", "--out",
                      str(sim), "--quiet").returncode == 0
    done = run_pincal("calibrate", "ur10", str(sim / "measurements.csv"), "--report", str(tmp_path / "r.json"))
    assert done.returncode == 0, done.stderr
    report = json.loads((tmp_path / "r.json").read_text(encoding="utf-8"))
    rows = report["sample_errors"]
    train = [r for r in rows if r["set"] == "train"]
    test = [r for r in rows if r["set"] == "test"]
    assert (len(train), len(test)) == (report["n_samples"], report["n_test_samples"]) == (25, 8)
    # one position per sample: the RMS over the samples is the report's RMS
    for part, key in ((train, ""), (test, "test_")):
        for when in ("before", "after"):
            rms = math.sqrt(np.mean([r[when] ** 2 for r in part]))
            assert rms == report[f"{key}rms_{when}"] or abs(rms / report[f"{key}rms_{when}"] - 1) < 1e-12
    cov = report["covariance"]
    identified = [n for n, p in report["parameters"].items() if p["identified"]]
    assert cov["parameters"] == identified
    matrix = np.array(cov["matrix"])
    assert matrix.shape == (len(identified), len(identified)) and np.allclose(matrix, matrix.T)
    assert np.allclose(np.sqrt(np.diag(matrix)), [report["parameters"][n]["std"] for n in identified], rtol=1e-12)
    assert np.linalg.eigvalsh(matrix).min() > 0


def test_a_figure_that_is_not_a_number_is_null_in_the_report(tmp_path: Path) -> None:
    """Joint readings only: no length error to average, so the held-out RMS is null (JSON has no NaN) and the
    held-out samples are still counted."""
    sim = tmp_path / "sim"
    assert run_pincal("simulate", "five_bar", "--measure", "joint:scale_joint", "--samples", "20", "--test-samples",
                      "5", "--seed", "3", "--out", str(sim), "--quiet").returncode == 0
    done = run_pincal("calibrate", "five_bar", str(sim / "measurements.csv"), "--report", str(tmp_path / "r.json"))
    assert done.returncode == 0, done.stderr

    def refuse(constant: str) -> None:
        raise AssertionError(f"{constant} in the report JSON")

    report = json.loads((tmp_path / "r.json").read_text(encoding="utf-8"), parse_constant=refuse)
    assert report["n_test_samples"] == 5 and report["test_rms_before"] is None and report["test_rms_after"] is None


def _every_output(folder: Path) -> None:
    """Every command's outputs, in ``folder``, the files named relative to it: simulate (with joint compliance, so
    that corrections files are written), design, calibrate, report, view, check, compensate, export."""
    folder.mkdir(parents=True)
    fit = ("--parameters", "default", "*.compliance", "--payload", "2@tool0")
    runs = [("simulate", "ur10", "--samples", "12", "--test-samples", "3", "--seed", "2", "--out", "sim", "--quiet",
             *fit),
            ("design", "ur10", "--poses", "12", "--candidates", "40", "--out", "poses.csv", "--quiet"),
            ("calibrate", "ur10", "sim/measurements.csv", *fit, "--out", "cal.urdf", "--report", "cal.json"),
            ("report", "ur10", "sim/measurements.csv", *fit, "--out", "cal.html", "--quiet"),
            ("view", "ur10", "sim/measurements.csv", *fit, "--out", "view.html", "--quiet"),
            ("check", "cal.urdf", "sim/measurements.csv", "--set", "test", "--report", "check.json", "--html",
             "check.html"),
            ("export", "cal.urdf", "--format", "yaml", "--out", "joints.yaml")]
    for args in runs:
        done = run_pincal(*args, cwd=folder)
        assert done.returncode == 0, (args, done.stdout, done.stderr)
    (folder / "targets.csv").write_text("sample,position:tool0:x,position:tool0:y,position:tool0:z\nA,0.5,0.3,0.4\n",
                                        encoding="utf-8")
    for args in (("--out", "commands.csv"), ("--nominal-targets", "--out", "nominal.csv")):
        done = run_pincal("compensate", "cal.urdf", "targets.csv", *args, cwd=folder)
        assert done.returncode == 0, done.stdout + done.stderr


def test_every_command_records_its_inputs_and_repeats_from_another_folder(tmp_path: Path) -> None:
    """Each output of each command names the pincal version, its input files with their SHA-256 and its options,
    and the same commands run in another folder (another depth) give the same bytes."""
    first, second = tmp_path / "a", tmp_path / "b" / "c" / "d"
    _every_output(first)
    _every_output(second)
    written = sorted(p.relative_to(first) for p in first.rglob("*") if p.is_file())
    assert len(written) == 16  # 15 outputs and the targets
    for name in written:
        assert (first / name).read_bytes() == (second / name).read_bytes(), name
    data, robot = _sha(first / "sim" / "measurements.csv"), _sha(Path(pincal.robot_path("ur10")))
    metadata = dict(line[2:].split(": ", 1) for line in (first / "sim" / "measurements.csv").read_text(
        encoding="utf-8").splitlines() if line.startswith("# "))
    assert metadata["pincal"] == pincal.__version__ and metadata["robot sha256"] == robot
    assert json.loads(metadata["simulate"])["payload"]["mass"] == 2.0
    truth = ET.parse(first / "sim" / "truth.urdf").getroot().find("pincal_provenance")
    assert truth is not None and truth.get("robot_sha256") == robot
    assert json.loads(truth.get("options", ""))["seed"] == 2
    assert truth.get("corrections_sha256") == _sha(first / "sim" / "truth.corrections.json")
    for corrections in ("sim/truth.corrections.json", "cal.corrections.json"):
        recorded = json.loads((first / corrections).read_text(encoding="utf-8"))["provenance"]
        assert recorded["pincal_version"] == pincal.__version__ and recorded["robot"]["sha256"] == robot
    assert json.loads((first / "cal.corrections.json").read_text(encoding="utf-8"))["provenance"]["data"][0][
        "sha256"] == data
    poses = (first / "poses.csv").read_text(encoding="utf-8")
    assert f"# pincal: {pincal.__version__}" in poses and f"# robot sha256: {robot}" in poses
    for page in ("cal.html", "view.html", "check.html"):
        text = (first / page).read_text(encoding="utf-8")
        assert data in text and pincal.__version__ in text, page
    assert html.unescape((first / "cal.html").read_text(encoding="utf-8")).count('"select": "auto"') >= 1
    check = json.loads((first / "check.json").read_text(encoding="utf-8"))["provenance"]
    assert check["sha256"]["sim/measurements.csv"] == data and check["options"] == {"register": False, "set": "test"}
    commands = (first / "commands.csv").read_text(encoding="utf-8")
    assert f"# sha256 cal.urdf: {_sha(first / 'cal.urdf')}" in commands and "# seed: 0" in commands
    assert "# nominal: ur10 (recorded in MODEL)" in (first / "nominal.csv").read_text(encoding="utf-8")
    assert _sha(first / "cal.urdf") in (first / "joints.yaml").read_text(encoding="utf-8")


@pytest.mark.parametrize("value", ["plain", 'a "quoted" name', "it's", "both ' and \"", "<&>\n\t\r", ""])
def test_attribute_values_are_quoted_as_xml_sax_quotes_them(value: str) -> None:
    from xml.sax.saxutils import quoteattr

    from pincal.calibration.provenance import _quoted

    assert _quoted(value) == quoteattr(value)
