"""Program filtering: a robot program's Cartesian targets rewritten so that the robot's own controller, which keeps
the nominal model, puts the calibrated robot on the pose each target intends (``pincal filter``, docs/filter.md).
SI units: m, rad.

Each Cartesian target (a tool centre point's pose in its frame, :class:`~pincal.io.programs.Target`) asks the flange
frame for ``F = B · W · T · tool⁻¹`` in a model's world, ``B`` the model's base frame, ``W`` the target's frame in it.
Taken in program order, as the controller runs it:

1. the controller's answer: the nominal robot's inverse kinematics from the joints of the move before (a joint target's
   values, or the previous Cartesian target's commands), else by :mod:`pincal.calibration.joint_commands`' rule (the
   reference configuration, then seeded random postures);
2. the calibrated model's commands from that answer
   (:meth:`~pincal.calibration.joint_commands.CommandSolver.solve_from`: the corrections file inverted, within the
   limits, checked by forward kinematics to the tolerance), on the same branch (every actuated joint within
   :data:`BRANCH` of the controller's answer);
3. the target rewritten as the nominal model's pose of the tool at those commands, in the target's frame: the
   controller's inverse kinematics of it gives back the commands, and the calibrated robot lands on the intended pose.

Joint targets are kept (they are the commands themselves). A target not reached, on another branch, or of an unknown
tool or frame is left as written, with its reason.
"""

from __future__ import annotations

import math
from dataclasses import field
from pathlib import Path

import numpy as np
import numpy.typing as npt
import pinocchio as pin

from pincal.calibration.arm_posture import arm_signs, mismatch, posture_edits
from pincal.calibration.joint_commands import CommandSolver, Model
from pincal.errors import Culprit, DataError, NotFoundError, listing
from pincal.io.programs import Edit, Program, Target, rewritten
from pincal.io.targets import OK
from pincal.model.batch_ik import Goals
from pincal.model.robot import Robot
from pincal.records import record

Array = npt.NDArray[np.float64]

#: Largest residual [m, rad] of the calibrated model at the commands for a target to be rewritten.
TOLERANCE = 1e-9
#: Largest change [rad or m] of an actuated joint between the controller's answer for the target as written and the
#: calibrated commands: beyond it, the calibrated solution is on another branch (another posture).
BRANCH = 0.2
#: The flange frames looked for, by language, the first the robot has taken (ROS-Industrial: KUKA's ``flange`` has
#: x out of the flange, as KRL's; ``tool0`` z out, as URScript's and RAPID's).
FLANGES = {"urscript": ("tool0",), "krl": ("flange", "tool0"), "rapid": ("tool0",)}
#: The base frames looked for, the first the robot has taken, else its root link (below a measurement frame).
BASES = ("base",)

__all__ = ["BRANCH", "TOLERANCE", "Filtered", "ProgramFilter", "default_frames", "filter_program"]


@record(frozen=True)
class Filtered:
    """One Cartesian target's outcome.

    Attributes:
        target: The target as read.
        status: ``ok``, or why it is left as written.
        pose: The pose written [m, rad] (in the target's frame), None when left as written.
        commands: The raw actuated commands [rad or m] the controller will reach, NaN when left as written.
        move: (distance [m], angle [rad]) between the pose as written and as rewritten, NaN when left as written.
        residual: (m, rad) of the calibrated model at the commands, NaN when left as written.
        bound: The calibration's predicted 95 % bound [m] at the commands (NaN: not known).
        posture: The edits writing the posture of the commands where it differs from the one the target names
            (KRL's status and turn, RAPID's configuration), and what changed in words (None: nothing).
    """

    target: Target
    status: str
    pose: pin.SE3 | None
    commands: Array
    move: tuple[float, float]
    residual: tuple[float, float]
    bound: float = math.nan
    posture: tuple[list[Edit], str | None] = ([], None)


