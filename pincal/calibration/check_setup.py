"""The measurement setup of ``pincal check``: what a day's measurements may have moved without touching the robot.

The setup is the measurement frame (``base.*``), the markers, the cameras and their targets, the planes a frame
touches, and the intrinsics of the cameras that read pixels (the nominal robot's registered on the data as calibrate's
"before" fits them; MODEL's held at the values its calibration carries, :func:`model_intrinsics`). A check prepares
each robot with these as its only parameters (:func:`prepare_setup`); the model's values are those its calibrated URDF
holds (:func:`file_setup`, docs/calibrated_urdf.md), [m, rad].
"""

from __future__ import annotations

import numpy as np
import numpy.typing as npt
import pinocchio as pin

from pincal.calibration.options import CalibrationOptions
from pincal.calibration.report_sections import CameraRecord
from pincal.calibration.setup import Prepared, dataset_models, parameters_for, prepare
from pincal.errors import DataError
from pincal.identification.measurements import parse_key, split_target
from pincal.identification.measurements.pixels import INTRINSICS, Pixel, declared_intrinsics, intrinsics_name
from pincal.identification.parameters import ParameterSet, kinds_where, parameter_kind, setup_phrase
from pincal.identification.problem import CalibrationProblem
from pincal.identification.starts import set_placement
from pincal.io.calibrated_urdf import attached_link, marker_link
from pincal.io.dataset import Dataset
from pincal.model.robot import Robot

Array = npt.NDArray[np.float64]



def setup_kinds() -> tuple[str, ...]:
    """The parameter kinds of the measurement setup, what a day's measurements may have moved, not the robot: those
    acting in the measurement models (``base``, ``marker``, ``cluster``, ``camera``, ``target``, ``plane``,
    ``intrinsics``, and a plugin's)."""
    return kinds_where(setup=True)


def model_means(parameters: ParameterSet, registered: bool) -> str:
    """What MODEL's side of a check is, in words: its setup (``parameters``, named by their kinds'
    :attr:`~pincal.identification.parameters.ParameterKind.setup_words`) as the file holds it, or re-estimated
    on DATA (``registered``)."""
    setup = setup_phrase(p.kind for p in parameters)
    if registered:
        return (f"MODEL's robot with its measurement setup ({setup}) re-estimated on DATA by least squares, its "
                "geometry held")
    return f"MODEL as it stands: the {setup} the file holds; nothing estimated"


def nominal_means(parameters: ParameterSet) -> str:
    """What the nominal side of a check is when its setup (``parameters``) is registered on DATA, in words."""
    return (f"the nominal robot with its measurement setup ({setup_phrase(p.kind for p in parameters)}) registered "
            "on DATA by least squares from its placement in closed form")


def check_exceeds_setup(side: str | None, problem: CalibrationProblem, estimated: int) -> None:
    """Refuse a registration that fits DATA exactly: ``side`` (``MODEL``, ``the nominal robot``) had ``estimated`` of
    its setup's parameters re-estimated on DATA's readings (``problem``'s residual rows), and no more readings than
    those leaves the errors zero whatever the robot: the comparison would say nothing of MODEL. ``side`` None: a
    probe (the plausibility's registration), never refused.

    Raises:
        DataError: the readings are no more than the setup parameters estimated on them.
    """
    rows = int(problem.row_samples().size)
    if side is not None and estimated and rows <= estimated:
        raise DataError(f"DATA's {rows} readings are no more than the {estimated} parameters of {side}'s measurement "
                        f"setup ({setup_phrase(p.kind for p in problem.parameters)}) registered on them: the "
                        "registration fits DATA exactly, and the errors say nothing of MODEL; check on more samples"
                        + (", or without --register (MODEL's setup as its file holds it)" if side == "MODEL" else ""))


NOMINAL_AS_CALIBRATED = ("the nominal robot with the measurement setup the calibration registered for it on its own "
                         "data (calibrate's 'before', recorded in MODEL), as it stands, as MODEL is")


def prepare_setup(robot: Robot, dataset: Dataset, options: CalibrationOptions) -> Prepared:
    """Every usable sample of ``dataset`` prepared for ``robot`` with the measurement setup as the parameters (the
    default set's ``base``, ``marker``, ``camera``, ``target`` and ``plane`` parameters, each declared marker on its
    own)."""
    models = dataset_models(robot, dataset, options)
    others = [p.name for p in parameters_for(robot, models, None, "each") if p.kind not in setup_kinds()]
    return prepare(robot, dataset, options, part=None, leave_out=others)


