"""A camera's fit is taken on to the least-squares minimum: LM's noise-level stop discounts the weakly seen
directions (a board's rotation on the hand trading with the wrist's parameters), and what it leaves along them once
doubled the held-out error of a Panda eye-to-hand campaign (seed 2 of docs/results/pixels_handeye.md: χ² 14.9 left).
Problems without a camera's intrinsics are left as LM stops them."""

from __future__ import annotations

from typing import Any

import numpy as np
import pytest
from scipy.optimize import least_squares

import pincal
from pincal.calibration.pixel_campaign import PixelSimulation, simulate_pixels
from pincal.identification import solver as solver_module
from pincal.identification.fit_options import FitOptions
from pincal.identification.parameters import ParameterSet
from pincal.identification.problem import CalibrationProblem, Observations
from pincal.identification.result import CalibrationResult


@pytest.fixture(scope="module")
def campaign() -> tuple[pincal.Robot, PixelSimulation, CalibrationProblem]:
    robot = pincal.load_robot("panda")
    sim = simulate_pixels(robot, "panda_hand", 40, 20, eye_to_hand=True, perturb=1e-3, noise=0.3, seed=2)
    train = sim.dataset.of_set("train")
    problem = CalibrationProblem(robot, sim.parameters, sim.measurements,
                                 Observations(train.joints, train.measurements))
    return robot, sim, problem


def _gap(problem: CalibrationProblem, result: CalibrationResult) -> float:
    """The χ² ``result``'s estimate has above the least-squares minimum plain Levenberg–Marquardt (MINPACK, every
    parameter, tight tolerances) reaches from it."""
    x = np.zeros(len(problem.parameters))
    for name, value in zip(result.names, result.x.tolist(), strict=True):
        x[problem.parameters.index(name)] = value

    def chi2(v: np.ndarray) -> float:
        return float(np.sum(problem.evaluate(v, jacobian=False).residual ** 2))

    fitted = least_squares(lambda v: problem.evaluate(v, jacobian=False).residual, x,
                           jac=lambda v: problem.evaluate(v).jacobian, method="lm", x_scale="jac",
                           xtol=1e-12, ftol=1e-12)
    return chi2(x) - chi2(np.asarray(fitted.x, dtype=float))


def test_the_eye_to_hand_calibration_ends_at_the_least_squares_minimum(
        campaign: tuple[pincal.Robot, PixelSimulation, CalibrationProblem],
        monkeypatch: pytest.MonkeyPatch) -> None:
    robot, sim, problem = campaign
    polished = pincal.calibrate(robot, sim.dataset).result
    assert polished.extra["polished"] is True
    assert _gap(problem, polished) < 3.0  # was 14.9 (below)

    def unpolished(problem: Any, result: CalibrationResult, *args: Any) -> CalibrationResult:
        return result

    monkeypatch.setattr(solver_module, "_polished", unpolished)
    stopped = pincal.calibrate(robot, sim.dataset).result
    assert stopped.message == solver_module.NOISE_LEVEL_STOP
    assert _gap(problem, stopped) > 10.0  # what LM's stop leaves: the case the polish is for


def test_a_problem_without_intrinsics_is_not_polished(
        campaign: tuple[pincal.Robot, PixelSimulation, CalibrationProblem]) -> None:
    _, sim, problem = campaign
    result = solver_module.fitting.fit(problem)
    assert result.message == solver_module.NOISE_LEVEL_STOP

    class WithoutIntrinsics:  # the same fit, seen by a problem whose parameters have no intrinsics
        parameters = ParameterSet([p for p in sim.parameters if p.kind != "intrinsics"])

    assert solver_module._polished(WithoutIntrinsics(), result, FitOptions(), "linear") is result  # type: ignore[arg-type]
    assert solver_module._polished(problem, result, FitOptions(), "linear") is not result
