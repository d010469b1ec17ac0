"""Cameras: eye-in-hand (a camera on the robot sees a target or a point in the world) and eye-to-hand (a fixed
camera, the measurement frame, sees a pose target on the robot), their unknown placements estimated with the
robot's geometry from closed-form starts."""

from __future__ import annotations

import numpy as np
import pinocchio as pin
import pytest
from conftest import ROBOTS, finite_difference_jacobian

import pincal
from pincal.errors import DataError
from pincal.identification import measurements as ms
from pincal.identification.ikm import ImplicitProblem
from pincal.identification.parameters import choose_parameters, parameter_pool
from pincal.identification.problem import CalibrationProblem, Observations
from pincal.identification.solver import identify
from pincal.study.simulation import perturbation, random_actuated, simulate_observations

#: Placements far from the identity [m, rad]: a camera 12 cm off the flange, turned by up to 2 rad; a target 1 m
#: away in the world; a fixed camera 2 m from the robot; a tag on the flange.
FAR = {"camera.{f}.tx": 0.05, "camera.{f}.ty": -0.03, "camera.{f}.tz": 0.1, "camera.{f}.rx": 0.4,
       "camera.{f}.ry": -1.2, "camera.{f}.rz": 2.0, "target.tx": 1.0, "target.ty": 0.4, "target.tz": -0.3,
       "target.rx": 0.3, "target.ry": 0.2, "target.rz": -0.8, "base.tx": 2.0, "base.ty": -1.0, "base.tz": 0.5,
       "base.rx": 0.2, "base.ry": -0.3, "base.rz": 1.5, "target.{f}@tag.tx": 0.02, "target.{f}@tag.ty": 0.05,
       "target.{f}@tag.tz": 0.08, "target.{f}@tag.rx": 1.0, "target.{f}@tag.ry": 0.5, "target.{f}@tag.rz": -0.4}


def setups(frame: str) -> dict[str, ms.Measurement]:
    return {"eye-in-hand pose": ms.camera_pose(frame), "eye-in-hand point": ms.camera_point(frame),
            "eye-to-hand pose": ms.pose(frame, target="tag")}


def truth(pset: pincal.ParameterSet, frame: str, rng: np.random.Generator) -> np.ndarray:
    """Random geometric errors of 1 mm / 1 mrad, and the cameras and targets far from the identity."""
    x = perturbation(pset, 1e-3, rng)
    for key, value in FAR.items():
        name = key.format(f=frame)
        if name in pset:
            x[pset.index(name)] = value
    return x


def blank(models: list[ms.Measurement], n: int) -> dict[str, np.ndarray]:
    values = {m.key: np.zeros((n, len(m.columns))) for m in models}
    for m in models:
        if isinstance(m, ms.Pose):
            values[m.key][:, 6] = 1.0
    return values


