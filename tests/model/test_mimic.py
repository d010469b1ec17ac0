"""``<mimic>`` joints: a follower moves with its leader (Panda's fingers), in the model, its derivatives, the
calibrated URDF and the command line; where pincal does not support them, the file is refused by name."""

from __future__ import annotations

from pathlib import Path

import numpy as np
import pinocchio as pin
import pytest
from conftest import ROBOTS, finite_difference_jacobian, run_pincal

import pincal
from pincal.identification import measurements as ms
from pincal.identification.parameters import choose_parameters
from pincal.identification.problem import CalibrationProblem
from pincal.io.dataset_reader import read_dataset
from pincal.study.simulation import random_actuated, simulate_observations

FINGERS = ["position:panda_rightfinger", "position:panda_leftfinger"]


def test_a_follower_is_not_actuated_and_moves_with_its_leader() -> None:
    panda = pincal.load_robot("panda")
    assert "panda_finger_joint1" in panda.actuated_joints and "panda_finger_joint2" not in panda.actuated_joints
    for opening in (0.0, 0.01, 0.04):
        qa = np.zeros(panda.n_actuated)
        qa[panda.actuated_joints.index("panda_finger_joint1")] = opening
        q = panda.solve_fk(qa)
        left = panda.placement(q, "panda_leftfinger").translation
        right = panda.placement(q, "panda_rightfinger").translation
        assert np.linalg.norm(left - right) == pytest.approx(2 * opening, abs=1e-12)  # both fingers open


def test_parameter_jacobian_through_a_follower_matches_finite_differences() -> None:
    panda = pincal.load_robot("panda")
    models = [ms.pose("panda_rightfinger"), ms.position("panda_leftfinger")]
    pool = choose_parameters(panda, models)
    assert {"panda_finger_joint2.tx", "panda_finger_joint1.offset"} <= set(pool.names)
    rng = np.random.default_rng(1)
    qa, _ = random_actuated(panda, 4, rng)
    problem = CalibrationProblem(panda, pool, models, simulate_observations(panda, pool, np.zeros(len(pool)),
                                                                            models, qa, rng))
    x = rng.normal(scale=1e-3, size=len(pool))
    jac = problem.evaluate(x).jacobian
    assert jac is not None
    fd = finite_difference_jacobian(problem, x)
    assert np.abs(jac - fd).max() <= 1e-7 * np.abs(jac).max()


def test_fingers_calibrate_through_the_cli_and_the_file_keeps_the_follower(tmp_path: Path) -> None:
    sim = tmp_path / "sim"
    done = run_pincal("simulate", "panda", "--samples", "40", "--test-samples", "10", "--measure", *FINGERS,
                      "--seed", "2", "--quiet", "--out", str(sim))
    assert done.returncode == 0, done.stderr
    data = read_dataset(sim / "measurements.csv")
    assert "panda_finger_joint1" in data.joint_names and "panda_finger_joint2" not in data.joint_names
    done = run_pincal("calibrate", "panda", str(sim / "measurements.csv"), "--out", str(tmp_path / "cal.urdf"))
    assert done.returncode == 0, done.stderr
    held_out = next(line for line in done.stdout.splitlines() if line.startswith("RMS position error (held out)"))
    before, after = (float(v) for v in held_out.split()[-4::2])
    assert after < 0.05 and before > 50 * after  # [mm]
    text = (tmp_path / "cal.urdf").read_text()
    assert '<mimic joint="panda_finger_joint1"' in text
    assert "panda_finger_joint2" not in pincal.load_robot(tmp_path / "cal.urdf").actuated_joints
    assert pin.buildModelFromUrdf(str(tmp_path / "cal.urdf"), mimic=True).nv == 8


