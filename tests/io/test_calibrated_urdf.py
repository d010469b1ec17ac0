"""The calibrated URDF is the calibrated model: loading it and running forward kinematics reproduces every
measured quantity the model predicts, in the measurement frame (docs/calibrated_urdf.md).

"Reproduces" means, for raw actuated readings ``qa`` and the written file loaded back (``pincal.load_robot``;
for trees also plain Pinocchio), with ``q`` its forward kinematics at ``qa``:

- ``position:f``: the origin of frame ``f`` (of ``f_marker`` when a marker on ``f`` is calibrated) in the
  file's root frame; ``position:f@m``: the origin of ``f_marker_m``;
- ``pose:f``: the placement of ``f`` in the root frame;
- ``distance:a-b`` and ``distance_increment:a-b``: the distance between the two origins (increments are its
  differences, so they follow);
- ``joint:j``: ``q[j] + zero``, with ``zero`` read from the file's ``<joint_sensor joint="j" zero=.../>``.

The expected values are the calibration problem's own predictions for a parameter vector x — the model the
fit works with — so the property is about the writer: x is random (1 mm, 1 mrad), and the match must hold to
1e-9 (m, rad) on inputs drawn for the test.
"""

from __future__ import annotations

import json
import xml.etree.ElementTree as ET
from pathlib import Path

import numpy as np
import pinocchio as pin
import pytest
from conftest import run_pincal

import pincal
from pincal.calibration.campaign import simulate, write_simulation
from pincal.identification.measurements import Distance, JointReading, Measurement, Pose, Position, parse_key, position
from pincal.identification.parameters import ParameterSet, candidate_parameters, choose_parameters
from pincal.identification.problem import CalibrationProblem, Observations
from pincal.io.calibrated_urdf import (
    MEASUREMENT_FRAME,
    calibrated_robot_text,
    declared_markers,
    source_text,
    written_frame,
)
from pincal.io.dataset_reader import read_dataset
from pincal.model.robot import Robot
from pincal.study.simulation import perturbation, random_actuated

Array = np.ndarray
TOLERANCE = 1e-9  # [m, rad]
SAMPLES = 6

#: Per robot, the measurement kinds that apply: external (position, pose: the default set then includes the
#: measurement frame ``base.*``), internal (distances between two of its frames, absolute and incremental),
#: and joint readings of instrumented passive joints.
CASES = [
    ("delta", ["position:end_effector", "pose:end_effector", "joint:rod_1_pitch"]),
    ("delta", ["distance:end_effector-base", "distance_increment:end_effector-arm_1"]),
    ("hexapod", ["position:end_effector", "pose:platform"]),
    ("hexapod", ["distance:end_effector-base", "distance_increment:platform-base"]),
    ("hexapod_device", ["pose:end_effector", "joint:device_lvdt", "joint:device_incl_x", "joint:device_incl_y",
                        "joint:device_rotary"]),
    ("hexapod_device", ["joint:device_lvdt", "joint:device_incl_x", "joint:device_incl_y"]),
    ("five_bar", ["position:end_effector", "pose:end_effector"]),
    ("five_bar", ["distance_increment:base_link-end_effector", "distance:proximal_1-platform", "joint:scale_joint"]),
    ("ucr3", ["position:end_effector", "pose:end_effector"]),
    ("ucr3", ["distance:end_effector-base_link", "distance_increment:end_effector-base_link"]),
    ("ur10", ["position:tool0", "pose:tool0"]),
    ("ur10", ["distance:tool0-base_link", "distance_increment:tool0-world"]),
    ("panda", ["position:panda_hand_tcp", "pose:panda_hand"]),
    ("panda", ["distance:panda_hand_tcp-panda_link0", "distance_increment:panda_hand-panda_link0"]),
    ("panda", ["position:panda_rightfinger", "pose:panda_leftfinger"]),  # the right finger's joint is a <mimic>
]


def _blank(m: Measurement, n: int) -> Array:
    values = np.zeros((n, 7 if isinstance(m, Pose) else m.size))
    if isinstance(m, Pose):
        values[:, 6] = 1.0  # identity quaternion: the prediction is then log3 of the absolute rotation
    return values


