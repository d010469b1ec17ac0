"""Measurement models: what a sensor reads for a robot configuration, and its parameter derivative.

Each model owns its maths: it predicts a small vector per sample from the sample's closed
configuration and the local twists of the frames it looks at (a :class:`SampleContext`, built by
:mod:`pincal.identification.problem`), writes that prediction's analytic Jacobian rows, and says how its
error is formed from the measured values. It also says what its data are: the width of a reading and the unit of
each column, a neutral reading, how a reading is simulated, and which markers, cameras and targets it reads (what
the parameter set, the dataset reader and the calibrated URDF ask of it). The problem stacks whatever models it is
given and never asks which kind: a new sensor is one subclass of :class:`Measurement`. A model may also predict
every sample at once (``predict_batch``, from a :class:`~pincal.identification.batch.BatchContext`, a tree's or a
closed-loop robot's); one without it is predicted sample by sample. All in SI units: positions
[m] in the measurement frame, orientations as rotation vectors [rad], joint readings [rad or m].

Keys (also the dataset column prefixes): ``position:<frame>``, ``position:<frame>@<marker>`` (a marker fixed on
``frame``: several per frame, each with its own offset), ``pose:<frame>``, ``pose:<frame>@<target>`` (a pose target
fixed on ``frame``, seen by a camera fixed in the world: eye-to-hand), ``camera:<frame>`` and ``camera_point:<frame>``
(a camera fixed on ``frame`` that sees a pose target or a point fixed in the world: eye-in-hand),
``distance:<a>-<b>``, ``distance_increment:<a>-<b>``, ``joint:<joint>``; and those of the kinds a plugin
declares (:mod:`pincal.plugins`).
"""

from __future__ import annotations

import math
import re
from abc import ABC, abstractmethod
from collections.abc import Callable, Mapping, Sequence
from dataclasses import field, replace
from typing import Any, ClassVar

import numpy as np
import numpy.typing as npt
import pinocchio as pin

from pincal.errors import DataError
from pincal.identification.batch import BatchContext
from pincal.identification.measurements.context import SampleContext
from pincal.model.robot import Robot
from pincal.records import record

Array = npt.NDArray[np.float64]

#: Builds a model from a key's kind, the rest of the key and σ (None: the kind's default).
KeyParser = Callable[[str, str, float | None], "Measurement"]
#: Measurement kind (the key's prefix) -> how to build its model: each subclass's ``from_key``, for its ``kinds``.
KINDS: dict[str, KeyParser] = {}
#: Measurement kind -> its model class (its data columns' ``components``), in the order the kinds were declared.
KIND_CLASSES: dict[str, type[Measurement]] = {}


#: A marker's name in a key (``position:<frame>@<marker>``): letters, digits and ``_`` (it becomes part of a URDF
#: link name).
MARKER_NAME = re.compile(r"[A-Za-z0-9_]+")

#: The unit of a unit quaternion's components (qx, qy, qz, qw, in that order) among a reading's columns.
QUATERNION = "quaternion"
#: The components of a placement's parameters: translation [m] then rotation vector [rad] (``exp6``).
PLACEMENT_COMPONENTS = ("tx", "ty", "tz", "rx", "ry", "rz")


@record(frozen=True)
class Attachment:
    """A placement a measurement model carries whose parameters the set estimates (a camera, a target).

    Attributes:
        kind: ``camera`` (on frame ``owner``) or ``target`` (the world target, ``owner`` empty; or a pose target
            ``<frame>@<target>`` on a frame).
        owner: What the placement belongs to (see ``kind``), as :attr:`Parameter.owner
            <pincal.identification.parameters.Parameter.owner>` names it.
        components: The placement's estimated components, among :data:`PLACEMENT_COMPONENTS`.
    """

    kind: str
    owner: str
    components: tuple[str, ...] = PLACEMENT_COMPONENTS


@record(frozen=True)
class NominalReadings:
    """What a kind's closed-form start reads of one of its models (:meth:`Measurement.start_placements`): the nominal
    robot's placement [m, rad] of each of the model's frames in the world at each sample the model reads, and its
    readings there (n, width), in the data's units."""

    placements: dict[str, list[pin.SE3]]
    values: Array


#: Attached placement name (``plane``, ``camera.<frame>``, …) -> its closed-form start, or why the data do not
#: determine it (one line, for the summary).
StartPlacements = dict[str, "pin.SE3 | str"]