@pytest.mark.parametrize(("name", "frame"), [("ur10", "tool0"), ("delta", "end_effector")])
@pytest.mark.parametrize("setup", ["eye-in-hand pose", "eye-in-hand point", "eye-to-hand pose"])
def test_camera_models_are_the_composed_placements_and_their_jacobians_match_finite_differences(
        name: str, frame: str, setup: str) -> None:
    robot = pincal.load_robot(ROBOTS / "delta.urdf" if name == "delta" else name)
    model = setups(frame)[setup]
    pset = pincal.ParameterSet([p for p in parameter_pool(robot, [model]) if p.kind != "compliance"])
    rng = np.random.default_rng(7)
    qa, _ = random_actuated(robot, 4, rng)
    problem = CalibrationProblem(robot, pset, [model], Observations(qa, blank([model], 4)))
    x = truth(pset, frame, rng)
    pred = problem.evaluate(x)
    # independently: the placements composed from the calibrated robot's forward kinematics
    values = pset.as_dict(x)

    def placement(prefix: str) -> pin.SE3:
        return pin.exp6(np.array([values.get(f"{prefix}.{c}", 0.0) for c in ("tx", "ty", "tz", "rx", "ry", "rz")]))

    calibrated = problem.robot_at(x)
    data = calibrated.model.createData()
    for k, q in enumerate(problem.configurations(x)):
        pin.framesForwardKinematics(calibrated.model, data, q)
        hand = data.oMf[calibrated.frame_id(frame)]
        if setup == "eye-to-hand pose":
            seen = placement("base") * hand * placement(f"target.{frame}@tag")
        else:
            seen = placement(f"camera.{frame}").inverse() * hand.inverse() * placement("target")
        if setup == "eye-in-hand point":
            world_point = placement("target").translation
            expected = (placement(f"camera.{frame}").inverse() * hand.inverse()).act(world_point)
            assert np.allclose(pred.predicted[model.key][k], expected, atol=1e-12)
        else:
            assert np.allclose(pred.predicted[model.key][k, :3], seen.translation, atol=1e-12)
            assert np.allclose(pin.exp3(pred.predicted[model.key][k, 3:]), seen.rotation, atol=1e-12)
    assert pred.jacobian is not None
    fd = finite_difference_jacobian(problem, x)
    assert np.max(np.abs(pred.jacobian - fd)) < 1e-5 * np.max(np.abs(fd))


def test_the_default_set_brings_each_camera_and_target_and_leaves_the_tool_and_the_first_placement_out() -> None:
    robot = pincal.load_robot("ur10")
    names = choose_parameters(robot, [ms.camera_pose("tool0")]).names
    assert {f"camera.tool0.{c}" for c in ("tx", "ty", "tz", "rx", "ry", "rz")} <= set(names)
    assert {f"target.{c}" for c in ("tx", "ty", "tz", "rx", "ry", "rz")} <= set(names)
    tool = "wrist_3_link-tool0_fixed_joint."
    assert not any(n.startswith(("base.", "shoulder_pan_joint.t", "shoulder_pan_joint.r", tool)) for n in names)
    point = choose_parameters(robot, [ms.camera_point("tool0")]).names
    assert [n for n in point if n.startswith("target.")] == ["target.tx", "target.ty", "target.tz"]
    tag = choose_parameters(robot, [ms.pose("tool0", target="tag")]).names
    assert {"base.rz", "target.tool0@tag.rx"} <= set(tag) and not any(n.startswith(tool) for n in tag)


@pytest.mark.parametrize("setup", ["eye-in-hand pose", "eye-in-hand point", "eye-to-hand pose"])
def test_closed_form_starts_then_the_fit_recover_the_robot_the_camera_and_the_target(setup: str) -> None:
    """Simulated with the camera turned by 2 rad and the target 1 m away (or the fixed camera 2 m away), 1 mm / 1 mrad
    geometric errors and 10 µm / 10 µrad noise: the closed form starts within a few mm of the truth, and the fit
    predicts 40 unseen postures to the noise level."""
    robot = pincal.load_robot("ur10")
    model = setups("tool0")[setup]
    pset = choose_parameters(robot, [model])
    rng = np.random.default_rng(3)
    x_true = truth(pset, "tool0", rng)
    qa, _ = random_actuated(robot, 60, rng)
    problem = CalibrationProblem(robot, pset, [model], simulate_observations(robot, pset, x_true, [model], qa, rng,
                                                                             noise=1e-5))
    start = problem.initial_guess()
    placed = [k for k, p in enumerate(pset) if p.kind in ("camera", "target", "base")]
    assert np.max(np.abs(start[placed] - x_true[placed])) < 0.01  # from 2 rad and 2 m away
    result = identify(problem)
    assert result.converged
    qt, _ = random_actuated(robot, 40, rng)
    unseen = CalibrationProblem(robot, pset, [model], simulate_observations(robot, pset, x_true, [model], qt, rng))
    error = unseen.evaluate(result.x, jacobian=False).errors[model.key]
    nominal = unseen.evaluate(start, jacobian=False).errors[model.key]
    assert np.sqrt(np.mean(nominal[:, :3] ** 2)) > 1e-3  # the geometric errors matter: mm before
    assert np.sqrt(np.mean(error[:, :3] ** 2)) < 3e-5
    if error.shape[1] == 6:
        assert np.sqrt(np.mean(error[:, 3:] ** 2)) < 3e-5