@record
class ProgramFilter:
    """A program filtered: its targets' outcomes in program order, the texts to write, the frames used."""

    program: Program
    results: list[Filtered]
    texts: dict[str, str]
    base_frame: str
    flange: str
    joint_targets: int
    notes: list[str] = field(default_factory=list)

    @property
    def rewritten(self) -> int:
        """How many targets were rewritten."""
        return sum(r.status == OK for r in self.results)


def _frame_choice(robot: Robot, wanted: str | None, candidates: tuple[str, ...], what: str) -> str:
    """``wanted`` (the keyword ``what``'s value) if ``robot`` has it, else the first of ``candidates`` it has."""
    if wanted:
        with Culprit(option=what):
            robot.frame_id(wanted, f"{what}={wanted}: ")
        return wanted
    for name in candidates:
        if robot.model.existFrame(name):
            return name
    error = NotFoundError(f"robot '{robot.name}' has none of the frames {listing(list(candidates))}; give "
                          f"{what}=NAME", "frame", candidates[0], [str(f.name) for f in robot.model.frames])
    error.option = what
    raise error


def default_frames(robot: Robot, language: str, base: str | None = None, flange: str | None = None) -> tuple[str, str]:
    """The base frame programs' coordinates are in, and the flange frame their tools hang on (``base``, ``flange``
    when given; else :data:`BASES` or the robot's own root link, and :data:`FLANGES`).

    Raises:
        NotFoundError: a frame the robot lacks.
    """
    from pincal.calibration.compensate import base_link

    base_frame = _frame_choice(robot, base, BASES, "base") if base or any(
        robot.model.existFrame(b) for b in BASES) else base_link(robot)
    return base_frame, _frame_choice(robot, flange, FLANGES[language] + (robot.end_effector,), "flange")


def _angle(rotation: Array) -> float:
    return float(np.linalg.norm(pin.log3(rotation)))


#: Largest distance [m] of the calibrated flange from the nominal one (in the base frame, at the reference posture)
#: of a model of the controller's robot: a calibration moves it by millimetres, another robot by decimetres.
ANOTHER_ROBOT = 0.1


