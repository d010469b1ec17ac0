"""Every export proved by reloading it (``pincal export``; docs/calibrated_urdf.md, "Exports"). SI units: m, rad.

An export is read back the way its consumer reads it and compared with the model it was written from, pincal's
:class:`~pincal.model.robot.Robot` of the URDF, at the postures the calibration fitted (the joint readings of the data
file the URDF records, when it is there) and :data:`POSTURES` random ones within the joint limits:

- the URDF itself, by plain Pinocchio (``buildModelFromXML``) and by yourdfpy: every link's placement in the root link;
- the per-joint YAML, composed back into joint origins (``origin xyz = x y z``, ``rpy = roll pitch yaw``, as
  ur_description's xacro composes its ``kinematics:`` entries) and loaded: every link's placement;
- a DH or modified-DH table, read back from its text and turned into forward kinematics (``base · A_1 ⋯ A_n · tool``):
  the end frame in the base frame.

The largest deviation goes into the export's header and the terminal; above the tolerance the export is refused.
"""

from __future__ import annotations

import io
import json
import math
import re
from pathlib import Path

import numpy as np
import numpy.typing as npt
import pinocchio as pin

from pincal.errors import PincalError, RobotFileError
from pincal.model.dh import Convention, DHRow, DHTable, chain_joints
from pincal.model.robot import Robot, robot_from_urdf_text
from pincal.model.urdf import read_extensions
from pincal.records import record

Array = npt.NDArray[np.float64]
#: Links are body frames: a joint may bear a link's name.
BODY = pin.FrameType.BODY

#: Largest deviation [m, rad] of a reloaded export from the model, for it to be written.
TOLERANCE = 1e-9
#: Random postures besides the fitted ones.
POSTURES = 100


@record(frozen=True)
class Deviation:
    """How far a reader's reading of an export is from the model: largest distance [m] and angle [rad]."""

    reader: str
    position: float
    orientation: float


@record(frozen=True)
class Postures:
    """The postures an export is checked at: (N, nq) configurations of the model, the first ``fitted`` the calibration
    data's."""

    q: Array
    fitted: int
    seed: int

    def words(self) -> str:
        """In words: how many, of which kind."""
        drawn = f"random ones within the joint limits (seed {self.seed})"
        if not self.fitted:
            return f"{len(self.q)} {drawn.replace('ones', 'postures')}"
        return f"the {self.fitted} postures of the calibration data and {len(self.q) - self.fitted} {drawn}"


def proof_postures(robot: Robot, model_path: str | Path | None, count: int = POSTURES, seed: int = 0) -> Postures:
    """The fitted postures of the calibration the URDF at ``model_path`` records (its data file's actuated readings,
    when the file is there and reads), then ``count`` random postures within the limits."""
    from pincal.calibration.provenance import read_provenance
    from pincal.io.dataset_reader import read_dataset
    from pincal.study.simulation import random_actuated

    rows: list[Array] = []
    if model_path is not None and Path(model_path).is_file():
        data = read_provenance(model_path).data
        if data is not None and data.is_file() and data.suffix.lower() == ".csv":
            try:
                dataset = read_dataset(data, robot.actuated_joints)
                columns = [dataset.joint_names.index(name) for name in robot.actuated_joints]
                rows += list(robot.solve_fk_batch(dataset.joints[:, columns]))
            except (PincalError, ValueError):
                rows = []
    fitted = len(rows)
    _, q = random_actuated(robot, count, np.random.default_rng(seed))
    return Postures(np.array([*rows, *q]), fitted, seed)


def _gap(a: pin.SE3, b: pin.SE3) -> tuple[float, float]:
    gap = a.inverse() * b
    return float(np.linalg.norm(gap.translation)), float(np.linalg.norm(pin.log3(gap.rotation)))


def _links(robot: Robot) -> list[str]:
    return [str(f.name) for f in robot.model.frames if f.type == pin.FrameType.BODY]


def _placements(robot: Robot, q: Array) -> dict[str, pin.SE3]:
    """Every link's placement in the root link at ``q``."""
    model, data = robot.model, robot.model.createData()
    pin.framesForwardKinematics(model, data, q)
    links = _links(robot)
    root = data.oMf[model.getFrameId(links[0], BODY)].inverse()
    return {name: root * data.oMf[model.getFrameId(name, BODY)] for name in links}


