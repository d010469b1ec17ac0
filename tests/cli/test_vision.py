"""Cameras from images, as a user runs them: ``pincal simulate --measure pixel:FRAME --images``, ``pincal detect``,
``pincal calibrate`` on the detections; a fixed camera seeing a board on the robot; what detect leaves out, and why.
"""

from __future__ import annotations

import json
import shutil
import sys
from pathlib import Path

import numpy as np
import pytest
from conftest import run_pincal

from pincal.errors import DataError
from pincal.io import vision
from pincal.io.dataset_reader import read_dataset

BOARD = "charuco:8x6:0.03:0.022:DICT_4X4_50"
TRUE_INTRINSICS = ("fx", "fy", "cx", "cy", "k1", "k2", "p1", "p2")


def _ok(done: object) -> str:
    assert done.returncode == 0, done.stdout + done.stderr  # type: ignore[attr-defined]
    return str(done.stdout)  # type: ignore[attr-defined]


def _within_3_sigma(report: Path, truth: Path, prefix: str) -> list[str]:
    """The intrinsics the calibration puts more than 3σ from the truth (their names)."""
    estimated = json.loads(report.read_text())["parameters"]
    true = json.loads(truth.read_text())["parameters"]
    names = [f"{prefix}.{c}" for c in TRUE_INTRINSICS]
    assert all(estimated[n]["std"] for n in names)
    return [n for n in names if abs(estimated[n]["value"] - true[n]) > 3 * estimated[n]["std"]]


@pytest.fixture(scope="module")
def images(tmp_path_factory: pytest.TempPathFactory) -> Path:
    """An eye-in-hand UR10 campaign: 12 images to calibrate from, 4 held out, rendered."""
    root = tmp_path_factory.mktemp("vision")
    out = _ok(run_pincal("simulate", "ur10", "--measure", "pixel:tool0", "--samples", "12", "--test-samples", "4",
                         "--images", "imgs", "--seed", "3", "--out", "sim", cwd=root))
    assert "wrote 16 images into imgs/" in out
    return root


def test_images_detected_and_calibrated_give_the_true_intrinsics(images: Path) -> None:
    files = sorted(str(p) for p in (images / "imgs").glob("*.png"))
    assert len(files) == 16
    out = _ok(run_pincal("detect", *files, "--board", BOARD, "--joints", "sim/joints.csv", "--measure",
                         "pixel:tool0", "--out", "det.csv", cwd=images))
    assert "in 16 of 16 images (0 left out)" in out
    detected = read_dataset(images / "det.csv")
    exact = read_dataset(images / "sim" / "measurements.csv")
    assert detected.sample_ids == exact.sample_ids and detected.sets == exact.sets
    assert detected.metadata["board"] == BOARD and detected.metadata["image size"] == "1280 960"
    errors = np.concatenate([(detected.measurements[k] - exact.measurements[k]).ravel()
                             for k in exact.measurements])
    errors = errors[np.isfinite(errors)]
    assert len(errors) > 0.9 * sum(np.isfinite(v).sum() for v in exact.measurements.values())
    assert np.sqrt(np.mean(errors ** 2)) < 0.3  # px: the detector's sub-pixel corners on a blurred, noisy image
    summary = _ok(run_pincal("calibrate", "ur10", "det.csv", "--report", "r.json", "--out", "cal.urdf", cwd=images))
    assert 'link name="tool0_camera"' in (images / "cal.urdf").read_text()  # the intrinsics stay in the report
    assert _within_3_sigma(images / "r.json", images / "sim" / "truth.json", "intrinsics.tool0") == []
    # the summary's reprojection errors: the nominal robot's pixels px off, the calibrated one's at the noise
    rows = {line.split("  ")[0]: line.split()[-4:] for line in summary.splitlines()
            if line.startswith("RMS reprojection")}
    assert set(rows) == {"RMS reprojection error (fit)", "RMS reprojection error (held out)"}
    report = json.loads((images / "r.json").read_text())
    for part, key in (("fit", "pixels"), ("held out", "test_pixels")):
        before, after = report[key]["rms_before"], report[key]["rms_after"]
        assert rows[f"RMS reprojection error ({part})"] == [f"{before:.3f}", "px", f"{after:.3f}", "px"]
        assert after < 0.3 < 1.0 < before


