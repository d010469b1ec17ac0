"""The 3-UCR parallel manipulator of study 004 (``robots_urdf/ucr3.urdf``).

pincal's general closed-loop solvers are checked against the closed form of this limb structure. A
limb is R (base, axis tangent to the base circle) - C (actuated translation + passive rotation along
A_i -> a_i) - U (platform); the C rotation and the U make a spherical joint at a_i, so the limb keeps
a_i in the vertical plane through z and A_i, as a 3-RPS limb does. With the paper's quaternion
(q0, q1, q2, q3), the platform centre is then (study 004, Eqs. 8 and 10, and our Eq. 9):

    x_O' = -2 rho q1 q2,   y_O' = rho (q2^2 - q1^2),   q3 = 0,   rho = L_m / sqrt3 = 50 mm,

and E = O' + L_O'E z'. The paper's Table 2 is checked against this model: its poses were generated
with the printed Eqs. (8)-(9) and z_O' = 300 mm, but its printed Eq. (9) is not the limbs' constraint,
so the poses do not close; its limb lengths r2, r3 agree with this model, r1 only for groups 1 and 4.
"""

from __future__ import annotations

import importlib.util
import math
import sys
from itertools import product

import numpy as np
import numpy.typing as npt
import pinocchio as pin
import pytest
import yourdfpy
from conftest import ROOT
from scipy.optimize import least_squares

import pincal

Array = npt.NDArray[np.float64]

UCR3 = ROOT / "robots_urdf" / "ucr3.urdf"
GENERATOR = ROOT / "tools" / "urdfgen" / "ucr3.py"
ACTUATED = ["limb_1_prismatic", "limb_2_prismatic", "limb_3_prismatic"]

# Study 004, Table 1 [m].
R_BASE = 0.068  # |O A_i|
R_PLATFORM = 0.050  # |O' a_i|
L_TOOL = 0.220  # L_O'E
SQRT3 = math.sqrt(3.0)
DIRECTIONS = np.array([[0.0, 1.0, 0.0], [SQRT3 / 2, -0.5, 0.0], [-SQRT3 / 2, -0.5, 0.0]])
BASE_JOINTS = R_BASE * DIRECTIONS  # A_i in O-XYZ
PLATFORM_JOINTS = R_PLATFORM * DIRECTIONS  # a_i in O'-X'Y'Z'

# Study 004, Table 2: r1, r2, r3 [mm], xE, yE, zE [mm], q0, q1, q2, q3.
TABLE2 = np.array([
    [300.042, 265.307, 349.770, 219.956, 24.0, 304.4, 0.714, 0.0, 0.7, 0.0],
    [289.905, 269.18, 350.913, 207.073, 58.349, 377.0, 0.823, -0.15, 0.55, 0.0],
    [287.356, 273.15, 350.147, 195.375, 72.150, 392.4, 0.843, -0.20, 0.50, 0.0],
    [296.341, 264.903, 350.822, 220.12, 33.807, 333.0, 0.758, -0.05, 0.65, 0.0],
    [346.459, 308.792, 263.091, -116.446, -169.831, 395.7, 0.847, 0.40, -0.35, 0.0],
    [376.653, 283.193, 270.914, -28.924, -251.544, 357.2, 0.794, 0.60, -0.10, 0.0],
])

# Workspace of the random tests: platform centre height and tilt (rotation about a horizontal axis).
Z_RANGE = (0.25, 0.35)  # z_O' [m]
MAX_TILT = math.radians(60.0)  # [rad]; beyond ~70 deg a cold start may land on another assembly
POSE_TOL = 1e-9  # [m, rad]


# --- closed form --------------------------------------------------------------------------------
def rotation(q1: float, q2: float) -> Array:
    """Platform orientation D_O' (study 004 Eq. 3) for q3 = 0 and q0 = sqrt(1 - q1² - q2²) >= 0."""
    q0 = math.sqrt(max(0.0, 1.0 - q1 * q1 - q2 * q2))
    return pin.Quaternion(q0, q1, q2, 0.0).toRotationMatrix()


