"""Joint columns that look read with the other sign or swapped with another joint's (or positions that look mirrored),
found from the nominal robot.

A joint read with the other sign (an encoder counting the other way, another sign convention) or the columns of two
joints exchanged leave every row of the file readable, and the calibration hopeless: the fit moves the robot by tens
of centimetres and degrees to imitate the mistake, or stalls (on a closed-loop robot, after tens of seconds of forward
kinematics that cannot assemble), and the samples whose readings fall outside the joint limits are dropped. Such a
mistake shows before any fit: read with the column negated (or the two exchanged), the nominal robot's start — its
measurement frame registered to the measured positions in closed form, as every calibration starts — fits the data
several times better, and keeps at least as many samples within the joint limits.

:func:`column_mistake` tries each actuated joint that moves a measured frame negated, and each pair of them (of the same
unit) exchanged, and the measured positions mirrored, on at most :data:`PROBED_SAMPLES` samples, and names the one that
explains the data
(:class:`ColumnMistake`). The pipeline asks before the fit when the start looks wrong
(:func:`start_looks_wrong`: its error beyond half the measured positions' spread, or many samples outside the joint
limits) and refuses the data then; after a fit it found implausible, the likely cause names it. Data that measure no
position (planes, cameras, joint readings) are not probed. Units: m, rad.
"""

from __future__ import annotations

import contextlib
import itertools
from collections.abc import Iterator
from dataclasses import replace
from typing import TYPE_CHECKING

import numpy as np
import numpy.typing as npt

from pincal import linalg
from pincal.errors import ConvergenceError, DataError, PincalError
from pincal.identification.measurements import Measurement
from pincal.identification.parameters import choose_parameters, influencing_joints, joint_unit, read_joints
from pincal.identification.predictions import remember
from pincal.identification.problem import CalibrationProblem
from pincal.io.adapters import observations_from
from pincal.io.dataset import Dataset
from pincal.model.robot import Robot
from pincal.records import record

if TYPE_CHECKING:
    from pincal.calibration.setup import Prepared

Array = npt.NDArray[np.float64]

#: Most samples a probe reads (evenly spaced over the file): enough to tell a wrong column from a right one, whatever
#: the file's size.
PROBED_SAMPLES = 40
#: A variant explains the data when the nominal robot's start error with it is at most this share of the error as read.
CLEARLY_BETTER = 0.2
#: The start looks wrong when its RMS position error exceeds this share of the measured positions' spread (the median
#: distance from their median point): healthy data start at 0.5 % (simulations) to 28 % of it (the TIAGo mocap data,
#: its marker 0.1 m off its frame); a flipped Delta arm or a Panda with two columns exchanged at 80 %.
WRONG_START = 0.5
#: The start looks wrong too when more than this share of the samples lie outside the joint limits.
MANY_OUTSIDE = 0.25
#: The variant of a probe that mirrors the measured positions (no joint's column changed): positions measured in a
#: left-handed frame. A symmetric robot (a Delta) can read them as two arms exchanged.
MIRRORED: tuple[str, ...] = ()
#: Two variants explain the data alike when their start errors are within this factor.
SAME_START = 1.5


@record(frozen=True)
class Start:
    """The nominal robot's start on some samples: how many of them it can use (within the joint limits, assembled), and
    its RMS position error [m] on them (inf with fewer than three)."""

    usable: int
    rms: float


@record(frozen=True)
class ColumnMistake:
    """A joint column read with the other sign (``joints`` one name), or two joints' columns exchanged (two names),
    and the nominal robot's start as read and as corrected, on ``probed`` samples; ``others``: the other columns'
    mistakes that explain the data as well (within :data:`SAME_START`; a symmetric robot, a Delta's arms, cannot tell
    them apart), ``mirror_too`` when a mirror of the positions does."""

    joints: tuple[str, ...]
    as_read: Start
    corrected: Start
    probed: int
    mirror_too: bool = False
    others: tuple[tuple[str, ...], ...] = ()

    @property
    def what(self) -> str:
        """The mistake in words: "joint 'a' looks read with the other sign", "the columns of joints 'a' and 'b' look
        exchanged", "the measured positions look mirrored" (no joint), and that a mirror explains them as well."""
        also = [f"'{v[0]}' read with the other sign" if len(v) == 1 else f"'{v[0]}' and '{v[1]}' exchanged"
                for v in self.others if v != MIRRORED]
        also += ["the measured positions mirrored, a left-handed frame"] if self.mirror_too else []
        mirror = f" (or {', or '.join(also)}: on this robot the data cannot tell which)" if also else ""
        if not self.joints:
            return ("the measured positions look mirrored (a left-handed measurement frame, or one axis negated)"
                    + mirror)
        return f"{_described(self.joints)}{mirror}"

    @property
    def evidence(self) -> str:
        """Why: the start's error and the samples within the limits, as read and corrected."""
        how = {0: "mirrored", 1: "with it negated"}.get(len(self.joints), "with the two exchanged")
        within = (f"{self.corrected.usable} of {self.probed} samples are usable ({self.as_read.usable} as read) and "
                  if self.corrected.usable != self.as_read.usable else "")
        before = f"{self.as_read.rms * 1e3:.3g} mm" if np.isfinite(self.as_read.rms) else "none (too few samples)"
        return (f"{how}, {within}the nominal robot's RMS position error at the start falls from {before} to "
                f"{self.corrected.rms * 1e3:.3g} mm")

    @property
    def fix(self) -> str:
        """What to do about it."""
        fix = {0: "negate one axis of the positions", 1: "negate that column"}.get(len(self.joints),
                                                                                  "exchange the two columns' names")
        if self.others:
            return "check which of them it is and correct that (exchange the two columns' names, or negate one)"
        return fix + (" (or negate one axis of the positions)" if self.mirror_too else "")