def _predictions(robot: Robot, pset: ParameterSet, models: list[Measurement], x: Array, qa: Array
                 ) -> dict[str, Array]:
    """The calibration model's absolute predictions at ``x`` (pose: position, log3 of the rotation)."""
    obs = Observations(qa, {m.key: _blank(m, qa.shape[0]) for m in models})
    return CalibrationProblem(robot, pset, models, obs).evaluate(x, jacobian=False).predicted


def _sensor_zeros(text: str) -> dict[str, float]:
    return {node.get("joint", ""): float(node.get("zero", "nan")) for node in ET.fromstring(text).iter("joint_sensor")}


def _point_frame(m: Measurement, frame: str, pset: ParameterSet) -> str:
    if isinstance(m, Position) and m.marker:
        return f"{frame}_marker_{m.marker}"
    marked = any(p.kind == "marker" and p.owner == frame for p in pset)
    return f"{frame}_marker" if marked and not isinstance(m, Pose) else frame


def _file_values(model: pin.Model, q: Array, m: Measurement, pset: ParameterSet, zeros: dict[str, float]) -> Array:
    """What measurement ``m`` reads on the written file's model at configuration ``q``."""
    data = model.createData()
    pin.framesForwardKinematics(model, data, q)

    def placement(frame: str) -> pin.SE3:
        assert model.existFrame(frame), frame
        return data.oMf[model.getFrameId(frame)]

    if isinstance(m, Pose):
        p = placement(m.frame)
        return np.concatenate([p.translation, pin.log3(p.rotation)])
    if isinstance(m, Position):
        return placement(_point_frame(m, m.frame, pset)).translation.copy()
    if isinstance(m, Distance):
        a = placement(_point_frame(m, m.frame_a, pset)).translation
        b = placement(_point_frame(m, m.frame_b, pset)).translation
        return np.array([np.linalg.norm(a - b)])
    assert isinstance(m, JointReading)
    jm = model.joints[model.getJointId(m.joint)]
    return np.array([q[jm.idx_q] + zeros[m.joint]])


def _gap(m: Measurement, got: Array, expected: Array) -> float:
    if isinstance(m, Pose):  # compare rotations, not their logs (the same near ±π)
        rotation = float(np.abs(pin.exp3(got[3:]) - pin.exp3(expected[3:])).max())
        return max(float(np.abs(got[:3] - expected[:3]).max()), rotation)
    return float(np.abs(got - expected).max())


def _tree_configuration(model: pin.Model, robot: Robot, qa: Array) -> Array:
    """A plain Pinocchio configuration with the actuated joints at ``qa``."""
    q = pin.neutral(model)
    for joint, value in zip(robot.actuated_joints, qa, strict=True):
        jm = model.joints[model.getJointId(joint)]
        if jm.nq == 1:
            q[jm.idx_q] = value
        else:
            q[jm.idx_q:jm.idx_q + 2] = [np.cos(value), np.sin(value)]
    return q


def _worst_gap(robot: Robot, pset: ParameterSet, models: list[Measurement], x: Array, path: Path,
               seed: int = 1) -> float:
    """Largest gap between the model's predictions at ``x`` and the file at ``path``, over fresh inputs (drawn
    where the calibrated robot assembles: near its workspace's edge, the nominal robot's may not)."""
    written = pincal.load_robot(path)
    qa, _ = random_actuated(written, SAMPLES, np.random.default_rng(seed))
    expected = _predictions(robot, pset, models, x, qa)
    text = path.read_text(encoding="utf-8")
    zeros = _sensor_zeros(text)
    plain = pin.buildModelFromUrdf(str(path), mimic=True) if not robot.loops else None
    worst = 0.0
    for k in range(SAMPLES):
        q = written.solve_fk(qa[k], tol=1e-13)  # the file takes the raw readings
        for m in models:
            worst = max(worst, _gap(m, _file_values(written.model, q, m, pset, zeros), expected[m.key][k]))
            if plain is not None:
                q_plain = _tree_configuration(plain, robot, qa[k])
                worst = max(worst, _gap(m, _file_values(plain, q_plain, m, pset, zeros), expected[m.key][k]))
    return worst


def _roots(text: str) -> set[str]:
    tree = ET.fromstring(text)
    return {link.get("name", "") for link in tree.iter("link")} - {c.get("link", "") for c in tree.iter("child")}


