"""Files in and out: datasets, safe writes, dataset adapters, calibrated URDF text, report files as text.

The names below load on first use (:mod:`pincal.lazy`).
"""

from __future__ import annotations

from typing import TYPE_CHECKING

from pincal.lazy import lazy_names

if TYPE_CHECKING:
    from pincal.io.adapters import measurements_for, observations_from
    from pincal.io.calibrated_urdf import calibrated_robot_text, joint_sensor_zeros
    from pincal.io.dataset import Dataset, write_dataset
    from pincal.io.dataset_reader import read_dataset
    from pincal.io.files import check_outputs, write_text

_LAZY: dict[str, str] = {
    "measurements_for": ".adapters",
    "observations_from": ".adapters",
    "calibrated_robot_text": ".calibrated_urdf",
    "joint_sensor_zeros": ".calibrated_urdf",
    "Dataset": ".dataset",
    "read_dataset": ".dataset_reader",
    "write_dataset": ".dataset",
    "check_outputs": ".files",
    "write_text": ".files",
}

__all__ = [
    "Dataset",
    "calibrated_robot_text",
    "check_outputs",
    "joint_sensor_zeros",
    "measurements_for",
    "observations_from",
    "read_dataset",
    "write_dataset",
    "write_text",
]

__getattr__, __dir__ = lazy_names(__name__, _LAZY)
