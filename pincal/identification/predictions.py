"""The calibration problem's predictions of every sample and their parameter derivatives, along the three paths of
:meth:`CalibrationProblem.evaluate <pincal.identification.problem.CalibrationProblem.evaluate>`: a closed-loop robot's
samples all at once (:mod:`~pincal.identification.loop_batch`), a tree's all at once
(:mod:`~pincal.identification.tree_batch`), or each sample in turn (the reference path the batched ones are tested
against). Each model writes its own rows (:meth:`~pincal.identification.measurements.Measurement.predict_batch`, or
sample by sample :meth:`~pincal.identification.measurements.Measurement.predict`)."""

from __future__ import annotations

import numpy as np
import numpy.typing as npt
import pinocchio as pin

from pincal.errors import ConvergenceError, DataError
from pincal.identification.batch import BatchContext, SpatialJacobian
from pincal.identification.derivatives import KinematicSensitivity, Probe, frame_probe
from pincal.identification.evaluation import Evaluated
from pincal.identification.measurements import Measurement, SampleContext
from pincal.model.jacobians import frame_jacobian
from pincal.model.kinematics import damped_pseudo_inverse
from pincal.model.robot import SOLVE_TOLERANCE, Robot

Array = npt.NDArray[np.float64]
IntArray = npt.NDArray[np.int64]

#: Samples a tree's batched evaluation takes at once: its intermediates (about 6 × p numbers per sample and measured
#: frame) stay a few megabytes, whatever the number of samples.
BATCH_SAMPLES = 2048
#: Largest entry of the passive joints' response to the loops (C_p⁺) before a sample counts as singular
#: (an identification step that takes a sample there is rejected).
SINGULAR_GAIN = 1e8
#: Fewest samples a closed-loop robot's evaluation solves together (:func:`solve_all`); fewer are
#: solved one by one, which costs less than a stacked solve's fixed cost (about 30 array operations per iteration).
SMALL_BATCH = 16
#: Largest predicted change [rad or m] of a passive joint a warm start of the batched closed-loop solves takes from the
#: configuration's response to the parameters (a larger one is not first-order small: Newton starts from the
#: remembered configuration instead).
PREDICTED_MOVE = 0.05


def predict_loops(problem: Evaluated, robot: Robot, sens: KinematicSensitivity | None, ctx: SampleContext,
                  qa_all: Array, preds: dict[str, Array], dpreds: dict[str, Array]) -> None:
    """Every sample of a closed-loop robot at once (:mod:`pincal.identification.loop_batch`), by blocks of at
    most :data:`BATCH_SAMPLES`: configurations (:func:`solve_all`), the measured frames' placements and spatial
    twists through the loops, each model's :meth:`Measurement.predict_batch`; a model without one is predicted
    sample by sample from the same configurations and twists."""
    assert problem.loop_batch is not None
    loops, model, n = problem.loop_batch, robot.model, problem.observations.n_samples
    q_all = solve_all(problem, robot, qa_all, ctx.x)
    probes: dict[str, Probe] = {f: frame_probe(robot, fid) for f, fid in problem.frame_ids.items()}
    batched = [m for m in problem.measurements if m.batched]
    one_by_one = [m for m in problem.measurements if not m.batched]
    for start in range(0, n, BATCH_SAMPLES):
        rows = slice(start, min(n, start + BATCH_SAMPLES))
        q = q_all[rows]
        terms = [(joint, col, regressor[rows]) for joint, col, regressor in problem.actuated_terms]
        velocities = None
        if sens is None:
            joints = loops.kinematics.forward(loops.kinematics.geometry(model, robot.closure), q)
            placements = {f: loops.placement(joints, probe.joint, probe.placement) for f, probe in probes.items()}
            twists: dict[str, SpatialJacobian] = {}
        else:
            placements, twists, velocities = _loop_twists(problem, robot, sens, q, terms, probes, start)
            passive = loops.kinematics.passive_v
            shape = (n, passive.size, velocities.shape[2])
            if problem.solves.response is None or problem.solves.response.shape != shape:
                problem.solves.response = np.empty(shape)
            problem.solves.response[rows] = velocities[:, passive]
        joint_terms: dict[str, list[tuple[int, Array]]] = {}
        for joint, col, regressor in terms:
            joint_terms.setdefault(robot.actuated_joints[joint], []).append((col, regressor))
        batch = BatchContext(ctx, q, {f: rotation for f, (rotation, _) in placements.items()},
                             {f: origin for f, (_, origin) in placements.items()}, twists, joint_terms, rows,
                             velocities)
        for m in batched:
            m.predict_batch(batch, preds[m.key][rows], dpreds[m.key][rows] if sens is not None else None)
        if one_by_one:
            predict_one_by_one(problem, robot, one_by_one, ctx, batch, preds, dpreds)


