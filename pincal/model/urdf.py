"""Reading pincal's URDF extensions: ``<loop>`` closures and ``<transmission>`` actuation.

The convention (README.md, "Loops in URDF"; after the URDF+ proposal of Chignoli et al., 2024)::

    <loop name="leg1_platform" type="spherical">
      <predecessor link="forearm_1"><origin xyz="0 0 -0.48" rpy="0 0 0"/></predecessor>
      <successor link="platform"><origin xyz="0.03 0 0" rpy="0 0 0"/></successor>
      <axis xyz="1 0 0"/>   <!-- revolute / prismatic only, in the predecessor anchor frame -->
    </loop>

Lengths are in metres, angles in radians. Plain URDF readers ignore these elements, so every file
still loads as a tree elsewhere.
"""

from __future__ import annotations

import contextlib
import math
import xml.etree.ElementTree as ET
from collections.abc import Iterator
from xml.parsers import expat

import numpy as np
import pinocchio as pin

from pincal.errors import LoopError, PincalError, RobotFileError, listing
from pincal.records import record

#: Loop types and the number of closure rows each contributes.
LOOP_ROWS: dict[str, int] = {"spherical": 3, "revolute": 5, "prismatic": 5, "fixed": 6}

#: URDF joint types that carry one degree of freedom and may be actuated.
SCALAR_JOINT_TYPES = ("revolute", "continuous", "prismatic")


@record(frozen=True)
class LoopSpec:
    """One loop closure as declared in the file.

    Attributes:
        name: Loop name.
        type: ``spherical``, ``revolute``, ``prismatic`` or ``fixed``.
        predecessor: Link carrying the first anchor.
        predecessor_origin: Anchor placement in the predecessor link frame [m, rad].
        successor: Link carrying the second anchor.
        successor_origin: Anchor placement in the successor link frame [m, rad].
        axis: Unit axis of relative motion in the predecessor anchor frame (revolute/prismatic).
    """

    name: str
    type: str
    predecessor: str
    predecessor_origin: pin.SE3
    successor: str
    successor_origin: pin.SE3
    axis: np.ndarray

    @property
    def rows(self) -> int:
        """Number of scalar closure equations of this loop."""
        return LOOP_ROWS[self.type]

    def with_origins(self, predecessor_origin: pin.SE3, successor_origin: pin.SE3) -> LoopSpec:
        """A copy with new anchor placements (used when anchors are calibrated)."""
        return LoopSpec(self.name, self.type, self.predecessor, predecessor_origin.copy(),
                        self.successor, successor_origin.copy(), self.axis.copy())


@record(frozen=True)
class UrdfExtensions:
    """What pincal reads from a URDF beyond the tree: loops, actuated joints and the link/joint names."""

    robot_name: str
    loops: list[LoopSpec]
    transmitted_joints: list[str]
    links: list[str]
    joints: dict[str, str]  # joint name -> URDF type
    mimics: dict[str, tuple[str, float, float]]  # follower -> (leader, multiplier, offset [rad or m]), from <mimic>
    notes: tuple[str, ...] = ()  # what the file says that pincal ignores, and why


class ElementLines:
    """The line (from 1) on which each element of a parsed URDF starts, read from its text only when an error asks:
    ElementTree keeps no lines, so the text is read again by expat, element for element in the same order."""

    def __init__(self, text: str, root: ET.Element) -> None:
        self.text, self.root = text, root

    def of(self, node: ET.Element) -> int | None:
        """The line ``node`` starts on, or None when the text does not hold it."""
        starts: list[int] = []
        parser = expat.ParserCreate()
        parser.StartElementHandler = lambda name, attributes: starts.append(parser.CurrentLineNumber)
        try:
            parser.Parse(self.text, True)
        except expat.ExpatError:  # not the text ``root`` was parsed from
            return None
        index = next((k for k, element in enumerate(self.root.iter()) if element is node), len(starts))
        return starts[index] if index < len(starts) else None

    @contextlib.contextmanager
    def at(self, node: ET.Element) -> Iterator[None]:
        """A block whose :class:`PincalError` names ``node``'s line when it names none."""
        try:
            yield
        except PincalError as error:
            if error.line is None:
                error.line = self.of(node)
            raise


