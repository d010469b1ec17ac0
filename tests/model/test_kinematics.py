"""One assembly, whatever the order: FK answers the reference assembly, warm-started or not (issue 9, item 2).

The reference assembly is what continuation from the reference configuration reaches (a cold solve). A
warm start is only a shortcut to it: Newton from a guess that jumps (moves a passive joint by more than
one continuation step) is refused and the solve continues from the reference. So the samples of a
dataset can be solved in any order, and shuffling them changes neither the predictions nor the
calibration. The two cases that used to fail (studies 001 and 004) are kept here with their inputs.
"""

from __future__ import annotations

import itertools
import sys

import numpy as np
import pinocchio as pin
import pytest
from conftest import ROOT

import pincal
from pincal.identification import measurements as ms
from pincal.identification.parameters import ParameterSet, apply_parameters, candidate_parameters
from pincal.identification.problem import CalibrationProblem, Observations
from pincal.identification.solver import identify
from pincal.model.kinematics import CONTINUATION_STEP
from pincal.study.simulation import random_actuated, simulate_observations

sys.path.insert(0, str(ROOT / "examples"))

import study_001_hexapod as study_001
import study_004_ucr3 as study_004

MM = 1e-3
#: Study 004's four poses chosen by κ from its 1000 workspace candidates (full run): limb length
#: changes r_i - r_ref [m]. Solved in the wrong order, a warm start from one pose put another on a
#: different assembly (0.19 m away) and 12 of the 24 orderings failed.
UCR3_POSES = np.array([
    [-0.07855677255384469, -0.03676838345968042, -0.01977563340180151],
    [-0.00691930972892896, -0.06407775456140714, -0.0231943339693486],
    [-0.01210091742507343, 0.00358517020878542, -0.05628578443884776],
    [0.04568368100626741, 0.01429276360541668, 0.07594184014864484],
])
#: Study 001, error set 3: samples 1 and 5 of the 60 postures chosen by κ (full run), commanded leg
#: changes [m]. Warm-started from sample 1, Newton put sample 5 on another branch 1.05 rad away.
HEXAPOD_POSTURES = np.array([
    [0.19850206134373488, -0.12098033609717344, 0.32748268822657534, 0.134215939505215, -0.22993090601322516,
     0.17832079605764925],
    [-0.21319326473841424, 0.2732386685430953, 0.2859655557224162, -0.05413371919121132, -0.0501631655414062,
     0.24439016712720837],
])


def passive_gap(robot: pincal.Robot, q1: np.ndarray, q2: np.ndarray) -> float:
    """Largest difference of any coordinate between two configurations [rad or m] (tangent space)."""
    return float(np.abs(pin.difference(robot.model, q1, q2)).max())


def plain_newton(robot: pincal.Robot, q_actuated: np.ndarray, guess: np.ndarray) -> np.ndarray:
    """Newton from ``guess`` with no jump check (what a warm start did before): the closed configuration."""
    start = guess.copy()
    robot.kinematics.set_actuated(start, q_actuated)
    report = robot.kinematics.close_loops(start, 1e-11)
    assert report.converged
    return report.q


# --- the kinematics layer -------------------------------------------------------------------------------
def test_study_001_warm_start_that_jumps_returns_the_reference_assembly() -> None:
    true, offsets = study_001.true_robots()[2]  # error set 3: ±10 mm, D0 +20 mm, ψ +2°
    neighbour, sample = HEXAPOD_POSTURES + offsets
    q_neighbour = true.solve_fk(neighbour)
    cold = true.solve_fk(sample)
    # the trap is still there: Newton from the neighbour closes the loops on another branch
    jumped = plain_newton(true, sample, q_neighbour)
    assert np.max(np.abs(true.closure_residual(jumped))) < 1e-10
    assert passive_gap(true, jumped, cold) > 1.0
    # pincal's warm start sees the jump and answers the reference assembly
    warm = true.solve_fk(sample, q_guess=q_neighbour)
    assert passive_gap(true, warm, cold) < 1e-9
    # and the reference assembly is the posture the sample was drawn for: its platform pose is the one
    # the nominal robot's IK gave (leg errors of ±10 mm move it by millimetres, not by a branch)
    nominal = study_001.robot()
    pose_nominal = nominal.placement(nominal.solve_fk(HEXAPOD_POSTURES[1]), "end_effector")
    pose_true = true.placement(warm, "end_effector")
    assert np.linalg.norm(pose_true.translation - pose_nominal.translation) < 0.05


