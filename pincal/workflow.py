"""End-to-end jobs behind the command line: simulate a dataset, calibrate from a dataset.

Files are SI throughout (m, rad). ``simulate`` writes ``measurements.csv`` (train and test
postures), ``truth.urdf`` (the true robot) and ``truth.json`` (the true parameter deviations);
``calibrate`` writes the calibrated URDF and the report JSON.
"""

from __future__ import annotations

import math
import re
import sys
from collections.abc import Sequence
from dataclasses import dataclass, replace
from pathlib import Path
from typing import Any, Literal, get_args

import numpy as np
import numpy.typing as npt

from pincal import linalg
from pincal.errors import ConvergenceError, DataError, NotFoundError, PincalError, listing
from pincal.identification.choices import Loss, Solver
from pincal.identification.combinations import describe_unidentifiable
from pincal.identification.corrections import Payload, moving_mass
from pincal.identification.ikm import ImplicitProblem
from pincal.identification.losses import outlier_samples
from pincal.identification.measurements import JointReading, Measurement, Pose, parse_key
from pincal.identification.metrics import angle_error_norms, error_norms, length_columns, rms, sample_length_errors
from pincal.identification.parameters import (
    DEFAULT_SET,
    MarkerFit,
    ParameterSet,
    choose_parameters,
    influencing_joints,
    joint_unit,
)
from pincal.identification.problem import CalibrationProblem, Observations
from pincal.identification.result import CalibrationResult
from pincal.identification.selection import SELECTIONS, select_and_fit
from pincal.identification.solver import identify
from pincal.io.adapters import joints_at_reference, measurements_for, observations_from
from pincal.io.calibrated_urdf import calibrated_robot_text, declared_markers, joint_sensor_zeros, source_text
from pincal.io.corrections import Corrections, corrections_dict, corrections_of, corrections_path
from pincal.io.dataset import MAX_SAMPLES, OCCLUDABLE_KINDS, Dataset, dataset_text, read_dataset
from pincal.io.files import check_outputs, make_directory, write_texts
from pincal.io.job import Job, load_job_robot
from pincal.io.job_data import job_dataset
from pincal.io.report_data import json_text, report_dict
from pincal.model.measured_frame import frame_moves
from pincal.model.robot import Robot, load_robot, unusable_samples
from pincal.progress import Progress
from pincal.study.simulation import perturbation, random_actuated, simulate_observations

Array = npt.NDArray[np.float64]

#: How the residuals are formed: forward kinematics (measured − predicted) or implicit loop residuals (IKM).
Formulation = Literal["fkm", "ikm"]
FORMULATIONS: tuple[Formulation, ...] = get_args(Formulation)


def measurement_models(robot: Robot, kinds: Sequence[str], frame: str | None, sigma: float) -> list[Measurement]:
    """Models from CLI words: ``position``/``pose`` (of ``frame``), or full keys such as
    ``distance:frameA-frameB``, ``distance_increment:a-b``, ``joint:device_lvdt``.

    ``frame`` None measures the robot's default frame (:attr:`~pincal.model.robot.Robot.end_effector`, which
    refuses when none is obvious). A named ``frame`` that the actuated joints do not move is measured as asked,
    with one warning line on stderr: its data can identify nothing but the measurement frame.
    """
    named, frame = frame is not None, frame or robot.end_effector
    out = []
    for kind in kinds:
        key = kind if ":" in kind else f"{kind}:{frame}"  # a bare kind measures --frame
        model = parse_key(key, sigma)
        model.check(robot)  # NotFoundError naming the frame or joint and the valid ones
        if isinstance(model, JointReading) and model.joint in robot.actuated_joints:
            raise DataError(f"measurement '{key}' reads actuated joint '{model.joint}', whose reading is every "
                            "sample's input; joint: measurements are for instrumented passive joints")
        out.append(model)
    if named and any(":" not in kind for kind in kinds) and not frame_moves(robot, frame):
        print(f"pincal: warning: the actuated joints of '{robot.name}' do not move frame '{frame}': its measurements "
              "can identify only the measurement frame", file=sys.stderr)
    return out


@dataclass
class Simulation:
    """A simulated campaign: the nominal robot, the parameters and their true values ``x_true`` [m, rad], the
    dataset and the measurement models; the payload the robot carried."""
    robot: Robot
    parameters: ParameterSet
    x_true: Array
    dataset: Dataset
    measurements: list[Measurement]
    payload: Payload | None = None


def check_payload(robot: Robot, parameters: ParameterSet, payload: Payload | None) -> None:
    """Refuse a payload that would change nothing: one on a frame the robot lacks, or one given with no
    ``<joint>.compliance`` among the parameters (the payload enters only the compliance terms; ignored, it would let
    a user believe the load was accounted for).

    Raises:
        NotFoundError: the payload's frame, listing the robot's frames.
        DataError: no compliance parameter.
    """
    if payload is None:
        return
    payload.check(robot)
    if not any(p.kind == "compliance" for p in parameters):
        raise DataError(f"the payload ({payload}) enters only the joint compliances, and no <joint>.compliance is "
                        "among the parameters: add '*.compliance' (--parameters default '*.compliance'), or give no "
                        "payload")


def check_movable(robot: Robot) -> None:
    """Refuse a robot with no actuated joint: nothing moves, so no posture can be drawn or told apart."""
    if robot.n_actuated == 0:
        raise DataError(f"robot '{robot.name}' has no actuated joint: nothing moves, there is nothing to simulate or "
                        "calibrate")


