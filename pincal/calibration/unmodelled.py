"""Simulated campaigns whose truth holds what the calibration model lacks, fitted on a narrow band of postures.

A calibration is used beyond the postures it was fitted on, and real robots carry effects its geometric model lacks.
:func:`narrow_band` simulates both: the true robot has geometric errors plus, as :class:`Effects` asks,

- joint compliance under gravity (``<joint>.compliance``: each actuated joint deflects by ``c τ_g(q)``, τ_g from the
  URDF's link masses; :mod:`pincal.identification.corrections`),
- gear harmonics twice per turn (``<joint>.sin2``, ``.cos2``), and
- a link's thermal growth: the longest joint placement's translation grows by a relative ``thermal`` over the
  session, linearly in time, the postures (training and held-out alike) measured in a random order;

the training postures lie in a narrow band (each actuated joint within ``±half`` of a random centre), the held-out ones
half inside that band, half beyond it (each joint, with probability ½, up to ``far × half`` from the centre; at least
one). The dataset marks the training postures ``set=train`` and the others ``set=test``; :attr:`NarrowBand.inside`
says which held-out posture was drawn inside the band. ``docs/results/extrapolation.md`` (``examples/extrapolation.py``)
is made of such campaigns. SI units: m, rad.
"""

from __future__ import annotations

import math

import numpy as np
import numpy.typing as npt

from pincal.calibration.setup import idle_parameters, measurement_models, parameters_for
from pincal.errors import DataError
from pincal.identification.parameters import ParameterSet
from pincal.identification.problem import CalibrationProblem, Observations
from pincal.io.dataset import Dataset
from pincal.model.assemblable import assemble
from pincal.model.robot import Robot
from pincal.records import record
from pincal.study.simulation import actuated_ranges, simulate_observations

Array = npt.NDArray[np.float64]

#: Most draws of postures per posture wanted before giving up (a band near a singularity).
DRAWS_PER_POSTURE = 200
#: Steps the link's length takes over the session (each posture measured at the step of its time).
THERMAL_STEPS = 10


@record(frozen=True)
class Effects:
    """What the true robot holds beyond its geometric errors.

    Attributes:
        compliance: Each actuated joint's true compliance [rad/(N m) or m/N], times a uniform draw in [0.5, 1.5].
        harmonics: σ of each actuated joint's true twice-per-turn harmonics ``sin2``, ``cos2`` [rad or m].
        thermal: Relative growth of the longest link over the session (dimensionless; 2e-4 is a steel link 17 K
            warmer at the end than at the start).
    """

    compliance: float = 0.0
    harmonics: float = 0.0
    thermal: float = 0.0

    def spec(self) -> list[str]:
        """The parameter patterns of the true robot: the default set and the effects' terms."""
        return ["default"] + (["*.compliance"] if self.compliance else []) + \
            (["*.sin2", "*.cos2"] if self.harmonics else [])


@record(frozen=True)
class NarrowBand:
    """A narrow-band campaign.

    Attributes:
        robot: The nominal robot.
        dataset: Training postures (``set=train``), then the held-out ones (``set=test``): inside first.
        inside: (n_test,) whether each held-out posture was drawn inside the training band.
        parameters, x_true: The true robot's parameters and deviations [m, rad, rad/(N m)] at the training postures.
    """

    robot: Robot
    dataset: Dataset
    inside: npt.NDArray[np.bool_]
    parameters: ParameterSet
    x_true: Array


