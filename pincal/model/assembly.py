"""Assembling a closed-loop URDF: the passive joints re-zeroed so that every ``<loop>`` closes at the zero
configuration.

pincal reads a closed-loop robot at its reference configuration, every joint at zero, where each loop must close to
1e-9 (:func:`~pincal.model.robot.check_reference_assembly`). Written by hand, a file's passive joints rarely meet:
their zero was drawn approximately. :func:`assemble_urdf` closes the loops with the smallest change that keeps every
length the file gives: the actuated joints stay at zero, the passive joints take the values that close the loops
(Gauss–Newton from zero, each step the least-norm one, so the assembly mode nearest the drawing is found), and each
passive joint's ``<origin>`` absorbs its value: ``origin ← origin · M_j(q_j)``, a rotation about a revolute joint's
axis, a translation along a prismatic one's. Link lengths, loop anchors, axes and the actuated joints' origins are
kept; only the moved origins' ``xyz``/``rpy`` are rewritten (:mod:`pincal.model.urdf_writer`). A loop that no value of
the passive joints closes (lengths that do not fit) is refused with its residual. Units: m, rad.
"""

from __future__ import annotations

import xml.etree.ElementTree as ET

import numpy as np
import numpy.typing as npt
import pinocchio as pin

from pincal.errors import LoopError, RobotFileError, listing
from pincal.model.closure import LoopClosure
from pincal.model.parts import (
    ReducedModel,
    frames_by_joint,
    has_mimic_joints,
    independent_blocks,
    loop_support,
    reduced_model,
)
from pincal.model.robot import MAX_JOINTS, robot_from_urdf_text
from pincal.model.urdf import LoopSpec, check_finite_origins, origin_to_se3, parse_urdf, read_extensions
from pincal.model.urdf_writer import calibrated_urdf_text
from pincal.records import record

Array = npt.NDArray[np.float64]

#: The loops count as closed when no residual row exceeds this [m, rad] (the file must close to 1e-9).
CLOSED = 1e-13
#: Most Gauss–Newton steps.
MAX_STEPS = 100


@record(frozen=True)
class JointShift:
    """How assembling moved one passive joint's origin.

    Attributes:
        joint: The joint's name.
        value: Its value that closes the loops [rad, or m for a prismatic joint], now its zero (one-DOF joints,
            continuous ones included; NaN for a multi-DOF one).
        translation: How far its origin moved [m].
        rotation: How far its origin turned [rad].
        unit: The unit of ``value``: ``rad`` or ``m``.
    """

    joint: str
    value: float
    translation: float
    rotation: float
    unit: str = "rad"


@record(frozen=True)
class Assembly:
    """A URDF assembled by :func:`assemble_urdf`.

    Attributes:
        text: The assembled URDF, the source with the moved origins rewritten.
        shifts: Each passive joint whose origin moved, in the model's order.
        residual_before: The largest closure residual row of the source at zero [m or rad].
        residual_after: The same, of the assembled file [m or rad].
        steps: Gauss–Newton steps taken.
    """

    text: str
    shifts: list[JointShift]
    residual_before: float
    residual_after: float
    steps: int


def assemble_urdf(text: str, source: str = "URDF") -> Assembly:
    """``text`` (a URDF with ``<loop>`` and ``<transmission>`` elements, the passive joints' origins approximate)
    with each passive joint re-zeroed where the loops close, the actuated joints at zero (module docstring).

    Raises:
        RobotFileError: not a URDF Pinocchio can build; too many joints; larger than
            :data:`~pincal.model.urdf.MAX_URDF_BYTES`.
        LoopError: no ``<loop>``; loops that no value of the passive joints closes (the loop and its residual); an
            assembled file that pincal still refuses (its mobility, its actuation).
    """
    root = parse_urdf(text, source)  # once, for the checks and the origins below
    extensions = read_extensions(text, source, root)
    check_finite_origins(text, source, root)
    if not extensions.loops:
        raise LoopError(f"{source} declares no <loop>: a serial robot has nothing to assemble")
    model = _model(text, source)
    closure = LoopClosure(model, extensions.loops)  # every loop's anchors checked, in the file's order
    worst: dict[int, float] = {}  # each loop's largest residual row, closed [m, rad]
    moved: dict[str, pin.SE3] = {}
    shifts: dict[int, JointShift] = {}
    origins = _urdf_origins(root)
    steps = 0
    before = 0.0
    for loops, part in _blocks(model, extensions.loops):  # independent loops closed block by block
        block = LoopClosure(part.model, [extensions.loops[k] for k in loops])
        passive = _passive_joints(part.model, extensions.transmitted_joints)
        q, block_steps, block_before = _close(part.model, block, passive)
        steps, before = max(steps, block_steps), max(before, block_before)
        data = pin.Data(part.model)
        pin.forwardKinematics(part.model, data, q)
        residual = block.residual(data)
        worst |= {k: float(np.max(np.abs(residual[rows])))
                  for k, rows in zip(loops, block.loop_slices().values(), strict=True)}
        values = pin.difference(part.model, pin.neutral(part.model), q)
        for j in passive:
            name = str(part.model.names[j])
            motion = part.model.jointPlacements[j].inverse() * data.liMi[j]  # M_j(q_j)
            if np.allclose(motion.homogeneous, np.eye(4), rtol=0.0, atol=1e-15):
                continue
            moved[name] = origins[name] * motion
            joint = part.model.joints[j]
            value = float(values[joint.idx_v]) if joint.nv == 1 else float("nan")
            unit = "m" if joint.shortname().startswith("JointModelP") else "rad"
            shifts[int(model.getJointId(name))] = JointShift(
                name, value, float(np.linalg.norm(moved[name].translation - origins[name].translation)),
                float(np.linalg.norm(pin.log3(motion.rotation))), unit)
    if max(worst.values()) > CLOSED * 1e3:
        raise LoopError(_not_closing(closure, worst, source))
    assembled = calibrated_urdf_text(text, moved, {}) if moved else text
    robot = robot_from_urdf_text(assembled)  # the checks of every load: closure below 1e-9, mobility, actuation
    after = float(np.max(np.abs(robot.closure_residual(robot.q_reference))))
    return Assembly(assembled, [shifts[j] for j in sorted(shifts)], before, after, steps)