def _loop_twists(problem: Evaluated, robot: Robot, sens: KinematicSensitivity, q: Array,
                 terms: list[tuple[int, int, Array]], probes: dict[str, Probe], start: int
                 ) -> tuple[dict[str, tuple[Array, Array]], dict[str, SpatialJacobian], Array]:
    """The measured frames' placements, spatial twists per unit parameter and every joint's velocity per unit
    parameter of the block of samples from ``start`` at configurations ``q`` (:meth:`LoopBatch.twists
    <pincal.identification.loop_batch.LoopBatch.twists>`), or the last evaluation's when they are the same: the robot
    built for the same kinematic deviations (:meth:`placed_robot <pincal.identification.problem.CalibrationProblem.
    placed_robot>`: the same object) and the same configurations, bit for bit. A fit of the measurement setup alone
    (the nominal robot's registration) moves only parameters these do not depend on; its arrays are kept read-only."""
    assert problem.loop_batch is not None
    key = (start, q.tobytes())
    kept = problem.solves.twists
    if kept is not None and kept[0] is robot and kept[1] == key:
        again: tuple[dict[str, tuple[Array, Array]], dict[str, SpatialJacobian], Array] = kept[2]
        return again
    system = problem.loop_batch.kinematics.linearised(robot.model, robot.closure, q)
    placements, twists, response = problem.loop_batch.twists(robot, sens, q, system, terms, probes, start,
                                                              SINGULAR_GAIN)
    made = (placements, twists, response.velocities)
    for array in (response.velocities, *(a for pair in placements.values() for a in pair),
                  *(t.left for t in twists.values())):
        array.flags.writeable = False
    problem.solves.twists = (robot, key, made)
    return made


def predict_samples(problem: Evaluated, robot: Robot, sens: KinematicSensitivity | None, ctx: SampleContext,
                    qa_all: Array, preds: dict[str, Array], dpreds: dict[str, Array]) -> None:
    """Each sample in turn: its configuration (the loops closed), its frames' local twists per parameter (through
    the loops by the implicit-function theorem), each model's :meth:`Measurement.predict`."""
    model, data, kin = robot.model, robot.kinematics.data, robot.kinematics
    n, p = problem.observations.n_samples, len(problem.all_parameters)
    jacobian = sens is not None
    probes = {f: frame_probe(robot, fid) for f, fid in problem.frame_ids.items()}
    passive, act_v = kin.passive_v, kin.actuated_v
    for k in range(n):
        q = problem.solves.solve(robot, k, qa_all[k])
        dv = None
        if jacobian:
            assert sens is not None
            pin.computeJointJacobians(model, data, q)
            pin.updateFramePlacements(model, data)
            dv = np.zeros((model.nv, p))
            for joint, col, regressor in problem.actuated_terms:
                dv[act_v[joint], col] = regressor[k]
            if robot.loops:
                _, cjac = robot.closure.residual_and_jacobian(data)
                gain = damped_pseudo_inverse(cjac[:, passive])
                if gain is None or float(np.abs(gain).max()) > SINGULAR_GAIN:
                    raise ConvergenceError(f"sample {k} is at a singular configuration: the passive joints are "
                                           "not determined by the actuated ones (with these parameters)")
                rhs = sens.closure_derivative(data)
                for joint, col, regressor in problem.actuated_terms:
                    rhs[:, col] += cjac[:, act_v[joint]] * regressor[k]
                dv[passive] = -gain @ rhs
        elif robot.loops:  # the loop solve ended with forward kinematics at q
            pin.updateFramePlacements(model, data)
        else:
            pin.framesForwardKinematics(model, data, q)
        twists = {}
        if jacobian:
            assert sens is not None and dv is not None
            for f, fid in problem.frame_ids.items():
                local = frame_jacobian(model, data, fid, pin.LOCAL)
                twists[f] = sens.probe_twist(data, probes[f]) + local @ dv
        ctx.sample, ctx.q, ctx.twists, ctx.dv = k, q, twists, dv
        for m in problem.measurements:
            m.predict(ctx, preds[m.key][k], dpreds[m.key][k] if jacobian else None)


