"""The laser displacement sensor of docs/extending.md (``examples/laser_sensor.py``): a measurement kind with unknowns
of its own, in one file that pincal does not name, through the library (its Jacobian against finite differences, its
start, its simulated readings, its key) and through ``pincal simulate``, ``calibrate``, ``check`` and ``report`` run
as the page writes them."""

from __future__ import annotations

import json
import os
import re
import subprocess
import sys
from collections.abc import Iterator
from pathlib import Path
from types import ModuleType

import numpy as np
import pinocchio as pin
import pytest
from conftest import PINCAL, ROOT

import pincal
from pincal.errors import DataError
from pincal.identification.measurements import KIND_CLASSES, KINDS, NominalReadings, parse_key
from pincal.identification.parameters import PARAMETER_KINDS, choose_parameters
from pincal.identification.problem import CalibrationProblem, Observations
from pincal.plugins import ENVIRONMENT, load_plugin

LASER = ROOT / "examples" / "laser_sensor.py"
RECIPE = (ROOT / "docs" / "extending.md").read_text(encoding="utf-8")


@pytest.fixture(scope="module")
def laser() -> Iterator[ModuleType]:
    """The plugin, loaded as ``PINCAL_PLUGINS`` loads it; its kinds unregistered afterwards (other tests list the
    kinds pincal has)."""
    module = load_plugin(str(LASER))
    try:
        yield module
    finally:
        for kind in module.Laser.kinds:
            KINDS.pop(kind, None)
            KIND_CLASSES.pop(kind, None)
        for name in (module.SENSOR, module.PLANE):
            PARAMETER_KINDS.pop(name, None)
        sys.modules.pop(module.__name__, None)


def test_the_jacobian_of_the_robot_the_sensor_and_the_plane_matches_finite_differences(laser: ModuleType) -> None:
    robot = pincal.load_robot("ur10")
    model = parse_key("laser:tool0", 1.0)  # σ 1 m: the residuals are the distances, their differences exact to 1e-9
    parameters = choose_parameters(robot, [model])
    names = [p.name for p in parameters]
    assert {"laser.tool0.tx", "laser.tool0.ry", "laser_plane.tz", "laser_plane.rx"} <= set(names)
    assert "laser.tool0.rz" not in names and "laser_plane.tx" not in names  # what a distance cannot see
    rng = np.random.default_rng(4)
    drawn = rng.uniform(-2.0, 2.0, (40, robot.n_actuated))
    nominal = CalibrationProblem(robot, parameters, [model], Observations(drawn, {model.key: model.neutral(40)}))
    distances = nominal.forward(np.zeros(len(parameters))).predicted[model.key][:, 0]
    actuated = drawn[np.abs(distances) < 3.0][:8]  # beams that meet the plane near the sensor
    assert len(actuated) == 8
    problem = CalibrationProblem(robot, parameters, [model], Observations(actuated, {model.key: model.neutral(8)}))
    x = rng.normal(scale=1e-3, size=len(parameters))
    evaluated = problem.evaluate(x)
    assert evaluated.jacobian is not None
    step = 1e-7
    numeric = np.column_stack([(problem.evaluate(x + step * e, jacobian=False).residual
                                - problem.evaluate(x - step * e, jacobian=False).residual) / (2 * step)
                               for e in np.eye(len(x))])
    np.testing.assert_allclose(evaluated.jacobian, numeric, rtol=1e-6, atol=1e-7)



