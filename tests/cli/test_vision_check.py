"""``pincal check`` on pixels, as a user runs it: a camera calibrated with its robot (eye-in-hand UR10, eye-to-hand
Panda) predicts held-out images with the intrinsics and placement its calibrated URDF carries, beside the nominal
robot with its camera registered (calibrate's "before"); each image's reprojection error in px.
"""

from __future__ import annotations

import json
import math
from pathlib import Path

import numpy as np
import pytest
from conftest import run_pincal

from pincal.calibration.check_pixels import image_errors, pixel_figures
from pincal.calibration.check_setup import model_intrinsics
from pincal.calibration.report import CalibrationReport
from pincal.calibration.report_sections import CameraRecord, Covariance
from pincal.calibration.summary_camera import separation_lines
from pincal.errors import DataError
from pincal.identification.measurements.pixels import INTRINSICS, declared_intrinsics, parse_board, project
from pincal.io.dataset_reader import read_dataset


def _ok(done: object) -> str:
    assert done.returncode == 0, done.stdout + done.stderr  # type: ignore[attr-defined]
    return str(done.stdout)  # type: ignore[attr-defined]


@pytest.fixture(scope="module")
def ur10(tmp_path_factory: pytest.TempPathFactory) -> Path:
    """An eye-in-hand UR10 campaign (14 images fitted, 5 held out, 0.3 px noise) calibrated into cal.urdf, r.json."""
    root = tmp_path_factory.mktemp("vision_check")
    _ok(run_pincal("simulate", "ur10", "--measure", "pixel:tool0", "--samples", "14", "--test-samples", "5",
                   "--noise", "0.3", "--seed", "3", "--out", "sim", cwd=root))
    out = _ok(run_pincal("calibrate", "ur10", "sim/measurements.csv", "--out", "cal.urdf", "--report", "r.json",
                         cwd=root))
    (root / "calibrate.txt").write_text(out)
    return root


def _corners_seen(csv: Path, rows: list[str]) -> list[int]:
    """Each sample's corners with a reading (u written), from the CSV."""
    data = read_dataset(csv)
    seen = [sum(int(np.isfinite(v[k, 0])) for v in data.measurements.values()) for k in range(data.n_samples)]
    return [seen[data.sample_ids.index(s)] for s in rows]


def test_check_predicts_held_out_pixels_as_the_calibration_did(ur10: Path) -> None:
    out = _ok(run_pincal("check", "cal.urdf", "sim/measurements.csv", "--set", "test", "--report", "c.json",
                         cwd=ur10))
    report, content = json.loads((ur10 / "r.json").read_text()), json.loads((ur10 / "c.json").read_text())
    # the URDF alone (intrinsics carried, camera and board links) predicts what the calibration reported held out
    held_out = report["test_pixels"]
    assert content["pixels"]["rms"] == pytest.approx(held_out["rms_after"], rel=1e-9)
    assert content["pixels"]["nominal_rms"] == pytest.approx(held_out["rms_before"], rel=1e-9)
    assert content["pixels"]["rms"] < 0.6 < 1.5 < content["pixels"]["nominal_rms"]  # the noise is 0.3 px per axis
    # each image's error is the RMS of its corners': together they make the total
    samples = content["samples"]
    counts = _corners_seen(ur10 / "sim" / "measurements.csv", [s["sample"] for s in samples])
    assert len(samples) == 5 and sum(counts) == content["pixels"]["n_corners"]
    for key, total in (("pixel_error", "rms"), ("nominal_pixel_error", "nominal_rms")):
        pooled = math.sqrt(sum(n * s[key] ** 2 for n, s in zip(counts, samples, strict=True)) / sum(counts))
        assert pooled == pytest.approx(content["pixels"][total], rel=1e-9)
    assert f"reprojection: MODEL {content['pixels']['rms']:.4f} px RMS" in out
    assert f"  {samples[0]['sample']}: {samples[0]['pixel_error']:.4f} px, " in out
    assert "verdict: MODEL predicts DATA no worse than the nominal robot" in out


