"""Files in and out: datasets, job files, safe writes, dataset adapters, calibrated URDF text, reports as data."""

from __future__ import annotations

from pincal.io.adapters import measurements_for, observations_from
from pincal.io.calibrated_urdf import calibrated_robot_text, joint_sensor_zeros
from pincal.io.dataset import Dataset, read_dataset, write_dataset
from pincal.io.files import check_outputs, write_text
from pincal.io.job import Job, read_job
from pincal.io.job_data import job_dataset
from pincal.io.report_data import report_dict

__all__ = [
    "Dataset",
    "Job",
    "calibrated_robot_text",
    "check_outputs",
    "job_dataset",
    "joint_sensor_zeros",
    "measurements_for",
    "observations_from",
    "read_dataset",
    "read_job",
    "report_dict",
    "write_dataset",
    "write_text",
]