def file_setup(problem: CalibrationProblem, register: bool) -> Array:
    """The setup as a calibrated robot's file holds it, as values [m, rad] of ``problem``'s setup parameters: each
    marker's point is its ``<frame>_marker`` link (less its declared nominal offset), each camera, target and contact
    plane its link (``contact_plane`` in the world, ``<support>_plane`` on a support; docs/calibrated_urdf.md); the
    measurement frame is the file's root (zero). A marker without a link is at its nominal offset.

    Raises:
        DataError: a camera, target or plane without its link, unless ``register`` (which places it on the data).
    """
    robot, parameters = problem.robot, problem.parameters
    q = robot.q_reference
    x = np.zeros(len(parameters))
    declared = {t: nominal for m in problem.measurements for t, nominal in m.markers.items()}

    def relative(frame: str, link: str) -> pin.SE3 | None:
        if not robot.model.existFrame(link):
            return None
        placement = robot.placement(q, link)
        return robot.placement(q, frame).inverse() * placement if frame else placement

    for (_, owner, _), idx in parameters.groups("marker").items():
        found = relative(split_target(owner)[0], marker_link(owner))
        if found is not None:
            point = found.translation - np.asarray(declared.get(owner) or (0.0, 0.0, 0.0))
            for k in idx:
                x[k] = point[parameters.parameters[k].component]
    for (kind, owner, _), idx in parameters.groups(*kinds_where(attached=True)).items():
        link = attached_link(kind, owner)
        found = relative(split_target(owner)[0] if owner else "", link)
        if found is not None:
            set_placement(problem, x, idx, found)
        elif not register:
            readings, placed = parameter_kind(kind).check_words
            raise DataError(f"MODEL has no link '{link}' (where a calibrated URDF holds its {kind}): without it the "
                            f"model cannot predict the {readings} readings as it stands; check with register=True, "
                            f"which places the {placed} on DATA", option="register")
    return x


def pixel_cameras(dataset: Dataset) -> list[str]:
    """The cameras whose pixels ``dataset`` holds, by owner (a frame; empty: the fixed camera), in column order."""
    owners: list[str] = []
    for key in dataset.measurements:
        model = parse_key(key)
        if isinstance(model, Pixel) and model.camera not in owners:
            owners.append(model.camera)
    return owners


def model_intrinsics(cameras: dict[str, CameraRecord] | None, dataset: Dataset, register: bool) -> Dataset:
    """``dataset`` with each pixel camera's intrinsics held at the values MODEL's calibration carries (``cameras``,
    the report's ``cameras``: fx, fy, cx, cy [px], k1, k2, p1, p2, k3 [1]), the way MODEL predicts pixels. A camera
    MODEL carries none of keeps the intrinsics DATA hold (``# intrinsics <frame> held: …``), or, with ``register``,
    is estimated on DATA with the rest of MODEL's setup.

    Raises:
        DataError: a camera whose intrinsics neither MODEL nor DATA hold, without ``register``.
    """
    metadata = dict(dataset.metadata)
    for owner in pixel_cameras(dataset):
        carried = (cameras or {}).get(intrinsics_name(owner))
        values = carried.intrinsics if carried is not None else None
        if isinstance(values, dict) and all(isinstance(values.get(c), int | float) for c in INTRINSICS):
            name = f"intrinsics {owner}".strip()
            metadata.pop(name, None)
            metadata[f"{name} held"] = " ".join(repr(float(values[c])) for c in INTRINSICS)
        elif not declared_intrinsics(metadata, owner)[1] and not register:
            camera = f"the camera on '{owner}'" if owner else "the fixed camera"
            raise DataError(f"MODEL carries no intrinsics of {camera} (a calibrated URDF or report of pincal "
                            "calibrate on pixels does): give DATA the camera's intrinsics held (detect "
                            "--camera-file), or check with register=True, which estimates them on DATA",
                            option="register")
    return Dataset(dataset.joint_names, dataset.joints, dataset.measurements, dataset.sample_ids, dataset.sets,
                   metadata)