def test_the_plane_is_the_world_the_robot_s_first_placement_is_left_out(laser: ModuleType) -> None:
    """The plane fixed in the world is all the readings see of the world (``world_anchor``): the first joint's
    placement moves every reading as the plane does, so the default set leaves it out, as it does for ``base.*``.
    With it in, the plane's tilts lay wholly in a null direction of the analytic Jacobian beside the base joint's
    (the fit marked them identified, their σ that of a combination); without it, they are seen alone: their weight
    in the null space (the norm of their entries in its orthonormal basis) is nil, the plane's offset along the
    normal still trades with the shoulder's height and the sensor's offset along the beam with the flange's."""
    robot = pincal.load_robot("ur10")
    model = parse_key("laser:tool0", 1e-5)
    parameters = choose_parameters(robot, [model])
    names = [p.name for p in parameters]
    assert not [name for name in names if name.startswith("shoulder_pan_joint.") and not name.endswith(".offset")]
    rng = np.random.default_rng(5)
    drawn = rng.uniform(-2.0, 2.0, (400, robot.n_actuated))
    nominal = CalibrationProblem(robot, parameters, [model], Observations(drawn, {model.key: model.neutral(400)}))
    distances = nominal.forward(np.zeros(len(parameters))).predicted[model.key][:, 0]
    actuated = drawn[(distances > 0.0) & (distances < 2.0)][:60]  # readings the sensor takes
    assert len(actuated) == 60
    problem = CalibrationProblem(robot, parameters, [model], Observations(actuated, {model.key: model.neutral(60)}))
    jacobian = problem.evaluate(np.zeros(len(parameters))).jacobian
    assert jacobian is not None
    scaled = jacobian * parameters.scales
    values, vt = np.linalg.svd(scaled, full_matrices=False)[1:]
    null = vt[int(np.sum(values > 1e-9 * values[0])):]
    weight = {name: float(np.linalg.norm(null[:, names.index(name)])) for name in names}
    assert weight["laser_plane.rx"] < 1e-6 and weight["laser_plane.ry"] < 1e-6
    assert weight["laser_plane.tz"] > 0.5 and weight["laser.tool0.tz"] > 0.5

def test_the_reading_is_the_distance_along_the_beam_to_the_plane(laser: ModuleType) -> None:
    """The sensor at nominal on the flange of the UR10 at zero, a plane offset and tilted: the reading is where the
    flange's z axis meets the plane, ``n·(g − o) / n·b`` (``g`` a point of the plane, ``n`` its normal, ``o`` the
    flange's origin, ``b`` its z axis)."""
    robot = pincal.load_robot("ur10")
    model = laser.laser("tool0")
    parameters = choose_parameters(robot, [model])
    q = np.zeros(robot.n_actuated)
    problem = CalibrationProblem(robot, parameters, [model], Observations(q[None], {model.key: model.neutral(1)}))
    frame = robot.placement(robot.q_reference, "tool0")
    delta = np.array([0.0, 0.0, -0.2, 0.1, -0.05, 0.0])  # the plane's tz [m], rx, ry [rad]
    placement = pin.exp6(pin.Motion(delta))
    x = np.zeros(len(parameters))
    for k, p in enumerate(parameters):
        if p.kind == laser.PLANE:
            x[k] = delta[p.component]
    beam = frame.rotation[:, 2]
    normal = placement.rotation[:, 2]
    expected = normal @ (placement.translation - frame.translation) / (normal @ beam)
    assert np.allclose(robot.q_reference, 0.0)
    assert problem.forward(x).predicted[model.key][0, 0] == pytest.approx(expected, abs=1e-12)


def test_its_start_is_the_plane_through_the_nominal_beams_hits(laser: ModuleType) -> None:
    """Readings of a plane tilted and offset, from sensors at nominal: the start is that plane (its normal and its
    offset along it), whatever the frames' placements."""
    rng = np.random.default_rng(1)
    plane = pin.exp6(pin.Motion(np.array([0.0, 0.0, -0.3]), np.array([0.05, -0.02, 0.0])))
    normal = plane.rotation[:, 2]
    frames, values = [], []
    for _ in range(12):
        frame = pin.SE3(pin.exp3(rng.normal(scale=0.3, size=3)) @ pin.rpy.rpyToMatrix(np.pi, 0.0, 0.0),
                        rng.uniform([-0.5, -0.5, 0.2], [0.5, 0.5, 0.8]))
        frames.append(frame)
        values.append([normal @ (plane.translation - frame.translation) / (normal @ frame.rotation[:, 2])])
    model = laser.laser("tool0")
    starts = laser.Laser.start_placements([model], lambda m: NominalReadings({"tool0": frames}, np.array(values)))
    start = starts[laser.PLANE]
    assert isinstance(start, pin.SE3)
    assert start.rotation[:, 2] == pytest.approx(normal, abs=1e-9)
    assert start.translation @ normal == pytest.approx(plane.translation @ normal, abs=1e-9)
    few = laser.Laser.start_placements([model], lambda m: NominalReadings({"tool0": frames[:2]},
                                                                          np.array(values[:2])))
    assert few == {laser.PLANE: "2 contact points do not fix a plane (three or more do)"}


