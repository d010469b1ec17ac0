"""Generate the 6-UPS Gough–Stewart hexapod of study 001, with and without its measuring device.

Writes ``robots_urdf/hexapod.urdf`` and ``robots_urdf/hexapod_device.urdf``::

    python tools/urdfgen/hexapod.py

Study 001 (Gough–Stewart platform calibrated with a passive U-P-U-R measuring link) lost its geometry
tables, so the geometry below is chosen: large enough for its postures (±400 mm in X and Y, rotations
within ±20°) with the legs far from singular over that range (checked by :func:`workspace_report`,
run at every generation and written into the files' comment blocks).

Conventions (SI units, metres and radians):

- World = base frame, origin O = centre of the device's lower U joint, Z up (against gravity).
- Platform frame origin P = centre of the device's upper U joint; at the reference configuration
  P = (0, 0, ``HEIGHT``) and the platform is parallel to the base.
- Leg i: base U joint centre A_i (in the base frame), platform S joint centre B_i (in the platform
  frame), leg length L_i = ||R B_i + t - A_i|| (study 001 Eq. 4) = L0_i + q_i, with q_i the prismatic
  joint ``leg_i_prismatic`` and L0_i the reference length (study 001 Eq. 5: L0_i is the length offset).
- Postures in study 001 Eq. 1-2: (x, y, z, α, β, γ), R = R_Y(β) R_X(α) R_z(γ).
- Device (study 001 Eq. 6-8): D = D0 + Dm = ||P - O||, with D0 = ``DEVICE_D0`` and Dm the LVDT joint;
  the link direction is R_Y(β) R_X(α) e_z = (cos α sin β, -sin α, cos α cos β), so the base U joint
  is ``device_incl_y`` (β, about the base Y axis) followed by ``device_incl_x`` (α, about the link's
  X axis). The upper U joint is ``device_upper_u1`` (link x) then ``device_upper_u2`` (y), and the
  rotary sensor ``device_rotary`` turns about the platform z axis through P:
  R = R_Y(β) R_X(α) R_x(u1) R_y(u2) R_z(rotary).
"""

from __future__ import annotations

import itertools
from dataclasses import dataclass
from pathlib import Path

import numpy as np
from numpy.typing import NDArray

try:  # run as a module (python -m tools.urdfgen.hexapod)
    from .common import UrdfWriter, box, cylinder, rod_rpy, sphere
except ImportError:  # run as a script (python tools/urdfgen/hexapod.py)
    from common import UrdfWriter, box, cylinder, rod_rpy, sphere  # type: ignore[no-redef]

Array = NDArray[np.float64]

# --- Chosen geometry -------------------------------------------------------------------------------
BASE_RADIUS = 0.9  # [m] circle of the base U-joint centres A_i
BASE_HALF_ANGLE = np.radians(10.0)  # [rad] A_i pairs at 0°, 120°, 240° ± this
PLATFORM_RADIUS = 0.5  # [m] circle of the platform S-joint centres B_i
PLATFORM_HALF_ANGLE = np.radians(10.0)  # [rad] B_i pairs at 60°, 180°, 300° ± this
HEIGHT = 0.85  # [m] reference height of P above O (= the device's fixed length D0)
DEVICE_D0 = 0.85  # [m] study 001: true fixed length of the measuring link

# --- Workspace of study 001 (section 4.2) ----------------------------------------------------------
WORKSPACE_XY = 0.4  # [m] |x|, |y| <= this
WORKSPACE_DZ = 0.05  # [m] |z - HEIGHT| <= this (study 001 gives no z range)
WORKSPACE_ANGLE = np.radians(20.0)  # [rad] |α|, |β|, |γ| <= this (a 40° range)

# --- Joint limits (checked against the workspace by workspace_report) ------------------------------
LEG_STROKE = (-0.55, 0.80)  # [m] prismatic q_i = L_i - L0_i
LEG_U_LIMIT = 1.0  # [rad] both base U-joint angles of each leg
DEVICE_TILT_LIMIT = 1.0  # [rad] device_incl_x, device_incl_y, device_upper_u1, device_upper_u2
DEVICE_LVDT_STROKE = (-0.15, 0.35)  # [m] Dm

