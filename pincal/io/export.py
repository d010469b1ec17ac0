"""A URDF's joint placements in the formats robots' software reads: per-joint x, y, z, roll, pitch, yaw YAML, and
a DH or modified-DH table (docs/calibrated_urdf.md, "Exports").

- ``yaml``: every ``<joint>``'s ``<origin>`` as the file holds it, keyed by joint name under ``kinematics:`` (the
  layout of ur_description's ``default_kinematics.yaml``), with its parent, child and type; each ``<loop>``'s
  two anchors under ``loops:``. Any robot, closed loops included.
- ``dh``, ``mdh``: the chain from a base frame to an end frame as a table (:mod:`pincal.model.dh`), with the base
  and tool transforms that make it exact and the conversion residual; refused where it is not representable.

Both are YAML (1.1 and 1.2 read the same values: every number has a decimal point). Lengths [m], angles [rad];
orientations in URDF's roll, pitch, yaw: ``R = Rz(yaw) · Ry(pitch) · Rx(roll)``.

A name (of the robot, a joint, a link, a frame, the source file) goes into the file as a key or value only as a plain
YAML word or a double-quoted string with its escapes (:func:`_key`), and into a ``#`` comment only as it is when it
holds no line break nor other control character, else as that quoted string (:func:`shown_name`): no name can end a
comment or a line and add a key of its own.
"""

from __future__ import annotations

import json
import re
import unicodedata
import xml.etree.ElementTree as ET
from typing import Literal

import pinocchio as pin

from pincal import validation
from pincal.errors import RobotFileError
from pincal.model.dh import CONVENTIONS, Convention, DHTable, Residual, conversion_residual, dh_table
from pincal.model.robot import Robot
from pincal.records import record

ExportFormat = Literal["yaml", "dh", "mdh", "hayati", "ur"]
#: The formats, the default first (``ur``: :mod:`pincal.io.ur_kinematics`).
FORMATS: tuple[ExportFormat, ...] = ("yaml", *CONVENTIONS, "ur")
#: Largest conversion residual of a DH table, position [m] and orientation [rad], for it to be written.
TOLERANCE = 1e-9
#: Random postures the residual is measured at (besides the zero posture).
POSTURES = 100
#: A calibrated URDF's measurement frame and the joint that hangs the robot below it (pincal.io.calibrated_urdf).
MEASUREMENT_FRAME, MEASUREMENT_JOINT = "measurement_frame", "measurement_frame_joint"

_PLAIN = re.compile(r"[A-Za-z_][A-Za-z0-9_.\-/]*")
_YAML_WORDS = {"y", "n", "yes", "no", "on", "off", "true", "false", "null", "~"}


def _key(name: str) -> str:
    """A YAML key: the name as is when plain, else a double-quoted (JSON) string."""
    plain = _PLAIN.fullmatch(name) and name.lower() not in _YAML_WORDS
    return name if plain else json.dumps(name)


def shown_name(name: str) -> str:
    """``name`` as a comment or a terminal line shows it: as it is, or, when it holds a line break or another
    control character (which would end a ``#`` comment), as a double-quoted string with its escapes."""
    unsafe = any(unicodedata.category(c)[0] == "C" or unicodedata.category(c) in ("Zl", "Zp") for c in name)
    return json.dumps(name) if unsafe else name


def _quoted(name: str) -> str:
    """``'name'`` in a comment, or ``name`` as :func:`shown_name` escapes it when it must be."""
    shown = shown_name(name)
    return shown if shown != name else f"'{name}'"


def _parsed(urdf_text: str) -> ET.Element:
    """The ``<robot>`` element of ``urdf_text``.

    Raises:
        TypeError: not a string.
        RobotFileError: not XML, or not a ``<robot>``.
    """
    validation.instance("urdf_text", urdf_text, str, "the text of a URDF (str)")
    try:
        tree = ET.fromstring(urdf_text)
    except ET.ParseError as exc:
        raise RobotFileError(f"urdf_text={validation.shown(urdf_text, 40)}: not a URDF: XML {exc}") from None
    if tree.tag != "robot":
        raise RobotFileError(f"urdf_text: the root element is <{tree.tag}>, not <robot>: not a URDF")
    return tree


def _num(value: float) -> str:
    """A float both YAML 1.1 and 1.2 read as that float: the shortest round-trip text, with a decimal point."""
    text = repr(float(value))
    mantissa, e, exponent = text.partition("e")
    if e and "." not in mantissa:
        mantissa += ".0"
    return mantissa + (f"e{'+' if not exponent.startswith('-') else ''}{exponent.lstrip('+')}" if e else "")


def _pose_fields(xyz: tuple[float, ...], rpy: tuple[float, ...]) -> list[tuple[str, str]]:
    return [(k, _num(v)) for k, v in zip(("x", "y", "z", "roll", "pitch", "yaw"), (*xyz, *rpy), strict=True)]


def _se3_fields(placement: pin.SE3) -> list[tuple[str, str]]:
    return _pose_fields(tuple(placement.translation), tuple(pin.rpy.matrixToRpy(placement.rotation)))


