"""The 6-UPS Gough–Stewart hexapod of study 001, with and without its measuring device.

pincal's general closed-loop solvers are checked against the hexapod's closed forms: the leg length
``L_i = ||R b_i + t - a_i||`` (study 001 Eq. 4-5) and the device readings (study 001 Eq. 6-8).
The geometry (a_i, b_i, reference pose) is read from the URDF text itself, not through pincal.
"""

from __future__ import annotations

import xml.etree.ElementTree as ET
from pathlib import Path

import numpy as np
import numpy.typing as npt
import pinocchio as pin
import pytest
import yourdfpy
from conftest import ROOT

import pincal

Array = npt.NDArray[np.float64]

URDF_DIR = ROOT / "robots_urdf"
HEXAPOD = URDF_DIR / "hexapod.urdf"
HEXAPOD_DEVICE = URDF_DIR / "hexapod_device.urdf"
LEGS = [f"leg_{i}_prismatic" for i in range(1, 7)]
DEVICE_JOINTS = ["device_incl_y", "device_incl_x", "device_lvdt", "device_upper_u1", "device_upper_u2",
                 "device_rotary"]
DEVICE_D0 = 0.85  # [m] study 001, section 4.2: true fixed length of the measuring link
HEIGHT = 0.85  # [m] reference height of P above O

# Study 001 workspace (section 4.2): |x|, |y| <= 400 mm, rotations within a 40° range.
WORKSPACE_XY = 0.4  # [m]
WORKSPACE_DZ = 0.05  # [m] around HEIGHT
WORKSPACE_ANGLE = np.radians(20.0)  # [rad] each Euler angle

POSE_TOL = 1e-9  # [m, rad]


# --- closed forms -----------------------------------------------------------------------------------
def _xyz(element: ET.Element | None) -> Array:
    assert element is not None
    return np.array([float(v) for v in element.get("xyz", "0 0 0").split()])


def _rpy(element: ET.Element | None) -> Array:
    assert element is not None
    return np.array([float(v) for v in element.get("rpy", "0 0 0").split()])


def leg_geometry(path: Path) -> tuple[Array, Array, Array]:
    """(a (6, 3) base U centres [m] in the base frame, b (6, 3) platform S centres [m] in the
    platform frame, L0 (6,) leg lengths [m] at the reference pose), read from the URDF text."""
    root = ET.parse(path).getroot()
    joints = {j.get("name"): j for j in root.findall("joint")}
    loops = {lp.get("name"): lp for lp in root.findall("loop")}
    floating = joints["platform_joint"].find("origin")
    reference = pin.SE3(pin.rpy.rpyToMatrix(_rpy(floating)), _xyz(floating))
    a = np.array([_xyz(joints[f"leg_{i}_u1"].find("origin")) for i in range(1, 7)])
    b = np.array([_xyz(loops[f"leg_{i}_platform"].find("successor/origin")) for i in range(1, 7)])
    return a, b, leg_lengths(a, b, reference)


def leg_lengths(a: Array, b: Array, pose: pin.SE3) -> Array:
    """Study 001 Eq. 4: L_i = ||R b_i + t - a_i|| [m]."""
    return np.linalg.norm(b @ pose.rotation.T + pose.translation - a, axis=1)


def posture(x: float, y: float, z: float, alpha: float, beta: float, gamma: float) -> pin.SE3:
    """Study 001 Eq. 1-2: position [m] and R = R_Y(β) R_X(α) R_z(γ) [rad]."""
    rot = pin.utils.rotate("y", beta) @ pin.utils.rotate("x", alpha) @ pin.utils.rotate("z", gamma)
    return pin.SE3(rot, np.array([x, y, z]))


def random_postures(seed: int, n: int) -> list[pin.SE3]:
    """Uniform postures in study 001's workspace."""
    rng = np.random.default_rng(seed)
    lim = np.array([WORKSPACE_XY, WORKSPACE_XY, WORKSPACE_DZ] + [WORKSPACE_ANGLE] * 3)
    samples = rng.uniform(-lim, lim, size=(n, 6)) + np.array([0.0, 0.0, HEIGHT, 0.0, 0.0, 0.0])
    return [posture(*s) for s in samples]


def device_readings(pose: pin.SE3) -> dict[str, float]:
    """Device joint values at a platform pose (O at the base origin, P at the platform origin).

    Study 001 Eq. 6: D = D0 + Dm = |OP|; Eq. 8: α = asin(-y/D), β = atan2(x, z); the upper U and the
    rotary sensor from R_X(α)ᵀ R_Y(β)ᵀ R = R_x(u1) R_y(u2) R_z(rotary).
    """
    x, y, z = pose.translation
    dist = float(np.linalg.norm(pose.translation))
    alpha, beta = np.arcsin(-y / dist), np.arctan2(x, z)
    m = (pin.utils.rotate("y", beta) @ pin.utils.rotate("x", alpha)).T @ pose.rotation
    return {
        "device_incl_y": float(beta), "device_incl_x": float(alpha), "device_lvdt": dist - DEVICE_D0,
        "device_upper_u1": float(np.arctan2(-m[1, 2], m[2, 2])), "device_upper_u2": float(np.arcsin(m[0, 2])),
        "device_rotary": float(np.arctan2(-m[0, 1], m[0, 0])),
    }


