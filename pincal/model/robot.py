"""The :class:`Robot`: a Pinocchio model of the cut tree, its loop closures and its actuation.

Load one with :func:`load_robot` from a URDF path or a known robot name.
"""

from __future__ import annotations

import contextlib
import functools
import os
import shlex
import sys
import tempfile
import xml.etree.ElementTree as ET
from collections.abc import Iterator, Mapping, Sequence
from pathlib import Path
from typing import Literal

import numpy as np
import numpy.typing as npt
import pinocchio as pin

from pincal import errors, validation
from pincal.errors import ArgumentError, ConvergenceError, DataError, LoopError, RobotFileError, listing, not_found
from pincal.model.batch_kinematics import BatchKinematics
from pincal.model.catalog import known_robot_names, robot_path
from pincal.model.closure import LoopClosure
from pincal.model.kinematics import ActuatedJoint, ClosedLoopKinematics, SolveReport
from pincal.model.measured_frame import FrameChoice, default_measured_frame
from pincal.model.mimic import with_mimics
from pincal.model.parts import RobotParts
from pincal.model.urdf import LoopSpec, check_finite_origins, check_urdf_size, parse_urdf, read_extensions

Array = npt.NDArray[np.float64]

#: The unit of a joint value, and of a length or angle parameter.
Unit = Literal["m", "rad"]

#: Largest closure residual accepted at the reference configuration [m, rad].
REFERENCE_TOLERANCE = 1e-9
#: Default FK/IK tolerance on the largest residual component [m, rad].
SOLVE_TOLERANCE = 1e-11


