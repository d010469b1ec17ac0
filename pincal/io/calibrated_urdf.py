"""The calibrated URDF: the whole calibrated model written as a URDF file.

The calibrated URDF is the nominal file with its joint and anchor origins edited, actuated offsets
folded into the actuated joints' origins, and the tree re-assembled: the closed configuration of the
calibrated robot at zero actuated readings becomes the new all-zero configuration (each passive
joint's value is folded into its origin), so the file obeys pincal's convention and loads back. The
measurement frame becomes its root link, each calibrated marker a link, and each instrumented passive
joint's sensor a ``<joint_sensor>``: the file reproduces every prediction of the calibrated model
(docs/calibrated_urdf.md).
"""

from __future__ import annotations

import math
import xml.etree.ElementTree as ET
from collections.abc import Mapping, Sequence
from pathlib import Path

import numpy as np
import numpy.typing as npt
import pinocchio as pin

from pincal.errors import ConvergenceError, DataError, RobotFileError, listing, not_found
from pincal.identification.derivatives import marker_points
from pincal.identification.measurements import Measurement, split_target
from pincal.identification.parameters import (
    JointPlacement,
    MarkerOffset,
    ParameterSet,
    ReadingOffset,
    attached_name,
    kinds_where,
    parameter_kind,
)
from pincal.model.robot import Robot, _build_model, check_reference_assembly
from pincal.model.urdf import origin_to_se3, read_extensions
from pincal.model.urdf_writer import FixedLink, calibrated_urdf_text

Array = npt.NDArray[np.float64]



#: Default name of the measurement frame's link, the root of a calibrated URDF that estimates ``base.*``.
MEASUREMENT_FRAME = "measurement_frame"


def marker_link(target: str) -> str:
    """Name of the link a calibrated marker becomes in the calibrated URDF: ``<frame>_marker`` for the marker of
    ``<frame>``, ``<frame>_marker_<marker>`` for declared marker ``<frame>@<marker>``."""
    frame, marker = split_target(target)
    return f"{frame}_marker_{marker}" if marker else f"{frame}_marker"


def written_frame(measurement: Measurement, frame: str, parameters: ParameterSet) -> str:
    """The frame of the calibrated URDF whose origin (and orientation, for poses) ``measurement`` reads on
    ``frame``: a declared marker's link for ``position:<frame>@<marker>``; the marker link when ``parameters``
    calibrate a marker on ``frame`` and the measurement reads points at its frames' markers
    (:attr:`~pincal.identification.measurements.Measurement.reads_markers`: positions and distances; a pose reads
    the frame itself); else ``frame``."""
    declared = [t for t in measurement.markers if split_target(t)[1]]
    if declared:
        return marker_link(declared[0])
    marked = any(p.is_a(MarkerOffset) and p.owner == frame for p in parameters)
    return marker_link(frame) if marked and measurement.reads_markers else frame


def joint_motion(model: pin.Model, jid: int, q: Array) -> pin.SE3:
    """The motion of joint ``jid`` at configuration ``q`` as a placement (``liMi = placement · motion``)."""
    data = model.createData()
    pin.forwardKinematics(model, data, q)
    return model.jointPlacements[jid].inverse() * data.liMi[jid]


def _joint_axis_motion(model: pin.Model, joint: str, value: float) -> pin.SE3:
    """A one-DOF joint's motion for ``value`` [rad or m], as a placement."""
    jid = model.getJointId(joint)
    q = pin.neutral(model)
    jm = model.joints[jid]
    if jm.nq == 1:
        q[jm.idx_q] = value
    else:
        q[jm.idx_q:jm.idx_q + 2] = [math.cos(value), math.sin(value)]
    return joint_motion(model, jid, q)


def _offset_motions(model: pin.Model, joint: str, value: float, rest: pin.Data,
                    data: pin.Data) -> dict[str, pin.SE3]:
    """The motion, as a placement, of every joint that ``joint`` at ``value`` [rad or m] moves: the joint
    itself and its ``<mimic>`` followers (Pinocchio moves them with it). ``rest`` holds the forward kinematics
    at the neutral configuration; ``data`` is overwritten (both made once: a long chain's take seconds)."""
    q = pin.neutral(model)
    jm = model.joints[model.getJointId(joint)]
    if jm.nq == 1:
        q[jm.idx_q] = value
    else:
        q[jm.idx_q:jm.idx_q + 2] = [math.cos(value), math.sin(value)]
    pin.forwardKinematics(model, data, q)
    return {str(model.names[j]): model.jointPlacements[j].inverse() * data.liMi[j] for j in range(1, model.njoints)
            if not np.array_equal(data.liMi[j].homogeneous, rest.liMi[j].homogeneous)}


