"""Calibration parameters: which placements, offsets and constants are unknown, and vector ↔ model.

Every chosen placement M becomes ``M · exp6(δ)``, δ = (tx, ty, tz, rx, ry, rz) in M's own frame
([m] and [rad]; the convention of Pinocchio's ``computeFrameKinematicRegressor(LOCAL)``). Names:

- ``<joint>.<c>``: the URDF origin of a joint (movable or fixed), c in tx, ty, tz, rx, ry, rz;
- ``<loop>.predecessor.<c>`` / ``<loop>.successor.<c>``: a loop anchor's origin;
- ``<joint>.offset``: a joint reading offset, ``q_true = q_read + δq`` [rad or m];
- ``base.<c>``: the robot base in the measurement frame (``world = base · exp6(δ) · robot``);
- ``marker.<frame>.<x|y|z>``: a measured point's offset in ``frame`` [m]; ``marker.<frame>@<marker>.<x|y|z>``: the
  offset of declared marker ``marker`` on ``frame`` [m], from its nominal offset;
- ``cluster.<frame>.<c>``: the rigid placement of the cluster of declared markers on ``frame``, ``exp6(δ)`` applied
  to their nominal offsets (in ``frame``);
- ``camera.<frame>.<c>``: the placement of a camera fixed on ``frame`` (frame ← camera, ``exp6(δ)``; eye-in-hand);
- ``target.<c>``: the placement of the target the eye-in-hand cameras see, in the robot's world frame (world ←
  target; a point target: its translation ``tx, ty, tz``); ``target.<frame>@<target>.<c>``: a pose target fixed on
  ``frame`` (frame ← target; eye-to-hand, the camera being the measurement frame ``base.*``);
- device constants named by their measurement model (e.g. ``scale.zero``).

The values of a :class:`ParameterSet` are deviations from the nominal robot (zero = nominal). What each kind of
parameter is and does lives in its class (:mod:`pincal.identification.parameters.kinds`).
"""


from __future__ import annotations

import fnmatch
from collections.abc import Iterable, Iterator, Sequence
from dataclasses import field

import numpy as np
import numpy.typing as npt

from pincal.errors import DataError, NotFoundError, listing, not_found
from pincal.identification.measurements import INTRINSICS
from pincal.identification.parameters.kinds import (
    CameraIntrinsics,
    Compliance,
    MarkerOffset,
    ParameterKind,
    ParameterUnit,
    ReadingOffset,
    parameter_kind,
)
from pincal.model.robot import Unit
from pincal.records import record

Array = npt.NDArray[np.float64]

COMPONENTS = ("tx", "ty", "tz", "rx", "ry", "rz")
AXES = ("x", "y", "z")
#: Default parameter scales: the typical size of a geometric error [m] and [rad].
LENGTH_SCALE = 1e-3
#: A camera's focal length or principal point [px], and a distortion coefficient [1]: their typical corrections,
#: 10 px and 0.1 (a lens's k1 is −0.5 to 0.5). Smaller ones leave what images fix (the principal point to ±3 px, k1
#: to ±0.015) "practically unidentified" to LM's stop at the noise level, which then ignores what remains to gain
#: along them: at 1 px and 1e-3, a 30-image UR10 campaign ended k1 2.9σ and cy 4.7σ from the truth.
PIXEL_SCALE = 10.0
DISTORTION_SCALE = 0.1
ANGLE_SCALE = 1e-3
#: Typical gravity torque [N m] and force [N] on a joint, for the scale of a compliance.
TORQUE_SCALE = 10.0
FORCE_SCALE = 100.0


