"""The 3D scene: URDF visuals as meshcat shapes, the recorded scene, the static page in a real browser,
the same drawing sent to a live meshcat window, and the ``view`` command."""

from __future__ import annotations

import base64
import html
import io
import json
import re
import subprocess
import sys
from pathlib import Path
from typing import Any

import meshcat
import numpy as np
import pytest
import umsgpack
from browser import orange_pixels, pixel_variance, render, served
from conftest import ROBOTS

import pincal
from pincal.calibration.campaign import Simulation, simulate
from pincal.calibration.options import CalibrationOptions
from pincal.calibration.pipeline import Calibration, calibrate
from pincal.calibration.report import CalibrationReport
from pincal.cli.app import main
from pincal.identification.corrections import Payload
from pincal.io.dataset import write_dataset
from pincal.model.catalog import resolve_mesh_file
from pincal.progress import Progress
from pincal.viz.scene import CalibrationView, configurations, draw_calibration, static_scene
from pincal.viz.static_page import StaticScene
from pincal.viz.visuals import MAX_MESH_TRIANGLES, STL_TRIANGLE, binary_stl_corners, clustered_mesh, robot_visuals

N_TRAIN = 30
LINKS_WITH_VISUALS = {"base", "arm_1", "rod_1", "arm_2", "rod_2", "arm_3", "rod_3", "platform", "end_effector"}


@pytest.fixture(scope="module")
def delta_case() -> tuple[Simulation, Calibration]:
    robot = pincal.load_robot(ROBOTS / "delta.urdf")
    sim = simulate(robot, ["position"], N_TRAIN, 10, perturb=1e-3, noise=1e-5, seed=3, parameter_spec=["model24"])
    return sim, calibrate(robot, sim.dataset, parameter_spec=["model24"], x_true=sim.x_true)


def _commands(page: str) -> list[dict[str, Any]]:
    """The meshcat commands embedded in a static page, decoded as the viewer's JavaScript does."""
    match = re.search(r"var commands = (\[.*?\]), samples =", page)
    assert match, "no command buffer in the page"
    return [umsgpack.unpackb(base64.b64decode(c)) for c in json.loads(match.group(1))]


def test_urdf_visuals_become_meshcat_shapes(delta: pincal.Robot, delta_text: str) -> None:
    import meshcat.geometry as mg

    visuals, notes = robot_visuals(delta)
    assert notes == []
    assert len(visuals) == delta_text.count("<visual>") == 15
    kinds = [type(v.geometry) for v in visuals]
    assert kinds.count(mg.Box) == 1 and kinds.count(mg.Cylinder) == 7 and kinds.count(mg.Sphere) == 7
    # arm_1's cylinder: URDF axis z turned by rpy (0, π/2, 0) runs along the link's x; meshcat's runs along y
    arm = next(v for v in visuals if delta.model.frames[v.frame_id].name == "arm_1" and v.name == "visual_0")
    np.testing.assert_allclose(arm.placement[:3, 1], [1.0, 0.0, 0.0], atol=1e-12)
    np.testing.assert_allclose(arm.placement[:3, 3], [0.13, 0.0, 0.0], atol=1e-12)


def test_meshes_embedded_from_local_files_or_replaced() -> None:
    import meshcat.geometry as mg

    ur10 = pincal.load_robot("ur10")
    visuals, notes = robot_visuals(ur10)
    # the visual .dae files are over the size budget: the links' collision .stl files stand in, simplified
    assert notes == [] and len(visuals) == 7
    assert all(isinstance(v.geometry, mg.TriangularMeshGeometry) for v in visuals)
    assert all(0 < len(v.geometry.faces) <= MAX_MESH_TRIANGLES for v in visuals)
    visuals, notes = robot_visuals(ur10, max_mesh_bytes=0)
    assert len([n for n in notes if "not drawn" in n]) == 7 and "skeleton" in notes[-1]
    assert len([v for v in visuals if v.name == "joint"]) == ur10.model.njoints - 1