def test_a_reading_beyond_the_range_is_not_taken(laser: ModuleType) -> None:
    model = laser.laser("tool0")
    predicted = np.array([[-0.1], [0.5], [laser.RANGE + 0.01], [laser.RANGE]])
    values = model.simulate(predicted, 0.0, np.random.default_rng(0))
    assert np.isnan(values[[0, 2], 0]).all() and values[[1, 3], 0].tolist() == [0.5, laser.RANGE]


@pytest.mark.parametrize("key", ["laser:tool0@plate", "laser:tool0-wrist_3_link"])
def test_a_key_it_cannot_read_is_refused_naming_it(laser: ModuleType, key: str) -> None:
    with pytest.raises(DataError, match=f"measurement '{re.escape(key)}' must name the frame the sensor is on"):
        parse_key(key)


def test_the_recipe_quotes_the_file() -> None:
    """Each Python excerpt of the laser's recipe is the file's text, as written there."""
    text = LASER.read_text(encoding="utf-8")
    section = RECIPE[RECIPE.index("## A sensor with unknowns of its own"):RECIPE.index("## A new parameter kind")]
    excerpts = re.findall(r"```python\n(.*?)```", section, re.DOTALL)
    assert len(excerpts) == 4
    for excerpt in excerpts:
        assert excerpt in text, excerpt


def _commands() -> list[list[str]]:
    """The ``pincal`` command lines of the recipe's shell block, split into arguments."""
    section = RECIPE[RECIPE.index("## A sensor with unknowns of its own"):RECIPE.index("## A new parameter kind")]
    block = re.search(r"```bash\n(.*?)```", section, re.DOTALL)
    assert block is not None
    lines = block.group(1).splitlines()
    assert lines[0] == "export PINCAL_PLUGINS=$PWD/examples/laser_sensor.py"
    assert all(line.startswith("pincal ") for line in lines[1:])
    return [line.split()[1:] for line in lines[1:]]


def test_the_recipe_s_commands_simulate_calibrate_check_and_report(tmp_path: Path) -> None:
    env = {**os.environ, ENVIRONMENT: str(LASER), "OPENBLAS_NUM_THREADS": "1"}
    done = {}
    for args in _commands():
        run = subprocess.run([str(PINCAL), *args], capture_output=True, text=True, timeout=300, env=env,
                             cwd=tmp_path, check=False)
        assert run.returncode == 0, (args, run.stderr)
        done[args[0]] = run.stdout
    report = json.loads((tmp_path / "result.json").read_text())
    assert report["test_rms_after"] < 0.01 * report["test_rms_before"], done["calibrate"]
    truth = json.loads((tmp_path / "sim" / "truth.json").read_text())["parameters"]
    for name in ("laser.tool0.tx", "laser.tool0.ty", "laser.tool0.rx", "laser.tool0.ry"):  # where it sits, its aim
        assert report["parameters"][name]["value"] == pytest.approx(truth[name], abs=1e-5), name
    assert "RMS laser distance error" in done["calibrate"] and "laser sensors" in done["calibrate"]
    urdf = (tmp_path / "ur10_calibrated.urdf").read_text()
    assert '<link name="tool0_laser"/>' in urdf and '<link name="laser_plane"/>' in urdf
    assert "no reading: the cells of 'laser:tool0' are all empty (not seen)" in done["calibrate"]
    assert "verdict: MODEL predicts DATA no worse than the nominal robot" in done["check"]
    assert "MODEL as it stands: the laser sensors and laser plane the file holds; nothing estimated" in done["check"]
    row = re.search(r"laser:tool0\s+length\s+\d+\s+([\d.]+) mm\s+[\d.]+ mm\s+([\d.]+) mm", done["check"])
    assert row is not None and float(row.group(1)) < 0.01 * float(row.group(2)), done["check"]
    assert (tmp_path / "report.html").stat().st_size > 10_000 and "held out" in done["report"]
    nominal = subprocess.run([str(PINCAL), "check", "ur10", "today/measurements.csv", "--nominal", "ur10"],
                             capture_output=True, text=True, timeout=300, env=env, cwd=tmp_path, check=False)
    assert nominal.returncode == 2 and nominal.stderr.strip() == (  # a model without the sensor's links
        "pincal: error: MODEL has no link 'laser_plane' (where a calibrated URDF holds its laser_plane): without it "
        "the model cannot predict the laser readings as it stands; check with --register, which places the laser "
        "sensors and their plane on DATA")
    _the_same_data_through_a_job_file(tmp_path, env, report)