def calibrated_robot_text(robot: Robot, source_text: str, parameters: ParameterSet, x: Array,
                          note: str = "", read_joints: Sequence[str] = (),
                          measurement_frame: str = MEASUREMENT_FRAME,
                          markers: Mapping[str, Sequence[float]] | None = None) -> tuple[str, dict[str, float]]:
    """URDF text of the calibrated robot: every estimate of ``x`` in the file, re-assembled at zero readings.

    What the file carries (docs/calibrated_urdf.md):

    - joint (movable and fixed) and loop-anchor placements: their origins, edited in place;
    - actuated-joint offsets (``q_true = q_read + δq``): folded into the joints' origins, so the file
      takes raw readings;
    - the re-assembly: the calibrated robot's closed configuration at zero actuated readings is the
      file's all-zero configuration (each passive joint's value folded into its origin);
    - the measurement frame (``base.*``, ``world = base · exp6(δ) · robot``): a new root link
      ``measurement_frame`` and a fixed joint ``measurement_frame_joint`` to the robot's old root,
      whose origin is ``exp6(δ)``. A file whose root already is that link gets the estimate composed
      into that joint (recalibrating a calibrated file);
    - markers (``marker.<frame>.*``, a measured point's offset in ``frame``): a link
      ``<frame>_marker`` on ``frame``'s link by a fixed joint ``<frame>_marker_joint`` (an existing
      one, from an earlier calibration, gets the new offset); each declared marker ``<frame>@<marker>`` (given
      in ``markers``, or with ``marker.<frame>@<marker>.*`` parameters) a link ``<frame>_marker_<marker>`` at its
      calibrated point ``exp6(δ_cluster) · (nominal + δ_marker)``, by a fixed joint ``<frame>_marker_<marker>_joint``;
    - cameras and targets (``camera.<frame>.*``, ``target.*``, ``target.<frame>@<target>.*``): a link
      ``<frame>_camera`` on ``frame``'s link, ``camera_target`` on the robot's root link (the target an eye-in-hand
      camera sees, in the robot's world frame) and ``<frame>_target_<target>`` on ``frame``'s link, each by a fixed
      joint named ``<link>_joint`` at the calibrated placement;
    - instrumented passive joints (``<joint>.offset`` of a non-actuated joint, and ``read_joints``):
      ``<joint_sensor joint="..." zero="z"/>``: the sensor reads ``q + z``, q the joint's value in the
      file, ``z = shift − δq`` [m or rad];
    - mesh files: named as in the source; where the file is written decides their names there
      (:mod:`pincal.io.mesh_files`).

    Loading the file and running forward kinematics at the raw actuated readings then reproduces the
    calibrated model's prediction of every measured quantity, in the measurement frame.

    Args:
        robot: The nominal robot (loaded from ``source_text``).
        source_text: The URDF text ``robot`` was loaded from.
        parameters: The parameter set ``x`` refers to.
        x: Deviations from the nominal robot [m, rad], one per parameter.
        note: Text of a comment at the top of the file (nothing when empty).
        read_joints: Passive joints whose sensors are read (``joint:<name>`` measurements) besides those
            with an offset parameter; each gets a ``<joint_sensor>``.
        measurement_frame: Name of the measurement frame's link.
        markers: Declared marker key (``<frame>@<marker>``) -> its nominal offset [m] in the frame: each
            becomes a link, with or without parameters of its own.

    Returns:
        The text, and the reference shift of each passive joint [rad or m]: the new zero is the old
        value plus this shift. A reading of an instrumented passive joint in the new file's terms is
        ``reading + δ − shift``, with δ its estimated reading offset (``<joint>.offset``) if any.

    Raises:
        ConvergenceError: the calibrated loops cannot be closed at zero actuated readings.
        RobotFileError: a parameter of a kind a URDF cannot hold, or a name the new elements need is taken.
        DataError: ``x`` does not match ``parameters``.
        NotFoundError: a marker's frame is neither a link nor a joint of the file.
    """
    x = np.asarray(x, dtype=float)
    if x.shape != (len(parameters),):
        raise DataError(f"parameter vector has shape {x.shape}, expected ({len(parameters)},) for the parameter set")
    foreign = [p.name for p in parameters
               if not (p.kind_class.urdf or p.kind_class.in_corrections or p.kind_class.in_report)]
    if foreign:  # a correction goes to the corrections file beside it (io.corrections_file): left out, not refused
        raise RobotFileError(f"parameters {listing(foreign)} are of a kind a calibrated URDF cannot hold; kinds it "
                             f"holds: {listing(kinds_where(in_urdf=True))}")
    ext = read_extensions(source_text)
    tree = ET.fromstring(source_text)  # read, never changed: the source is parsed once here
    root = _xml_joint_origins(tree)
    joint_origins: dict[str, pin.SE3] = {}
    loop_origins: dict[tuple[str, str], pin.SE3] = {}
    loops = {lp.name: lp for lp in ext.loops}
    for (kind, owner, side), idx in parameters.groups(*kinds_where(kinematic=True)).items():
        exp = pin.exp6(parameters.placement_delta(x, idx))
        if kind == JointPlacement.name:
            joint_origins[owner] = joint_origins.get(owner, root[owner]) * exp
        else:
            loop = loops[owner]
            base = loop.predecessor_origin if side == "predecessor" else loop.successor_origin
            loop_origins[(owner, side)] = base * exp
    rest, moved = robot.model.createData(), robot.model.createData()
    pin.forwardKinematics(robot.model, rest, pin.neutral(robot.model))
    for k, p in enumerate(parameters):
        if p.is_a(ReadingOffset) and p.owner in robot.actuated_joints and x[k] != 0.0:
            for name, motion in _offset_motions(robot.model, p.owner, x[k], rest, moved).items():
                joint_origins[name] = joint_origins.get(name, root[name]) * motion
    shifts = _reassemble(robot, source_text, joint_origins, loop_origins, root) if ext.loops else {}
    fixed_links = _measurement_frame_link(tree, parameters, x, joint_origins, root, measurement_frame)
    fixed_links += _marker_links(tree, parameters, x, joint_origins, root, markers or {})
    fixed_links += _attached_links(tree, parameters, x, joint_origins, root, measurement_frame)
    offsets = {p.owner: float(x[k]) for k, p in enumerate(parameters) if p.is_a(ReadingOffset)}
    read = [j for j in dict.fromkeys([*read_joints, *offsets]) if j not in robot.actuated_joints]
    sensor_zeros = {j: shifts.get(j, 0.0) - offsets.get(j, 0.0) for j in read}
    text = calibrated_urdf_text(source_text, joint_origins, loop_origins, header_note=note, fixed_links=fixed_links,
                                sensor_zeros=sensor_zeros)
    if ext.loops:
        check_reference_assembly(Robot(_build_model(text, "calibrated URDF"), read_extensions(text).loops,
                                       robot.actuated_joints, robot.name), "calibrated URDF")
    return text, shifts