@record(frozen=True)
class Measurement(ABC):
    """Base class: ``key`` names the data columns, ``size`` the values per sample, ``sigma`` the
    standard deviation of each value (same units) used to weight the residual.

    A subclass implements :meth:`predict` (the prediction and its Jacobian rows), optionally
    :meth:`predict_batch` (the same for every sample of a tree at once), and, where they
    differ from the defaults, the data columns and their units, the error, the row units and σ, the neutral and the
    simulated reading, and what it reads besides the robot's frames (markers, cameras, targets, joints). A subclass
    that declares the key ``kinds`` it parses also defines ``from_key(kind, rest, sigma)``, a classmethod building
    its model from a key.
    """

    kinds: ClassVar[tuple[str, ...]] = ()
    #: Names of the data columns' components (``<key>:<component>``); empty: one per row, numbered.
    components: ClassVar[tuple[str, ...]] = ()
    #: Leading error columns that are lengths [m] (a point's position, a distance), then the columns that are
    #: angles [rad] (an orientation's rotation vector): what the reports' error sizes are made of.
    length_rows: ClassVar[int] = 0
    angle_rows: ClassVar[int] = 0
    #: What the reports call the size of the length rows and of the angle rows (a frame on a plane: its distance to
    #: the plane and its tilt).
    error_words: ClassVar[tuple[str, str]] = ("position", "orientation")
    #: Whether a sample may lack this reading (all its values NaN: an occluded marker); the problem leaves the
    #: missing rows out. Other kinds need every value.
    occludable: ClassVar[bool] = False
    #: The unit of each data column, in column order (``m``, ``rad``, :data:`QUATERNION`); empty: ``m`` for each.
    units: ClassVar[tuple[str, ...]] = ()
    #: What a reading not taken failed to see (``marker`` for a position), for the dataset reader's messages.
    sighted: ClassVar[str] = "target"
    #: Whether the model reads points at its frames' marker offsets (``marker.<frame>.*``): the calibrated URDF then
    #: places the point it reads on the frame's marker link.
    reads_markers: ClassVar[bool] = False
    #: Whether a reading states a contact whose values are all 0 when none is written (a frame on a plane): a job
    #: file may then give the measurement no columns.
    zero_when_unwritten: ClassVar[bool] = False
    #: How many robot frames a job file's ``[[measure]]`` of the kind names: 1 (``frame = "NAME"``) or 2 (``frames =
    #: ["A", "B"]``: a distance joins two).
    job_frames: ClassVar[int] = 1
    #: The keys of a job file's ``[[measure]]`` the kind reads besides the common ones, each a string, -> what only the
    #: kinds that read it are (a plane's ``support``: "a contact with a plane is held by a support"); :meth:`job_key`
    #: builds the key from them.
    job_keys: ClassVar[dict[str, str]] = {}

    key: str
    size: int
    sigma: float
    #: σ of each residual row [each row's unit] over ``sigma`` (a camera's depth noise three times its lateral noise:
    #: ``(1e-3, 1e-3, 3e-3)``); None: ``sigma`` on every row (and a pose's ``sigma_angle`` on its angle rows).
    component_sigma: tuple[float, ...] | None = field(default=None, kw_only=True)

    def __init_subclass__(cls, **kwargs: Any) -> None:
        super().__init_subclass__(**kwargs)
        kinds = cls.__dict__.get("kinds", ())
        if kinds and "from_key" not in cls.__dict__:
            raise TypeError(f"{cls.__name__} declares the key kinds {kinds} but no from_key to build itself from a key")
        for kind in kinds:
            KINDS[kind] = cls.__dict__["from_key"].__get__(None, cls)
            KIND_CLASSES[kind] = cls

    @classmethod
    def job_key(cls, kind: str, frames: Sequence[str], keys: Mapping[str, str]) -> str:
        """The measurement key a job file's ``[[measure]]`` declares: its ``kind``, the ``frames`` it names
        (:attr:`job_frames` of them) and the values of the kind's own :attr:`job_keys` that it gives (``keys``);
        ``<kind>:<frame>``, ``<kind>:<a>-<b>`` for two frames."""
        return f"{kind}:{'-'.join(frames)}"

    @property
    def frames(self) -> tuple[str, ...]:
        """The robot frames this model looks at (each must exist; the problem gives each its twist)."""
        return ()

    @property
    def incremental(self) -> bool:
        """Whether each value is the change since the previous sample (the first sample's row is ignored)."""
        return False

    @property
    def locates_point(self) -> bool:
        """Whether the first three values are a point's position [m] in the measurement frame (what
        registers an unknown measurement frame, and what the IKM formulation holds fixed)."""
        return False

    @property
    def in_measurement_frame(self) -> bool:
        """Whether its readings are taken in the measurement frame, whose placement ``base.*`` is then estimated:
        those that locate a point, and a fixed camera's pixels."""
        return self.locates_point

    @property
    def columns(self) -> tuple[str, ...]:
        """The dataset's column names of this measurement, in the order of its values."""
        names = self.components or tuple(str(i) for i in range(self.size))
        return tuple(f"{self.key}:{c}" for c in names)

    @property
    def width(self) -> int:
        """Values per reading as stored (its data columns): 7 for a pose's position and quaternion, ``size`` for
        most."""
        return len(self.columns)

    @property
    def column_units(self) -> tuple[str, ...]:
        """The unit of each data column (:attr:`units`, ``m`` for each when the class declares none)."""
        return self.units or ("m",) * self.width

    @classmethod
    def component_units(cls) -> tuple[str, ...]:
        """The unit of each of the kind's :attr:`components` (what the dataset reader checks each column for)."""
        return cls.units or ("m",) * len(cls.components)

    def neutral(self, n: int) -> Array:
        """(n, width) neutral readings: zeros, with an identity quaternion where the reading holds one (what
        linearises the problem at given postures, whose Jacobian does not depend on the readings)."""
        values = np.zeros((n, self.width))
        quaternion = [c for c, unit in enumerate(self.column_units) if unit == QUATERNION]
        if quaternion:
            values[:, quaternion[-1]] = 1.0  # qw, the last of (qx, qy, qz, qw)
        return values

    def simulate(self, predicted: Array, sigma: float, rng: np.random.Generator) -> Array:
        """(N, width) readings from the predictions (N, size) (absolute, as :meth:`predict` writes them) with
        Gaussian noise σ (the reading's unit) added to each value; an incremental model reads the change since
        the previous sample (its first row NaN)."""
        if self.incremental:
            n = len(predicted)
            values = np.full((n, self.width), np.nan)
            values[1:] = np.diff(predicted, axis=0) + rng.normal(scale=sigma, size=(n - 1, self.width))
            return values
        noisy: Array = predicted + rng.normal(scale=sigma, size=predicted.shape)
        return noisy

    @property
    def read_joints(self) -> tuple[str, ...]:
        """The joints whose own readings are this model's values (a joint column of the data each)."""
        return ()

    @property
    def markers(self) -> Mapping[str, tuple[float, float, float] | None]:
        """The marker keys it measures (``<frame>`` or ``<frame>@<marker>``) -> each one's nominal offset [m] in
        its frame as the data declare it (None: not declared, zero); each gets offset parameters."""
        return {}

    def with_markers(self, nominals: Mapping[str, tuple[float, float, float]]) -> Measurement:
        """This model with the nominal offsets [m] the data declare for its markers (itself if it has none)."""
        return self

    def with_metadata(self, metadata: Mapping[str, str]) -> Measurement:
        """This model with what the dataset's metadata declare for it (a board, a camera's intrinsics); itself if
        it reads none."""
        return self

    def with_angle_sigma(self, sigma_angle: float) -> Measurement:
        """This model with σ ``sigma_angle`` [rad] on its angle rows (itself if it has none)."""
        return self

    @property
    def attachments(self) -> tuple[Attachment, ...]:
        """The placements it carries whose parameters are estimated: cameras and targets."""
        return ()

    def closed_form(self, frame_poses: list[pin.SE3], values: Array, translating: bool = False
                    ) -> tuple[pin.SE3, pin.SE3, tuple[str, str]]:
        """The closed-form placements of its :attr:`attachments` from the nominal poses of its (first) frame and its
        readings (N, width): the placement on the frame, the one in the world (the second name empty: the inverse
        of the measurement frame's placement ``base``) and their names. Raises DataError when the data do not
        determine them (``translating``: the variants for a frame that only translates)."""
        raise DataError(f"measurement '{self.key}' has no closed-form start")

    @classmethod
    def start_placements(cls, models: Sequence[Measurement],
                         nominal: Callable[[Measurement], NominalReadings]) -> StartPlacements:
        """The closed-form starts of the placements ``models`` carry (their :attr:`attachments`), read from the
        nominal robot and the data (``nominal(model)``); ``models`` are every model of the problem that shares this
        hook (a plane's contacts of both kinds). Default: none, each placement starts at nominal (a camera's start is
        :meth:`closed_form`, one model at a time)."""
        return {}

    def absolute(self) -> Measurement:
        """The model of the absolute reading of an incremental one (itself when it is not incremental)."""
        return self

    def row_units(self) -> list[str]:
        """The unit of each residual row: ``m`` unless a subclass says otherwise."""
        return ["m"] * self.size

    def row_sigmas(self) -> Array:
        """σ of each residual row (same units as the row): :attr:`component_sigma` if given, else
        :meth:`uniform_row_sigmas`."""
        if self.component_sigma is not None:
            return np.array(self.component_sigma, dtype=np.float64)
        return self.uniform_row_sigmas()

    def uniform_row_sigmas(self) -> Array:
        """σ of each residual row from the one ``sigma`` (a subclass with angle rows gives them their own)."""
        return np.full(self.size, self.sigma)

    def with_component_sigma(self, sigmas: Sequence[float]) -> Measurement:
        """This model with one σ per residual row [each row's unit, :meth:`row_units`].

        Raises:
            DataError: not one finite σ > 0 per row (the message lists the rows).
        """
        values = tuple(float(v) for v in sigmas)
        if len(values) != self.size or not all(0.0 < v < math.inf for v in values):
            rows = ", ".join(f"{c} [{u}]" for c, u in zip(self.row_names(), self.row_units(), strict=True))
            raise DataError(f"measurement '{self.key}': σ {list(sigmas)} must give one finite value > 0 per residual "
                            f"row, {self.size}: {rows}")
        return replace(self, component_sigma=values)

    def row_names(self) -> tuple[str, ...]:
        """The residual rows' names: the data components when there is one per row, else numbers (a pose's
        ``x y z rx ry rz``)."""
        if len(self.components) == self.size:
            return self.components
        if self.length_rows == 3 and self.angle_rows == 3 and self.size == 6:
            return ("x", "y", "z", "rx", "ry", "rz")
        return tuple(str(i) for i in range(self.size))

    def check(self, robot: Robot) -> None:
        """Raise NotFoundError if the robot lacks what this model looks at."""
        for f in self.frames:
            robot.frame_id(f)

    @abstractmethod
    def predict(self, ctx: SampleContext, out: Array, jac: Array | None) -> None:
        """Write the sample's prediction into ``out`` (size,) and, if ``jac`` is given, its derivative
        w.r.t. the parameters into ``jac`` (size, p), which arrives zeroed."""

    def predict_batch(self, batch: BatchContext, out: Array, jac: Array | None) -> None:
        """Write every sample's prediction into ``out`` (N, size) and, if ``jac`` is given, its derivative into
        ``jac`` (N, size, p), which arrives zeroed: what :meth:`predict` writes, for all samples at once (a tree's
        batched evaluation). Optional: a model without it is predicted sample by sample (see :attr:`batched`)."""
        raise NotImplementedError(f"{type(self).__name__} predicts one sample at a time")

    @property
    def batched(self) -> bool:
        """Whether :meth:`predict_batch` predicts what :meth:`predict` does: defined by the class that defines
        :meth:`predict`, or by a subclass of it (a subclass that overrides only :meth:`predict` is predicted sample
        by sample, never with its parent's batched prediction)."""
        def owner(name: str) -> type:
            return next(c for c in type(self).__mro__ if name in c.__dict__)
        batch = owner("predict_batch")
        return batch is not Measurement and issubclass(batch, owner("predict"))

    def error(self, predicted: Array, measured: Array, model: pin.Model) -> Array:
        """Predicted − measured, (N, size), from the predictions (N, size) and the data (N, width)."""
        return predicted - measured



def parse_key(key: str, sigma: float | None = None) -> Measurement:
    """A measurement model from its key, e.g. ``position:end_effector`` or ``distance:o1-o2``."""
    kind, _, rest = key.partition(":")
    if not rest:
        raise DataError(f"measurement '{key}' is not of the form kind:frame; kinds are {', '.join(KINDS)}")
    if kind not in KINDS:
        raise DataError(f"unknown measurement kind '{kind}' in '{key}'; kinds are {', '.join(KINDS)}")
    return KINDS[kind](kind, rest, sigma)


def point_derivative(placement: pin.SE3, twist: Array, point: Array) -> Array:
    """d(world position of ``point`` fixed in a frame)/dθ from the frame's local twist (6 × n)."""
    rot = placement.rotation
    derivative: Array = rot @ (twist[:3] - pin.skew(point) @ twist[3:])
    return derivative