def _floats(text: str | None, count: int, what: str) -> np.ndarray:
    if text is None:
        return np.zeros(count)
    parts = text.split()
    try:
        values = np.array([float(p) for p in parts])
    except ValueError:
        raise RobotFileError(f"{what}: '{text}' is not {count} numbers") from None
    if values.size != count:
        raise RobotFileError(f"{what}: '{text}' has {values.size} numbers, expected {count}")
    if not np.all(np.isfinite(values)):
        raise RobotFileError(f"{what}: '{text}' contains NaN or infinity")
    return values


def origin_to_se3(element: ET.Element | None, what: str) -> pin.SE3:
    """The placement given by an ``<origin xyz rpy>`` element (identity when absent) [m, rad]."""
    if element is None:
        return pin.SE3.Identity()
    xyz = _floats(element.get("xyz"), 3, f"{what} origin xyz")
    rpy = _floats(element.get("rpy"), 3, f"{what} origin rpy")
    return pin.SE3(pin.rpy.rpyToMatrix(*rpy), xyz)


def _anchor(loop: ET.Element, tag: str, name: str, links: set[str], link_list: list[str]
            ) -> tuple[str, pin.SE3]:
    node = loop.find(tag)
    if node is None:
        raise LoopError(f"loop '{name}' has no <{tag}> element")
    link = node.get("link")
    if not link:
        raise LoopError(f"loop '{name}': <{tag}> has no link attribute")
    if link not in links:
        raise LoopError(f"loop '{name}' names link '{link}' as {tag}; links are: {listing(link_list)}")
    return link, origin_to_se3(node.find("origin"), f"loop '{name}' {tag}")


def _loop(node: ET.Element, links: set[str], link_list: list[str]) -> LoopSpec:
    name = node.get("name")
    if not name:
        raise LoopError("a <loop> element has no name attribute")
    kind = node.get("type")
    if kind not in LOOP_ROWS:
        raise LoopError(f"loop '{name}' has type '{kind}'; valid types are: {listing(LOOP_ROWS)}")
    pred, pred_origin = _anchor(node, "predecessor", name, links, link_list)
    succ, succ_origin = _anchor(node, "successor", name, links, link_list)
    for side, origin in (("predecessor", pred_origin), ("successor", succ_origin)):
        if float(np.max(np.abs(origin.translation))) > MAX_ORIGIN:
            raise LoopError(f"loop '{name}' {side} origin is beyond {MAX_ORIGIN:g} m: a typo or a unit error")
    if pred == succ:
        raise LoopError(f"loop '{name}' joins link '{pred}' to itself")
    axis_node = node.find("axis")
    axis = _floats(axis_node.get("xyz") if axis_node is not None else None, 3, f"loop '{name}' axis")
    if axis_node is None:
        axis = np.array([1.0, 0.0, 0.0])
    norm = float(np.linalg.norm(axis))
    if norm < 1e-12:
        raise LoopError(f"loop '{name}' has a zero axis")
    return LoopSpec(name, kind, pred, pred_origin, succ, succ_origin, axis / norm)


#: Largest robot file pincal reads [bytes]: 50 times the largest URDF of example-robot-data (TIAGo dual, 0.2 MB). A
#: robot file is read several times over (checked, built by Pinocchio, indexed for writing, its meshes listed); one
#: of 50 MB took minutes of CPU. A URDF that large holds what no kinematic model needs (inline data, comments, copies
#: of visual elements): refused before it is read.
MAX_URDF_BYTES = 10 * 2**20


