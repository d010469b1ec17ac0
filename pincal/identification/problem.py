"""The calibration problem: weighted residuals and their analytic Jacobian over a dataset.

Forward (FKM) formulation (study 000, Eq. 3.4): for each sample, the loops are closed for the
actuated readings (plus their offsets) with the current parameters, each measurement model
predicts its reading, and the residual is ``(predicted - measured) / σ``. Derivatives are exact:
kinematic regressors for the placements, the implicit-function theorem through the loops,
configuration Jacobians for the offsets. FK is warm-started from the previous evaluation of the
same sample, so each evaluation inside Levenberg–Marquardt costs about one Newton step per sample;
the kinematics layer refuses a warm start that jumps to another assembly, so every sample is solved
on the reference assembly, whatever the order of the samples. Trees and closed-loop robots are evaluated for
every sample at once (:mod:`~pincal.identification.tree_batch`, :mod:`~pincal.identification.loop_batch`); the
per-sample path is the reference they are tested against.
"""

from __future__ import annotations

from collections.abc import Sequence
from typing import Protocol

import numpy as np
import numpy.typing as npt
import pinocchio as pin

from pincal.errors import DataError, listing, not_found
from pincal.identification import predictions, starts
from pincal.identification.corrections import Payload, correction_regressors
from pincal.identification.derivatives import KinematicSensitivity, attached_terms, marker_points, right_jacobian
from pincal.identification.evaluation import Observations as Observations
from pincal.identification.evaluation import Prediction as Prediction
from pincal.identification.evaluation import Recalled, SolveState
from pincal.identification.loop_batch import LoopBatch
from pincal.identification.measurements import Measurement, SampleContext
from pincal.identification.parameters import (
    ParameterSet,
    ReadingOffset,
    apply_parameters,
    joint_unit,
    kinds_where,
    offset_parameter,
)
from pincal.identification.tree_batch import TreeBatch, tree_batch
from pincal.model.robot import SOLVE_TOLERANCE, Robot

Array = npt.NDArray[np.float64]
IntArray = npt.NDArray[np.int64]


class Problem(Protocol):
    """What identification needs of a problem (FKM, IKM, or one IKM chain)."""

    parameters: ParameterSet
    observations: Observations

    def evaluate(self, x: Array, jacobian: bool = True) -> Prediction:
        """Weighted residual and, if ``jacobian``, its Jacobian w.r.t. the parameter vector ``x`` [m, rad]."""

    def row_samples(self) -> IntArray:
        """The sample index of each residual row."""

    def initial_guess(self) -> Array:
        """A starting parameter vector [m, rad]."""

    def settle_assembly(self, x: Array) -> list[int]:
        """Samples whose configuration at ``x`` left the reference assembly, each reset to it."""


#: Largest coordinate gap [rad or m] between a remembered configuration and the reference assembly's that
#: still counts as the same configuration (FK closes the loops to 1e-11).
SAME_CONFIGURATION = 1e-6
#: A sample whose configuration travelled less than this [rad or m] during a fit is still on the assembly it
#: started on: errors of millimetres move joints by milliradians, another assembly is a tenth of a radian away.
SETTLED_TRAVEL = 0.05