def _largest(reader: str, pairs: list[tuple[pin.SE3, pin.SE3]]) -> Deviation:
    gaps = [_gap(a, b) for a, b in pairs] or [(0.0, 0.0)]
    return Deviation(reader, max(g[0] for g in gaps), max(g[1] for g in gaps))


def _joint_values(robot: Robot, q: Array) -> dict[str, float]:
    """Each one-coordinate joint's value [rad or m] at ``q`` (a continuous joint's angle)."""
    out = {}
    for j in range(1, robot.model.njoints):
        joint = robot.model.joints[j]
        if joint.nq == 1:
            out[str(robot.model.names[j])] = float(q[joint.idx_q])
        elif joint.nq == 2 and joint.nv == 1:
            out[str(robot.model.names[j])] = math.atan2(q[joint.idx_q + 1], q[joint.idx_q])
    return out


def _several_coordinates(robot: Robot) -> dict[str, tuple[int, int]]:
    """The joints of more than one degree of freedom (floating, planar): name -> (first index in q, nq)."""
    out = {}
    for j in range(1, robot.model.njoints):
        joint = robot.model.joints[j]
        if joint.nv > 1:
            out[str(robot.model.names[j])] = (int(joint.idx_q), int(joint.nq))
    return out


def _neutral_where(robot: Robot, q: Array, joints: dict[str, tuple[int, int]]) -> Array:
    """``q`` with the coordinates of ``joints`` (as :func:`_several_coordinates`) at the model's neutral (origin)."""
    out = np.array(q, dtype=float)
    neutral = pin.neutral(robot.model)
    for start, count in joints.values():
        out[start:start + count] = neutral[start:start + count]
    return out


_GEOMETRY = re.compile(r"<(visual|collision)\b[^>]*?(?:/>|>.*?</\1\s*>)", re.DOTALL)


def urdf_deviations(urdf_text: str, robot: Robot, postures: Postures, with_yourdfpy: bool = True) -> list[Deviation]:
    """The URDF reloaded by plain Pinocchio (a ``<mimic>`` follower, a joint of its own there, set as its ``<mimic>``
    says from its leader [rad or m]) and, unless not ``with_yourdfpy``, by yourdfpy against ``robot``: every link's
    placement in the root."""
    plain = pin.buildModelFromXML(urdf_text)
    mimics = read_extensions(urdf_text).mimics  # follower -> (leader, multiplier, offset)
    data = plain.createData()
    loaded = None
    if with_yourdfpy:  # its import alone (trimesh, networkx, scipy.special) costs a calibration about 0.4 s
        import yourdfpy

        kinematic = _GEOMETRY.sub("", urdf_text)  # yourdfpy parses visuals pincal leaves out (with a note) when bad
        loaded = yourdfpy.URDF.load(io.BytesIO(kinematic.encode("utf-8")), build_scene_graph=True, load_meshes=False,
                                    build_collision_scene_graph=False, load_collision_meshes=False)
    links = _links(robot)
    root = links[0]
    by_pinocchio: list[tuple[pin.SE3, pin.SE3]] = []
    by_yourdfpy: list[tuple[pin.SE3, pin.SE3]] = []
    several = _several_coordinates(robot)
    for q in postures.q:
        expected = _placements(robot, q)
        values = _joint_values(robot, q)
        values.update({follower: multiplier * values[leader] + offset
                       for follower, (leader, multiplier, offset) in mimics.items() if leader in values})
        q_plain = pin.neutral(plain)
        for j in range(1, plain.njoints):
            joint, name = plain.joints[j], str(plain.names[j])
            if name in values and joint.nq == 1:
                q_plain[joint.idx_q] = values[name]
            elif name in values and joint.nq == 2:
                q_plain[joint.idx_q:joint.idx_q + 2] = [math.cos(values[name]), math.sin(values[name])]
            elif name in several and several[name][1] == joint.nq:  # a floating or planar joint: its coordinates
                start = several[name][0]
                q_plain[joint.idx_q:joint.idx_q + joint.nq] = q[start:start + joint.nq]
        pin.framesForwardKinematics(plain, data, q_plain)
        base = data.oMf[plain.getFrameId(root, BODY)].inverse()
        by_pinocchio += [(expected[n], base * data.oMf[plain.getFrameId(n, BODY)]) for n in links
                         if plain.existFrame(n, BODY)]
        if loaded is None:
            continue
        # yourdfpy poses revolute, prismatic and continuous joints only: a floating or planar one at its origin
        at_origin = _placements(robot, _neutral_where(robot, q, several)) if several else expected
        loaded.update_cfg({n: values[n] for n in loaded.actuated_joint_names if n in values})
        by_yourdfpy += [(at_origin[n], pin.SE3(np.asarray(loaded.get_transform(n, root), dtype=float)))
                        for n in links if n in loaded.link_map]
    pinocchio = _largest("Pinocchio", by_pinocchio)
    return [pinocchio, _largest("yourdfpy", by_yourdfpy)] if loaded is not None else [pinocchio]


