"""The measurement noise of data that state none: estimated from the data before model selection.

Data without ``# sigma`` lines (and no ``--sigma``) say nothing of the instrument, and the model's default σ
(1e-5 m) says nothing of it either. So :func:`estimate_noise` fits every identifiable parameter once (a provisional fit)
and takes the a-posteriori RMS of each reading's residuals, corrected for the degrees of freedom the fit used
(``σ̂² = Σ w_k e_k² / Σ w_k · m / (m − p)``: ``e_k`` the errors of sample k's rows, ``w_k`` its robust weight, m rows,
p identified parameters), per measurement key and per kind of row (lengths [m], angles [rad]). The σ of a row kind
is never taken below the model's default (1e-5 m, rad): data that fit more closely than that are near exact, and the
default keeps their fit going to the numerical floor. The estimates then weight the calibration as ``# sigma`` lines
would (:func:`with_noise`); the report's ``estimated_sigma`` and the summary say so.
"""

from __future__ import annotations

from dataclasses import replace
from typing import Any

import numpy as np
import numpy.typing as npt

from pincal.calibration.options import CalibrationOptions
from pincal.errors import PincalError
from pincal.identification.measurements import Measurement
from pincal.identification.problem import CalibrationProblem
from pincal.identification.result import CalibrationResult
from pincal.identification.solver import identify
from pincal.io.adapters import channel_sigma
from pincal.io.dataset import Dataset

Array = npt.NDArray[np.float64]


def unstated(models: list[Measurement], metadata: dict[str, str], options: CalibrationOptions) -> dict[str, list[str]]:
    """The row kinds (``length``, ``angle``) of each model whose σ neither ``options`` nor a ``# sigma`` line gives
    (a joint reading's rows count as ``length``: its one σ, in rad or m); a pose's angle rows only with its length
    rows (a stated σ of the pose weights both)."""
    if options.sigma is not None:
        return {}
    out: dict[str, list[str]] = {}
    for m in models:
        if channel_sigma(m.key, metadata, None) is not None:
            continue
        angle = m.angle_rows and options.pose_sigma_angle is None \
            and channel_sigma(m.key, metadata, None, angle=True) is None
        out[m.key] = ["length", "angle"] if angle else ["length"]
    return out


def _rows(m: Measurement, kind: str) -> slice:
    """The residual rows of ``m`` of one kind: its length rows (every row of a model with neither), or its angle
    rows."""
    if kind == "angle":
        return slice(m.length_rows, m.length_rows + m.angle_rows)
    return slice(0, m.length_rows or m.size)


def estimate_noise(problem: CalibrationProblem, result: CalibrationResult,
                   wanted: dict[str, list[str]]) -> dict[str, dict[str, float]]:
    """Per measurement key and row kind in ``wanted``: the σ [m or rad] the residuals of ``result`` (a fit of every
    identifiable parameter of ``problem``) show, dof-corrected and robust-weighted, at least the model's default."""
    rows = int(problem.row_samples().size)
    used = len(result.identified)
    correction = rows / (rows - used) if rows > used else 1.0
    weights = np.asarray(result.sample_weights, dtype=float)
    out: dict[str, dict[str, float]] = {}
    for m in problem.measurements:
        for kind in wanted.get(m.key, []):
            part = _rows(m, kind)
            errors = np.asarray(result.errors_after[m.key], dtype=float)[:, part]
            seen = np.all(np.isfinite(errors), axis=1)
            if not seen.any():
                continue
            squares = float(np.sum(weights[seen, None] * errors[seen] ** 2))
            count = float(np.sum(weights[seen])) * errors.shape[1]
            sigma = float(np.sqrt(correction * squares / max(count, 1e-300)))
            floor = float(np.min(m.uniform_row_sigmas()[part]))
            out.setdefault(m.key, {})[kind] = max(sigma, floor)
    return out


def with_noise(dataset: Dataset, estimates: dict[str, dict[str, float]]) -> Dataset:
    """``dataset`` with ``# sigma`` lines stating ``estimates`` (an angle σ per measurement kind: the largest of its
    keys')."""
    metadata = dict(dataset.metadata)
    for key, kinds in estimates.items():
        kind, _, name = key.partition(":")
        if "length" in kinds:
            metadata[f"sigma {kind} {name}"] = repr(kinds["length"])
        if "angle" in kinds:
            line = f"sigma {kind} angle"
            metadata[line] = repr(max(kinds["angle"], float(metadata.get(line, 0.0))))
    return replace(dataset, metadata=metadata)


def provisional_noise(problem: CalibrationProblem, metadata: dict[str, str], options: CalibrationOptions,
                      **fitting: Any) -> dict[str, dict[str, float]]:
    """The noise of the readings whose σ is stated nowhere (:func:`unstated`), from a provisional fit of every
    identifiable parameter (``fitting``: :func:`~pincal.identification.solver.identify`'s options); empty when every
    σ is stated or the provisional fit fails (the defaults then stay)."""
    wanted = unstated(list(problem.measurements), metadata, options)
    if not wanted:
        return {}
    try:
        result = identify(problem, **fitting)
    except PincalError:
        return {}
    return estimate_noise(problem, result, wanted)
