"""The one preparation of a calibration: robot, dataset and options → measurement models → parameters → usable
samples → observations → problem.

Every consumer builds its problem here — :func:`~pincal.calibration.calibrate`, the held-out evaluation, ``view`` and
``report`` from a result JSON, cross-validation, ``design`` and the Monte Carlo trial — so that "which samples",
"which parameters" and "which models" mean the same in each. SI units: m, rad.
"""

from __future__ import annotations

import sys
from collections.abc import Collection, Sequence
from dataclasses import field, replace

import numpy as np
import numpy.typing as npt

from pincal import validation
from pincal.calibration.options import CalibrationOptions
from pincal.calibration.samples import check_moving_frames, usable_part
from pincal.errors import DataError
from pincal.identification.choices import MarkerFit
from pincal.identification.corrections import Payload
from pincal.identification.measurements import Measurement, parse_key
from pincal.identification.parameters import Compliance, ParameterSet, choose_parameters
from pincal.identification.predictions import carry_over, remember
from pincal.identification.problem import CalibrationProblem
from pincal.io.adapters import joints_at_reference, measurements_for, observations_from
from pincal.io.dataset import Dataset
from pincal.model.measured_frame import frame_moves
from pincal.model.robot import Robot
from pincal.records import record

Array = npt.NDArray[np.float64]


def measurement_models(robot: Robot, kinds: Sequence[str], frame: str | None, sigma: float,
                       refuse_still: bool = False) -> list[Measurement]:
    """Models from CLI words: ``position``/``pose`` (of ``frame``), or full keys such as
    ``distance:frameA-frameB``, ``distance_increment:a-b``, ``joint:device_lvdt``.

    ``frame`` None measures the robot's default frame (:attr:`~pincal.model.robot.Robot.end_effector`, which
    refuses when none is obvious). A named ``frame`` that the actuated joints do not move (``--frame F``, or in a
    key ``KIND:F``) is measured as asked, with one warning line on stderr: its data can identify nothing but the
    measurement frame; with ``refuse_still``, refused (DataError:
    :func:`~pincal.calibration.samples.check_moving_frames`).
    """
    named, frame = frame is not None, frame or robot.end_effector
    out = []
    for kind in kinds:
        key = kind if ":" in kind else f"{kind}:{frame}"  # a bare kind measures --frame
        model = parse_key(key, sigma)
        model.check(robot)  # NotFoundError naming the frame or joint and the valid ones
        actuated = [joint for joint in model.read_joints if joint in robot.actuated_joints]
        if actuated:
            raise DataError(f"measurement '{key}' reads actuated joint '{actuated[0]}', whose reading is every "
                            "sample's input; joint: measurements are for instrumented passive joints")
        out.append(model)
    if refuse_still:  # a design for frames nothing moves would mean nothing
        check_moving_frames(robot, out)
        return out
    still = [frame] if named and any(":" not in kind for kind in kinds) and not frame_moves(robot, frame) else []
    for kind, model in zip(kinds, out, strict=True):  # KIND:FRAME: the frames it names, when none of them moves
        if ":" in kind and model.frames and not any(frame_moves(robot, f) for f in model.frames):
            still += [f for f in model.frames if f not in still]
    for name in still:
        print(f"pincal: warning: the actuated joints of '{robot.name}' do not move frame '{name}': its measurements "
              "can identify only the measurement frame", file=sys.stderr)
    return out


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
    if not any(p.is_a(Compliance) for p in parameters):
        raise DataError(f"the payload ({payload}) enters only the joint compliances, and no <joint>.compliance is "
                        "among the parameters: add '*.compliance' (--parameters default '*.compliance'), or give no "
                        "payload")