def _reassemble(robot: Robot, source_text: str, joint_origins: dict[str, pin.SE3],
                loop_origins: dict[tuple[str, str], pin.SE3], root: dict[str, pin.SE3]) -> dict[str, float]:
    """Fold the calibrated robot's closed configuration at zero actuated readings into the passive joints'
    origins (``joint_origins`` is updated); returns each one-DOF passive joint's shift [rad or m]."""
    text = calibrated_urdf_text(source_text, joint_origins, loop_origins)
    model = _build_model(text, "calibrated URDF")
    loose = Robot(model, read_extensions(text).loops, robot.actuated_joints, robot.name)
    report = loose.solve_fk_report(np.zeros(loose.n_actuated))
    if not report.converged:
        raise ConvergenceError(f"the calibrated loops do not close at zero actuated readings (residual "
                               f"{report.residual:.3g}): the estimate is far from the nominal robot")
    q = report.q
    shifts: dict[str, float] = {}
    for jid in range(1, model.njoints):
        name = str(model.names[jid])
        jm = model.joints[jid]
        if name in robot.actuated_joints:
            continue
        if jm.nv > 1:  # floating, planar, ...: fold the joint's whole motion into its origin
            joint_origins[name] = joint_origins.get(name, root[name]) * joint_motion(loose.model, jid, q)
            continue
        value = q[jm.idx_q] if jm.nq == 1 else math.atan2(q[jm.idx_q + 1], q[jm.idx_q])
        if value != 0.0:
            shifts[name] = float(value)
            joint_origins[name] = joint_origins.get(name, root[name]) * _joint_axis_motion(loose.model, name, value)
    return shifts


