"""Writing a calibrated URDF: the source file with new origins and added frames, all else untouched.

URDF writers such as yourdfpy's drop pincal's ``<loop>`` and ``<transmission>`` elements, and
re-serialising through ElementTree would rewrite namespaces, quoting and layout. So the source text
is edited in place: an XML parser locates each ``<origin>`` to change, and only its ``xyz`` and ``rpy``
attribute values are rewritten (an absent origin is inserted). New elements are inserted as text:
links attached by fixed joints (a new root link such as the measurement frame, marker frames),
``<joint_sensor>`` elements (an instrumented passive joint's reading at the joint's zero) and mesh
file names made loadable. Everything else — other joints, loops, transmissions, visuals, materials,
comments, formatting — is kept byte for byte, and a diff of the calibrated file against the source
shows exactly the calibrated placements and the added frames.
"""

from __future__ import annotations

import functools
import re
import xml.parsers.expat
from collections.abc import Sequence
from dataclasses import field
from pathlib import Path

import numpy as np
import pinocchio as pin

from pincal.errors import RobotFileError, listing
from pincal.records import record

ANCHOR_ROLES = ("predecessor", "successor")
#: The comment written before new ``<joint_sensor>`` elements.
SENSOR_COMMENT = ("pincal: instrumented passive joints. The sensor of each reads q + zero [m or rad], q the joint's "
                  "value in this file (its zero is where the calibrated robot closes at zero actuated readings)")
# tried from a run of blanks' first only: from each, the pattern would rescan the rest of the run
_ATTRIBUTE = re.compile(rb"""(?<!\s)(\s+)([^\s=/>]+)(\s*=\s*)("[^"]*"|'[^']*')""")
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


@record(frozen=True)
class FixedLink:
    """A link to add to a URDF, attached to the tree by a new fixed joint.

    Exactly one of ``parent`` and ``child`` is the new link; the other exists. A new parent of an
    existing link makes a new root (the existing link must be the current root), e.g. the
    measurement frame above the robot's base; a new child is a frame on an existing link, e.g. a
    marker.

    Attributes:
        joint: Name of the new fixed joint.
        parent: Parent link of the joint.
        child: Child link of the joint.
        origin: Placement of the child link frame in the parent link frame [m, rad].
        comment: Text of an XML comment written before the new elements (none when empty).
    """

    joint: str
    parent: str
    child: str
    origin: pin.SE3
    comment: str = ""


@record
class _Element:
    """Byte spans of an element found in the source: its start tag and its first ``<origin>``."""

    start: int
    start_tag_end: int = -1
    origin: tuple[int, int] | None = None  # span of the origin's start tag
    origins: int = 0
    self_closing: bool = False


@record
class _Index:
    joints: dict[str, _Element] = field(default_factory=dict)
    anchors: dict[tuple[str, str], _Element] = field(default_factory=dict)
    loops: list[str] = field(default_factory=list)
    root_start: int = -1
    root_end_tag: int = -1  # start of ``</robot>``
    links: dict[str, _Element] = field(default_factory=dict)
    joint_links: dict[str, dict[str, str]] = field(default_factory=dict)  # joint -> {"parent": link, "child": link}
    meshes: list[tuple[int, int, str]] = field(default_factory=list)  # mesh start tag span, filename
    sensors: dict[str, _Element] = field(default_factory=dict)  # <joint_sensor> by joint name


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


@functools.lru_cache(maxsize=8)
def _index(data: bytes) -> _Index:
    """Locate the robot's top-level links and joints, the loops' anchors, their ``<origin>`` start
    tags, the meshes and the ``<joint_sensor>`` elements (read only by its callers: one parse per source text)."""
    index = _Index()
    stack: list[tuple[str, _Element | None]] = []
    joint_names: list[str] = []  # of the top-level joints, in file order
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
            joint_names.append(attributes.get("name", ""))
            index.joints.setdefault(joint_names[-1], tracked)
        elif path == ["robot"] and tag == "link":
            tracked = _Element(here, _tag_end(data, here))
            index.links.setdefault(attributes.get("name", ""), tracked)
        elif path == ["robot"] and tag == "joint_sensor":
            tracked = _Element(here, _tag_end(data, here))
            index.sensors.setdefault(attributes.get("joint", ""), tracked)
        elif path == ["robot", "joint"] and tag in ("parent", "child"):
            index.joint_links.setdefault(joint_names[-1], {}).setdefault(tag, attributes.get("link", ""))
        elif path == ["robot", "loop"] and tag in ANCHOR_ROLES:
            tracked = _Element(here, _tag_end(data, here))
            index.anchors.setdefault((index.loops[-1], tag), tracked)
        elif tag == "origin" and stack[-1][1] is not None:
            owner = stack[-1][1]
            owner.origins += 1
            if owner.origin is None:
                owner.origin = (here, _tag_end(data, here))
        if tag == "mesh" and len(path) >= 2 and path[:2] == ["robot", "link"]:
            index.meshes.append((here, _tag_end(data, here), attributes.get("filename", "")))
        if path == ["robot"] and tag == "loop":
            index.loops.append(attributes.get("name", ""))
        stack.append((tag, tracked))

    def end(tag: str) -> None:
        _, tracked = stack.pop()
        here = parser.CurrentByteIndex
        if not stack:
            index.root_end_tag = here
        if tracked is not None and here == tracked.start_tag_end:
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


