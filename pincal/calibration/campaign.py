"""Simulated calibration campaigns: true errors, random postures, noisy readings; and their files.

``simulate`` draws a campaign; ``write_simulation`` writes ``measurements.csv`` (train and test postures),
``truth.urdf`` (the true robot) and ``truth.json`` (the true parameter deviations). SI units: m, rad.
"""

from __future__ import annotations

import hashlib
import json
from collections.abc import Sequence
from pathlib import Path
from typing import Any

import numpy as np
import numpy.typing as npt

from pincal import validation
from pincal.calibration.provenance import Provenance, robot_source, sha256, version, with_provenance
from pincal.calibration.setup import check_movable, idle_parameters, measurement_models, parameters_for
from pincal.errors import ArgumentError, ConvergenceError, DataError, not_found
from pincal.identification.corrections import Payload
from pincal.identification.measurements import Measurement
from pincal.identification.parameters import ParameterSet, read_joints
from pincal.identification.problem import CalibrationProblem, Observations
from pincal.io.calibrated_urdf import calibrated_robot_text, declared_markers, joint_sensor_zeros, source_text
from pincal.io.corrections_file import corrections_dict, corrections_of, corrections_path
from pincal.io.dataset import MAX_SAMPLES, Dataset, dataset_text
from pincal.io.files import check_directory, check_outputs, json_text, write_texts
from pincal.io.mesh_files import MeshMode, MeshPlan, plan_meshes
from pincal.model.assemblable import unusable_samples
from pincal.model.robot import Robot
from pincal.records import record
from pincal.study.simulation import perturbation, random_actuated, simulate_observations

Array = npt.NDArray[np.float64]

@record
class Simulation:
    """A simulated campaign: the nominal robot, the parameters and their true values ``x_true`` [m, rad], the
    dataset and the measurement models; the payload the robot carried."""
    robot: Robot
    parameters: ParameterSet
    x_true: Array
    dataset: Dataset
    measurements: list[Measurement]
    payload: Payload | None = None


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


def _check_arguments(robot: Any, kinds: Any, n_train: Any, n_test: Any, frame: Any, perturb: Any, noise: Any,
                     seed: Any, parameter_spec: Any, spread: Any, payload: Any, joint_noise: Any,
                     posture_seed: Any = None, shift: Any = None) -> None:
    """Refuse the arguments of :func:`simulate` the command line would refuse, naming each."""
    validation.instance("robot", robot, Robot, "a Robot (pincal.load_robot)")
    if not validation.texts("kinds", kinds):
        raise ArgumentError("kinds=[]: give at least one measurement kind, e.g. ['position'] (the kinds of "
                            "measurement_models: position, pose, or keys such as distance:A-B, joint:NAME)")
    validation.whole("n_train", n_train, 1)
    validation.whole("n_test", n_test, 0)
    if frame is not None:
        validation.instance("frame", frame, str, "a frame name (str) or None")
    validation.real("perturb", perturb, "m, rad")
    validation.real("noise", noise, "m, rad")
    validation.real("joint_noise", joint_noise, "rad or m")
    validation.whole("seed", seed, 0)
    if posture_seed is not None:
        validation.whole("posture_seed", posture_seed, 0)
    if shift is not None:
        validation.instance("shift", shift, dict, "a dict of parameter name -> value [m, rad] or None")
        for name, value in shift.items():
            validation.instance("shift", name, str, "parameter names (str)")
            validation.real(f"shift[{name!r}]", value, "m, rad")
    validation.optional_texts("parameter_spec", parameter_spec)
    validation.optional_real("spread", spread, "rad or m")
    if payload is not None:
        validation.instance("payload", payload, Payload, "a Payload or None")


