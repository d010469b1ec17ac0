"""A camera on one chain seeing a board on another, as a user runs it: ``pincal simulate tiago_no_hand --measure
cross_pixel:head_2_link-arm_tool_link --images``, ``pincal detect``, ``pincal calibrate``, ``pincal check``; the
malformed and impossible ``--measure`` refused before any output."""

from __future__ import annotations

import json
from pathlib import Path

import pytest
from conftest import run_pincal

from pincal.io.dataset_reader import read_dataset

MEASURE = "cross_pixel:head_2_link-arm_tool_link"
BOARD = "charuco:8x6:0.03:0.022:DICT_4X4_50"


def _ok(done: object) -> str:
    assert done.returncode == 0, done.stdout + done.stderr  # type: ignore[attr-defined]
    return str(done.stdout)  # type: ignore[attr-defined]


@pytest.fixture(scope="module")
def campaign(tmp_path_factory: pytest.TempPathFactory) -> Path:
    """TIAGo's head camera seeing a board in its gripper: 12 images to calibrate from, 4 held out, rendered and
    detected."""
    root = tmp_path_factory.mktemp("cross")
    out = _ok(run_pincal("simulate", "tiago_no_hand", "--measure", MEASURE, "--samples", "12", "--test-samples", "4",
                         "--images", "imgs", "--seed", "3", "--out", "sim", cwd=root))
    assert "seen by a camera on 'head_2_link', the board on 'arm_tool_link'" in out
    assert "wrote 16 images into imgs/" in out
    files = sorted(str(p) for p in (root / "imgs").glob("*.png"))
    out = _ok(run_pincal("detect", *files, "--board", BOARD, "--joints", "sim/joints.csv", "--measure", MEASURE,
                         "--out", "det.csv", cwd=root))
    assert "in 16 of 16 images (0 left out)" in out
    return root


def test_detections_are_keyed_by_both_frames(campaign: Path) -> None:
    data = read_dataset(campaign / "det.csv")
    assert data.metadata["board"] == BOARD
    assert data.measurements and all(k.startswith(f"{MEASURE}@") for k in data.measurements)
    exact = read_dataset(campaign / "sim" / "measurements.csv")
    assert set(data.measurements) == set(exact.measurements)


def test_calibrate_and_check_from_the_detected_corners(campaign: Path) -> None:
    out = _ok(run_pincal("calibrate", "tiago_no_hand", "det.csv", "--out", "cal.urdf", "--report", "rep.json",
                         cwd=campaign))
    line = next(s for s in out.splitlines() if s.startswith("RMS reprojection error (held out)"))
    before, after = (float(w) for w in line.split() if w.replace(".", "").isdigit())
    assert after < 0.6 < 2.0 < before
    assert "camera on 'head_2_link' (intrinsics.head_2_link)" in out
    report = json.loads((campaign / "rep.json").read_text())["parameters"]
    truth = json.loads((campaign / "sim" / "truth.json").read_text())["parameters"]
    for name in ("camera.head_2_link.rx", "target.arm_tool_link@board.tx", "intrinsics.head_2_link.fx"):
        assert name in report
    assert abs(report["intrinsics.head_2_link.fx"]["value"] - truth["intrinsics.head_2_link.fx"]) < 10.0
    out = _ok(run_pincal("check", "cal.urdf", "det.csv", "--set", "test", cwd=campaign))
    row = next(s for s in out.splitlines() if s.strip().startswith(MEASURE))
    model_rms, nominal_rms = float(row.split()[3]), float(row.split()[7])
    assert model_rms < 0.6 and nominal_rms > 2.0
    assert "verdict: MODEL predicts DATA no worse than the nominal robot" in out


@pytest.mark.parametrize(("measure", "message"), [
    ("cross_pixel:head_2_link", "cross_pixel:<camera frame>-<board frame>"),
    ("cross_pixel:head_2_link-nothere", "frame 'nothere' does not exist"),
    ("cross_pixel:head_2_link-head_2_link", "on the same frame"),
])
def test_a_bad_measure_is_refused_before_any_output(tmp_path: Path, measure: str, message: str) -> None:
    done = run_pincal("simulate", "tiago_no_hand", "--measure", measure, "--out", "sim", cwd=tmp_path)
    assert done.returncode == 2
    assert done.stderr.startswith("pincal: error: ") and message in done.stderr and "Traceback" not in done.stderr
    assert not (tmp_path / "sim").exists()