def test_a_fixed_camera_seeing_a_board_on_the_hand(tmp_path: Path) -> None:
    _ok(run_pincal("simulate", "panda", "--measure", "board_pixel:panda_hand", "--samples", "20", "--noise", "0.2",
                   "--seed", "1", "--out", "sim", cwd=tmp_path))
    text = (tmp_path / "sim" / "measurements.csv").read_text()
    assert "# board: charuco:8x6:0.03:0.022:DICT_4X4_50" in text and "board_pixel:panda_hand@34:u" in text
    _ok(run_pincal("calibrate", "panda", "sim/measurements.csv", "--report", "r.json", cwd=tmp_path))
    report = json.loads((tmp_path / "r.json").read_text())["parameters"]
    assert {"base.tx", "target.panda_hand@board.tx", "intrinsics.fx"} <= set(report)
    assert _within_3_sigma(tmp_path / "r.json", tmp_path / "sim" / "truth.json", "intrinsics") == []
    pixels = json.loads((tmp_path / "r.json").read_text())["pixels"]
    out = _ok(run_pincal("report", "panda", "sim/measurements.csv", "--out", "page.html", "--quiet", cwd=tmp_path))
    assert f"RMS reprojection error {pixels['rms_before']:.3f} → {pixels['rms_after']:.3f} px" in out
    assert (tmp_path / "page.html").stat().st_size > 0


def test_detect_names_every_image_it_leaves_out(images: Path, tmp_path: Path) -> None:
    import cv2

    shutil.copy(images / "sim" / "joints.csv", tmp_path / "joints.csv")
    kept = [images / "imgs" / f"{k:04d}.png" for k in range(4)]
    for path in kept:
        shutil.copy(path, tmp_path / path.name)
    shutil.copy(kept[0], tmp_path / "0004.png")  # the same image under another name
    sharp = cv2.imread(str(kept[1]), cv2.IMREAD_GRAYSCALE)
    cv2.imwrite(str(tmp_path / "0005.png"), cv2.GaussianBlur(sharp, (0, 0), 6.0))  # out of focus
    cv2.imwrite(str(tmp_path / "0006.png"), np.full_like(sharp, 200) + (np.indices(sharp.shape)[1] % 7 * 20)
                .astype(np.uint8))  # stripes: sharp, but no board
    shutil.copy(images / "imgs" / "0009.png", tmp_path / "extra.png")  # no joint row named extra
    files = [str(tmp_path / n) for n in ("0000.png", "0001.png", "0002.png", "0003.png", "0004.png", "0005.png",
                                          "0006.png", "extra.png")]
    out = _ok(run_pincal("detect", *files, "--board", BOARD, "--joints", "joints.csv", "--measure", "pixel:tool0",
                         "--out", "det.csv", cwd=tmp_path))
    lines = out.splitlines()
    assert any("0004.png: the same image as" in line and "0000.png" in line for line in lines)
    assert any("0005.png: blurred: the variance of its Laplacian is" in line for line in lines)
    assert any("0006.png: 0 corners found, fewer than 6" in line for line in lines)
    assert any("image 'extra' has no row in the joints file" in line for line in lines)
    assert any("joints row 0007: no image named '0007'" in line for line in lines)
    assert "in 4 of 8 images" in out
    assert read_dataset(tmp_path / "det.csv").sample_ids == ["0000", "0001", "0002", "0003"]


def test_intrinsics_held_at_a_camera_file(images: Path, tmp_path: Path) -> None:
    import cv2

    true = json.loads((images / "sim" / "truth.json").read_text())["parameters"]
    values = [true[f"intrinsics.tool0.{c}"] for c in ("fx", "fy", "cx", "cy", "k1", "k2", "p1", "p2", "k3")]
    storage = cv2.FileStorage(str(tmp_path / "camera.yaml"), cv2.FILE_STORAGE_WRITE)
    storage.write("camera_matrix", np.array([[values[0], 0, values[2]], [0, values[1], values[3]], [0, 0, 1.0]]))
    storage.write("distortion_coefficients", np.array([values[4:]]))
    storage.release()
    ros = tmp_path / "camera_info.yaml"
    ros.write_text("image_width: 1280\nimage_height: 960\ncamera_matrix:\n  rows: 3\n  cols: 3\n  data: ["
                   + ", ".join(map(repr, [values[0], 0, values[2], 0, values[1], values[3], 0, 0, 1.0]))
                   + "]\ndistortion_model: plumb_bob\ndistortion_coefficients:\n  rows: 1\n  cols: 5\n  data: ["
                   + ", ".join(map(repr, values[4:])) + "]\n")
    assert vision.read_camera_file(tmp_path / "camera.yaml") == pytest.approx(values, rel=1e-12, abs=1e-15)
    assert vision.read_camera_file(ros) == tuple(values)
    files = sorted(str(p) for p in (images / "imgs").glob("*.png"))
    _ok(run_pincal("detect", *files, "--board", BOARD, "--joints", str(images / "sim" / "joints.csv"), "--measure",
                   "pixel:tool0", "--camera-file", str(ros), "--out", "det.csv", cwd=tmp_path))
    assert "# intrinsics tool0 held: " in (tmp_path / "det.csv").read_text()
    _ok(run_pincal("calibrate", "ur10", "det.csv", "--report", "r.json", cwd=tmp_path))
    report = json.loads((tmp_path / "r.json").read_text())["parameters"]
    assert not [n for n in report if n.startswith("intrinsics")]
    assert "camera.tool0.tx" in report