_FLOW = re.compile(r'\s*([A-Za-z_]\w*):\s*("(?:[^"\\]|\\.)*"|[^,}]*?)\s*(?:,|}|$)')


def _value(text: str) -> str:
    text = text.strip()
    return str(json.loads(text)) if text.startswith('"') else text


def flow_map(text: str) -> dict[str, str]:
    """The entries of a one-line YAML flow map ``{key: value, …}`` as pincal's exports write it."""
    inner = text.strip()
    if not (inner.startswith("{") and inner.endswith("}")):
        raise RobotFileError(f"'{text[:40]}' is not a flow map {{key: value, ...}}")
    return {m.group(1): _value(m.group(2)) for m in _FLOW.finditer(inner[1:-1]) if m.group(1)}


def _blocks(text: str) -> dict[str, dict[str, str]]:
    """The ``kinematics:`` entries of a per-joint YAML: joint → its fields."""
    out: dict[str, dict[str, str]] = {}
    current: dict[str, str] | None = None
    inside = False
    for line in text.splitlines():
        if line.startswith("#") or not line.strip():
            continue
        if not line.startswith(" "):
            inside = line.rstrip() == "kinematics:"
            continue
        if not inside:
            continue
        if line.startswith("  ") and not line.startswith("    "):
            current = out.setdefault(_value(line.strip()[:-1]), {})
        elif current is not None:
            key, _, value = line.strip().partition(":")
            current[key] = _value(value)
    return out


def _se3(fields: dict[str, str], what: str) -> pin.SE3:
    try:
        x, y, z, roll, pitch, yaw = (float(fields[k]) for k in ("x", "y", "z", "roll", "pitch", "yaw"))
    except (KeyError, ValueError):
        raise RobotFileError(f"{what}: x, y, z, roll, pitch, yaw are not all numbers") from None
    return pin.SE3(pin.rpy.rpyToMatrix(roll, pitch, yaw), np.array([x, y, z]))


def yaml_deviation(yaml_text: str, urdf_text: str, robot: Robot, postures: Postures) -> Deviation:
    """The per-joint YAML composed back into the URDF's joint origins (and loop anchors), loaded, against ``robot``."""
    from pincal.model.urdf_writer import calibrated_urdf_text

    origins = {name: _se3(fields, f"joint '{name}'") for name, fields in _blocks(yaml_text).items()}
    loops: dict[tuple[str, str], pin.SE3] = {}
    inside, current = False, ""
    for line in yaml_text.splitlines():
        if not line.startswith((" ", "#")) and line.strip():
            inside = line.rstrip() == "loops:"
        elif inside and line.startswith("  ") and not line.startswith("    "):
            current = _value(line.strip()[:-1])
        elif inside and line.strip().startswith(("predecessor:", "successor:")):
            role, _, value = line.strip().partition(":")
            loops[(current, role)] = _se3(flow_map(value), f"loop '{current}' {role}")
    composed = robot_from_urdf_text(calibrated_urdf_text(urdf_text, origins, loops))
    pairs = []
    for q in postures.q:
        expected, got = _placements(robot, q), _placements(composed, q)
        pairs += [(expected[n], got[n]) for n in expected if n in got]
    return _largest("the YAML composed into joint origins, by Pinocchio", pairs)