def platform_centre(z: float, q1: float, q2: float) -> Array:
    """O' [m] in O-XYZ: x, y fixed by the limbs' plane constraints (3-RPS), z free."""
    rho = R_PLATFORM
    return np.array([-2.0 * rho * q1 * q2, rho * (q2 * q2 - q1 * q1), z])


def tool_pose(z: float, q1: float, q2: float) -> pin.SE3:
    """Pose of E (the end effector) for platform height z_O' [m] and quaternion components q1, q2."""
    rot = rotation(q1, q2)
    return pin.SE3(rot, platform_centre(z, q1, q2) + L_TOOL * rot[:, 2])


def limb_lengths(z: float, q1: float, q2: float) -> Array:
    """r_i = |A_i a_i| [m] (study 004 Eq. 4): the closed-form inverse kinematics."""
    rot = rotation(q1, q2)
    joints = platform_centre(z, q1, q2) + PLATFORM_JOINTS @ rot.T
    return np.linalg.norm(joints - BASE_JOINTS, axis=1)


def tilt_coordinates(z: float, tilt: float, azimuth: float) -> tuple[float, float, float]:
    """(z, q1, q2) of a platform tilted by ``tilt`` [rad] about the horizontal axis at ``azimuth``."""
    s = math.sin(tilt / 2.0)
    return z, s * math.cos(azimuth), s * math.sin(azimuth)


def workspace(n: int, seed: int) -> list[tuple[float, float, float]]:
    """Random (z_O', q1, q2), uniform in height and over the disc of tilt vectors up to MAX_TILT."""
    rng = np.random.default_rng(seed)
    return [tilt_coordinates(rng.uniform(*Z_RANGE), MAX_TILT * math.sqrt(rng.uniform()),
                             rng.uniform(-math.pi, math.pi)) for _ in range(n)]


def pose_error(a: pin.SE3, b: pin.SE3) -> float:
    return float(np.max(np.abs(pin.log6(a.actInv(b)).vector)))


# --- helpers on the robot -----------------------------------------------------------------------
@pytest.fixture(scope="module")
def ucr3() -> pincal.Robot:
    return pincal.load_robot(UCR3)


def model_limb_lengths(robot: pincal.Robot, q: Array) -> Array:
    """|A_i a_i| [m] measured in the model: base revolute centre to the U centre."""
    return np.array([np.linalg.norm(robot.placement(q, f"limb_{i}_cross").translation
                                    - robot.placement(q, f"limb_{i}_cylinder").translation)
                     for i in (1, 2, 3)])


def reference_length(robot: pincal.Robot) -> float:
    """r_i at the reference configuration [m]: the actuated value is r_i minus this."""
    return float(model_limb_lengths(robot, robot.q_reference)[0])


def table_group(k: int) -> tuple[Array, pin.SE3, Array]:
    """Table 2 row k: limb lengths [m], pose of E (quaternion normalised), raw quaternion."""
    row = TABLE2[k]
    quat = row[6:] / np.linalg.norm(row[6:])
    rot = pin.Quaternion(*quat).toRotationMatrix()
    return row[:3] / 1000.0, pin.SE3(rot, row[3:6] / 1000.0), quat


def paper_quaternion(m: pin.SE3) -> Array:
    """(q0, q1, q2, q3) of a pose, q0 >= 0 (study 004's order, scalar first)."""
    x, y, z, w = pin.Quaternion(m.rotation).coeffs()
    quat = np.array([w, x, y, z])
    return quat if w >= 0 else -quat


# --- the file -----------------------------------------------------------------------------------
def test_file_is_the_generator_output(monkeypatch: pytest.MonkeyPatch) -> None:
    # the generator puts the repository root on sys.path to import tools.urdfgen: undone after the test, or later
    # worker processes (the fleet's Dask cluster) would import pincal from the source tree instead of the install
    monkeypatch.setattr(sys, "path", list(sys.path))
    spec = importlib.util.spec_from_file_location("ucr3_generator", GENERATOR)
    assert spec is not None and spec.loader is not None
    generator = importlib.util.module_from_spec(spec)
    spec.loader.exec_module(generator)
    assert generator.build().render() == UCR3.read_text(encoding="utf-8")


