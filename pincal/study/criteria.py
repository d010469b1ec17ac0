"""The criteria by which postures are chosen (:func:`pincal.study.pose_selection.select_poses`), in a module light
enough for a command-line parser to read: ``condition`` minimises the condition number κ of the scaled identification
Jacobian; ``d-optimal`` maximises ``log det(JᵀJ)``."""

from __future__ import annotations

CRITERIA = ("condition", "d-optimal")