def inverse_jacobian(a: Array, b: Array, pose: pin.SE3) -> Array:
    """Leg rates per platform twist (6 × 6): rows [u_iᵀ, ((R b_i) × u_i)ᵀ], twist (v_P, ω) in the
    world frame."""
    arm = b @ pose.rotation.T
    legs = arm + pose.translation - a
    u = legs / np.linalg.norm(legs, axis=1)[:, None]
    return np.hstack([u, np.cross(arm, u)])


def pose_error(m1: pin.SE3, m2: pin.SE3) -> tuple[float, float]:
    """(position error [m], rotation angle [rad]) between two placements."""
    return (float(np.linalg.norm(m1.translation - m2.translation)),
            float(np.linalg.norm(pin.log3(m1.rotation.T @ m2.rotation))))


def joint_value(robot: pincal.Robot, q: Array, joint: str) -> float:
    return float(q[robot.model.joints[robot.model.getJointId(joint)].idx_q])


# --- fixtures ---------------------------------------------------------------------------------------
@pytest.fixture(scope="module")
def hexapod() -> pincal.Robot:
    return pincal.load_robot(HEXAPOD)


@pytest.fixture(scope="module")
def hexapod_device() -> pincal.Robot:
    return pincal.load_robot(HEXAPOD_DEVICE)


@pytest.fixture(scope="module")
def geometry() -> tuple[Array, Array, Array]:
    return leg_geometry(HEXAPOD)


# --- the files --------------------------------------------------------------------------------------
@pytest.mark.parametrize("path", [HEXAPOD, HEXAPOD_DEVICE], ids=["hexapod", "hexapod_device"])
def test_files_load_as_trees_in_plain_pinocchio_and_yourdfpy(path: Path) -> None:
    model = pin.buildModelFromUrdf(str(path))
    free_flyer = model.joints[model.getJointId("platform_joint")]
    assert (free_flyer.nq, free_flyer.nv) == (7, 6)
    assert model.existFrame("end_effector")
    urdf = yourdfpy.URDF.load(str(path), load_meshes=False)
    assert "platform" in urdf.link_map and "end_effector" in urdf.link_map
    assert all(j in urdf.joint_map for j in LEGS)


@pytest.mark.parametrize("path", [HEXAPOD, HEXAPOD_DEVICE], ids=["hexapod", "hexapod_device"])
def test_reference_assembly(path: Path) -> None:
    robot = pincal.load_robot(path)
    q0 = pin.neutral(robot.model)
    assert np.max(np.abs(robot.closure_residual(q0))) < 1e-9
    assert robot.mobility() == 6
    assert robot.actuated_joints == LEGS
    assert {lp.name: lp.type for lp in robot.loops if lp.name.startswith("leg_")} == {
        f"leg_{i}_platform": "spherical" for i in range(1, 7)}
    reference = robot.placement(q0, "end_effector")
    assert np.allclose(reference.translation, [0.0, 0.0, HEIGHT], atol=1e-12)
    assert np.allclose(reference.rotation, np.eye(3), atol=1e-12)
    if path == HEXAPOD_DEVICE:
        assert [(lp.name, lp.type) for lp in robot.loops if lp.name.startswith("device")] == [
            ("device_platform", "fixed")]
        assert all(robot.model.existJointName(j) for j in DEVICE_JOINTS)
        assert not set(DEVICE_JOINTS) & set(robot.actuated_joints)


def test_device_file_is_the_hexapod_file_plus_the_device() -> None:
    for plain, with_device in zip(leg_geometry(HEXAPOD), leg_geometry(HEXAPOD_DEVICE), strict=True):
        assert np.array_equal(plain, with_device)


# --- inverse and forward kinematics -----------------------------------------------------------------
def test_ik_matches_closed_form_leg_lengths(hexapod: pincal.Robot,
                                            geometry: tuple[Array, Array, Array]) -> None:
    a, b, lengths0 = geometry
    for pose in random_postures(seed=1, n=40):
        q = hexapod.solve_ik(pose, frame="end_effector")
        expected = leg_lengths(a, b, pose) - lengths0  # study 001 Eq. 5, offsets L0_i
        assert np.max(np.abs(hexapod.actuated_values(q) - expected)) < 1e-9
        assert np.max(np.abs(hexapod.closure_residual(q))) <= 1e-10
        assert max(pose_error(hexapod.placement(q, "end_effector"), pose)) < POSE_TOL