def _described(joints: tuple[str, ...]) -> str:
    """A joint read with the other sign (one name), or two joints' columns exchanged (two), in words."""
    if len(joints) == 1:
        return f"joint '{joints[0]}' looks read with the other sign"
    return f"the columns of joints '{joints[0]}' and '{joints[1]}' look exchanged"


def probed_part(part: Dataset, most: int = PROBED_SAMPLES) -> Dataset:
    """At most ``most`` samples of ``part``, evenly spaced."""
    if part.n_samples <= most:
        return part
    return part.subset(np.unique(np.linspace(0, part.n_samples - 1, most).round().astype(np.intp)))


def start_of(robot: Robot, part: Dataset, models: list[Measurement]) -> Start:
    """The nominal robot's start on ``part``: the samples it can use, and its RMS position error [m] with the
    measurement frame registered to the measured positions (Kabsch), the markers at their frames' origins."""
    from pincal.calibration.samples import usable_part  # (samples asks this module for a likely cause)

    samples, _, closed = usable_part(robot, part)
    if samples.n_samples < 3:
        return Start(samples.n_samples, np.inf)
    problem = CalibrationProblem(robot, choose_parameters(robot, models, ["base.*"]), models,
                                 observations_from(robot, samples.joint_names, samples.joints, samples.measurements,
                                                   models))
    remember(problem, closed)
    try:
        errors = problem.evaluate(problem.initial_guess(), jacobian=False).errors
    except PincalError:  # a start the nominal robot cannot evaluate says nothing either way
        return Start(samples.n_samples, np.inf)
    squares = [np.sum(errors[m.key][:, :3] ** 2, axis=1) for m in models if m.locates_point]
    values = np.concatenate(squares) if squares else np.zeros(0)
    values = values[np.isfinite(values)]
    return Start(samples.n_samples, float(np.sqrt(values.mean())) if values.size >= 3 else np.inf)


def probed_joints(robot: Robot, part: Dataset, models: list[Measurement]) -> list[str]:
    """The actuated joints of one coordinate with a column in ``part`` that move a measured frame, in model order."""
    moving = influencing_joints(robot, sorted({f for m in models for f in m.frames}), read_joints(models))
    return [j for j in moving if j in robot.actuated_joints and j in part.joint_names
            and robot.model.joints[robot.model.getJointId(j)].nq == 1]


def column_mistake(robot: Robot, part: Dataset, models: list[Measurement]) -> ColumnMistake | None:
    """The joint read with the other sign, or the two joints' columns exchanged, that explains ``part``'s measured
    positions: with it corrected, the nominal robot's start keeps at least as many samples and its error falls to
    :data:`CLEARLY_BETTER` of the error as read or less (the best such; None when none does, or when the data locate no
    point)."""
    if not any(m.locates_point for m in models):
        return None
    probed = probed_part(part)
    as_read = start_of(robot, probed, models)
    joints = probed_joints(robot, probed, models)
    variants: list[tuple[str, ...]] = [(j,) for j in joints]
    variants += [(a, b) for a, b in itertools.combinations(joints, 2) if joint_unit(robot, a) == joint_unit(robot, b)]
    if all(m.key.startswith("position:") for m in models if m.locates_point):  # a mirror is no rotation of a pose
        variants.append(MIRRORED)
    found: dict[tuple[str, ...], Start] = {}
    for variant in variants:
        corrected = start_of(robot, _corrected(probed, variant), models)
        if np.isfinite(corrected.rms) and corrected.usable >= as_read.usable \
                and corrected.rms <= CLEARLY_BETTER * as_read.rms:
            found[variant] = corrected
    if not found:
        return None
    best = min(found, key=lambda variant: (found[variant].rms, variants.index(variant)))
    alike = tuple(v for v in variants if v in found and v != best and found[v].rms <= SAME_START * found[best].rms)
    mirror_too = best != MIRRORED and MIRRORED in alike
    return ColumnMistake(best, as_read, found[best], probed.n_samples, mirror_too,
                         tuple(v for v in alike if v != MIRRORED))