def test_loads_as_a_tree_in_pinocchio_and_yourdfpy() -> None:
    model = pin.buildModelFromUrdf(str(UCR3))
    assert (model.nq, model.nv) == (22, 21)  # free-flying platform + 3 limbs x 5 joints
    assert model.joints[model.getJointId("platform_floating")].shortname() == "JointModelFreeFlyer"
    urdf = yourdfpy.URDF.load(str(UCR3), load_meshes=False)
    assert "end_effector" in urdf.link_map
    assert urdf.joint_map["platform_floating"].type == "floating"
    assert sum(j.type == "revolute" for j in urdf.robot.joints) == 12


def test_reference_configuration(ucr3: pincal.Robot) -> None:
    q0 = ucr3.q_reference
    assert ucr3.actuated_joints == ACTUATED
    assert [(lp.name, lp.type) for lp in ucr3.loops] == [(f"limb_{i}_platform", "fixed") for i in (1, 2, 3)]
    assert np.max(np.abs(ucr3.closure_residual(q0))) < 1e-12
    assert ucr3.mobility() == 3  # 21 velocities, 18 independent closure rows
    # Table 1 geometry: A_i on the base, a_i on the platform, E 220 mm along the platform normal.
    for i in (1, 2, 3):
        np.testing.assert_allclose(ucr3.placement(q0, f"limb_{i}_cylinder").translation, BASE_JOINTS[i - 1],
                                   atol=1e-15)
    np.testing.assert_allclose(model_limb_lengths(ucr3, q0), limb_lengths(0.3, 0.0, 0.0), atol=1e-15)
    assert pose_error(ucr3.placement(q0, "end_effector"), tool_pose(0.3, 0.0, 0.0)) < 1e-15
    # the actuated joint is the limb length: r_i = r_ref + q_i
    q = ucr3.solve_fk(np.array([0.02, -0.01, 0.03]))
    np.testing.assert_allclose(model_limb_lengths(ucr3, q), reference_length(ucr3) + np.array([0.02, -0.01, 0.03]),
                               atol=1e-12)


# --- Table 2 of study 004 -----------------------------------------------------------------------
def test_table2_poses_follow_the_printed_eqs_8_9_and_do_not_close(ucr3: pincal.Robot) -> None:
    """The table's poses are Eqs. (8)-(9) at z_O' = 300 mm; Eq. (9) breaks limbs 2 and 3's constraint."""
    rho = R_PLATFORM
    offsets = []
    for k in range(len(TABLE2)):
        _, pose, (_, q1, q2, q3) = table_group(k)
        rot = pose.rotation
        centre = pose.translation - L_TOOL * rot[:, 2]
        assert q3 == 0.0  # Eq. (10)
        assert abs(centre[2] - 0.300) < 0.4e-3
        assert abs(centre[0] - (-2.0 * rho * q1 * q2)) < 0.2e-3  # Eq. (8): the table agrees
        printed_eq9 = rho / 2.0 * (4.0 * q2 * q2 - 2.0 * q1 * q1 - 1.0)  # reading of the printed Eq. (9)
        assert abs(centre[1] - printed_eq9) < 0.1e-3
        # Each base revolute keeps a_i in the plane through A_i normal to its axis: the closure.
        q_ref = ucr3.q_reference
        joints = centre + PLATFORM_JOINTS @ rot.T
        offsets.append([ucr3.placement(q_ref, f"limb_{i}_cylinder").rotation[:, 0]
                        @ (joints[i - 1] - BASE_JOINTS[i - 1]) for i in (1, 2, 3)])
    offsets_mm = np.abs(np.array(offsets)) * 1000.0
    assert np.all(offsets_mm[:, 0] < 0.2)  # limb 1: Eq. (8) is its constraint
    assert np.all(offsets_mm[:, 1:] > 0.4)  # limbs 2, 3: a_i off its plane in every group...
    assert offsets_mm[:, 1:].max() > 20.0  # ...by up to 21 mm (group 6)
    # The poses cannot be reached (a 3-DOF robot, an inconsistent 6D target).
    for k in (1, 5):
        with pytest.raises(pincal.ConvergenceError):
            ucr3.solve_ik(table_group(k)[1])


