"""Measurement datasets: the CSV table of joint readings and measurements that calibration consumes.

One row per sample (robot posture). Columns:

- a joint name (``arm_1_joint``): that joint's reading [rad or m]. The actuated joints are required;
  instrumented passive joints (a linear scale, an LVDT, an encoder) are optional extra readings;
- ``<kind>:<frame>:<component>``: a measurement, one of

  =====================================  ==================  ========================================
  column                                 unit                meaning
  =====================================  ==================  ========================================
  ``position:<frame>:x|y|z``             m                   frame origin in the measurement frame
  ``position:<frame>@<marker>:x|y|z``    m                   marker ``<marker>`` fixed on ``<frame>``;
                                                             all three empty: the marker was not seen
  ``pose:<frame>:x|y|z|qx|qy|qz|qw``     m, unit quaternion  frame placement in the measurement frame
  ``distance:<frameA>-<frameB>:d``       m                   distance between the two frame origins
  ``distance_increment:<A>-<B>:d``       m                   change of that distance since the previous
                                                             sample (scale reset); empty on the first row
  =====================================  ==================  ========================================

  and those of a kind a plugin declares (:mod:`pincal.plugins`), whose model says its components and their units;
- optional ``sample`` (an id) and ``set`` (``train`` or ``test``; default ``train``).

Lines starting with ``#`` are comments; those before the header may carry metadata as
``# key: value`` (``# robot: delta``, ``# sigma position: 1e-5``, ``# marker m1 on tool0: 0 0 0.05`` for a
marker's nominal offset [m] in its frame). SI units everywhere.

A position's three cells may all be empty (or NaN): that reading was not taken (an occluded marker), and the
sample keeps its other readings. One or two empty cells of a position are an error.
"""

from __future__ import annotations

import csv
import io
import math
from collections.abc import Collection, Iterator, Mapping
from dataclasses import field
from pathlib import Path

import numpy as np
import numpy.typing as npt

from pincal import validation
from pincal.errors import DataError, listing
from pincal.identification.measurements import KIND_CLASSES, parse_key
from pincal.io.files import write_text
from pincal.records import record

Array = npt.NDArray[np.float64]


class _Components(Mapping[str, tuple[str, ...]]):
    """Measurement kind -> its components, of the kinds with columns of their own, read from the kinds' registry
    each time (a kind a plugin declares after this module was imported is one too)."""

    def __getitem__(self, kind: str) -> tuple[str, ...]:
        model = KIND_CLASSES.get(kind)
        if model is None or not model.components:
            raise KeyError(kind)
        return model.components

    def __iter__(self) -> Iterator[str]:
        return iter([kind for kind, model in KIND_CLASSES.items() if model.components])

    def __len__(self) -> int:
        return len(list(iter(self)))


class _Occludable(Collection[str]):
    """The measurement kinds with columns of their own whose readings a sample may lack, from the registry."""

    def __contains__(self, kind: object) -> bool:
        return kind in list(self)

    def __iter__(self) -> Iterator[str]:
        return iter([kind for kind in MEASUREMENT_COMPONENTS if KIND_CLASSES[kind].occludable])

    def __len__(self) -> int:
        return len(list(iter(self)))


#: Measurement kinds with columns of their own, and their components in column (and array) order: each
#: measurement model's (a joint reading is a joint column).
MEASUREMENT_COMPONENTS: Mapping[str, tuple[str, ...]] = _Components()
#: Measurement kinds whose readings a sample may lack, all cells empty (an occluded marker's position).
OCCLUDABLE_KINDS: Collection[str] = _Occludable()
SAMPLE_COLUMN = "sample"
SET_COLUMN = "set"
SET_NAMES = ("train", "test")
#: Lengths beyond this are taken for millimetres [m].
MAX_PLAUSIBLE_LENGTH = 20.0
#: Revolute readings beyond this, on most rows, are taken for degrees [rad].
MAX_PLAUSIBLE_ANGLE = 4.0 * math.pi
#: Largest accepted deviation of a quaternion's norm from 1.
QUATERNION_NORM_TOLERANCE = 1e-3
#: Unit words that, in a file's ``# units:`` line, mean its numbers are not SI.
FOREIGN_UNITS = ("mm", "cm", "millimetre", "millimetres", "millimeter", "millimeters", "deg", "degree", "degrees",
                 "°", "inch", "inches")
#: Most rows one calibration takes: beyond it the fit would run for many minutes without a word (a closed-loop
#: robot costs about 0.2 ms per sample and iteration), so a larger file is refused at once, before parsing.
MAX_SAMPLES = 20_000
#: Largest file read at all [bytes]: far more than MAX_SAMPLES rows of any measurement set.
MAX_FILE_BYTES = 256 * 1024 * 1024


