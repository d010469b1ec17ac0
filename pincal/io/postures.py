"""Static postures found in a recording: where the joints stay still, each averaged into one sample of a dataset.

A posture is a stretch of joint-state messages over which every joint the robot needs stays within a band of width
``tolerance`` (its readings' max − min [rad or m]) for at least ``time`` [s]. Each posture is accounted for: kept,
and averaged (joints: mean; position: mean; orientation: the average quaternion, F. L. Markley et al., "Averaging
Quaternions", J. Guidance, Control, and Dynamics 30(4), 2007, doi:10.2514/1.28949, eq. 12), or dropped with the
reason:

- too short: the joints stood still for at least a fifth of ``time`` but less than ``time``;
- a joint not published during it: the topic carried none of its readings in that stretch;
- measurement missing: no reading, or none for more than half of the posture;
- measurement moving: its mean over the posture's first half and over its second half differ by more than ``drift``
  [m for positions, rad for orientations].
"""

from __future__ import annotations

import math
from collections.abc import Sequence

import numpy as np
import numpy.typing as npt

from pincal import validation
from pincal.errors import ArgumentError
from pincal.io.bags import JointStates, MeasurementStream
from pincal.io.dataset import Dataset
from pincal.records import record

Array = npt.NDArray[np.float64]

#: Default width of the band every joint stays within during a posture [rad or m].
STILL_TOLERANCE = 1e-3
#: Default shortest posture [s].
STILL_TIME = 1.0
#: Default largest drift of the measurement within a posture [m, rad].
DRIFT = 1e-3
#: A stop shorter than the shortest posture, but at least this fraction of it, is listed as too short; a briefer one
#: is motion.
SHORT_FRACTION = 0.2
#: A posture whose measurement has no reading for more than this fraction of it is dropped.
LARGEST_GAP = 0.5


@record(frozen=True)
class StillRule:
    """What counts as a static posture.

    Attributes:
        tolerance: Width of the band every joint stays within [rad or m].
        time: Shortest posture [s].
        drift: Largest change of the measurement between a posture's halves [m; rad for an orientation].
    """

    tolerance: float = STILL_TOLERANCE
    time: float = STILL_TIME
    drift: float = DRIFT

    def __post_init__(self) -> None:
        """Refuse what ``pincal import`` refuses of ``--still-tolerance``, ``--still-time`` and ``--drift``.

        Raises:
            TypeError: not a number.
            ArgumentError: NaN, infinite, zero or negative.
        """
        for name, unit in (("tolerance", "rad or m"), ("time", "s"), ("drift", "m, rad")):
            object.__setattr__(self, name, validation.real(name, getattr(self, name), unit, strict=True))


#: The defaults: STILL_TOLERANCE, STILL_TIME, DRIFT.
DEFAULT_RULE = StillRule()


@record(frozen=True)
class Posture:
    """One stop of the robot found in the recording.

    Attributes:
        number: Its number, from 1, in time order.
        start: Time of its first joint-state message [s], from the recording's first.
        end: Time of its last [s], from the recording's first.
        n_states: Joint-state messages in it.
        n_readings: Measurement readings in it.
        joints: (n,) mean reading of each joint [rad or m], in the order asked; NaN for a joint without reading.
        position: (3,) mean position [m], or None when dropped.
        quaternion: (4,) average orientation (x, y, z, w), or None (a point, or dropped).
        reason: Why it was dropped; empty when kept.
    """

    number: int
    start: float
    end: float
    n_states: int
    n_readings: int
    joints: Array
    position: Array | None
    quaternion: Array | None
    reason: str = ""

    @property
    def kept(self) -> bool:
        """Whether the posture is a sample of the dataset."""
        return not self.reason

    @property
    def duration(self) -> float:
        """Its length [s]."""
        return self.end - self.start

    @property
    def sample_id(self) -> str:
        """Its sample id in the dataset: ``p`` and its number."""
        return f"p{self.number}"

    def line(self) -> str:
        """One line for the table and the dataset's header: ``t 2.00-3.50 s (1.50 s), 151 joint states, 76 readings:
        kept`` or ``...: dropped, <reason>``."""
        what = "kept" if self.kept else f"dropped, {self.reason}"
        return (f"t {self.start:.2f}-{self.end:.2f} s ({self.duration:.2f} s), {self.n_states} joint states, "
                f"{self.n_readings} readings: {what}")