def predict_tree(problem: Evaluated, robot: Robot, sens: KinematicSensitivity | None, ctx: SampleContext,
                 qa_all: Array, preds: dict[str, Array], dpreds: dict[str, Array]) -> None:
    """Every sample at once (a tree, :mod:`pincal.identification.tree_batch`), by blocks of at most
    :data:`BATCH_SAMPLES`: configurations, the measured frames' placements and spatial twists, each model's
    :meth:`Measurement.predict_batch`; a model without one is predicted sample by sample from the same
    configurations and twists."""
    assert problem.tree_batch is not None
    tree, model, n = problem.tree_batch, robot.model, problem.observations.n_samples
    probes = {f: frame_probe(robot, fid) for f, fid in problem.frame_ids.items()}
    batched = [m for m in problem.measurements if m.batched]
    one_by_one = [m for m in problem.measurements if not m.batched]
    for start in range(0, n, BATCH_SAMPLES):
        rows = slice(start, min(n, start + BATCH_SAMPLES))
        size = rows.stop - rows.start
        q = tree.configurations(qa_all[rows])
        placed, origins = tree.forward(model, q)
        placements = {f: tree.frame_placement(model, placed, f, size) for f in problem.frame_ids}
        terms = [(joint, col, regressor[rows]) for joint, col, regressor in problem.actuated_terms]
        twists = {} if sens is None else {f: tree.twist(f, probes[f], sens, placed, origins, placements[f], terms)
                                          for f in problem.frame_ids}
        joint_terms: dict[str, list[tuple[int, Array]]] = {}
        for joint, col, regressor in terms:
            joint_terms.setdefault(robot.actuated_joints[joint], []).append((col, regressor))
        batch = BatchContext(ctx, q, {f: placement.rotation for f, placement in placements.items()},
                             {f: placement.translation for f, placement in placements.items()}, twists,
                             joint_terms, rows)
        for m in batched:
            m.predict_batch(batch, preds[m.key][rows], dpreds[m.key][rows] if sens is not None else None)
        if one_by_one:
            predict_one_by_one(problem, robot, one_by_one, ctx, batch, preds, dpreds)


