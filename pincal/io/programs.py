"""Robot programs read for ``pincal filter`` (docs/filter.md): their targets, in SI units, and where in the text each
is written, so that a target can be rewritten and every other byte kept.

One reader per language (:mod:`pincal.io.urscript`, :mod:`pincal.io.krl`, :mod:`pincal.io.rapid`, chosen by
:func:`pincal.io.program_reader.read_program`) returns a :class:`Program`: its files' texts, its :class:`Target` s in
program order and the :class:`Problem` s (constructs the reader does not read: a target it cannot place, a tool or
frame it is not given), each named by file and line. A Cartesian target is the pose [m, rad] of the tool centre point
in its frame (a UR program's base, a KUKA ``BASE``, an ABB work object), with that frame in the robot's base frame and
the tool in the flange frame; a joint target its joint values [rad] (or [m]). :func:`rewritten` puts new poses into
the texts. This module holds what the readers share; it imports none of them.
"""

from __future__ import annotations

import itertools
import math
import re
from collections.abc import Callable, Sequence
from dataclasses import field
from pathlib import Path

import numpy as np
import numpy.typing as npt
import pinocchio as pin

from pincal.errors import DataError
from pincal.records import record

Array = npt.NDArray[np.float64]

#: The languages, by the suffix of the program file.
LANGUAGES = {".script": "urscript", ".urscript": "urscript", ".src": "krl", ".mod": "rapid", ".modx": "rapid"}
#: Largest program read [characters]: a robot program is text of a few thousand lines.
MAX_CHARACTERS = 20_000_000


@record(frozen=True)
class Edit:
    """Text ``text`` in place of characters ``start:end`` of file ``file``."""

    file: str
    start: int
    end: int
    text: str


@record(frozen=True)
class NamedPosture:
    """The posture a Cartesian target names, as written (docs/filter.md, "Posture"): KRL's status and turn, RAPID's
    configuration.

    Attributes:
        language: ``krl`` (fields ``S``, ``T``) or ``rapid`` (``cf1``, ``cf4``, ``cf6``, ``cfx``).
        file: The file it is written in.
        fields: Each field's value as written and the span of its text.
        binary: The fields written as KRL's bit strings (``'B110'``), written back so.
    """

    language: str
    file: str
    fields: dict[str, tuple[int, int, int]]
    binary: frozenset[str] = frozenset()


@record(frozen=True)
class Target:
    """One target of a program.

    Attributes:
        file: The file it is written in (a key of :attr:`Program.texts`).
        line: Its line (1-based) there.
        name: Its name (a variable) or the move that holds it inline.
        joints: Joint values [rad or m] of a joint target; None for a Cartesian one.
        pose: The tool centre point's pose in the target's frame [m, rad]; None for a joint target.
        tool: The tool centre point in the flange frame.
        frame: The target's frame in the robot's base frame.
        context: The tool and frame in words (``tool 'tool1', work object 'wobj1'``).
        render: The edits that write another pose [m, rad] (in the same frame, for the same tool) in place of it.
        uses: The lines of the moves that read it.
        posture: The posture the target names (KRL's status and turn, RAPID's configuration); None: none.
        render_joints: A joint target's edits that write other joint values [rad or m] in place of its own.
        near: Joint values [rad or m] the controller's inverse kinematics of a Cartesian target starts from, when the
            program names them (URScript's ``get_inverse_kin(p, qnear=q)``); None: the move before.
    """

    file: str
    line: int
    name: str
    joints: Array | None
    pose: pin.SE3 | None
    tool: pin.SE3
    frame: pin.SE3
    context: str
    render: Callable[[pin.SE3], list[Edit]] | None = None
    uses: tuple[int, ...] = ()
    posture: NamedPosture | None = None
    render_joints: Callable[[Array], list[Edit]] | None = None
    near: Array | None = None

    @property
    def cartesian(self) -> bool:
        """Whether it is a pose (else joint values)."""
        return self.pose is not None


@record(frozen=True)
class Problem:
    """A construct a reader does not read: left as written, with a warning."""

    file: str
    line: int
    what: str


