"""Output files: written whole or not at all, never over an input.

Every file pincal writes goes through :func:`write_text`: the text is written to a temporary file in
the target's directory and renamed over the target, so an interrupted run or a full disk leaves the
previous file intact. :func:`check_outputs` runs before any work: it refuses an output that resolves to
an input or to another output, or that is a directory, and checks that missing parent directories can be
created (or says why not), so that no error surfaces after a long fit; the directories are made only when the
files are written, so a refused command leaves nothing behind.

A process killed at the instant of a write (SIGKILL, a power cut) leaves its temporary, ``.NAME.XXXXXXXX.part``, in
the folder. The next write to that folder removes such leftovers (:func:`remove_stale_temporaries`): a writer holds
an exclusive advisory lock (``flock``) on its temporary from the moment it creates it until it renames it, and the
kernel drops that lock when the process ends, however it ends; a temporary of that exact naming that nobody holds
locked is stale, one that another pincal is writing right now is locked and kept. Where the file system has no
locks (or the platform no ``fcntl``), nothing is removed.
"""

from __future__ import annotations

import contextlib
import json
import os
import re
import stat
import tempfile
from collections import deque
from collections.abc import Iterable, Sequence
from pathlib import Path
from typing import Any

from pincal.errors import Culprit, OutputError

try:
    import fcntl
except ImportError:  # not a POSIX platform: no advisory locks, no stale temporary told from a live one
    fcntl = None  # type: ignore[assignment]


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


def check_outputs(outputs: Iterable[tuple[str, str | Path]], inputs: Iterable[str | Path] = (),
                  keywords: bool = False) -> None:
    """Refuse unusable outputs before any work, and check that their missing parent directories can be created
    (:func:`check_directory`: nothing is created here, so a command refused later leaves no empty directory).

    Args:
        outputs: (what, path) pairs, e.g. ``("--out", "cal.urdf")``: the files to be written.
        inputs: Paths that will be read (robot file, data file, result JSON); an output may be none of them.
        keywords: Each ``what`` starts with the keyword of the library argument that gave the path (``out``,
            ``meshes='copy'``): the error's ``option`` field names it (:func:`output_option`), so that the command
            line can show its flag.

    Raises:
        OutputError: an output is an input, two outputs are the same file, an output is a directory, or its
            directory cannot be created or written.
    """
    read = {resolved(p): str(p) for p in inputs}
    seen: dict[Path, str] = {}
    for what, path in outputs:
        with Culprit(option=output_option(what) if keywords else None):
            target = resolved(path)
            if target in read:
                raise OutputError(f"{what} '{path}' is the input file '{read[target]}': pincal never writes over "
                                  "its input; choose another output name")
            if target in seen:
                raise OutputError(f"{what} '{path}' is the same file as {seen[target]}; give each output its own "
                                  "name")
            seen[target] = f"{what} '{path}'"
            _refuse_non_file(target, f"{what} '{path}'")
            check_directory(target.parent, f"{what} '{path}'")


def output_option(what: str) -> str | None:
    """The library keyword an output's label ``what`` starts with (``out``, ``meshes`` of ``meshes='copy'``), or None
    when it starts with none (a flag, ``--out``)."""
    found = re.match(r"([a-z][a-z0-9_]*)\b", what)
    return found.group(1) if found else None


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


def check_directory(directory: str | Path, what: str, option: str | None = None) -> Path:
    """``directory``, checked to be a writable directory or to be creatable as one, without creating anything:
    the nearest part of it that exists must be a directory in which a file can be written and removed. ``what``
    names it in messages; ``option``: the library keyword that gave it, the error's ``option`` field.

    Raises:
        OutputError: it or a part of it is a file, or it cannot be created, or cannot be written.
    """
    with Culprit(option=option):
        return _checked_directory(directory, what)