def _quoted(value: str) -> bytes:
    """``value`` as a double-quoted XML attribute value."""
    escaped = value.replace("&", "&amp;").replace("<", "&lt;").replace(">", "&gt;").replace('"', "&quot;")
    return b'"' + escaped.encode("utf-8") + b'"'


def _comment(text: str, what: str) -> bytes:
    if "--" in text or text.endswith("-"):
        raise ValueError(f"{what} {text!r} cannot be an XML comment: it contains '--' or ends in '-'")
    return b"<!-- " + text.encode("utf-8") + b" -->"


def _fixed_link_elements(link: FixedLink, new_link: str) -> list[bytes]:
    xyz, rpy = origin_attributes(link.origin)
    lines = [_comment(link.comment, f"comment of link '{new_link}'")] if link.comment else []
    lines.append(b"<link name=" + _quoted(new_link) + b"/>")
    lines.append(b"<joint name=" + _quoted(link.joint) + b' type="fixed"><parent link=' + _quoted(link.parent)
                 + b"/><child link=" + _quoted(link.child) + b'/><origin xyz="' + xyz.encode() + b'" rpy="'
                 + rpy.encode() + b'"/></joint>')
    return lines


def _block(data: bytes, at: int, lines: list[bytes], indent: bytes | None = None) -> tuple[int, int, bytes]:
    """An insertion of ``lines`` before the element starting at ``at``: on lines of their own, indented
    like that element (or by ``indent``), when it starts its line; else inline."""
    newline = b"\r\n" if b"\r\n" in data else b"\n"
    line_start = data.rfind(b"\n", 0, at) + 1
    lead = data[line_start:at]
    if lead.strip(b" \t"):
        return at, at, b"".join(line + b" " for line in lines)
    pad = lead if indent is None else indent
    return line_start, line_start, b"".join(pad + line + newline for line in lines)


def _indent_of(data: bytes, at: int) -> bytes:
    lead = data[data.rfind(b"\n", 0, at) + 1:at]
    return b"" if lead.strip(b" \t") else lead


def _root_links(index: _Index) -> list[str]:
    children = {links.get("child", "") for links in index.joint_links.values()}
    return [name for name in index.links if name not in children]


def _fixed_link_edits(data: bytes, index: _Index, fixed_links: Sequence[FixedLink]
                      ) -> tuple[list[tuple[int, int, bytes]], list[bytes]]:
    """The insertion of a new root (before the first link) and the new child links (returned as
    lines, for the end of the file)."""
    edits: list[tuple[int, int, bytes]] = []
    tail: list[bytes] = []
    new_names: set[str] = set()
    for link in fixed_links:
        if link.joint in index.joints or link.joint in new_names:
            raise RobotFileError(f"cannot add joint '{link.joint}': the URDF already has a joint of that name")
        known = [name for name in (link.parent, link.child) if name in index.links]
        if len(known) != 1:
            state = "both exist" if len(known) == 2 else "neither exists"
            raise RobotFileError(f"cannot add fixed joint '{link.joint}' from '{link.parent}' to '{link.child}': "
                                 f"exactly one of the two links must be new, {state}; links are: "
                                 f"{listing(index.links)}")
        new_link = link.child if link.parent in index.links else link.parent
        if new_link in new_names:
            raise RobotFileError(f"cannot add link '{new_link}' twice")
        new_names.update((new_link, link.joint))
        lines = _fixed_link_elements(link, new_link)
        if new_link == link.child:
            tail += lines
            continue
        if edits:
            raise RobotFileError(f"cannot add a second new root '{new_link}': a URDF has one root")
        roots = _root_links(index)
        if link.child not in roots:
            parent_joint = next(j for j, ends in index.joint_links.items() if ends.get("child") == link.child)
            raise RobotFileError(f"cannot give link '{link.child}' the new parent '{link.parent}': it already has "
                                 f"parent joint '{parent_joint}'; only the root link ({listing(roots)}) can")
        first = min(element.start for element in index.links.values())
        edits.append(_block(data, first, lines))
    return edits, tail