def test_fk_of_ik_recovers_the_pose(hexapod: pincal.Robot) -> None:
    for pose in random_postures(seed=2, n=40):
        q_actuated = hexapod.actuated_values(hexapod.solve_ik(pose, frame="end_effector"))
        q = hexapod.solve_fk(q_actuated)
        assert np.max(np.abs(hexapod.actuated_values(q) - q_actuated)) < 1e-12
        assert max(pose_error(hexapod.placement(q, "end_effector"), pose)) < POSE_TOL


def test_cold_start_fk_from_closed_form_leg_lengths(hexapod: pincal.Robot,
                                                    geometry: tuple[Array, Array, Array]) -> None:
    a, b, lengths0 = geometry
    poses = random_postures(seed=3, n=2000)
    failures = []
    for k, pose in enumerate(poses):
        try:
            q = hexapod.solve_fk(leg_lengths(a, b, pose) - lengths0)
        except pincal.ConvergenceError:
            failures.append((k, "no convergence"))
            continue
        position, angle = pose_error(hexapod.placement(q, "end_effector"), pose)
        if max(position, angle) > POSE_TOL:
            failures.append((k, f"other assembly: {position:.3g} m, {angle:.3g} rad away"))
    assert len(failures) <= 0.001 * len(poses), failures[:10]


# --- the measuring device ---------------------------------------------------------------------------
def test_device_readings_match_study_001_closed_form(hexapod_device: pincal.Robot,
                                                     geometry: tuple[Array, Array, Array]) -> None:
    a, b, lengths0 = geometry
    corners = [posture(sx * WORKSPACE_XY, sy * WORKSPACE_XY, HEIGHT, sa * WORKSPACE_ANGLE,
                       sb * WORKSPACE_ANGLE, sg * WORKSPACE_ANGLE)
               for sx, sy, sa, sb, sg in [(1, 1, 1, 1, 1), (-1, 1, -1, 1, -1), (1, -1, 1, -1, -1)]]
    for pose in random_postures(seed=4, n=30) + corners:
        q = hexapod_device.solve_fk(leg_lengths(a, b, pose) - lengths0)
        readings = {j: joint_value(hexapod_device, q, j) for j in DEVICE_JOINTS}
        expected = device_readings(pose)
        for joint in DEVICE_JOINTS:
            assert readings[joint] == pytest.approx(expected[joint], abs=1e-9), joint
        # Study 001 Eq. 6-7: the readings give back the position of P.
        alpha, beta = readings["device_incl_x"], readings["device_incl_y"]
        dist = DEVICE_D0 + readings["device_lvdt"]
        position = dist * np.array([np.cos(alpha) * np.sin(beta), -np.sin(alpha),
                                    np.cos(alpha) * np.cos(beta)])
        assert np.linalg.norm(position - pose.translation) < POSE_TOL


def test_device_does_not_change_the_platform_kinematics(hexapod: pincal.Robot, hexapod_device: pincal.Robot,
                                                        geometry: tuple[Array, Array, Array]) -> None:
    a, b, lengths0 = geometry
    for pose in random_postures(seed=5, n=20):
        q_actuated = leg_lengths(a, b, pose) - lengths0
        q_plain = hexapod.solve_fk(q_actuated)
        q_device = hexapod_device.solve_fk(q_actuated)
        assert max(pose_error(hexapod_device.placement(q_device, "end_effector"),
                              hexapod.placement(q_plain, "end_effector"))) < POSE_TOL
        assert np.allclose(hexapod_device.frame_jacobian_actuated(q_device, "end_effector"),
                           hexapod.frame_jacobian_actuated(q_plain, "end_effector"), atol=1e-8)


# --- derivatives through the loops ------------------------------------------------------------------
def test_closed_loop_jacobian_matches_finite_differences_and_closed_form(
        hexapod: pincal.Robot, geometry: tuple[Array, Array, Array]) -> None:
    a, b, lengths0 = geometry
    step = 1e-6  # [m]
    for pose in random_postures(seed=6, n=5):
        q = hexapod.solve_fk(leg_lengths(a, b, pose) - lengths0)
        jac = hexapod.frame_jacobian_actuated(q, "end_effector")  # LOCAL_WORLD_ALIGNED (v, ω)
        assert jac.shape == (6, 6)
        q_actuated = hexapod.actuated_values(q)
        numeric = np.empty((6, 6))
        for k in range(6):
            plus, minus = q_actuated.copy(), q_actuated.copy()
            plus[k] += step
            minus[k] -= step
            m_plus = hexapod.placement(hexapod.solve_fk(plus, q_guess=q), "end_effector")
            m_minus = hexapod.placement(hexapod.solve_fk(minus, q_guess=q), "end_effector")
            numeric[:3, k] = (m_plus.translation - m_minus.translation) / (2 * step)
            numeric[3:, k] = pin.log3(m_plus.rotation @ m_minus.rotation.T) / (2 * step)
        assert np.max(np.abs(jac - numeric)) < 1e-6
        # The closed-loop Jacobian inverts the hexapod's closed-form inverse Jacobian.
        assert np.max(np.abs(inverse_jacobian(a, b, pose) @ jac - np.eye(6))) < 1e-9