def _checked_directory(directory: str | Path, what: str) -> Path:
    """:func:`check_directory`'s checks."""
    folder = Path(directory)
    if folder.exists() and not folder.is_dir():
        raise OutputError(f"{what}: '{folder}' is a file, not a directory")
    existing = next((place for place in (folder, *folder.parents) if place.exists()), Path("."))
    missing = existing != folder
    if missing and (not existing.is_dir() or folder.is_symlink()):
        culprit = "a dangling symbolic link" if folder.is_symlink() else f"'{existing}' is a file"
        raise OutputError(f"{what}: cannot create directory '{folder}': {culprit}")
    try:  # a file written and removed: permissions, read-only mounts and pseudo file systems (/proc) all tell
        handle, probe = tempfile.mkstemp(dir=existing, prefix=PROBE_PREFIX)
        os.close(handle)
        with contextlib.suppress(FileNotFoundError):  # removed meanwhile as stale: it was written all the same
            os.unlink(probe)
    except OSError as exc:
        if missing:
            raise OutputError(f"{what}: cannot create directory '{folder}': {exc.strerror or exc}") from None
        raise OutputError(f"{what}: directory '{folder}' is not writable") from None
    return folder


def make_directory(directory: str | Path, what: str) -> Path:
    """``directory``, created with its parents if missing, and checked to be writable (:func:`check_directory`).
    Called when the files are written: before any work, commands call :func:`check_directory`.

    Raises:
        OutputError: it is a file, cannot be created, or cannot be written.
    """
    folder = check_directory(directory, what)
    try:
        folder.mkdir(parents=True, exist_ok=True)
    except OSError as exc:
        raise OutputError(f"{what}: cannot create directory '{folder}': {exc.strerror or exc}") from None
    return folder


def _made_directories(folders: Iterable[Path], what: str) -> list[Path]:
    """Create the missing ``folders`` (:func:`make_directory`); the directories created, deepest first, for
    :func:`_remove_directories` to take back if the write fails."""
    made: list[Path] = []
    try:
        for folder in folders:
            missing = [place for place in (folder, *folder.parents) if not place.exists()]
            if missing:
                make_directory(folder, what)
                made.extend(missing)
    except OutputError:
        _remove_directories(made)
        raise
    return made


