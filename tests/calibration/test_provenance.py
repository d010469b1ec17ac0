"""Every output records where it came from, and identical inputs give byte-identical outputs
(docs/calibrated_urdf.md, "Provenance"); the report holds per-sample errors and the covariance."""

from __future__ import annotations

import hashlib
import json
import math
import xml.etree.ElementTree as ET
from pathlib import Path

import numpy as np
import pinocchio as pin
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