@record(frozen=True)
class Parameter:
    """One scalar unknown.

    Attributes:
        name: Unique name (see module docstring).
        kind: The name of its kind (:data:`~pincal.identification.parameters.kinds.PARAMETER_KINDS`): ``joint``,
            ``anchor``, ``offset``, ``base``, ``marker``, ``cluster``, ``camera``, ``target``, ``harmonic`` or
            ``compliance``; :attr:`kind_class` is the kind itself.
        owner: What the parameter belongs to: a joint name, loop name, frame name (``<frame>@<marker>`` for a
            declared marker, ``<frame>@<target>`` for a pose target; empty for the world target), or device constant
            name.
        component: Index in (tx, ty, tz, rx, ry, rz) for placements, in (x, y, z) for markers, in
            (sin1, cos1, sin2, cos2) for harmonics.
        side: ``predecessor`` or ``successor`` for anchors.
        unit: ``m`` or ``rad``; a compliance ``rad/(N m)`` or ``m/N``.
    """

    name: str
    kind: str
    owner: str
    component: int = 0
    side: str = ""
    unit: ParameterUnit = "m"

    @property
    def kind_class(self) -> type[ParameterKind]:
        """The parameter's kind (NotFoundError listing the kinds for a name none registered)."""
        return parameter_kind(self.kind)

    def is_a(self, kind: type[ParameterKind]) -> bool:
        """Whether the parameter is of ``kind`` (a :class:`ParameterKind` subclass) or of a kind derived from it."""
        return issubclass(self.kind_class, kind)

    @property
    def scale(self) -> float:
        """Typical size [m, rad, rad/(N m), m/N, px or 1], used to scale the identification problem: 1 mm, 1 mrad,
        for a compliance the deflection of 1 mrad under 10 N m (1 mm under 100 N), 1 px, and 1e-3 for a distortion
        coefficient."""
        return {"m": LENGTH_SCALE, "rad": ANGLE_SCALE, "rad/(N m)": ANGLE_SCALE / TORQUE_SCALE,
                "m/N": LENGTH_SCALE / FORCE_SCALE, "px": PIXEL_SCALE, "1": DISTORTION_SCALE}[self.unit]

    @property
    def term(self) -> str:
        """The last part of the name: a placement component, ``offset``, a harmonic term or ``compliance``."""
        return self.name.rsplit(".", 1)[-1]

    @property
    def group(self) -> tuple[str, str, str]:
        """The placement this parameter belongs to: (kind, owner, side)."""
        return (self.kind, self.owner, self.side)


def placement_parameters(kind: str, owner: str, side: str = "",
                         components: Sequence[str] = COMPONENTS) -> list[Parameter]:
    """The parameters of one placement (a joint origin, a loop anchor, the base, a marker cluster, a camera, a
    target): named and measured as the kind says."""
    of_kind = parameter_kind(kind)
    prefix = of_kind.prefix(owner, side)
    return [Parameter(f"{prefix}.{c}", kind, owner, COMPONENTS.index(c), side, of_kind.unit(c)) for c in components]


def offset_parameter(joint: str, unit: Unit) -> Parameter:
    """The reading offset ``δq`` of a joint [m or rad]: ``q_true = q_read + δq``."""
    return Parameter(f"{joint}.offset", ReadingOffset.name, joint, 0, "", ReadingOffset.unit("offset", unit))


def harmonic_parameters(joint: str, unit: Unit, orders: int = 2) -> list[Parameter]:
    """The harmonics of an actuated joint's reading, ``<joint>.sin1``, ``.cos1`` (and ``.sin2``, ``.cos2`` for
    ``orders=2``) [rad or m]: ``δq = a₁ sin q_r + b₁ cos q_r + a₂ sin 2q_r + b₂ cos 2q_r``."""
    terms = ("sin1", "cos1", "sin2", "cos2")[:2 * orders]
    return [Parameter(f"{joint}.{t}", "harmonic", joint, k, "", unit) for k, t in enumerate(terms)]


def compliance_parameter(joint: str, unit: Unit) -> Parameter:
    """An actuated joint's compliance ``<joint>.compliance`` [rad/(N m), or m/N for a prismatic joint]:
    ``δq = c τ_g(q_r)``, τ_g the gravity torque on the joint."""
    return Parameter(f"{joint}.compliance", Compliance.name, joint, 0, "", Compliance.unit("compliance", unit))


def marker_parameters(key: str) -> list[Parameter]:
    """The marker offset [m] of the point ``key`` (``<frame>`` or ``<frame>@<marker>``): its x, y, z
    components in the frame."""
    return [Parameter(f"marker.{key}.{a}", MarkerOffset.name, key, k, "", "m") for k, a in enumerate(AXES)]


def cluster_parameters(frame: str) -> list[Parameter]:
    """The placement of the cluster of declared markers on ``frame`` (tx, ty, tz [m], rx, ry, rz [rad])."""
    return placement_parameters("cluster", frame)


def intrinsics_parameters(owner: str) -> list[Parameter]:
    """The intrinsics of the camera on frame ``owner`` (empty: the fixed camera), ``intrinsics[.<frame>].<c>``:
    ``fx, fy, cx, cy`` [px], ``k1, k2, p1, p2, k3`` [1]."""
    prefix = CameraIntrinsics.prefix(owner)
    return [Parameter(f"{prefix}.{c}", CameraIntrinsics.name, owner, k, "", CameraIntrinsics.unit(c))
            for k, c in enumerate(INTRINSICS)]


def attached_name(kind: str, owner: str) -> str:
    """The name of a camera's or a target's placement (its parameters' prefix): ``camera.<frame>``, ``target`` (the
    world target, ``owner`` empty) or ``target.<frame>@<target>``, ``owner`` the frame or the pose target on it."""
    return parameter_kind(kind).prefix(owner)


