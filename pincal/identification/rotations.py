"""Rotations of many samples at once: moved to :mod:`pincal.model.rotations` (the batched closed-loop kinematics
needs them below the identification layer); re-exported here under their old names."""

from pincal.model.rotations import (
    NEAR_PI,
    SMALL_ANGLE,
    cross_columns,
    jlog3,
    log3,
    quaternion_matrices,
    rotate,
    skew,
)

__all__ = ["NEAR_PI", "SMALL_ANGLE", "cross_columns", "jlog3", "log3", "quaternion_matrices", "rotate", "skew"]