class CalibrationProblem:
    """Residuals and Jacobians of one robot, parameter set, measurement set and dataset.

    Args:
        robot: The nominal robot.
        parameters: The unknowns (deviations from nominal).
        measurements: The measurement models; their keys index ``observations.values``.
        observations: The data.
        joint_sigma: σ of the actuated readings [rad or m] (one, or one per actuated joint), or None.
        payload: A point mass the robot carries, whose gravity torque adds to the links' in the compliance terms
            (:func:`~pincal.identification.corrections.gravity_torques`); unused without a compliance parameter.
    """

    def __init__(self, robot: Robot, parameters: ParameterSet, measurements: Sequence[Measurement],
                 observations: Observations, joint_sigma: float | Sequence[float] | None = None,
                 payload: Payload | None = None) -> None:
        self.robot = robot
        self.payload = payload
        self.parameters = parameters
        self.measurements = list(measurements)
        self.observations = observations
        self._check()
        self.joint_sigma = self._joint_sigma(joint_sigma)
        if self.joint_sigma is not None:
            # the readings' noise enters each sample's covariance through d(prediction)/d(reading), which
            # the actuated offset columns give: add those missing as nuisance columns (dropped on output)
            present = {p.owner for p in parameters if p.is_a(ReadingOffset)}
            extra = [offset_parameter(j, joint_unit(robot, j)) for j in robot.actuated_joints if j not in present]
            parameters = ParameterSet(list(parameters.parameters) + extra)
        self.all_parameters = parameters
        self.kinematic = parameters.of_kind(*kinds_where(kinematic=True))
        self.kinematic_set = parameters.subset(self.kinematic)
        actuated = {name: k for k, name in enumerate(robot.actuated_joints)}
        self.actuated_offsets = [(actuated[p.owner], k) for k, p in enumerate(parameters)
                                 if p.is_a(ReadingOffset) and p.owner in actuated]
        self.reading_offsets = {p.owner: k for k, p in enumerate(parameters)
                                if p.is_a(ReadingOffset) and p.owner not in actuated}
        corrections = [(k, p) for k, p in enumerate(parameters) if p.kind_class.in_corrections]
        strays = [p.name for _, p in corrections if p.owner not in actuated]
        if strays:
            raise DataError(f"corrections {listing(strays)} are of joints that are not actuated; harmonics and "
                            "compliance correct actuated joints' values")
        regressors = correction_regressors(robot, [(p.owner, p.term) for _, p in corrections], observations.actuated,
                                           payload)
        #: (actuated joint, column, (N,) regressor): the joint's value moves by x[column] × regressor per sample; a
        #: reading offset is the term whose regressor is 1, a harmonic or a compliance one that varies by sample
        ones = np.ones(observations.n_samples)
        self.actuated_terms = [(joint, k, ones) for joint, k in self.actuated_offsets] + [
            (actuated[p.owner], k, r) for (k, p), r in zip(corrections, regressors, strict=True)]
        self.base = parameters.groups("base").get(("base", "base", ""), [])
        # each measured marker's nominal offset [m] on its frame (zero when the data declare none)
        self.marker_nominals = {target: np.array(nominal if nominal is not None else (0.0, 0.0, 0.0))
                                for m in self.measurements for target, nominal in m.markers.items()}
        self.frames = sorted({f for m in self.measurements for f in m.frames})
        self.frame_ids = {f: robot.frame_id(f) for f in self.frames}
        #: Each sample's configuration remembered from one evaluation to the next (the warm starts of its solves)
        self.solves = SolveState(observations.n_samples, robot.kinematics.continuous)
        self.rows_per_sample = sum(m.size for m in self.measurements)
        #: The cameras and targets (attached placement names) the last :meth:`initial_guess` placed in closed form.
        self.placed_in_closed_form: list[str] = []
        self.not_in_closed_form: list[str] = []  # why the data did not determine a camera's start: one per reading
        self._initial: Array | None = None  # the default start, found once (the preparation and the fit ask it)
        self._start: tuple[Array, Prediction] | None = None  # the start and its evaluation (start_prediction)
        self._recalled = Recalled() if not robot.loops else None  # a tree's last evaluations
        self._placed: tuple[Array, Robot] | None = None  # the last kinematic deviations and their robot (placed_robot)
        #: A tree's batched evaluation (every sample at once), when its joints allow it; False: sample by sample
        #: (the reference path, which the benchmarks and tests also run on trees to compare the two).
        self.tree_batch: TreeBatch | None = tree_batch(robot, self.frame_ids) if not robot.loops else None
        self._batched_trees = self.tree_batch is not None and self.tree_batch.unsupported is None
        #: A closed-loop robot's batched evaluation (loops closed and derivatives for every sample at once), when its
        #: joints allow it; False: sample by sample (the reference path, which the tests compare it with).
        self.loop_batch = LoopBatch(robot, self.frame_ids) if robot.loops else None
        self._batched_loops = self.loop_batch is not None and self.loop_batch.unsupported is None
        self._seen: dict[str, npt.NDArray[np.bool_]] = {}
        for m in self.measurements:
            taken = np.all(np.isfinite(observations.values[m.key]), axis=1)
            taken[:1] &= not m.incremental
            self._seen[m.key] = taken

    def seen(self, key: str) -> npt.NDArray[np.bool_]:
        """(N,) whether each sample holds a reading of measurement ``key`` (False: a row of NaN, an occluded
        marker; an incremental measurement's first row counts as not taken)."""
        if key not in self._seen:
            raise not_found("measurement", key, list(self._seen))
        return self._seen[key]

    def n_readings(self) -> dict[str, int]:
        """Measurement key -> the number of samples that hold a reading of it (the readings the fit uses)."""
        return {m.key: int(np.count_nonzero(self.seen(m.key))) for m in self.measurements}

    def _joint_sigma(self, joint_sigma: float | Sequence[float] | None) -> Array | None:
        if joint_sigma is None:
            return None
        values = np.broadcast_to(np.asarray(joint_sigma, dtype=float), (self.robot.n_actuated,)).copy()
        if not np.all(np.isfinite(values)) or np.any(values < 0):
            raise DataError(f"joint_sigma must be non-negative standard deviations [rad or m], got {values}")
        return None if not np.any(values > 0) else values

    def _augment(self, x: Array) -> Array:
        """Pad a parameter vector with the nuisance offset columns (zero)."""
        extra = len(self.all_parameters) - len(self.parameters)
        return x if extra == 0 or x.size == len(self.all_parameters) else np.concatenate([x, np.zeros(extra)])

    def row_samples(self) -> IntArray:
        """The sample index of each residual row (the row order of :meth:`evaluate`)."""
        rows = [np.repeat(np.flatnonzero(self.seen(m.key)), m.size) for m in self.measurements]
        return np.concatenate(rows).astype(np.int64)

    def _check(self) -> None:
        obs, robot = self.observations, self.robot
        if obs.actuated.ndim != 2 or obs.actuated.shape[1] != robot.n_actuated:
            raise DataError(f"actuated readings have shape {obs.actuated.shape}; expected (N, {robot.n_actuated}) "
                            f"for {listing(robot.actuated_joints)}")
        if not np.all(np.isfinite(obs.actuated)):
            row = int(np.argwhere(~np.isfinite(obs.actuated))[0, 0])
            raise DataError(f"actuated readings of sample {row} contain NaN or infinity")
        for m in self.measurements:
            if m.key not in obs.values:
                raise DataError(f"no data for measurement '{m.key}'; data has {listing(obs.values)}")
            values = obs.values[m.key]
            if values.shape != (obs.n_samples, len(m.columns)):
                raise DataError(f"data for '{m.key}' has shape {values.shape}; expected "
                                f"({obs.n_samples}, {len(m.columns)}) for {listing(m.columns)}")
            check = values[1:] if m.incremental else values
            missing = np.all(np.isnan(check), axis=1) if m.occludable else np.zeros(len(check), dtype=bool)
            if not np.all(np.isfinite(check[~missing])):
                row = int(np.flatnonzero(~missing & ~np.all(np.isfinite(check), axis=1))[0]) + int(m.incremental)
                whole = " (a reading not taken is NaN in all its values)" if m.occludable else ""
                raise DataError(f"measurement '{m.key}' of sample {row} is NaN or infinite{whole}")
            m.check(robot)

    # --- evaluation -----------------------------------------------------------------------------
    def robot_at(self, x: Array) -> Robot:
        """The robot with the kinematic deviations of ``x`` [m, rad] applied (the calibrated robot at the end): a new
        Robot of the caller's own."""
        full = self._augment(np.asarray(x, dtype=float))
        return apply_parameters(self.robot, self.kinematic_set, full[self.kinematic])

    def placed_robot(self, x: Array) -> Robot:
        """:meth:`robot_at` for the problem's own evaluations: the robot built for the last kinematic deviations
        asked, reused while they stay the same, bit for bit (a fit moves the offsets, the base and the markers alone
        in most of its evaluations: 15 kinematic vectors in 70 evaluations of a Delta's calibration). Not for a caller
        to keep or change: the next evaluation at other deviations replaces it."""
        full = self._augment(np.asarray(x, dtype=float))
        deviations = full[self.kinematic]
        if self._placed is None or not np.array_equal(self._placed[0], deviations):
            self._placed = (deviations.copy(), apply_parameters(self.robot, self.kinematic_set, deviations))
        return self._placed[1]

    def actuated_values(self, x: Array) -> Array:
        """Actuated joint values [rad or m] with the offsets of ``x`` applied, (N, na)."""
        qa = self.observations.actuated.copy()
        x = self._augment(np.asarray(x, dtype=float))
        for joint, k, regressor in self.actuated_terms:
            qa[:, joint] += x[k] * regressor
        return qa

    def configurations(self, x: Array) -> Array:
        """Closed configurations (N, nq) of every sample at ``x``, on the reference assembly."""
        robot = self.placed_robot(x)
        qa = self.actuated_values(x)
        if self._batched_loops and robot.loops:
            return predictions.solve_all(self, robot, qa, self._augment(np.asarray(x, dtype=float))).copy()
        return np.array([self.solves.solve(robot, k, qa[k]) for k in range(qa.shape[0])])

    def initial_guess(self, start: Array | None = None) -> Array:
        """A starting point: zero (or ``start``, [m, rad]), except the placements closed forms give from the nominal
        robot (the cameras and targets, else an unknown measurement frame registered to the measured points:
        :func:`pincal.identification.starts.initial_guess`); the default one is found once."""
        if start is not None:
            return starts.initial_guess(self, start)
        if self._initial is None:
            self._initial = starts.initial_guess(self)
        return self._initial.copy()

    def start_prediction(self) -> Prediction:
        """The forward evaluation with the Jacobian at :meth:`initial_guess`, kept for the fit that starts there:
        :meth:`evaluate` there gives it without the Jacobian (the unit check reads it) and with it once (the fit's
        first evaluation); any other evaluation, or new configurations, drop it (closed loops' configurations move)."""
        x0 = self.initial_guess()
        if self._start is None:
            self._start = (x0, CalibrationProblem.evaluate(self, x0, jacobian=True))
        return self._start[1]

    def _started(self, x: Array, jacobian: bool, spare_rows: int) -> Prediction | None:
        """The kept start's evaluation as :meth:`evaluate` at ``x`` gives it (with the Jacobian once), else None."""
        kept = self._start[1] if self._start is not None and np.array_equal(x, self._start[0]) else None
        if kept is None or jacobian:
            self._start = None
        if kept is None or kept.jacobian is None or (jacobian and not spare_rows):
            return kept
        if not jacobian:
            return Prediction(kept.residual, None, kept.errors, kept.predicted)
        full = np.zeros((kept.jacobian.shape[0] + spare_rows, kept.jacobian.shape[1]))
        full[:kept.jacobian.shape[0]] = kept.jacobian
        return Prediction(kept.residual, full, kept.errors, kept.predicted)

    def settle_assembly(self, x: Array) -> list[int]:
        """Samples whose remembered configuration at ``x`` is not on the reference assembly, each reset to it.

        Warm starts follow each sample's assembly from one parameter estimate to the next; a long LM step
        (a gross outlier pulls one) can carry a sample onto another assembly that continuation from the
        reference would not reach at ``x``. One cold solve per sample (continuation from the reference)
        tells, for the samples whose configuration travelled more than :data:`SETTLED_TRAVEL` since they were
        last checked; a tree has nothing to close and returns at once.
        """
        if not self.robot.loops:
            return []
        travelled = np.flatnonzero(self.solves.travel > SETTLED_TRAVEL)
        self.solves.travel[:] = 0.0
        if travelled.size == 0:
            return []
        robot = self.placed_robot(x)
        qa = self.actuated_values(x)
        moved = []
        for k in travelled:
            remembered = self.solves.configurations[k]
            if remembered is None:
                continue
            report = robot.kinematics.solve_fk(qa[k], None, SOLVE_TOLERANCE)
            gap = np.abs(pin.difference(robot.model, remembered, report.q)) if report.converged else None
            if gap is not None and float(gap.max()) > SAME_CONFIGURATION:
                self.solves.configurations[k] = report.q
                moved.append(int(k))
        if moved:
            self._start = None  # solved on the configurations replaced here
        return moved

    def forward(self, x: Array) -> Prediction:
        """The forward (FKM) predictions at ``x`` [m, rad], without the Jacobian, whatever the formulation (an IKM
        problem's too: the starting point registers the measurement frame on them)."""
        return CalibrationProblem.evaluate(self, x, jacobian=False)

    def drop_start(self) -> None:
        """Forget the kept evaluation of the start (:meth:`start_prediction`): the configurations it was solved from
        are replaced."""
        self._start = None

    def evaluate(self, x: Array, jacobian: bool = True, spare_rows: int = 0) -> Prediction:
        """Weighted residual and its Jacobian w.r.t. ``x``; the Jacobian with ``spare_rows`` rows of zeros after the
        residual's (for a caller's own rows, a prior's: no copy of the m × p array to append them).

        With ``joint_sigma``, each measurement's rows of each sample are whitened by their covariance
        ``Σ = diag(σ²) + G Σ_q Gᵀ``, where ``Σ_q`` holds the actuated readings' variances and
        ``G = d(prediction)/d(reading)``; the correlation the shared reading noise creates *between*
        two measurements of one sample, and between consecutive incremental readings, is neglected.
        Without ``joint_sigma`` the residual is ``(predicted − measured)/σ``. The covariance is
        re-evaluated at each call and held constant in the Jacobian, as iteratively re-weighted least
        squares does.

        A tree (no loops) is evaluated for every sample at once, and so is a closed-loop robot
        (:mod:`~pincal.identification.predictions`); a robot with a joint kind :mod:`~pincal.identification.tree_batch`
        or :mod:`~pincal.model.batch_kinematics` does not take, sample by sample. They give the same numbers (to
        1e-10, tests/identification/test_tree_batch.py and test_loop_batch.py).
        """
        given = np.ascontiguousarray(x, dtype=float)
        started = self._started(given, jacobian, spare_rows)
        if started is not None:
            return started
        recalled = None if self._recalled is None else self._recalled.recall(given, jacobian, spare_rows)
        if recalled is not None:
            return recalled
        prediction = self._evaluated(given, jacobian, spare_rows)
        if self._recalled is not None:
            start = self._initial is not None and np.array_equal(given, self._initial)
            self._recalled.keep(given, prediction, spare_rows, start)
        return prediction

    def _evaluated(self, x: Array, jacobian: bool, spare_rows: int) -> Prediction:
        """:meth:`evaluate` computed (neither the kept start's nor a tree's recalled evaluation)."""
        x = self._augment(x)
        output_jacobian = jacobian
        jacobian = jacobian or self.joint_sigma is not None
        robot = self.placed_robot(x)
        n, p = self.observations.n_samples, len(self.all_parameters)
        sens = KinematicSensitivity(robot, self.all_parameters, x) if jacobian else None
        base_delta = self.all_parameters.placement_delta(x, self.base) if self.base else np.zeros(6)
        ctx = self._context(robot.model, robot.kinematics.data, x, base_delta)
        qa_all = self.actuated_values(x)
        preds: dict[str, Array] = {m.key: np.empty((n, m.size)) for m in self.measurements}
        dpreds: dict[str, Array] = {}
        full: Array | None = None
        if self._batched_trees and not robot.loops:
            assert self.tree_batch is not None
            if jacobian and self._in_place(output_jacobian):  # the models write the Jacobian's own rows
                full = np.zeros((sum(n * m.size for m in self.measurements) + spare_rows, p))
                dpreds = self._row_blocks(full)
            elif jacobian:  # kept from one evaluation to the next: _assemble copies them out
                dpreds = {m.key: self.tree_batch.scratch.array(("jacobian", m.key), (n, m.size, p))
                          for m in self.measurements}
                for block in dpreds.values():
                    block.fill(0.0)
            predictions.predict_tree(self, robot, sens, ctx, qa_all, preds, dpreds)
        else:
            if jacobian and self._in_place(output_jacobian):
                full = np.zeros((sum(n * m.size for m in self.measurements) + spare_rows, p))
                dpreds = self._row_blocks(full)
            elif jacobian:
                dpreds = {m.key: np.zeros((n, m.size, p)) for m in self.measurements}
            if self._batched_loops and robot.loops:
                predictions.predict_loops(self, robot, sens, ctx, qa_all, preds, dpreds)
            else:
                predictions.predict_samples(self, robot, sens, ctx, qa_all, preds, dpreds)
        return self._assemble(preds, dpreds, output_jacobian, full, spare_rows)

    def _in_place(self, output_jacobian: bool) -> bool:
        """Whether the Jacobian's rows can be the models' derivative blocks themselves, scaled in place (one m × p
        array per evaluation, no copy): every sample took every reading, none is a change since the previous
        sample, no joint noise whitens the rows, and no column is added to the parameters'."""
        return (output_jacobian and self.joint_sigma is None and len(self.all_parameters) == len(self.parameters)
                and all(not m.incremental and bool(np.all(self.seen(m.key))) for m in self.measurements))

    def _row_blocks(self, full: Array) -> dict[str, Array]:
        """Each measurement's (N, rows, p) view of its rows of ``full`` (measurements in order, samples in order)."""
        n, p = self.observations.n_samples, full.shape[1]
        blocks, start = {}, 0
        for m in self.measurements:
            blocks[m.key] = full[start:start + n * m.size].reshape(n, m.size, p)
            start += n * m.size
        return blocks

    def _context(self, model: pin.Model, data: pin.Data, x: Array, base_delta: Array) -> SampleContext:
        """The measurement models' context for one evaluation at ``x`` (per-sample fields unset)."""
        base_jacobian = right_jacobian(base_delta, [self.all_parameters.parameters[k].component for k in self.base])
        return SampleContext(model, data, x, pin.exp6(base_delta), base_jacobian, self.base,
                             marker_points(self.all_parameters, x, self.marker_nominals), self.reading_offsets,
                             self.frame_ids, self.observations.values, **attached_terms(self.all_parameters, x))

    def _assemble(self, preds: dict[str, Array], dpreds: dict[str, Array], jacobian: bool,
                  full: Array | None = None, spare_rows: int = 0) -> Prediction:
        """Errors, weighted residuals and the Jacobian (written once, into the array returned, with ``spare_rows``
        rows of zeros after the residual's; or scaled in place when the derivative blocks are ``full``'s own rows,
        :meth:`_row_blocks`) from each model's predictions and derivatives."""
        errors: dict[str, Array] = {}
        blocks = []
        keep = len(self.parameters)
        sizes = [int(np.count_nonzero(self.seen(m.key))) * m.size for m in self.measurements]
        if full is None and jacobian:
            full = np.empty((sum(sizes) + spare_rows, keep))
            full[sum(sizes):] = 0.0
        start = 0
        for m, size in zip(self.measurements, sizes, strict=True):
            measured = self.observations.values[m.key]
            err = m.error(preds[m.key], measured, self.robot.model)
            weights = m.row_sigmas()
            jac = dpreds.get(m.key)
            if m.incremental:
                err = np.vstack([np.zeros((1, m.size)), preds[m.key][1:] - preds[m.key][:-1] - measured[1:]])
                if jac is not None:
                    jac = np.concatenate([np.zeros((1, *jac.shape[1:])), jac[1:] - jac[:-1]])
            rows = np.flatnonzero(self.seen(m.key))  # a reading not taken has no rows (its error stays NaN)
            errors[m.key] = err
            block = None if full is None else full[start:start + size].reshape(rows.size, m.size, keep)
            start += size
            if self.joint_sigma is None or jac is None:
                blocks.append((err[rows] / weights).reshape(-1))
                if block is not None and jac is not None:
                    taken = jac if rows.size == len(jac) else jac[rows]
                    np.divide(taken[..., :keep], weights[None, :, None], out=block)
                continue
            columns = [col for _, col in sorted(self.actuated_offsets)]
            white_err, white_jac = predictions.whiten(err[rows], jac[rows], weights, dpreds[m.key][..., columns],
                                                      self.joint_sigma, m.incremental, rows)
            blocks.append(white_err.reshape(-1))
            if block is not None:
                block[...] = white_jac[..., :keep]
        residual = np.concatenate(blocks)
        return Prediction(residual, full, errors, preds)