def test_table2_ik_of_the_closed_pose_gives_the_limb_lengths(ucr3: pincal.Robot) -> None:
    """IK of the pose fixed by the table's independent coordinates (z_E, q1, q2) [the 3 DOF]."""
    r_ref = reference_length(ucr3)
    r1_excess = []
    for k in range(len(TABLE2)):
        r_table, pose, (_, q1, q2, _) = table_group(k)
        z_centre = pose.translation[2] - L_TOOL * pose.rotation[2, 2]
        target = tool_pose(z_centre, q1, q2)
        q = ucr3.solve_ik(target, frame="end_effector")
        assert np.max(np.abs(ucr3.closure_residual(q))) <= 1e-10
        assert pose_error(ucr3.placement(q, "end_effector"), target) < POSE_TOL
        r = ucr3.actuated_values(q) + r_ref
        np.testing.assert_allclose(r, limb_lengths(z_centre, q1, q2), atol=1e-9)  # general = closed form
        np.testing.assert_allclose(target.translation[[0, 2]], pose.translation[[0, 2]], atol=0.2e-3)
        # r2, r3 as tabulated, to the rounding of the table's quaternion (|q| = 1 +- 1.2e-3)
        np.testing.assert_allclose(r[1:], r_table[1:], atol=0.4e-3)
        r1_excess.append(r_table[0] - r[0])
    r1_excess_mm = np.array(r1_excess) * 1000.0
    np.testing.assert_allclose(r1_excess_mm[[0, 3]], 0.0, atol=0.4)  # groups 1 and 4: r1 too
    # groups 2, 3, 5, 6: the table's r1 is 2.5 to 21.9 mm longer than the closed pose needs
    assert np.all(r1_excess_mm[[1, 2, 4, 5]] > 2.0)
    assert np.all(r1_excess_mm[[1, 2, 4, 5]] < 23.0)


def test_table2_fk_of_the_limb_lengths(ucr3: pincal.Robot) -> None:
    r_ref = reference_length(ucr3)
    for k in range(4):  # groups 1-4 assemble
        r_table, pose, quat = table_group(k)
        q = ucr3.solve_fk(r_table - r_ref)
        assert np.max(np.abs(ucr3.closure_residual(q))) <= 1e-10
        m = ucr3.placement(q, "end_effector")
        assert abs(paper_quaternion(m)[3]) < 1e-9  # Eq. (10) holds at every assembly
        if k in (0, 3):  # the groups whose r1 agrees: x_E, z_E within 1 mm, q within 0.002
            np.testing.assert_allclose(m.translation[[0, 2]], pose.translation[[0, 2]], atol=1e-3)
            np.testing.assert_allclose(paper_quaternion(m), quat, atol=2e-3)
    # Groups 5 and 6: no assembly exists; the nearest reachable limb lengths are 2.8 and 9.9 mm away
    # (multi-start least squares over every height and tilt of the closed form).
    for k, gap in ((4, 2.818e-3), (5, 9.893e-3)):
        r_table = table_group(k)[0]
        with pytest.raises(pincal.ConvergenceError):
            ucr3.solve_fk(r_table - r_ref)
        best = min(float(np.linalg.norm(least_squares(_length_mismatch, start, args=(r_table,)).fun))
                   for start in product((-0.3, 0.3), np.linspace(-3.0, 3.0, 5), np.linspace(-3.0, 3.0, 5)))
        assert best == pytest.approx(gap, abs=0.01e-3)


def _length_mismatch(p: Array, r_target: Array) -> Array:
    return _lengths_of_tilt_vector(p) - r_target


def _lengths_of_tilt_vector(p: Array) -> Array:
    """Limb lengths for platform height p[0] and rotation vector (p[1], p[2], 0) (any tilt)."""
    x, y, _, w = pin.Quaternion(pin.exp3(np.array([p[1], p[2], 0.0]))).coeffs()
    sign = 1.0 if w >= 0 else -1.0
    return limb_lengths(p[0], sign * x, sign * y)