def average_quaternion(quaternions: Array) -> Array:
    """The average orientation of (K, 4) unit quaternions (x, y, z, w): the unit eigenvector of Σ q qᵀ with the
    largest eigenvalue (Markley et al. 2007, eq. 12), sign chosen with w ≥ 0. Insensitive to each quaternion's sign.

    Raises:
        ArgumentError: not (K, 4) with K ≥ 1, a value not finite, or a quaternion of zero norm (no orientation).
    """
    values = np.asarray(quaternions, dtype=float)
    if values.ndim != 2 or values.shape[0] == 0 or values.shape[1] != 4:
        raise ArgumentError(f"quaternions: shape {values.shape}; give (K, 4) quaternions (x, y, z, w), K ≥ 1",
                            option="quaternions")
    if not np.all(np.isfinite(values)):
        row = int(np.flatnonzero(~np.all(np.isfinite(values), axis=1))[0])
        raise ArgumentError(f"quaternions[{row}] = {values[row].tolist()}: not finite", option="quaternions")
    with np.errstate(over="ignore", under="ignore"):
        norms = np.linalg.norm(values, axis=1)
    if not np.all((norms > 0.0) & np.isfinite(norms)):
        row = int(np.flatnonzero(~((norms > 0.0) & np.isfinite(norms)))[0])
        raise ArgumentError(f"quaternions[{row}] = {values[row].tolist()}: not a rotation (norm {norms[row]:g})",
                            option="quaternions")
    _, vectors = np.linalg.eigh(values.T @ values)
    mean = vectors[:, -1]
    return np.asarray(-mean if mean[3] < 0 else mean, dtype=float)


def _forward_filled(values: Array) -> Array:
    """Each NaN replaced by the last reading above it in its column (NaN until the first)."""
    filled = values.copy()
    for row in range(1, filled.shape[0]):
        missing = np.isnan(filled[row])
        filled[row, missing] = filled[row - 1, missing]
    return filled


def still_runs(times: Array, values: Array, rule: StillRule) -> list[tuple[int, int]]:
    """The stops in ``values`` (M, n) at ``times`` (M,) [s]: index ranges [i, j) over which every column stays within a
    band of ``rule.tolerance`` (NaN ignored), of at least ``SHORT_FRACTION × rule.time`` [s], found from the first
    message on, each as long as it goes."""
    runs, i, m = [], 0, len(times)
    while i < m:
        low = high = values[i]
        j = i + 1
        while j < m:
            low, high = np.fmin(low, values[j]), np.fmax(high, values[j])
            if np.any(high - low > rule.tolerance):
                break
            j += 1
        if j - i >= 2 and times[j - 1] - times[i] >= SHORT_FRACTION * rule.time:
            runs.append((i, j))
            i = j
        else:
            i += 1
    return runs


def _measurement_fault(stream: MeasurementStream, pick: npt.NDArray[np.bool_], start: float,
                       end: float, drift: float) -> str:
    """Why the readings ``pick`` of ``stream`` cannot stand for the posture [start, end] [s]; empty if they can."""
    at = stream.times[pick]
    if at.size == 0:
        return "measurement missing (no reading)"
    gap = float(np.max(np.diff(np.concatenate([[start], at, [end]]))))
    if gap > LARGEST_GAP * (end - start):
        return f"measurement missing ({gap:.2f} s without a reading of {end - start:.2f} s)"
    half = at.size // 2
    if half == 0:
        return ""
    positions = stream.positions[pick]
    moved = float(np.linalg.norm(_mean(positions[:half]) - _mean(positions[half:])))
    if not moved <= drift:  # an overflow's NaN or infinity is moving too
        return f"measurement moving ({moved * 1e3:.2f} mm between its halves > {drift * 1e3:g} mm)"
    if stream.quaternions is not None:
        first, second = (average_quaternion(q) for q in (stream.quaternions[pick][:half],
                                                          stream.quaternions[pick][half:]))
        turned = 2.0 * math.acos(min(1.0, abs(float(first @ second))))
        if turned > drift:
            return f"measurement turning ({turned * 1e3:.2f} mrad between its halves > {drift * 1e3:g} mrad)"
    return ""