def check_sample_counts(n_train: int, n_test: int) -> None:
    """Refuse sample counts :func:`simulate` cannot give: no training sample, or more than a calibration takes.

    Raises:
        DataError: naming the counts.
    """
    if n_train < 1 or n_test < 0:
        raise DataError(f"need at least one training sample (got {n_train}) and no negative test count")
    if n_train + n_test > MAX_SAMPLES:
        raise DataError(f"{n_train} + {n_test} samples: pincal calibrates at most {MAX_SAMPLES} samples in one run, "
                        "so it simulates no more")


def simulate(robot: Robot, kinds: Sequence[str], n_train: int, n_test: int = 0, frame: str | None = None,
             perturb: float = 1e-3, noise: float = 1e-5, seed: int = 0,
             parameter_spec: Sequence[str] | None = None, progress: bool = False,
             spread: float | None = None, payload: Payload | None = None) -> Simulation:
    """Simulate a calibration campaign on ``robot`` with random true errors.

    Args:
        robot: The nominal robot.
        kinds: Measurement kinds (see :func:`measurement_models`).
        n_train: Postures to calibrate from.
        n_test: Postures to validate on (held out).
        frame: Frame of the ``position``/``pose`` kinds; default: the robot's end effector.
        perturb: σ of the true errors [m and rad].
        noise: σ of the measurement noise [m, and rad for angles].
        seed: Random seed (same seed, same files).
        parameter_spec: Which parameters carry errors (named set or patterns); default: all
            candidates.
        progress: Show a progress bar while drawing postures (on a terminal).
        spread: Half-range [rad or m] of the actuated values about the reference, within the URDF limits;
            None: within the URDF limits (see :func:`~pincal.study.simulation.actuated_ranges`).
        payload: A point mass the robot carries; its gravity torque adds to the links' in the true compliances'
            deflections (refused without a compliance parameter: :func:`check_payload`).
    """
    check_sample_counts(n_train, n_test)
    check_movable(robot)
    rng = np.random.default_rng(seed)
    models = measurement_models(robot, kinds, frame, max(noise, 1e-9))
    pset = choose_parameters(robot, models, parameter_spec)
    check_payload(robot, pset, payload)
    x_true = perturbation(pset, perturb, rng)
    qa, _ = random_actuated(robot, n_train + n_test, rng, spread=spread, progress=progress)
    try:
        obs = simulate_observations(robot, pset, x_true, models, qa, rng, noise=noise, payload=payload)
    except ConvergenceError as exc:
        raise ConvergenceError(f"the simulated robot, with true errors of σ {perturb:g} (m, rad), cannot be "
                               f"assembled: {exc}; give smaller errors (perturb)") from None
    joint_names = list(robot.actuated_joints)
    joints = [obs.actuated]
    measured: dict[str, Array] = {}
    for m in models:
        if isinstance(m, JointReading):
            joint_names.append(m.joint)
            joints.append(obs.values[m.key])
        else:
            measured[m.key] = obs.values[m.key]
    n = n_train + n_test
    dataset = Dataset(joint_names, np.hstack(joints), measured, [str(k) for k in range(n)],
                      ["train"] * n_train + ["test"] * n_test,
                      {"robot": robot.name, "units": "SI (m, rad)", "perturb": repr(perturb), "seed": str(seed),
                       **{f"sigma {m.key.split(':', 1)[0]} {m.key.split(':', 1)[1]}": repr(max(noise, 1e-9))
                          for m in models}})
    return Simulation(robot, pset, x_true, dataset, models, payload)


SIMULATION_FILES = ("measurements.csv", "truth.urdf", "truth.json")


def simulation_outputs(robot: Robot, out: str | Path) -> list[Path]:
    """The files :func:`write_simulation` writes into ``out``, checked (:func:`~pincal.io.files.check_outputs`):
    ``out`` is a directory or can be made one, and none of the files is the robot's own URDF.

    Raises:
        OutputError: ``out`` is a file or cannot be created, or a file would replace the robot's URDF.
    """
    folder = make_directory(out, "--out")
    paths = [folder / name for name in SIMULATION_FILES]
    check_outputs([("--out", p) for p in paths], [robot.source] if robot.source is not None else [])
    return paths


def write_simulation(sim: Simulation, out: Path) -> list[Path]:
    """Write measurements.csv, truth.urdf and truth.json into ``out``; returns the paths.

    ``truth.urdf`` is the true robot written as a calibrated URDF (docs/calibrated_urdf.md): its forward
    kinematics at the actuated readings of ``measurements.csv``, in its root frame (the measurement frame
    when ``base.*`` carries errors), reproduces the measurements up to the noise; the sensors of read
    passive joints read ``q + zero`` (its ``<joint_sensor>`` elements, also in ``truth.json``).
    """
    paths = simulation_outputs(sim.robot, out)
    read = [m.joint for m in sim.measurements if isinstance(m, JointReading)]
    text, shifts = calibrated_robot_text(sim.robot, source_text(sim.robot), sim.parameters, sim.x_true,
                                         note="the TRUE robot of a pincal simulation (nominal + known errors)",
                                         read_joints=read, markers=declared_markers(sim.measurements))
    truth = {"robot": sim.robot.name, "units": "SI: m, rad", "parameters": sim.parameters.as_dict(sim.x_true),
             "reference_shifts": shifts, "joint_sensor_zeros": joint_sensor_zeros(text)}
    texts = list(zip(paths, (dataset_text(sim.dataset), text, json_text(truth)), strict=True))
    corrections = corrections_of(sim.robot, sim.parameters, sim.x_true, sim.payload)
    if corrections is not None:  # the true joint harmonics and compliances, as a calibration writes them
        texts.append((corrections_path(paths[1]), json_text(corrections_dict(corrections, sim.robot))))
    return write_texts(texts)