def filter_program(program: Program, model: Model, nominal: Robot, base: str | None = None, flange: str | None = None,
                   tolerance: float = TOLERANCE, seed: int = 0, joint_targets: str = "keep") -> ProgramFilter:
    """``program``'s Cartesian targets rewritten for a controller that keeps ``nominal`` (module docstring).

    Args:
        program: The program read (:mod:`pincal.io.programs`).
        model: The calibrated model (:func:`~pincal.calibration.compensate.load_model`).
        nominal: The robot the controller keeps; the same actuated joints as the model's.
        base: The base frame of the program's coordinates (:func:`default_frames`).
        flange: The flange frame its tools hang on (:func:`default_frames`).
        tolerance: Largest residual [m, rad] of the calibrated model at a rewritten target's commands.
        seed: Seed of the random starts of a target with no move before it.
        joint_targets: ``keep`` (the commands themselves, as written); ``intended``: each is taken for the flange
            pose the nominal model gives it (joints computed offline on the nominal model) and rewritten as the
            calibrated commands for that pose, on the same branch.

    Raises:
        DataError: ``nominal`` is not the model's robot; a joint target of another count of joints.
        NotFoundError: a frame either robot lacks.
    """
    robot = model.robot
    if nominal.actuated_joints != robot.actuated_joints:
        raise DataError(f"the nominal robot '{nominal.name}' actuates {listing(nominal.actuated_joints)}, the model "
                        f"{listing(robot.actuated_joints)}: they are not the same robot")
    base_frame, flange_frame = default_frames(nominal, program.language, base, flange)
    for robot_, what in ((robot, "MODEL"), (nominal, "the nominal robot")):
        with Culprit(option="base"):
            robot_.frame_id(base_frame, f"{what}, base={base_frame}: ")
        with Culprit(option="flange"):
            robot_.frame_id(flange_frame, f"{what}, flange={flange_frame}: ")
    nominal_solver = CommandSolver(Model(nominal), flange_frame, tolerance, seed)
    solver = CommandSolver(model, flange_frame, tolerance, seed)
    nominal_base = nominal.placement(nominal.q_reference, base_frame)
    model_base = robot.placement(robot.q_reference, base_frame)
    flanges = [b.inverse() * r.placement(r.q_reference, flange_frame)
               for r, b in ((nominal, nominal_base), (robot, model_base))]
    gap = float(np.linalg.norm(flanges[0].translation - flanges[1].translation))
    if gap > ANOTHER_ROBOT:
        raise DataError(f"MODEL ({robot.name}) puts the flange {gap:.3g} m from where the nominal robot "
                        f"'{nominal.name}' puts it at its reference posture (a calibration moves it by millimetres): "
                        "it is not a calibration of that robot; give nominal=ROBOT, the robot MODEL was calibrated "
                        "from",
                        option="nominal")
    previous: Array | None = None
    results: list[Filtered] = []
    joint_count = 0
    for target in program.targets:
        if target.joints is not None:
            joint_count += 1
            if len(target.joints) != robot.n_actuated:
                raise DataError(f"{target.file} line {target.line}: joint target '{target.name}' has "
                                f"{len(target.joints)} values; robot '{robot.name}' has {robot.n_actuated} actuated "
                                f"joints ({listing(robot.actuated_joints)})", file=target.file, line=target.line)
            previous = np.asarray(target.joints, dtype=float)
            if joint_targets == "intended":
                outcome = _joints(target, solver, nominal, model_base, nominal_base, flange_frame)
                results.append(outcome)
                previous = outcome.commands if outcome.status == OK else previous
            continue
        outcome = _one(target, solver, nominal_solver, nominal, (model_base, nominal_base, base_frame), flange_frame,
                       previous if target.near is None else target.near)
        if outcome.status == OK:
            previous = outcome.commands
        results.append(outcome)
    _bounds(results, model, nominal)
    edits: list[Edit] = []
    for outcome in results:
        if outcome.pose is not None and outcome.target.render is not None:
            edits += outcome.target.render(outcome.pose) + outcome.posture[0]
        elif outcome.status == OK and outcome.target.render_joints is not None:
            edits += outcome.target.render_joints(outcome.commands)
    return ProgramFilter(program, results, rewritten(program, edits), base_frame, flange_frame, joint_count)


def _goal(placement: pin.SE3) -> Goals:
    return Goals(placement.translation[None, :].copy(), placement.rotation[None, :, :].copy())


def _one(target: Target, solver: CommandSolver, nominal_solver: CommandSolver, nominal: Robot,
         bases: tuple[pin.SE3, pin.SE3, str], flange: str, previous: Array | None) -> Filtered:
    """One Cartesian target (module docstring); ``bases``: the base frame's placement in the model and in the nominal
    robot, and its name."""
    assert target.pose is not None
    model_base, nominal_base, base_frame = bases
    nan = np.full(solver.robot.n_actuated, np.nan)
    missed = (math.nan, math.nan)
    intended = target.frame * target.pose * target.tool.inverse()  # the flange in the base frame
    answer = None
    if previous is not None:
        start = nominal.solve_fk(previous)
        answer = nominal_solver.solve_from(_goal(nominal_base * intended), start[None, :])
    named = target.posture

    def check(raw: Array) -> str | None:
        return None if named is None else mismatch(named, arm_signs(nominal, nominal.solve_fk(raw), raw, base_frame))

    if answer is None or answer.statuses[0] != OK or check(answer.raw[0]) is not None:
        for start in nominal_solver.starts():  # the rule of compensate, each start's answer checked for the posture
            tried = nominal_solver.solve_from(_goal(nominal_base * intended), start[None, :])
            if tried.statuses[0] == OK and (answer is None or answer.statuses[0] != OK or check(tried.raw[0]) is None):
                answer = tried
                if check(tried.raw[0]) is None:
                    break
    if answer is None or answer.statuses[0] != OK:
        reason = answer.statuses[0].partition(": ")[2] if answer is not None else "no start reaches it"
        return Filtered(target, f"the nominal controller does not reach it: {reason}", None, nan, missed, missed)
    wrong = check(answer.raw[0])
    if wrong is not None:
        return Filtered(target, f"no posture found matches the one the target names: {wrong}", None, nan, missed,
                        missed)
    controller = answer.raw[0]
    start = solver.robot.solve_fk(solver.model.corrected(controller)) if solver.model.corrections is not None \
        else answer.configurations[0]
    status, raw, residual = _commands_near(solver, model_base * intended, start, controller,
                                           "the calibrated robot does not reach it from the controller's posture",
                                           "the controller's answer")
    if raw is None:
        return Filtered(target, status, None, nan, missed, missed)
    reached = nominal_base.inverse() * nominal.placement(nominal.solve_fk(raw), flange)
    pose = target.frame.inverse() * reached * target.tool
    gap = target.pose.inverse() * pose
    posture = ([], None) if named is None else posture_edits(named, arm_signs(nominal, nominal.solve_fk(raw), raw,
                                                                               base_frame))
    return Filtered(target, OK, pose, raw, (float(np.linalg.norm(gap.translation)), _angle(gap.rotation)), residual,
                    posture=posture)