def test_study_004_warm_starts_between_poses_give_the_cold_answers() -> None:
    pset, mapping = study_004.model_parameters()
    x_true = mapping @ study_004.true_physical()
    kinematic = pset.of_kind("joint", "anchor")
    offsets = [pset.index(f"limb_{i}_prismatic.offset") for i in (1, 2, 3)]
    robots = {"nominal": (study_004.robot(), UCR3_POSES),
              "true": (apply_parameters(study_004.robot(), pset.subset(kinematic), x_true[kinematic]),
                       UCR3_POSES + x_true[offsets])}
    jumps = 0
    for robot, poses in robots.values():
        cold = [robot.solve_fk(qa) for qa in poses]
        for i, j in itertools.permutations(range(len(poses)), 2):
            warm = robot.solve_fk(poses[j], q_guess=cold[i])
            assert passive_gap(robot, warm, cold[j]) < 1e-9, (i, j)
            jumps += passive_gap(robot, plain_newton(robot, poses[j], cold[i]), cold[j]) > 1e-6
    assert jumps >= 1  # at least one of these warm starts lands elsewhere without the jump check


def test_warm_start_on_a_trajectory_is_kept_and_cheap() -> None:
    """A guess one small step away is used as is: one Jacobian and a few Newton steps, no continuation."""
    robot = pincal.load_robot("delta")
    qa = np.array([0.3, -0.2, 0.5])
    q = robot.solve_fk(qa)
    report = robot.solve_fk_report(qa + 1e-3, q_guess=q)
    assert report.converged and report.iterations <= 4
    assert passive_gap(robot, report.q, robot.solve_fk(qa + 1e-3)) < 1e-9


def test_far_guess_on_another_assembly_is_not_followed() -> None:
    """A guess farther than one continuation step (in actuated values) is not a warm start: the answer is
    continuation from the reference, even when the guess sits on another assembly mode."""
    robot = pincal.load_robot("delta")
    qa = np.array([0.2, 0.1, -0.3])
    cold = robot.solve_fk(qa)
    other = robot.solve_fk(qa + 2 * CONTINUATION_STEP)
    assert passive_gap(robot, robot.solve_fk(qa, q_guess=other), cold) < 1e-9


# --- the calibration problem: any order -------------------------------------------------------------
def study_004_problem(order: tuple[int, ...], x_true: np.ndarray, pset: ParameterSet) -> CalibrationProblem:
    """The study's calibration problem (6D poses of E, weighted as its ΔE) with the poses in ``order``."""
    models = [ms.pose("end_effector", sigma=MM, sigma_angle=2.0)]
    obs = simulate_observations(study_004.robot(), pset, x_true, models, UCR3_POSES[list(order)],
                                np.random.default_rng(0))
    return CalibrationProblem(study_004.robot(), pset, models, obs)


def test_study_004_every_ordering_of_the_four_poses_calibrates_alike() -> None:
    pset, mapping = study_004.model_parameters()
    x_true = mapping @ study_004.true_physical()
    key = "pose:end_effector"
    reference = None
    for order in itertools.permutations(range(4)):
        problem = study_004_problem(order, x_true, pset)
        back = np.argsort(order)
        start = problem.evaluate(np.zeros(len(pset)), jacobian=False).errors[key][back]
        # the nominal and the true robot are solved on the same assembly: 0.1 mm errors move E by < 1 mm
        assert np.max(np.linalg.norm(start[:, :3], axis=1)) < 1 * MM, order
        if reference is None:
            reference = start
        np.testing.assert_allclose(start, reference, rtol=0, atol=1e-12)
    for order in [(0, 1, 2, 3), (0, 2, 1, 3), (3, 1, 0, 2)]:  # the first two failed before
        result = identify(study_004_problem(order, x_true, pset), max_iter=50, loss="linear")
        assert result.converged
        after = result.errors_after[key][np.argsort(order)]
        assert np.max(np.linalg.norm(after[:, :3], axis=1)) < 1e-9  # [m]: the four poses fitted exactly


# --- property: shuffling the samples of a dataset changes nothing, on every robot --------------------------
def generic_parameters(robot: pincal.Robot) -> ParameterSet:
    """Actuated offsets and the successor anchor of every loop (translations in the robot's plane for a
    planar one): a small set for any robot."""
    pool = candidate_parameters(robot, offsets=robot.actuated_joints)
    names = [f"{joint}.offset" for joint in robot.actuated_joints]
    names += [f"{loop.name}.successor.t{axis}" for loop in robot.loops for axis in "xyz"]
    return pool.select([n for n in names if n in pool])


def samples_both_robots_reach(robot: pincal.Robot, pset: ParameterSet, x_true: np.ndarray, n: int,
                              spread: float, rng: np.random.Generator) -> np.ndarray:
    """``n`` random actuated inputs (n, na) [rad or m] at which the nominal and the true robot both assemble."""
    kinematic = pset.of_kind("joint", "anchor")
    offsets = np.zeros(robot.n_actuated)
    for k, p in enumerate(pset):
        if p.kind == "offset":
            offsets[robot.actuated_joints.index(p.owner)] = x_true[k]
    true = apply_parameters(robot, pset.subset(kinematic), x_true[kinematic])
    qa, _ = random_actuated(robot, 2 * n, rng, spread=spread)
    reached = [a for a in qa if true.solve_fk_report(a + offsets).converged]
    assert len(reached) >= n
    return np.array(reached[:n])


