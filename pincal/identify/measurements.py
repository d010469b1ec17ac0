"""Measurement models: what a sensor reads for a robot configuration, and its parameter derivative.

Each model predicts a small vector per sample from the sample's closed configuration and the local
twists of the frames it looks at (computed by :mod:`pincal.identify.problem`). All in SI units: positions
[m] in the measurement frame, orientations as rotation vectors [rad], joint readings [rad or m].

Keys (also the dataset column prefixes): ``position:<frame>``, ``pose:<frame>``,
``distance:<a>-<b>``, ``distance_increment:<a>-<b>``, ``joint:<joint>``.
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np
import numpy.typing as npt
import pinocchio as pin

from pincal.errors import DataError

Array = npt.NDArray[np.float64]


@dataclass(frozen=True)
class Measurement:
    """Base class: ``key`` names the data columns, ``size`` the values per sample, ``sigma`` the
    standard deviation of each value (same units) used to weight the residual."""

    key: str
    size: int
    sigma: float

    @property
    def frames(self) -> tuple[str, ...]:
        return ()

    @property
    def incremental(self) -> bool:
        return False

    def row_units(self) -> list[str]:
        return ["m"] * self.size


@dataclass(frozen=True)
class Position(Measurement):
    """3D position of a frame's origin (plus an optional marker offset), e.g. by a laser tracker."""

    frame: str = ""

    @property
    def frames(self) -> tuple[str, ...]:
        return (self.frame,)


@dataclass(frozen=True)
class Pose(Measurement):
    """6D pose of a frame: position [m] then the rotation vector ``log3(R_measᵀ R)`` [rad].

    ``sigma`` weights the position rows; ``sigma_angle`` the orientation rows.
    """

    frame: str = ""
    sigma_angle: float = 1e-4

    @property
    def frames(self) -> tuple[str, ...]:
        return (self.frame,)

    def row_units(self) -> list[str]:
        return ["m", "m", "m", "rad", "rad", "rad"]


@dataclass(frozen=True)
class Distance(Measurement):
    """Distance between two frames' origins [m]; ``increment`` for a scale reset between readings
    (each value is the change since the previous sample, so the scale's zero drops out)."""

    frame_a: str = ""
    frame_b: str = ""
    increment: bool = False

    @property
    def frames(self) -> tuple[str, ...]:
        return (self.frame_a, self.frame_b)

    @property
    def incremental(self) -> bool:
        return self.increment


@dataclass(frozen=True)
class JointReading(Measurement):
    """A passive joint's encoder (or an instrumented measuring chain's sensor) [rad or m]."""

    joint: str = ""


def position(frame: str, sigma: float = 1e-5) -> Position:
    return Position(f"position:{frame}", 3, sigma, frame)


def pose(frame: str, sigma: float = 1e-5, sigma_angle: float = 1e-5) -> Pose:
    return Pose(f"pose:{frame}", 6, sigma, frame, sigma_angle)


def distance(frame_a: str, frame_b: str, sigma: float = 1e-6, increment: bool = False) -> Distance:
    kind = "distance_increment" if increment else "distance"
    return Distance(f"{kind}:{frame_a}-{frame_b}", 1, sigma, frame_a, frame_b, increment)


def joint_reading(joint: str, sigma: float = 1e-5) -> JointReading:
    return JointReading(f"joint:{joint}", 1, sigma, joint)


def parse_key(key: str, sigma: float | None = None) -> Measurement:
    """A measurement model from its key, e.g. ``position:end_effector`` or ``distance:o1-o2``."""
    kind, _, rest = key.partition(":")
    if not rest:
        raise DataError(f"measurement '{key}' is not of the form kind:frame; kinds are position, pose, "
                        "distance, distance_increment, joint")
    if kind == "position":
        return position(rest, sigma or 1e-5)
    if kind == "pose":
        return pose(rest, sigma or 1e-5, sigma or 1e-5)
    if kind in ("distance", "distance_increment"):
        a, sep, b = rest.partition("-")
        if not sep:
            raise DataError(f"measurement '{key}' must name two frames as {kind}:frameA-frameB")
        return distance(a, b, sigma or 1e-6, increment=kind == "distance_increment")
    if kind == "joint":
        return joint_reading(rest, sigma or 1e-5)
    raise DataError(f"unknown measurement kind '{kind}' in '{key}'; kinds are position, pose, distance, "
                    "distance_increment, joint")


def point_derivative(placement: pin.SE3, twist: Array, point: Array) -> Array:
    """d(world position of ``point`` fixed in a frame)/dθ from the frame's local twist (6 × n)."""
    rot = placement.rotation
    return rot @ (twist[:3] - pin.skew(point) @ twist[3:])
