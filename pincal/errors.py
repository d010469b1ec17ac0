"""The pincal error hierarchy: every error pincal raises on purpose derives from :class:`PincalError`.

Messages name the culprit and, where it helps, list what would have been valid.
"""

from __future__ import annotations

TYPE_CHECKING = False  # typing.TYPE_CHECKING without importing typing: the ``pincal`` command's start imports this
if TYPE_CHECKING:
    from collections.abc import Iterable
    from types import TracebackType


class PincalError(Exception):
    """Root of all pincal errors: the message says what is wrong; the fields name the culprit for a program.

    Args:
        message: The one-line message.
        option: The option or argument at fault by its keyword name (``cv_seed``, whether given as a keyword, in a
            job file or as a flag), or None.
        column: The data column at fault (its header name, or its position from 1), or None.
        sample: The sample at fault (its id, or its row from 0), or None.
        file: The file at fault, as given, or None.
        line: The line of ``file`` at fault (from 1), or None.

    Attributes:
        option: As given, or None.
        column: As given, or None.
        sample: As given, or None.
        file: As given, or None.
        line: As given, or None.
    """

    def __init__(self, message: str = "", *, option: str | None = None, column: str | int | None = None,
                 sample: str | int | None = None, file: str | None = None, line: int | None = None) -> None:
        super().__init__(message)
        self.option, self.column, self.sample, self.file, self.line = option, column, sample, file, line


class Culprit:
    """A ``with`` block whose :class:`PincalError` gets the culprit fields it does not name: a reader states once the
    file it reads (and, where known, the line, sample, column or option) for the checks below it; the message and
    the traceback are left as they are.

    Args:
        option: The option at fault, or None.
        column: The data column at fault, or None.
        sample: The sample at fault, or None.
        file: The file read, as given, or None.
        line: The line of ``file`` (from 1), or None.
    """

    def __init__(self, *, option: str | None = None, column: str | int | None = None,
                 sample: str | int | None = None, file: str | None = None, line: int | None = None) -> None:
        self.fields = {"option": option, "column": column, "sample": sample, "file": file, "line": line}

    def __enter__(self) -> None:
        return None

    def __exit__(self, kind: type[BaseException] | None, error: BaseException | None,
                 traceback: TracebackType | None) -> None:
        if isinstance(error, PincalError):
            for name, value in self.fields.items():
                if value is not None and getattr(error, name) is None:
                    setattr(error, name, value)


class RobotFileError(PincalError):
    """A URDF file cannot be read or is not a valid robot description."""


class LoopError(RobotFileError):
    """A ``<loop>`` or ``<transmission>`` element is malformed, names something missing, or does not close."""


class ArgumentError(PincalError, ValueError):
    """A library call's argument has a value the call cannot take (the message names the argument and the value)."""


class ConvergenceError(PincalError):
    """An iterative solver (closed-loop FK/IK, identification) did not converge."""


class DataError(PincalError):
    """Measurement data is malformed, inconsistent or insufficient."""


class IdentifiabilityError(PincalError):
    """The data cannot identify what was asked of it."""


class OutputError(PincalError):
    """An output path cannot be written, or would overwrite an input or another output."""


class PluginError(PincalError):
    """A plugin named in ``PINCAL_PLUGINS`` cannot be loaded.

    Attributes:
        entry: The entry at fault, as written (a ``.py`` file or a dotted module name).
    """

    def __init__(self, message: str, entry: str = "") -> None:
        super().__init__(message)
        self.entry = entry


class NotFoundError(PincalError, KeyError):
    """A named robot, frame, joint, link or parameter does not exist.

    Attributes:
        kind: What was looked up (``frame``, ``joint``, ...), when known.
        name: The name asked for.
        choices: The names that exist.
    """

    def __init__(self, message: str, kind: str = "", name: str = "", choices: Iterable[str] = (), *,
                 option: str | None = None, column: str | int | None = None, sample: str | int | None = None,
                 file: str | None = None, line: int | None = None) -> None:
        super().__init__(message, option=option, column=column, sample=sample, file=file, line=line)
        self.kind, self.name, self.choices = kind, name, list(choices)

    def __str__(self) -> str:  # KeyError would otherwise quote the message
        return str(self.args[0]) if self.args else ""


def not_found(kind: str, name: str, choices: Iterable[str], where: str = "", context: str = "") -> NotFoundError:
    """The one wording of a failed lookup: ``{context}{kind} '{name}' does not exist{where}; {kind}s are: ...``.

    Args:
        kind: What was looked up (``frame``, ``joint``, ``parameter``).
        name: The name asked for.
        choices: The names that exist (listed, shortened past 30).
        where: Where it was looked for, e.g. `` in robot 'delta'``.
        context: Who asked, e.g. ``measurement 'joint:x': ``.
    """
    choices = list(choices)
    return NotFoundError(f"{context}{kind} '{name}' does not exist{where}; {kind}s are: {listing(choices)}", kind,
                         name, choices)


def listing(names: Iterable[str], limit: int = 30) -> str:
    """A comma-separated list of ``names`` for error messages, shortened past ``limit`` entries."""
    names = list(names)
    shown = ", ".join(names[:limit])
    return shown + (f", ... ({len(names)} in all)" if len(names) > limit else "")