@dataclass
class Calibration:
    """One calibration: the problem, the identification result, the report dict and the calibrated URDF text."""
    problem: CalibrationProblem
    result: CalibrationResult
    report: dict[str, Any]
    urdf_text: str
    corrections: Corrections | None = None  # joint harmonics and compliances: the corrections file


def calibrate(robot: Robot, dataset: Dataset, parameter_spec: Sequence[str] | None = None, solver: Solver = "lm",
              loss: Loss = "auto", sigma: float | None = None, x_true: Array | None = None,
              pose_sigma_angle: float | None = None, formulation: Formulation = "fkm",
              max_iter: int = 100, select: str = "auto", cv: str | None = None, cv_seed: int = 0,
              progress: bool = False, markers: MarkerFit = "each", payload: Payload | None = None) -> Calibration:
    """Identify ``robot``'s parameters from the ``train`` samples; evaluate on the ``test`` samples.

    ``select``: ``bic`` leaves out the groups of parameters (joint translations, joint rotations, reading offsets)
    the Bayesian information criterion rejects, then refits (:mod:`pincal.identification.selection`); ``none``
    fits every identifiable parameter; ``auto`` (default) is ``bic`` for the default parameter set and ``none``
    for a set named by ``parameter_spec`` (a model the user chose is fitted as chosen). ``cv``: ``K``, ``KxR``
    or ``loo`` runs K-fold cross-validation (R times) of the whole fit, selection included, over every usable
    sample of the file (:func:`cross_validate`), the shuffles seeded ``cv_seed``, ``cv_seed + 1``, …; the report
    gets ``cv``. ``progress`` shows the folds on stderr
    (when it is a terminal).

    ``formulation``: ``fkm`` (measured − predicted by forward kinematics) or ``ikm`` (implicit loop
    residuals with the measured pose held fixed, study 000). Errors before/after are position errors
    [m] (and, for poses, orientation errors [rad]) by forward kinematics in both cases, so the two can be
    compared. "Before" is the same model for the fit and the held-out samples: the nominal robot, with
    the measurement frame registered to the training data in closed form when all of ``base.*`` is
    estimated (``report["before_means"]`` says which). ``max_iter`` bounds the solver's iterations.
    ``loss``: ``auto`` (default; least squares, then a Cauchy refit when the data hold implausible samples,
    which the report lists), ``linear`` or ``cauchy`` (see :func:`pincal.identification.solver.identify`).
    ``markers``: how the default set fits the markers declared on a frame (``position:<frame>@<marker>``):
    ``each`` marker's offset, or one rigid placement of the frame's ``cluster`` (their nominal offsets declared
    in the file). A marker not seen in a sample (its cells empty) leaves that sample's other readings in use; a
    sample with no reading at all is dropped and listed. The report counts the readings (``readings``,
    ``readings_not_seen``, ``test_readings``): every RMS is over the readings taken.
    ``payload``: a point mass the robot carried during the measurements, whose gravity torque adds to the links' in
    the compliance terms (:class:`~pincal.identification.corrections.Payload`); refused unless a ``<joint>.compliance``
    is among the parameters (:func:`check_payload`). The report and the corrections file record it.

    Raises:
        DataError: no training sample (every row is ``set=test``, or none can be assembled); a ``cv_seed`` that
            would seed nothing (:func:`check_cv_seed`).
    """
    check_movable(robot)
    check_cv_seed(cv, cv_seed)
    if formulation not in FORMULATIONS:
        raise DataError(f"unknown formulation '{formulation}'; formulations are: {listing(FORMULATIONS)}")
    if max_iter < 1:
        raise DataError(f"max_iter is {max_iter}: at least one iteration is needed")
    if "train" not in dataset.sets:
        raise DataError(f"all {dataset.n_samples} samples are marked set=test: there is nothing to fit on; mark "
                        "the samples to calibrate from set=train (or leave the set column out)")
    train = dataset.of_set("train")
    models = measurements_for(robot, list(dataset.measurements), dataset.joint_names, sigma, dataset.metadata)
    if pose_sigma_angle is not None:
        models = [replace(m, sigma_angle=pose_sigma_angle) if isinstance(m, Pose) else m for m in models]
    if not models:
        raise DataError("the data has no measurement columns ('<kind>:<frame>:<component>', e.g. "
                        "position:end_effector:x, see docs/dataset.md) and no passive joint readings: nothing to "
                        "calibrate from")
    at_reference = joints_at_reference(robot, dataset.joint_names, models)
    pset = choose_parameters(robot, models, parameter_spec, markers)
    check_payload(robot, pset, payload)
    train, dropped_info = usable_part(robot, train)
    if train.n_samples == 0:
        raise DataError(f"none of the {len(dropped_info)} training samples can be used: "
                        f"{dropped_info[0]['reason'] if dropped_info else 'no data'}")
    obs = observations_from(robot, train.joint_names, train.joints, train.measurements, models)
    if select not in SELECT_CHOICES:
        raise DataError(f"unknown selection '{select}'; selections are: {listing(SELECT_CHOICES)}")
    if select == "bic" and formulation != "fkm":
        raise DataError("--select bic chooses among fkm fits; with --formulation ikm use --select none (or auto)")
    if select == "auto":
        named = parameter_spec is not None and len(parameter_spec) > 0 and list(parameter_spec) != [DEFAULT_SET]
        select = "none" if named or formulation != "fkm" else "bic"
    folds, every = None, None
    if cv is not None:  # checked before any fit
        check_cross_validation(models, formulation)
        usable, _ = usable_part(robot, dataset)
        folds = parse_cv(cv, usable.n_samples, cv_seed)
        every = observations_from(robot, usable.joint_names, usable.joints, usable.measurements, models)
    problem = CalibrationProblem(robot, pset, models, obs, payload=payload)
    if formulation == "fkm":
        check_length_scale(problem)
    full_set, removed, first = pset, [], None
    if formulation == "ikm":
        result = identify(ImplicitProblem(robot, pset, models, obs), solver=solver, loss=loss, max_iter=max_iter)
        result.extra["closure_before"] = result.errors_before
        result.extra["closure_after"] = result.errors_after
        result.errors_before = problem.evaluate(result.x0, jacobian=False).errors
        result.errors_after = problem.evaluate(result.x, jacobian=False).errors
    else:
        fitted = select_and_fit(problem, select, solver=solver, loss=loss, max_iter=max_iter)
        problem, result, removed, first = fitted.problem, fitted.result, fitted.removed, fitted.first
        pset = problem.parameters
        if x_true is not None and removed:
            x_true = x_true[[full_set.index(name) for name in pset.names]]
    status = "" if result.converged else f"NOT CONVERGED ({result.message} after {result.iterations} iterations): "
    text, shifts = calibrated_robot_text(robot, source_text(robot), pset, result.x,
                                         note=f"{status}calibrated by pincal from {obs.n_samples} samples "
                                              f"({', '.join(m.key for m in models)})",
                                         read_joints=[m.joint for m in models if isinstance(m, JointReading)],
                                         markers=declared_markers(models))
    report = report_dict(result, problem, x_true, shifts)
    corrections = corrections_of(robot, pset, result.x, payload)
    report["corrections"] = corrections.joints if corrections is not None else {}
    report["payload"] = payload.as_dict() if payload is not None else None
    if payload is not None:  # what its mass is weighed against [kg]
        report["links_mass"] = moving_mass(robot)
    report["markers"] = markers
    report["formulation"] = formulation
    report["selection"] = {"policy": select if formulation == "fkm" else "none", "removed": removed,
                           "removed_groups": list(fitted.removed_groups) if removed else [],
                           "n_candidates": len(full_set)}
    if first is not None:  # what the data cannot see among all the candidates, not only among the kept ones
        report["n_identifiable"] = first.identifiability.rank
        report["unidentifiable"] = [c.description for c in first.identifiability.unidentifiable]
        report["n_parameters"] = len(full_set)
    combinations = (first or result).identifiability.unidentifiable
    report["unidentifiable_listing"] = describe_unidentifiable(combinations, UNIDENTIFIABLE_LINES)
    report["n_estimated"] = len(result.identified)
    report["n_residuals"] = int(problem.row_samples().size)
    report["joints_at_reference"] = at_reference
    report["dropped_samples"] = dropped_info
    report["down_weighted_samples"] = [train.sample_ids[k] for k in result.down_weighted()]
    lengths = sample_length_errors(result.errors_after, obs.n_samples)
    report["down_weighted"] = [{"sample": train.sample_ids[k], "weight": float(result.sample_weights[k]),
                                "error_after": float(lengths[k]) if lengths is not None and np.isfinite(lengths[k])
                                else None}
                               for k in result.down_weighted()]
    report["n_samples_in_file"] = dataset.n_samples
    suspects = result.extra.get("outlier_test", [])
    report["outlier_test"] = [train.sample_ids[k] for k in suspects] if isinstance(suspects, list) else []
    if "test" in dataset.sets:
        test = dataset.of_set("test")
        test, dropped_test = usable_part(robot, test)
        if dropped_test:  # listed, never silently
            report["dropped_test_samples"] = dropped_test
        tobs = observations_from(robot, test.joint_names, test.joints, test.measurements, models)
        tprob = CalibrationProblem(robot, pset, models, tobs, payload=payload)
        errors_before = tprob.evaluate(result.x0, jacobian=False).errors  # the same "before" as the fit's
        held_out = tprob.evaluate(result.x, jacobian=False)
        errors_after = held_out.errors
        # held-out samples the calibrated model cannot explain at the noise level the held-out set itself
        # shows (the same test as the fit's outlier test): named, since they inflate the held-out figures
        strange = outlier_samples(tprob, held_out)
        report["held_out_outliers"] = [test.sample_ids[k] for k in strange]
        moving = influencing_joints(robot, sorted({f for m in models for f in m.frames}),
                                    [m.joint for m in models if isinstance(m, JointReading)])
        report["held_out_outside_range"] = held_out_outside_range(robot, train, test, joints=moving)
        before, after = error_norms(errors_before), error_norms(errors_after)
        report["test_readings"] = tprob.n_readings()
        report.update({"n_test_samples": tobs.n_samples, "test_rms_before": rms(before), "test_rms_after": rms(after),
                       "test_max_before": float(before.max()) if before.size else None,
                       "test_max_after": float(after.max()) if after.size else None})
        angles_before, angles_after = angle_error_norms(errors_before), angle_error_norms(errors_after)
        if angles_before.size:
            report.update({"test_rms_angle_before": rms(angles_before), "test_rms_angle_after": rms(angles_after),
                           "test_max_angle_before": float(angles_before.max()),
                           "test_max_angle_after": float(angles_after.max())})
        trusted = result.sigma2 <= NOISE_CONTRADICTED  # a fit at the noise level: strange held-out rows are wrong
        report["worse_than_nominal"] = _worse_than_nominal(errors_before, errors_after, tobs.n_samples,
                                                           strange if trusted else [])
    if folds is not None and every is not None:
        report["cv"] = cross_validate(robot, full_set, models, every, folds, select=select, progress=progress,
                                      payload=payload, solver=solver, loss=loss, max_iter=max_iter)
    return Calibration(problem, result, report, text, corrections)