def predict_one_by_one(problem: Evaluated, robot: Robot, models: list[Measurement], ctx: SampleContext,
                       batch: BatchContext, preds: dict[str, Array], dpreds: dict[str, Array]) -> None:
    """The models without a batched prediction, sample by sample over the block of ``batch``: Pinocchio's frame
    placements at each configuration, the local twists from the batch's spatial ones."""
    model, data, act_v = robot.model, robot.kinematics.data, robot.kinematics.actuated_v
    spatial = {f: twist.full() for f, twist in batch.twists.items()}
    for row, k in enumerate(range(batch.samples.start, batch.samples.stop)):
        pin.framesForwardKinematics(model, data, batch.q[row])
        dv = None
        if spatial and batch.velocities is not None:  # closed loops: the passive joints move too
            dv = batch.velocities[row]
        elif spatial:
            dv = np.zeros((model.nv, len(problem.all_parameters)))
            for joint, col, regressor in problem.actuated_terms:
                dv[act_v[joint], col] = regressor[k]
        ctx.sample, ctx.q, ctx.dv = k, batch.q[row], dv
        ctx.twists = {f: _local_twist(batch.rotations[f][row], batch.translations[f][row], w[row])
                      for f, w in spatial.items()}
        for m in models:
            m.predict(ctx, preds[m.key][k], dpreds[m.key][k] if spatial else None)



def solve_all(problem: Evaluated, robot: Robot, qa_all: Array, x: Array) -> Array:
    """Every sample's configuration on the reference assembly:
    :meth:`SolveState.solve <pincal.identification.evaluation.SolveState.solve>` for all samples at once, by stacked
    Newton solves (:class:`~pincal.model.batch_kinematics.BatchKinematics`).

    A sample solved before starts from its own last configuration (moved by :func:`predicted_change`, Newton's
    refusals measured from the configuration itself). A first solve, and a refused warm start, is answered by
    continuation from the reference, all such samples stepping together: what the per-sample path's first solves
    come to (a warm start from the nearest solved sample is refused unless it lands on the same assembly), with no
    neighbour search and no chain of solves waiting for each other. A sample the stacked solves do not close is
    solved alone (:meth:`SolveState.solve_from <pincal.identification.evaluation.SolveState.solve_from>`: finer
    continuation, or the error naming it); so are the samples of a set of fewer than :data:`SMALL_BATCH`, where a
    stacked solve's fixed cost exceeds a few solves alone.
    """
    assert problem.loop_batch is not None
    kin = problem.loop_batch.kinematics
    n, model, closure = len(qa_all), robot.model, robot.closure
    known = np.array([guess is not None for guess in problem.solves.configurations], dtype=bool)
    previous = np.full((n, model.nq), np.nan)
    if np.any(known):
        previous[known] = np.array([guess for guess in problem.solves.configurations if guess is not None])
    q = np.full((n, model.nq), np.nan)
    ok = np.zeros(n, dtype=bool)
    warm = np.flatnonzero(known)
    if warm.size >= SMALL_BATCH:
        q[warm], ok[warm] = kin.warm_solve(model, closure, qa_all[warm], previous[warm], SOLVE_TOLERANCE,
                                           predicted_change(problem, x, warm))
    cold = np.flatnonzero(~ok) if warm.size >= SMALL_BATCH else np.flatnonzero(~known)
    if cold.size >= SMALL_BATCH:
        q[cold], ok[cold] = kin.continuation(model, closure, qa_all[cold], SOLVE_TOLERANCE)
    for row in np.flatnonzero(~ok).tolist():  # alone: finer steps, or the error naming the sample
        q[row] = problem.solves.solve_from(robot, row, qa_all[row], previous[row] if known[row] else None)
        known[row] = False  # its travel is counted
    travel = np.abs(q - previous).max(axis=1, initial=0.0)
    problem.solves.travel[known] += travel[known]
    for k in range(n):
        problem.solves.configurations[k] = q[k]
    problem.solves.solved_at = x.copy()
    return q


def remember(problem: Evaluated, q: Array | None) -> None:
    """Take ``q`` (N, nq), every sample's closed configuration on the reference assembly of ``problem``'s robot at or
    near the parameters its next evaluation asks for (a usability check's, another problem's on the same samples),
    as the warm starts of its next solves: Newton from them, refused where it jumps, as from a configuration solved
    by ``problem`` itself. Nothing for None or a robot without loops."""
    if q is None or not problem.robot.loops:
        return
    q = np.asarray(q, dtype=float)
    if q.shape != (problem.observations.n_samples, problem.robot.model.nq):
        raise ValueError(f"configurations of shape {q.shape}, expected "
                         f"({problem.observations.n_samples}, {problem.robot.model.nq})")
    problem.solves.configurations = list(q.copy())
    problem.drop_start()  # the start's evaluation, if made, was solved from other configurations