class Robot:
    """A robot with optional closed kinematic loops.

    Attributes:
        name: Robot name from the URDF.
        model: Pinocchio model of the cut tree (the loops are not in it).
        loops: Loop declarations, anchors in link frames [m, rad].
        actuated_joints: Names of the actuated joints, the order of ``q_actuated`` vectors.
        source: Path of the URDF file this robot was loaded from, if any.
        notes: What the file says that pincal ignores, and why (a transmission on a fixed joint, ...).
        q_reference: The reference configuration (Pinocchio's neutral, where the file is assembled).

    One Robot may serve several threads at once: the scratch its methods write (Pinocchio's ``Data``, ...) is one per
    thread (:mod:`pincal.model.per_thread`; kept while the thread and the robot live), and its model, loops and
    actuated joints are only read, which no caller may change while another thread uses them (a new Robot instead).
    """

    def __init__(self, model: pin.Model, loops: list[LoopSpec], actuated_joints: list[str],
                 name: str = "robot", source: Path | None = None, notes: Sequence[str] = ()) -> None:
        self.name = name
        self.notes = list(notes)
        self.model = model
        self.loops = list(loops)
        self.actuated_joints = list(actuated_joints)
        self.source = source
        self.closure = LoopClosure(model, self.loops)
        actuated = []
        for joint in self.actuated_joints:
            jid = self.joint_id(joint, "actuated ")
            jm = model.joints[jid]
            if jm.nv != 1:
                raise LoopError(f"actuated joint '{joint}' has {jm.nv} degrees of freedom; actuated "
                                "joints must be revolute, continuous or prismatic")
            actuated.append(ActuatedJoint(joint, jid, jm.idx_q, jm.idx_v, jm.nq))
        self.q_reference = pin.neutral(model)
        self.kinematics = ClosedLoopKinematics(model, self.closure, actuated, self.q_reference)

    # --- structure ------------------------------------------------------------------------------
    @property
    def is_closed_loop(self) -> bool:
        """True when the robot has at least one loop closure."""
        return bool(self.loops)

    @property
    def n_actuated(self) -> int:
        """The number of actuated joints."""
        return len(self.actuated_joints)

    def frame_id(self, frame: str, context: str = "") -> int:
        """Pinocchio frame id of a frame or link name; NotFoundError lists the frames otherwise."""
        if not self.model.existFrame(frame):
            names = [f.name for f in self.model.frames if f.type in (pin.FrameType.BODY, pin.FrameType.OP_FRAME)]
            raise not_found("frame", frame, names, f" in robot '{self.name}'", context)
        return int(self.model.getFrameId(frame))

    def joint_id(self, joint: str, context: str = "") -> int:
        """Pinocchio joint id of a movable joint; NotFoundError lists the joints otherwise."""
        if not self.model.existJointName(joint):
            raise not_found("joint", joint, [str(n) for n in self.model.names[1:]], f" in robot '{self.name}'",
                            context)
        return int(self.model.getJointId(joint))

    @functools.cached_property
    def batch(self) -> BatchKinematics:
        """The batched twin of :attr:`kinematics` (every sample at once: :mod:`pincal.model.batch_kinematics`), built
        on first use."""
        return BatchKinematics(self.kinematics)

    @functools.cached_property
    def measured_frame_choice(self) -> FrameChoice:
        """The default measured frame and the rule that chose it, or why none is obvious
        (:func:`~pincal.model.measured_frame.default_measured_frame`)."""
        return default_measured_frame(self)

    @property
    def end_effector(self) -> str:
        """The default measured (end-effector) frame: ``end_effector`` in pincal's robot files, another name of
        :data:`~pincal.model.measured_frame.END_EFFECTOR_NAMES`, else the one link the actuated joints move with no
        moving link below it.

        Raises:
            NotFoundError: no such frame is obvious (several moving ends, listed as ``choices``, or none).
        """
        choice = self.measured_frame_choice
        if choice.frame is None:
            raise choice.error()
        return choice.frame

    @functools.cached_property
    def parts(self) -> RobotParts[Robot]:
        """Its independent loop blocks, and the part that moves given frames (:mod:`pincal.model.parts`)."""
        return RobotParts(self)

    def reduced(self, model: pin.Model, loops: list[LoopSpec], actuated_joints: list[str]) -> Robot:
        """A robot of this one's name, source and notes on ``model`` (a reduced model of its joints), with ``loops``
        and ``actuated_joints`` of its own (a part of it: :mod:`pincal.model.parts`)."""
        return Robot(model, loops, actuated_joints, name=self.name, source=self.source, notes=self.notes)

    def mobility(self, q: Array | None = None, tol: float = 1e-8) -> int:
        """Degrees of freedom ``nv - rank(dc/dv)`` at ``q`` (default: the reference configuration); the rank is the
        sum of the independent loop blocks' (:mod:`pincal.model.parts`)."""
        if not self.loops:
            return int(self.model.nv)
        q = self.q_reference if q is None else np.asarray(q, dtype=float)
        rank = sum(int(np.linalg.matrix_rank(part.robot.kinematics.closure_jacobian(q[part.q_index])[1], tol=tol))
                   for part in self.parts.blocks)
        return int(self.model.nv - rank)

    # --- configurations -------------------------------------------------------------------------
    def actuated_values(self, q: Array) -> Array:
        """Actuated joint values in ``q`` [rad or m], in ``actuated_joints`` order."""
        return self.kinematics.actuated_values(np.asarray(q, dtype=float))

    def closure_residual(self, q: Array) -> Array:
        """Stacked loop-closure residual at ``q`` [m for positions, rad for angles], each independent block of loops
        evaluated on its own joints (:mod:`pincal.model.parts`)."""
        q = self._q(q)
        blocks = self.parts.blocks
        if blocks[0].whole:
            return self.kinematics.closure_residual(q)
        out = np.empty(self.closure.rows)
        rows = list(self.closure.loop_slices().values())
        for part in blocks:
            residual = part.robot.kinematics.closure_residual(q[part.q_index])
            for k, block_rows in zip(part.loops, part.robot.closure.loop_slices().values(), strict=True):
                out[rows[k]] = residual[block_rows]
        return out

    def placement(self, q: Array, frame: str) -> pin.SE3:
        """Placement of ``frame`` in the world frame at configuration ``q`` [m, rad]."""
        fid = self.frame_id(frame)
        pin.forwardKinematics(self.model, self.kinematics.data, self._q(q))
        return pin.updateFramePlacement(self.model, self.kinematics.data, fid).copy()

    def _q(self, q: Array) -> Array:
        q = np.asarray(q, dtype=float)
        if q.shape != (self.model.nq,):
            raise DataError(f"configuration has shape {q.shape}, expected ({self.model.nq},)")
        return q

    def _qa(self, q_actuated: Array | float) -> Array:
        qa = np.atleast_1d(np.asarray(q_actuated, dtype=float))
        if qa.shape != (self.n_actuated,):
            raise DataError(f"actuated values have shape {qa.shape}, expected ({self.n_actuated},) for "
                             f"{listing(self.actuated_joints)}")
        if not np.all(np.isfinite(qa)):
            raise DataError(f"actuated values contain NaN or infinity: {qa}")
        return qa

    # --- kinematics -----------------------------------------------------------------------------
    def solve_fk_report(self, q_actuated: Array, q_guess: Array | None = None,
                        tol: float = SOLVE_TOLERANCE) -> SolveReport:
        """Like :meth:`solve_fk` but returns the solver report instead of raising."""
        qa = self._qa(q_actuated)
        return self.kinematics.solve_fk(qa, None if q_guess is None else self._q(q_guess), tol)

    def solve_fk(self, q_actuated: Array, q_guess: Array | None = None,
                 tol: float = SOLVE_TOLERANCE) -> Array:
        """Full configuration with every loop closed for the given actuated values.

        The answer is the reference assembly: the configuration that continuation from
        :attr:`q_reference` reaches (see :mod:`pincal.model.kinematics`). A guess only makes the solve
        cheaper: Newton from it is kept unless it jumps (moves a passive joint by more than
        ``CONTINUATION_STEP``), and a guess farther than that in actuated values is not used. Give a
        previous answer as the guess (a guess placed on another assembly by hand can stay there).

        Args:
            q_actuated: Actuated joint values [rad or m], in ``actuated_joints`` order.
            q_guess: A nearby closed configuration (warm start); None for a cold start.
            tol: Largest accepted closure residual component [m, rad].

        Returns:
            The configuration q (nq,).

        Raises:
            ConvergenceError: the loops could not be closed; says the residual and the input.
        """
        report = self.solve_fk_report(q_actuated, q_guess, tol)
        if not report.converged:
            raise ConvergenceError(
                f"forward kinematics of '{self.name}' did not converge for actuated values "
                f"{np.array2string(np.asarray(q_actuated, dtype=float), precision=6)} "
                f"({listing(self.actuated_joints)}): closure residual {report.residual:.3g} after "
                f"{report.iterations} iterations. The input may be outside the workspace or near a "
                "singularity; try a q_guess from a nearby solution.")
        return report.q

    def solve_fk_batch(self, q_actuated: Array, q_guess: Array | None = None,
                       tol: float = SOLVE_TOLERANCE) -> Array:
        """Forward kinematics of many samples, (N, na) -> (N, nq).

        A closed-loop robot whose joints :mod:`pincal.model.batch_kinematics` takes solves every sample at once
        (stacked Newton steps, the same warm starts and refusals as :meth:`solve_fk`); a sample that does not close
        there, or another robot, is solved by :meth:`solve_fk`.

        Args:
            q_actuated: Actuated values, one sample per row [rad or m].
            q_guess: One configuration used for every sample, or (N, nq) guesses, one per sample;
                None for cold starts from the reference configuration.
            tol: Largest accepted closure residual component [m, rad].

        Raises:
            ConvergenceError: naming the first sample (row index) that failed.
        """
        qa = np.atleast_2d(np.asarray(q_actuated, dtype=float))
        guesses = None if q_guess is None else np.asarray(q_guess, dtype=float)
        out = np.empty((qa.shape[0], self.model.nq))
        alone = np.ones(len(qa), dtype=bool)
        batch = self.batch if self.loops else None
        if batch is not None and batch.unsupported is None and qa.shape[1:] == (self.n_actuated,) \
                and np.all(np.isfinite(qa)) and (guesses is None or guesses.shape in ((self.model.nq,), out.shape)):
            # every sample at once (pincal.model.batch_kinematics); the samples it does not close, alone below
            tiled = None if guesses is None else np.broadcast_to(guesses, out.shape)
            out[:], solved = batch.solve(self.model, self.closure, qa, tiled, tol)
            alone = ~solved
        for k in np.flatnonzero(alone).tolist():
            guess = None if guesses is None else (guesses if guesses.ndim == 1 else guesses[k])
            try:
                out[k] = self.solve_fk(qa[k], guess, tol)
            except ConvergenceError as exc:
                raise ConvergenceError(f"sample {k}: {exc}") from None
        return out

    def solve_ik(self, target: pin.SE3 | Array, frame: str | None = None, q_guess: Array | None = None,
                 tol: float = SOLVE_TOLERANCE) -> Array:
        """Full configuration, actuated joints included, placing ``frame`` at ``target``.

        Args:
            target: A ``pinocchio.SE3`` in the world frame [m, rad], or a position (3,) [m] for
                translational robots (orientation left free).
            frame: End-effector frame; default :attr:`end_effector`.
            q_guess: Start configuration; the reference configuration otherwise.
            tol: Largest accepted residual component (closure and target) [m, rad].

        Raises:
            TypeError: a target that is neither an SE3 nor 3 numbers; a frame name that is not a string.
            ArgumentError: a position that is not 3 finite numbers, an SE3 with NaN or infinity, a tolerance that
                is not a positive number.
            ConvergenceError: the target was not reached (unreachable, or a bad guess).
        """
        if frame is not None:
            validation.instance("frame", frame, str, "a frame name (str)")
        tol = validation.real("tol", tol, "m, rad", strict=True)
        goal: pin.SE3 | Array
        if isinstance(target, pin.SE3):
            if not np.all(np.isfinite(target.homogeneous)):
                raise ArgumentError(f"target={validation.shown(target)}: the placement holds NaN or infinity")
            goal = target
        else:
            goal = validation.finite_vector("target", target, 3, "m")
        name = frame or self.end_effector
        fid = self.frame_id(name)
        start = self.q_reference if q_guess is None else self._q(q_guess)
        report = self.kinematics.solve_ik(goal, fid, start, tol)
        if not report.converged:
            raise ConvergenceError(
                f"inverse kinematics of '{self.name}' did not reach the target of frame '{name}': "
                f"largest residual {report.residual:.3g} after {report.iterations} iterations. The "
                "target may be unreachable (or, for a robot with fewer than 6 DOF, over-specified: "
                "give a position).")
        return report.q

    def configuration_jacobian(self, q: Array) -> Array:
        """``dv/dq_a`` (nv × na): joint velocities per unit actuated velocity, through the loops."""
        return self.kinematics.configuration_jacobian(self._q(q))

    def frame_jacobian_actuated(self, q: Array, frame: str | None = None,
                                reference: pin.ReferenceFrame = pin.LOCAL_WORLD_ALIGNED) -> Array:
        """Jacobian (6 × na) of a frame's twist (linear [m], angular [rad]) w.r.t. the actuated joints.

        Computed through the loops by the implicit-function theorem; ``q`` must be closed.
        """
        return self.kinematics.frame_jacobian_actuated(self._q(q), self.frame_id(frame or self.end_effector),
                                                       reference)

    def __repr__(self) -> str:
        return (f"Robot('{self.name}', nq={self.model.nq}, nv={self.model.nv}, loops={len(self.loops)}, "
                f"actuated={self.actuated_joints})")