#: Model selection choices of :func:`calibrate`: ``auto`` (``bic`` for the default parameter set, ``none`` for a
#: named one), or a policy of :data:`~pincal.identification.selection.SELECTIONS`.
SELECT_CHOICES = ("auto", *SELECTIONS)


@dataclass(frozen=True)
class Folds:
    """A cross-validation plan: ``k`` folds (``k`` = the sample count for leave-one-out), ``repeats`` shuffles, the
    ``r``-th drawn from a permutation seeded ``seed + r``."""

    k: int
    repeats: int
    leave_one_out: bool = False
    seed: int = 0

    @property
    def label(self) -> str:
        """How the plan reads in a report: ``5-fold × 4`` or ``leave-one-out``."""
        if self.leave_one_out:
            return "leave-one-out"
        label = f"{self.k}-fold" + (f" × {self.repeats}" if self.repeats > 1 else "")
        if self.seed:
            last = self.seed + self.repeats - 1
            label += f", shuffle seed {self.seed}" if last == self.seed else f", shuffle seeds {self.seed}–{last}"
        return label


#: Where the user gave an option of :func:`calibrate`: on the command line, as a keyword argument of
#: :func:`calibrate`, or in a job file (its path). A message names the option as it is written there.
OptionSource = Literal["command line", "keyword"] | Path


