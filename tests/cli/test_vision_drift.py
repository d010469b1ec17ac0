"""``pincal drift`` on a camera's pixels, as a user runs it: sessions of images judged against the calibration, their
RMS reprojection errors in px, the camera's intrinsics held at the calibrated values."""

from __future__ import annotations

import json
import math
from pathlib import Path

import pytest
from conftest import run_pincal

from pincal.io.dataset import dataset_text
from pincal.io.dataset_reader import read_dataset

NOISE = 0.3  # px per coordinate


def _done(done: object, code: int = 0) -> str:
    assert done.returncode == code, done.stdout + done.stderr  # type: ignore[attr-defined]
    return str(done.stdout)  # type: ignore[attr-defined]


@pytest.fixture(scope="module")
def sessions(tmp_path_factory: pytest.TempPathFactory) -> Path:
    """An eye-in-hand UR10 calibrated on 20 images; a later session of 20 new images of the same robot
    (``same.csv``), and one of the nominal robot (``moved/measurements.csv``: every geometric error gone)."""
    root = tmp_path_factory.mktemp("vision_drift")
    _done(run_pincal("simulate", "ur10", "--measure", "pixel:tool0", "--samples", "20", "--test-samples", "20",
                     "--noise", str(NOISE), "--seed", "3", "--out", "sim", cwd=root))
    _done(run_pincal("calibrate", "ur10", "sim/measurements.csv", "--out", "cal.urdf", cwd=root))
    later = read_dataset(root / "sim" / "measurements.csv").of_set("test")
    (root / "same.csv").write_text(dataset_text(later))
    _done(run_pincal("simulate", "ur10", "--measure", "pixel:tool0", "--samples", "20", "--perturb", "0",
                     "--noise", str(NOISE), "--seed", "5", "--out", "moved", cwd=root))
    return root


def test_a_session_of_the_same_robot_is_unchanged_and_the_nominal_one_changed(sessions: Path) -> None:
    out = _done(run_pincal("drift", "cal.urdf", "same.csv", "moved/measurements.csv", "--report", "drift.json",
                           "--html", "drift.html", cwd=sessions), code=1)
    assert "its setup re-registered [px; shifts in mm or mrad]" in out
    rows = {line.split()[0]: line.split() for line in out.splitlines() if line.startswith(("same.csv", "moved/"))}
    same, moved = rows["same.csv"], rows["moved/measurements.csv"]
    assert same[1] == "20" and same[-1] == "unchanged"
    assert moved[1] == "20" and "CHANGED:" in moved
    report = json.loads((sessions / "drift.json").read_text())
    first, second = report["sessions"]
    assert first["unit"] == second["unit"] == "px"
    corner = NOISE * math.sqrt(2.0)  # a corner's |(Δu, Δv)| RMS under the noise alone [px]
    assert 0.8 * corner < first["expected_rms"] < 1.25 * corner
    assert 0.8 * corner < first["rms"] < 1.25 * corner  # the same robot: its noise only
    assert second["rms"] > 3 * second["expected_rms"]  # the nominal robot's geometry: pixels off by more
    assert not any(name.startswith("intrinsics") for name in first["setup"])  # held at the calibration's
    assert {"camera.tool0.rx", "target.tx"} <= set(first["setup"])  # the camera and board re-registered
    page = (sessions / "drift.html").read_text()
    assert "<th>RMS [px]</th><th>predicted [px]</th>" in page
    assert f"<td>{first['rms']:.4f}</td>" in page


def test_a_model_without_the_camera_s_intrinsics_is_refused_in_one_line(sessions: Path) -> None:
    text = (sessions / "cal.urdf").read_text()
    start = text.index("<pincal_calibration")
    carried = text[start:text.index("</pincal_calibration>") + len("</pincal_calibration>")]
    assert "intrinsics.tool0" in carried
    (sessions / "bare.urdf").write_text(text.replace("intrinsics.tool0", "intrinsics.elsewhere"))
    done = run_pincal("drift", "bare.urdf", "same.csv", cwd=sessions)
    assert done.returncode == 2 and len(done.stderr.splitlines()) == 1, done.stderr
    assert done.stderr.startswith("pincal: error: MODEL carries no intrinsics of the camera on 'tool0'")