@pytest.mark.parametrize(("edit", "message"), [
    ('<mimic joint="panda_finger_joint1"/>', "follows 'no_such_joint', which is not a revolute, continuous or "
                                             "prismatic joint of the file"),
    ('<mimic joint="panda_finger_joint1"/>', "multiplier: 'two' is not 1 numbers"),
])
def test_a_bad_mimic_is_named(tmp_path: Path, edit: str, message: str) -> None:
    text = pincal.robot_path("panda").read_text()
    assert edit in text
    bad = edit.replace('"/>', '" multiplier="two"/>') if "multiplier" in message else \
        edit.replace("panda_finger_joint1", "no_such_joint")
    path = tmp_path / "panda.urdf"
    path.write_text(text.replace(edit, bad))
    with pytest.raises(pincal.RobotFileError, match=f"joint 'panda_finger_joint2' <mimic>.*{message}"):
        pincal.load_robot(path)


def test_a_mimic_in_a_closed_loop_robot_is_refused_by_name(tmp_path: Path) -> None:
    text = (ROBOTS / "five_bar.urdf").read_text()
    start = text.index('<joint name="distal_2_joint"')
    end = text.index("</joint>", start)
    path = tmp_path / "five_bar_mimic.urdf"
    path.write_text(text[:end] + '<mimic joint="distal_1_joint"/>' + text[end:])
    done = run_pincal("info", str(path))
    assert done.returncode == 2 and "Traceback" not in done.stderr
    assert "joint distal_2_joint has a <mimic> element; pincal supports mimic joints in serial robots only" \
        in done.stderr


def test_a_transmission_on_a_mimic_joint_is_ignored_with_a_note(tmp_path: Path) -> None:
    text = pincal.robot_path("panda").read_text()
    transmission = ('<transmission name="t"><type>transmission_interface/SimpleTransmission</type>'
                    '<joint name="panda_finger_joint2"/></transmission></robot>')
    path = tmp_path / "panda.urdf"
    path.write_text(text.replace("</robot>", transmission))
    done = run_pincal("info", str(path))
    assert done.returncode == 0, done.stderr
    assert "note: joint 'panda_finger_joint2' has both a <transmission> and a <mimic> element: ignored" in done.stdout
    assert "panda_finger_joint2" not in pincal.load_robot(path).actuated_joints


TALOS_FINGERS = ["gripper_left_inner_double_joint", "gripper_left_fingertip_1_joint", "gripper_left_fingertip_2_joint",
                 "gripper_left_motor_single_joint", "gripper_left_inner_single_joint",
                 "gripper_left_fingertip_3_joint"]


def test_talos_fingers_sorted_before_their_leader_follow_it() -> None:
    by_name = pincal.load_robot("talos")
    by_path = pincal.load_robot(str(pincal.robot_path("talos")))
    assert by_name.model.nq == by_path.model.nq == 32  # 44 joints, 12 of them finger followers
    assert not set(TALOS_FINGERS) & set(by_name.actuated_joints) and "gripper_left_joint" in by_name.actuated_joints
    text = pincal.robot_path("talos").read_text()
    free = pin.buildModelFromXML(text)  # every joint free, in Pinocchio's order (the fingers before their motor)
    assert free.getJointId("gripper_left_fingertip_1_joint") < free.getJointId("gripper_left_joint")
    qa = np.zeros(by_name.n_actuated)
    qa[by_name.actuated_joints.index("gripper_left_joint")] = -0.5
    q = by_name.solve_fk(qa)
    q_free = pin.neutral(free)
    for joint, sign in [("gripper_left_joint", 1.0), *((f, 1.0 if f == TALOS_FINGERS[0] else -1.0)
                                                        for f in TALOS_FINGERS)]:
        q_free[free.idx_qs[free.getJointId(joint)]] = -0.5 * sign  # the file's multipliers: +1 once, -1 else
    data = free.createData()
    pin.framesForwardKinematics(free, data, q_free)
    for link in ("gripper_left_fingertip_1_link", "gripper_left_fingertip_3_link", "gripper_left_motor_double_link"):
        expected = data.oMf[free.getFrameId(link)].translation
        assert np.abs(by_name.placement(q, link).translation - expected).max() <= 1e-12