@contextlib.contextmanager
def _captured_stderr() -> Iterator[list[str]]:
    """Capture what C++ code (urdfdom) writes to file descriptor 2, to put it in our error instead."""
    lines: list[str] = []
    try:
        saved = os.dup(2)
    except OSError:  # no usable stderr: nothing to capture
        yield lines
        return
    with tempfile.TemporaryFile(mode="w+b") as sink:
        sys.stderr.flush()
        os.dup2(sink.fileno(), 2)
        try:
            yield lines
        finally:
            sys.stderr.flush()
            os.dup2(saved, 2)
            os.close(saved)
            sink.seek(0)
            lines.extend(line.strip() for line in sink.read().decode(errors="replace").splitlines())


def _build_model(text: str, source: str, mimics: Mapping[str, tuple[str, float, float]] | None = None) -> pin.Model:
    """Pinocchio's model of the file's tree, each of ``mimics`` (follower -> leader, multiplier, offset) following
    its leader (:mod:`pincal.model.mimic`)."""
    with _captured_stderr() as messages:
        try:
            return with_mimics(pin.buildModelFromXML(text), mimics or {}, source)
        except (RuntimeError, ValueError, IndexError) as exc:
            error: Exception = exc
    detail = "; ".join(m for m in messages if m and not m.startswith("at line")) or str(error)
    raise RobotFileError(f"{source}: Pinocchio cannot build the model: {detail}")


