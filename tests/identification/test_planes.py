"""Contact with a plane: a frame on an unknown plane (its origin, or flush with its z axis along the normal), the
plane estimated with the robot from a closed-form start."""

from __future__ import annotations

import numpy as np
import pinocchio as pin
import pytest
from conftest import ROBOTS, finite_difference_jacobian

import pincal
from pincal.errors import DataError
from pincal.identification import measurements as ms
from pincal.identification.parameters import ParameterSet, choose_parameters, parameter_pool
from pincal.identification.problem import CalibrationProblem, Observations
from pincal.identification.solver import identify
from pincal.identification.starts import fit_plane
from pincal.study.simulation import perturbation, random_actuated

#: A plane 0.4 m along its normal, tilted by 0.3 and −0.2 rad [m, rad].
TILTED = {"tz": 0.4, "rx": 0.3, "ry": -0.2}


def _plane(values: dict[str, float], prefix: str) -> pin.SE3:
    """The plane's placement from the parameter values (support ← plane)."""
    return pin.exp6(np.array([0.0, 0.0, values.get(f"{prefix}.tz", 0.0), values.get(f"{prefix}.rx", 0.0),
                              values.get(f"{prefix}.ry", 0.0), 0.0]))


@pytest.mark.parametrize(("name", "frame", "support"), [("ur10", "tool0", ""), ("ur10", "tool0", "forearm_link"),
                                                        ("delta", "end_effector", "")])
@pytest.mark.parametrize("normal", [False, True])
def test_the_rows_are_the_distance_and_tilts_in_the_plane_and_their_jacobian_matches_finite_differences(
        name: str, frame: str, support: str, normal: bool) -> None:
    robot = pincal.load_robot(ROBOTS / "delta.urdf" if name == "delta" else name)
    model = ms.plane_contact(frame, support) if normal else ms.plane_point(frame, support)
    pset = ParameterSet([p for p in parameter_pool(robot, [model]) if p.kind != "compliance"])
    rng = np.random.default_rng(5)
    qa, _ = random_actuated(robot, 4, rng)
    problem = CalibrationProblem(robot, pset, [model], Observations(qa, {model.key: np.zeros((4, model.width))}))
    x = perturbation(pset, 1e-2, rng)
    prefix = ms.plane_name(support)
    for term, value in TILTED.items():
        x[pset.index(f"{prefix}.{term}")] = value
    pred = problem.evaluate(x)
    calibrated = problem.robot_at(x)  # independently: the frame seen from the plane by forward kinematics
    data = calibrated.model.createData()
    plane = _plane(pset.as_dict(x), prefix)
    for k, q in enumerate(problem.configurations(x)):
        pin.framesForwardKinematics(calibrated.model, data, q)
        held = data.oMf[calibrated.frame_id(support)] if support else pin.SE3.Identity()
        seen = plane.inverse() * held.inverse() * data.oMf[calibrated.frame_id(frame)]
        expected = [seen.translation[2], *seen.rotation[:2, 2]] if normal else [seen.translation[2]]
        assert np.allclose(pred.predicted[model.key][k], expected, atol=1e-12)
    assert pred.jacobian is not None
    fd = finite_difference_jacobian(problem, x)
    assert np.max(np.abs(pred.jacobian - fd)) < 1e-5 * np.max(np.abs(fd))


def test_the_closed_form_fits_the_plane_through_noisy_points_as_offset_and_tilts_only() -> None:
    rng = np.random.default_rng(2)
    truth = _plane({f"p.{k}": v for k, v in TILTED.items()}, "p")
    local = np.column_stack([rng.uniform(-0.5, 0.5, (40, 2)), rng.normal(scale=1e-4, size=40)])
    points = np.array([truth.act(p) for p in local])
    fitted = fit_plane(points, np.zeros(len(points)))
    delta = pin.log6(fitted).vector
    assert np.allclose(delta[[0, 1, 5]], 0.0, atol=1e-12)  # only the offset and the two tilts
    assert np.allclose(delta[[2, 3, 4]], [TILTED["tz"], TILTED["rx"], TILTED["ry"]], atol=2e-4)
    shifted = fit_plane(points + 0.01 * truth.rotation[:, 2], np.full(len(points), 0.01))  # each read 10 mm off it
    assert np.allclose(pin.log6(shifted).vector, delta, atol=1e-9)
    read = rng.uniform(-0.05, 0.05, 40)  # off the plane, as a dial gauge reads them: the distances place it
    off = fit_plane(points + read[:, None] * truth.rotation[:, 2], read)
    assert np.allclose(pin.log6(off).vector, delta, atol=1e-9)
    with pytest.raises(DataError, match="lie on a line"):
        fit_plane(np.outer(np.linspace(0, 1, 5), [1.0, 2.0, 0.5]), np.zeros(5))
    axes = np.tile(truth.rotation[:, 2], (5, 1))  # on a line, but the frames' axes give the normal
    on_line = fit_plane(np.outer(np.linspace(0, 1, 5), truth.rotation[:, 0]) + truth.translation, np.zeros(5), axes)
    assert np.allclose(pin.log6(on_line).vector, pin.log6(truth).vector, atol=1e-9)


def _no_readings(model: ms.Measurement) -> Observations:
    """One UR10 sample of zero readings: a problem to take the robot and the parameters from."""
    return Observations(np.zeros((1, 6)), {model.key: np.zeros((1, model.width))})