def _remove_directories(made: Sequence[Path]) -> None:
    """Remove the directories a failed write created (deepest first), those that are still empty."""
    for folder in sorted(made, key=lambda p: len(p.parts), reverse=True):
        with contextlib.suppress(OSError):
            folder.rmdir()


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
    every old file in place. Missing directories are created first, and removed again if the write fails. The
    files that existed are recorded for :func:`take_replaced`. The stale temporaries of an earlier write killed in
    each target's folder are removed first (:func:`remove_stale_temporaries`).

    Raises:
        OutputError: as :func:`write_text`; no target has been touched.
    """
    folders = list(dict.fromkeys(Path(path).parent for path, _ in files))
    made = _made_directories(folders, "output directory")
    for folder in folders:
        remove_stale_temporaries(folder)
    staged: list[tuple[str, int, Path]] = []
    try:
        for path, text in files:
            staged.append((*_staged(Path(path), text), Path(path)))
        for temporary, _, target in staged:
            if target.exists():
                _REPLACED.append(target)
            os.replace(temporary, target)
    except OutputError:
        for temporary, _, _ in staged:
            Path(temporary).unlink(missing_ok=True)
        _remove_directories(made)
        raise
    finally:
        for _, handle, _ in staged:  # the locks go with the handles: the temporaries are renamed or removed
            os.close(handle)
    return [target for _, _, target in staged]


#: The name of a temporary :func:`write_texts` writes beside its target ``NAME``: ``.NAME.XXXXXXXX.part``, the eight
#: characters drawn by :func:`tempfile.mkstemp`; and of the probe :func:`make_directory` writes and removes.
TEMPORARY_NAME = re.compile(r"\..+\.[a-z0-9_]{8}\.part")
PROBE_PREFIX = ".pincal-probe."
PROBE_NAME = re.compile(re.escape(PROBE_PREFIX) + r"[a-z0-9_]{8}")


def _lock(handle: int, wait: bool) -> bool:
    """Whether an exclusive advisory lock on the open file ``handle`` is now held (False: another process holds it,
    or the file system or the platform has no locks)."""
    if fcntl is None:
        return False
    try:
        fcntl.flock(handle, fcntl.LOCK_EX | (0 if wait else fcntl.LOCK_NB))
    except OSError:
        return False
    return True


def _same_file(handle: int, path: str | Path) -> bool:
    """Whether ``path`` (not followed if a link) is still the file open as ``handle``."""
    try:
        there, here = os.lstat(path), os.fstat(handle)
    except OSError:
        return False
    return (there.st_dev, there.st_ino) == (here.st_dev, here.st_ino)


def remove_stale_temporaries(folder: str | Path) -> list[Path]:
    """Remove the temporaries a killed pincal left in ``folder``; return their paths.

    Only regular files named exactly as pincal names its temporaries (:data:`TEMPORARY_NAME`, :data:`PROBE_NAME`)
    are looked at, and only those no process holds locked are removed: a writer locks its temporary from its
    creation to its rename (module docstring). Nothing is removed where locks are unavailable; a file that cannot
    be opened or removed is left as it is.
    """
    removed: list[Path] = []
    if fcntl is None:
        return removed
    try:
        entries = [entry for entry in os.scandir(folder)
                   if TEMPORARY_NAME.fullmatch(entry.name) or PROBE_NAME.fullmatch(entry.name)]
    except OSError:
        return removed
    for entry in entries:
        try:
            handle = os.open(entry.path, os.O_RDONLY | os.O_NOFOLLOW | os.O_NONBLOCK | os.O_CLOEXEC)
        except OSError:  # a link, gone meanwhile, not readable
            continue
        try:
            if stat.S_ISREG(os.fstat(handle).st_mode) and _lock(handle, wait=False) and _same_file(handle, entry.path):
                os.unlink(entry.path)
                removed.append(Path(entry.path))
        except OSError:
            pass
        finally:
            os.close(handle)
    return removed


def _staged(target: Path, text: str | bytes) -> tuple[str, int]:
    """``text`` written to a temporary file beside ``target``, with ``target``'s permissions: its path, and its open
    handle, which holds the lock that tells it from a stale one until it is closed (after the rename)."""
    _refuse_non_file(target, f"output '{target}'")
    try:
        mode = target.stat().st_mode & 0o7777
    except OSError:
        mode = NEW_FILE_MODE
    handle, temporary = _locked_temporary(target)
    try:
        with os.fdopen(handle, "wb", closefd=False) as stream:
            stream.write(text if isinstance(text, bytes) else text.encode("utf-8"))
            stream.flush()
            os.fsync(stream.fileno())
        os.chmod(temporary, mode)
    except OSError as exc:
        Path(temporary).unlink(missing_ok=True)
        os.close(handle)
        raise OutputError(f"cannot write '{target}': {exc.strerror or exc}; every previous output is "
                          "unchanged") from None
    return temporary, handle


def _locked_temporary(target: Path) -> tuple[int, str]:
    """A new temporary beside ``target``, open and locked: (handle, path). Made again if another process's
    :func:`remove_stale_temporaries` took it for stale in the instant between its creation and its lock."""
    for _ in range(100):
        try:
            handle, temporary = tempfile.mkstemp(dir=target.parent, prefix=f".{target.name}.", suffix=".part")
        except OSError as exc:
            raise OutputError(f"cannot write '{target}': {exc.strerror or exc}") from None
        if not _lock(handle, wait=True) or _same_file(handle, temporary):
            return handle, temporary
        os.close(handle)
    raise OutputError(f"cannot write '{target}': its temporary files keep disappearing")


def json_text(content: dict[str, Any]) -> str:
    """``content`` as the indented JSON text of pincal's report files (keys in the order given); a record in it (an
    object with ``as_dict``, such as a report section) written as the JSON object it gives."""
    return json.dumps(content, indent=2, sort_keys=False, default=_json_object) + "\n"


def _json_object(value: Any) -> Any:
    """A record's JSON object (its ``as_dict()``), for :func:`json.dumps`; TypeError for anything else."""
    as_dict = getattr(value, "as_dict", None)
    if as_dict is None:
        raise TypeError(f"{type(value).__name__} is not JSON serializable")
    return as_dict()