def test_the_calibrated_urdf_carries_the_intrinsics_with_their_sigma(ur10: Path) -> None:
    report = json.loads((ur10 / "r.json").read_text())
    camera = report["cameras"]["intrinsics.tool0"]
    assert camera["frame"] == "tool0" and not camera["held"] and camera["board"].startswith("charuco:8x6")
    for name in INTRINSICS:  # the data declare no nominal intrinsics: the estimates are the intrinsics
        estimate = report["parameters"][f"intrinsics.tool0.{name}"]
        assert (camera["intrinsics"][name], camera["std"][name]) == (estimate["value"], estimate["std"])
    assert '"cameras":{"intrinsics.tool0"' in (ur10 / "cal.urdf").read_text()


def test_a_model_without_intrinsics_is_refused_unless_registered(ur10: Path) -> None:
    done = run_pincal("check", "ur10", "sim/measurements.csv", "--nominal", "ur10", cwd=ur10)
    assert done.returncode == 2 and len(done.stderr.splitlines()) == 1
    assert done.stderr.startswith("pincal: error: MODEL carries no intrinsics of the camera on 'tool0'")
    out = _ok(run_pincal("check", "ur10", "sim/measurements.csv", "--nominal", "ur10", "--register", "--set", "test",
                         cwd=ur10))
    assert "reprojection: MODEL" in out  # the nominal robot against itself, both registered: not worse


def test_a_fixed_camera_checked_on_a_board_on_the_hand(tmp_path: Path) -> None:
    _ok(run_pincal("simulate", "panda", "--measure", "board_pixel:panda_hand", "--samples", "14", "--test-samples",
                   "4", "--noise", "0.3", "--seed", "1", "--out", "sim", cwd=tmp_path))
    _ok(run_pincal("calibrate", "panda", "sim/measurements.csv", "--out", "cal.urdf", "--report", "r.json",
                   cwd=tmp_path))
    _ok(run_pincal("check", "cal.urdf", "sim/measurements.csv", "--set", "test", "--report", "c.json", cwd=tmp_path))
    held_out = json.loads((tmp_path / "r.json").read_text())["test_pixels"]
    figures = json.loads((tmp_path / "c.json").read_text())["pixels"]
    assert figures["rms"] == pytest.approx(held_out["rms_after"], rel=1e-9)
    assert figures["rms"] < figures["nominal_rms"]
    # the board on the hand: each held-out image has its predicted bound, the same in calibrate's report and check's
    predicted = json.loads((tmp_path / "c.json").read_text())["pixel_predicted"]
    reported = json.loads((tmp_path / "r.json").read_text())["predicted_held_out"]["pixels"]
    assert predicted["images"] == reported["images"] == 4
    for name in ("median_bound", "median_model_bound", "median_bound_at_board"):
        assert 0.0 < predicted[name] == pytest.approx(reported[name], rel=1e-6)
    assert predicted["median_model_bound"] < predicted["median_bound"]


def test_image_errors_pool_each_images_corners() -> None:
    errors = {"pixel:tool0@0": np.array([[3.0, 4.0], [np.nan, np.nan], [1.0, 0.0]]),
              "pixel:tool0@1": np.array([[0.0, 0.0], [np.nan, np.nan], [np.nan, np.nan]]),
              "position:tool0": np.ones((3, 3))}
    per_image = image_errors(errors, 3)
    assert per_image is not None
    assert per_image[0] == pytest.approx(math.sqrt(25.0 / 2)) and np.isnan(per_image[1]) and per_image[2] == 1.0
    assert image_errors({"position:tool0": np.ones((3, 3))}, 3) is None
    figures = pixel_figures(errors, {k: 2.0 * v for k, v in errors.items()})
    assert figures is not None and figures["n_corners"] == 3 and figures["max"] == 5.0
    assert figures["nominal_rms"] == pytest.approx(2.0 * figures["rms"])