def _corrected(part: Dataset, joints: tuple[str, ...]) -> Dataset:
    """``part`` with the column of ``joints[0]`` negated (one joint), the columns of the two exchanged, or (none:
    :data:`MIRRORED`) its measured positions mirrored (their x negated)."""
    if joints == MIRRORED:
        return replace(part, measurements={key: values * np.where(np.arange(values.shape[1]) == 0, -1.0, 1.0)
                                           if key.startswith("position:") else values
                                           for key, values in part.measurements.items()})
    values = part.joints.copy()
    columns = [part.joint_names.index(j) for j in joints]
    if len(columns) == 1:
        values[:, columns[0]] = -values[:, columns[0]]
    else:
        values[:, columns] = values[:, columns[::-1]]
    return replace(part, joints=values)


def start_looks_wrong(rms: float, spread: float, outside: int, samples: int) -> bool:
    """Whether a calibration's start looks like data read wrongly: its RMS position error ``rms`` [m] beyond
    :data:`WRONG_START` of the measured positions' ``spread`` [m], or more than :data:`MANY_OUTSIDE` of the ``samples``
    outside the joint limits (``outside`` of them)."""
    return rms > WRONG_START * spread or outside > MANY_OUTSIDE * samples


def refuse_column_mistake(robot: Robot, part: Dataset, models: list[Measurement], plausible: float | str) -> None:
    """Refuse ``part`` when a column of it looks read with the other sign or exchanged with another
    (:func:`column_mistake`); nothing with ``plausible`` off.

    Raises:
        DataError: naming the joint or the two, the evidence, and the remedy.
    """
    if plausible == "off":
        return
    try:
        mistake = column_mistake(robot, part, models)
    except PincalError:  # data the probe cannot read say nothing of their columns: the caller's error stands
        return
    if mistake is not None:
        raise DataError(f"{mistake.what}: {mistake.evidence}; {mistake.fix}, or give plausible='off' to fit the "
                        "readings as they are")


def check_columns(fit: Prepared, part: Dataset, plausible: float | str) -> None:
    """Before the fit of ``fit`` (the training samples ``part`` prepared), when its start looks wrong
    (:func:`start_looks_wrong`, on its start's RMS position error against the measured positions' spread, and the
    samples dropped outside the joint limits), refuse a column read with the other sign or exchanged
    (:func:`refuse_column_mistake`).

    Raises:
        DataError: as :func:`refuse_column_mistake`.
    """
    located = [m for m in fit.models if m.locates_point]
    if plausible == "off" or not located:  # nothing to probe
        return
    problem = fit.problem
    outside = sum(1 for d in fit.dropped if "outside its URDF limits" in d["reason"])
    rms = spread = 0.0
    if problem.observations.n_samples >= 3:
        errors = problem.evaluate(problem.initial_guess(), jacobian=False).errors  # the start the fit reads: kept
        squares = np.concatenate([np.sum(errors[m.key][:, :3] ** 2, axis=1) for m in located])
        points = np.vstack([problem.observations.values[m.key][:, :3] for m in located])
        points = points[np.all(np.isfinite(points), axis=1)]
        if np.isfinite(squares).any() and len(points):
            rms = float(np.sqrt(np.nanmean(squares)))
            spread = float(linalg.median(np.linalg.norm(points - linalg.median(points, axis=0), axis=1)))
    if start_looks_wrong(rms, spread, outside, part.n_samples):
        refuse_column_mistake(fit.robot, part, fit.models, plausible)


@contextlib.contextmanager
def mistake_named(fit: Prepared, part: Dataset, plausible: float | str) -> Iterator[None]:
    """A fit of ``fit`` that ends where the robot cannot assemble (forward kinematics that does not converge) with its
    likely cause named: a column of ``part`` read with the other sign or exchanged (DataError, as
    :func:`refuse_column_mistake`), else the ConvergenceError with the causes to check."""
    try:
        yield
    except ConvergenceError as exc:
        refuse_column_mistake(fit.robot, part, fit.models, plausible)
        raise ConvergenceError(f"{exc}; if the data are of this robot, check its joint columns: a joint read with "
                               "the other sign or from another zero than the URDF's gives postures it cannot "
                               "assemble") from None
