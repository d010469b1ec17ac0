"""A camera on one chain seeing a board on another (``cross_pixel``): TIAGo's head camera and a board in its gripper.

Simulated campaigns (``simulate_cross_pixels``): 40 images to calibrate from, 20 held out, a ChArUco board of 8 × 6
squares of 30 mm in the gripper (``arm_tool_link``), the camera on ``head_2_link`` (1280 × 960 px, fx ≈ 1000 px,
barrel distortion), corner noise σ 0.3 px, robot geometric errors σ 1 mm / 1 mrad on every parameter of the default
set. Held-out error: the camera's position in the board's frame at the 20 held-out postures (the head's and the
arm's chains between them, with the camera's and the board's placements), predicted against the truth (RMS, mm).
Two calibrations from the same pixels: **pincal** (``pincal.calibrate``, default options: robot geometry, camera,
board and intrinsics jointly, started without help) and **perfect kinematics** (the robot's geometry held at its
truth, only the camera, the board and the intrinsics fitted: what the images could give at best). Also each
intrinsic's deviation from the truth in units of its σ.

Run: ``python examples/pixels_two_chains.py`` (prints one line per seed).
"""

from __future__ import annotations

import numpy as np
import pinocchio as pin
from scipy.optimize import least_squares

import pincal
from pincal.calibration.cross_campaign import simulate_cross_pixels
from pincal.calibration.pixel_campaign import DEFAULT_INTRINSICS, PixelSimulation
from pincal.identification.problem import CalibrationProblem, Observations

CAMERA, HAND = "head_2_link", "arm_tool_link"
N_TRAIN, N_TEST, NOISE, PERTURB = 40, 20, 0.3, 1e-3
SEEDS = (1, 2, 3)
SETUP = ("camera", "target", "intrinsics")


def placement(sim: PixelSimulation, x: np.ndarray, prefix: str) -> pin.SE3:
    """The attached placement ``prefix`` (``camera.<frame>``, ``target.<frame>@board``) at ``x``: exp6 of its six
    parameters."""
    return pin.exp6(np.array([x[sim.parameters.index(f"{prefix}.{c}")] for c in ("tx", "ty", "tz", "rx", "ry", "rz")]))


def camera_in_board(sim: PixelSimulation, x: np.ndarray, actuated: np.ndarray) -> list[pin.SE3]:
    """The camera's placement in the board's frame (board ← camera) at each row of ``actuated``, by the robot and
    setup at ``x``."""
    problem = CalibrationProblem(sim.robot, sim.parameters, sim.measurements,
                                 Observations.neutral(sim.measurements, actuated))
    robot = problem.robot_at(x)
    camera, board = placement(sim, x, f"camera.{CAMERA}"), placement(sim, x, f"target.{HAND}@board")
    out = []
    for qa in problem.actuated_values(x):
        q = robot.solve_fk(qa)
        out.append((robot.placement(q, HAND) * board).actInv(robot.placement(q, CAMERA) * camera))
    return out


def perfect_kinematics(sim: PixelSimulation, train) -> np.ndarray:
    """The setup fitted to the training pixels on the true robot: the robot's parameters held at their truth."""
    problem = CalibrationProblem(sim.robot, sim.parameters, sim.measurements,
                                 Observations(train.joints, train.measurements))
    free = [k for k, p in enumerate(sim.parameters) if p.kind in SETUP]
    x = sim.x_true.copy()
    x[free] = problem.initial_guess()[free]

    def residual(v: np.ndarray) -> np.ndarray:
        x[free] = v
        return problem.evaluate(x, jacobian=False).residual

    def jacobian(v: np.ndarray) -> np.ndarray:
        x[free] = v
        return problem.evaluate(x).jacobian[:, free]

    x[free] = least_squares(residual, x[free], jac=jacobian, method="lm", x_scale="jac", xtol=1e-12, ftol=1e-12).x
    return x


def rms_mm(truth: list[pin.SE3], predicted: list[pin.SE3]) -> float:
    """RMS [mm] of the position differences."""
    errors = [np.linalg.norm(a.translation - b.translation) for a, b in zip(truth, predicted, strict=True)]
    return float(np.sqrt(np.mean(np.square(errors))) * 1e3)


def main() -> None:
    robot = pincal.load_robot("tiago_no_hand")
    for seed in SEEDS:
        sim = simulate_cross_pixels(robot, CAMERA, HAND, N_TRAIN, N_TEST, perturb=PERTURB, noise=NOISE, seed=seed)
        data = sim.dataset
        train, test = data.of_set("train"), data.of_set("test")
        truth = camera_in_board(sim, sim.x_true, test.joints)
        cal = pincal.calibrate(robot, data)
        fitted = dict(zip(cal.result.names, cal.result.x.tolist(), strict=True))
        std = dict(zip(cal.result.names, cal.result.std.tolist(), strict=True))
        x_cal = np.array([fitted.get(name, 0.0) for name in sim.parameters.names])
        ours = rms_mm(truth, camera_in_board(sim, x_cal, test.joints))
        best = rms_mm(truth, camera_in_board(sim, perfect_kinematics(sim, train), test.joints))
        names = [f"intrinsics.{CAMERA}.{c}" for c in ("fx", "fy", "cx", "cy", "k1", "k2")]
        sigmas = " ".join(f"{n.rpartition('.')[2]} {(fitted[n] - DEFAULT_INTRINSICS[k]) / std[n]:+.2f}σ"
                          for k, n in enumerate(names))
        print(f"seed {seed}: held-out camera-in-board position RMS: pincal {ours:.3f} mm, perfect kinematics "
              f"{best:.3f} mm, ratio {ours / best:.2f}; intrinsics {sigmas}")


if __name__ == "__main__":
    main()