def simulate(robot: Robot, kinds: Sequence[str], n_train: int, n_test: int = 0, frame: str | None = None,
             perturb: float = 1e-3, noise: float = 1e-5, seed: int = 0,
             parameter_spec: Sequence[str] | None = None, progress: bool = False,
             spread: float | None = None, payload: Payload | None = None, joint_noise: float = 0.0,
             posture_seed: int | None = None, shift: dict[str, float] | None = None) -> Simulation:
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
        parameter_spec: Which parameters carry errors (named set or patterns); default: the default set's candidates
            less those that move no measurement at the drawn postures (as the calibration's default set leaves them
            out, :meth:`~pincal.calibration.setup.Prepared.without_idle`).
        progress: Show a progress bar while drawing postures (on a terminal).
        spread: Half-range [rad or m] of the actuated values about the reference, within the URDF limits;
            None: within the URDF limits (see :func:`~pincal.study.simulation.actuated_ranges`).
        payload: A point mass the robot carries; its gravity torque adds to the links' in the true compliances'
            deflections (refused without a compliance parameter: :func:`~pincal.calibration.setup.check_payload`).
        joint_noise: σ of the noise on the actuated readings [rad or m] (0: the readings are the true values).
        posture_seed: Seed of the postures and the noise alone; ``seed`` then draws only the true errors, so that
            one ``seed`` and several posture seeds are the same robot measured on new postures (sessions of one
            robot). None: ``seed`` draws both (the files of earlier versions).
        shift: Added to the true errors, by parameter name [m, rad] (a robot that changed since: a joint offset that
            slipped by 2 mrad is ``{"arm_1_joint.offset": 0.002}``); each name must be one of the parameters.

    Raises:
        TypeError, ArgumentError: an argument of the wrong type or value (named, with the value), ``kinds`` empty.
        NotFoundError: a ``shift`` name that is no parameter of the simulation (they are listed).
    """
    _check_arguments(robot, kinds, n_train, n_test, frame, perturb, noise, seed, parameter_spec, spread, payload,
                     joint_noise, posture_seed, shift)
    check_sample_counts(n_train, n_test)
    check_movable(robot)
    rng = np.random.default_rng(seed)
    models = measurement_models(robot, kinds, frame, max(noise, 1e-9))
    pset = parameters_for(robot, models, parameter_spec, payload=payload)
    drawn = perturbation(pset, perturb, rng)
    if posture_seed is not None:  # the robot's errors drawn from seed, the postures and the noise from their own
        rng = np.random.default_rng([posture_seed, 1])
    qa, _ = random_actuated(robot, n_train + n_test, rng, spread=spread, progress=progress)
    for _ in range(REDRAWS + 1):
        x_true = drawn.copy()
        at_nominal = CalibrationProblem(robot, pset, models, Observations.neutral(models, qa), payload=payload)
        if parameter_spec is None:  # as the calibration's default set: no error where it would move no measurement
            x_true[idle_parameters(at_nominal, np.zeros(len(pset)))] = 0.0
        for name, value in (shift or {}).items():
            x_true[_index(pset, name)] += value
        failed = true_robot_failures(at_nominal, x_true)
        if len(failed) in (0, len(qa)):  # every posture, drawn anywhere: the true robot is beyond assembling
            break
        qa[failed], _ = random_actuated(robot, len(failed), rng, spread=spread)  # drawn again, checked again
    errors = f"true errors of σ {perturb:g} (m, rad)" + "".join(f" and {name} shifted by {value:g}"
                                                                   for name, value in (shift or {}).items())
    smaller = f"errors smaller than perturb={perturb:g}" + (" and shift=NAME=VALUE" if shift else "")
    if failed:
        tried = "" if len(failed) == len(qa) else f" after {REDRAWS} redraws"
        raise ConvergenceError(f"the simulated robot, with {errors}, cannot be assembled at {len(failed)} of "
                               f"{len(qa)} random postures of '{robot.name}' that the nominal robot assembles{tried}: "
                               f"give {smaller}, or a smaller spread=S about the reference", option="perturb")
    try:
        obs = simulate_observations(robot, pset, x_true, models, qa, rng, noise=noise, joint_noise=joint_noise,
                                    payload=payload)
    except ConvergenceError as exc:
        raise ConvergenceError(f"the simulated robot, with {errors}, cannot be assembled: {exc}; give "
                               f"{smaller}", option="perturb") from None
    joint_names = list(robot.actuated_joints)
    joints = [obs.actuated]
    measured: dict[str, Array] = {}
    for m in models:
        if m.read_joints:  # an instrumented passive joint: its readings are joint columns
            joint_names += m.read_joints
            joints.append(obs.values[m.key])
        else:
            measured[m.key] = obs.values[m.key]
    n = n_train + n_test
    dataset = Dataset(joint_names, np.hstack(joints), measured, [str(k) for k in range(n)],
                      ["train"] * n_train + ["test"] * n_test,
                      {"robot": robot.name, "pincal": version(), "units": "SI (m, rad)", "perturb": repr(perturb),
                       "seed": str(seed), **({"posture seed": str(posture_seed)} if posture_seed is not None else {}),
                       **({"robot sha256": sha256(robot.source)} if robot.source is not None else {}),
                       "simulate": json.dumps(simulation_options(kinds, n_train, n_test, frame, perturb, noise, seed,
                                                                 parameter_spec, spread, payload, joint_noise,
                                                                 posture_seed, shift)),
                       **{f"sigma {m.key.split(':', 1)[0]} {m.key.split(':', 1)[1]}": repr(max(noise, 1e-9))
                          for m in models}})
    return Simulation(robot, pset, x_true, dataset, models, payload)


def simulation_options(kinds: Sequence[str], n_train: int, n_test: int, frame: str | None, perturb: float,
                       noise: float, seed: int, parameter_spec: Sequence[str] | None, spread: float | None,
                       payload: Payload | None, joint_noise: float, posture_seed: int | None = None,
                       shift: dict[str, float] | None = None) -> dict[str, Any]:
    """The arguments of :func:`simulate` as its outputs record them (JSON values; lengths [m], angles [rad], mass
    [kg]); ``posture_seed`` and ``shift`` only when given (the records of earlier versions unchanged)."""
    return {"measure": list(kinds), "samples": n_train, "test_samples": n_test, "frame": frame, "perturb": perturb,
            "noise": noise, "joint_noise": joint_noise, "seed": seed,
            "parameters": list(parameter_spec) if parameter_spec is not None else None, "spread": spread,
            "payload": payload.as_dict() if payload is not None else None,
            **({"posture_seed": posture_seed} if posture_seed is not None else {}),
            **({"shift": dict(shift)} if shift else {})}


def _index(parameters: ParameterSet, name: str) -> int:
    """The position of parameter ``name`` in ``parameters``; NotFoundError listing them when it is none."""
    if name not in parameters.names:
        raise not_found("parameter", name, list(parameters.names), " among the simulation's parameters", "shift: ")
    return list(parameters.names).index(name)


#: Rounds of redrawing the postures the simulated (true) robot cannot assemble: near the edge of the workspace, a
#: posture the nominal robot assembles may lie outside the true robot's.
REDRAWS = 20


def true_robot_failures(at_nominal: CalibrationProblem, x_true: Array) -> list[int]:
    """The samples of ``at_nominal`` that the true robot (nominal + ``x_true`` [m, rad]) cannot assemble, or
    assembles at a singular configuration (:func:`~pincal.model.assemblable.unusable_samples`); none for a serial
    robot."""
    if not at_nominal.robot.loops:
        return []
    true_robot = at_nominal.robot_at(x_true)
    return [k for k, _ in unusable_samples(true_robot, at_nominal.actuated_values(x_true))]


SIMULATION_FILES = ("measurements.csv", "truth.urdf", "truth.json")


def _mesh_plan(robot: Robot, truth: Path, meshes: MeshMode) -> MeshPlan:
    return plan_meshes(source_text(robot), robot.source.parent if robot.source is not None else None, truth, meshes)


def simulation_outputs(robot: Robot, out: str | Path, meshes: MeshMode = "keep") -> list[Path]:
    """The files :func:`write_simulation` writes into ``out``, checked (:func:`~pincal.io.files.check_outputs`):
    ``out`` is a directory or can be made one, and none of the files is the robot's own URDF or one of its meshes.

    Raises:
        OutputError: ``out`` is a file or cannot be created, or a file would replace the robot's URDF.
        NotFoundError: ``meshes`` is ``copy`` and a mesh of the robot is found nowhere here.
    """
    copies = _mesh_plan(robot, Path(out) / SIMULATION_FILES[1], meshes).copies  # a mesh found nowhere: no folder made
    folder = check_directory(out, "out", option="out")
    paths = [folder / name for name in SIMULATION_FILES]
    check_outputs([("out", p) for p in paths] + [("meshes='copy'", dest) for _, dest in copies],
                  [p for p in (robot.source, *(found for found, _ in copies)) if p is not None], keywords=True)
    return paths


def write_simulation(sim: Simulation, out: Path, meshes: MeshMode = "keep", given: str | None = None) -> list[Path]:
    """Write measurements.csv, truth.urdf and truth.json into ``out`` (with ``meshes`` ``copy``, the meshes into
    ``out/truth_meshes/``: :mod:`pincal.io.mesh_files`), and truth.corrections.json when the truth has joint
    corrections; returns the paths of the first three. ``truth.urdf`` (its ``<pincal_provenance>`` element) and
    the corrections file record the robot (``given``: as the user named it) and the simulation's arguments.

    ``truth.urdf`` is the true robot written as a calibrated URDF (docs/calibrated_urdf.md): its forward
    kinematics at the actuated readings of ``measurements.csv``, in its root frame (the measurement frame
    when ``base.*`` carries errors), reproduces the measurements up to the noise; the sensors of read
    passive joints read ``q + zero`` (its ``<joint_sensor>`` elements, also in ``truth.json``).
    """
    validation.instance("sim", sim, Simulation, "a Simulation (pincal.simulate)")
    validation.path("out", out)
    paths = simulation_outputs(sim.robot, out, meshes)
    plan = _mesh_plan(sim.robot, paths[1], meshes)
    read = read_joints(sim.measurements)
    text, shifts = calibrated_robot_text(sim.robot, source_text(sim.robot), sim.parameters, sim.x_true,
                                         note="the TRUE robot of a pincal simulation (nominal + known errors)",
                                         read_joints=read, markers=declared_markers(sim.measurements))
    truth = {"robot": sim.robot.name, "pincal_version": version(),
             "robot_sha256": sha256(sim.robot.source) if sim.robot.source is not None else None,
             "units": "SI: m, rad", "parameters": sim.parameters.as_dict(sim.x_true),
             "reference_shifts": shifts, "joint_sensor_zeros": joint_sensor_zeros(text)}
    provenance = simulation_provenance(sim, given)
    corrections = corrections_of(sim.robot, sim.parameters, sim.x_true, sim.payload)
    beside: list[tuple[Path, str | bytes]] = []
    named = None
    if corrections is not None:  # the true joint harmonics and compliances, as a calibration writes them
        content = {**corrections_dict(corrections, sim.robot), "provenance": provenance.as_dict(out)}
        beside.append((corrections_path(paths[1]), json_text(content)))
        named = (corrections_path(paths[1]).name, hashlib.sha256(str(beside[0][1]).encode("utf-8")).hexdigest())
    text = with_provenance(text, provenance, out, named)
    texts: list[tuple[Path, str | bytes]] = list(zip(paths, (dataset_text(sim.dataset), plan.text(text),
                                                             json_text(truth)), strict=True))
    return write_texts([*texts, *beside, *plan.files()])[:len(texts)]


def simulation_provenance(sim: Simulation, given: str | None = None) -> Provenance:
    """What a simulation's truth files record: the pincal version, the robot (``given``: as the user named it, else
    its name) and its URDF's SHA-256, no data (the simulation made them), and the simulation's arguments."""
    options = json.loads(sim.dataset.metadata.get("simulate", "{}"))
    return Provenance(robot_source(given or sim.robot.name, sim.robot), [], options, version())
