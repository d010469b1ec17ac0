"""Loading robots: the checks on the file, serial robots by name, and every shipped file as a tree."""

from __future__ import annotations

import json
from pathlib import Path

import numpy as np
import pinocchio as pin
import pytest
import yourdfpy
from conftest import ROBOTS, run_pincal
from mechanisms import crank_rocker_urdf, four_bar_urdf

import pincal
from pincal.model.measured_frame import frame_moves


def _write(tmp_path: Path, text: str, name: str = "robot.urdf") -> Path:
    path = tmp_path / name
    path.write_text(text)
    return path


def test_delta_structure(delta: pincal.Robot) -> None:
    assert [loop.name for loop in delta.loops] == ["leg_1_platform", "leg_2_platform", "leg_3_platform"]
    assert {loop.type for loop in delta.loops} == {"spherical"}
    assert delta.closure.rows == 9
    assert delta.is_closed_loop


@pytest.mark.parametrize(
    ("edit", "error", "message"),
    [
        (('predecessor link="rod_2"', 'predecessor link="rodd_2"'), pincal.LoopError,
         r"loop 'leg_2_platform' names link 'rodd_2'.*links are: base, arm_1"),
        (('type="spherical"', 'type="ball"'), pincal.LoopError,
         r"type 'ball'; valid types are: spherical, revolute, prismatic, fixed"),
        (('xyz="0.0 0.0 -0.48" rpy="0.0 0.0 0.0"/></predecessor>',
          'xyz="0.0 0.0 -0.47" rpy="0.0 0.0 0.0"/></predecessor>'), pincal.LoopError,
         r"loop 'leg_1_platform' does not close at the reference configuration"),
        (('<joint name="arm_3_joint"><hardwareInterface>', '<joint name="arm_4_joint"><hardwareInterface>'),
         pincal.LoopError, r"transmission 'arm_3_joint_transmission' names joint 'arm_4_joint', which does "
                           r"not exist; movable joints are: arm_1_joint"),
        (('successor link="platform"', 'successor link="rod_1"'), pincal.LoopError,
         r"loop 'leg_1_platform' joins link 'rod_1' to itself"),
        (('<loop name="leg_2_platform"', '<loop name="leg_1_platform"'), pincal.LoopError,
         r"duplicate loop name 'leg_1_platform'"),
        (('"rod_1"><origin xyz="0.0 0.0 -0.48"', '"rod_1"><origin xyz="0.0 zero -0.48"'), pincal.RobotFileError,
         r"loop 'leg_1_platform' predecessor origin xyz: '0.0 zero -0.48' is not 3 numbers"),
        (('"rod_1"><origin xyz="0.0 0.0 -0.48"', '"rod_1"><origin xyz="0.0 nan -0.48"'), pincal.RobotFileError,
         r"contains NaN"),
        (('<link name="rod_1_cross"', '<link name="rod_2"'), pincal.RobotFileError,
         r"duplicate link name 'rod_2'"),
        (('<predecessor link="rod_2"><origin xyz="0.0 0.0 -0.48" rpy="0.0 0.0 0.0"/></predecessor>', ''),
         pincal.LoopError,
         r"loop 'leg_2_platform' has no <predecessor> element"),
        (('<joint name="rod_1_roll"', '<joint name="rod_1_pitch"'), pincal.RobotFileError,
         r"duplicate joint name 'rod_1_pitch'"),
        (('"rod_1"><origin xyz="0.0 0.0 -0.48"', '"rod_1"><origin xyz="0.0 0.0 -1.3e154"'), pincal.LoopError,
         r"loop 'leg_1_platform' predecessor origin is beyond 10000 m"),
        (('<origin xyz="0.26 0.0 0.0"', '<origin xyz="260.0e3 0.0 0.0"'), pincal.RobotFileError,
         r"joint 'rod_1_pitch' origin xyz \[260000.*beyond 10000 m: a typo or a unit error"),
    ],
)
def test_malformed_files_name_the_culprit(tmp_path: Path, delta_text: str, edit: tuple[str, str],
                                          error: type, message: str) -> None:
    old, new = edit
    assert old in delta_text
    path = _write(tmp_path, delta_text.replace(old, new, 1))
    with pytest.raises(error, match=message) as caught:
        pincal.load_robot(path)
    assert caught.value.file == str(path)