def _box_soup(divisions: int) -> np.ndarray:
    """The corners of a unit cube's faces, each face split into ``divisions``² squares of two triangles [m]."""
    t = np.linspace(0.0, 1.0, divisions + 1)
    corners = []
    for axis in range(3):
        for side in (0.0, 1.0):
            for i in range(divisions):
                for j in range(divisions):
                    square = [(t[i], t[j]), (t[i + 1], t[j]), (t[i + 1], t[j + 1]), (t[i], t[j + 1])]
                    points = [np.insert(np.array(uv), axis, side) for uv in square]
                    corners += [points[0], points[1], points[2], points[0], points[2], points[3]]
    return np.array(corners)


def test_a_mesh_is_shared_and_simplified_to_the_triangle_budget() -> None:
    fine = _box_soup(30)  # 10 800 triangles as an STL file holds them: three corners each, none shared
    vertices, faces = clustered_mesh(fine, max_triangles=10**6)
    assert len(faces) == len(fine) // 3 and len(vertices) == 6 * 31**2 - 12 * 31 + 8  # shared, none lost
    np.testing.assert_allclose(vertices[faces].reshape(-1, 3), fine, atol=1e-3)
    vertices, faces = clustered_mesh(fine, max_triangles=400)
    assert 12 <= len(faces) <= 400
    # still the cube, to within a grid cell (400 triangles on six faces: at most 5 cells along a side, 0.2 m each)
    distance = np.minimum(np.abs(vertices), np.abs(vertices - 1.0)).min(axis=1)
    assert distance.max() < 0.2 and np.ptp(vertices, axis=0).min() > 0.8