def _write(robot: Robot, pset: ParameterSet, x: Array, models: list[Measurement], path: Path) -> str:
    read = [m.joint for m in models if isinstance(m, JointReading)]
    text, _ = calibrated_robot_text(robot, source_text(robot), pset, x, note="test", read_joints=read,
                                    markers=declared_markers(models))
    path.write_text(text, encoding="utf-8")
    return text


@pytest.mark.parametrize(("name", "keys"), CASES, ids=[f"{n}-{'+'.join(k.split(':')[0] for k in keys)}"
                                                       for n, keys in CASES])
def test_the_file_reproduces_every_measured_quantity(name: str, keys: list[str], tmp_path: Path) -> None:
    robot = pincal.load_robot(name)
    models = [parse_key(k) for k in keys]
    pset = choose_parameters(robot, models)  # the default set: every candidate
    kinds = {p.kind for p in pset}
    external = any(isinstance(m, (Position, Pose)) for m in models)
    assert ("base" in kinds) == external and "offset" in kinds and ("anchor" in kinds) == bool(robot.loops)
    read = [m.joint for m in models if isinstance(m, JointReading)]
    assert all(f"{j}.offset" in pset for j in read)  # read passive joints' offsets are estimated too
    x = perturbation(pset, 1e-3, np.random.default_rng(0))
    text = _write(robot, pset, x, models, tmp_path / "cal.urdf")
    assert _worst_gap(robot, pset, models, x, tmp_path / "cal.urdf") <= TOLERANCE
    assert set(_sensor_zeros(text)) == set(read)
    assert _roots(text) == ({MEASUREMENT_FRAME} if external else _roots(source_text(robot)))


@pytest.mark.parametrize("name", ["delta", "ur10"])
def test_the_measurement_frame_is_the_root_and_matters(name: str, tmp_path: Path) -> None:
    """The base placement is in the file (the robot alone misses the measurements by about a millimetre), the
    robot's own names survive, and deleting the two added elements gives the robot in its own base frame."""
    robot = pincal.load_robot(name)
    frame = robot.end_effector
    models = [parse_key(f"position:{frame}")]
    pset = choose_parameters(robot, models)
    x = perturbation(pset, 1e-3, np.random.default_rng(2))
    text = _write(robot, pset, x, models, tmp_path / "cal.urdf")
    source = ET.fromstring(source_text(robot))
    tree = ET.fromstring(text)
    for tag in ("link", "joint", "loop", "transmission"):
        names = [e.get("name") for e in source.findall(tag)]
        assert set(names) <= {e.get("name") for e in tree.findall(tag)}, tag
    assert len(tree.findall("link/visual")) == len(source.findall("link/visual"))
    (old_root,) = _roots(source_text(robot))
    joint = tree.find(f"joint[@name='{MEASUREMENT_FRAME}_joint']")
    assert joint is not None and joint.get("type") == "fixed"
    assert joint.find(f"parent[@link='{MEASUREMENT_FRAME}']") is not None
    assert joint.find(f"child[@link='{old_root}']") is not None

    qa, _ = random_actuated(robot, SAMPLES, np.random.default_rng(3))
    expected = _predictions(robot, pset, models, x, qa)[models[0].key]
    base = pin.exp6(pset.placement_delta(x, pset.groups("base")[("base", "base", "")]))
    written = pincal.load_robot(tmp_path / "cal.urdf")
    frame_link = tree.find(f"link[@name='{MEASUREMENT_FRAME}']")
    assert frame_link is not None
    tree.remove(frame_link)  # the robot's base as the reference: drop the measurement frame and its joint
    tree.remove(joint)
    (tmp_path / "robot_frame.urdf").write_text(ET.tostring(tree, encoding="unicode"), encoding="utf-8")
    robot_frame = pincal.load_robot(tmp_path / "robot_frame.urdf")
    point = written_frame(models[0], frame, pset)  # the default set calibrates a marker: the point is its link
    assert point == f"{frame}_marker"
    gaps = []
    for k in range(SAMPLES):
        in_tracker = written.placement(written.solve_fk(qa[k], tol=1e-13), point).translation
        in_base = robot_frame.placement(robot_frame.solve_fk(qa[k], tol=1e-13), point).translation
        np.testing.assert_allclose(in_tracker, expected[k], atol=TOLERANCE, rtol=0)
        np.testing.assert_allclose(in_base, base.actInv(expected[k]), atol=TOLERANCE, rtol=0)
        gaps.append(float(np.linalg.norm(in_base - expected[k])))
    assert min(gaps) > 1e-4  # dropping the measurement frame would be a millimetre-scale error