@record
class ParameterSet:
    """An ordered set of parameters; its vectors hold deviations from the nominal robot."""

    parameters: list[Parameter] = field(default_factory=list)

    def __post_init__(self) -> None:
        names = [p.name for p in self.parameters]
        if len(set(names)) != len(names):
            dup = sorted({n for n in names if names.count(n) > 1})
            raise DataError(f"duplicate parameters: {listing(dup)}")
        self._index = {p.name: k for k, p in enumerate(self.parameters)}
        # what :meth:`groups` and :meth:`indices_of` found, per argument: a fit asks the same of every evaluation
        self._groups: dict[tuple[str, ...], dict[tuple[str, str, str], list[int]]] = {}
        self._of_kind: dict[type[ParameterKind], list[int]] = {}

    def __len__(self) -> int:
        return len(self.parameters)

    def __iter__(self) -> Iterator[Parameter]:
        return iter(self.parameters)

    def __contains__(self, name: object) -> bool:
        return name in self._index

    @property
    def names(self) -> list[str]:
        """The parameter names, in vector order."""
        return [p.name for p in self.parameters]

    @property
    def scales(self) -> Array:
        """Typical sizes [m or rad], one per parameter."""
        return np.array([p.scale for p in self.parameters])

    @property
    def lengths_and_angles(self) -> list[str]:
        """Each parameter's unit as its kind gives it (:attr:`Parameter.unit`) where it is ``m`` or ``rad``, else
        ``""``: the units the identifiability analysis words its combinations in."""
        return [p.unit if p.unit in ("m", "rad") else "" for p in self.parameters]

    def index(self, name: str) -> int:
        """The position of parameter ``name`` in the vector; NotFoundError lists the names otherwise."""
        try:
            return self._index[name]
        except KeyError:
            raise not_found("parameter", name, self.names) from None

    def of_kind(self, *kinds: str) -> list[int]:
        """Indices of the parameters of the given kinds."""
        return [k for k, p in enumerate(self.parameters) if p.kind in kinds]

    def groups(self, *kinds: str) -> dict[tuple[str, str, str], list[int]]:
        """Indices per placement (kind, owner, side), for the given kinds (found once per set and kinds; the caller
        may change what it gets)."""
        found = self._groups.get(kinds)
        if found is None:
            found = {}
            for k, p in enumerate(self.parameters):
                if p.kind in kinds:
                    found.setdefault(p.group, []).append(k)
            self._groups[kinds] = found
        return {group: list(indices) for group, indices in found.items()}

    def indices_of(self, kind: type[ParameterKind]) -> list[int]:
        """Indices of the parameters of ``kind`` or of a kind derived from it (:meth:`Parameter.is_a`), found once
        per set and kind."""
        if kind not in self._of_kind:
            self._of_kind[kind] = [k for k, p in enumerate(self.parameters) if p.is_a(kind)]
        return list(self._of_kind[kind])

    def subset(self, indices: Iterable[int]) -> ParameterSet:
        """The parameters at ``indices``, in that order."""
        return ParameterSet([self.parameters[k] for k in indices])

    def select(self, patterns: Sequence[str]) -> ParameterSet:
        """The parameters whose names match any shell-style pattern (``arm_*.t?``, ``*.offset``).

        A pattern starting with ``!`` removes what it matches; patterns that are all exclusions start
        from every parameter. Raises NotFoundError for a pattern matching nothing, or when nothing is left.
        """
        only_exclusions = all(pattern.startswith("!") for pattern in patterns)
        keep: list[bool] = [only_exclusions] * len(self.parameters)  # "!base.*" alone: everything but the base
        for pattern in patterns:
            negate = pattern.startswith("!")
            pat = pattern[1:] if negate else pattern
            hits = [k for k, p in enumerate(self.parameters) if fnmatch.fnmatchcase(p.name, pat)]
            if not hits:
                raise NotFoundError(f"parameter pattern '{pattern}' matches nothing; parameters are: "
                                    f"{listing(self.names)}")
            for k in hits:
                keep[k] = not negate
        chosen = [p for p, k in zip(self.parameters, keep, strict=True) if k]
        if not chosen:
            raise NotFoundError(f"the patterns {' '.join(patterns)} leave no parameter to identify")
        return ParameterSet(chosen)

    def vector(self, values: dict[str, float] | None = None) -> Array:
        """A parameter vector, zero (nominal) except for the given ``{name: value}``."""
        x = np.zeros(len(self))
        for name, value in (values or {}).items():
            x[self.index(name)] = value
        return x

    def as_dict(self, x: Array) -> dict[str, float]:
        """Parameter name -> its value [m or rad] in the vector ``x``."""
        return {p.name: float(v) for p, v in zip(self.parameters, x, strict=True)}

    def placement_delta(self, x: Array, indices: list[int]) -> Array:
        """The 6-vector δ of one placement group from the parameter vector."""
        delta = np.zeros(6)
        for k in indices:
            delta[self.parameters[k].component] = x[k]
        return delta