def _flow(fields: list[tuple[str, str]]) -> str:
    return "{" + ", ".join(f"{k}: {v}" for k, v in fields) + "}"


def _origin(node: ET.Element | None, what: str) -> tuple[tuple[float, ...], tuple[float, ...]]:
    """(xyz [m], rpy [rad]) of an ``<origin>`` as written (zeros where absent)."""
    values = []
    for attribute in ("xyz", "rpy"):
        text = node.get(attribute, "0 0 0") if node is not None else "0 0 0"
        try:
            parsed = tuple(float(v) for v in text.split())
        except ValueError:
            parsed = ()
        if len(parsed) != 3:
            raise RobotFileError(f"{what}: <origin {attribute}='{text}'> is not three numbers")
        values.append(parsed)
    return values[0], values[1]


def joint_origins_yaml(urdf_text: str, source: str) -> str:
    """The ``yaml`` export of a URDF (module docstring): every joint's origin, every loop's anchors.

    Args:
        urdf_text: The URDF.
        source: What it is, for the header comment (its file, its SHA-256).

    Raises:
        TypeError: an argument that is not a string.
        RobotFileError: ``urdf_text`` is not a URDF, or an ``<origin>`` is not three numbers.
    """
    tree = _parsed(urdf_text)
    validation.instance("source", source, str, "a description (str)")
    lines = [f"# pincal export: the joint origins of {shown_name(source)} (robot {_quoted(tree.get('name', ''))}), as "
             "its <origin>s hold them",
             "# x, y, z [m]: the joint frame's origin in its parent link's frame; roll, pitch, yaw [rad]: its "
             "orientation, URDF's rpy (R = Rz(yaw) Ry(pitch) Rx(roll))",
             "# the layout of ur_description's default_kinematics.yaml, keyed by joint name; parent, child, type as "
             "in the URDF", "kinematics:"]
    for joint in tree.findall("joint"):
        name = joint.get("name", "")
        xyz, rpy = _origin(joint.find("origin"), f"joint '{name}'")
        ends = [(tag, joint.find(tag)) for tag in ("parent", "child")]
        lines.append(f"  {_key(name)}:")
        lines += [f"    {k}: {v}" for k, v in _pose_fields(xyz, rpy)]
        lines += [f"    {tag}: {_key(node.get('link', ''))}" for tag, node in ends if node is not None]
        lines.append(f"    type: {_key(joint.get('type', ''))}")
    loops = tree.findall("loop")
    if loops:
        lines.append("# each <loop>'s anchors: x .. yaw place the anchor frame in its link's frame")
        lines.append("loops:")
    for loop in loops:
        name = loop.get("name", "")
        lines += [f"  {_key(name)}:", f"    type: {_key(loop.get('type', ''))}"]
        for role in ("predecessor", "successor"):
            anchor = loop.find(role)
            if anchor is None:
                continue
            xyz, rpy = _origin(anchor.find("origin"), f"loop '{name}' {role}")
            lines.append(f"    {role}: {_flow([('link', _key(anchor.get('link', ''))), *_pose_fields(xyz, rpy)])}")
    return "\n".join(lines) + "\n"


def _root(tree: ET.Element) -> str:
    children = {c.get("link") for c in tree.findall("joint/child")}
    roots = [link.get("name", "") for link in tree.findall("link") if link.get("name") not in children]
    if len(roots) != 1:
        raise RobotFileError(f"the URDF has {len(roots)} root links; a robot has one")
    return roots[0]


def default_base(urdf_text: str) -> str:
    """The base frame of a DH table by default: the URDF's root link; in a calibrated URDF whose root is the
    measurement frame, the robot's own root below it (the child of ``measurement_frame_joint``)."""
    tree = _parsed(urdf_text)
    root = _root(tree)
    if root == MEASUREMENT_FRAME:
        for joint in tree.findall("joint"):
            child = joint.find("child")
            if joint.get("name") == MEASUREMENT_JOINT and child is not None:
                return child.get("link", root)
    return root


@record(frozen=True)
class DHExport:
    """A DH table, its conversion residual and its YAML text."""

    table: DHTable
    residual: Residual
    text: str


_LAYOUT = {
    "dh": ("classic Denavit-Hartenberg", "A_i = Rz(theta_i) Tz(d_i) Tx(a_i) Rx(alpha_i)", ("theta", "d", "a", "alpha")),
    "mdh": ("modified (Craig) Denavit-Hartenberg", "A_i = Rx(alpha_{i-1}) Tx(a_{i-1}) Rz(theta_i) Tz(d_i); row i "
            "holds alpha_{i-1}, a_{i-1}, theta_i, d_i", ("alpha", "a", "theta", "d")),
    "hayati": ("Denavit-Hartenberg with Hayati's parallel-axis rows", "A_i = Rz(theta_i) Tz(d_i) Tx(a_i) Rx(alpha_i) "
               "Ry(beta_i): classic DH where beta_i = 0, Hayati's form where d_i = 0", ("theta", "d", "a", "alpha",
                                                                                        "beta")),
}