def parameters_for(robot: Robot, models: Sequence[Measurement], spec: Sequence[str] | None = None,
                   markers: MarkerFit = "each", payload: Payload | None = None,
                   leave_out: Collection[str] = ()) -> ParameterSet:
    """The parameters of a calibration of ``robot`` by ``models``: those ``spec`` chooses (a named set or patterns,
    :func:`~pincal.identification.parameters.choose_parameters`; None: the default set) less those named in
    ``leave_out``; refused with a payload that would change nothing (:func:`check_payload`)."""
    pset = choose_parameters(robot, models, spec, markers)
    if leave_out:
        pset = ParameterSet([p for p in pset if p.name not in set(leave_out)])
    check_payload(robot, pset, payload)
    return pset


def check_movable(robot: Robot) -> None:
    """Refuse a robot with no actuated joint: nothing moves, so no posture can be drawn or told apart."""
    if robot.n_actuated == 0:
        raise DataError(f"robot '{robot.name}' has no actuated joint: nothing moves, there is nothing to simulate or "
                        "calibrate")


def dataset_models(robot: Robot, dataset: Dataset, options: CalibrationOptions) -> list[Measurement]:
    """The measurement models of ``dataset``'s columns, weighted by ``options.sigma`` (over the file's ``# sigma``
    lines) and ``options.pose_sigma_angle``.

    Raises:
        DataError: the data measure nothing (no measurement column and no passive joint reading).
    """
    models = measurements_for(robot, list(dataset.measurements), dataset.joint_names, options.sigma, dataset.metadata)
    if options.pose_sigma_angle is not None:
        models = [m.with_angle_sigma(options.pose_sigma_angle) for m in models]
    if not models:
        raise DataError("the data has no measurement columns ('<kind>:<frame>:<component>', e.g. "
                        "position:end_effector:x, see docs/dataset.md) and no passive joint readings: nothing to "
                        "calibrate from")
    return models


#: A parameter whose Jacobian column (over every sample) is below this fraction of the largest moves no measurement:
#: structural zeros sit at 1e-10 or below, the weakest real effects at 1e-3 and above (every robot of the catalog).
NO_EFFECT = 1e-7
#: How far [m, rad] the setup's parameters are moved before judging which parameters move no measurement.
SETUP_PROBE = 0.05


def idle_parameters(problem: CalibrationProblem, x: npt.NDArray[np.float64]) -> npt.NDArray[np.bool_]:
    """Which of ``problem``'s parameters move no measurement of its samples near ``x`` [m, rad]: a Jacobian column
    below :data:`NO_EFFECT` of the largest (placements whose motion a loop or a joint absorbs at the nominal
    geometry). The setup's parameters (measurement frame, markers, cameras, targets) are first moved off ``x`` by
    :data:`SETUP_PROBE`: their start is arbitrary (a marker at its frame's origin would hide the last joint's zero)."""
    setup = np.array([p.kind_class.acts_in == "measurement" for p in problem.parameters])
    probe = np.random.default_rng(0).choice([-1.0, 1.0], size=x.size) * SETUP_PROBE
    jacobian = problem.evaluate(np.where(setup, x + probe, x)).jacobian
    assert jacobian is not None  # asked for
    norms = np.linalg.norm(jacobian, axis=0)
    return np.asarray(norms <= NO_EFFECT * max(float(norms.max(initial=0.0)), np.finfo(float).tiny))


