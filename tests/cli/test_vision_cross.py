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


def test_drift_judges_the_pixels_and_the_scene_draws_the_board_on_its_frame(campaign: Path) -> None:
    """drift judges the pixels of two chains in px; the report's 3D scene draws the camera on the head and, at every
    image, the board on the gripper in front of it (0.3 to 1 m, its centre inside the image)."""
    import numpy as np

    import pincal
    from pincal.calibration.options import CalibrationOptions
    from pincal.calibration.report import CalibrationReport
    from pincal.viz.camera_scene import camera_placements
    from pincal.viz.scene import CalibrationView, configurations

    if not (campaign / "rep.json").exists():
        _ok(run_pincal("calibrate", "tiago_no_hand", "det.csv", "--out", "cal.urdf", "--report", "rep.json",
                       cwd=campaign))
    out = _ok(run_pincal("drift", "cal.urdf", "det.csv", cwd=campaign))  # pixels of two chains: judged in px
    assert "its setup re-registered [px; shifts in mm or mrad]" in out
    assert next(line for line in out.splitlines() if line.startswith("det.csv")).endswith("unchanged")
    assert "warning: session 'det.csv' is the data MODEL was calibrated from" in out
    report = CalibrationReport.read(campaign / "rep.json")
    view = CalibrationView.from_result(pincal.load_robot("tiago_no_hand"), read_dataset(campaign / "det.csv"),
                                       report, CalibrationOptions())
    _, _, calibrated, q = configurations(view)
    drawn = {name: placements for name, _, placements, _ in
             camera_placements(view, calibrated, q, view.base_placement().homogeneous)}
    assert set(drawn) == {"head_2_link_frustum", "head_2_link_board"}
    cameras, boards = drawn["head_2_link_frustum"], drawn["head_2_link_board"]
    assert len(cameras) == len(boards) == 12  # the fitted images
    centre = np.array([0.12, 0.09, 0.0, 1.0])  # the 8 × 6 board of 30 mm squares: its centre in its frame
    k = report.cameras["intrinsics.head_2_link"].intrinsics if report.cameras else {}
    for camera, board in zip(cameras, boards, strict=True):
        seen = np.linalg.solve(camera, board @ centre)[:3]
        assert 0.25 < seen[2] < 1.1
        u, v = k["fx"] * seen[0] / seen[2] + k["cx"], k["fy"] * seen[1] / seen[2] + k["cy"]
        assert 0 < u < 2 * k["cx"] and 0 < v < 2 * k["cy"]


def test_compensate_refuses_targets_on_a_moving_board_and_reaches_them_in_the_base(campaign: Path) -> None:
    """The board of a camera on another chain moves with the robot: targets relative to it fix one chain relative to
    the other, which compensate refuses in one line saying so; the same board's poses in the robot's base frame (the
    calibrated model's own, at held-out images) are reached."""
    import pinocchio as pin

    import pincal

    if not (campaign / "cal.urdf").exists():
        _ok(run_pincal("calibrate", "tiago_no_hand", "det.csv", "--out", "cal.urdf", "--report", "rep.json",
                       cwd=campaign))
    model = pincal.load_robot(str(campaign / "cal.urdf"))
    held_out = read_dataset(campaign / "det.csv").of_set("test")
    link = "arm_tool_link_target_board"
    columns = ",".join(f"pose:{link}:{c}" for c in ("x", "y", "z", "qx", "qy", "qz", "qw"))
    rows = [f"{s}," + ",".join(repr(float(v)) for v in pin.SE3ToXYZQUAT(model.placement(model.solve_fk(q), link)))
            for s, q in zip(held_out.sample_ids[:2], held_out.joints[:2], strict=True)]
    (campaign / "board_targets.csv").write_text("\n".join([f"sample,{columns}", *rows]) + "\n")
    done = run_pincal("compensate", "cal.urdf", "board_targets.csv", "--targets-in", "board", "--out", "c.csv",
                      cwd=campaign)
    assert done.returncode == 2 and len(done.stderr.splitlines()) == 1 and not (campaign / "c.csv").exists()
    assert done.stderr.startswith(f"pincal: error: --targets-in board: MODEL's board (link '{link}') moves with the "
                                  "robot, as does its camera (link 'head_2_link_camera')")
    assert "give the targets in 'base'" in done.stderr and "eye-in-hand" not in done.stderr
    out = _ok(run_pincal("compensate", "cal.urdf", "board_targets.csv", "--targets-in", "base", "--out", "c.csv",
                         cwd=campaign))
    assert "reached 2 of 2" in out