def test_missing_transmission_reports_the_mobility(tmp_path: Path, delta_text: str) -> None:
    start = delta_text.index('<transmission name="arm_3_joint_transmission">')
    end = delta_text.index("</transmission>", start) + len("</transmission>")
    path = _write(tmp_path, delta_text[:start] + delta_text[end:])
    with pytest.raises(pincal.LoopError, match=r"mobility is 3 .* but 2 joints are actuated"):
        pincal.load_robot(path)


def test_transmission_on_a_fixed_joint_is_refused(tmp_path: Path, delta_text: str) -> None:
    text = delta_text.replace('<joint name="arm_3_joint"><hardwareInterface>',
                              '<joint name="end_effector_joint"><hardwareInterface>')
    with pytest.raises(pincal.LoopError, match="'end_effector_joint' of type 'fixed'"):
        pincal.load_robot(_write(tmp_path, text))


def test_joint_origin_with_nan_is_refused(tmp_path: Path, delta_text: str) -> None:
    text = delta_text.replace('rpy="0.0 1.08292', 'rpy="nan 1.08292', 1)
    assert text != delta_text
    with pytest.raises(pincal.RobotFileError, match=r"joint 'rod_1_pitch' origin rpy.*NaN"):
        pincal.load_robot(_write(tmp_path, text))


def test_not_a_urdf(tmp_path: Path) -> None:
    broken = _write(tmp_path, "<robot>\n<link name='a'>\n</robot>")
    with pytest.raises(pincal.RobotFileError, match="not well-formed XML") as caught:
        pincal.load_robot(broken)
    assert (caught.value.file, caught.value.line) == (str(broken), 3)  # the line the parser stopped at
    sdf = _write(tmp_path, "<sdf/>", "model.urdf")
    with pytest.raises(pincal.RobotFileError, match="root element is <sdf>") as caught:
        pincal.load_robot(sdf)
    assert (caught.value.file, caught.value.line) == (str(sdf), None)
    with pytest.raises(pincal.RobotFileError, match="does not exist") as caught:
        pincal.load_robot(tmp_path / "missing.urdf")
    assert caught.value.file == str(tmp_path / "missing.urdf")
    with pytest.raises(pincal.NotFoundError, match=r"known robots are: .*delta.*'pincal robots' lists them"):
        pincal.load_robot("no_such_robot")


@pytest.mark.parametrize(("name", "n_joints", "frame"), [("ur10", 6, "tool0"), ("panda", 8, "panda_hand")])
def test_example_robot_data_serial_robots(name: str, n_joints: int, frame: str) -> None:
    robot = pincal.load_robot(name)
    assert robot.source is not None and "example-robot-data" in str(robot.source)
    assert not robot.loops and robot.n_actuated == n_joints and robot.end_effector == frame
    rng = np.random.default_rng(0)
    q = pin.randomConfiguration(robot.model)
    assert robot.solve_fk(robot.actuated_values(q)) == pytest.approx(q, abs=1e-15)
    target = robot.placement(q, frame)
    q_ik = robot.solve_ik(target, q_guess=q + rng.normal(scale=0.05, size=q.size))
    err = pin.log6(target.actInv(robot.placement(q_ik, frame))).vector
    assert np.max(np.abs(err)) < 1e-10
    # serial Jacobian w.r.t. actuated joints equals Pinocchio's frame Jacobian
    data = robot.model.createData()
    expected = pin.computeFrameJacobian(robot.model, data, q, robot.frame_id(frame), pin.LOCAL_WORLD_ALIGNED)
    np.testing.assert_allclose(robot.frame_jacobian_actuated(q, frame), expected, atol=1e-12)