URDF_DIR = Path(__file__).resolve().parents[2] / "robots_urdf"


@dataclass(frozen=True)
class HexapodGeometry:
    """Nominal geometry, all arrays in double precision.

    Attributes:
        base_joints: (6, 3) A_i [m] in the base frame.
        platform_joints: (6, 3) B_i [m] in the platform frame.
        height: [m] z of P at the reference configuration.
        reference_lengths: (6,) L0_i [m].
    """

    base_joints: Array
    platform_joints: Array
    height: float
    reference_lengths: Array


def hexapod_geometry() -> HexapodGeometry:
    """The chosen hexapod: legs 2k, 2k+1 start from the base pair at 120k° and cross to the
    platform pairs at 120k° - 60° and 120k° + 60°."""
    base, platform = [], []
    for k in range(3):
        centre = np.radians(120.0 * k)
        for side in (-1.0, 1.0):
            a = centre + side * BASE_HALF_ANGLE
            b = centre + side * (np.radians(60.0) - PLATFORM_HALF_ANGLE)
            base.append([BASE_RADIUS * np.cos(a), BASE_RADIUS * np.sin(a), 0.0])
            platform.append([PLATFORM_RADIUS * np.cos(b), PLATFORM_RADIUS * np.sin(b), 0.0])
    base_joints = np.array(base, dtype=np.float64)
    platform_joints = np.array(platform, dtype=np.float64)
    p = np.array([0.0, 0.0, HEIGHT])
    lengths = np.linalg.norm(platform_joints + p - base_joints, axis=1)
    return HexapodGeometry(base_joints, platform_joints, HEIGHT, lengths)


def rot_x(a: float) -> Array:
    c, s = np.cos(a), np.sin(a)
    return np.array([[1.0, 0.0, 0.0], [0.0, c, -s], [0.0, s, c]])


def rot_y(a: float) -> Array:
    c, s = np.cos(a), np.sin(a)
    return np.array([[c, 0.0, s], [0.0, 1.0, 0.0], [-s, 0.0, c]])


def rot_z(a: float) -> Array:
    c, s = np.cos(a), np.sin(a)
    return np.array([[c, -s, 0.0], [s, c, 0.0], [0.0, 0.0, 1.0]])


def posture_rotation(alpha: float, beta: float, gamma: float) -> Array:
    """Study 001 Eq. 2: R = R_Y(β) R_X(α) R_z(γ)."""
    return rot_y(beta) @ rot_x(alpha) @ rot_z(gamma)


def leg_frame(direction: Array) -> Array:
    """Rotation of a frame whose z axis points along ``direction`` (the same as ``rod_rpy``)."""
    _, pitch, yaw = rod_rpy(direction.tolist())
    return rot_z(yaw) @ rot_y(pitch)


