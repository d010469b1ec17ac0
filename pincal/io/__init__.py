"""Files in and out: datasets, safe writes, dataset adapters, calibrated URDF text, report files as text."""

from __future__ import annotations

from pincal.io.adapters import measurements_for, observations_from
from pincal.io.calibrated_urdf import calibrated_robot_text, joint_sensor_zeros
from pincal.io.dataset import Dataset, read_dataset, write_dataset
from pincal.io.files import check_outputs, write_text

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