def test_unknown_frame_lists_frames(delta: pincal.Robot) -> None:
    with pytest.raises(pincal.NotFoundError, match=r"frame 'tcp' does not exist.*end_effector"):
        delta.placement(delta.q_reference, "tcp")


@pytest.mark.parametrize("path", sorted(ROBOTS.glob("*.urdf")), ids=lambda p: p.stem)
def test_shipped_files_load_as_trees_elsewhere(path: Path) -> None:
    model = pin.buildModelFromUrdf(str(path))
    tree = yourdfpy.URDF.load(str(path), load_meshes=False, build_scene_graph=False)
    assert len(tree.joint_map) == model.njoints - 1 + sum(
        1 for j in tree.joint_map.values() if j.type == "fixed")
    robot = pincal.load_robot(path)
    assert "end_effector" in [f.name for f in robot.model.frames]
    assert np.max(np.abs(robot.closure_residual(robot.q_reference)), initial=0.0) < 1e-9
    assert robot.mobility() == robot.n_actuated
    assert "<!--" in path.read_text()[:200], "each robot file starts with a comment block giving its source"


def test_a_failed_lookup_names_the_culprit_and_carries_the_choices(delta: pincal.Robot) -> None:
    """One wording for every lookup: the kind, the name, where, and what exists (kept on the error too)."""
    with pytest.raises(pincal.NotFoundError, match=r"^joint 'elbow' does not exist in robot 'delta'; joints are: "
                                                   r"arm_1_joint, rod_1_pitch") as caught:
        delta.joint_id("elbow")
    assert caught.value.kind == "joint" and caught.value.name == "elbow" and "arm_2_joint" in caught.value.choices
    with pytest.raises(pincal.NotFoundError, match=r"^frame 'tcp' does not exist in robot 'delta'") as caught:
        delta.frame_id("tcp")
    assert "end_effector" in caught.value.choices


# --- the default measured frame: one the actuated joints move -----------------------------------------------------
@pytest.mark.parametrize(("name", "frame"), [("delta", "end_effector"), ("five_bar", "end_effector"),
                                             ("hexapod", "end_effector"), ("hexapod_device", "end_effector"),
                                             ("ucr3", "end_effector"), ("ur3", "tool0"), ("ur5", "tool0"),
                                             ("ur10", "tool0"), ("panda", "panda_hand"), ("tiago", "arm_tool_link"),
                                             ("tiago_no_hand", "arm_tool_link")])
def test_robots_by_name_keep_their_measured_frames(name: str, frame: str) -> None:
    robot = pincal.load_robot(name)
    assert robot.end_effector == frame and robot.measured_frame_choice.rule == "named"
    assert frame_moves(robot, frame)


def test_without_an_end_effector_name_the_one_moving_end_is_measured(tmp_path: Path) -> None:
    """The file's last frame is a link fixed to the ground: it was once measured, before = after, nothing learnt."""
    robot = pincal.load_robot(_write(tmp_path, crank_rocker_urdf()))
    assert robot.model.frames[len(robot.model.frames) - 1].name == "stand"
    assert not frame_moves(robot, "stand") and not frame_moves(robot, "ground")
    assert all(frame_moves(robot, link) for link in ("crank", "coupler", "rocker"))
    assert robot.end_effector == "rocker" and robot.measured_frame_choice.rule == "moving end"
    assert robot.measured_frame_choice.candidates == ("rocker",)


def test_a_still_frame_named_like_an_end_effector_is_passed_over(tmp_path: Path) -> None:
    text = crank_rocker_urdf().replace('link name="stand"', 'link name="end_effector"').replace(
        '<child link="stand"/>', '<child link="end_effector"/>')
    robot = pincal.load_robot(_write(tmp_path, text))
    assert not frame_moves(robot, "end_effector")
    assert robot.end_effector == "rocker"