@pytest.mark.parametrize(("name", "keys"), [("delta", ["position:end_effector", "distance:end_effector-rod_1"]),
                                            ("ur10", ["position:tool0", "position:wrist_3_joint", "pose:tool0"])])
def test_markers_become_frames_named_after_their_measurement(name: str, keys: list[str], tmp_path: Path) -> None:
    robot = pincal.load_robot(name)
    models = [parse_key(k) for k in keys]
    frames = sorted({f for m in models for f in m.frames})
    pset = candidate_parameters(robot, frames=frames, base=True, markers=True)
    x = perturbation(pset, 1e-3, np.random.default_rng(4))
    text = _write(robot, pset, x, models, tmp_path / "cal.urdf")
    links = {link.get("name") for link in ET.fromstring(text).findall("link")}
    assert {f"{f}_marker" for f in frames} <= links
    assert _worst_gap(robot, pset, models, x, tmp_path / "cal.urdf") <= TOLERANCE


@pytest.mark.parametrize("fit", ["each", "cluster"])
@pytest.mark.parametrize(("name", "frame"), [("delta", "end_effector"), ("ur10", "tool0")])
def test_declared_markers_become_links_at_their_calibrated_points(name: str, frame: str, fit: str,
                                                                   tmp_path: Path) -> None:
    """Markers m1, m2 declared on a frame at nominal offsets, fitted each or as a cluster, and m3 known (its
    offset given, no parameter): each is a link ``<frame>_marker_<m>`` by a fixed joint, and the file reproduces
    every marker's predicted position; a recalibration moves the same links."""
    robot = pincal.load_robot(name)
    models: list[Measurement] = [position(frame, marker="m1", nominal=(0.05, 0.0, 0.02)),
                                 position(frame, marker="m2", nominal=(-0.03, 0.04, 0.0)),
                                 position(frame, marker="m3", nominal=(0.0, -0.02, 0.06))]
    pset = choose_parameters(robot, models, ["default", f"!marker.{frame}@m3.*"] if fit == "each" else None, fit)
    assert not any(p.owner == f"{frame}@m3" for p in pset)
    assert ("cluster" in {p.kind for p in pset}) == (fit == "cluster")
    for step, path in enumerate((tmp_path / "cal.urdf", tmp_path / "again.urdf")):
        x = perturbation(pset, 1e-2, np.random.default_rng(6 + step))  # 1 cm, 10 mrad
        text = _write(robot, pset, x, models, path)
        tree = ET.fromstring(text)
        links = [link.get("name") for link in tree.findall("link")]
        for marker in ("m1", "m2", "m3"):
            assert links.count(f"{frame}_marker_{marker}") == 1
            joint = tree.find(f"joint[@name='{frame}_marker_{marker}_joint']")
            assert joint is not None and joint.get("type") == "fixed"
            assert written_frame(models[0], frame, pset) == f"{frame}_marker_m1"
        assert _worst_gap(robot, pset, models, x, path) <= TOLERANCE
        robot = pincal.load_robot(path)  # recalibrated: the marker joints get the new points, none is added


@pytest.mark.parametrize(("name", "keys"), [("delta", ["position:end_effector", "joint:rod_1_pitch"]),
                                            ("ur10", ["position:tool0", "pose:tool0"])])
def test_recalibrating_a_calibrated_file(name: str, keys: list[str], tmp_path: Path) -> None:
    """A calibrated file calibrated again: the new measurement frame is composed into its root joint, the
    marker and the joint sensor get their new values, and nothing is added twice."""
    models = [parse_key(k) for k in keys]
    frames = sorted({f for m in models for f in m.frames})
    read = [m.joint for m in models if isinstance(m, JointReading)]
    path = tmp_path / "first.urdf"
    for step, robot in enumerate((pincal.load_robot(name), None)):
        robot = robot or pincal.load_robot(path)
        pset = candidate_parameters(robot, frames=frames, base=True, markers=True,
                                    offsets=list(robot.actuated_joints) + read)
        x = perturbation(pset, 1e-3, np.random.default_rng(5 + step))
        out = tmp_path / ("first.urdf" if step == 0 else "second.urdf")
        text = _write(robot, pset, x, models, out)
        assert _worst_gap(robot, pset, models, x, out) <= TOLERANCE
    tree = ET.fromstring(text)
    assert [link.get("name") for link in tree.findall("link")].count(MEASUREMENT_FRAME) == 1
    assert len(tree.findall("joint_sensor")) == len(read)