def _root_link(tree: ET.Element) -> str:
    children = {c.get("link") for c in tree.findall("joint/child")}
    roots = [name for name in (link.get("name", "") for link in tree.findall("link")) if name not in children]
    if len(roots) != 1:
        raise RobotFileError(f"the URDF has {len(roots)} root links ({listing(roots) or 'none'}); a robot has one")
    return roots[0]


def _fixed_joint(tree: ET.Element, joint: str, parent: str, child: str) -> bool:
    """True if ``joint`` is a fixed joint from ``parent`` to ``child``; RobotFileError if it exists otherwise."""
    for node in tree.findall("joint"):
        if node.get("name") == joint:
            ends = [e.get("link") if e is not None else None for e in (node.find("parent"), node.find("child"))]
            if node.get("type") != "fixed" or ends != [parent, child]:
                raise RobotFileError(f"joint '{joint}' exists but is not a fixed joint from '{parent}' to '{child}': "
                                     "rename it, or pass another frame name")
            return True
    return False


def _measurement_frame_link(tree: ET.Element, parameters: ParameterSet, x: Array, joint_origins: dict[str, pin.SE3],
                            root: dict[str, pin.SE3], name: str) -> list[FixedLink]:
    """The measurement frame as a new root (or composed into the file's own measurement frame joint)."""
    idx = parameters.groups("base").get(("base", "base", ""), [])
    if not idx:
        return []
    base = pin.exp6(parameters.placement_delta(x, idx))  # world = base · robot (problem._predict)
    old_root = _root_link(tree)
    joint = f"{name}_joint"
    if old_root == name:  # recalibrating a calibrated file: its measurement frame is the robot's parent
        child = next((j.find("child") for j in tree.findall("joint")
                      if j.get("name") == joint), None)
        if child is None or not _fixed_joint(tree, joint, name, child.get("link", "")):
            raise RobotFileError(f"the root link is '{name}' but it has no fixed joint '{joint}' to the robot; pass "
                                 "another measurement frame name")
        joint_origins[joint] = base * joint_origins.get(joint, root[joint])
        return []
    links = {link.get("name") for link in tree.findall("link")}
    if name in links or joint in root:
        raise RobotFileError(f"the URDF already has a link '{name}' or a joint '{joint}' that is not its root; pass "
                             "another measurement frame name")
    comment = (f"pincal: the measurement frame (e.g. the tracker's), the root. The fixed joint {joint} places the "
               f"robot's base '{old_root}' in it: the calibrated registration. With the robot's base as the "
               f"reference, take '{old_root}' as the root (docs/calibrated_urdf.md)")
    return [FixedLink(joint, name, old_root, base, comment)]


def _frame_link(tree: ET.Element, frame: str) -> str:
    """The link whose frame is ``frame`` (a link, or a joint: its child link's frame is the joint's)."""
    links = [link.get("name", "") for link in tree.findall("link")]
    if frame in links:
        return frame
    for node in tree.findall("joint"):
        child = node.find("child")
        if node.get("name") == frame and child is not None:
            return child.get("link", "")
    raise not_found("frame", frame, links, " in the URDF as a link or a joint")


def _marker_links(tree: ET.Element, parameters: ParameterSet, x: Array, joint_origins: dict[str, pin.SE3],
                  root: dict[str, pin.SE3], declared: Mapping[str, Sequence[float]]) -> list[FixedLink]:
    """Each calibrated marker as a link on its frame's link (or composed into an existing marker joint)."""
    out = []
    points = marker_points(parameters, x, {t: np.asarray(v, dtype=float) for t, v in declared.items()})
    for target, point in points.items():
        frame, marker = split_target(target)
        link, joint = marker_link(target), f"{marker_link(target)}_joint"
        parent = _frame_link(tree, frame)
        placement = pin.SE3(np.eye(3), point.point)
        if _fixed_joint(tree, joint, parent, link):  # the marker of an earlier calibration: re-estimated
            if joint in joint_origins:
                raise RobotFileError(f"link '{link}' cannot be both the marker on '{frame}' (marker.{target}.*) and a "
                                     f"calibrated frame of its own ({joint}.*): choose one")
            joint_origins[joint] = placement
            continue
        what = f"marker '{marker}' on '{frame}'" if marker else f"marker on '{frame}'"
        out.append(FixedLink(joint, parent, link, placement,
                             f"pincal: the calibrated {what}, the point measured there"))
    return out


