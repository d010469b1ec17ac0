"""Non-geometric corrections (joint harmonics, compliance): their derivatives, their recovery, the corrections file
and the function that applies it, checked against the calibrated model's predictions."""

from __future__ import annotations

import json
import re
from dataclasses import replace
from pathlib import Path

import numpy as np
import pytest
from conftest import finite_difference_jacobian, run_pincal

import pincal
from pincal.errors import DataError
from pincal.identification import measurements as ms
from pincal.identification.corrections import Payload, gravity_torques
from pincal.identification.parameters import choose_parameters
from pincal.identification.problem import CalibrationProblem
from pincal.io.corrections_file import (
    Corrections,
    corrected_readings,
    corrections_dict,
    corrections_path,
    read_corrections,
)
from pincal.io.dataset_reader import read_dataset
from pincal.model.robot import robot_from_urdf_text
from pincal.study.simulation import random_actuated, simulate_observations

CORRECTIONS = ["*.sin1", "*.cos1", "*.sin2", "*.cos2", "*.compliance"]


@pytest.mark.parametrize(("name", "frame", "spec", "payload"), [
    ("ur10", "tool0", ["default", *CORRECTIONS], None),
    ("ur10", "tool0", ["default", *CORRECTIONS], Payload(6.0, "tool0", (0.0, 0.05, 0.1))),
    ("delta", "end_effector", ["model24", "*.sin1", "*.cos2"], None)])
def test_correction_columns_match_finite_differences(name: str, frame: str, spec: list[str],
                                                     payload: Payload | None) -> None:
    robot = pincal.load_robot(name)
    models = [ms.position(frame)]
    pset = choose_parameters(robot, models, spec)
    assert any(p.kind == "harmonic" for p in pset)
    rng = np.random.default_rng(1)
    qa, _ = random_actuated(robot, 5, rng)
    problem = CalibrationProblem(robot, pset, models, simulate_observations(robot, pset, np.zeros(len(pset)), models,
                                                                            qa, rng), payload=payload)
    x = rng.normal(size=len(pset)) * pset.scales
    jac = problem.evaluate(x).jacobian
    assert jac is not None
    fd = finite_difference_jacobian(problem, x)
    assert np.abs(jac - fd).max() <= 1e-6 * np.abs(jac).max()


def test_gravity_torques_need_a_tree_with_masses() -> None:
    ur10 = pincal.load_robot("ur10")
    torques = gravity_torques(ur10, np.zeros((1, 6)))
    assert abs(torques[0, 0]) < 1e-9 and abs(torques[0, 1]) > 10.0  # a vertical axis carries none, the shoulder does
    with pytest.raises(DataError, match="for trees only; robot 'delta' has loops"):
        gravity_torques(pincal.load_robot("delta"), np.zeros((1, 3)))
    assert ur10.source is not None
    massless = re.sub(r"<inertial>.*?</inertial>", "", ur10.source.read_text(), flags=re.S)
    with pytest.raises(DataError, match="carry no <inertial> mass"):
        gravity_torques(robot_from_urdf_text(massless), np.zeros((1, 6)))


def test_compliance_of_a_closed_loop_robot_is_refused_in_one_line(tmp_path: Path) -> None:
    sim = tmp_path / "sim"
    done = run_pincal("simulate", "delta", "--samples", "20", "--seed", "1", "--quiet", "--out", str(sim))
    assert done.returncode == 0, done.stderr
    done = run_pincal("calibrate", "delta", str(sim / "measurements.csv"), "--parameters", "model24", "*.compliance")
    assert done.returncode == 2 and done.stderr.count("\n") == 1
    assert "pincal computes for trees only" in done.stderr