def check_urdf_size(size: int, source: str = "URDF") -> None:
    """Refuse a robot file of more than :data:`MAX_URDF_BYTES` (``size`` in bytes, or characters of a text), before
    anything parses it.

    Raises:
        RobotFileError: naming the file, its size and the cap.
    """
    if size > MAX_URDF_BYTES:
        raise RobotFileError(f"{source} is {size / 2**20:.1f} MiB; pincal reads robot files of at most "
                             f"{MAX_URDF_BYTES // 2**20} MiB (the largest example-robot-data URDF is 0.2 MB): remove "
                             "what a kinematic model does not need (comments, inline data, repeated visuals)")


def parse_urdf(text: str, source: str = "URDF") -> ET.Element:
    """The ``<robot>`` element of URDF text, its size checked first (:func:`check_urdf_size`).

    Raises:
        RobotFileError: too large, not well-formed XML (its ``line`` the parser's), or not a ``<robot>`` document.
    """
    check_urdf_size(len(text), source)
    try:
        root = ET.fromstring(text)
    except ET.ParseError as exc:
        raise RobotFileError(f"{source} is not well-formed XML: {exc}", line=exc.position[0]) from None
    if root.tag != "robot":
        raise RobotFileError(f"{source}: root element is <{root.tag}>, expected <robot>")
    return root


def read_extensions(text: str, source: str = "URDF", root: ET.Element | None = None) -> UrdfExtensions:
    """Parse the tree's names and pincal's ``<loop>``/``<transmission>`` elements from URDF text.

    Args:
        text: The URDF.
        source: Its name, for the errors.
        root: ``text`` parsed already (:func:`parse_urdf`), to read it once.

    Raises:
        RobotFileError: the text is not a URDF document, or larger than :data:`MAX_URDF_BYTES`; a link or joint
            without a name or of a name used twice, a mimic that cannot be, a nested loop (its ``line`` the one the
            element at fault starts on).
        LoopError: a loop or transmission is malformed or names a missing link or joint (a loop's ``line`` the one it
            starts on).
    """
    root = parse_urdf(text, source) if root is None else root
    if root.tag != "robot":
        raise RobotFileError(f"{source}: root element is <{root.tag}>, expected <robot>")
    link_list = [n.get("name", "") for n in root.findall("link")]
    joints = {n.get("name", ""): n.get("type", "") for n in root.findall("joint")}
    lines = ElementLines(text, root)
    _check_names(root, source, lines)
    _check_tree(root, source, lines)
    loops = _loops(root, set(link_list), link_list, lines)
    transmission_problems = _check_top_level(root, source, lines)
    transmitted, unusable = _transmitted_joints(root, joints)
    mimics, notes = _mimics(root, joints, source, lines)
    transmission_problems += unusable + [
        (f"joint '{j}' has both a <transmission> and a <mimic> element",
         "a mimic joint follows its leader and cannot be actuated on its own") for j in transmitted if j in mimics]
    if mimics and loops:
        raise RobotFileError(f"{source}: joint {listing(list(mimics))} has a <mimic> element; pincal supports mimic "
                             "joints in serial robots only, not in robots with <loop> elements")
    if loops and transmission_problems:  # the transmissions choose a closed-loop robot's actuated joints
        what, valid = transmission_problems[0]
        raise LoopError(f"{source}: {what}; {valid}")
    notes += [f"{what}: ignored (a serial robot's actuated joints are its movable joints)"
              for what, _ in transmission_problems]
    transmitted = [j for j in transmitted if j not in mimics]
    return UrdfExtensions(root.get("name", "robot"), loops, transmitted, link_list, joints, mimics, tuple(notes))


def _check_names(root: ET.Element, source: str, lines: ElementLines) -> None:
    """Refuse a ``<link>`` or ``<joint>`` without a name, or a name used twice within its kind (the second's line)."""
    for kind in ("link", "joint"):
        seen: set[str] = set()
        for node in root.findall(kind):
            n = node.get("name", "")
            if not n:
                raise RobotFileError(f"{source}: a <{kind}> element has no name", line=lines.of(node))
            if n in seen:
                raise RobotFileError(f"{source}: duplicate {kind} name '{n}'", line=lines.of(node))
            seen.add(n)