def _written(key: str, value: str | int, source: OptionSource, in_file: bool = True) -> str:
    """Option ``key`` (a keyword of :func:`calibrate`) set to ``value`` as the user writes it at ``source``:
    ``--cv-seed 5``, ``cv_seed=5``, or ``cv_seed = 5 in job.toml`` (without the file when not ``in_file``)."""
    if source == "command line":
        return f"--{key.replace('_', '-')} {value}"
    if source == "keyword":
        return f"{key}={value!r}"
    shown = f'"{value}"' if isinstance(value, str) else str(value)  # TOML's quotes
    return f"{key} = {shown}" + (f" in {source}" if in_file else "")


#: Largest ratio between the spread of measured positions and the nominal robot's at the same joint readings (either
#: way) before the data are taken for lengths in another unit: a nominal robot is off by millimetres, not by its size.
LENGTH_SCALE_RATIO = 30.0


def check_length_scale(problem: CalibrationProblem) -> None:
    """Refuse positions read in the wrong unit (DataError naming the measurement): the spread of each measured
    position (the median distance [m] from their median point, indifferent to a frame's placement and to gross
    outliers) against the nominal robot's at the same joint readings, from the calibration's start. Data in metres
    read as millimetres shrink 1000× (the fit would squash the robot onto them); a frame that barely moves (a spread
    under 1 mm) is not judged."""
    x0 = problem.initial_guess()
    predicted = problem.evaluate(x0, jacobian=False).predicted
    for m in problem.measurements:
        if length_columns(m.key) != 3 or m.key not in predicted:
            continue
        measured, nominal = problem.observations.values[m.key][:, :3], predicted[m.key][:, :3]
        rows = np.all(np.isfinite(measured), axis=1) & np.all(np.isfinite(nominal), axis=1)
        if np.count_nonzero(rows) < 3:
            continue
        spread_measured, spread_nominal = (float(np.median(np.linalg.norm(a[rows] - np.median(a[rows], axis=0),
                                                                          axis=1))) for a in (measured, nominal))
        if spread_nominal < 1e-3:
            continue
        ratio = spread_nominal / spread_measured if spread_measured > 0.0 else math.inf
        if not 1.0 / LENGTH_SCALE_RATIO <= ratio <= LENGTH_SCALE_RATIO:
            shown = f"{ratio:.0f}× as much" if ratio >= 1.0 else f"{1.0 / ratio:.0f}× less"
            raise DataError(f"the measured positions '{m.key}' spread {spread_measured * 1e3:.3g} mm about their "
                            f"median, the nominal robot's at the same joint readings {spread_nominal * 1e3:.3g} mm "
                            f"({shown}): are the lengths in the unit stated (metres in a CSV; a job file's [data] "
                            "units)?")


def check_cv_seed(cv: str | None, cv_seed: int, cv_source: OptionSource = "keyword",
                  seed_source: OptionSource = "keyword") -> None:
    """Refuse a shuffle seed that would seed nothing: a ``cv_seed`` other than 0 (the default) with no ``cv``, or
    with ``cv="loo"`` (leave-one-out leaves each sample out in turn, with no shuffle to seed); and a negative one.
    The message names each option as the user gave it, at ``cv_source`` and ``seed_source``: ``--cv-seed 5`` on
    the command line, ``cv_seed=5`` to :func:`calibrate`; a job file's own seed is blamed on the file and its key,
    as the job reader's errors are (``job.toml: cv_seed: 5 ...``).

    Raises:
        DataError: naming the seed and, with ``loo``, the ``cv`` that has no shuffle.
    """
    job = seed_source if isinstance(seed_source, Path) else None
    culprit = f"{job}: cv_seed: {cv_seed}" if job is not None else _written("cv_seed", cv_seed, seed_source)
    seed_option = "--cv-seed" if seed_source == "command line" else "cv_seed"
    if cv_seed < 0:
        raise DataError(f"{culprit}: give a whole number ≥ 0")
    if not cv_seed:
        return
    if cv is None:
        if seed_source == "command line":
            raise DataError(f"{culprit} seeds the shuffles of --cv; give --cv too (e.g. --cv 5x4)")
        raise DataError(f"{culprit} seeds the shuffles of a K-fold cross-validation, and no cv is given; give cv too "
                        f"(e.g. {_written('cv', '5x4', seed_source, in_file=False)})")
    if cv.strip().lower() == "loo":
        loo = _written("cv", cv, cv_source, in_file=cv_source != job)
        folds = _written("cv", "5x4", cv_source, in_file=False)
        raise DataError(f"{culprit} seeds the shuffles of K-fold plans; {loo} has none (it leaves each sample out in "
                        f"turn): drop {seed_option}, or cross-validate by K folds (e.g. {folds})")