def test_simulated_corrections_are_recovered_and_the_file_reproduces_the_predictions(tmp_path: Path) -> None:
    """UR10 with true harmonics and compliances: the geometric model cannot fit them; with the corrections the fit
    reaches the noise, and the calibrated URDF fed the corrected readings predicts the held-out postures exactly as
    the calibration reports."""
    sim = tmp_path / "sim"
    spec = ["default", "*.sin1", "*.cos1", "*.compliance"]
    assert run_pincal("simulate", "ur10", "--samples", "60", "--test-samples", "30", "--parameters", *spec,
                      "--seed", "3", "--quiet", "--out", str(sim)).returncode == 0
    assert (sim / "truth.corrections.json").is_file()
    data = sim / "measurements.csv"
    geometric = run_pincal("calibrate", "ur10", str(data), "--report", str(tmp_path / "g.json"))
    assert geometric.returncode == 0, geometric.stderr
    out, report = tmp_path / "cal.urdf", tmp_path / "r.json"
    done = run_pincal("calibrate", "ur10", str(data), "--parameters", *spec, "--out", str(out), "--report", str(report))
    assert done.returncode == 0, done.stderr
    assert f"wrote {tmp_path / 'cal.corrections.json'}" in done.stdout
    fitted, plain = json.loads(report.read_text()), json.loads((tmp_path / "g.json").read_text())
    assert fitted["test_rms_after"] < 3e-5 < 0.01 * plain["test_rms_after"]  # [m]: at the noise, not at millimetres
    truth = read_corrections(sim / "truth.corrections.json").joints
    found = read_corrections(tmp_path / "cal.corrections.json").joints
    for joint in ("shoulder_lift_joint", "elbow_joint"):  # loaded by gravity: their compliance is seen
        assert found[joint]["compliance"] == pytest.approx(truth[joint]["compliance"], rel=0.1)
        assert found[joint]["sin1"] == pytest.approx(truth[joint]["sin1"], abs=1e-4)  # [rad]
    nominal = pincal.load_robot("ur10")
    calibrated = pincal.load_robot(out)
    held = read_dataset(data, nominal.actuated_joints).of_set("test")
    readings = held.joints[:, [held.joint_names.index(j) for j in nominal.actuated_joints]]
    corrected = corrected_readings(read_corrections(tmp_path / "cal.corrections.json"), nominal, readings)
    points = np.array([calibrated.placement(calibrated.solve_fk(q), "tool0_marker").translation for q in corrected])
    errors = np.linalg.norm(points - held.measurements["position:tool0"], axis=1)
    assert float(np.sqrt(np.mean(errors**2))) == pytest.approx(fitted["test_rms_after"], rel=1e-6)
    raw = np.array([calibrated.placement(calibrated.solve_fk(q), "tool0_marker").translation for q in readings])
    assert float(np.sqrt(np.mean(np.linalg.norm(raw - held.measurements["position:tool0"], axis=1) ** 2))) > 1e-3


# --- a payload: the load the joints carry beside the links' ------------------------------------------------------
PAYLOAD = "8@tool0:0,0,0.15"  # [kg] on the flange, 15 cm out along its axis [m]
PAYLOAD_SPEC = ["default", "*.compliance"]


@pytest.fixture(scope="module")
def loaded_sim(tmp_path_factory: pytest.TempPathFactory) -> Path:
    """``pincal simulate ur10`` with true compliances, the arm carrying 8 kg on tool0: read-only for the tests."""
    sim = tmp_path_factory.mktemp("loaded")
    done = run_pincal("simulate", "ur10", "--samples", "40", "--test-samples", "20", "--parameters", *PAYLOAD_SPEC,
                      "--payload", PAYLOAD, "--seed", "3", "--quiet", "--out", str(sim))
    assert done.returncode == 0, done.stderr
    return sim


def test_a_compliance_under_a_payload_is_recovered_and_the_file_applies_it(tmp_path: Path, loaded_sim: Path) -> None:
    """UR10 carrying 8 kg: calibrated with that payload, the compliances come back and the fit reaches the noise;
    without it the fit stays at tenths of a millimetre, and the summary says the model misses an effect. The corrections
    file records the payload, and the calibrated URDF fed the readings it corrects predicts the held-out postures
    exactly as the calibration reports."""
    data = loaded_sim / "measurements.csv"
    truth = read_corrections(loaded_sim / "truth.corrections.json")
    assert truth.payload == Payload(8.0, "tool0", (0.0, 0.0, 0.15))
    unloaded = run_pincal("calibrate", "ur10", str(data), "--parameters", *PAYLOAD_SPEC, "--report",
                          str(tmp_path / "u.json"))
    # without the payload the compliances cannot explain the deflections, and the prior holds the placements that
    # could absorb them near the URDF: the fit stays far above the noise, and says so
    assert unloaded.returncode in (0, 1), unloaded.stdout + unloaded.stderr
    assert "THE FIT DOES NOT REACH THE STATED NOISE" in unloaded.stdout and "the model misses an effect" in \
        unloaded.stdout.replace("\n  ", " ").replace("  ", " "), unloaded.stdout
    out, report = tmp_path / "cal.urdf", tmp_path / "r.json"
    done = run_pincal("calibrate", "ur10", str(data), "--parameters", *PAYLOAD_SPEC, "--payload", PAYLOAD, "--out",
                      str(out), "--report", str(report))
    assert done.returncode == 0, done.stderr
    assert "payload 8 kg on tool0 at (0, 0, 0.15) m, in the gravity torque of the compliances" in done.stdout
    fitted, plain = json.loads(report.read_text()), json.loads((tmp_path / "u.json").read_text())
    assert fitted["payload"] == {"mass": 8.0, "frame": "tool0", "offset": [0.0, 0.0, 0.15]}
    assert fitted["test_rms_after"] < 3e-5 < 0.1 * plain["test_rms_after"]  # [m]: the noise, against 0.7 mm
    written = json.loads(corrections_path(out).read_text())
    assert written["payload"] == fitted["payload"]
    found = read_corrections(corrections_path(out))
    assert found.payload == truth.payload
    for joint in ("shoulder_lift_joint", "elbow_joint", "wrist_1_joint"):  # the payload makes wrist_1's seen too
        assert found.joints[joint]["compliance"] == pytest.approx(truth.joints[joint]["compliance"], rel=0.02)
    nominal, calibrated = pincal.load_robot("ur10"), pincal.load_robot(out)
    held = read_dataset(data, nominal.actuated_joints).of_set("test")
    readings = held.joints[:, [held.joint_names.index(j) for j in nominal.actuated_joints]]

    def rms_of(corrections: Corrections) -> float:
        corrected = corrected_readings(corrections, nominal, readings)
        points = np.array([calibrated.placement(calibrated.solve_fk(q), "tool0_marker").translation
                           for q in corrected])
        return float(np.sqrt(np.mean(np.linalg.norm(points - held.measurements["position:tool0"], axis=1) ** 2)))

    assert rms_of(found) == pytest.approx(fitted["test_rms_after"], rel=1e-6)
    assert rms_of(Corrections(found.robot, found.joints)) > 10 * fitted["test_rms_after"]  # the payload forgotten


