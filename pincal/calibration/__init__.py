"""The calibration pipeline: options, preparation, fit, held-out evaluation, cross-validation, simulation, the
typed report and its summary, and calibration from files.

The names below load on first use (as :mod:`pincal`'s do), so that reading the options does not import Pinocchio.
"""

from __future__ import annotations

from typing import TYPE_CHECKING

from pincal.lazy import lazy_names

if TYPE_CHECKING:
    from pincal.calibration.campaign import Simulation, simulate, write_simulation
    from pincal.calibration.crossval import Folds, cross_validate, parse_cv
    from pincal.calibration.from_files import calibrate_files, calibrate_job
    from pincal.calibration.heldout import HeldOut, evaluate_held_out
    from pincal.calibration.options import CalibrationOptions
    from pincal.calibration.pipeline import Calibration, calibrate
    from pincal.calibration.report import CalibrationReport
    from pincal.calibration.samples import read_robot_dataset, usable_part
    from pincal.calibration.setup import Prepared, measurement_models, prepare
    from pincal.calibration.summary import summary_text

#: Public name -> the module that defines it (imported on first access).
_LAZY: dict[str, str] = {
    "CalibrationOptions": "options",
    "prepare": "setup",
    "Prepared": "setup",
    "measurement_models": "setup",
    "read_robot_dataset": "samples",
    "usable_part": "samples",
    "calibrate": "pipeline",
    "Calibration": "pipeline",
    "CalibrationReport": "report",
    "HeldOut": "heldout",
    "evaluate_held_out": "heldout",
    "Folds": "crossval",
    "cross_validate": "crossval",
    "parse_cv": "crossval",
    "simulate": "campaign",
    "Simulation": "campaign",
    "write_simulation": "campaign",
    "calibrate_files": "from_files",
    "calibrate_job": "from_files",
    "summary_text": "summary",
}

__all__ = [
    "Calibration",
    "CalibrationOptions",
    "CalibrationReport",
    "Folds",
    "HeldOut",
    "Prepared",
    "Simulation",
    "calibrate",
    "calibrate_files",
    "calibrate_job",
    "cross_validate",
    "evaluate_held_out",
    "measurement_models",
    "parse_cv",
    "prepare",
    "read_robot_dataset",
    "simulate",
    "summary_text",
    "usable_part",
    "write_simulation",
]


__getattr__, __dir__ = lazy_names(__name__, {name: f".{module}" for name, module in _LAZY.items()})