def test_a_fixed_joint_mimic_is_ignored() -> None:
    reduced = pincal.load_robot(pincal.robot_path("talos").with_name("talos_reduced.urdf"))
    assert reduced.model.nq == 32 and "gripper_left_inner_double_joint" not in list(reduced.model.names)
    assert "the <mimic> of fixed joint 'gripper_left_inner_double_joint' is ignored: a fixed joint does not move" \
        in reduced.notes


def test_talos_gripper_calibrates_through_the_cli(tmp_path: Path) -> None:
    sim = tmp_path / "sim"
    frame = "gripper_left_fingertip_1_link"
    done = run_pincal("simulate", "talos", "--samples", "40", "--test-samples", "10", "--measure", "position",
                      "--frame", frame, "--seed", "1", "--quiet", "--out", str(sim))
    assert done.returncode == 0, done.stderr
    done = run_pincal("calibrate", "talos", str(sim / "measurements.csv"), "--out", str(tmp_path / "cal.urdf"))
    assert done.returncode == 0, done.stderr
    held_out = next(line for line in done.stdout.splitlines() if line.startswith("RMS position error (held out)"))
    before, after = (float(v) for v in held_out.split()[-4::2])
    assert after < 0.1 and before > 20 * after  # [mm]
    assert pincal.load_robot(tmp_path / "cal.urdf").model.nq == 32


#: A gripper of one motor: the measured finger hangs on a follower that sorts before its leader (Pinocchio's
#: Jacobians of a model of one velocity coordinate are vectors of 6).
GRIPPER = """<robot name="gripper"><link name="palm"/><link name="motor_link"/><link name="finger"/><link name="tool0"/>
<joint name="motor" type="revolute"><parent link="palm"/><child link="motor_link"/><origin xyz="0 0.02 0.05"/>
<axis xyz="1 0 0"/><limit lower="-1" upper="1" effort="1" velocity="1"/></joint>
<joint name="a_finger" type="revolute"><parent link="palm"/><child link="finger"/><origin xyz="0 -0.02 0.05"/>
<axis xyz="1 0 0"/><limit lower="-1" upper="1" effort="1" velocity="1"/><mimic joint="motor" multiplier="-1"/></joint>
<joint name="tip_joint" type="fixed"><parent link="finger"/><child link="tool0"/><origin xyz="0 0 0.06"/></joint>
</robot>"""


def test_a_measured_chain_through_a_mimic_joint_is_described_simulated_and_calibrated(tmp_path: Path) -> None:
    path = tmp_path / "gripper.urdf"
    path.write_text(GRIPPER)
    done = run_pincal("info", str(path))
    assert done.returncode == 0, done.stderr
    assert "actuated joints (1): motor" in done.stdout and "measured frame (default): tool0" in done.stdout
    sim = tmp_path / "sim"
    done = run_pincal("simulate", str(path), "--samples", "20", "--test-samples", "5", "--seed", "1", "--quiet",
                      "--out", str(sim))
    assert done.returncode == 0, done.stderr
    done = run_pincal("calibrate", str(path), str(sim / "measurements.csv"), "--out", str(tmp_path / "cal.urdf"))
    assert done.returncode == 0, done.stderr
    held_out = next(line for line in done.stdout.splitlines() if line.startswith("RMS position error (held out)"))
    after = float(held_out.split()[-2])
    assert after < 0.05  # [mm]: the noise (a circle's errors are mostly the measurement frame's, registered before)


def test_a_continuous_joint_following_a_revolute_one_is_refused_in_one_line(tmp_path: Path) -> None:
    path = tmp_path / "gripper.urdf"
    path.write_text(GRIPPER.replace('name="a_finger" type="revolute"', 'name="a_finger" type="continuous"'))
    done = run_pincal("info", str(path))
    assert done.returncode == 2 and len(done.stderr.splitlines()) == 1
    assert "joint 'a_finger' <mimic>: a continuous joint cannot follow 'motor', a revolute joint" in done.stderr
