"""Experiment design: which postures to measure, chosen among random reachable candidates by the conditioning of the
scaled identification Jacobian, and compared with random sets of the same size.

:func:`design_poses` draws the candidates (:func:`~pincal.study.simulation.random_actuated`), linearises the
calibration problem at each (the measurement models and parameters as :mod:`pincal.calibration.setup` chooses them),
stacks each posture's rows of the identification Jacobian (:func:`~pincal.study.pose_selection.jacobian_blocks`) and
chooses by condition number or D-optimality (:func:`~pincal.study.pose_selection.select_poses`). SI units: m, rad.
"""

from __future__ import annotations

from collections.abc import Sequence
from dataclasses import dataclass

import numpy as np
import numpy.typing as npt

from pincal.calibration.setup import measurement_models, parameters_for
from pincal.errors import DataError, listing
from pincal.identification.measurements import Measurement
from pincal.identification.parameters import ParameterSet
from pincal.identification.problem import CalibrationProblem, Observations
from pincal.io.dataset import MAX_SAMPLES
from pincal.model.robot import Robot
from pincal.study.pose_selection import PoseSelection, condition_number, jacobian_blocks, log_det, select_poses
from pincal.study.simulation import random_actuated

Array = npt.NDArray[np.float64]

#: Random pose sets the selection is compared with.
RANDOM_SETS = 200


def absolute_measurements(measurements: list[Measurement]) -> tuple[list[Measurement], bool]:
    """The measurements with incremental distances made absolute, and whether they were incremental.

    A scale reset between readings sees differences of consecutive postures: the design is then made
    on the absolute rows with ``difference=True`` (:mod:`pincal.study.pose_selection`). That needs every measurement
    to be incremental.
    """
    incremental = [m for m in measurements if m.incremental]
    if not incremental:
        return measurements, False
    if len(incremental) != len(measurements):
        raise DataError(f"cannot design for incremental ({listing(m.key for m in incremental)}) and absolute "
                        "measurements together: choose poses for one kind at a time")
    return [m.absolute() for m in incremental], True


def random_set_baseline(blocks: Array, k: int, selection: PoseSelection, scales: Array, difference: bool,
                        rng: np.random.Generator, count: int = RANDOM_SETS) -> tuple[float, float]:
    """Median κ and median ``log det`` of ``count`` random ``k``-sets of the candidates, on the columns
    the selection was made for (an unidentifiable random set counts as κ = ∞, log det = −∞)."""
    n = blocks.shape[0]
    kappas, logdets = [], []
    for _ in range(count):
        indices = rng.choice(n, k, replace=False)
        kappas.append(condition_number(blocks, indices, scales, selection.columns, difference))
        logdets.append(log_det(blocks, indices, scales, selection.columns, difference))
    return float(np.median(kappas)), float(np.median(logdets))


@dataclass(frozen=True)
class Design:
    """A chosen set of postures.

    Attributes:
        models: The measurement models designed for (incremental distances made absolute).
        keys: The measurements as the user named them.
        parameters: The parameters the design is for.
        candidates: (N, na) the candidate actuated values [rad or m].
        selection: The choice (indices into ``candidates``, in measuring order; κ and log det of the choice).
        kappa_random, logdet_random: Median κ and log det of random sets of the same size.
    """

    models: list[Measurement]
    keys: str
    parameters: ParameterSet
    candidates: Array
    selection: PoseSelection
    kappa_random: float
    logdet_random: float

    @property
    def chosen(self) -> Array:
        """The chosen postures' actuated values (K, na) [rad or m], in measuring order."""
        return self.candidates[self.selection.indices]


def design_poses(robot: Robot, measure: Sequence[str], frame: str | None, parameter_spec: Sequence[str] | None,
                 candidates: int, poses: int, criterion: str = "condition", seed: int = 0,
                 spread: float | None = None, progress: bool = False) -> Design:
    """Choose ``poses`` of ``candidates`` random reachable postures of ``robot`` for measuring ``measure`` (words as
    :func:`~pincal.calibration.setup.measurement_models` reads them) and calibrating ``parameter_spec``.

    Raises:
        DataError: more than :data:`~pincal.io.dataset.MAX_SAMPLES` ``candidates``; ``poses`` outside
            1..``candidates``; postures too few to measure as many values as the parameters the candidates can
            identify (naming the least that can work).
    """
    if candidates > MAX_SAMPLES:  # before any work: each candidate costs a posture and a Jacobian block
        raise DataError(f"--candidates {candidates}: pincal draws at most {MAX_SAMPLES} candidate postures, as many "
                        "as it calibrates samples in one run")
    if candidates < 1 or not 1 <= poses <= candidates:
        raise DataError(f"cannot choose {poses} of {candidates} candidate postures: need "
                        "1 <= --poses <= --candidates")
    models, difference = absolute_measurements(measurement_models(robot, measure, frame, 1e-5))
    pset = parameters_for(robot, models, parameter_spec)
    rng = np.random.default_rng(seed)
    qa, _ = random_actuated(robot, candidates, rng, spread=spread, progress=progress)
    problem = CalibrationProblem(robot, pset, models, Observations.neutral(models, qa))
    blocks = jacobian_blocks(problem)
    scales = np.asarray(pset.scales, dtype=float)
    selection = select_poses(blocks, poses, criterion, scales=scales, names=pset.names, difference=difference,
                             progress=progress)
    rows = int(blocks.shape[1])  # measured values per posture (a difference of postures with --measure
    values = rows * (poses - int(difference))  # distance_increment: one fewer)
    if values < len(selection.columns):  # κ infinite for any such set: nothing to design
        needed = -(-len(selection.columns) // rows) + int(difference)
        raise DataError(f"--poses {poses}: {poses} postures give {values} measured values, fewer than the "
                        f"{len(selection.columns)} parameters the candidates can identify; choose at least {needed} "
                        "postures (or fewer --parameters)")
    kappa_random, logdet_random = random_set_baseline(blocks, poses, selection, scales, difference, rng)
    keys = ", ".join(m.key.replace("distance:", "distance_increment:", 1) if difference else m.key for m in models)
    return Design(models, keys, pset, qa, selection, kappa_random, logdet_random)
