"""Experiment design: which postures to measure, chosen among random reachable candidates by the conditioning of the
scaled identification Jacobian, and compared with random sets of the same size.

:func:`design_poses` draws the candidates (:func:`~pincal.study.simulation.random_actuated`), linearises the
calibration problem at each (the measurement models and parameters as :mod:`pincal.calibration.setup` chooses them),
stacks each posture's rows of the identification Jacobian (:func:`~pincal.study.pose_selection.jacobian_blocks`) and
chooses by condition number or D-optimality (:func:`~pincal.study.pose_selection.select_poses`). SI units: m, rad.

The design linearises at the nominal robot. A nominal drawn with exactly parallel joint axes (a UR's shoulder, elbow
and first wrist joints) hides directions that a real robot, whose axes are slightly off, shows weakly: ``pincal
calibrate``, which counts at its estimate, finds them. :func:`off_nominal` counts the directions the candidates
identify on the robot off its nominal geometry by errors of :data:`OFF_NOMINAL`, and names the parallel axes, so that
the two counts are told apart in words.
"""

from __future__ import annotations

from collections.abc import Sequence

import numpy as np
import numpy.typing as npt
import pinocchio as pin

from pincal import linalg
from pincal.calibration.setup import measurement_models, parameters_for
from pincal.errors import DataError, PincalError, listing
from pincal.identification.measurements import Measurement
from pincal.identification.parameters import ParameterSet
from pincal.identification.problem import CalibrationProblem, Observations
from pincal.io.dataset import MAX_SAMPLES
from pincal.model.robot import Robot
from pincal.records import record
from pincal.study.pose_selection import (
    PoseSelection,
    condition_number,
    jacobian_blocks,
    log_det,
    pool_columns,
    select_poses,
)
from pincal.study.simulation import perturbation, random_actuated

Array = npt.NDArray[np.float64]

#: Random pose sets the selection is compared with.
RANDOM_SETS = 200
#: Errors [m, rad] of the robot off its nominal geometry on which :func:`off_nominal` counts again: ``pincal
#: simulate``'s default, the size of a real robot's.
OFF_NOMINAL = 1e-3
#: Largest sine of the angle between two joint axes called parallel [-].
PARALLEL = 1e-9


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
    return float(linalg.median(kappas)), float(linalg.median(logdets))


@record(frozen=True)
class OffNominal:
    """What the candidates identify on the robot off its nominal geometry, when more than on the nominal.

    Attributes:
        identifiable: The parameters the candidate pool identifies there.
        sigma: The errors drawn on every parameter [m, rad].
        parallel_axes: Runs of consecutive joints with exactly parallel axes on the nominal robot, on the chains
            that move the measured frames (what hides the other directions); empty when none.
    """

    identifiable: int
    sigma: float
    parallel_axes: tuple[tuple[str, ...], ...]


def parallel_axes(robot: Robot, frames: Sequence[str]) -> tuple[tuple[str, ...], ...]:
    """Runs of consecutive revolute joints whose axes are exactly parallel (sine below :data:`PARALLEL`) on the chains
    from the root to ``frames``, at the reference configuration, in chain order; none for a closed-loop robot."""
    if robot.loops:
        return ()
    model = robot.model
    data = pin.Data(model)
    pin.computeJointJacobians(model, data, robot.q_reference)
    runs: list[tuple[str, ...]] = []
    for frame in frames:
        run: list[str] = []
        previous: Array | None = None
        for joint in list(model.supports[model.frames[robot.frame_id(frame)].parentJoint])[1:]:
            if model.joints[joint].nv != 1:
                continue
            axis = pin.getJointJacobian(model, data, joint, pin.WORLD)[3:, model.joints[joint].idx_v]
            norm = float(np.linalg.norm(axis))
            if norm < PARALLEL:  # a prismatic joint: no axis of rotation, the run ends
                run, previous = [], None
                continue
            axis = axis / norm
            if previous is not None and float(np.linalg.norm(np.cross(previous, axis))) < PARALLEL:
                run.append(str(model.names[joint]))
            else:
                if len(run) > 1 and tuple(run) not in runs:
                    runs.append(tuple(run))
                run = [str(model.names[joint])]
            previous = axis
        if len(run) > 1 and tuple(run) not in runs:
            runs.append(tuple(run))
    return tuple(runs)


def off_nominal(problem: CalibrationProblem, difference: bool, nominal: int, seed: int) -> OffNominal | None:
    """The parameters the candidates of ``problem`` identify on the robot off its nominal geometry (every parameter
    off by a normal draw of σ :data:`OFF_NOMINAL`, generator ``seed``) when more than ``nominal``, the count at the
    nominal; None when no more, or when a candidate does not assemble there."""
    pset = problem.parameters
    x = perturbation(pset, OFF_NOMINAL, np.random.default_rng(seed))
    try:
        blocks = jacobian_blocks(problem, x)
    except PincalError:
        return None
    count = len(pool_columns(blocks * np.asarray(pset.scales, dtype=float), pset.names, difference))
    if count <= nominal:
        return None
    frames = list(dict.fromkeys(frame for m in problem.measurements for frame in m.frames))
    return OffNominal(count, OFF_NOMINAL, parallel_axes(problem.robot, frames))


@record(frozen=True)
class Design:
    """A chosen set of postures.

    Attributes:
        models: The measurement models designed for (incremental distances made absolute).
        keys: The measurements as the user named them.
        parameters: The parameters the design is for.
        candidates: (N, na) the candidate actuated values [rad or m].
        selection: The choice (indices into ``candidates``, in measuring order; κ and log det of the choice).
        kappa_random, logdet_random: Median κ and log det of random sets of the same size.
        off_nominal: What the candidates identify off the nominal geometry, when more (:func:`off_nominal`).
    """

    models: list[Measurement]
    keys: str
    parameters: ParameterSet
    candidates: Array
    selection: PoseSelection
    kappa_random: float
    logdet_random: float
    off_nominal: OffNominal | None = None

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
            identify (naming the least that can work); a measured frame no actuated joint moves.
    """
    if candidates > MAX_SAMPLES:  # before any work: each candidate costs a posture and a Jacobian block
        raise DataError(f"candidates={candidates}: pincal draws at most {MAX_SAMPLES} candidate postures, as many "
                        "as it calibrates samples in one run", option="candidates")
    if candidates < 1 or not 1 <= poses <= candidates:
        raise DataError(f"cannot choose poses={poses} of candidates={candidates} candidate postures: need "
                        "1 <= poses <= candidates", option="poses")
    models, difference = absolute_measurements(measurement_models(robot, measure, frame, 1e-5, refuse_still=True))
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
        raise DataError(f"poses={poses}: {poses} postures give {values} measured values, fewer than the "
                        f"{len(selection.columns)} parameters the candidates can identify; choose at least {needed} "
                        "postures (or fewer parameters)", option="poses")
    kappa_random, logdet_random = random_set_baseline(blocks, poses, selection, scales, difference, rng)
    keys = ", ".join(m.key.replace("distance:", "distance_increment:", 1) if difference else m.key for m in models)
    off = off_nominal(problem, difference, len(selection.columns), seed)
    return Design(models, keys, pset, qa, selection, kappa_random, logdet_random, off)
