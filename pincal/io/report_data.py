"""Report files as text: the indented JSON pincal writes, and the orientation-error norms its figures use."""

from __future__ import annotations

import json
from pathlib import Path
from typing import Any

import numpy as np
import numpy.typing as npt

from pincal.identification.solver import angle_columns
from pincal.io.files import write_text

Array = npt.NDArray[np.float64]



def angle_error_norms(errors: dict[str, Array]) -> Array:
    """Orientation error angles [rad] of the pose readings (norm of ``log3(R_measᵀ R_pred)``), one per reading taken
    (a reading not taken, NaN, has none)."""
    parts = [np.linalg.norm(err[:, angle_columns(key)], axis=1) for key, err in errors.items()
             if angle_columns(key).stop > angle_columns(key).start]
    norms = np.concatenate(parts) if parts else np.zeros(0)
    return np.asarray(norms[~np.isnan(norms)], dtype=np.float64)


def write_json(path: str | Path, content: dict[str, Any]) -> None:
    """Write ``content`` as indented JSON (:func:`json_text`), whole or not at all."""
    write_text(path, json_text(content))


def json_text(content: dict[str, Any]) -> str:
    """``content`` as the indented JSON text of pincal's report files."""
    return json.dumps(content, indent=2, sort_keys=False) + "\n"