def dh_export(robot: Robot, urdf_text: str, source: str, convention: str, end: str | None = None,
              base: str | None = None, tolerance: float = TOLERANCE, postures: int = POSTURES,
              seed: int = 0) -> DHExport:
    """The ``dh`` or ``mdh`` export of the chain from ``base`` (default :func:`default_base`) to ``end`` (default the
    robot's measured frame), verified against Pinocchio's forward kinematics.

    Raises:
        TypeError: an argument of another type.
        ArgumentError: ``tolerance`` not > 0, ``postures`` < 1, ``seed`` < 0.
        RobotFileError: ``urdf_text`` is not a URDF; not representable (closed loops, a joint neither revolute nor
            prismatic), or the conversion residual is above ``tolerance`` [m, rad].
        NotFoundError: a frame does not exist, or no end frame is obvious.
    """
    validation.instance("robot", robot, Robot, "a Robot (pincal.load_robot)")
    root = _root(_parsed(urdf_text))
    validation.instance("source", source, str, "a description (str)")
    for name, frame in (("end", end), ("base", base)):
        if frame is not None:
            validation.instance(name, frame, str, "a frame name (str) or None")
    tolerance = validation.real("tolerance", tolerance, "m, rad", strict=True)
    postures = validation.whole("postures", postures, 1)
    seed = validation.whole("seed", seed, 0)
    if convention not in CONVENTIONS:
        raise RobotFileError(f"convention '{convention}' is not one of {', '.join(CONVENTIONS)}")
    conv: Convention = "dh" if convention == "dh" else "hayati" if convention == "hayati" else "mdh"
    base = base or default_base(urdf_text)
    end = end or robot.end_effector
    table = dh_table(robot, end, base, conv)
    residual = conversion_residual(robot, table, postures, seed)
    if residual.position > tolerance or residual.orientation > tolerance:
        raise RobotFileError(f"the {conv} table of {base} -> {end} misses the URDF by {residual.position:.3g} m, "
                             f"{residual.orientation:.3g} rad (tolerance {tolerance:g}): not representable")
    title, formula, columns = _LAYOUT[conv]
    lines = [f"# pincal export: {title} table of {shown_name(source)} (robot {_quoted(robot.name)}), chain "
             f"{shown_name(base)} -> {shown_name(end)}",
             "# lengths [m], angles [rad]; the pose of the end frame in the base frame is",
             "#   base * A_1(q_1) * ... * A_n(q_n) * tool,",
             f"#   {formula},",
             "#   theta_i = theta + q_i (revolute), d_i = d + q_i (prismatic), q_i the joint's value as in the URDF",
             "# base, tool: x, y, z [m], roll, pitch, yaw [rad] (URDF rpy: R = Rz(yaw) Ry(pitch) Rx(roll))",
             f"# conversion residual: largest gap to the URDF's forward kinematics (Pinocchio) at the zero posture "
             f"and {residual.postures} random ones within the joint limits (seed {residual.seed}): "
             f"{residual.position:.3g} m, {residual.orientation:.3g} rad"]
    if base != root:
        lines.append(f"# base frame {_quoted(base)}; the URDF's root is {_quoted(root)}: the base frame's placement in "
                     "it is not in the table")
    for first, second in table.parallel:
        lines.append(f"# axes of {shown_name(first)} and {shown_name(second)} parallel: their common normal taken "
                     "with d = 0")
    swapped = {first for first, _, _ in table.hayati}
    for first, second, distance in table.hayati:
        lines.append(f"# axes of {shown_name(first)} and {shown_name(second)} nearly parallel: the row of "
                     f"{shown_name(first)} in Hayati's form (beta about y, d = 0), chosen because its classic d, "
                     f"{distance:.3g} m, exceeds the chain's size, {table.size:.3g} m")
    for first, second, angle, distance in table.near_parallel:
        if first in swapped:
            continue
        lines.append(f"# axes of {shown_name(first)} and {shown_name(second)} {angle:.3g} rad from parallel: their "
                     f"common normal is {distance:.3g} m away, d values large and cancelling (exact, as the residual "
                     "shows)")
    lines += [f"convention: {conv}", f"base_frame: {_key(base)}", f"end_frame: {_key(end)}",
              f"base: {_flow(_se3_fields(table.base))}", "joints:"]
    for row in table.rows:
        values = {"theta": row.theta, "d": row.d, "a": row.a, "alpha": row.alpha, "beta": row.beta}
        fields = [("name", _key(row.joint)), ("type", "prismatic" if row.prismatic else "revolute"),
                  *((c, _num(values[c])) for c in columns)]
        lines.append(f"  - {_flow(fields)}")
    lines += [f"tool: {_flow(_se3_fields(table.tool))}",
              f"residual: {{position: {_num(residual.position)}, orientation: {_num(residual.orientation)}, "
              f"postures: {residual.postures}, seed: {residual.seed}}}"]
    return DHExport(table, residual, "\n".join(lines) + "\n")
