"""Every ``pincal export`` proved by reloading it: the URDF by plain Pinocchio and yourdfpy, the per-joint YAML
composed back into joint origins, a DH table read back into forward kinematics; each against the model at the
calibration data's postures and random ones, the deviation printed and in the file's header, an export off by more
than the tolerance refused; a file changed by a micrometre is caught."""

from __future__ import annotations

import re
from pathlib import Path

import pytest
from conftest import run_pincal

import pincal
from pincal.calibration.export_proof import dh_deviation, proof_postures, yaml_deviation

PROOF = re.compile(r"proved by reloading, against the model at the (\d+) postures of the calibration data and 100 "
                   r"random ones within the joint limits \(seed 0\): (.*)")


@pytest.fixture(scope="module")
def calibrated(tmp_path_factory: pytest.TempPathFactory) -> Path:
    folder = tmp_path_factory.mktemp("ur10_proof")
    assert run_pincal("simulate", "ur10", "--measure", "position", "--samples", "30", "--seed", "3", "--quiet",
                      "--out", str(folder)).returncode == 0
    assert run_pincal("calibrate", "ur10", str(folder / "measurements.csv"), "--out",
                      str(folder / "cal.urdf")).returncode == 0
    return folder / "cal.urdf"


@pytest.mark.parametrize("fmt", ["yaml", "dh", "mdh"])
def test_each_export_is_reloaded_and_its_deviation_printed(calibrated: Path, tmp_path: Path, fmt: str) -> None:
    out = tmp_path / f"{fmt}.yaml"
    done = run_pincal("export", str(calibrated), "--format", fmt, "--out", str(out))
    assert done.returncode == 0, done.stderr
    found = PROOF.search(done.stdout)
    assert found is not None and found.group(1) == "30"
    readers = dict(re.findall(r"([^:;]+): ([0-9.e+-]+) m", found.group(2)))
    assert {r.strip() for r in readers} == {"Pinocchio", "yourdfpy", (
        "the YAML composed into joint origins, by Pinocchio" if fmt == "yaml" else
        f"the {fmt} table read back, as forward kinematics")}
    assert all(float(v) <= 1e-9 for v in readers.values())
    assert "# " + found.group(0) in out.read_text(encoding="utf-8").splitlines()


def test_an_export_beyond_the_tolerance_is_refused(calibrated: Path, tmp_path: Path) -> None:
    out = tmp_path / "k.yaml"
    done = run_pincal("export", str(calibrated), "--format", "yaml", "--tolerance", "1e-30", "--out", str(out))
    assert done.returncode == 2 and "not written" in done.stderr and " reads the yaml export " in done.stderr
    assert done.stderr.count("\n") == 1 and not out.exists()


def test_a_file_changed_by_a_micrometre_is_caught(calibrated: Path, tmp_path: Path) -> None:
    robot = pincal.load_robot(calibrated)
    postures = proof_postures(robot, calibrated, 5)
    text = calibrated.read_text(encoding="utf-8")
    for fmt in ("yaml", "dh"):
        out = tmp_path / f"{fmt}.yaml"
        assert run_pincal("export", str(calibrated), "--format", fmt, "--out", str(out)).returncode == 0
        written = out.read_text(encoding="utf-8")
        key = "    z: " if fmt == "yaml" else "d: "
        at = written.index(key, written.index("elbow_joint")) + len(key)
        end = min(i for i in (written.find(c, at) for c in ",\n}") if i > 0)
        changed = written[:at] + repr(float(written[at:end]) + 1e-6) + written[end:]
        deviation = (yaml_deviation(changed, text, robot, postures) if fmt == "yaml"
                     else dh_deviation(changed, robot, postures))
        assert 1e-7 < deviation.position < 1e-5
        same = (yaml_deviation(written, text, robot, postures) if fmt == "yaml"
                else dh_deviation(written, robot, postures))
        assert same.position <= 1e-9