def test_several_moving_ends_are_refused_with_the_candidates(tmp_path: Path) -> None:
    """A four-bar cut at its coupler-rocker joint ends in two moving links: neither is the obvious one."""
    robot = pincal.load_robot(_write(tmp_path, four_bar_urdf()))
    with pytest.raises(pincal.NotFoundError, match=r"no frame named like an end effector.*2 moving links have no "
                                                   r"moving link below them: coupler, rocker.*--frame") as caught:
        _ = robot.end_effector
    assert caught.value.kind == "frame" and caught.value.choices == ["coupler", "rocker"]
    assert robot.measured_frame_choice.frame is None


def test_a_robot_whose_actuated_joints_move_nothing_has_no_default_frame(tmp_path: Path) -> None:
    text = crank_rocker_urdf().replace('type="revolute"><parent link="ground"/><child link="crank"/>',
                                       'type="fixed"><parent link="ground"/><child link="crank"/>')
    text = text.replace('<transmission name="crank_motor"><joint name="crank_joint"/></transmission>', "")
    text = text.replace(text[text.index("<loop"):text.index("</loop>") + len("</loop>")], "")
    robot = pincal.load_robot(_write(tmp_path, text))  # serial: coupler and rocker joints actuated, crank fixed
    assert robot.end_effector == "rocker"  # a serial chain: its moving end
    still = pincal.load_robot(_write(tmp_path, '<robot name="post"><link name="floor"/><link name="post"/>'
                                               '<joint name="j" type="fixed"><parent link="floor"/>'
                                               '<child link="post"/></joint></robot>', "post.urdf"))
    with pytest.raises(pincal.NotFoundError, match="move none of its links: there is no frame to measure"):
        _ = still.end_effector


def test_simulate_and_calibrate_a_four_bar_measure_a_moving_frame(tmp_path: Path) -> None:
    path = _write(tmp_path, crank_rocker_urdf(), "crank_rocker.urdf")
    sim = tmp_path / "sim"
    done = run_pincal("simulate", str(path), "--samples", "30", "--test-samples", "10", "--seed", "1", "--quiet",
                      "--out", str(sim))
    assert done.returncode == 0, done.stderr
    assert "warning" not in done.stderr
    header = next(line for line in (sim / "measurements.csv").read_text().splitlines() if line.startswith("sample,"))
    assert "position:rocker:x" in header and "stand" not in header
    report = tmp_path / "report.json"
    done = run_pincal("calibrate", str(path), str(sim / "measurements.csv"), "--report", str(report))
    assert done.returncode == 0, done.stdout + done.stderr
    data = json.loads(report.read_text())
    # errors of 1 mm / 1 mrad move the rocker by about 0.5 mm, which the fit removes (measuring the ground-fixed
    # stand, before = after and only the measurement frame's 3 directions were identifiable)
    assert data["rms_before"] > 1e-4 and data["test_rms_before"] > 1e-4
    assert data["rms_after"] < data["rms_before"] / 2 and data["test_rms_after"] < data["test_rms_before"] / 2
    assert data["n_identifiable"] > 6


def test_simulating_a_four_bar_without_an_obvious_frame_is_refused_in_one_line(tmp_path: Path) -> None:
    path = _write(tmp_path, four_bar_urdf(), "four_bar.urdf")
    done = run_pincal("simulate", str(path), "--samples", "5", "--quiet", "--out", str(tmp_path / "sim"))
    assert done.returncode == 2 and len(done.stderr.strip().splitlines()) == 1
    assert "coupler, rocker" in done.stderr and "--frame" in done.stderr and "Traceback" not in done.stderr
    done = run_pincal("simulate", str(path), "--samples", "5", "--frame", "coupler", "--quiet", "--out",
                      str(tmp_path / "sim"))
    assert done.returncode == 0, done.stderr