def _posture(number: int, rows: npt.NDArray[np.intp], states: JointStates, columns: npt.NDArray[np.intp],
             names: Sequence[str], stream: MeasurementStream, rule: StillRule) -> Posture:
    """Posture ``number`` over the joint-state messages ``rows``, averaged or dropped with its reason."""
    start, end = float(states.times[rows[0]]), float(states.times[rows[-1]])
    raw = states.positions[np.ix_(rows, columns)]
    counts = np.sum(~np.isnan(raw), axis=0)
    joints = np.array([_mean(c[~np.isnan(c)]) if n else np.nan for c, n in zip(raw.T, counts, strict=True)])
    pick = (stream.times >= start) & (stream.times <= end)
    n = int(np.sum(pick))
    reason = ""
    if end - start < rule.time:
        reason = f"too short ({end - start:.2f} s < {rule.time:g} s)"
    elif not np.all(counts):
        silent = [names[int(k)] for k in np.flatnonzero(counts == 0)]
        reason = f"joint {', '.join(silent)} not published during it"
    else:
        reason = _measurement_fault(stream, pick, start, end, rule.drift)
    origin = float(states.times[0])
    if reason:
        return Posture(number, start - origin, end - origin, len(rows), n, joints, None, None, reason)
    quaternion = average_quaternion(stream.quaternions[pick]) if stream.quaternions is not None else None
    return Posture(number, start - origin, end - origin, len(rows), n, joints, _mean(stream.positions[pick]),
                   quaternion)


def _mean(values: Array) -> Array:
    """The mean of ``values`` along its first axis, taken about its first row: exact for readings that stay within
    a tolerance of each other, however large they are (a plain sum of huge readings would overflow)."""
    return np.asarray(values[0] + np.mean(values - values[0], axis=0), dtype=float)


def find_postures(states: JointStates, names: Sequence[str], stream: MeasurementStream,
                  rule: StillRule = DEFAULT_RULE) -> list[Posture]:
    """The static postures of a recording, every one kept or dropped with its reason (module docstring).

    Args:
        states: The joint-state messages; they may carry extra joints, and joints in any order.
        names: The joints that must stay still, each a name ``states`` carries; the order of ``Posture.joints``.
        stream: The measurement's readings.
        rule: What counts as a posture.
    """
    columns = np.array([states.names.index(name) for name in names], dtype=np.intp)
    carrying = np.flatnonzero(np.any(~np.isnan(states.positions[:, columns]), axis=1))
    values = _forward_filled(states.positions[np.ix_(carrying, columns)])
    with np.errstate(over="ignore", invalid="ignore"):  # readings far apart: an infinite spread, not a stop
        runs = still_runs(states.times[carrying], values, rule)
        return [_posture(k + 1, carrying[i:j], states, columns, names, stream, rule) for k, (i, j) in enumerate(runs)]


def postures_dataset(postures: Sequence[Posture], names: Sequence[str], key: str,
                     metadata: dict[str, str]) -> Dataset:
    """The kept postures as a :class:`Dataset`: joints ``names``, one measurement ``key`` (``pose:<frame>``: x, y, z,
    qx, qy, qz, qw; ``position:<frame>``: x, y, z), sample ids ``p<number>``, every row in the training set; the
    ``metadata`` and one ``posture <number>`` line per posture (:meth:`Posture.line`) as its header."""
    kept = [p for p in postures if p.kept]
    values = [np.concatenate([p.position, p.quaternion]) if p.quaternion is not None else p.position
              for p in kept if p.position is not None]
    width = 7 if key.startswith("pose:") else 3
    lines = {f"posture {p.number}": p.line() for p in postures}
    return Dataset(list(names), np.array([p.joints for p in kept]).reshape(len(kept), len(names)),
                   {key: np.array(values, dtype=float).reshape(len(kept), width)}, [p.sample_id for p in kept],
                   ["train"] * len(kept), {**metadata, **lines})