def parse_cv(text: str, n_samples: int, seed: int = 0) -> Folds:
    """``K``, ``KxR`` (K folds, R shuffles, seeded ``seed``, ``seed + 1``, …) or ``loo`` as a :class:`Folds`, for
    ``n_samples`` usable samples.

    Raises:
        DataError: another text, K < 2, K above the sample count, R outside 1..100, or a negative seed.
    """
    if seed < 0:
        raise DataError(f"--cv-seed {seed}: give a whole number ≥ 0")
    word = text.strip().lower()
    if word == "loo":
        return Folds(n_samples, 1, leave_one_out=True)
    match = re.fullmatch(r"([0-9]+)(?:x([0-9]+))?", word)
    if match is None:
        raise DataError(f"--cv '{text}': give K (folds), KxR (K folds, R shuffles, e.g. 5x4) or loo")
    k, repeats = int(match.group(1)), int(match.group(2) or 1)
    if not 2 <= k <= n_samples or not 1 <= repeats <= 100:
        raise DataError(f"--cv '{text}': K must lie between 2 and the {n_samples} usable samples, R between 1 and 100")
    return Folds(k, repeats, seed=seed)


def check_cross_validation(models: Sequence[Measurement], formulation: str) -> None:
    """Refuse a cross-validation that would not mean what it says (DataError naming why): of the ``ikm``
    formulation (the folds fit by forward kinematics), of ``distance_increment`` data (a fold breaks the chain of
    readings), or of data with no position, pose or distance (the figure is a position error)."""
    if formulation != "fkm":
        raise DataError("--cv cross-validates the fkm formulation; run it without --formulation ikm")
    chained = [m.key for m in models if m.key.startswith("distance_increment:")]
    if chained:
        raise DataError(f"--cv cannot split {listing(chained)}: each reading is the change since the previous sample, "
                        "so a fold would break the chain")
    if not any(length_columns(m.key) for m in models):
        raise DataError("--cv reports the position error of unseen samples, and these data measure no position, pose "
                        "or distance")


def cross_validate(robot: Robot, pset: ParameterSet, models: Sequence[Measurement], obs: Observations, folds: Folds,
                   select: str = "bic", *, progress: bool = False, payload: Payload | None = None,
                   **options: Any) -> dict[str, Any]:
    """K-fold cross-validation of the whole fit (selection and robust starts included): each fold is fitted
    without its samples and predicts them (with the ``payload`` of the compliance terms, if any). ``options`` go to
    :func:`~pincal.identification.selection.select_and_fit`.

    The ``r``-th shuffle is a permutation seeded ``folds.seed + r``: the plan holds the seed (``parse_cv(text,
    n_samples, seed)``; its label in the report names it). A ``seed=`` keyword, this function's until the seed moved
    into :class:`Folds`, is refused with a TypeError saying where it went, and the arguments after ``select`` are
    keyword-only, so an old call's positional seed is not taken for ``progress``. A fold whose fit fails is listed
    and left out; one whose fit stopped short of convergence is counted. Returns the plan, the RMS position error of the
    predictions [m] (``rms``, pooled over every fold and repeat; None when no fold could be fitted), the same per
    length-type reading when there are several (``rms_by_reading``, e.g. each marker of a body) and of the
    orientation [rad] for poses (``rms_angle``), the predictions' count, the failed fits and the unconverged ones.
    """
    if "seed" in options:
        raise TypeError(f"cross_validate() takes the shuffles' seed from its plan, not seed={options['seed']!r}: "
                        "give Folds(k, repeats, seed=...) or parse_cv(text, n_samples, seed)")
    n = obs.n_samples
    lengths, angles, failed, unconverged = [], [], [], 0
    by_reading: dict[str, list[Array]] = {m.key: [] for m in models if length_columns(m.key)}
    with Progress(f"cross-validation ({folds.label})", folds.k * folds.repeats, quiet=not progress) as bar:
        for repeat in range(folds.repeats):
            order = (np.arange(n) if folds.leave_one_out
                     else np.random.default_rng(folds.seed + repeat).permutation(n))
            for f in range(folds.k):
                bar.advance()
                test = np.sort(order[f::folds.k])
                train = np.setdiff1d(np.arange(n), test)
                try:
                    fitted = select_and_fit(CalibrationProblem(robot, pset, models, obs.subset(train),
                                                               payload=payload), select, **options)
                    held = CalibrationProblem(robot, fitted.problem.parameters, models, obs.subset(test),
                                              payload=payload)
                    errors = held.evaluate(fitted.result.x, jacobian=False).errors
                except PincalError as exc:
                    failed.append(f"repeat {repeat + 1}, fold {f + 1}: {exc}")
                    continue
                unconverged += not fitted.result.converged
                lengths.append(error_norms(errors))
                angles.append(angle_error_norms(errors))
                for key, parts in by_reading.items():
                    parts.append(error_norms(errors, [key]))
    pooled = np.concatenate(lengths) if lengths else np.zeros(0)
    out: dict[str, Any] = {"plan": folds.label, "n_samples": n, "n_predictions": int(pooled.size),
                           "rms": rms(pooled) if pooled.size else None, "failed_folds": failed,
                           "unconverged_folds": int(unconverged)}
    if len(by_reading) > 1 and pooled.size:
        joined = {key: np.concatenate(parts) for key, parts in by_reading.items()}
        out["rms_by_reading"] = {key: rms(v) if v.size else None for key, v in joined.items()}
    turned = np.concatenate(angles) if angles else np.zeros(0)
    if turned.size:
        out["rms_angle"] = rms(turned)
    return out