def parse_measurement_key(key: str) -> tuple[str, tuple[str, ...]]:
    """Split a measurement key (``position:end_effector``, ``distance:O1-O2``) into kind and frames.

    Raises:
        DataError: unknown kind, or a distance key that does not name two frames as ``A-B``.
    """
    kind, sep, frames = key.partition(":")
    if not sep or not frames:
        raise DataError(f"measurement '{key}' is not '<kind>:<frame>'; kinds are: {listing(MEASUREMENT_COMPONENTS)}")
    if kind not in MEASUREMENT_COMPONENTS:
        raise DataError(f"measurement '{key}' has unknown kind '{kind}'; kinds are: "
                        f"{listing(MEASUREMENT_COMPONENTS)}")
    return kind, parse_key(key).frames  # the measurement model's own grammar


def is_increment(key: str) -> bool:
    """Whether measurement ``key``'s values are each the change since the previous sample (its model says)."""
    return parse_key(key).incremental


def _rebased_increments(increments: Array, indices: npt.NDArray[np.intp]) -> Array:
    """Increments between consecutive selected samples: the sums of the original ones in between."""
    out = np.full(indices.size, np.nan)
    for k in range(1, indices.size):
        a, b = int(indices[k - 1]), int(indices[k])
        if b > a:
            out[k] = math.fsum(increments[a + 1:b + 1])
        elif b < a:
            out[k] = -math.fsum(increments[b + 1:a + 1])
        else:
            out[k] = 0.0
    return out


@record
class Dataset:
    """Joint readings and measurements, one row per sample.

    Attributes:
        joint_names: Names of the joint-reading columns, the column order of ``joints``.
        joints: (N, nj) joint readings [rad or m].
        measurements: Measurement key (``position:end_effector``, ``distance:O1-O2``) -> (N, k)
            array, k = 3 (position [m]), 7 (pose: x, y, z [m], qx, qy, qz, qw) or 1 (distances [m]).
            The first row of a ``distance_increment`` measurement is NaN; a position row of NaN is a reading
            not taken (an occluded marker).
        sample_ids: N sample ids.
        sets: N set names, ``train`` or ``test``.
        metadata: ``# key: value`` header comments.
    """

    joint_names: list[str]
    joints: Array
    measurements: dict[str, Array]
    sample_ids: list[str]
    sets: list[str]
    metadata: dict[str, str] = field(default_factory=dict)

    def __post_init__(self) -> None:
        self.joint_names = list(self.joint_names)
        self.joints = np.asarray(self.joints, dtype=float).reshape(-1, len(self.joint_names))
        self.sample_ids = list(map(str, self.sample_ids))
        self.sets = list(self.sets)
        n = self.joints.shape[0]
        if len(set(self.joint_names)) != len(self.joint_names):
            raise DataError(f"duplicated joint names in {listing(self.joint_names)}")
        measurements = {}
        for key, values in self.measurements.items():
            kind, _ = parse_measurement_key(key)
            width = len(MEASUREMENT_COMPONENTS[kind])
            array = np.asarray(values, dtype=float)
            if array.shape != (n, width):
                raise DataError(f"measurement '{key}' has shape {array.shape}, expected ({n}, {width})")
            if is_increment(key) and n and not np.isnan(array[0, 0]):
                raise DataError(f"measurement '{key}': the first row must be NaN (no previous sample), "
                                f"not {float(array[0, 0])!r}")
            if kind in OCCLUDABLE_KINDS:
                partial = np.flatnonzero(np.any(np.isnan(array), axis=1) & ~np.all(np.isnan(array), axis=1))
                if partial.size:
                    raise DataError(f"measurement '{key}', row {int(partial[0])}: some values are NaN and some not; a "
                                    "reading not taken (an occluded marker) is NaN in all its values")
            measurements[key] = array
        self.measurements = measurements
        if len(self.sample_ids) != n or len(self.sets) != n:
            raise DataError(f"{n} joint rows but {len(self.sample_ids)} sample ids and {len(self.sets)} set names")
        wrong = sorted(set(self.sets).difference(SET_NAMES))
        if wrong:
            raise DataError(f"set names {listing(repr(s) for s in wrong)} are not valid; sets are: "
                            f"{listing(SET_NAMES)}")

    @property
    def n_samples(self) -> int:
        """Number of samples N."""
        return int(self.joints.shape[0])

    def joint_column(self, name: str) -> Array:
        """(N,) readings of joint ``name`` [rad or m]."""
        if name not in self.joint_names:
            raise DataError(f"no readings of joint '{name}'; joint columns are: {listing(self.joint_names)}")
        return self.joints[:, self.joint_names.index(name)]

    def subset(self, mask_or_indices: npt.ArrayLike) -> Dataset:
        """The samples selected by a boolean mask of length N or by integer indices, in that order.

        ``distance_increment`` measurements are re-based so that each stays the change since the
        previous *selected* sample (the sum of the original increments in between); the first is NaN.
        """
        selector = np.asarray(mask_or_indices)
        if selector.dtype == bool:
            if selector.shape != (self.n_samples,):
                raise DataError(f"mask has shape {selector.shape}, expected ({self.n_samples},)")
            indices = np.flatnonzero(selector)
        else:
            if selector.size and not np.issubdtype(selector.dtype, np.integer):
                raise DataError(f"subset takes a boolean mask or integer indices, not {selector.dtype}")
            indices = selector.astype(np.intp).reshape(-1)
            bad = indices[(indices < 0) | (indices >= self.n_samples)]
            if bad.size:
                raise DataError(f"sample indices {listing(str(i) for i in bad)} are out of range "
                                f"0..{self.n_samples - 1}")
        measurements = {}
        for key, values in self.measurements.items():
            if is_increment(key):
                measurements[key] = _rebased_increments(values[:, 0], indices)[:, None]
            else:
                measurements[key] = values[indices].copy()
        chosen = indices.tolist()  # Python ints: indexing lists with numpy's is several times slower
        return Dataset(list(self.joint_names), self.joints[indices].copy(), measurements,
                       [self.sample_ids[i] for i in chosen], [self.sets[i] for i in chosen], dict(self.metadata))

    def of_set(self, name: str) -> Dataset:
        """The samples of set ``name`` (``train`` or ``test``)."""
        if name not in SET_NAMES:
            raise DataError(f"set '{name}' is not valid; sets are: {listing(SET_NAMES)}")
        return self.subset(np.array([s == name for s in self.sets], dtype=bool))


