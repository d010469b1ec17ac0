"""Writing a calibrated URDF: the source file with new joint and loop-anchor origins, all else untouched.

URDF writers such as yourdfpy's drop pincal's ``<loop>`` and ``<transmission>`` elements, and
re-serialising through ElementTree would rewrite namespaces, quoting and layout. So the source text
is edited in place: an XML parser locates each ``<origin>`` to change, and only its ``xyz`` and ``rpy``
attribute values are rewritten (an absent origin is inserted). Everything else — other joints, loops,
transmissions, visuals, materials, comments, formatting — is kept byte for byte, and a diff of the
calibrated file against the source shows exactly the calibrated placements.
"""

from __future__ import annotations

import re
import xml.parsers.expat
from dataclasses import dataclass, field
from pathlib import Path

import numpy as np
import pinocchio as pin

from pincal.errors import RobotFileError, listing

ANCHOR_ROLES = ("predecessor", "successor")
_ATTRIBUTE = re.compile(rb"""(\s+)([^\s=/>]+)(\s*=\s*)("[^"]*"|'[^']*')""")
_BOM = b"\xef\xbb\xbf"
_DECLARATION = re.compile(rb"^(?:\xef\xbb\xbf)?<\?xml[^>]*\?>[ \t]*\r?\n?")


def format_float(x: float) -> str:
    """Shortest text that reads back as the same double (``repr``), with -0.0 written as 0.0."""
    value = float(x)
    return repr(value + 0.0 if value == 0.0 else value)


def origin_attributes(placement: pin.SE3) -> tuple[str, str]:
    """``xyz`` [m] and ``rpy`` [rad] attribute values of ``placement`` (rpy from ``matrixToRpy``)."""
    xyz = " ".join(format_float(v) for v in np.asarray(placement.translation))
    rpy = " ".join(format_float(v) for v in pin.rpy.matrixToRpy(np.asarray(placement.rotation)))
    return xyz, rpy


@dataclass
class _Element:
    """Byte spans of an element found in the source: its start tag and its first ``<origin>``."""

    start: int
    start_tag_end: int = -1
    origin: tuple[int, int] | None = None  # span of the origin's start tag
    origins: int = 0
    self_closing: bool = False


@dataclass
class _Index:
    joints: dict[str, _Element] = field(default_factory=dict)
    anchors: dict[tuple[str, str], _Element] = field(default_factory=dict)
    loops: list[str] = field(default_factory=list)
    root_start: int = -1


def _tag_end(data: bytes, start: int) -> int:
    """Index just past the ``>`` closing the tag that starts at ``start`` (quotes may hold ``>``)."""
    quote = 0
    for i in range(start, len(data)):
        ch = data[i]
        if quote:
            if ch == quote:
                quote = 0
        elif ch in (0x22, 0x27):  # " '
            quote = ch
        elif ch == 0x3E:  # >
            return i + 1
    raise RobotFileError("unterminated tag in URDF")


def _index(data: bytes) -> _Index:
    """Locate the robot's top-level joints, the loops' anchors and their ``<origin>`` start tags."""
    index = _Index()
    stack: list[tuple[str, _Element | None]] = []
    parser = xml.parsers.expat.ParserCreate(encoding="UTF-8")

    def start(tag: str, attributes: dict[str, str]) -> None:
        here = parser.CurrentByteIndex
        path = [t for t, _ in stack]
        tracked: _Element | None = None
        if not stack:
            if tag != "robot":
                raise RobotFileError(f"root element is <{tag}>, expected <robot>")
            index.root_start = here
        elif path == ["robot"] and tag == "joint":
            tracked = _Element(here, _tag_end(data, here))
            index.joints.setdefault(attributes.get("name", ""), tracked)
        elif path == ["robot"] and tag == "loop":
            index.loops.append(attributes.get("name", ""))
        elif path == ["robot", "loop"] and tag in ANCHOR_ROLES:
            tracked = _Element(here, _tag_end(data, here))
            index.anchors.setdefault((index.loops[-1], tag), tracked)
        elif tag == "origin" and stack[-1][1] is not None:
            owner = stack[-1][1]
            owner.origins += 1
            if owner.origin is None:
                owner.origin = (here, _tag_end(data, here))
        stack.append((tag, tracked))

    def end(tag: str) -> None:
        _, tracked = stack.pop()
        if tracked is not None and parser.CurrentByteIndex == tracked.start_tag_end:
            tracked.self_closing = True  # expat reports <x/>'s end just past the tag

    parser.StartElementHandler = start
    parser.EndElementHandler = end
    try:
        parser.Parse(data, True)
    except xml.parsers.expat.ExpatError as exc:
        raise RobotFileError(f"URDF is not well-formed XML: {exc}") from None
    return index