def _the_same_data_through_a_job_file(folder: Path, env: dict[str, str], report: dict[str, float]) -> None:
    """The simulated file's distances written in mm under a name of their own, read by a job file that declares the
    laser as any one-frame kind: the same calibration; a plane's ``support`` given to it is refused, naming it."""
    lines = [line for line in (folder / "sim" / "measurements.csv").read_text().splitlines()
             if not line.startswith("#")]
    rows = [line.split(",") for line in lines]
    assert rows[0][-1] == "laser:tool0:distance"
    rows[0][-1] = "distance_mm"
    for row in rows[1:]:
        row[-1] = repr(float(row[-1]) * 1e3) if row[-1] else ""
    (folder / "laser_mm.csv").write_text("\n".join(",".join(row) for row in rows) + "\n", encoding="utf-8")
    job = ('robot = "ur10"\n[data]\nfile = "laser_mm.csv"\nheld_out = "set"\nsample = "sample"\n[[measure]]\n'
           'kind = "laser"\nframe = "tool0"\ncolumns = ["distance_mm"]\nunits = "mm"\nsigma = 1e-5\n')
    (folder / "job.toml").write_text(job, encoding="utf-8")
    run = subprocess.run([str(PINCAL), "calibrate", "job.toml", "--report", "job.json"], capture_output=True,
                         text=True, timeout=300, env=env, cwd=folder, check=False)
    assert run.returncode == 0, run.stderr
    from_job = json.loads((folder / "job.json").read_text())
    assert from_job["test_rms_after"] == pytest.approx(report["test_rms_after"], rel=1e-6)
    (folder / "job.toml").write_text(job + 'support = "base_link"\n', encoding="utf-8")
    refused = subprocess.run([str(PINCAL), "calibrate", "job.toml"], capture_output=True, text=True, timeout=300,
                             env=env, cwd=folder, check=False)
    assert refused.returncode == 2 and refused.stderr.strip() == (
        "pincal: error: job.toml: [measure 1] support: only a contact with a plane is held by a support; a laser is "
        "not")


def test_without_the_plugin_the_kind_is_unknown_and_with_a_bad_key_it_is_named(tmp_path: Path) -> None:
    env = {**os.environ, "OPENBLAS_NUM_THREADS": "1"}
    env.pop(ENVIRONMENT, None)
    args = ["simulate", "ur10", "--samples", "10", "--out", "sim", "--measure"]
    without = subprocess.run([str(PINCAL), *args, "laser"], capture_output=True, text=True, timeout=300, env=env,
                             cwd=tmp_path, check=False)
    assert without.returncode == 2 and "unknown measurement kind 'laser'" in without.stderr
    bad = subprocess.run([str(PINCAL), *args, "laser:tool0@plate"], capture_output=True, text=True, timeout=300,
                         env={**env, ENVIRONMENT: str(LASER)}, cwd=tmp_path, check=False)
    assert bad.returncode == 2 and bad.stderr.startswith("pincal: error: measurement 'laser:tool0@plate' must name "
                                                         "the frame the sensor is on as 'laser:<frame>'")
    assert "Traceback" not in bad.stderr and not (tmp_path / "sim").exists()
