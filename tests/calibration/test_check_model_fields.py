"""``pincal check`` on a calibration rebuilt from its report JSON: an error in the report names the report as its
``file`` (the robot it rebuilds has no file of its own), and the command says it in one line."""

from __future__ import annotations

import json
from pathlib import Path

import pytest
from conftest import run_pincal

import pincal
from pincal.calibration.check_model import load_model
from pincal.errors import DataError
from pincal.io.dataset_reader import read_dataset


@pytest.fixture(scope="module")
def calibrated(tmp_path_factory: pytest.TempPathFactory) -> Path:
    """A five-bar simulated (12 postures) and calibrated on its offsets: sim/measurements.csv, r.json."""
    root = tmp_path_factory.mktemp("rebuilt")
    for args in (("simulate", "five_bar", "--samples", "12", "--seed", "3", "--quiet", "--out", str(root / "sim")),
                 ("calibrate", "five_bar", str(root / "sim" / "measurements.csv"), "--parameters", "*.offset",
                  "--select", "none", "--report", str(root / "r.json"), "--out", str(root / "cal.urdf"))):
        done = run_pincal(*args)
        assert done.returncode in (0, 1), done.stderr
    return root


def test_a_report_whose_parameters_the_nominal_lacks_names_the_report(calibrated: Path, tmp_path: Path) -> None:
    content = json.loads((calibrated / "r.json").read_text(encoding="utf-8"))
    first = next(iter(content["parameters"]))
    content["parameters"] = {"no_such_joint.tx" if name == first else name: value
                             for name, value in content["parameters"].items()}
    report = tmp_path / "other.json"
    report.write_text(json.dumps(content), encoding="utf-8")
    data = calibrated / "sim" / "measurements.csv"
    with pytest.raises(DataError, match=r"no_such_joint\.tx") as caught:
        load_model(str(report), pincal.load_robot("five_bar"), read_dataset(data))
    assert caught.value.file == str(report)
    done = run_pincal("check", str(report), str(data), "--nominal", "five_bar")
    lines = done.stderr.strip().splitlines()
    assert done.returncode == 2 and len(lines) == 1 and "Traceback" not in done.stderr
    assert lines[0].startswith(f"pincal: error: MODEL '{report}': its parameters are not those of robot 'five_bar'")