def carry_over(source: Evaluated, target: Evaluated) -> None:
    """``target`` (a problem on ``source``'s samples, over other parameters) starts its solves from ``source``'s last
    configurations, with the travel ``source`` counted since it last knew them on the reference assembly: the
    assembly check at the end of a fit (:meth:`CalibrationProblem.settle_assembly`) sees what both problems moved.
    Nothing while a sample of ``source`` has no configuration, or for a robot without loops."""
    if not source.robot.loops or any(q is None for q in source.solves.configurations):
        return
    remember(target, np.array(source.solves.configurations))
    target.solves.travel += source.solves.travel


def predicted_change(problem: Evaluated, x: Array, rows: IntArray) -> Array | None:
    """(len(rows), n_passive) the passive joints' first-order change [rad or m] from the remembered
    configurations of samples ``rows`` to ``x``: the last Jacobian evaluation's dv/dθ times the parameters'
    change; None without one, and zero for a sample it would move by more than :data:`PREDICTED_MOVE`."""
    if problem.solves.response is None or problem.solves.solved_at is None or problem.solves.solved_at.shape != x.shape:
        return None
    change = problem.solves.response[rows] @ (x - problem.solves.solved_at)
    change[~(np.abs(change).max(axis=1, initial=0.0) <= PREDICTED_MOVE)] = 0.0
    return np.asarray(change, dtype=float)


def _local_twist(rotation: Array, translation: Array, spatial: Array) -> Array:
    """(6, p) a frame's local twist ``Ad(oMf⁻¹) W`` from its spatial twist ``W`` (6, p), the frame at ``rotation``,
    ``translation`` [m]: ``(Rᵀ (W_v − t × W_ω), Rᵀ W_ω)``."""
    local: Array = np.vstack([rotation.T @ (spatial[:3] - np.cross(translation, spatial[3:], axis=0)),
                              rotation.T @ spatial[3:]])
    return local


def whiten(err: Array, jac: Array, weights: Array, reading_jac: Array, joint_sigma: Array, incremental: bool,
           rows: npt.NDArray[np.intp]) -> tuple[Array, Array]:
    """Each sample's rows whitened by ``L⁻¹``, ``L Lᵀ = diag(σ²) + G Σ_q Gᵀ``: ``err`` and ``jac`` hold the samples
    ``rows`` (those with a reading), ``weights`` the rows' σ [m, rad], ``reading_jac`` (N, rows, na) every sample's
    ``G``, the predictions' derivative w.r.t. the actuated readings, whose σ is ``joint_sigma`` [rad or m]."""
    g = reading_jac * joint_sigma  # (N, rows, na), scaled by σ_q
    if incremental:  # a difference of two samples: independent reading noise at each (diagonal only)
        var = np.sum(g[rows] ** 2, axis=2) + np.sum(g[rows - 1] ** 2, axis=2) + weights**2
        scale = np.sqrt(var)
        return err / scale, jac / scale[..., None]
    g = g[rows]
    cov = g @ np.swapaxes(g, 1, 2)
    cov[:, np.arange(weights.size), np.arange(weights.size)] += weights**2
    try:
        chol = np.linalg.cholesky(cov)  # diag(σ²) + G Σ_q Gᵀ, σ > 0: positive definite unless out of range
    except np.linalg.LinAlgError:
        raise DataError("a sample's measurement covariance (stated σ and the joint readings' noise) is not "
                        "positive definite: a σ or a reading is out of range") from None
    white_err = np.linalg.solve(chol, err[..., None])[..., 0]
    white_jac = np.linalg.solve(chol, jac)
    return white_err, white_jac