def workspace_report(geo: HexapodGeometry, samples: int = 20000, seed: int = 0) -> dict[str, float]:
    """Checks the workspace numerically: random postures plus all 2^6 corners.

    Returns the smallest singular value and the largest condition number of the inverse kinematic
    Jacobian (rows [u_i, (R B_i) x u_i], mapping platform twist (v_P, ω) to leg rates), the ranges of
    leg stroke, base U-joint angles and device joint angles; raises if a range leaves its limit.
    """
    rng = np.random.default_rng(seed)
    lim = np.array([WORKSPACE_XY, WORKSPACE_XY, WORKSPACE_DZ] + [WORKSPACE_ANGLE] * 3)
    postures = rng.uniform(-lim, lim, size=(samples, 6))
    corners = np.array(list(itertools.product(*[(-v, v) for v in lim])))
    postures = np.vstack([postures, corners])
    frames = [leg_frame(geo.platform_joints[i] + [0, 0, geo.height] - geo.base_joints[i]) for i in range(6)]
    sigma_min, cond_max = np.inf, 0.0
    stroke = [np.inf, -np.inf]
    u_max = 0.0
    device_tilt_max = 0.0
    lvdt = [np.inf, -np.inf]
    for x, y, dz, alpha, beta, gamma in postures:
        rot = posture_rotation(alpha, beta, gamma)
        t = np.array([x, y, geo.height + dz])
        legs = (geo.platform_joints @ rot.T) + t - geo.base_joints
        lengths = np.linalg.norm(legs, axis=1)
        u = legs / lengths[:, None]
        jac = np.hstack([u, np.cross(geo.platform_joints @ rot.T, u)])
        s = np.linalg.svd(jac, compute_uv=False)
        sigma_min = min(sigma_min, s[-1])
        cond_max = max(cond_max, s[0] / s[-1])
        q = lengths - geo.reference_lengths
        stroke = [min(stroke[0], q.min()), max(stroke[1], q.max())]
        for i in range(6):
            d = frames[i].T @ u[i]  # leg direction in the U-joint frame: R_y(θ1) R_x(θ2) e_z
            u_max = max(u_max, abs(np.arcsin(-d[1])), abs(np.arctan2(d[0], d[2])))
        dist = float(np.linalg.norm(t))
        lvdt = [min(lvdt[0], dist - DEVICE_D0), max(lvdt[1], dist - DEVICE_D0)]
        a_dev, b_dev = np.arcsin(-t[1] / dist), np.arctan2(t[0], t[2])
        m = (rot_y(b_dev) @ rot_x(a_dev)).T @ rot  # = R_x(u1) R_y(u2) R_z(rotary)
        u1, u2 = np.arctan2(-m[1, 2], m[2, 2]), np.arcsin(np.clip(m[0, 2], -1.0, 1.0))
        device_tilt_max = max(device_tilt_max, abs(a_dev), abs(b_dev), abs(u1), abs(u2))
    report = {
        "sigma_min": float(sigma_min), "cond_max": float(cond_max),
        "stroke_min": float(stroke[0]), "stroke_max": float(stroke[1]), "leg_u_max": float(u_max),
        "device_tilt_max": float(device_tilt_max), "lvdt_min": float(lvdt[0]), "lvdt_max": float(lvdt[1]),
    }
    checks = [
        ("leg stroke", LEG_STROKE[0] < stroke[0] and stroke[1] < LEG_STROKE[1]),
        ("leg U angles", u_max < LEG_U_LIMIT),
        ("device angles", device_tilt_max < DEVICE_TILT_LIMIT),
        ("device LVDT", DEVICE_LVDT_STROKE[0] < lvdt[0] and lvdt[1] < DEVICE_LVDT_STROKE[1]),
        ("conditioning", cond_max < 100.0),
    ]
    bad = [name for name, ok in checks if not ok]
    if bad:
        raise ValueError(f"workspace check failed for {bad}: {report}")
    return report


