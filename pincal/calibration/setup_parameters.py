"""The measurement setup's parameters: those of no selection group (measurement frame, markers, cameras, targets,
planes, device constants), which "before" fits with the robot at nominal
(:func:`~pincal.calibration.heldout.register_setup`), and which the report, the predicted bound's growth and drift read
the same way."""

from __future__ import annotations

from pincal.identification.parameters import ParameterSet


def setup_columns(parameters: ParameterSet) -> list[int]:
    """The setup's parameters (their indices in ``parameters``): those of no selection group (measurement frame,
    markers, cameras, targets, planes, device constants), which "before" fits with the robot at nominal."""
    return [k for k, p in enumerate(parameters) if p.kind_class.selection_group(p) is None]
