"""Every measurement model's analytic Jacobian against finite differences, on every reference robot
it applies to, with all candidate parameters (placements, anchors, offsets, base, markers)."""

from __future__ import annotations

import numpy as np
import pytest
from conftest import finite_difference_jacobian

import pincal
from pincal.identification import measurements as ms
from pincal.identification.parameters import candidate_parameters
from pincal.identification.problem import CalibrationProblem, Observations
from pincal.study.simulation import random_actuated

DEVICE = ("device_incl_x", "device_incl_y", "device_lvdt", "device_rotary")

CASES = {
    "delta": lambda: [ms.position("end_effector"), ms.pose("end_effector")],
    "ur10": lambda: [ms.position("tool0"), ms.pose("tool0"), ms.distance("tool0", "base_link")],
    "hexapod": lambda: [ms.pose("end_effector")],
    "hexapod_device": lambda: [ms.joint_reading(j) for j in DEVICE],
    "five_bar": lambda: [ms.joint_reading("scale_joint"), ms.position("end_effector"),
                         ms.distance("base_link", "end_effector", increment=True)],
    "ucr3": lambda: [ms.pose("end_effector"), ms.position("end_effector")],
}


def _blank(models: list, n: int) -> dict[str, np.ndarray]:
    out = {}
    for m in models:
        values = np.zeros((n, len(m.columns)))
        if isinstance(m, ms.Pose):
            values[:, 6] = 1.0  # qw: the identity rotation
        if m.incremental:
            values[0] = np.nan
        out[m.key] = values
    return out


@pytest.mark.parametrize("name", sorted(CASES))
def test_measurement_jacobians_match_finite_differences(name: str) -> None:
    robot = pincal.load_robot(name)
    models = CASES[name]()
    frames = sorted({f for m in models for f in m.frames})
    read = [m.joint for m in models if isinstance(m, ms.JointReading)]
    pset = candidate_parameters(robot, frames=frames, offsets=list(robot.actuated_joints) + read,
                                base=True, markers=True)
    rng = np.random.default_rng(11)
    qa, _ = random_actuated(robot, 5, rng)
    problem = CalibrationProblem(robot, pset, models, Observations(qa, _blank(models, 5)))
    x = rng.normal(scale=1e-3, size=len(pset))
    jac = problem.evaluate(x).jacobian
    assert jac is not None
    fd = finite_difference_jacobian(problem, x)
    scale = np.max(np.abs(fd))
    worst = np.max(np.abs(jac - fd), axis=0) / scale
    assert worst.max() < 2e-5, f"worst column {pset.names[int(np.argmax(worst))]}: {worst.max():.2e}"
