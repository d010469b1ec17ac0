"""The one preparation of a calibration: robot, dataset and options → measurement models → parameters → usable
samples → observations → problem.

Every consumer builds its problem here — :func:`~pincal.calibration.calibrate`, the held-out evaluation, ``view`` and
``report`` from a result JSON, cross-validation, ``design`` and the Monte Carlo trial — so that "which samples",
"which parameters" and "which models" mean the same in each. SI units: m, rad.
"""

from __future__ import annotations

import sys
from collections.abc import Collection, Sequence
from dataclasses import dataclass, replace

import numpy as np
import numpy.typing as npt

from pincal.calibration.options import CalibrationOptions
from pincal.calibration.samples import usable_part
from pincal.errors import DataError
from pincal.identification.choices import MarkerFit
from pincal.identification.corrections import Payload
from pincal.identification.measurements import Measurement, parse_key
from pincal.identification.parameters import ParameterSet, choose_parameters
from pincal.identification.problem import CalibrationProblem
from pincal.io.adapters import joints_at_reference, measurements_for, observations_from
from pincal.io.dataset import Dataset
from pincal.model.measured_frame import frame_moves
from pincal.model.robot import Robot

Array = npt.NDArray[np.float64]


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
        actuated = [joint for joint in model.read_joints if joint in robot.actuated_joints]
        if actuated:
            raise DataError(f"measurement '{key}' reads actuated joint '{actuated[0]}', whose reading is every "
                            "sample's input; joint: measurements are for instrumented passive joints")
        out.append(model)
    if named and any(":" not in kind for kind in kinds) and not frame_moves(robot, frame):
        print(f"pincal: warning: the actuated joints of '{robot.name}' do not move frame '{frame}': its measurements "
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
    if not any(p.kind == "compliance" for p in parameters):
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


@dataclass(frozen=True)
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
    """

    robot: Robot
    models: list[Measurement]
    parameters: ParameterSet
    samples: Dataset
    dropped: list[dict[str, str]]
    problem: CalibrationProblem
    joints_at_reference: list[str]
    payload: Payload | None = None

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


def prepare(robot: Robot, dataset: Dataset, options: CalibrationOptions, part: str | None = "train",
            leave_out: Collection[str] = ()) -> Prepared:
    """The calibration problem of ``dataset``'s samples of set ``part`` (None: every sample) under ``options``.

    The parameters are those ``options`` choose (``parameter_spec``, ``markers``) less those named in ``leave_out``
    (e.g. those model selection left out of a fit). Samples that cannot be used (no reading, a reading outside the
    joint limits, a posture the nominal robot cannot assemble) are left out and listed in :attr:`Prepared.dropped`.

    Raises:
        DataError: the data measure nothing; an actuated joint that moves a measured frame has no column; a payload
            with no compliance parameter; none of the part's samples can be used.
    """
    check_movable(robot)
    models = dataset_models(robot, dataset, options)
    at_reference = joints_at_reference(robot, dataset.joint_names, models)
    pset = parameters_for(robot, models, options.parameter_spec, options.markers, options.payload, leave_out)
    samples = dataset if part is None else dataset.of_set(part)
    what = {"train": "training ", "test": "held-out "}.get(part or "", "")
    return _prepared(robot, samples, models, pset, options.payload, at_reference, what)


def _prepared(robot: Robot, part: Dataset, models: list[Measurement], pset: ParameterSet, payload: Payload | None,
              at_reference: list[str], what: str, allow_empty: bool = False) -> Prepared:
    samples, dropped = usable_part(robot, part)
    if samples.n_samples == 0 and not allow_empty:
        raise DataError(f"none of the {len(dropped)} {what}samples can be used: "
                        f"{dropped[0]['reason'] if dropped else 'no data'}")
    obs = observations_from(robot, samples.joint_names, samples.joints, samples.measurements, models)
    problem = CalibrationProblem(robot, pset, models, obs, payload=payload)
    return Prepared(robot, models, pset, samples, dropped, problem, at_reference, payload)