# --- the general solver over a workspace --------------------------------------------------------
def test_workspace_is_within_the_prismatic_limits(ucr3: pincal.Robot) -> None:
    r_ref = reference_length(ucr3)
    extension = np.array([limb_lengths(*x) for x in workspace(2000, seed=40)]) - r_ref
    idx = [ucr3.model.joints[ucr3.model.getJointId(name)].idx_q for name in ACTUATED]
    assert np.all(extension > ucr3.model.lowerPositionLimit[idx])
    assert np.all(extension < ucr3.model.upperPositionLimit[idx])


def test_ik_then_fk_round_trip(ucr3: pincal.Robot) -> None:
    r_ref = reference_length(ucr3)
    for x in workspace(100, seed=41):
        target = tool_pose(*x)
        q = ucr3.solve_ik(target, frame="end_effector")
        np.testing.assert_allclose(ucr3.actuated_values(q) + r_ref, limb_lengths(*x), atol=1e-9)
        q_fk = ucr3.solve_fk(ucr3.actuated_values(q))
        assert np.max(np.abs(ucr3.closure_residual(q_fk))) <= 1e-10
        assert pose_error(ucr3.placement(q_fk, "end_effector"), target) < POSE_TOL


def test_cold_start_fk_converges_over_the_workspace(ucr3: pincal.Robot) -> None:
    r_ref = reference_length(ucr3)
    samples = workspace(2000, seed=42)
    failures = 0
    for x in samples:
        qa = limb_lengths(*x) - r_ref
        report = ucr3.solve_fk_report(qa)
        if not report.converged or pose_error(ucr3.placement(report.q, "end_effector"), tool_pose(*x)) > POSE_TOL:
            failures += 1
            continue
        np.testing.assert_allclose(ucr3.actuated_values(report.q), qa, atol=1e-12)
    assert failures <= 0.001 * len(samples)


def test_fk_poses_obey_eqs_8_and_10(ucr3: pincal.Robot) -> None:
    """x_E = -(L_m/sqrt3) 2 q1 q2 + 2 q0 q2 L_O'E (Eq. 8), q3 = 0 (Eq. 10), and y_E as in our Eq. 9."""
    rng = np.random.default_rng(43)
    r_ref = reference_length(ucr3)
    for _ in range(50):
        q = ucr3.solve_fk(rng.uniform(-0.03, 0.03, 3))
        m = ucr3.placement(q, "end_effector")
        q0, q1, q2, q3 = paper_quaternion(m)
        assert abs(q3) < 1e-10
        x_e = -2.0 * R_PLATFORM * q1 * q2 + 2.0 * q0 * q2 * L_TOOL
        y_e = R_PLATFORM * (q2 * q2 - q1 * q1) - 2.0 * q0 * q1 * L_TOOL
        np.testing.assert_allclose(m.translation[:2], [x_e, y_e], atol=1e-10)
        z_centre = m.translation[2] - L_TOOL * m.rotation[2, 2]
        np.testing.assert_allclose(ucr3.actuated_values(q) + r_ref, limb_lengths(z_centre, q1, q2), atol=1e-10)


def test_actuated_jacobian_matches_finite_differences(ucr3: pincal.Robot) -> None:
    eps = 1e-6
    poses = [*workspace(6, seed=44), tilt_coordinates(0.30, math.radians(75.0), 0.3)]
    r_ref = reference_length(ucr3)
    for x in poses:
        qa = limb_lengths(*x) - r_ref
        q = ucr3.solve_ik(tool_pose(*x), frame="end_effector")
        jac = ucr3.frame_jacobian_actuated(q, "end_effector")
        assert jac.shape == (6, 3)
        fd = np.empty((6, 3))
        for k in range(3):
            step = np.zeros(3)
            step[k] = eps
            plus = ucr3.placement(ucr3.solve_fk(qa + step, q_guess=q, tol=1e-14), "end_effector")
            minus = ucr3.placement(ucr3.solve_fk(qa - step, q_guess=q, tol=1e-14), "end_effector")
            fd[:3, k] = (plus.translation - minus.translation) / (2 * eps)
            fd[3:, k] = pin.log3(plus.rotation @ minus.rotation.T) / (2 * eps)  # world-aligned angular
        scale = max(1.0, float(np.max(np.abs(fd))))
        np.testing.assert_allclose(jac, fd, atol=1e-6 * scale)
        assert np.linalg.matrix_rank(jac, tol=1e-6) == 3