def read_dh(text: str) -> DHTable:
    """A DH or modified-DH table as ``pincal export --format dh|mdh`` writes it, read back.

    Raises:
        RobotFileError: a line it does not read.
    """
    fields: dict[str, str] = {}
    rows: list[DHRow] = []
    for line in text.splitlines():
        if line.startswith("#") or not line.strip():
            continue
        if line.startswith("  - "):
            row = flow_map(line[4:])
            try:
                rows.append(DHRow(row["name"], row["type"] == "prismatic", float(row["a"]), float(row["alpha"]),
                                  float(row["d"]), float(row["theta"]), float(row.get("beta", "0.0"))))
            except (KeyError, ValueError):
                raise RobotFileError(f"DH row '{line.strip()[:60]}' is not read") from None
        else:
            key, _, value = line.partition(":")
            fields[key.strip()] = value.strip()
    convention = fields.get("convention", "")
    if convention not in ("dh", "mdh", "hayati"):
        raise RobotFileError(f"convention '{convention}' is not dh, mdh or hayati")
    kind: Convention = "dh" if convention == "dh" else "mdh" if convention == "mdh" else "hayati"
    return DHTable(kind, _value(fields.get("base_frame", "")), _value(fields.get("end_frame", "")),
                   _se3(flow_map(fields["base"]), "base"), tuple(rows), _se3(flow_map(fields["tool"]), "tool"))


def dh_deviation(dh_text: str, robot: Robot, postures: Postures) -> Deviation:
    """A DH table's text read back (:func:`read_dh`) and turned into forward kinematics, against ``robot``: the end
    frame in the base frame."""
    table = read_dh(dh_text)
    model, data = robot.model, robot.model.createData()
    joints = chain_joints(robot, table.base_frame, table.end_frame)
    base, end = model.getFrameId(table.base_frame), model.getFrameId(table.end_frame)
    pairs = []
    for q in postures.q:
        values = _joint_values(robot, q)
        pin.framesForwardKinematics(model, data, q)
        chain = np.array([values[str(model.names[j])] for j in joints])
        pairs.append((data.oMf[base].inverse() * data.oMf[end], table.placement(chain)))
    return _largest(f"the {table.convention} table read back, as forward kinematics", pairs)


def header_line(deviations: list[Deviation], postures: Postures) -> str:
    """The export's header comment: each reader's deviation."""
    return ("# proved by reloading, against the model at " + postures.words() + ": " + "; ".join(
        f"{d.reader}: {d.position:.3g} m, {d.orientation:.3g} rad" for d in deviations))


def with_header(text: str, line: str) -> str:
    """``text`` with ``line`` after its leading comment lines."""
    lines = text.splitlines(keepends=True)
    k = 0
    while k < len(lines) and lines[k].startswith("#"):
        k += 1
    return "".join([*lines[:k], line + "\n", *lines[k:]])


def ur_deviations(yaml_text: str, tcp: pin.SE3, robot: Robot, base: str, tool: str,
                  postures: Postures) -> list[Deviation]:
    """The ur_description kinematics YAML read back and composed as ur_description's chain does (``origin · Rz(q)``
    per joint, then its fixed ``flange`` and ``tool0``), against ``robot``'s ``tool`` in its ``base``: with the TCP
    the export names, and without it (what the tool correction alone is)."""
    from pincal.io.ur_kinematics import JOINTS, KEYS, compose

    blocks = _blocks(yaml_text)
    missing = [key for key in KEYS if key not in blocks]
    if missing:
        raise RobotFileError(f"the ur_description kinematics lack {', '.join(missing)}")
    entries = [_se3(blocks[key], key) for key in KEYS]
    with_tcp: list[tuple[pin.SE3, pin.SE3]] = []
    without: list[tuple[pin.SE3, pin.SE3]] = []
    for q in postures.q:
        values = _joint_values(robot, q)
        composed = compose(entries, np.array([values[name] for name in JOINTS]))[-1]
        expected = robot.placement(q, base).inverse() * robot.placement(q, tool)
        with_tcp.append((expected, composed * tcp))
        without.append((expected, composed))
    return [_largest("ur_description's chain composed from the YAML, with the TCP", with_tcp),
            _largest("without the TCP (the calibrated tool frame's correction)", without)]