def _blocks(model: pin.Model, loops: list[LoopSpec]) -> list[tuple[tuple[int, ...], ReducedModel]]:
    """The loops (indices) in independent blocks, each with the model of the joints that move it
    (:mod:`pincal.model.parts`); all loops on the whole model when they are one block or a joint is a mimic."""
    groups = independent_blocks(model, loops)
    if len(groups) == 1 or has_mimic_joints(model):
        return [(tuple(range(len(loops))), reduced_model(model, frozenset(range(1, model.njoints))))]
    frames = frames_by_joint(model)
    return [(group, reduced_model(model, frozenset().union(*(loop_support(model, loops[k]) for k in group)),
                                  frames)) for group in groups]


def _model(text: str, source: str) -> pin.Model:
    """The cut tree, as :func:`~pincal.model.robot.load_robot` builds it (mimic joints following their leader)."""
    try:
        model = pin.buildModelFromXML(text, mimic=True)
    except (RuntimeError, ValueError, IndexError) as exc:
        raise RobotFileError(f"{source}: Pinocchio cannot build the model: {exc}") from None
    if model.njoints - 1 > MAX_JOINTS:
        raise RobotFileError(f"{source} has {model.njoints - 1} joints; pincal takes at most {MAX_JOINTS}")
    return model


def _passive_joints(model: pin.Model, actuated: list[str]) -> list[int]:
    """The ids of the joints with a velocity that no ``<transmission>`` names."""
    return [j for j in range(1, model.njoints) if model.joints[j].nv > 0 and str(model.names[j]) not in actuated]


def _close(model: pin.Model, closure: LoopClosure, passive: list[int]) -> tuple[Array, int, float]:
    """The configuration (actuated joints at zero) where the loops close: Gauss–Newton on the passive joints from
    zero, least-norm steps halved until the residual decreases. Returns it, the steps taken and the largest residual
    row at zero [m, rad]."""
    columns = np.concatenate([np.arange(model.joints[j].idx_v, model.joints[j].idx_v + model.joints[j].nv)
                              for j in passive]).astype(int) if passive else np.zeros(0, dtype=int)
    data = pin.Data(model)
    q = pin.neutral(model)
    residual, jacobian = _evaluate(model, closure, data, q)
    before = float(np.max(np.abs(residual)))
    steps = 0
    while steps < MAX_STEPS and float(np.max(np.abs(residual))) > CLOSED and columns.size:
        v = np.zeros(model.nv)
        v[columns] = -np.linalg.lstsq(jacobian[:, columns], residual, rcond=None)[0]
        cost, length = float(residual @ residual), 1.0
        while length > 1e-6:
            trial = pin.integrate(model, q, length * v)
            r_trial, j_trial = _evaluate(model, closure, data, trial)
            if float(r_trial @ r_trial) < cost:
                q, residual, jacobian = trial, r_trial, j_trial
                break
            length /= 2.0
        else:
            break  # a least-squares minimum that does not close: refused by the caller
        steps += 1
    return q, steps, before


def _evaluate(model: pin.Model, closure: LoopClosure, data: pin.Data, q: Array) -> tuple[Array, Array]:
    """Closure residual [m, rad] and its Jacobian (rows × nv) at ``q``."""
    pin.computeJointJacobians(model, data, q)
    return closure.residual_and_jacobian(data)


def _not_closing(closure: LoopClosure, worst: dict[int, float], source: str) -> str:
    """Why the loops do not close: the loops left open (``worst``: each loop's largest residual row) and their
    largest residual row."""
    open_loops = {spec.name: worst[k] for k, spec in enumerate(closure.specs) if worst[k] > CLOSED * 1e3}
    shown = listing(f"'{name}' ({value * 1e3:.4g} mm or mrad)" for name, value in open_loops.items())
    return (f"{source}: no values of the passive joints close loop{'s' if len(open_loops) > 1 else ''} {shown} with "
            "the actuated joints at zero: the lengths do not fit (a link's origin or a loop anchor is off), or an "
            "actuated joint's zero puts the loop out of reach; assemble turns the passive joints only")


def _urdf_origins(root: ET.Element) -> dict[str, pin.SE3]:
    """Each joint's ``<origin>`` as the file (``root``: its ``<robot>`` element) writes it [m, rad] (Pinocchio's joint
    placement may include fixed joints above it)."""
    return {str(joint.get("name")): origin_to_se3(joint.find("origin"), f"joint '{joint.get('name')}'")
            for joint in root.findall("joint")}