@record
class Program:
    """A program read: its files' texts (the first the program itself), its targets in order, its problems."""

    language: str
    texts: dict[str, str]
    targets: list[Target] = field(default_factory=list)
    problems: list[Problem] = field(default_factory=list)
    #: Where the robot's base was taken to be in the program's world frame, in words (KRL, RAPID; "" for URScript).
    robot_base: str = ""


#: Each language's controller maker, and a pattern of the names the maker's robots go by in URDFs (``ur10e``,
#: ``kr16_2``, ``abb_irb2400``).
VENDORS = {"urscript": ("Universal Robots", r"(?<![a-z])ur(?:3|5|10|12|15|16|20|30)e?(?![0-9])|universal"),
           "krl": ("KUKA", r"kuka|(?<![a-z])kr[ _-]?\d"), "rapid": ("ABB", r"(?<![a-z])abb(?![a-z])|irb[ _-]?\d")}


def vendor_mismatch(language: str, names: Sequence[str]) -> str | None:
    """Why robots named ``names`` (their URDF names) may not run a program of ``language``: a name of another
    maker's robots (:data:`VENDORS`), in words; None when no name says so (a name of no known maker says nothing)."""
    maker = VENDORS[language][0]
    for name in dict.fromkeys(names):
        for other, (vendor, pattern) in VENDORS.items():
            if other != language and re.search(pattern, name.lower()):
                article = "an" if vendor == "ABB" else "a"  # "an ABB arm", "a Universal Robots arm"
                shown = "URScript" if language == "urscript" else language.upper()
                return (f"the program is {shown} (the language of {maker}) but robot '{name}' is named like "
                        f"{article} {vendor} arm: check that MODEL and the nominal robot are the robot that runs it")
    return None


def language_of(path: str | Path) -> str:
    """The language of a program file by its suffix (:data:`LANGUAGES`).

    Raises:
        DataError: another suffix.
    """
    suffix = Path(path).suffix.lower()
    if suffix not in LANGUAGES:
        raise DataError(f"PROGRAM '{path}': pincal filter reads URScript (.script), KUKA KRL (.src with its .dat) and "
                        f"ABB RAPID (.mod) programs, not '{suffix or 'a file without suffix'}'", file=str(path))
    return LANGUAGES[suffix]


#: Bytes no program text holds (C0 controls but tab, line feed, vertical tab, form feed, carriage return and DOS's
#: end-of-file mark): a file holding one is not a program.
_NOT_TEXT = re.compile(rb"[\x00-\x08\x0e-\x19\x1b-\x1f]")


def decoded(data: bytes) -> tuple[str, str]:
    """A program file's bytes as text and the encoding they were read in: UTF-8, else Latin-1 (which KUKA and ABB
    files may use); the output is written in the same encoding, so that every byte not rewritten is kept."""
    try:
        return data.decode("utf-8"), "utf-8"
    except UnicodeDecodeError:
        return data.decode("latin-1"), "latin-1"


def encoding_of(path: str | Path) -> str:
    """The encoding :func:`read_text` read the file at ``path`` in (``utf-8`` or ``latin-1``)."""
    return decoded(Path(path).read_bytes())[1]


def read_text(path: str | Path, what: str = "PROGRAM") -> str:
    """A program file's text, its line endings kept (UTF-8, else Latin-1: :func:`decoded`).

    Raises:
        DataError: missing, a directory, unreadable, too large, empty or not text (a control byte); its ``file``
            ``path``, and the ``line`` of a control byte.
    """
    path = Path(path)
    if not path.is_file():
        raise DataError(f"{what} '{path}' is not a file", file=str(path))
    try:
        data = path.read_bytes()
    except OSError as exc:
        raise DataError(f"cannot read {what} '{path}': {exc.strerror or exc}", file=str(path)) from None
    if len(data) > MAX_CHARACTERS:
        raise DataError(f"{what} '{path}' has {len(data)} bytes; a program of at most {MAX_CHARACTERS} is read",
                        file=str(path))
    if not data.strip():
        raise DataError(f"{what} '{path}' is empty", file=str(path))
    control = _NOT_TEXT.search(data)
    if control is not None:
        raise DataError(f"{what} '{path}' is not a text file (byte 0x{data[control.start()]:02x} at offset "
                        f"{control.start()}): a program is text", file=str(path),
                        line=line_of(lines_of(data[:control.start()].decode("latin-1")), control.start()))
    return decoded(data)[0]