def test_a_target_out_of_view_has_no_rows_and_the_fit_uses_the_others() -> None:
    robot = pincal.load_robot("ur10")
    model = ms.camera_pose("tool0")
    pset = choose_parameters(robot, [model])
    rng = np.random.default_rng(4)
    x_true = truth(pset, "tool0", rng)
    qa, _ = random_actuated(robot, 50, rng)
    obs = simulate_observations(robot, pset, x_true, [model], qa, rng, noise=1e-5)
    obs.values[model.key][::5] = np.nan  # 10 samples in which the camera did not see the target
    problem = CalibrationProblem(robot, pset, [model], obs)
    assert problem.n_readings() == {model.key: 40}
    pred = problem.evaluate(problem.initial_guess())
    assert pred.residual.size == 40 * 6 and np.all(np.isfinite(pred.residual))
    assert np.all(np.isnan(pred.errors[model.key][::5]))
    result = identify(problem)
    fitted = problem.evaluate(result.x, jacobian=False).errors[model.key][1::5]
    assert np.sqrt(np.mean(fitted[:, :3] ** 2)) < 3e-5


def test_a_camera_or_target_key_that_names_no_frame_is_refused_and_ikm_refuses_a_target() -> None:
    with pytest.raises(DataError, match=r"'pose:tool0@' must name a frame and a target as 'pose:<frame>@<target>'"):
        ms.parse_key("pose:tool0@")
    delta = pincal.load_robot(ROBOTS / "delta.urdf")
    model = ms.pose("end_effector", target="tag")
    pset = choose_parameters(delta, [model])
    qa, _ = random_actuated(delta, 3, np.random.default_rng(0))
    with pytest.raises(DataError, match="'pose:end_effector@tag' is a target on the frame whose placement is "
                                        "estimated: use FKM"):
        ImplicitProblem(delta, pset, [model], Observations(qa, blank([model], 3)))


@pytest.mark.parametrize("setup", ["eye-in-hand pose", "eye-in-hand point", "eye-to-hand pose"])
def test_a_camera_on_a_platform_that_only_translates_starts_from_the_translating_closed_form(setup: str) -> None:
    """The Delta's platform never turns, so its rotations cannot separate the camera from the target: the start
    registers the readings' translations instead, and the fit predicts unseen postures to the noise (a camera turned
    by 2.5 rad: from the identity, the fit left the loops unclosable)."""
    robot = pincal.load_robot(ROBOTS / "delta.urdf")
    model = setups("end_effector")[setup]
    pset = choose_parameters(robot, [model])
    rng = np.random.default_rng(3)
    x_true = perturbation(pset, 1e-3, rng)
    far = {"camera.end_effector.rx": 2.5, "camera.end_effector.ry": 0.6, "target.tz": -0.6, "target.rz": 1.0,
           "base.tx": 1.0, "base.rz": 2.0, "target.end_effector@tag.rx": 1.5}
    for name, value in far.items():
        if name in pset:
            x_true[pset.index(name)] = value
    qa, _ = random_actuated(robot, 60, rng)
    problem = CalibrationProblem(robot, pset, [model], simulate_observations(robot, pset, x_true, [model], qa, rng,
                                                                             noise=1e-5))
    problem.initial_guess()
    assert problem.placed_in_closed_form and not problem.not_in_closed_form
    result = identify(problem)
    qt, _ = random_actuated(robot, 40, rng)
    unseen = CalibrationProblem(robot, pset, [model], simulate_observations(robot, pset, x_true, [model], qt, rng))
    error = unseen.evaluate(result.x, jacobian=False).errors[model.key]
    assert result.converged and np.sqrt(np.mean(error[:, :3] ** 2)) < 3e-5