def test_model_intrinsics_hold_the_carried_values(ur10: Path) -> None:
    data = read_dataset(ur10 / "sim" / "measurements.csv")
    values = {c: float(k + 1) for k, c in enumerate(INTRINSICS)}
    carried = {"intrinsics.tool0": CameraRecord("tool0", intrinsics=values)}
    held = model_intrinsics(carried, data, register=False)
    assert declared_intrinsics(held.metadata, "tool0") == (tuple(float(k + 1) for k in range(9)), True)
    with pytest.raises(DataError, match="MODEL carries no intrinsics of the camera on 'tool0'"):
        model_intrinsics(None, data, register=False)
    assert declared_intrinsics(model_intrinsics(None, data, register=True).metadata, "tool0") == (None, False)


def test_compensate_brings_the_camera_to_poses_relative_to_the_board(ur10: Path) -> None:
    """The pixels fix the camera's pose relative to the board (not to the robot's base, which the board's placement
    trades with): targets of the camera in the board's frame, the truth's, reached by the true robot at the
    calibrated model's commands to the calibration's accuracy."""
    import pinocchio as pin

    import pincal

    truth = pincal.load_robot(str(ur10 / "sim" / "truth.urdf"))
    board = truth.placement(truth.q_reference, "camera_target")
    held_out = read_dataset(ur10 / "sim" / "measurements.csv").of_set("test")
    columns = ",".join(f"pose:tool0_camera:{c}" for c in ("x", "y", "z", "qx", "qy", "qz", "qw"))
    rows = [f"{s}," + ",".join(repr(float(v)) for v in pin.SE3ToXYZQUAT(board.actInv(truth.placement(q,
                                                                                                    "tool0_camera"))))
            for s, q in zip(held_out.sample_ids, held_out.joints, strict=True)]
    (ur10 / "camera_targets.csv").write_text("\n".join([f"sample,{columns}", *rows]) + "\n")
    out = _ok(run_pincal("compensate", "cal.urdf", "camera_targets.csv", "--targets-in", "board", "--out",
                         "camera_commands.csv", cwd=ur10))
    assert "in the board's frame, link 'camera_target'" in out and "reached 5 of 5" in out
    lines = [line for line in (ur10 / "camera_commands.csv").read_text().splitlines() if not line.startswith("#")]
    header = lines[0].split(",")
    joints = [header.index(j) for j in held_out.joint_names]
    commands = [np.array([float(line.split(",")[k]) for k in joints]) for line in lines[1:]]
    assert [line.split(",")[header.index("status")] for line in lines[1:]] == ["ok"] * 5
    true = json.loads((ur10 / "sim" / "truth.json").read_text())["parameters"]
    k = np.array([true.get(f"intrinsics.tool0.{c}", 0.0) for c in INTRINSICS])
    corners = parse_board(read_dataset(ur10 / "sim" / "measurements.csv").metadata["board"]).corners()

    def seen(q: np.ndarray) -> np.ndarray:  # the board's corners the true camera sees at q [px]
        in_camera = truth.placement(q, "tool0_camera").inverse() * board
        return project(corners @ in_camera.rotation.T + in_camera.translation, k)[0]

    off = [float(np.sqrt(np.mean(np.sum((seen(q) - seen(wanted)) ** 2, axis=1))))
           for q, wanted in zip(commands, held_out.joints, strict=True)]
    # the true camera at the commands sees the board within a few px of the target's view (the calibrated intrinsics'
    # σ in cx, cy trades with the camera's rotation: a pose target is that much off)
    assert max(off) < 4.0
    done = run_pincal("compensate", "ur10", "camera_targets.csv", "--targets-in", "board", "--frame", "tool0",
                      "--out", "c2.csv", cwd=ur10)
    assert done.returncode == 2 and len(done.stderr.splitlines()) == 1
    assert done.stderr.startswith("pincal: error: --targets-in board: MODEL has no link 'camera_target'")


