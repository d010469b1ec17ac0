"""The pincal error hierarchy: every error pincal raises on purpose derives from :class:`PincalError`.

Messages name the culprit and, where it helps, list what would have been valid.
"""

from __future__ import annotations

from collections.abc import Iterable


class PincalError(Exception):
    """Root of all pincal errors."""


class RobotFileError(PincalError):
    """A URDF file cannot be read or is not a valid robot description."""


class LoopError(RobotFileError):
    """A ``<loop>`` or ``<transmission>`` element is malformed, names something missing, or does not close."""


class ConvergenceError(PincalError):
    """An iterative solver (closed-loop FK/IK, identification) did not converge."""


class DataError(PincalError):
    """Measurement data is malformed, inconsistent or insufficient."""


class IdentifiabilityError(PincalError):
    """The data cannot identify what was asked of it."""


class OutputError(PincalError):
    """An output path cannot be written, or would overwrite an input or another output."""


class NotFoundError(PincalError, KeyError):
    """A named robot, frame, joint or link does not exist."""

    def __str__(self) -> str:  # KeyError would otherwise quote the message
        return str(self.args[0]) if self.args else ""


def listing(names: Iterable[str], limit: int = 30) -> str:
    """A comma-separated list of ``names`` for error messages, shortened past ``limit`` entries."""
    names = list(names)
    shown = ", ".join(names[:limit])
    return shown + (f", ... ({len(names)} in all)" if len(names) > limit else "")