def contact_postures(problem: CalibrationProblem, model: ms.PlanePoint, x_true: np.ndarray, n: int,
                     rng: np.random.Generator) -> np.ndarray:
    """(n, na) readings at which the true robot touches the true plane (flush for a ``plane`` model): random
    postures moved onto it by Gauss–Newton steps on the contact rows, less the true reading offsets."""
    robot = problem.robot_at(x_true)
    pset = problem.parameters
    plane = _plane(pset.as_dict(x_true), ms.plane_name(model.support))
    data = robot.model.createData()
    fid = robot.frame_id(model.frame)
    out = []
    for q in random_actuated(problem.robot, n, rng)[0]:
        for _ in range(30):
            pin.framesForwardKinematics(robot.model, data, q)
            frame = data.oMf[fid]
            seen = plane.inverse() * frame
            rows = np.array([seen.translation[2], *seen.rotation[:2, 2]])[:model.size]
            jac = pin.computeFrameJacobian(robot.model, data, q, fid, pin.LOCAL_WORLD_ALIGNED)
            to_plane = plane.rotation.T
            d = np.vstack([to_plane[2] @ jac[:3], (-to_plane @ pin.skew(frame.rotation[:, 2]) @ jac[3:])[:2]])
            q = q - np.linalg.pinv(d[:model.size]) @ rows
        assert np.max(np.abs(rows)) < 1e-12
        out.append(q - [x_true[pset.index(f"{j}.offset")] for j in problem.robot.actuated_joints])
    return np.array(out)


@pytest.mark.parametrize("normal", [False, True])
def test_contact_postures_give_the_plane_in_closed_form_and_the_fit_predicts_unseen_contacts(normal: bool) -> None:
    """A UR10 with 1 mm / 1 mrad errors touches a plane tilted by 0.3 rad, 0.4 m away, 40 times (and 40 unseen):
    the nominal contact points give the plane within a few mm and mrad; the fit predicts the unseen contacts to
    the noise (10 µm, 10 µrad), from errors of millimetres at the start."""
    robot = pincal.load_robot("ur10")
    model = ms.plane_contact("tool0") if normal else ms.plane_point("tool0")
    pset = choose_parameters(robot, [model])
    rng = np.random.default_rng(11)
    x_true = perturbation(pset, 1e-3, rng)
    for term, value in TILTED.items():
        x_true[pset.index(f"plane.{term}")] = value
    blank = CalibrationProblem(robot, pset, [model], _no_readings(model))
    fitted, unseen = (contact_postures(blank, model, x_true, n, rng) for n in (40, 40))
    readings = rng.normal(scale=1e-5, size=(40, model.width))
    problem = CalibrationProblem(robot, pset, [model], Observations(fitted, {model.key: readings}))
    start = problem.initial_guess()
    assert problem.placed_in_closed_form == ["plane"]
    plane = pset.of_kind("plane")
    assert np.max(np.abs(start[plane] - x_true[plane])) < 0.01
    result = identify(problem)
    assert result.converged
    check = CalibrationProblem(robot, pset, [model], Observations(unseen, {model.key: np.zeros((40, model.width))}))
    before = check.evaluate(start, jacobian=False).errors[model.key]
    after = check.evaluate(result.x, jacobian=False).errors[model.key]
    assert np.sqrt(np.mean(before[:, 0] ** 2)) > 1e-3
    assert np.sqrt(np.mean(after ** 2, axis=0)).max() < 3e-5


def test_what_contact_cannot_see_is_unidentifiable_and_left_at_its_start() -> None:
    """On a plane parallel to the base's xy plane, the base joint's x and y translations move the tool along
    the plane only: the analysis lists them among what the data cannot see, and the fit leaves them."""
    robot = pincal.load_robot("ur10")
    model = ms.plane_contact("tool0")
    pset = choose_parameters(robot, [model])
    rng = np.random.default_rng(12)
    x_true = perturbation(pset, 1e-3, rng)
    x_true[pset.index("plane.tz")] = 0.3
    blank = CalibrationProblem(robot, pset, [model], _no_readings(model))
    problem = CalibrationProblem(robot, pset, [model],
                                 Observations(contact_postures(blank, model, x_true, 30, rng),
                                              {model.key: np.zeros((30, 3))}))
    result = identify(problem)
    base = set(result.identifiability.base_names)
    assert {"plane.tz", "plane.rx", "plane.ry"} & base
    assert not {"shoulder_pan_joint.tx", "shoulder_pan_joint.ty"} & base
    start = problem.initial_guess()
    for name in ("shoulder_pan_joint.tx", "shoulder_pan_joint.ty"):
        assert result.x[pset.index(name)] == pytest.approx(start[pset.index(name)], abs=1e-6)  # µm: not moved
    assert any("shoulder_pan_joint.tx" in c.description for c in result.identifiability.unidentifiable)


def test_the_default_set_has_the_plane_s_offset_and_tilts_and_the_support_s_chain() -> None:
    robot = pincal.load_robot("ur10")
    names = choose_parameters(robot, [ms.plane_point("tool0"), ms.plane_contact("wrist_2_link")]).names
    assert [n for n in names if n.startswith("plane")] == ["plane.tz", "plane.rx", "plane.ry"]
    held = choose_parameters(robot, [ms.plane_contact("tool0", "upper_arm_link")]).names
    assert [n for n in held if n.startswith("plane")] == ["plane.upper_arm_link.tz", "plane.upper_arm_link.rx",
                                                          "plane.upper_arm_link.ry"]


def test_a_plane_key_without_a_frame_or_support_is_refused() -> None:
    assert ms.parse_key("plane:tool0@base_link") == ms.plane_contact("tool0", "base_link")
    assert ms.parse_key("plane_point:tool0", 2e-4) == ms.plane_point("tool0", sigma=2e-4)
    for key in ("plane:@base_link", "plane:tool0@"):
        with pytest.raises(DataError, match=r"must name a frame as 'plane:<frame>', or a frame and the robot frame"):
            ms.parse_key(key)