#: Most non-fixed joints a robot may have: one Pinocchio data of 200 velocities holds 4 × 200³ numbers (0.26 GB).
MAX_JOINTS = 200
#: Most ``<joint>`` elements of any type a URDF may have: Pinocchio's parser recurses down a chain and overflows
#: the stack (SIGSEGV) past a few thousand.
MAX_URDF_JOINTS = 2000


def _check_joint_count(root: ET.Element, where: str) -> None:
    """Refuse a URDF (``root``: its ``<robot>`` element) with more joints than pincal takes, counted in the XML
    before Pinocchio builds the model."""
    joints = root.findall("joint")
    moving = sum(1 for joint in joints if joint.get("type") != "fixed")
    if moving > MAX_JOINTS:
        raise RobotFileError(f"{where} has {moving} joints; pincal takes at most {MAX_JOINTS} (Pinocchio's "
                             "working data grow with the cube of the joints: 0.9 GB each for 300)")
    if len(joints) > MAX_URDF_JOINTS:
        raise RobotFileError(f"{where} has {len(joints)} <joint> elements; pincal takes at most {MAX_URDF_JOINTS}, "
                             f"fixed ones included, and at most {MAX_JOINTS} that move")


def load_robot(path: str | Path) -> Robot:
    """Load a robot from a URDF file, or by name (``delta``, ``hexapod``, ``ur10``, ``panda``, ...). A known name
    that is also a directory here (``pincal simulate delta --out delta``) is the known robot: a directory is no robot
    file.

    Loops come from ``<loop>`` elements and actuated joints from ``<transmission>`` elements. A
    robot without loops is serial: all its one-DOF joints are actuated.

    The file must be assembled at the reference configuration (Pinocchio's neutral, every joint at
    zero): the closure residual there must be below 1e-9 and the mobility (nv minus the rank of the
    closure Jacobian) must equal the number of actuated joints.

    Raises:
        RobotFileError: unreadable or invalid file; LoopError for loop and actuation problems.
        NotFoundError: neither a file nor a known robot name.
    """
    p = Path(validation.path("path", path))
    try:
        is_file, is_dir, exists = p.is_file(), p.is_dir(), p.exists()
    except OSError:  # e.g. a name longer than the file system allows
        is_file = is_dir = exists = False
    bare = not (p.suffix or "/" in str(path))  # a name, not a path
    if not is_file:
        if is_dir and bare and str(path) in known_robot_names():
            return load_robot(robot_path(str(path)))  # a directory is no robot file: the known robot of that name
        if is_dir or exists or not bare:
            what = ("is a directory; give a URDF file or a known robot name" if is_dir else "is not a regular file "
                    "(a device, a pipe or a socket)" if exists else "does not exist")
            raise RobotFileError(f"robot file '{path}' {what}", file=str(path))
        p = robot_path(str(path))
    suffix = p.suffix.lower()
    if suffix in (".toml", ".csv"):  # the arguments swapped, or a job file where a robot is asked for
        what = ("a job file (TOML): only 'pincal calibrate JOB.toml' reads one (docs/job_file.md)" if suffix == ".toml"
                else "a data file (CSV): the robot comes first, then the data (pincal calibrate ROBOT DATA.csv)")
        raise RobotFileError(f"robot file '{path}' is {what}; give a URDF file or a known robot name", file=str(path))
    try:
        with errors.Culprit(file=str(p)):
            check_urdf_size(p.stat().st_size, f"robot file '{path}'")  # before it is read
        text = p.read_text(encoding="utf-8")
    except (OSError, UnicodeDecodeError) as exc:
        raise RobotFileError(f"cannot read '{p}': {exc}", file=str(p)) from None
    return robot_from_urdf_text(text, source=p)