def narrow_band(robot: Robot, effects: Effects, seed: int, n_train: int = 60, n_inside: int = 40,
                n_outside: int = 40, half: float = 0.25, far: float = 3.0, perturb: float = 3e-4,
                noise: float = 5e-4) -> NarrowBand:
    """A campaign of one marker's position (the default measured frame, the measurement frame unknown) on ``robot``.

    Args:
        robot: A serial or tree robot with link masses (for the compliance).
        effects: What the true robot holds beyond its geometric errors.
        seed: Random seed (the same seed, the same campaign).
        n_train: Postures to calibrate from.
        n_inside: Postures held out inside the band.
        n_outside: Postures held out beyond it.
        half: Half-width of the band [rad or m] about its random centre, per actuated joint (at most an eighth of the
            joint's range).
        far: How far beyond the centre the outside postures reach, in half-widths.
        perturb: σ of the true geometric errors [m and rad] (the measurement frame's and the marker's too).
        noise: σ of the measurement noise [m].

    Raises:
        DataError: the band leaves too few postures the robot can assemble.
    """
    rng = np.random.default_rng(seed)
    models = measurement_models(robot, ["position"], None, noise)
    pset = parameters_for(robot, models, effects.spec())
    low, high = actuated_ranges(robot)
    width = np.minimum(np.full(low.size, half), (high - low) / 8.0)
    centre = rng.uniform(low + far * width, high - far * width)
    train = _postures(robot, rng, centre, width, n_train, 1.0, low, high)
    inside = _postures(robot, rng, centre, width, n_inside, 1.0, low, high)
    outside = _postures(robot, rng, centre, width, n_outside, far, low, high)
    x_true = _truth(pset, effects, perturb, rng)
    everywhere = np.vstack([train, inside, outside])
    at_nominal = CalibrationProblem(robot, pset, models, Observations.neutral(models, everywhere))
    geometric = np.array([p.kind_class.name not in ("compliance", "harmonic") for p in pset])
    x_true[geometric & idle_parameters(at_nominal, np.zeros(len(pset)))] = 0.0
    key = models[0].key
    n_test = len(inside) + len(outside)
    n = len(train) + n_test
    time = rng.permutation(n) / max(n - 1, 1)  # the order the postures were measured in, 0 to 1
    values = np.empty((n, 3))
    for step in np.unique(np.round(time * THERMAL_STEPS)):  # the link's length in steps of the session
        at = np.flatnonzero(np.round(time * THERMAL_STEPS) == step)
        truth = thermal_growth(robot, pset, x_true, effects.thermal * step / THERMAL_STEPS)
        values[at] = simulate_observations(robot, pset, truth, models, everywhere[at], rng, noise=noise).values[key]
    frame = key.split(":", 1)[1]
    dataset = Dataset(list(robot.actuated_joints), everywhere, {key: values}, [str(k) for k in range(n)],
                      ["train"] * len(train) + ["test"] * n_test,
                      {"robot": robot.name, "units": "SI (m, rad)", f"sigma position {frame}": repr(noise)})
    return NarrowBand(robot, dataset, np.arange(n_test) < len(inside), pset, x_true)


def _postures(robot: Robot, rng: np.random.Generator, centre: Array, width: Array, n: int, far: float, low: Array,
              high: Array) -> Array:
    """``n`` postures (n, na) [rad or m] the robot assembles: within ``centre ± width`` (``far`` 1), or each joint with
    probability ½ between ``width`` and ``far × width`` from the centre (at least one), the others within the band."""
    out: list[Array] = []
    for _ in range(DRAWS_PER_POSTURE):
        draws = centre + rng.uniform(-width, width, size=(n, centre.size))
        if far > 1.0:
            beyond = rng.random((n, centre.size)) < 0.5
            beyond[np.arange(n), rng.integers(centre.size, size=n)] = True
            reach = rng.uniform(width, far * width, size=(n, centre.size)) * rng.choice([-1.0, 1.0], (n, centre.size))
            draws = np.where(beyond, centre + reach, draws)
        draws = draws[np.all((draws >= low) & (draws <= high), axis=1)]
        if draws.size:
            out.extend(draws[assemble(robot, draws, 1e4).usable])
        if len(out) >= n:
            return np.array(out[:n])
    raise DataError(f"only {len(out)} of {n} postures of '{robot.name}' drawn in the band could be assembled")


def _truth(parameters: ParameterSet, effects: Effects, perturb: float, rng: np.random.Generator) -> Array:
    """True deviations: geometric ones normal of σ ``perturb`` [m, rad], compliances ``effects.compliance`` × U(0.5,
    1.5), harmonics normal of σ ``effects.harmonics``."""
    x = np.zeros(len(parameters))
    for k, p in enumerate(parameters):
        kind = p.kind_class.name
        if kind == "compliance":
            x[k] = effects.compliance * rng.uniform(0.5, 1.5)
        elif kind == "harmonic":
            x[k] = effects.harmonics * rng.normal()
        else:
            x[k] = perturb * rng.normal()
    return x


def thermal_growth(robot: Robot, parameters: ParameterSet, x: Array, relative: float) -> Array:
    """``x`` with the longest joint placement's translation among ``parameters`` grown by ``relative`` of its nominal
    length: the growth of ``M.translation`` expressed in the placement's own frame, added to its ``tx``, ``ty``, ``tz``
    deviations [m]."""
    names = list(robot.model.names)
    owners = {p.name.rpartition(".")[0] for p in parameters if p.kind_class.name == "joint"} & set(names)
    if not relative or not owners:
        return x
    longest = max(sorted(owners), key=lambda o: float(np.linalg.norm(robot.model.jointPlacements[names.index(o)]
                                                                      .translation)))
    placement = robot.model.jointPlacements[names.index(longest)]
    grown = x.copy()
    for k, p in enumerate(parameters):
        owner, _, term = p.name.rpartition(".")
        if owner == longest and p.kind_class.name == "joint" and term in ("tx", "ty", "tz"):
            grown[k] += float((placement.rotation.T @ (relative * placement.translation))["xyz".index(term[1])])
    return grown


def rms(values: Array) -> float:
    """Root mean square [m] of the finite ``values`` (NaN when none)."""
    finite = values[np.isfinite(values)]
    return math.sqrt(float(np.mean(finite**2))) if finite.size else math.nan