def _check_tree(root: ET.Element, source: str, lines: ElementLines) -> None:
    """Refuse a link that is the child of several joints: a closed chain written as a graph, not a tree (the second
    joint's line)."""
    parents: dict[str, list[ET.Element]] = {}
    for joint in root.findall("joint"):
        child = joint.find("child")
        if child is not None:
            parents.setdefault(child.get("link", ""), []).append(joint)
    for link, nodes in parents.items():
        if len(nodes) > 1:
            named = [node.get("name", "") for node in nodes]
            raise RobotFileError(f"{source}: link '{link}' is the child of {len(named)} joints ({listing(named)}); a "
                                 "URDF is a tree: cut a closed chain with a <loop> element (README, Loops in URDF)",
                                 line=lines.of(nodes[1]))


def _check_top_level(root: ET.Element, source: str, lines: ElementLines) -> list[tuple[str, str]]:
    """Refuse a ``<loop>`` nested in another element instead of a child of ``<robot>``; return the same problem of
    each ``<transmission>`` (a ``<ros2_control>`` block holds some) as (what, what would be valid): only a
    closed-loop robot refuses it."""
    problems: list[tuple[str, str]] = []
    for tag in ("loop", "transmission"):  # Pinocchio ignores them anywhere; pincal reads only top-level ones
        top = {id(n) for n in root.findall(tag)}
        for parent in root.iter():
            for child in parent:
                if child.tag == tag and id(child) not in top:
                    what = (f"<{tag} name='{child.get('name', '')}'> is inside <{parent.tag} "
                            f"name='{parent.get('name', '')}'>")
                    if tag == "loop":
                        raise RobotFileError(f"{source}: {what}; <loop> elements must be children of <robot>",
                                             line=lines.of(child))
                    problems.append((what, "<transmission> elements must be children of <robot>"))
    return problems


def _loops(root: ET.Element, links: set[str], link_list: list[str], lines: ElementLines) -> list[LoopSpec]:
    """The top-level ``<loop>`` closures, in file order; LoopError on a malformed or duplicate one (its line)."""
    loops: list[LoopSpec] = []
    for node in root.findall("loop"):
        with lines.at(node):
            loop = _loop(node, links, link_list)
            if any(existing.name == loop.name for existing in loops):
                raise LoopError(f"duplicate loop name '{loop.name}'")
        loops.append(loop)
    return loops


def _transmitted_joints(root: ET.Element, joints: dict[str, str]) -> tuple[list[str], list[tuple[str, str]]]:
    """The actuated joints the ``<transmission>`` elements name, in file order; and, as (what, what would be valid),
    the problem of each left out: naming no joint, a joint that does not exist or is not revolute, continuous or
    prismatic, or a joint another transmission names."""
    transmitted: list[str] = []
    problems: list[tuple[str, str]] = []
    movable = [j for j, t in joints.items() if t in SCALAR_JOINT_TYPES]
    for node in root.findall("transmission"):
        tname = node.get("name", "?")
        joint_nodes = node.findall("joint")
        if not joint_nodes:
            problems.append((f"transmission '{tname}' names no joint", f"movable joints are: {listing(movable)}"))
        for jn in joint_nodes:
            jname = jn.get("name", "")
            if jname not in joints:
                problems.append((f"transmission '{tname}' names joint '{jname}', which does not exist",
                                 f"movable joints are: {listing(movable)}"))
            elif joints[jname] not in SCALAR_JOINT_TYPES:
                problems.append((f"transmission '{tname}' names joint '{jname}' of type '{joints[jname]}'",
                                 "only revolute, continuous and prismatic joints can be actuated"))
            elif jname in transmitted:
                problems.append((f"joint '{jname}' is named by two transmissions", "name it once"))
            else:
                transmitted.append(jname)
    return transmitted, problems