def test_the_summary_gives_each_images_error_and_the_intrinsics(ur10: Path) -> None:
    out = (ur10 / "calibrate.txt").read_text()
    report = json.loads((ur10 / "r.json").read_text())
    camera = report["cameras"]["intrinsics.tool0"]
    values, stds = camera["intrinsics"], camera["std"]
    assert (f"camera on 'tool0' (intrinsics.tool0): fx {values['fx']:.2f} ± {stds['fx']:.2f}, fy "
            f"{values['fy']:.2f} ± {stds['fy']:.2f}") in out
    assert "corners seen: fitted 490 of 490 in 14 images; held out 175 in 5 images" in out
    assert "position readings" not in out  # corners are not positions
    # each image's reprojection error before and after: pooled over its corners, the report's RMS
    images = {part: [e for e in report["sample_errors"] if e["set"] == part] for part in ("train", "test")}
    counts = {part: _corners_seen(ur10 / "sim" / "measurements.csv", [e["sample"] for e in entries])
              for part, entries in images.items()}
    for part, figures in (("train", report["pixels"]), ("test", report["test_pixels"])):
        for when in ("before", "after"):
            pooled = math.sqrt(sum(n * e[f"pixel_{when}"] ** 2 for n, e in zip(counts[part], images[part],
                                                                                strict=True)) / sum(counts[part]))
            assert pooled == pytest.approx(figures[f"rms_{when}"], rel=1e-9)
    worst = max(images["train"] + images["test"], key=lambda e: e["pixel_after"])
    assert f"{worst['sample']} ({worst['set']}) {worst['pixel_before']:.3f} → {worst['pixel_after']:.3f} px" in out


def _report(correlation: float) -> CalibrationReport:
    """A report of one camera whose fx correlates with its placement's tz by ``correlation`` (σ 2 px, 1 mm)."""
    names = ["intrinsics.tool0.fx", "camera.tool0.tz", "camera.tool0.ry"]
    std = np.array([2.0, 1e-3, 1e-3])
    rho = np.array([[1.0, correlation, 0.0], [correlation, 1.0, 0.0], [0.0, 0.0, 1.0]])
    return CalibrationReport(cameras={"intrinsics.tool0": CameraRecord("tool0")},
                             covariance=Covariance(names, (rho * np.outer(std, std)).tolist()))


def test_the_focal_length_against_the_distance_in_words() -> None:
    lines = separation_lines(_report(-0.99))  # σ 1/√(1 − 0.99²) = 7.09× what a known tz would leave
    assert lines[0] == "not separated by these views:" and len(lines) == 2
    assert lines[1].startswith("  the focal length fx against the camera's distance to the board: σ 2 px, 7.09× what "
                               "a known placement would leave (ρ -0.99 with camera.tool0.tz)")
    assert separation_lines(_report(-0.9)) == []  # 2.29×: the views separate them well enough


def test_the_report_page_shows_the_camera(ur10: Path) -> None:
    out = _ok(run_pincal("report", "ur10", "sim/measurements.csv", "--out", "page.html", "--quiet", cwd=ur10))
    assert "wrote page.html" in out
    page = (ur10 / "page.html").read_text()
    camera = page[page.index("<h2>Camera</h2>"):page.index("<h2>Parameters</h2>")]
    assert 'aria-label="reprojection error of each image before and after calibration: 14 fitted images, 5 held ' \
        'out"' in camera
    assert 'aria-label="residuals of the 490 fitted corners over the image plane, before (×' in camera
    assert camera.count("<figure><svg ") == 2 and "<img " not in camera and "data:image/png" not in camera
    images = camera[:camera.index("residuals of the 490")]
    assert images.count('<circle ') >= 2 * 19  # every image before and after
    cameras = json.loads((ur10 / "r.json").read_text())["cameras"]["intrinsics.tool0"]
    for name in INTRINSICS:  # the page's table is the calibration's
        value, std = cameras["intrinsics"][name], cameras["std"][name]
        assert f"<td>intrinsics.tool0.{name}</td><td>{'px' if name[0] in 'fc' else '1'}</td><td>{value:.6g}</td>" \
               f"<td>{std:.3g}</td>" in camera