@pytest.mark.parametrize(("args", "message"), [
    (["--board", "chess:8x6", "--measure", "pixel:tool0"], "board 'chess:8x6' is not charuco:COLSxROWS"),
    (["--board", BOARD, "--measure", "pose:tool0"], "--measure pose:tool0 is not pixel:<frame>"),
    (["--board", "charuco:8x6:0.03:0.022:DICT_9X9_1", "--measure", "pixel:tool0"],
     "board dictionary 'DICT_9X9_1' is not one of OpenCV's"),
])
def test_detect_refuses_bad_arguments_in_one_line(images: Path, tmp_path: Path, args: list[str],
                                                  message: str) -> None:
    files = [str(images / "imgs" / "0000.png")]
    done = run_pincal("detect", *files, "--joints", str(images / "sim" / "joints.csv"), *args, "--out", "d.csv",
                      cwd=tmp_path)
    assert done.returncode == 2
    assert done.stderr.startswith("pincal: error: ") and message in done.stderr
    assert len(done.stderr.splitlines()) == 1
    assert not (tmp_path / "d.csv").exists()


def test_without_opencv_the_error_says_how_to_install_it(monkeypatch: pytest.MonkeyPatch) -> None:
    monkeypatch.setitem(sys.modules, "cv2", None)
    with pytest.raises(vision.VisionUnavailableError, match=r'pip install "pincal\[vision\]"'):
        vision.opencv()


def test_a_camera_file_without_a_camera_matrix_is_named(tmp_path: Path) -> None:
    bad = tmp_path / "info.yaml"
    bad.write_text("image_width: 640\n")
    with pytest.raises(DataError, match=r"info\.yaml: no camera_matrix or k or K list of numbers"):
        vision.read_camera_file(bad)



def test_detect_pairs_images_by_time(images: Path, tmp_path: Path) -> None:
    joints = read_dataset(images / "sim" / "joints.csv")
    times = 1700000000.0 + 2.0 * np.arange(joints.n_samples)
    header = "sample,set,time," + ",".join(joints.joint_names)
    rows = [f"{s},{t},{float(w)!r}," + ",".join(repr(float(v)) for v in q)
            for s, t, w, q in zip(joints.sample_ids, joints.sets, times, joints.joints, strict=True)]
    (tmp_path / "joints.csv").write_text("\n".join([header, *rows]) + "\n")
    offsets = {0: 0.01, 1: -0.02, 2: 0.004, 3: 0.3}  # image 3 is 0.3 s from its row: beyond the tolerance
    files = []
    for k, offset in offsets.items():
        name = tmp_path / f"{times[k] + offset:.3f}.png"
        shutil.copy(images / "imgs" / f"{k:04d}.png", name)
        files.append(str(name))
    out = _ok(run_pincal("detect", *files, "--board", BOARD, "--joints", "joints.csv", "--measure", "pixel:tool0",
                         "--pair", "time", "--tolerance", "0.05", "--out", "det.csv", cwd=tmp_path))
    assert f"image '{times[3] + 0.3:.3f}': the nearest joint row (0003) is 0.3 s away, beyond the tolerance 0.05 s" \
        in out
    detected = read_dataset(tmp_path / "det.csv")
    assert detected.sample_ids == ["0000", "0001", "0002"] and "time" not in detected.joint_names
    exact = read_dataset(images / "sim" / "measurements.csv")
    assert np.array_equal(detected.joints, exact.joints[:3])
    done = run_pincal("detect", *files, "--board", BOARD, "--joints", str(images / "sim" / "joints.csv"),
                      "--measure", "pixel:tool0", "--pair", "time", "--out", "d2.csv", cwd=tmp_path)
    assert done.returncode == 2 and "pairing by time needs a 'time' column" in done.stderr


def test_an_apriltag_grid_detected_as_simulated(tmp_path: Path) -> None:
    board = "aruco:4x3:0.05:0.012:DICT_APRILTAG_36h11"
    _ok(run_pincal("simulate", "ur10", "--measure", "pixel:tool0", "--board", board, "--samples", "4", "--images",
                   "imgs", "--seed", "2", "--out", "sim", cwd=tmp_path))
    files = sorted(str(p) for p in (tmp_path / "imgs").glob("*.png"))
    _ok(run_pincal("detect", *files, "--board", board, "--joints", "sim/joints.csv", "--measure", "pixel:tool0",
                   "--out", "det.csv", cwd=tmp_path))
    detected, exact = read_dataset(tmp_path / "det.csv"), read_dataset(tmp_path / "sim" / "measurements.csv")
    assert detected.metadata["board"] == board
    errors = np.concatenate([(detected.measurements[k] - exact.measurements[k]).ravel()
                             for k in detected.measurements])
    assert np.all(np.isfinite(errors)) and len(errors) == 2 * 48 * 4  # every marker's four corners in every image
    assert np.sqrt(np.mean(errors ** 2)) < 0.4