def _mimics(root: ET.Element, joints: dict[str, str], source: str, lines: ElementLines
            ) -> tuple[dict[str, tuple[str, float, float]], list[str]]:
    """``<mimic joint= multiplier= offset=>`` elements: a follower joint at ``multiplier · leader + offset``
    [rad or m], as follower -> (leader, multiplier, offset); and the notes on those ignored (a fixed joint cannot
    move, so its ``<mimic>`` says nothing)."""
    mimics: dict[str, tuple[str, float, float]] = {}
    notes: list[str] = []
    for joint in root.findall("joint"):
        node = joint.find("mimic")
        if node is None:
            continue
        with lines.at(node):  # the <mimic> element
            name, leader = joint.get("name", ""), node.get("joint", "")
            what = f"{source}: joint '{name}' <mimic>"
            if leader not in joints or joints[leader] not in SCALAR_JOINT_TYPES:
                raise RobotFileError(f"{what} follows '{leader}', which is not a revolute, continuous or prismatic "
                                     "joint of the file")
            multiplier = float(_floats(node.get("multiplier", "1"), 1, f"{what} multiplier")[0])
            offset = float(_floats(node.get("offset", "0"), 1, f"{what} offset")[0])
            if joints[name] == "fixed":
                notes.append(f"the <mimic> of fixed joint '{name}' is ignored: a fixed joint does not move")
                continue
            if joints[name] not in SCALAR_JOINT_TYPES:
                raise RobotFileError(f"{what}: only revolute, continuous and prismatic joints can mimic")
            if (joints[name] == "continuous") != (joints[leader] == "continuous"):  # cos/sin pair against one value
                raise RobotFileError(f"{what}: a {joints[name]} joint cannot follow '{leader}', a {joints[leader]} "
                                     "joint; a continuous joint mimics a continuous one only")
            mimics[name] = (leader, multiplier, offset)
    for name, (leader, _, _) in mimics.items():
        if leader in mimics:
            raise RobotFileError(f"{source}: joint '{name}' mimics '{leader}', which mimics another joint; a leader "
                                 "must be a joint of its own")
    return mimics, notes


#: Largest plausible joint-origin translation [m]: beyond it a value is a typo or a unit error.
MAX_ORIGIN = 1e4


def check_finite_origins(text: str, source: str = "URDF", root: ET.Element | None = None) -> None:
    """Refuse joint origins with NaN/inf, non-numeric or implausibly large values (Pinocchio would
    read them silently); ``root``: ``text`` parsed already (:func:`parse_urdf`).

    Raises:
        RobotFileError: naming the joint, its ``line`` the one the joint starts on.
    """
    root = parse_urdf(text, source) if root is None else root
    lines = ElementLines(text, root)
    for joint in root.findall("joint"):
        with lines.at(joint):
            placement = origin_to_se3(joint.find("origin"), f"{source}: joint '{joint.get('name')}'")
            if float(np.max(np.abs(placement.translation))) > MAX_ORIGIN:
                raise RobotFileError(f"{source}: joint '{joint.get('name')}' origin xyz "
                                     f"{np.array2string(placement.translation, precision=4)} m is beyond "
                                     f"{MAX_ORIGIN:g} m: a typo or a unit error (URDF lengths are in metres)")
            limit = joint.find("limit")
            if limit is not None and joint.get("type") in ("revolute", "prismatic"):
                bounds = [limit.get(k) for k in ("lower", "upper")]
                if None not in bounds:
                    what = f"{source}: joint '{joint.get('name')}' limit"
                    lower, upper = (float(_floats(text, 1, what)[0]) for text in bounds)
                    if lower > upper:
                        raise RobotFileError(f"{source}: joint '{joint.get('name')}' has limit lower {lower:g} > "
                                             f"upper {upper:g}")
            axis = joint.find("axis")
            if axis is not None:
                values = _floats(axis.get("xyz"), 3, f"{source}: joint '{joint.get('name')}' axis")
                if joint.get("type") in SCALAR_JOINT_TYPES and math.isclose(float(np.linalg.norm(values)), 0):
                    raise RobotFileError(f"{source}: joint '{joint.get('name')}' has a zero axis")