def lines_of(text: str) -> str:
    """``text`` with each carriage return that ends a line alone (old Mac line ends) made a line feed: the same
    length, so that positions in it are positions in ``text``, and its lines are the readers' lines. The texts written
    are the ones read, their line ends kept."""
    return re.sub(r"\r(?!\n)", "\n", text)


def line_of(text: str, position: int) -> int:
    """The line (1-based) of character ``position`` of ``text``."""
    return text.count("\n", 0, position) + 1


def comment_free(text: str, marker: str) -> str:
    """``text`` with every comment from ``marker`` (KRL ``;``, RAPID ``!``) to the end of its line blanked: the same
    length, line breaks and strings kept, so that positions in it are positions in ``text``."""
    out = list(text)
    k, quoted = 0, False
    while k < len(text):
        c = text[k]
        if c == '"':
            quoted = not quoted
        elif c == "\n":
            quoted = False
        elif c == marker and not quoted:
            end = text.find("\n", k)
            end = len(text) if end < 0 else end
            out[k:end] = " " * (end - k)
            k = end
            continue
        k += 1
    return "".join(out)


def closing(text: str, start: int, pairs: str = "()[]{}") -> int:
    """The index of the bracket closing the one at ``start``, brackets nested and strings (double quotes) skipped;
    -1 when it is not closed."""
    opens = {pairs[k]: pairs[k + 1] for k in range(0, len(pairs), 2)}
    stack: list[str] = []
    k = start
    while k < len(text):
        c = text[k]
        if c == '"':
            end = text.find('"', k + 1)
            if end < 0:
                return -1
            k = end
        elif c in opens:
            stack.append(opens[c])
        elif stack and c == stack[-1]:
            stack.pop()
            if not stack:
                return k
        elif c in ")]}":
            return -1
        k += 1
    return -1


def split_top(text: str, start: int, end: int, separator: str = ",") -> list[tuple[int, int]]:
    """The spans of ``text[start:end]`` between top-level separators (outside brackets and strings)."""
    spans, depth, first, k = [], 0, start, start
    while k < end:
        c = text[k]
        if c == '"':
            close = text.find('"', k + 1, end)
            k = close if close >= 0 else end
        elif c in "([{":
            depth += 1
        elif c in ")]}":
            depth -= 1
        elif c == separator and depth == 0:
            spans.append((first, k))
            first = k + 1
        k += 1
    spans.append((first, end))
    return spans


def stripped(text: str, span: tuple[int, int]) -> tuple[int, int]:
    """``span`` without the white space at its ends."""
    a, b = span
    while a < b and text[a].isspace():
        a += 1
    while b > a and text[b - 1].isspace():
        b -= 1
    return a, b


_NUMBER = re.compile(r"[+-]?(?:\d+\.?\d*|\.\d+)(?:[eE][+-]?\d+)?")


def numbers(text: str, start: int, end: int) -> list[tuple[float, int, int]] | None:
    """The comma-separated numbers of ``text[start:end]`` with their spans; None when an item is not a number."""
    out = []
    for span in split_top(text, start, end):
        a, b = stripped(text, span)
        if not _NUMBER.fullmatch(text, a, b):
            return None
        out.append((float(text[a:b]), a, b))
    return out


def joint_render(file: str, spans: Sequence[tuple[int, int]], scale: float,
                 decimals: int) -> Callable[[Array], list[Edit]]:
    """The edits writing joint values [rad or m] times ``scale`` (180/π for degrees) over the numbers at ``spans``."""
    def render(joints: Array) -> list[Edit]:
        return [Edit(file, a, b, number_text(float(v) * scale, decimals))
                for v, (a, b) in zip(joints, spans, strict=False)]
    return render


def number_text(value: float, decimals: int) -> str:
    """``value`` with ``decimals`` decimals, ``-0`` written ``0``."""
    text = f"{value:.{decimals}f}"
    return text[1:] if text.startswith("-") and float(text) == 0.0 else text