def attached_link(kind: str, owner: str) -> str:
    """Name of the link a calibrated camera, target or plane becomes: ``<frame>_camera``, ``camera_target`` (the world
    target, ``owner`` empty), ``<frame>_target_<target>``, ``contact_plane`` (a plane in the world) or
    ``<support>_plane``: the kind says (:meth:`~pincal.identification.parameters.ParameterKind.urdf_link`)."""
    return parameter_kind(kind).urdf_link(owner)


def _attached_links(tree: ET.Element, parameters: ParameterSet, x: Array, joint_origins: dict[str, pin.SE3],
                    root: dict[str, pin.SE3], measurement_frame: str) -> list[FixedLink]:
    """Each calibrated camera, target and plane (its z axis the normal) as a link: on its frame's link, or the world
    target and plane on the robot's root link; such a link of an earlier calibration gets the new placement as its
    joint's origin."""
    out = []
    links = {link.get("name") for link in tree.findall("link")}
    robot_root, robot_root_placement = _root_link(tree), pin.SE3.Identity()
    frame_joint = f"{measurement_frame}_joint"
    if robot_root == measurement_frame and frame_joint in root:  # a calibrated file: the robot hangs below its
        child = next(j.find("child") for j in tree.findall("joint") if j.get("name") == frame_joint)  # tracker frame
        if child is not None and child.get("link"):
            robot_root, robot_root_placement = child.get("link", ""), root[frame_joint]
    for (kind, owner, _), idx in parameters.groups(*kinds_where(attached=True)).items():
        link = attached_link(kind, owner)
        joint = f"{link}_joint"
        world_target = not owner  # the world target and a plane in the world; a camera is always on a frame
        parent = robot_root if world_target else _frame_link(tree, split_target(owner)[0])
        placement = pin.exp6(parameters.placement_delta(x, idx))  # the world target: in the model's world frame,
        if world_target:  # the file's root link, which a calibrated file's robot root hangs below
            placement = robot_root_placement.inverse() * placement
        if link in links:
            if not _fixed_joint(tree, joint, parent, link):
                raise RobotFileError(f"the URDF already has a link '{link}', the name of the calibrated "
                                     f"{attached_name(kind, owner)}: rename it")
            joint_origins[joint] = placement  # the camera or target of an earlier calibration: re-estimated
            continue
        what = kind + (f" on '{split_target(owner)[0]}'" if owner else " fixed in the robot's world frame")
        out.append(FixedLink(joint, parent, link, placement, f"pincal: the calibrated {what}"))
    return out


def declared_markers(models: Sequence[Measurement]) -> dict[str, tuple[float, float, float]]:
    """The declared markers the measurements read (``position:<frame>@<marker>``) -> their nominal offsets [m] in
    their frames (zero when the data declare none): what :func:`calibrated_robot_text` takes as ``markers``."""
    return {target: nominal if nominal is not None else (0.0, 0.0, 0.0)
            for m in models for target, nominal in m.markers.items() if split_target(target)[1]}


def joint_sensor_zeros(text: str) -> dict[str, float]:
    """The ``<joint_sensor joint zero>`` elements of a calibrated URDF: joint -> z [m or rad], the sensor
    reading when the joint is at zero in that file (``reading = q + z``)."""
    out = {}
    for node in ET.fromstring(text).findall("joint_sensor"):
        try:
            out[node.get("joint", "")] = float(node.get("zero", ""))
        except ValueError:
            raise RobotFileError(f"<joint_sensor joint='{node.get('joint')}'> has zero '{node.get('zero')}', not a "
                                 "number") from None
    return out


def _xml_joint_origins(tree: ET.Element) -> dict[str, pin.SE3]:
    """Each joint's ``<origin>`` in the URDF ``tree`` (its root element), by joint name."""
    return {j.get("name", ""): origin_to_se3(j.find("origin"), f"joint '{j.get('name')}'")
            for j in tree.findall("joint")}


def source_text(robot: Robot) -> str:
    """The text of the URDF file the robot was loaded from; RobotFileError if it has none."""
    if robot.source is None:
        raise RobotFileError(f"robot '{robot.name}' has no source file to write a calibrated URDF from")
    return Path(robot.source).read_text(encoding="utf-8")