def _sensor_edits(data: bytes, index: _Index, sensor_zeros: dict[str, float]
                  ) -> tuple[list[tuple[int, int, bytes]], list[bytes]]:
    edits: list[tuple[int, int, bytes]] = []
    tail: list[bytes] = []
    for joint, zero in sensor_zeros.items():
        if joint not in index.joints:
            raise RobotFileError(f"joint sensor of joint '{joint}': no such joint; joints are: {listing(index.joints)}")
        value = format_float(zero).encode()
        if joint in index.sensors:
            element = index.sensors[joint]
            a, b = element.start, element.start_tag_end
            edits.append((a, b, _set_attributes(data[a:b], {b"zero": value})))
        else:
            tail.append(b"<joint_sensor joint=" + _quoted(joint) + b' zero="' + value + b'"/>')
    if tail:
        tail.insert(0, _comment(SENSOR_COMMENT, "sensor comment"))
    return edits, tail


def _mesh_edits(data: bytes, index: _Index, mesh_filenames: dict[str, str]) -> list[tuple[int, int, bytes]]:
    unknown = sorted(set(mesh_filenames) - {name for _, _, name in index.meshes})
    if unknown:
        raise RobotFileError(f"mesh files {listing(unknown)} are not in the URDF; meshes are: "
                             f"{listing(sorted({name for _, _, name in index.meshes})) or 'none'}")
    edits = []
    for a, b, name in index.meshes:
        if name in mesh_filenames:
            edits.append((a, b, _set_attributes(data[a:b], {b"filename": _quoted(mesh_filenames[name])[1:-1]})))
    return edits


def calibrated_urdf_text(source_text: str, joint_origins: dict[str, pin.SE3],
                         loop_origins: dict[tuple[str, str], pin.SE3], header_note: str = "",
                         fixed_links: Sequence[FixedLink] = (), sensor_zeros: dict[str, float] | None = None,
                         mesh_filenames: dict[str, str] | None = None) -> str:
    """``source_text`` with new joint origins, loop-anchor origins and added frames; all else unchanged.

    Args:
        source_text: The URDF the robot was loaded from.
        joint_origins: Joint name -> placement of the joint in its parent link frame [m, rad].
        loop_origins: (loop name, ``predecessor`` or ``successor``) -> anchor placement in that
            link's frame [m, rad].
        header_note: Text of an XML comment put after the XML declaration (e.g. "calibrated by
            pincal on 2025-01-01 from data.csv"); nothing is added when empty.
        fixed_links: Links to add, each with its fixed joint: a new root is written before the first
            link, new child links before ``</robot>``.
        sensor_zeros: Joint name -> reading of the joint's sensor when the joint is at zero in this
            file [m or rad], written as ``<joint_sensor joint="..." zero="..."/>`` (an existing element
            for the joint gets the new value). The sensor then reads ``q + zero``.
        mesh_filenames: Mesh ``filename`` -> new file name (e.g. a ``file://`` URI), for every mesh
            element with that file name.

    Raises:
        RobotFileError: the text is not a URDF; a joint, loop, anchor role, sensor joint or mesh file
            does not exist; a new link or joint name is taken, or a new parent is given to a link other
            than the root.
        ValueError: ``header_note`` or a link's comment cannot be an XML comment (contains ``--`` or
            ends with ``-``).
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
    edits += _mesh_edits(data, index, mesh_filenames or {})
    root_edits, tail = _fixed_link_edits(data, index, fixed_links)
    sensor_edits, sensor_tail = _sensor_edits(data, index, sensor_zeros or {})
    edits += root_edits + sensor_edits
    tail += sensor_tail
    if tail:
        first = min(element.start for element in index.links.values()) if index.links else index.root_end_tag
        edits.append(_block(data, index.root_end_tag, tail, indent=_indent_of(data, first)))
    if header_note:
        comment = _comment(header_note, "header note")
        declaration = _DECLARATION.match(data)
        at = declaration.end() if declaration else len(_BOM) if data.startswith(_BOM) else 0
        newline = b"" if declaration and data[at - 1:at] == b"\n" else b"\n" if declaration else b""
        edits.append((at, at, newline + comment + b"\n"))
    for a, b, text in sorted(edits, key=lambda e: e[0], reverse=True):
        data = data[:a] + text + data[b:]
    return data.decode("utf-8")


def write_calibrated_urdf(source_text: str, path: str | Path, joint_origins: dict[str, pin.SE3],
                          loop_origins: dict[tuple[str, str], pin.SE3], header_note: str = "",
                          fixed_links: Sequence[FixedLink] = (), sensor_zeros: dict[str, float] | None = None,
                          mesh_filenames: dict[str, str] | None = None) -> None:
    """Write :func:`calibrated_urdf_text` to ``path`` (UTF-8)."""
    text = calibrated_urdf_text(source_text, joint_origins, loop_origins, header_note, fixed_links, sensor_zeros,
                                mesh_filenames)
    Path(path).write_text(text, encoding="utf-8")
