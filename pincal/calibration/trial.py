"""The Monte Carlo trial of ``pincal montecarlo``: a simulated campaign calibrated as a user's would be.

:class:`SimulatedCalibration` is a trial for :func:`~pincal.study.montecarlo.run_monte_carlo`: it draws a campaign
(:func:`~pincal.calibration.campaign.simulate`: true errors, random postures, noisy readings, training and held-out
samples) and calibrates it with :func:`~pincal.calibration.pipeline.calibrate` — the preparation, the fit and the
held-out evaluation of every other command — with no model selection. SI units: m, rad.
"""

from __future__ import annotations

import functools
from collections.abc import Sequence
from typing import Any

import numpy as np

from pincal.calibration.campaign import check_sample_counts, simulate
from pincal.calibration.options import CalibrationOptions
from pincal.calibration.pipeline import calibrate
from pincal.calibration.setup import measurement_models, parameters_for
from pincal.errors import ConvergenceError
from pincal.identification.choices import Solver
from pincal.identification.fit_options import FitOptions
from pincal.identification.metrics import calibration_gain
from pincal.model.robot import Robot, load_robot
from pincal.records import record


@functools.lru_cache(maxsize=8)
def _robot(name_or_path: str) -> Robot:
    """One Robot per process and name, shared by the threads of a pool (its scratch is one per thread)."""
    return load_robot(name_or_path)


@record(frozen=True)
class SimulatedCalibration:
    """A simulated calibration campaign as a Monte Carlo trial; ``level`` is the noise σ [m, rad].

    Each trial draws true errors (σ = ``perturb`` [m, rad]), ``n_train + n_test`` random postures and noisy
    readings from its seed, calibrates from the training postures as ``pincal calibrate`` does (with
    ``--select none``) and reports:

    - ``gain`` [%]: G of study 000 Eq. 4.1 over all parameters, ``gain_identified`` over the identified ones;
    - ``rms_before``, ``rms_after`` [m]: RMS length-type error on the held-out postures (the report's
      ``test_rms_before``/``test_rms_after``: "before" is the nominal robot with its setup registered);
    - ``parameter_error`` [m, rad]: ``max |x̂ − x_true|`` over the identified parameters;
    - ``rank``, ``condition_number``, ``iterations``, ``converged`` (1/0).

    Attributes:
        robot: Robot name or URDF path.
        measurements: Measurement keys (``position:end_effector``, ``joint:device_lvdt``, ...).
        parameters: Named set or patterns (see :func:`pincal.identification.parameters.choose_parameters`); None: the
            default set.
        n_train, n_test: Postures to calibrate from and to validate on.
        perturb: σ of the true parameter errors [m and rad].
        joint_noise: σ of the actuated readings' noise [m or rad] per unit of ``level`` (0: exact).
        solver: ``lm``, ``tsvd`` or ``ridge``.
        spread: Half-range [rad or m] of the random actuated values about the reference, within the URDF limits;
            None: within the URDF limits (:func:`pincal.study.simulation.actuated_ranges`).
    """

    robot: str
    measurements: tuple[str, ...]
    parameters: tuple[str, ...] | None = None
    n_train: int = 30
    n_test: int = 20
    perturb: float = 1e-3
    joint_noise: float = 0.0
    solver: Solver = FitOptions.solver
    spread: float | None = None

    def __call__(self, seed: int, level: Any) -> dict[str, float]:
        """Run the trial of ``seed`` at noise σ ``level`` [m, rad]; its metrics (only ``converged`` if it did not)."""
        noise = float(level or 0.0)
        robot = _robot(self.robot)
        spec = list(self.parameters) if self.parameters else None
        sim = simulate(robot, self.measurements, self.n_train, self.n_test, perturb=self.perturb, noise=noise,
                       seed=seed, parameter_spec=spec, spread=self.spread, joint_noise=noise * self.joint_noise)
        options = CalibrationOptions(parameter_spec=self.parameters, select="none", solver=self.solver)
        try:
            cal = calibrate(robot, sim.dataset, options)
        except ConvergenceError:
            return {"converged": 0.0}
        result = cal.result
        # the truth of the parameters calibrated (the default set leaves out those that move no measurement)
        x_true = sim.x_true[[sim.parameters.index(name) for name in result.names]]
        metrics = {
            "gain": calibration_gain(x_true, result.x0, result.x),
            "gain_identified": calibration_gain(x_true[result.identified], result.x0[result.identified],
                                                result.x[result.identified]),
            "parameter_error": float(np.max(np.abs(result.x - x_true)[result.identified])),
            "rank": float(result.identifiability.rank),
            "condition_number": float(result.identifiability.condition_number),
            "iterations": float(result.iterations),
            "converged": float(result.converged),
        }
        if cal.held_out is not None:
            figures = cal.held_out.figures()
            metrics["rms_before"], metrics["rms_after"] = figures["test_rms_before"], figures["test_rms_after"]
        return metrics


def monte_carlo_trial(robot: Robot, source: str, measure: Sequence[str], frame: str | None,
                      parameters: Sequence[str] | None, n_train: int, n_test: int, perturb: float, solver: Solver,
                      spread: float | None) -> tuple[SimulatedCalibration, int]:
    """The trial of ``pincal montecarlo`` on ``robot`` (loaded from ``source``, a name or a URDF path the worker
    processes load again), measuring ``measure`` (words as :func:`~pincal.calibration.setup.measurement_models` reads
    them), and the number of parameters it calibrates; checked here, once, rather than in every worker.

    Raises:
        DataError: sample counts :func:`~pincal.calibration.campaign.simulate` cannot give; a measurement or a
            parameter pattern that does not fit the robot (NotFoundError).
    """
    check_sample_counts(n_train, n_test)
    models = measurement_models(robot, measure, frame, 1e-5)
    n_parameters = len(parameters_for(robot, models, parameters))
    trial = SimulatedCalibration(source, tuple(m.key for m in models), tuple(parameters) if parameters else None,
                                 n_train=n_train, n_test=n_test, perturb=perturb, solver=solver, spread=spread)
    return trial, n_parameters