#: Fitted and random postures the calibrated URDF ``pincal calibrate`` writes is checked at (each at most).
CALIBRATED_POSTURES = 10
#: The smallest bound a proof states [m, rad]: below it, round-off decides the figure.
FLOOR = 1e-12


def bound(value: float) -> str:
    """``value`` [m or rad] as a bound that does not depend on round-off: ``1e-12`` below :data:`FLOOR`, else the
    power of ten at or above it."""
    if not value > FLOOR:
        return f"{FLOOR:.0e}"
    return f"{10.0 ** math.ceil(math.log10(value) - 1e-9):.0e}"


def calibrated_proof(urdf_text: str, robot: Robot, joint_names: list[str], readings: Array, seed: int = 0) -> str:
    """The calibrated URDF ``pincal calibrate`` writes, reloaded by plain Pinocchio (:func:`urdf_deviations`; yourdfpy
    too in ``pincal export``, whose import would cost every calibration about 0.4 s) and compared with ``robot``, the
    calibrated model it was written from (pincal's Robot of that text: its geometric part, what a URDF holds; harmonics
    and compliance live in the corrections file) at up to :data:`CALIBRATED_POSTURES` of the fitted postures
    (``readings`` [rad or m], columns ``joint_names``, evenly spaced) and as many random ones within the joint limits
    (``seed``).

    Returns:
        One line: each deviation as a bound [m, rad] (:func:`bound`) and the number of postures.

    Raises:
        PincalError: a reader's deviation above :data:`TOLERANCE`.
    """
    from pincal.study.simulation import random_actuated

    rows: list[Array] = []
    if len(readings):  # an actuated joint with no column at its reference, as the fit read it
        reference = robot.actuated_values(robot.q_reference)
        picked = np.array([np.asarray(readings, dtype=float)[:, joint_names.index(name)] if name in joint_names
                           else np.full(len(readings), reference[k])
                           for k, name in enumerate(robot.actuated_joints)]).T
        step = max(1, len(picked) // CALIBRATED_POSTURES)
        try:
            rows = list(robot.solve_fk_batch(picked[::step][:CALIBRATED_POSTURES]))
        except (PincalError, ValueError):
            rows = []
    _, q = random_actuated(robot, CALIBRATED_POSTURES, np.random.default_rng(seed))
    postures = Postures(np.array([*rows, *q]), len(rows), seed)
    return proof_statement(urdf_deviations(urdf_text, robot, postures, with_yourdfpy=False), len(postures.q))


def proof_statement(deviations: list[Deviation], count: int) -> str:
    """The line a calibrated URDF's proof prints and writes in its header; refused above :data:`TOLERANCE`.

    Raises:
        PincalError: a reader's deviation above :data:`TOLERANCE` (naming it).
    """
    worst = max(deviations, key=lambda d: max(d.position, d.orientation))
    if max(worst.position, worst.orientation) > TOLERANCE:
        raise PincalError(f"calibrate: {worst.reader} reads the calibrated URDF {worst.position:.1g} m, "
                          f"{worst.orientation:.1g} rad away from the calibrated model (tolerance {TOLERANCE:g}): "
                          "not written")
    return (f"the calibrated URDF reloaded by plain Pinocchio: within {bound(worst.position)} m, "
            f"{bound(worst.orientation)} rad of the calibrated model at {count} postures")


_LEADING = re.compile(r"(?:<\?xml[^>]*\?>[ \t]*\n?)?(?:<!--(?:(?!-->).)*-->[ \t]*\n)?", re.DOTALL)


def with_comment(urdf_text: str, line: str) -> str:
    """``urdf_text`` with ``line`` as an XML comment after its declaration and header note (a comment changes no
    placement: the proof of the text holds for the text with it)."""
    at = _LEADING.match(urdf_text)
    end = at.end() if at else 0
    return urdf_text[:end] + f"<!-- {line} -->\n" + urdf_text[end:]