def test_the_scene_draws_the_camera_looking_at_its_board(ur10: Path) -> None:
    """In the 3D scene, the calibrated camera's frustum rides on tool0 and the board lies in front of it at every
    image, where the simulation drew the views (0.3 to 1 m from the board's centre), its centre inside the image."""
    import pincal
    from pincal.calibration.options import CalibrationOptions
    from pincal.viz.camera_scene import camera_placements
    from pincal.viz.scene import CalibrationView, configurations

    report = CalibrationReport.read(ur10 / "r.json")
    view = CalibrationView.from_result(pincal.load_robot("ur10"), read_dataset(ur10 / "sim" / "measurements.csv"),
                                       report, CalibrationOptions())
    _, _, calibrated, q = configurations(view)
    drawn = {name: (segments, placements) for name, segments, placements, _ in
             camera_placements(view, calibrated, q, view.base_placement().homogeneous)}
    assert set(drawn) == {"tool0_frustum", "tool0_board"}
    (frustum, cameras), (outline, boards) = drawn["tool0_frustum"], drawn["tool0_board"]
    assert len(cameras) == 14 and len(boards) == 1 and frustum.shape == (16, 3) and outline.shape == (8, 3)
    centre = np.r_[outline.max(axis=0) / 2, 1.0]  # the board's centre, in its frame
    k = report.cameras["intrinsics.tool0"].intrinsics if report.cameras else {}
    for camera in cameras:
        seen = np.linalg.solve(camera, boards[0] @ centre)[:3]
        assert 0.25 < seen[2] < 1.1
        u, v = k["fx"] * seen[0] / seen[2] + k["cx"], k["fy"] * seen[1] / seen[2] + k["cy"]
        assert 0 < u < 2 * k["cx"] and 0 < v < 2 * k["cy"]


def test_check_gives_each_image_a_predicted_bound_in_px_and_at_the_board(ur10: Path) -> None:
    """``pincal check`` on held-out images gives each its predicted 95 % bound of the reprojection error [px], the
    model's part below it, and in mm at the board: the bound times the board's metres per pixel, which lies between
    the true camera's nearest and farthest corner depth over its focal length."""
    import pincal

    out = _ok(run_pincal("check", "cal.urdf", "sim/measurements.csv", "--set", "test", "--report", "chk.json",
                         cwd=ur10))
    assert "predicted 95 % bound of an image's reprojection error: median " in out
    assert "predicted errors: not known" not in out
    rows = [line for line in out.splitlines() if line.startswith("  00") and "mm at the board)" in line]
    assert len(rows) == 5
    content = json.loads((ur10 / "chk.json").read_text())
    account = content["pixel_predicted"]
    assert account["unit"] == "px" and account["level"] == 0.95 and account["images"] == 5
    assert account["inside"] >= 4  # the noise is 0.3 px, the model fitted on 14 images
    truth = pincal.load_robot(str(ur10 / "sim" / "truth.urdf"))
    fx = json.loads((ur10 / "sim" / "truth.json").read_text())["parameters"]["intrinsics.tool0.fx"]
    corners = parse_board(read_dataset(ur10 / "sim" / "measurements.csv").metadata["board"]).corners()
    held_out = read_dataset(ur10 / "sim" / "measurements.csv").of_set("test")
    board = truth.placement(truth.q_reference, "camera_target")
    for sample, q in zip(held_out.sample_ids, held_out.joints, strict=True):
        entry = next(s for s in content["samples"] if s["sample"] == sample)
        assert 0.0 < entry["pixel_model_bound"] < entry["pixel_bound"] < 3.0
        in_camera = truth.placement(q, "tool0_camera").inverse() * board
        depth = (corners @ in_camera.rotation.T + in_camera.translation)[:, 2]
        per_pixel = entry["pixel_bound_at_board"] / entry["pixel_bound"]  # m/px at the board
        assert 0.9 * depth.min() / fx < per_pixel < 1.5 * depth.max() / fx


