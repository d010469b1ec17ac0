"""Output files: written whole or not at all, never over an input.

Every file pincal writes goes through :func:`write_text`: the text is written to a temporary file in
the target's directory and renamed over the target, so an interrupted run or a full disk leaves the
previous file intact. :func:`check_outputs` runs before any work: it refuses an output that resolves to
an input or to another output, or that is a directory, and creates missing parent directories (or
says why it cannot), so that no error surfaces after a long fit.
"""

from __future__ import annotations

import json
import os
import stat
import tempfile
from collections import deque
from collections.abc import Iterable, Sequence
from pathlib import Path
from typing import Any

from pincal.errors import OutputError


def _umask() -> int:
    mask = os.umask(0)
    os.umask(mask)
    return mask


#: Permissions of a new output file, as ``open`` would give it (read once: setting the umask to read it is not
#: thread-safe).
NEW_FILE_MODE = 0o666 & ~_umask()


def resolved(path: str | Path) -> Path:
    """``path`` made absolute with its symbolic links followed; a link loop is left as written (nothing to follow)."""
    try:
        return Path(path).expanduser().resolve()
    except RuntimeError:  # a symbolic link loop (Python < 3.13)
        return Path(path).expanduser().absolute()


def check_outputs(outputs: Iterable[tuple[str, str | Path]], inputs: Iterable[str | Path] = ()) -> None:
    """Refuse unusable outputs before any work, and create their missing parent directories.

    Args:
        outputs: (what, path) pairs, e.g. ``("--out", "cal.urdf")``: the files to be written.
        inputs: Paths that will be read (robot file, data file, result JSON); an output may be none of them.

    Raises:
        OutputError: an output is an input, two outputs are the same file, an output is a directory, or its
            directory cannot be created or written.
    """
    read = {resolved(p): str(p) for p in inputs}
    seen: dict[Path, str] = {}
    for what, path in outputs:
        target = resolved(path)
        if target in read:
            raise OutputError(f"{what} '{path}' is the input file '{read[target]}': pincal never writes over its "
                              "input; choose another output name")
        if target in seen:
            raise OutputError(f"{what} '{path}' is the same file as {seen[target]}; give each output its own name")
        seen[target] = f"{what} '{path}'"
        _refuse_non_file(target, f"{what} '{path}'")
        make_directory(target.parent, f"{what} '{path}'")


def input_problem(path: Path) -> str | None:
    """Why ``path`` cannot be read as an input file, in words that follow its name (``is a directory``), or None
    for a regular file (a symbolic link to one included)."""
    try:
        info = path.stat()
    except FileNotFoundError:
        dangling = path.is_symlink()
        return "is a symbolic link to a file that does not exist" if dangling else "does not exist"
    except OSError as exc:  # a symbolic link loop, a name too long, a directory not searchable
        return f"cannot be opened: {exc.strerror or exc}"
    if stat.S_ISDIR(info.st_mode):
        return "is a directory"
    if not stat.S_ISREG(info.st_mode):
        return "is not a regular file (a device, a pipe or a socket)"
    return None


def _refuse_non_file(target: Path, what: str) -> None:
    """Refuse an existing output that is not a regular file: a directory, or a device or pipe that a rename
    would replace; and a place behind a symbolic link loop."""
    for place in (target, *target.parents):
        problem = input_problem(place)
        if problem and problem.startswith("cannot be opened"):
            raise OutputError(f"{what}: '{place}' {problem}")
        if problem is None or problem == "is a directory":
            break
    if target.is_dir():
        raise OutputError(f"{what} is a directory; give a file name")
    if target.exists() and not target.is_file():
        raise OutputError(f"{what} is not a regular file (a device, a pipe or a socket); pincal writes regular files "
                          "only: give a file name")


def make_directory(directory: str | Path, what: str) -> Path:
    """``directory``, created with its parents if missing, and checked to be writable.

    Raises:
        OutputError: it is a file, cannot be created, or cannot be written.
    """
    folder = Path(directory)
    if folder.exists() and not folder.is_dir():
        raise OutputError(f"{what}: '{folder}' is a file, not a directory")
    try:
        folder.mkdir(parents=True, exist_ok=True)
    except OSError as exc:
        raise OutputError(f"{what}: cannot create directory '{folder}': {exc.strerror or exc}") from None
    try:  # a file written and removed: permissions, read-only mounts and pseudo file systems (/proc) all tell
        handle, probe = tempfile.mkstemp(dir=folder, prefix=".pincal-probe.")
        os.close(handle)
        os.unlink(probe)
    except OSError:
        raise OutputError(f"{what}: directory '{folder}' is not writable") from None
    return folder


#: The existing files that writes replaced, oldest first, until :func:`take_replaced` takes them.
_REPLACED: deque[Path] = deque(maxlen=1000)


def take_replaced() -> list[Path]:
    """The existing files that :func:`write_texts` replaced since the last call, oldest first (then forgotten): the
    command line says so, as a replaced output's old content is gone."""
    taken = list(dict.fromkeys(_REPLACED))
    _REPLACED.clear()
    return taken


def write_text(path: str | Path, text: str) -> Path:
    """Write ``text`` (UTF-8) to ``path`` whole or not at all: a temporary file in the same directory, then
    renamed over ``path`` (an existing file keeps its permissions). Returns the path.

    Raises:
        OutputError: the directory is missing or not writable, or the disk is full (the old file is kept).
    """
    return write_texts([(path, text)])[0]


def write_texts(files: Sequence[tuple[str | Path, str | bytes]]) -> list[Path]:
    """Write several files as one: every text (UTF-8) or bytes (as they are: a mesh) goes to a temporary file
    first, and only when all are on disk are they renamed over their targets, so a failure (a full disk) leaves
    every old file in place. The files that existed are recorded for :func:`take_replaced`.

    Raises:
        OutputError: as :func:`write_text`; no target has been touched.
    """
    staged: list[tuple[str, Path]] = []
    try:
        for path, text in files:
            staged.append((_staged(Path(path), text), Path(path)))
    except OutputError:
        for temporary, _ in staged:
            Path(temporary).unlink(missing_ok=True)
        raise
    for temporary, target in staged:
        if target.exists():
            _REPLACED.append(target)
        os.replace(temporary, target)
    return [target for _, target in staged]


def _staged(target: Path, text: str | bytes) -> str:
    """``text`` written to a temporary file beside ``target``, with ``target``'s permissions; its path."""
    _refuse_non_file(target, f"output '{target}'")
    try:
        mode = target.stat().st_mode & 0o7777
    except OSError:
        mode = NEW_FILE_MODE
    try:
        handle, temporary = tempfile.mkstemp(dir=target.parent, prefix=f".{target.name}.", suffix=".part")
    except OSError as exc:
        raise OutputError(f"cannot write '{target}': {exc.strerror or exc}") from None
    try:
        with os.fdopen(handle, "wb") as stream:
            stream.write(text if isinstance(text, bytes) else text.encode("utf-8"))
            stream.flush()
            os.fsync(stream.fileno())
        os.chmod(temporary, mode)
    except OSError as exc:
        Path(temporary).unlink(missing_ok=True)
        raise OutputError(f"cannot write '{target}': {exc.strerror or exc}; every previous output is "
                          "unchanged") from None
    return temporary


def json_text(content: dict[str, Any]) -> str:
    """``content`` as the indented JSON text of pincal's report files (keys in the order given)."""
    return json.dumps(content, indent=2, sort_keys=False) + "\n"