#: Robot -> half-range of its random actuated inputs [rad or m] (wider than the simulation defaults, so
#: that neighbouring samples are far apart and warm starts between them would jump).
SPREADS = {"delta": 1.0, "five_bar": 0.35, "hexapod": 0.2, "hexapod_device": 0.2, "ucr3": 0.08}


@pytest.mark.parametrize("name", sorted(SPREADS))
def test_shuffled_samples_give_identical_predictions_and_calibrations(name: str) -> None:
    robot = pincal.load_robot(name)
    rng = np.random.default_rng(20)
    pset = generic_parameters(robot)
    x_true = rng.normal(scale=1e-3, size=len(pset))  # 1 mm, 1 mrad
    qa = samples_both_robots_reach(robot, pset, x_true, 10, SPREADS[name], rng)
    models = [ms.pose(robot.end_effector)]
    obs = simulate_observations(robot, pset, x_true, models, qa, rng, noise=1e-6)
    key = models[0].key

    def run(order: np.ndarray) -> tuple[np.ndarray, np.ndarray, np.ndarray, np.ndarray]:
        problem = CalibrationProblem(robot, pset, models, obs.subset(order))
        back = np.argsort(order)
        truth = problem.evaluate(x_true, jacobian=False).predicted[key][back]
        configurations = problem.configurations(np.zeros(len(pset)))[back]
        result = identify(problem, loss="linear")
        return truth, configurations, result.x, result.errors_after[key][back]

    first = run(np.arange(len(qa)))
    for seed in (1, 2):
        order = np.random.default_rng(seed).permutation(len(qa))
        truth, configurations, x, after = run(order)
        np.testing.assert_allclose(truth, first[0], rtol=0, atol=1e-9)
        np.testing.assert_allclose(configurations, first[1], rtol=0, atol=1e-9)
        np.testing.assert_allclose(x, first[2], rtol=0, atol=1e-9)
        np.testing.assert_allclose(after, first[3], rtol=0, atol=1e-9)


def test_a_problem_solves_each_sample_as_a_cold_solve_does() -> None:
    """Whatever the order: every configuration of a problem is the robot's own cold FK answer."""
    robot = study_004.robot()
    pset, _ = study_004.model_parameters()
    models = [ms.pose("end_effector")]
    blank = {models[0].key: np.tile([0.0, 0.0, 0.0, 0.0, 0.0, 0.0, 1.0], (4, 1))}
    for order in itertools.permutations(range(4)):
        poses = UCR3_POSES[list(order)]
        problem = CalibrationProblem(robot, pset, models, Observations(poses, blank))
        for q, qa in zip(problem.configurations(np.zeros(len(pset))), poses, strict=True):
            assert passive_gap(robot, q, robot.solve_fk(qa)) < 1e-9


def test_a_redundant_task_s_step_has_no_null_space_part_from_round_off() -> None:
    """The damped Gauss–Newton step of a task with fewer rows than joints (a point aimed by a six-axis arm) is the
    minimum-norm step ``−J⁺ r`` up to the damping (1e-10 relative), with no part in the null space of ``J`` beyond
    round-off: solved through ``JᵀJ``, whose three zero eigenvalues only the damping lifts, that part was round-off
    amplified 1e10 times (2e-7 to 2e-6 of the step here), and it made the solves after one another differ between BLAS
    builds. A square task's step is the Newton step."""
    from pincal.model.kinematics import damped_gauss_newton_step

    rng = np.random.default_rng(0)
    for _ in range(5):
        jac, residual = rng.normal(size=(3, 6)), rng.normal(size=3) * 1e-3
        pseudo = np.linalg.pinv(jac)
        step = damped_gauss_newton_step(jac, residual, damping=1e-10)
        assert step is not None
        scale = float(np.max(np.abs(pseudo @ residual)))
        assert np.max(np.abs((np.eye(6) - pseudo @ jac) @ step)) <= 1e-12 * scale
        np.testing.assert_allclose(step, -pseudo @ residual, rtol=0.0, atol=1e-8 * scale)
        square, rhs = rng.normal(size=(6, 6)) + 3.0 * np.eye(6), rng.normal(size=6)
        newton = damped_gauss_newton_step(square, rhs, damping=0.0)
        assert newton is not None
        np.testing.assert_allclose(newton, -np.linalg.solve(square, rhs), rtol=1e-10, atol=0.0)