#: Most lines the summary gives the unidentifiable combinations (the report's ``unidentifiable`` has them all).
UNIDENTIFIABLE_LINES = 10
#: Relative difference of two RMS errors below which they are the same (a fit of the base alone reproduces the
#: closed-form registration of the "before" model up to round-off).
SAME_ERROR = 1e-6
#: σ² factor beyond which a fit does not reach the stated noise (residuals over 3 × σ).
NOISE_CONTRADICTED = 9.0


def _worse_than_nominal(before: dict[str, Array], after: dict[str, Array], n: int, strange: list[int]) -> bool:
    """Whether the calibrated model predicts the held-out samples worse than the nominal one (RMS length error),
    leaving out the ``strange`` held-out samples (those a fit at the noise level cannot explain: a wrong reading
    in the held-out set must not condemn a good fit); on all samples when that would leave none."""
    per_before, per_after = sample_length_errors(before, n), sample_length_errors(after, n)
    if per_before is None or per_after is None:
        return bool(rms(error_norms(after)) > (1 + SAME_ERROR) * rms(error_norms(before)))
    keep = np.setdiff1d(np.arange(n), strange) if len(strange) < n else np.arange(n)
    keep = keep[np.isfinite(per_after[keep]) & np.isfinite(per_before[keep])]  # samples with a length reading
    return bool(rms(per_after[keep]) > (1 + SAME_ERROR) * rms(per_before[keep]))


def joint_kinds(robot: Robot) -> dict[str, str]:
    """``revolute`` or ``prismatic`` for each one-DOF joint of ``robot`` (the kinds whose readings
    :func:`~pincal.io.dataset.read_dataset` checks for degrees and millimetres; continuous joints are left out)."""
    model = robot.model
    names = [str(model.names[jid]) for jid in range(1, model.njoints) if model.joints[jid].nq == 1]
    return {name: "prismatic" if joint_unit(robot, name) == "m" else "revolute" for name in names}


def read_robot_dataset(path: str | Path, robot: Robot, min_samples: int = 2) -> Dataset:
    """:func:`~pincal.io.dataset.read_dataset` for ``robot``, the readings of its revolute and prismatic joints
    checked for degrees and millimetres. Every command reads data through here. A file whose ``# robot:`` line
    names another robot is refused. The actuated joints that move a measured frame must have a column; that is
    checked with the measurement models (:func:`~pincal.io.adapters.joints_at_reference`)."""
    dataset = read_dataset(path, None, min_samples, joint_kinds=joint_kinds(robot),
                           joint_like=[str(n) for n in robot.model.names[1:]])
    recorded = dataset.metadata.get("robot")
    names = {robot.name} | ({robot.source.stem} if robot.source is not None else set())
    if recorded is not None and recorded not in names:
        raise DataError(f"{path}: its '# robot: {recorded}' line says the data are of robot '{recorded}', not of "
                        f"{' or '.join(repr(n) for n in sorted(names))} (the URDF's <robot name> or file name); give "
                        "the robot the data were taken on, or correct that line")
    return dataset


def usable_part(robot: Robot, part: Dataset) -> tuple[Dataset, list[dict[str, str]]]:
    """The samples of ``part`` that can be used, and each dropped one with its reason.

    Dropped: samples with no reading at all (every marker's cells empty, and nothing else measured),
    readings outside the URDF joint limits (a reading the robot cannot have is a wrong
    reading), and postures the nominal robot cannot assemble or that sit at a singularity
    (:func:`~pincal.model.robot.unusable_samples`).
    """
    reasons: dict[int, str] = dict(unseen_samples(robot, part))
    for k, reason in out_of_limits(robot, part):
        reasons[k] = f"{reasons[k]}; {reason}" if k in reasons else reason
    reference = robot.actuated_values(robot.q_reference)  # a joint with no column stays at its reference value
    actuated = np.column_stack([part.joints[:, part.joint_names.index(j)] if j in part.joint_names
                                else np.full(part.n_samples, reference[k])
                                for k, j in enumerate(robot.actuated_joints)])
    inside = [k for k in range(part.n_samples) if k not in reasons]
    for k, reason in unusable_samples(robot, actuated[inside]):
        reasons[inside[k]] = reason
    dropped = [{"sample": part.sample_ids[k], "reason": reasons[k]} for k in sorted(reasons)]
    return part.subset([k for k in range(part.n_samples) if k not in reasons]), dropped


def unseen_samples(robot: Robot, part: Dataset) -> list[tuple[int, str]]:
    """Samples of ``part`` that hold no reading: every measurement is a position whose cells are all empty (no
    marker seen), and no passive joint is read. Each with its reason."""
    keys = list(part.measurements)
    read = [j for j in part.joint_names if j not in robot.actuated_joints]
    if not keys or read or any(key.partition(":")[0] not in OCCLUDABLE_KINDS for key in keys):
        return []
    seen = np.zeros(part.n_samples, dtype=bool)
    for key in keys:
        seen |= np.all(np.isfinite(part.measurements[key]), axis=1)
    what = f"'{keys[0]}'" if len(keys) == 1 else f"any of the {len(keys)} markers"
    return [(int(k), f"no reading: the cells of {what} are all empty (not seen)") for k in np.flatnonzero(~seen)]


#: A held-out reading counts as outside the fitted range beyond this share of the training readings' range (5 %: a
#: held-out set drawn like the training set rarely lies that far out, so the warning means extrapolation).
RANGE_MARGIN = 0.05