def _commands_near(solver: CommandSolver, goal: pin.SE3, start: Array, near: Array, unreached: str,
                   near_what: str) -> tuple[str, Array | None, tuple[float, float]]:
    """The calibrated commands [rad or m] that put the flange on ``goal`` (in the model's base), solved from ``start``
    and kept only on the branch of ``near`` (``near_what`` in words): the status (``OK``, else why not, opening with
    ``unreached`` when the robot does not reach it), the commands or None, and the solve's residual [m, rad]."""
    missed = (math.nan, math.nan)
    commands = solver.solve_from(_goal(goal), start[None, :])
    if commands.statuses[0] != OK:
        return f"{unreached}: {commands.statuses[0].partition(': ')[2]}", None, missed
    raw = commands.raw[0]
    jump = float(np.max(np.abs(raw - near)))
    if jump > BRANCH:
        return f"the calibrated commands are on another branch ({jump:.3g} rad or m from {near_what})", None, missed
    return OK, raw, (float(commands.residuals[0, 0]), float(commands.residuals[0, 1]))


def _joints(target: Target, solver: CommandSolver, nominal: Robot, model_base: pin.SE3, nominal_base: pin.SE3,
            flange: str) -> Filtered:
    """A joint target taken for the flange pose the nominal model gives it: the calibrated commands for that pose from
    the written values, on their branch (``joint_targets="intended"``)."""
    written = np.asarray(target.joints, dtype=float)
    nan = np.full(len(written), np.nan)
    missed = (math.nan, math.nan)
    intended = nominal_base.inverse() * nominal.placement(nominal.solve_fk(written), flange)
    start = solver.robot.solve_fk(solver.model.corrected(written))
    status, raw, residual = _commands_near(solver, model_base * intended, start, written,
                                           "the calibrated robot does not reach its nominal pose from it",
                                           "the values written")
    if raw is None:
        return Filtered(target, status, None, nan, missed, missed)
    gap = intended.inverse() * (nominal_base.inverse() * nominal.placement(nominal.solve_fk(raw), flange))
    return Filtered(target, OK, None, raw, (float(np.linalg.norm(gap.translation)), _angle(gap.rotation)), residual)


def _bounds(results: list[Filtered], model: Model, nominal: Robot) -> None:
    """Each rewritten target's predicted 95 % bound [m] from the calibration the model's URDF carries, in place."""
    from pincal.calibration.carried import read_carried
    from pincal.calibration.predicted import bounds_at

    source = model.robot.source
    rows = [k for k, r in enumerate(results) if r.status == OK]
    if not rows or source is None or not Path(source).is_file():
        return
    calibration = read_carried(source)
    if calibration is None:
        return
    found = bounds_at(nominal, calibration, np.array([results[k].commands for k in rows]))
    if found is None:
        return
    for k, bound in zip(rows, found[0].tolist(), strict=True):
        old = results[k]
        results[k] = Filtered(old.target, old.status, old.pose, old.commands, old.move, old.residual, float(bound),
                              old.posture)
