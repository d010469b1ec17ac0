"""Closed-form Delta kinematics (study 000 geometry) used to check pincal's general solvers.

Leg i lies in the vertical plane at angle theta_i; the arm (length La) turns about the tangential
axis at A_i = Rb (cos, sin, 0); alpha > 0 lowers it. The rod (length Lb) joins the elbow B_i to
C_i = P + Rn (cos, sin, 0) on the platform, whose centre is P. Units: m, rad.
"""

from __future__ import annotations

import math

import numpy as np

LA, LB, RB, RN = 0.260, 0.480, 0.194, 0.030
THETAS = (0.0, 2.0 * math.pi / 3.0, 4.0 * math.pi / 3.0)


def _leg_frame(theta: float) -> np.ndarray:
    c, s = math.cos(theta), math.sin(theta)
    return np.array([[c, -s, 0.0], [s, c, 0.0], [0.0, 0.0, 1.0]])


def elbow(alpha: float, theta: float) -> np.ndarray:
    """B_i in the world frame [m]."""
    return _leg_frame(theta) @ np.array([RB + LA * math.cos(alpha), 0.0, -LA * math.sin(alpha)])


def inverse(p: np.ndarray) -> np.ndarray:
    """Arm angles [rad] placing the platform centre at ``p`` (the elbow-out branch)."""
    out = np.empty(3)
    for i, theta in enumerate(THETAS):
        c = _leg_frame(theta).T @ p + np.array([RN - RB, 0.0, 0.0])  # C_i - A_i in the leg frame
        # |c - La (cos a, 0, -sin a)|^2 = Lb^2  ->  k1 cos a + k2 sin a = k3
        k1, k2 = -2.0 * LA * c[0], 2.0 * LA * c[2]
        k3 = LB**2 - c @ c - LA**2
        rho = math.hypot(k1, k2)
        if abs(k3) > rho:
            raise ValueError("unreachable")
        phi = math.atan2(k2, k1)
        roots = (phi - math.acos(k3 / rho), phi + math.acos(k3 / rho))
        # the elbow-out branch (elbow farther from the axis: larger cos a) is the file's assembly
        best = max(roots, key=math.cos)
        out[i] = math.atan2(math.sin(best), math.cos(best))
    return out


def forward(alpha: np.ndarray) -> np.ndarray:
    """Platform centre [m] for arm angles ``alpha``: intersection of three spheres, lower root."""
    centres = [elbow(a, t) - RN * np.array([math.cos(t), math.sin(t), 0.0]) for a, t in zip(alpha, THETAS, strict=True)]
    c1, c2, c3 = centres
    ex = (c2 - c1) / np.linalg.norm(c2 - c1)
    i = ex @ (c3 - c1)
    ey = c3 - c1 - i * ex
    ey /= np.linalg.norm(ey)
    ez = np.cross(ex, ey)
    d = np.linalg.norm(c2 - c1)
    j = ey @ (c3 - c1)
    x = d / 2.0
    y = (i**2 + j**2 - 2.0 * i * x) / (2.0 * j)
    z = math.sqrt(LB**2 - x**2 - y**2)
    candidates = [c1 + x * ex + y * ey + s * z * ez for s in (1.0, -1.0)]
    return min(candidates, key=lambda p: p[2])