def test_mesh_names_are_the_sources() -> None:
    """The calibrated text names its meshes as the source does: where the file is written decides their names
    there (pincal.io.mesh_files, tests/io/test_mesh_files.py)."""
    robot = pincal.load_robot("ur10")
    pset = choose_parameters(robot, [parse_key("position:tool0")])
    text, _ = calibrated_robot_text(robot, source_text(robot), pset, np.full(len(pset), 1e-3))
    names = [mesh.get("filename", "") for mesh in ET.fromstring(text).iter("mesh")]
    assert names == [mesh.get("filename", "") for mesh in ET.fromstring(source_text(robot)).iter("mesh")]
    assert len(names) == 14 and all(n.startswith("package://example-robot-data/") for n in names)


@pytest.mark.parametrize(("name", "kinds"), [
    ("delta", ["position"]),
    ("hexapod", ["pose"]),
    ("hexapod_device", ["pose", "joint:device_lvdt", "joint:device_incl_x", "joint:device_incl_y"]),
    ("five_bar", ["distance_increment:base_link-end_effector", "joint:scale_joint"]),
    ("ur10", ["position", "pose"]),
    ("ur10", ["position:tool0@m1", "position:tool0@m2", "position:wrist_3_link@m1"]),
])
def test_simulated_truth_reproduces_its_measurements(name: str, kinds: list[str], tmp_path: Path) -> None:
    """``truth.urdf`` of a noise-free simulation reproduces ``measurements.csv``: positions and poses in its root
    (the measurement frame), distances, and joint readings through its ``<joint_sensor>`` zeros."""
    robot = pincal.load_robot(name)
    sim = simulate(robot, kinds, 6, 2, noise=0.0, seed=3)
    write_simulation(sim, tmp_path)
    truth = pincal.load_robot(tmp_path / "truth.urdf")
    zeros = _sensor_zeros((tmp_path / "truth.urdf").read_text(encoding="utf-8"))
    assert json.loads((tmp_path / "truth.json").read_text())["joint_sensor_zeros"] == pytest.approx(zeros, abs=0)
    data = read_dataset(tmp_path / "measurements.csv", robot.actuated_joints)
    columns = [data.joint_names.index(j) for j in robot.actuated_joints]
    for k in range(data.n_samples):
        q = truth.solve_fk(data.joints[k, columns], tol=1e-13)
        for m in sim.measurements:
            got = _file_values(truth.model, q, m, sim.parameters, zeros)
            if isinstance(m, JointReading):
                assert abs(got[0] - data.joints[k, data.joint_names.index(m.joint)]) <= TOLERANCE
            elif isinstance(m, Pose):
                measured = data.measurements[m.key][k]
                rotation = pin.Quaternion(measured[6], *measured[3:6]).matrix()
                assert np.abs(got[:3] - measured[:3]).max() <= TOLERANCE
                assert np.abs(pin.exp3(got[3:]) - rotation).max() <= TOLERANCE
            elif m.incremental:
                if k > 0:
                    previous = _file_values(truth.model, truth.solve_fk(data.joints[k - 1, columns], tol=1e-13), m,
                                            sim.parameters, zeros)
                    assert abs(got[0] - previous[0] - data.measurements[m.key][k, 0]) <= TOLERANCE
            else:
                assert np.abs(got - data.measurements[m.key][k]).max() <= TOLERANCE


@pytest.mark.parametrize(("name", "kinds", "samples"), [("delta", ["position"], "40"),
                                                        ("ur10", ["position", "pose"], "20")])