@record(frozen=True)
class Prepared:
    """One part of a dataset made into a calibration problem.

    Attributes:
        robot: The nominal robot.
        models: The measurement models.
        parameters: The parameters (all candidates chosen, or those a fit kept).
        samples: The usable samples of the part, in file order.
        dropped: Each sample of the part that cannot be used: ``{"sample": id, "reason": text}``.
        problem: The problem on ``samples``.
        joints_at_reference: Actuated joints with no column, left at their reference (they move nothing measured).
        payload: The payload of the compliance terms, or None.
        no_effect: Default candidates left out because they move no measurement of these samples.
    """

    robot: Robot
    models: list[Measurement]
    parameters: ParameterSet
    samples: Dataset
    dropped: list[dict[str, str]]
    problem: CalibrationProblem
    joints_at_reference: list[str]
    payload: Payload | None = None
    no_effect: list[str] = field(default_factory=list)

    def on(self, part: Dataset, parameters: ParameterSet | None = None, what: str = "") -> Prepared:
        """The same models and payload on other samples (``part``'s usable ones, ``what`` says which in messages),
        with these or other ``parameters``; none usable gives a problem of no sample.
        """
        return _prepared(self.robot, part, self.models, parameters or self.parameters, self.payload,
                         self.joints_at_reference, what, allow_empty=True)

    def fitted_by(self, problem: CalibrationProblem) -> Prepared:
        """The same samples with the parameters of ``problem`` (the problem a fit solved, e.g. over the parameters
        model selection kept)."""
        return replace(self, parameters=problem.parameters, problem=problem)

    def without_idle(self) -> Prepared:
        """The same problem less the parameters that move no measurement of its samples (a Jacobian column below
        :data:`NO_EFFECT` of the largest, at the start): a candidate set's placements whose motion a loop or a
        joint absorbs, which the data can never estimate."""
        problem = self.problem
        idle = idle_parameters(problem, problem.initial_guess())
        if not idle.any() or idle.all():
            return self
        kept = ParameterSet([p for p, out in zip(self.parameters, idle, strict=True) if not out])
        reduced = CalibrationProblem(self.robot, kept, self.models, problem.observations, payload=self.payload)
        carry_over(problem, reduced)
        return replace(self, parameters=kept, problem=reduced,
                       no_effect=[n for n, out in zip(self.parameters.names, idle, strict=True) if out])


def prepare(robot: Robot, dataset: Dataset, options: CalibrationOptions, part: str | None = "train",
            leave_out: Collection[str] = ()) -> Prepared:
    """The calibration problem of ``dataset``'s samples of set ``part`` (None: every sample) under ``options``.

    The parameters are those ``options`` choose (``parameter_spec``, ``markers``) less those named in ``leave_out``
    (e.g. those model selection left out of a fit); the default set leaves out the candidates that move no
    measurement of these samples (:meth:`Prepared.without_idle`). Samples that cannot be used (no reading, a reading
    outside the joint limits, a posture the nominal robot cannot assemble) are left out and listed in
    :attr:`Prepared.dropped`.

    Raises:
        DataError: the data measure nothing; an actuated joint that moves a measured frame has no column; a payload
            with no compliance parameter; none of the part's samples can be used.
        TypeError: ``robot``, ``dataset`` or ``options`` of the wrong type (named, with the value).
    """
    validation.instance("robot", robot, Robot, "a Robot (pincal.load_robot)")
    validation.instance("dataset", dataset, Dataset, "a Dataset (pincal.read_dataset)")
    validation.instance("options", options, CalibrationOptions, "CalibrationOptions")
    check_movable(robot)
    models = dataset_models(robot, dataset, options)
    at_reference = joints_at_reference(robot, dataset.joint_names, models)
    pset = parameters_for(robot, models, options.parameter_spec, options.markers, options.payload, leave_out)
    samples = dataset if part is None else dataset.of_set(part)
    what = {"train": "training ", "test": "held-out "}.get(part or "", "")
    prepared = _prepared(robot, samples, models, pset, options.payload, at_reference, what)
    # the default set holds no candidate the data can never see; parameters the user names stay, to be reported
    return prepared.without_idle() if not options.parameter_spec else prepared


def _prepared(robot: Robot, part: Dataset, models: list[Measurement], pset: ParameterSet, payload: Payload | None,
              at_reference: list[str], what: str, allow_empty: bool = False) -> Prepared:
    samples, dropped, closed = usable_part(robot, part)
    if samples.n_samples == 0 and not allow_empty:
        raise DataError(f"none of the {len(dropped)} {what}samples can be used: "
                        f"{dropped[0]['reason'] if dropped else 'no data'}")
    obs = observations_from(robot, samples.joint_names, samples.joints, samples.measurements, models)
    problem = CalibrationProblem(robot, pset, models, obs, payload=payload)
    remember(problem, closed)  # the usability check's configurations start the first solves
    return Prepared(robot, models, pset, samples, dropped, problem, at_reference, payload)