# --- writing ------------------------------------------------------------------------------------
def _format(value: float) -> str:
    return "" if math.isnan(value) else repr(float(value))


def write_dataset(dataset: Dataset, path: str | Path) -> None:
    """Write ``dataset`` as CSV (:func:`dataset_text`) to ``path``, whole or not at all.

    Raises:
        TypeError: ``dataset`` not a :class:`Dataset`, ``path`` not a path (named, with the value).
    """
    validation.instance("dataset", dataset, Dataset, "a Dataset")
    validation.path("path", path)
    write_text(path, dataset_text(dataset))


def dataset_text(dataset: Dataset) -> str:
    """``dataset`` as CSV text; :func:`read_dataset` gives it back exactly (floats as ``repr``).

    Raises:
        DataError: metadata, sample ids, column names or values that could not be read back as written.
    """
    for key, value in dataset.metadata.items():
        if not key.strip() or key != key.strip() or ":" in key or "\n" in key or "\n" in value \
                or value != value.strip():
            raise DataError(f"metadata '{key}': '{value}' cannot be written as '# key: value' (keys without ':', "
                            "no newlines, no surrounding spaces)")
    for sample in dataset.sample_ids:
        if not sample or sample != sample.strip() or sample.startswith("#") or "\n" in sample:
            raise DataError(f"sample id {sample!r} cannot be written (empty, padded, multi-line or starting "
                            "with '#')")
    for key, values in dataset.measurements.items():
        body = values[1:] if is_increment(key) else values
        if key.partition(":")[0] in OCCLUDABLE_KINDS:  # readings not taken are written as empty cells
            body = body[~np.all(np.isnan(body), axis=1)]
        if not np.all(np.isfinite(body)):
            raise DataError(f"measurement '{key}' holds NaN or infinite values")
    if not np.all(np.isfinite(dataset.joints)):
        raise DataError("joint readings hold NaN or infinite values")

    header = [SAMPLE_COLUMN, SET_COLUMN, *dataset.joint_names]
    for key in dataset.measurements:
        components = MEASUREMENT_COMPONENTS[key.partition(":")[0]]
        header.extend(f"{key}:{c}" for c in components)
    for column in header:
        if len(column) > csv.field_size_limit() or column != column.strip():
            raise DataError(f"column '{column[:60]}{'...' if len(column) > 60 else ''}' ({len(column)} characters) "
                            f"cannot be read back from a CSV file (at most {csv.field_size_limit()} characters, no "
                            "surrounding spaces): give its joint or frame a shorter name")
    buffer = io.StringIO()
    for key, value in dataset.metadata.items():
        buffer.write(f"# {key}: {value}\n")
    writer = csv.writer(buffer, lineterminator="\n")
    writer.writerow(header)
    for r in range(dataset.n_samples):
        row = [dataset.sample_ids[r], dataset.sets[r], *(_format(v) for v in dataset.joints[r])]
        for values in dataset.measurements.values():
            row.extend(_format(v) for v in values[r])
        writer.writerow(row)
    return buffer.getvalue()