def test_simulate_then_calibrate_reproduces_the_truth(name: str, kinds: list[str], samples: str,
                                                      tmp_path: Path) -> None:
    """Noise-free ``pincal simulate`` then ``pincal calibrate``: on the held-out postures, the calibrated file
    predicts what the true file predicts, in the measurement frame (whatever the parameters it chose among the
    ones the data cannot tell apart)."""
    sim = run_pincal("simulate", name, "--samples", samples, "--test-samples", "10", "--measure", *kinds,
                  "--noise", "0", "--seed", "1", "--out", str(tmp_path / "sim"), "--quiet")
    assert sim.returncode == 0, sim.stderr
    cal = run_pincal("calibrate", name, str(tmp_path / "sim" / "measurements.csv"), "--out", str(tmp_path / "cal.urdf"))
    assert cal.returncode in (0, 1), cal.stderr  # 1: the iteration limit; the file is written either way
    truth, calibrated = pincal.load_robot(tmp_path / "sim" / "truth.urdf"), pincal.load_robot(tmp_path / "cal.urdf")
    data = read_dataset(tmp_path / "sim" / "measurements.csv", truth.actuated_joints).of_set("test")
    # the point measured: a position reads the marker link both files carry (the truth's marker and the calibrated
    # one); a pose reads the frame itself
    frame = truth.end_effector if "pose" in kinds else f"{truth.end_effector}_marker"
    worst = [0.0, 0.0]
    for qa in data.joints[:, [data.joint_names.index(j) for j in truth.actuated_joints]]:
        a = truth.placement(truth.solve_fk(qa, tol=1e-13), frame)
        b = calibrated.placement(calibrated.solve_fk(qa, tol=1e-13), frame)
        worst[0] = max(worst[0], float(np.abs(a.translation - b.translation).max()))
        worst[1] = max(worst[1], float(np.linalg.norm(pin.log3(a.rotation.T @ b.rotation))))
    assert worst[0] <= 1e-7  # [m]
    if "pose" in kinds:
        assert worst[1] <= 1e-7  # [rad]


@pytest.mark.parametrize(("key", "camera_link", "seen_link"), [
    ("camera:tool0", "tool0_camera", "camera_target"),
    ("camera_point:tool0", "tool0_camera", "camera_target"),
    ("pose:tool0@tag", MEASUREMENT_FRAME, "tool0_target_tag"),
])
def test_cameras_and_targets_are_links_that_reproduce_the_calibrated_readings(key: str, camera_link: str,
                                                                             seen_link: str) -> None:
    """The camera's link and the link it sees, at the raw readings, give the calibrated model's prediction of the
    camera reading to 1e-9 (the camera 12 cm and 2 rad from the identity, the target 1 m away)."""
    robot = pincal.load_robot("ur10")
    model = parse_key(key)
    pset = choose_parameters(robot, [model])
    rng = np.random.default_rng(11)
    x = perturbation(pset, 1e-3, rng)
    far = {"camera.tool0.tz": 0.12, "camera.tool0.ry": -2.0, "target.tx": 1.0, "target.rz": 0.7, "base.tx": 2.0,
           "base.rz": 1.2, "target.tool0@tag.ty": 0.05, "target.tool0@tag.rx": 1.1}
    for name, value in far.items():
        if name in pset:
            x[pset.index(name)] = value
    qa, _ = random_actuated(robot, 5, rng)
    values = {key: np.tile([0, 0, 0, 0, 0, 0, 1.0][:len(model.columns)], (5, 1))}
    predicted = CalibrationProblem(robot, pset, [model], Observations(qa, values)).evaluate(x, jacobian=False)
    text, _ = calibrated_robot_text(robot, source_text(robot), pset, x)
    tree = ET.fromstring(text)
    assert tree.find(f"link[@name='{seen_link}']") is not None
    loaded = pin.buildModelFromXML(text)
    data = loaded.createData()
    for k in range(5):
        q = pin.neutral(loaded)
        for j, name in enumerate(robot.actuated_joints):
            q[loaded.joints[loaded.getJointId(name)].idx_q] = qa[k, j]
        pin.framesForwardKinematics(loaded, data, q)
        seen = data.oMf[loaded.getFrameId(camera_link)].inverse() * data.oMf[loaded.getFrameId(seen_link)]
        expected = predicted.predicted[key][k]
        assert np.allclose(seen.translation, expected[:3], atol=1e-9)
        if len(expected) == 6:
            assert np.allclose(pin.log3(seen.rotation), expected[3:], atol=1e-9)