def held_out_outside_range(robot: Robot, train: Dataset, test: Dataset, margin: float = RANGE_MARGIN,
                           joints: Sequence[str] | None = None) -> list[dict[str, Any]]:
    """The held-out readings of actuated joints outside the range the training readings cover.

    For each actuated joint, a ``test`` sample whose reading lies below the training minimum or above the
    training maximum by more than ``margin`` × (max − min) is listed: its error measures how the calibrated
    model extrapolates, not how it fits. An unbounded (continuous) joint's readings are compared as angles in
    [−π, π).

    ``joints`` limits the check to those joints (the ones that move what is measured; default: every actuated one).

    Returns:
        One dict per sample and joint, in sample order: ``sample`` (its id), ``joint``, ``value`` [rad or m] and
        ``range`` ([min, max] of the training readings [rad or m]).
    """
    if train.n_samples == 0 or test.n_samples == 0:
        return []
    found: list[tuple[int, int, dict[str, Any]]] = []
    for order, joint in enumerate(robot.actuated_joints):
        if joint not in train.joint_names or joint not in test.joint_names or (joints is not None
                                                                              and joint not in joints):
            continue
        fitted, held = train.joints[:, train.joint_names.index(joint)], test.joints[:, test.joint_names.index(joint)]
        if robot.model.joints[robot.joint_id(joint)].nq == 2:
            fitted, held = linalg.wrap_angle(fitted), linalg.wrap_angle(held)
        low, high = float(np.nanmin(fitted)), float(np.nanmax(fitted))
        tol = margin * (high - low)
        for k in np.flatnonzero((held < low - tol) | (held > high + tol)):
            found.append((int(k), order, {"sample": test.sample_ids[k], "joint": joint, "value": float(held[k]),
                                          "range": [low, high]}))
    return [entry for _, _, entry in sorted(found, key=lambda item: item[:2])]


#: A reading counts as outside a joint's URDF limits beyond this share of its range: URDF limits are nominal,
#: and a real encoder may read a little past them (the TIAGo data's torso reads 0.350184 m against 0.35 m).
LIMIT_MARGIN = 0.01


def out_of_limits(robot: Robot, part: Dataset, margin: float = LIMIT_MARGIN) -> list[tuple[int, str]]:
    """Samples with a joint reading outside that joint's URDF limits by more than ``margin`` of its range
    (one-DOF joints with a range), and why."""
    model = robot.model
    found: list[tuple[int, str]] = []
    for c, name in enumerate(part.joint_names):
        if not model.existJointName(name):
            continue
        joint = model.joints[model.getJointId(name)]
        if joint.nq != 1:
            continue
        lower, upper = float(model.lowerPositionLimit[joint.idx_q]), float(model.upperPositionLimit[joint.idx_q])
        if not (math.isfinite(lower) and math.isfinite(upper) and lower < upper):
            continue
        unit = joint_unit(robot, name)
        tol = margin * (upper - lower)
        for k in np.flatnonzero((part.joints[:, c] < lower - tol) | (part.joints[:, c] > upper + tol)):
            found.append((int(k), f"joint '{name}' reads {part.joints[k, c]:.6g} {unit}, outside its URDF limits "
                                  f"[{lower:.6g}, {upper:.6g}] {unit}"))
    return sorted(found, key=lambda item: item[0])


def calibrate_files(robot_path: str, data_path: str, out_urdf: str | None, report_path: str | None,
                    **options: Any) -> Calibration:
    """:func:`calibrate` from files: the outputs are checked before the fit (never over an input, parents
    created) and each is written whole or not at all."""
    robot = load_robot(robot_path)
    beside = str(corrections_path(out_urdf)) if out_urdf else None
    outputs = [(what, path) for what, path in (("--out", out_urdf), ("--report", report_path),
                                               ("--out (its corrections file)", beside)) if path]
    check_outputs(outputs, [p for p in (robot.source, data_path) if p is not None])
    dataset = read_robot_dataset(data_path, robot)
    cal = calibrate(robot, dataset, **options)
    texts = [(out_urdf, cal.urdf_text), (report_path, json_text(cal.report) if report_path else "")]
    if cal.corrections is not None:  # what the URDF cannot hold goes beside it
        texts.append((beside, json_text(corrections_dict(cal.corrections, robot))))
    write_texts([(path, text) for path, text in texts if path])  # all or none
    return cal


def calibrate_job(job: Job) -> Calibration:
    """:func:`calibrate` as a job file says (:mod:`pincal.io.job`): its robot, its data read into SI units, its
    options; the outputs are checked before the fit (never over an input, the job file included) and each is written
    whole or not at all."""
    def source(option: str) -> OptionSource:  # the command line's value in place of the job's, or the job's own
        return "command line" if option in job.overrides else job.path

    check_cv_seed(job.options.get("cv"), job.options.get("cv_seed", 0), source("cv"), source("cv_seed"))
    robot = load_job_robot(job)
    payload = job.options.get("payload")
    if payload is not None and "payload" not in job.overrides:  # the job's own: name the file
        try:
            payload.check(robot)
        except NotFoundError as exc:  # the same culprit, the job file named
            raise NotFoundError(f"{job.path}: {exc}", exc.kind, exc.name, exc.choices) from None
    beside = corrections_path(job.out) if job.out else None
    outputs = [(what, path) for what, path in (("out", job.out), ("report", job.report),
                                               ("out (its corrections file)", beside)) if path]
    check_outputs(outputs, [p for p in (robot.source, job.path, *job.files) if p is not None])
    cal = calibrate(robot, job_dataset(job, robot), **job.options)
    texts = [(job.out, cal.urdf_text), (job.report, json_text(cal.report) if job.report else "")]
    if cal.corrections is not None:  # what the URDF cannot hold goes beside it
        texts.append((beside, json_text(corrections_dict(cal.corrections, robot))))
    write_texts([(path, text) for path, text in texts if path])  # all or none
    return cal