def _set_attributes(tag: bytes, values: dict[bytes, bytes]) -> bytes:
    """``tag`` (an ``<origin .../>`` start tag) with these attribute values set, others kept as written."""
    done: set[bytes] = set()

    def replace(match: re.Match[bytes]) -> bytes:
        name = match.group(2)
        if name in values:
            done.add(name)
            return match.group(1) + name + match.group(3) + b'"' + values[name] + b'"'
        return match.group(0)

    edited = _ATTRIBUTE.sub(replace, tag)
    extra = b"".join(b" " + n + b'="' + v + b'"' for n, v in values.items() if n not in done)
    if not extra:
        return edited
    closing = b"/>" if edited.endswith(b"/>") else b">"
    return edited[: -len(closing)].rstrip() + extra + closing


def _edits(data: bytes, element: _Element, placement: pin.SE3, what: str) -> tuple[int, int, bytes]:
    """The (start, end, replacement) that gives ``element`` the origin ``placement``."""
    if element.origins > 1:
        raise RobotFileError(f"{what} has {element.origins} <origin> elements; a URDF allows one")
    xyz, rpy = origin_attributes(placement)
    values = {b"xyz": xyz.encode(), b"rpy": rpy.encode()}
    if element.origin is not None:
        a, b = element.origin
        return a, b, _set_attributes(data[a:b], values)
    if element.self_closing:
        raise RobotFileError(f"{what} is an empty element; it needs parent and child links")
    at = element.start_tag_end
    indent = re.match(rb"[ \t]*\r?\n?[ \t]*", data[at:])
    ws = indent.group(0) if indent else b""
    return at, at, ws + b'<origin xyz="' + values[b"xyz"] + b'" rpy="' + values[b"rpy"] + b'"/>'


def calibrated_urdf_text(source_text: str, joint_origins: dict[str, pin.SE3],
                         loop_origins: dict[tuple[str, str], pin.SE3], header_note: str = "") -> str:
    """``source_text`` with new joint origins and loop-anchor origins; everything else unchanged.

    Args:
        source_text: The URDF the robot was loaded from.
        joint_origins: Joint name -> placement of the joint in its parent link frame [m, rad].
        loop_origins: (loop name, ``predecessor`` or ``successor``) -> anchor placement in that
            link's frame [m, rad].
        header_note: Text of an XML comment put after the XML declaration (e.g. "calibrated by
            pincal on 2025-01-01 from data.csv"); nothing is added when empty.

    Raises:
        RobotFileError: the text is not a URDF, or a joint, loop or anchor role does not exist.
        ValueError: ``header_note`` cannot be an XML comment (contains ``--`` or ends with ``-``).
    """
    data = source_text.encode("utf-8")
    index = _index(data)
    unknown = [j for j in joint_origins if j not in index.joints]
    if unknown:
        raise RobotFileError(f"joints {listing(unknown)} are not in the URDF; joints are: {listing(index.joints)}")
    unknown = [f"{loop} ({role})" for loop, role in loop_origins if loop not in index.loops]
    if unknown:
        raise RobotFileError(f"loops {listing(unknown)} are not in the URDF; loops are: "
                             f"{listing(index.loops) or 'none'}")
    roles = [role for _, role in loop_origins if role not in ANCHOR_ROLES]
    if roles:
        raise RobotFileError(f"loop anchor roles {listing(roles)} are not valid; roles are: {listing(ANCHOR_ROLES)}")
    missing = [f"{loop} ({role})" for loop, role in loop_origins if (loop, role) not in index.anchors]
    if missing:
        raise RobotFileError(f"loop anchors {listing(missing)} have no element in the URDF")

    edits = [_edits(data, index.joints[j], m, f"joint '{j}'") for j, m in joint_origins.items()]
    edits += [_edits(data, index.anchors[key], m, f"loop '{key[0]}' {key[1]}") for key, m in loop_origins.items()]
    if header_note:
        if "--" in header_note or header_note.endswith("-"):
            raise ValueError(f"header note {header_note!r} cannot be an XML comment: it contains '--' or ends in '-'")
        declaration = _DECLARATION.match(data)
        at = declaration.end() if declaration else len(_BOM) if data.startswith(_BOM) else 0
        newline = b"" if declaration and data[at - 1:at] == b"\n" else b"\n" if declaration else b""
        edits.append((at, at, newline + b"<!-- " + header_note.encode("utf-8") + b" -->\n"))
    for a, b, text in sorted(edits, key=lambda e: e[0], reverse=True):
        data = data[:a] + text + data[b:]
    return data.decode("utf-8")


def write_calibrated_urdf(source_text: str, path: str | Path, joint_origins: dict[str, pin.SE3],
                          loop_origins: dict[tuple[str, str], pin.SE3], header_note: str = "") -> None:
    """Write :func:`calibrated_urdf_text` to ``path`` (UTF-8)."""
    text = calibrated_urdf_text(source_text, joint_origins, loop_origins, header_note)
    Path(path).write_text(text, encoding="utf-8")