def test_the_corrections_file_round_trips_its_payload(tmp_path: Path) -> None:
    ur10 = pincal.load_robot("ur10")
    corrections = Corrections("ur10", {"elbow_joint": {"compliance": 1e-4}}, Payload(2.5, "tool0", (0.1, 0.0, 0.0)))
    path = tmp_path / "c.corrections.json"
    path.write_text(json.dumps(corrections_dict(corrections, ur10, tmp_path)))
    assert read_corrections(path) == replace(corrections, nominal_urdf="ur10")  # a known robot by its name
    qa = np.array([0.1, -0.8, 1.2, -0.4, 0.3, 0.0])
    moved = corrected_readings(corrections, ur10, qa) - qa
    assert moved[2] == pytest.approx(1e-4 * gravity_torques(ur10, qa[None], corrections.payload)[0, 2], rel=1e-12)
    for bad, message in [({"mass": -1, "frame": "tool0"}, "payload mass -1 kg"),
                         ({"mass": 1}, "is not {mass = KG")]:
        content = json.loads(path.read_text())
        content["payload"] = bad
        path.write_text(json.dumps(content))
        with pytest.raises(DataError, match=re.escape(f"'{path}': payload")):
            read_corrections(path)
        with pytest.raises(DataError, match=re.escape(message)):
            read_corrections(path)


@pytest.mark.parametrize(("args", "message"), [
    (["--payload", "8@tool0"], "pincal: error: the payload (8 kg on tool0) enters only the joint compliances, and no "
                               "<joint>.compliance is among the parameters: add '*.compliance'"),
    (["--parameters", *PAYLOAD_SPEC, "--payload", "8@tool9"], "pincal: error: payload: frame 'tool9' does not exist "
                                                              "in robot 'ur10'; frames are: world, base_link"),
    (["--payload=-8@tool0"], "argument --payload: '-8@tool0': payload mass -8 kg: a mass is a finite number ≥ 0 [kg]"),
    (["--payload", "8kg@tool0"], "argument --payload: '8kg@tool0' is not MASS@FRAME or MASS@FRAME:X,Y,Z (kg; m in "
                                 "the frame)"),
    (["--payload", "8@tool0:0,0.1"], "'8@tool0:0,0.1' is not MASS@FRAME or MASS@FRAME:X,Y,Z"),
    (["--payload", "8"], "'8' is not MASS@FRAME"),
])
def test_a_payload_the_calibration_cannot_use_is_refused_in_one_line(loaded_sim: Path, args: list[str],
                                                                      message: str) -> None:
    done = run_pincal("calibrate", "ur10", str(loaded_sim / "measurements.csv"), *args)
    assert done.returncode == 2 and done.stderr.count("\n") == 1, done.stderr
    assert message in done.stderr


def test_the_nominal_urdf_is_found_beside_the_corrections_file(tmp_path: Path) -> None:
    """A corrections file names its nominal URDF relative to itself: read from any working directory, the path is
    resolved against the file's folder (a known robot's name stays a name)."""
    robot_file = tmp_path / "robot" / "r.urdf"
    robot_file.parent.mkdir()
    robot_file.write_text(pincal.robot_path("ur10").read_text(encoding="utf-8"), encoding="utf-8")
    ur10 = pincal.load_robot(robot_file)
    folder = tmp_path / "out"
    folder.mkdir()
    path = folder / "cal.corrections.json"
    corrections = Corrections("ur10", {"elbow_joint": {"sin1": 1e-4}})
    content = corrections_dict(corrections, ur10, folder)
    assert content["nominal_urdf"] == "../robot/r.urdf"
    path.write_text(json.dumps(content), encoding="utf-8")
    assert Path(read_corrections(path).nominal_urdf).resolve() == robot_file.resolve()
    path.write_text(json.dumps(corrections_dict(corrections, pincal.load_robot("ur10"), folder)), encoding="utf-8")
    assert read_corrections(path).nominal_urdf == "ur10"