def test_a_binary_stl_file_reads_as_its_triangles(tmp_path: Path) -> None:
    soup = _box_soup(1)
    records = np.zeros(len(soup) // 3, dtype=STL_TRIANGLE)
    records["corners"] = soup.reshape(-1, 3, 3)
    path = tmp_path / "cube.stl"
    path.write_bytes(b"\0" * 80 + len(records).to_bytes(4, "little") + records.tobytes())
    np.testing.assert_array_equal(binary_stl_corners(path), soup)
    path.write_text("solid cube\nendsolid cube\n")
    assert binary_stl_corners(path) is None


def test_a_mesh_drawn_on_several_links_is_decimated_once_and_anew_when_its_file_changes(tmp_path: Path) -> None:
    from pincal.viz.visuals import _mesh_geometry, _stl_mesh

    def write(soup: np.ndarray) -> None:
        records = np.zeros(len(soup) // 3, dtype=STL_TRIANGLE)
        records["corners"] = soup.reshape(-1, 3, 3)
        path.write_bytes(b"\0" * 80 + len(records).to_bytes(4, "little") + records.tobytes())

    path = tmp_path / "caster.stl"
    write(_box_soup(2))
    first, second = _mesh_geometry(path), _mesh_geometry(path)
    assert first is not second and first.uuid != second.uuid  # two geometries of the page, one decimation
    decimated = clustered_mesh(binary_stl_corners(path))
    for geometry in (first, second):
        np.testing.assert_array_equal(geometry.vertices, decimated[0])
        np.testing.assert_array_equal(geometry.faces, decimated[1])
    before = _stl_mesh.cache_info()
    _mesh_geometry(path)
    assert _stl_mesh.cache_info().hits == before.hits + 1
    write(_box_soup(3) * 2.0)  # another size: decimated anew
    np.testing.assert_array_equal(_mesh_geometry(path).vertices, clustered_mesh(binary_stl_corners(path))[0])
    assert _stl_mesh.cache_info().misses == before.misses + 1


def test_package_uris_resolve_beside_the_urdf(tmp_path: Path) -> None:
    mesh = tmp_path / "share" / "my_robot" / "meshes" / "link.stl"
    mesh.parent.mkdir(parents=True)
    mesh.write_bytes(b"solid x\nendsolid x\n")
    urdf_dir = tmp_path / "share" / "my_robot" / "urdf"
    urdf_dir.mkdir()
    assert resolve_mesh_file("package://my_robot/meshes/link.stl", urdf_dir) == mesh
    assert resolve_mesh_file("../meshes/link.stl", urdf_dir) == (urdf_dir / "../meshes/link.stl").resolve() == mesh
    assert resolve_mesh_file(f"file://{mesh}", urdf_dir) == mesh
    assert resolve_mesh_file("package://other_robot/meshes/link.stl", urdf_dir) is None


def test_static_scene_holds_robots_samples_and_one_frame_per_sample(delta_case: tuple[Simulation, Calibration]
                                                                    ) -> None:
    _, cal = delta_case
    page, summary = static_scene(CalibrationView.from_calibration(cal))
    assert summary.n_samples == N_TRAIN and summary.n_visuals == 15 and set(summary.frames) == LINKS_WITH_VISUALS
    # errors of ~2 mm on a robot of ~0.8 m: magnified to be seen, by a round factor
    assert summary.magnification in (10.0, 20.0, 50.0)
    commands = _commands(page)
    objects = {c["path"] for c in commands if c["type"] == "set_object"}
    for group in ("robot_nominal", "robot_calibrated"):
        assert {p for p in objects if p.startswith(f"/meshcat/pincal/{group}/")} == {
            f"/meshcat/pincal/{group}/{delta_frame}/{visual}"
            for delta_frame, visual in _visual_paths(cal.problem.robot)}
    for group in ("points", "error_before", "error_after"):
        assert {p for p in objects if p.startswith(f"/meshcat/pincal/samples/{group}/")} == {
            f"/meshcat/pincal/samples/{group}/{k:03d}" for k in range(N_TRAIN)}
    ghost = next(c for c in commands if c["path"] == "/meshcat/pincal/robot_nominal/platform/visual_0")
    solid = next(c for c in commands if c["path"] == "/meshcat/pincal/robot_calibrated/platform/visual_0")
    assert ghost["object"]["materials"][0]["transparent"] and ghost["object"]["materials"][0]["opacity"] < 1
    assert not solid["object"]["materials"][0]["transparent"]
    (animation,) = [c for c in commands if c["type"] == "set_animation"]
    clips = {a["path"]: a["clip"] for a in animation["animations"]}
    assert "/meshcat/pincal/robot_calibrated/platform" in clips and "/meshcat/pincal/samples/current" in clips
    times = [key["time"] for key in clips["/meshcat/pincal/samples/current"]["tracks"][0]["keys"]]
    assert times[::2] == list(range(N_TRAIN))  # one held frame per sample: time = sample index
    # offline: the page loads nothing from anywhere
    assert not re.search(r"""(?:src|href)\s*=\s*["']?\s*(?:https?:)?//""", page)
    assert "MeshCat.Viewer" in page


def _visual_paths(robot: pincal.Robot) -> set[tuple[str, str]]:
    visuals, _ = robot_visuals(robot)
    return {(str(robot.model.frames[v.frame_id].name), v.name) for v in visuals}


class _LiveWindow:
    """Stands in for meshcat's ViewerWindow (a running server): it receives each command."""

    def __init__(self) -> None:
        self.received: list[dict[str, Any]] = []

    def send(self, command: Any) -> None:
        self.received.append(command.lower())


def test_the_same_drawing_goes_to_a_live_meshcat_window(delta_case: tuple[Simulation, Calibration]) -> None:
    _, cal = delta_case
    view = CalibrationView.from_calibration(cal)
    live = _LiveWindow()
    draw_calibration(meshcat.Visualizer(window=live), view)
    recorded = StaticScene()
    draw_calibration(recorded.visualizer(), view)
    assert [(c["type"], c.get("path")) for c in live.received] == \
        [(c["type"], c.get("path")) for c in (cmd.lower() for cmd in recorded.commands)]
    replayed = _LiveWindow()
    recorded.replay(meshcat.Visualizer(window=replayed))
    assert len(replayed.received) == len(recorded.commands) > 3 * N_TRAIN


def test_scene_in_a_real_browser(tmp_path: Path, delta_case: tuple[Simulation, Calibration]) -> None:
    sim, cal = delta_case
    view = CalibrationView.from_calibration(cal)
    page, summary = static_scene(view)
    (tmp_path / "scene.html").write_text(page, encoding="utf-8")
    k = 17
    with served(tmp_path) as base:
        shown = render(f"{base}scene.html#sample={k}", tmp_path / "scene.png")
    match = re.search(r'<pre id="pincal-scene-status"[^>]*>(.*?)</pre>', shown.dom, re.S)
    assert match and match.group(1), "the page's script did not report the scene it built"
    status = json.loads(html.unescape(match.group(1)))
    assert status["webgl"], "no WebGL in the browser: nothing could be drawn"
    # the browser built the robots' parts and every sample's marker and error segments
    assert status["robot_nominal"] == status["robot_calibrated"] == summary.n_visuals == 15
    assert set(status["frames"]) == LINKS_WITH_VISUALS
    assert status["points"] == status["error_before"] == status["error_after"] == N_TRAIN
    assert status["animation_seconds"] == pytest.approx(N_TRAIN - 1 + 0.9, abs=1e-5)
    # stepping to sample k moved the highlight to its measured point and the robot to its pose there
    assert status["sample"] == k
    measured = sim.dataset.of_set("train").measurements["position:end_effector"][k]
    np.testing.assert_allclose(status["current_point"], measured, atol=1e-6)
    _, _, calibrated, q_calibrated = configurations(view)
    platform = calibrated.placement(q_calibrated[k], "platform").translation
    np.testing.assert_allclose(status["calibrated_frames"]["platform"], platform, atol=1e-6)
    assert np.linalg.norm(status["calibrated_frames"]["platform"] - measured) < 1e-4  # the calibration fits
    # and it is on the screen: not blank, and the orange robot fills part of the view below the legend
    assert pixel_variance(shown.screenshot) > 30
    assert orange_pixels(shown.screenshot[240:]) > 3000


def test_progress_bar_draws_unless_quiet() -> None:
    stream = io.StringIO()
    with Progress("forward kinematics", 4, stream=stream) as progress:
        for _ in range(4):
            progress.advance()
    assert stream.getvalue().endswith(f"forward kinematics [{'#' * 30}] 4/4\n")
    silent = io.StringIO()
    with Progress("forward kinematics", 4, quiet=True, stream=silent) as progress:
        progress.advance(4)
    assert silent.getvalue() == ""


def test_view_command_and_result_reuse(tmp_path: Path, capsys: pytest.CaptureFixture[str],
                                       delta_case: tuple[Simulation, Calibration]) -> None:
    sim, cal = delta_case
    data, result, scene = tmp_path / "measurements.csv", tmp_path / "result.json", tmp_path / "scene.html"
    write_dataset(sim.dataset, data)
    assert main(["calibrate", "delta", str(data), "--parameters", "model24", "--report", str(result)]) == 0
    capsys.readouterr()
    assert main(["view", "delta", str(data), "--parameters", "model24", "--result", str(result),
                 "--out", str(scene), "--quiet"]) == 0
    out = capsys.readouterr()
    assert f"wrote {scene}" in out.out and "15 shapes per robot" in out.out and f"{N_TRAIN} samples" in out.out
    assert out.err == ""  # --quiet
    assert "pincal-scene-status" in scene.read_text(encoding="utf-8")
    # the result read back gives the calibration's own errors
    view = CalibrationView.from_result(cal.problem.robot, sim.dataset, CalibrationReport.read(result),
                                       CalibrationOptions(parameter_spec=["model24"]))
    np.testing.assert_allclose(view.x, cal.result.x, atol=1e-15)
    key = "position:end_effector"
    np.testing.assert_allclose(view.errors_after[key], cal.result.errors_after[key], atol=1e-9)
    # a result made with other parameters than those asked for: one line, saying what to do
    assert main(["view", "delta", str(data), "--result", str(result), "--out", str(scene), "--quiet"]) == 2
    err = capsys.readouterr().err.strip().splitlines()
    assert len(err) == 1 and err[0].startswith("pincal: error:") and "--parameters" in err[0]


def test_occluded_markers_draw_each_sample_at_its_first_marker_seen(tmp_path: Path) -> None:
    """Three markers on the UR10's tool0, some not seen: each sample's point and error segments come from its first
    marker seen, never NaN, and the page holds finite transforms only."""
    robot = pincal.load_robot("ur10")
    sim = simulate(robot, ["position:tool0@m1", "position:tool0@m2", "position:tool0@m3"], 12, 0, seed=2)
    values = sim.dataset.measurements
    values["position:tool0@m1"][[1, 4]] = np.nan
    values["position:tool0@m2"][[4]] = np.nan
    view = CalibrationView.from_calibration(calibrate(robot, sim.dataset))
    points, before, after = view.point_errors()
    assert points is not None and before is not None and after is not None
    assert np.isfinite(points).all() and np.isfinite(before).all() and np.isfinite(after).all()
    np.testing.assert_array_equal(points[1], values["position:tool0@m2"][1])
    np.testing.assert_array_equal(points[4], values["position:tool0@m3"][4])
    np.testing.assert_array_equal(points[0], values["position:tool0@m1"][0])
    page, summary = static_scene(view)
    transforms = [c["matrix"] for c in _commands(page) if c["type"] == "set_transform"]
    assert summary.n_samples == 12 and transforms and all(np.isfinite(np.asarray(m, dtype=float)).all()
                                                          for m in transforms)


def test_a_result_read_back_predicts_with_the_payload_it_records(tmp_path: Path) -> None:
    """A compliance fitted under a payload: the view rebuilt from the report JSON gives the calibration's errors."""
    ur10 = pincal.load_robot("ur10")
    payload = Payload(8.0, "tool0", (0.0, 0.0, 0.15))
    spec = ["default", "*.compliance"]
    sim = simulate(ur10, ["position"], 30, seed=3, parameter_spec=spec, payload=payload)
    cal = calibrate(ur10, sim.dataset, parameter_spec=spec, payload=payload)
    report = json.loads(cal.report.to_json())
    options = CalibrationOptions(parameter_spec=spec)
    view = CalibrationView.from_result(ur10, sim.dataset, CalibrationReport.from_json(report), options)
    key = "position:tool0"
    np.testing.assert_allclose(view.errors_after[key], cal.result.errors_after[key], atol=1e-12)
    report["payload"] = None  # the same numbers read as if no load had been carried: other predictions
    forgotten = CalibrationView.from_result(ur10, sim.dataset, CalibrationReport.from_json(report), options)
    assert np.abs(forgotten.errors_after[key] - cal.result.errors_after[key]).max() > 1e-4  # [m]


#: In a fresh interpreter: meshcat's drawing modules loaded alone, then the whole package on first use of a name only
#: its ``__init__`` defines.
LEAN_PROBE = """
import sys
from pincal.viz.visuals import lean_meshcat
lean_meshcat()
import meshcat.geometry, meshcat.animation, meshcat.commands
server = ("meshcat.visualizer", "tornado", "zmq", "IPython")
print(sorted(m for m in server if m in sys.modules))
import meshcat
print(meshcat.Visualizer.__name__, sorted(m for m in server if m in sys.modules))
"""


def test_meshcat_s_drawing_modules_load_without_its_server() -> None:
    done = subprocess.run([sys.executable, "-P", "-c", LEAN_PROBE], capture_output=True, text=True, timeout=120,
                          check=False)
    assert done.returncode == 0, done.stderr
    assert done.stdout.splitlines() == ["[]", "Visualizer ['IPython', 'meshcat.visualizer', 'tornado', 'zmq']"]