@pytest.mark.parametrize("name", ["delta", "five_bar", "hexapod", "ucr3"])
def test_the_batched_usability_check_finds_what_solving_each_sample_alone_finds(name: str) -> None:
    from pincal.model.assemblable import assemble, unusable_samples
    from pincal.study.simulation import random_actuated

    robot = pincal.load_robot(name)
    reachable, _ = random_actuated(robot, 20, np.random.default_rng(4))
    actuated = np.vstack([reachable, 4.0 * reachable[:4]])  # readings far beyond: some cannot be assembled
    found = unusable_samples(robot, actuated)
    assert found == list(assemble(robot, actuated, stacked=False).reasons.items())
    assert all(k >= 20 for k, _ in found)


@pytest.mark.parametrize("name", ["ur10", "tiago_no_hand"])  # tiago: two continuous wheel joints (cos, sin)
def test_a_trees_configurations_written_at_once_are_those_of_each_sample_alone(name: str) -> None:
    from pincal.model.assemblable import assemble

    robot = pincal.load_robot(name)
    rng = np.random.default_rng(5)
    actuated = rng.uniform(-1.0, 1.0, size=(30, robot.n_actuated))
    guesses = np.array([robot.solve_fk(a) for a in rng.uniform(-1.0, 1.0, size=(30, robot.n_actuated))])
    for start in (None, guesses):
        at_once, alone = assemble(robot, actuated, guesses=start), assemble(robot, actuated, guesses=start,
                                                                           stacked=False)
        assert np.array_equal(at_once.q, alone.q) and at_once.reasons == alone.reasons == {}
    with pytest.raises(pincal.DataError, match="NaN"):  # a reading that is not a number: refused as one sample alone is
        assemble(robot, np.vstack([actuated, np.full(robot.n_actuated, np.nan)]))


@pytest.mark.parametrize(("target", "error", "message"), [
    ([float("nan"), 0.0, 0.0], pincal.ArgumentError, r"^target=\[nan, 0\.0, 0\.0\]: must be 3 finite numbers \[m\]"),
    ([0.0, 0.0], pincal.ArgumentError, r"^target=\[0\.0, 0\.0\]: must be 3 numbers \[m\], not an array of shape "
                                       r"\(2,\)"),
    ((0.0, float("inf"), -0.5), pincal.ArgumentError, r"^target=\(0\.0, inf, -0\.5\): must be 3 finite numbers"),
    (None, TypeError, r"^target=None: expected 3 numbers, not NoneType"),
    ("0 0 -0.5", TypeError, r"^target='0 0 -0\.5': expected 3 numbers, not str"),
])
def test_solve_ik_names_a_target_it_cannot_take(delta: pincal.Robot, target: object, error: type[Exception],
                                                message: str) -> None:
    with pytest.raises(error, match=message):
        delta.solve_ik(target)  # type: ignore[arg-type]


def test_solve_ik_names_a_frame_or_tolerance_it_cannot_take(delta: pincal.Robot) -> None:
    goal = delta.placement(delta.q_reference, "end_effector")
    with pytest.raises(TypeError, match=r"^frame=5: expected a frame name \(str\), not int"):
        delta.solve_ik(goal.translation, frame=5)  # type: ignore[arg-type]
    with pytest.raises(pincal.ArgumentError, match=r"^tol=nan: must be a finite number > 0 \[m, rad\]"):
        delta.solve_ik(goal.translation, tol=float("nan"))
    broken = pin.SE3(goal.rotation, np.array([np.nan, 0.0, 0.0]))
    with pytest.raises(pincal.ArgumentError, match=r"^target=.*: the placement holds NaN or infinity"):
        delta.solve_ik(broken)
    q = delta.solve_ik(goal.translation)  # a good target still reached
    assert np.allclose(delta.placement(q, "end_effector").translation, goal.translation, atol=1e-10)