def robot_from_urdf_text(text: str, source: Path | None = None) -> Robot:
    """Build and check a :class:`Robot` from URDF text (see :func:`load_robot`); its errors' ``file`` is ``source``."""
    where = str(source) if source else "URDF"
    with errors.Culprit(file=str(source) if source else None):
        root = parse_urdf(text, where)  # once, for the checks below
        ext = read_extensions(text, where, root)
        check_finite_origins(text, where, root)
        _check_joint_count(root, where)
        model = _build_model(text, where, ext.mimics)
        if ext.loops:
            actuated = ext.transmitted_joints
        else:
            multi = [model.names[j] for j in range(1, model.njoints) if model.joints[j].nv > 1]
            if multi:
                raise RobotFileError(f"{where}: serial robot with multi-DOF joints {listing(multi)}; a serial "
                                     "robot's joints must be revolute, continuous or prismatic")
            actuated = [model.names[j] for j in range(1, model.njoints) if model.joints[j].nv == 1]  # not mimics
        robot = Robot(model, ext.loops, actuated, name=ext.robot_name, source=source, notes=ext.notes)
        check_reference_assembly(robot, where)
        return robot


def check_reference_assembly(robot: Robot, where: str = "URDF") -> None:
    """Refuse a robot whose loops do not close at the reference configuration or whose mobility
    does not match its actuation. Each independent block of loops is checked on its own joints: the closure Jacobian
    is block diagonal, its rank the blocks' summed (:mod:`pincal.model.parts`)."""
    if not robot.loops:
        return
    blocks = [(part, *part.robot.kinematics.closure_jacobian(part.robot.q_reference)) for part in robot.parts.blocks]
    if not all(np.all(np.isfinite(r)) and np.all(np.isfinite(jac)) for _, r, jac in blocks):
        raise LoopError(f"{where}: the loop closures evaluate to non-finite numbers at the reference "
                        "configuration: an origin, axis or length is out of range")
    worst = {k: float(np.max(np.abs(r[rows]))) for part, r, _ in blocks
             for k, rows in zip(part.loops, part.robot.closure.loop_slices().values(), strict=True)}
    for k, loop in enumerate(robot.loops):
        if worst[k] > REFERENCE_TOLERANCE:
            draft = shlex.quote(str(robot.source)) if robot.source is not None else "DRAFT.urdf"
            raise LoopError(f"{where}: loop '{loop.name}' does not close at the reference configuration (all "
                            f"joints zero): residual {worst[k]:.3g} m/rad > {REFERENCE_TOLERANCE:g}; assemble it: "
                            f"pincal assemble {draft} --out ROBOT.urdf turns the passive joints until every loop "
                            "closes with every joint at zero")
    rank = rank_p = 0
    redundant: list[int] = []
    try:
        for part, _, jac in blocks:
            block_rank = int(np.linalg.matrix_rank(jac, tol=1e-8))
            rank += block_rank
            rank_p += int(np.linalg.matrix_rank(jac[:, part.robot.kinematics.passive_v], tol=1e-8))
            for k, rows in zip(part.loops, part.robot.closure.loop_slices().values(), strict=True):
                others = np.ones(jac.shape[0], dtype=bool)
                others[rows] = False
                if int(np.linalg.matrix_rank(jac[others], tol=1e-8)) == block_rank:
                    redundant.append(k)
    except np.linalg.LinAlgError:
        raise LoopError(f"{where}: the closure Jacobian at the reference configuration cannot be decomposed "
                        "(numbers out of range)") from None
    if redundant:
        several = len(redundant) > 1
        names = [robot.loops[k].name for k in sorted(redundant)]
        raise LoopError(f"{where}: loop{'s' if several else ''} {listing(names)} add{'' if several else 's'} no "
                        f"constraint that the other loops do not already impose (closure rank {rank} with or without "
                        f"{'each' if several else 'it'}): a duplicated or redundant loop; remove it")
    mobility = robot.model.nv - rank
    if mobility != robot.n_actuated:
        raise LoopError(f"{where}: mobility is {mobility} (nv {robot.model.nv} minus closure rank {rank}) but "
                        f"{robot.n_actuated} joints are actuated ({listing(robot.actuated_joints) or 'none'}); "
                        "declare one <transmission> per actuated joint")
    if rank_p < robot.kinematics.passive_v.size:
        raise LoopError(f"{where}: the actuated joints ({listing(robot.actuated_joints)}) do not determine the "
                        f"passive joints at the reference configuration (passive closure rank {rank_p} < "
                        f"{robot.kinematics.passive_v.size}): a singular reference or a wrong choice of "
                        "actuated joints")


def joint_unit(robot: Robot, joint: str) -> Unit:
    """``m`` for a prismatic joint (its value is a length), ``rad`` for any other joint."""
    shortname = robot.model.joints[robot.model.getJointId(joint)].shortname()
    return "m" if shortname.startswith("JointModelP") and "Planar" not in shortname else "rad"