def comment(geo: HexapodGeometry, report: dict[str, float], with_device: bool) -> str:
    def point(p: Array) -> str:
        return "(" + ", ".join(f"{v:+.6f}" for v in p) + ")"

    rows = "\n".join(
        f"  leg_{i + 1}: A = {point(geo.base_joints[i])}  B = {point(geo.platform_joints[i])}  "
        f"L0 = {geo.reference_lengths[i]:.9f}" for i in range(6))
    half_a, half_b = np.degrees(BASE_HALF_ANGLE), np.degrees(PLATFORM_HALF_ANGLE)
    angle = np.degrees(WORKSPACE_ANGLE)
    text = f"""6-UPS Gough-Stewart hexapod{' with the measuring device' if with_device else ''} of study 001
(Gough-Stewart platform calibrated with a passive measuring link: LVDT, biaxial inclinometer, rotary
sensor; 42 robot parameters = per leg A_i (3), B_i (3), length offset (1)). Generated by
tools/urdfgen/hexapod.py: do not edit by hand. SI units: m, rad.

The paper's geometry tables are lost; chosen geometry (A_i in the base frame, B_i in the platform frame):
  A_i on a circle of radius {BASE_RADIUS} m in pairs at 0, 120, 240 deg +/- {half_a:g} deg, z = 0
  B_i on a circle of radius {PLATFORM_RADIUS} m in pairs at 60, 180, 300 deg +/- {half_b:g} deg, z = 0
  Base frame origin O = (0, 0, 0), the device's lower U centre; platform frame origin P = the device's
  upper U centre; reference height of P: {geo.height} m (= device D0 = {DEVICE_D0} m).
{rows}

Reference configuration (Pinocchio neutral: every joint zero, identity quaternion): platform at
P = (0, 0, {geo.height}), parallel to the base; leg lengths L_i = L0_i + q_i with q_i = leg_i_prismatic.
Leg i: base -> leg_i_u1 (about y of a frame at A_i whose z points along the leg) -> leg_i_cross
(massless) -> leg_i_u2 (about x) -> leg_i_cylinder -> leg_i_prismatic (along z, origin L0_i) ->
leg_i_rod, whose origin is B_i; spherical <loop> leg_i_platform closes it on the platform at B_i.
The platform hangs on the base by the floating joint platform_joint (a Pinocchio free-flyer).
Actuated joints (<transmission>): leg_1_prismatic ... leg_6_prismatic.

Workspace (study 001, section 4.2): |x|, |y| <= {WORKSPACE_XY} m, |z - {geo.height}| <= {WORKSPACE_DZ} m,
Euler angles |alpha|, |beta|, |gamma| <= {angle:g} deg, R = R_Y(beta) R_X(alpha) R_z(gamma)
(study 001 Eq. 2). Checked on 20000 random postures and the 64 corners: inverse Jacobian smallest
singular value {report['sigma_min']:.4f}, largest condition number {report['cond_max']:.2f};
leg strokes q_i in [{report['stroke_min']:.4f}, {report['stroke_max']:.4f}] m; base U angles
<= {report['leg_u_max']:.4f} rad."""
    if with_device:
        text += f"""

Measuring device (study 001 section 3, Eq. 6-8), a passive U-P-U-R link from O to P, not actuated:
  base -> device_incl_y (beta, about the base Y axis, at O) -> device_gimbal_lower (massless)
  -> device_incl_x (alpha, about the link's X axis) -> device_tube_lower -> device_lvdt (Dm, along the
  link z axis, origin D0 = {DEVICE_D0} m) -> device_tube_upper (origin at P) -> device_upper_u1 (about x)
  -> device_gimbal_upper (massless) -> device_upper_u2 (about y) -> device_yoke -> device_rotary (about
  the platform z axis through P) -> device_flange; fixed <loop> device_platform: device_flange = platform.
  D = D0 + Dm = |OP| (Eq. 6); OP = D (cos alpha sin beta, -sin alpha, cos alpha cos beta) (Eq. 7), i.e.
  alpha = asin(-y/D), beta = atan2(x, z) (Eq. 8); R = R_Y(beta) R_X(alpha) R_x(u1) R_y(u2) R_z(rotary).
  The inclinometer axes are perpendicular (psi = 90 deg). At the reference every device joint is zero.
  Over the workspace: device angles <= {report['device_tilt_max']:.4f} rad, Dm in
  [{report['lvdt_min']:.4f}, {report['lvdt_max']:.4f}] m."""
    return text