def test_the_board_scale_is_depth_over_focal_length_for_a_board_facing_the_camera() -> None:
    """A board square to the optical axis at depth z [m] seen with focal length f [px]: z / f metres per pixel."""
    from pincal.calibration.check_pixels import metres_per_pixel
    from pincal.identification.measurements.pixels import pixel

    board_spec = "charuco:5x4:0.04:0.03:DICT_4X4_50"
    models = [pixel("tool0", k).with_metadata({"board": board_spec}) for k in range(12)]
    z, f = 0.8, 640.0
    uv = {m.key: np.array([[f * m.point()[0] / z + 320.0, f * m.point()[1] / z + 240.0]]) for m in models}
    assert math.isclose(metres_per_pixel(models, uv, 0), z / f, rel_tol=1e-12)
    uv[models[0].key][0, 0] = np.nan
    assert math.isclose(metres_per_pixel(models, uv, 0), z / f, rel_tol=1e-12)  # a corner not seen is left out
    assert math.isnan(metres_per_pixel(models[:1], uv, 0))


def test_calibrate_reports_the_held_out_images_bounds_that_check_gives_again(ur10: Path) -> None:
    """calibrate's report predicts each held-out image's reprojection error (px, and mm at the board); check on the
    same images with the calibrated URDF (its carried covariance) gives the same bounds."""
    summary = (ur10 / "calibrate.txt").read_text()
    assert "predicted 95 % bound of a held-out image's reprojection error: median " in summary
    held = json.loads((ur10 / "r.json").read_text())["predicted_held_out"]["pixels"]
    assert held["images"] == 5 and held["unit"] == "px"
    if not (ur10 / "chk.json").exists():
        _ok(run_pincal("check", "cal.urdf", "sim/measurements.csv", "--set", "test", "--report", "chk.json", cwd=ur10))
    checked = {s["sample"]: s for s in json.loads((ur10 / "chk.json").read_text())["samples"]}
    for image in held["images_predicted"]:
        again = checked[image["sample"]]
        assert math.isclose(image["pixel_error"], again["pixel_error"], rel_tol=1e-6)
        for name in ("pixel_bound", "pixel_model_bound", "pixel_bound_at_board"):
            assert math.isclose(image[name], again[name], rel_tol=1e-6), name


def test_with_no_parameter_uncertainty_an_images_bound_is_the_noises_chi_quantile(ur10: Path) -> None:
    """With a zero covariance of the estimates, an image's bound is the corners' noise alone: its n corners' 2n errors
    of σ each, ‖e‖'s 95 % quantile σ √χ²₀.₉₅(2n) over √n; the model's part is 0."""
    from scipy.stats import chi2

    import pincal
    from pincal.calibration.check_pixels import pixel_bounds
    from pincal.calibration.options import CalibrationOptions
    from pincal.calibration.setup import prepare

    problem = prepare(pincal.load_robot("ur10"), read_dataset(ur10 / "sim" / "measurements.csv"),
                      CalibrationOptions(), part="test").problem
    x = problem.initial_guess()
    q = len(x)
    bounds = pixel_bounds(problem, np.zeros((q, q)), list(range(q)), 4.0, x)
    assert bounds is not None
    n = 35  # the 8 x 6 board's inner corners, every one seen in the simulated images
    sigma = 2.0 * 0.3  # √σ̂² times the σ [px] the file declares ('# sigma pixel: 0.3', simulate's --noise)
    assert np.all(bounds.model_bound == 0.0)
    assert np.allclose(bounds.bound, sigma * math.sqrt(chi2.ppf(0.95, 2 * n)) / math.sqrt(n), rtol=1e-9)