def wrapped_near(angle: float, near: float, period: float) -> float:
    """``angle`` moved by whole periods to lie nearest ``near``."""
    return angle + period * round((near - angle) / period)


def rotation_vector_near(rotation: Array, near: Sequence[float]) -> Array:
    """The rotation vector [rad] of ``rotation`` nearest ``near`` (of the vectors ``r + 2πk r/|r|`` that give it)."""
    r = np.asarray(pin.log3(rotation), dtype=float)
    angle = float(np.linalg.norm(r))
    if angle < 1e-12:
        return r
    axis = r / angle
    candidates = [axis * (angle + 2 * math.pi * k) for k in (-2, -1, 0, 1)]
    candidates += [-axis * (2 * math.pi * k - angle) for k in (-1, 1, 2)]
    target = np.asarray(near, dtype=float)
    return min(candidates, key=lambda c: float(np.linalg.norm(c - target)))


#: Largest orientation error [rad] of the angles :func:`euler_zyx_near` picks along a singular family (B = ±90°):
#: far below what a program's 5 decimals of a degree write (1.7e-7 rad).
SINGULAR_TOLERANCE = 1e-9


def euler_zyx_near(rotation: Array, near: Sequence[float]) -> tuple[float, float, float]:
    """(A, B, C) [rad] with ``R = Rz(A) Ry(B) Rx(C)`` (KUKA's angles, URDF's yaw, pitch, roll), of the two families
    that give ``rotation`` and their whole turns the nearest ``near``. At ``B = ±90°`` (within
    :data:`SINGULAR_TOLERANCE`) only ``A − C`` (or ``A + C``) is defined: the split of it nearest ``near`` is taken,
    so that a rotation written there and not moved keeps its angles."""
    roll, pitch, yaw = (float(v) for v in pin.rpy.matrixToRpy(rotation))
    candidates = [(yaw, pitch, roll), (yaw + math.pi, math.pi - pitch, roll + math.pi)]
    if abs(math.cos(pitch)) < 1e-6:
        sign = 1.0 if pitch > 0 else -1.0  # B = +90°: R depends on A - C; B = -90°: on A + C
        a_near, b_near, c_near = near
        for b in (pitch, wrapped_near(pitch, b_near, 2 * math.pi)):
            defined = wrapped_near(yaw - sign * roll, a_near - sign * c_near, 2 * math.pi)
            a = (a_near + sign * c_near + defined) / 2
            c = sign * (a_near + sign * c_near - defined) / 2
            error = float(np.linalg.norm(pin.log3(zyx_rotation(a, b, c).T @ rotation)))
            if error < SINGULAR_TOLERANCE:
                candidates.append((a, b, c))
    best: tuple[float, float, float] | None = None
    distance = math.inf
    for a, b, c in candidates:
        triple = tuple(wrapped_near(v, n, 2 * math.pi) for v, n in zip((a, b, c), near, strict=True))
        gap = sum((v - n) ** 2 for v, n in zip(triple, near, strict=True))
        if gap < distance:
            best, distance = (triple[0], triple[1], triple[2]), gap
    assert best is not None
    return best


def zyx_rotation(a: float, b: float, c: float) -> Array:
    """``Rz(a) Ry(b) Rx(c)`` [rad]."""
    return np.asarray(pin.rpy.rpyToMatrix(c, b, a), dtype=float)


def rewritten(program: Program, edits: list[Edit]) -> dict[str, str]:
    """The program's texts with ``edits`` made (which must not overlap); the texts no edit touches as they were.

    Raises:
        DataError: two edits overlap (a reader's error: never silently dropped).
    """
    out = dict(program.texts)
    for name in out:
        mine = sorted((e for e in edits if e.file == name), key=lambda e: e.start)
        for before, after in itertools.pairwise(mine):
            if after.start < before.end:
                raise DataError(f"{name}: two rewrites overlap at characters {after.start}..{before.end}", file=name,
                                line=line_of(lines_of(out[name]), after.start))
        text = out[name]
        for edit in reversed(mine):
            text = text[:edit.start] + edit.text + text[edit.end:]
        out[name] = text
    return out