def build(geo: HexapodGeometry, report: dict[str, float], with_device: bool) -> UrdfWriter:
    name = "hexapod_device" if with_device else "hexapod"
    w = UrdfWriter(name, comment(geo, report, with_device))
    grey, thin = 0.035, 0.02
    w.link("base", cylinder(BASE_RADIUS + 0.1, 0.02, xyz=(0, 0, -0.011)), mass=50.0)
    w.link("platform", cylinder(PLATFORM_RADIUS + 0.05, 0.02, xyz=(0, 0, 0.011)), mass=10.0)
    w.joint("platform_joint", "floating", "base", "platform", xyz=(0.0, 0.0, geo.height))
    w.link("end_effector", sphere(0.02))
    w.joint("end_effector_joint", "fixed", "platform", "end_effector")

    for i in range(6):
        n = i + 1
        a, b = geo.base_joints[i], geo.platform_joints[i]
        length = float(geo.reference_lengths[i])
        direction = b + np.array([0.0, 0.0, geo.height]) - a
        sleeve = 0.55 * length
        w.link(f"leg_{n}_cross", sphere(0.045), mass=0.0)
        w.link(f"leg_{n}_cylinder", cylinder(grey, sleeve, xyz=(0, 0, sleeve / 2)), mass=2.0)
        w.link(f"leg_{n}_rod", cylinder(thin, sleeve, xyz=(0, 0, -sleeve / 2)), sphere(0.035), mass=1.0)
        w.joint(f"leg_{n}_u1", "revolute", "base", f"leg_{n}_cross", xyz=a, rpy=rod_rpy(direction),
                axis=(0, 1, 0), limits=(-LEG_U_LIMIT, LEG_U_LIMIT))
        w.joint(f"leg_{n}_u2", "revolute", f"leg_{n}_cross", f"leg_{n}_cylinder",
                axis=(1, 0, 0), limits=(-LEG_U_LIMIT, LEG_U_LIMIT))
        w.joint(f"leg_{n}_prismatic", "prismatic", f"leg_{n}_cylinder", f"leg_{n}_rod",
                xyz=(0.0, 0.0, length), axis=(0, 0, 1), limits=LEG_STROKE)
        w.loop(f"leg_{n}_platform", "spherical", f"leg_{n}_rod", (0.0, 0.0, 0.0), "platform", b)

    if with_device:
        tube = 0.5 * DEVICE_D0
        w.link("device_gimbal_lower", sphere(0.03), mass=0.0)
        w.link("device_tube_lower", cylinder(0.018, tube, xyz=(0, 0, tube / 2)),
               box((0.06, 0.06, 0.03), xyz=(0, 0, 0.08)), mass=0.5)  # the box: biaxial inclinometer
        w.link("device_tube_upper", cylinder(0.01, tube, xyz=(0, 0, -tube / 2)), mass=0.2)
        w.link("device_gimbal_upper", sphere(0.025), mass=0.0)
        w.link("device_yoke", cylinder(0.03, 0.02, xyz=(0, 0, 0.02)), mass=0.1)  # rotary sensor body
        w.link("device_flange", box((0.08, 0.08, 0.01), xyz=(0, 0, 0.035)), mass=0.1)
        w.joint("device_incl_y", "revolute", "base", "device_gimbal_lower",
                axis=(0, 1, 0), limits=(-DEVICE_TILT_LIMIT, DEVICE_TILT_LIMIT))
        w.joint("device_incl_x", "revolute", "device_gimbal_lower", "device_tube_lower",
                axis=(1, 0, 0), limits=(-DEVICE_TILT_LIMIT, DEVICE_TILT_LIMIT))
        w.joint("device_lvdt", "prismatic", "device_tube_lower", "device_tube_upper",
                xyz=(0.0, 0.0, DEVICE_D0), axis=(0, 0, 1), limits=DEVICE_LVDT_STROKE)
        w.joint("device_upper_u1", "revolute", "device_tube_upper", "device_gimbal_upper",
                axis=(1, 0, 0), limits=(-DEVICE_TILT_LIMIT, DEVICE_TILT_LIMIT))
        w.joint("device_upper_u2", "revolute", "device_gimbal_upper", "device_yoke",
                axis=(0, 1, 0), limits=(-DEVICE_TILT_LIMIT, DEVICE_TILT_LIMIT))
        w.joint("device_rotary", "revolute", "device_yoke", "device_flange",
                axis=(0, 0, 1), limits=(-np.pi, np.pi))
        w.loop("device_platform", "fixed", "device_flange", (0.0, 0.0, 0.0), "platform", (0.0, 0.0, 0.0))

    for i in range(6):
        w.transmission(f"leg_{i + 1}_prismatic")
    return w


def main() -> None:
    geo = hexapod_geometry()
    report = workspace_report(geo)
    for with_device, filename in ((False, "hexapod.urdf"), (True, "hexapod_device.urdf")):
        path = URDF_DIR / filename
        build(geo, report, with_device).write(str(path))
        print(f"wrote {path}")
    print("workspace: " + ", ".join(f"{k} = {v:.4f}" for k, v in report.items()))


if __name__ == "__main__":
    main()
