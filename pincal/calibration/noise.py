"""The measurement noise of data that state none: estimated from the data before model selection.

Data without ``# sigma`` lines (and no ``--sigma``) say nothing of the instrument, and the model's default σ
(1e-5 m) says nothing of it either; nor is an instrument's noise the same on every axis (a camera sees depth far worse
than across its image, a tracker's axes differ). So :func:`estimate_noise` fits every identifiable parameter once (a
provisional fit) and estimates one variance per measurement key and residual row (its axis: ``x``, ``y``, ``z`` of a
position, the six rows of a pose, a plane's distance and tilts) by variance components (Förstner 1979, "Ein Verfahren
zur Schätzung von Varianz- und Kovarianzkomponenten"; Koch 1999, "Parameter estimation and hypothesis testing in linear
models", §3.6): with the fit linearised at its estimate, each group g of rows gets

    σ̂_g² = Σ_{i∈g} w_i e_i² / r_g,    r_g = Σ_{i∈g} (1 − h_ii)

``e_i`` the rows' residuals, ``w_i`` their robust weights, ``r_g`` the group's redundancy (``h_ii`` the leverage of row
i in the weighted fit, with its prior: the degrees of freedom the fit took from the group), iterated with the weights
``1/σ̂_g²`` until they settle (:data:`ITERATIONS`). A row's σ is never taken below the model's default (1e-5 m, rad):
data that fit more closely than that are near exact, and the default keeps their fit going to the numerical floor. The
estimates then weight the calibration as ``# sigma`` lines of one σ per row would (:func:`with_noise`); the report's
``estimated_sigma`` and the summary say so.
"""

from __future__ import annotations

from dataclasses import replace

import numpy as np
import numpy.typing as npt

from pincal.calibration.options import CalibrationOptions
from pincal.calibration.report_sections import EstimatedSigma
from pincal.errors import PincalError
from pincal.identification.measurements import Measurement
from pincal.identification.prior import prior_sigma
from pincal.identification.problem import CalibrationProblem
from pincal.identification.result import CalibrationResult
from pincal.identification.solver import identify_with
from pincal.io.adapters import channel_sigma
from pincal.io.dataset import Dataset

Array = npt.NDArray[np.float64]
IntArray = npt.NDArray[np.intp]


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


#: Rounds of variance-component estimation (each: leverages under the current weights, then the new σ per group).
ITERATIONS = 8


def estimate_noise(problem: CalibrationProblem, result: CalibrationResult, wanted: dict[str, list[str]],
                   prior: Array | None = None) -> dict[str, EstimatedSigma]:
    """Per measurement key whose row kinds ``wanted`` lists: the σ [m or rad] of each of its rows of those kinds, by
    variance components on the residuals of ``result`` (a fit of every identifiable parameter of ``problem``, with the
    prior σ ``prior`` [parameter units; inf or None: none]), robust-weighted, each at least the model's default. Each
    key's entry: ``rows`` (row name -> σ, the rows estimated) and their ``units``, and ``length`` and ``angle`` (the
    RMS of its estimated length and angle rows) as a σ of one per kind."""
    groups = _row_groups(problem, wanted)
    if not groups or result.final is None or result.final.jacobian is None:
        return {}
    factors = _variance_components(problem, result, groups, prior)
    stated = np.concatenate([np.tile(m.row_sigmas(), int(np.count_nonzero(problem.seen(m.key))))
                             for m in problem.measurements])
    rows: dict[str, dict[str, float]] = {}
    units: dict[str, dict[str, str]] = {}
    for (key, row), members in groups.items():
        model = next(m for m in problem.measurements if m.key == key)
        floor = float(model.uniform_row_sigmas()[row])
        sigma = max(float(np.sqrt(factors[(key, row)])) * float(stated[members[0]]), floor)
        rows.setdefault(key, {})[model.row_names()[row]] = sigma
        units.setdefault(key, {})[model.row_names()[row]] = model.row_units()[row]
    out: dict[str, EstimatedSigma] = {}
    for key, estimated in rows.items():  # in the groups' order
        m = next(m for m in problem.measurements if m.key == key)
        kinds: dict[str, float] = {}
        for kind in wanted[key]:
            values = [estimated[name] for name in m.row_names()[_rows(m, kind)] if name in estimated]
            if values:
                kinds[kind] = float(np.sqrt(np.mean(np.square(values))))
        out[key] = EstimatedSigma(rows=estimated, units=units[key], length=kinds.get("length"),
                                  angle=kinds.get("angle"))
    return out


def _row_groups(problem: CalibrationProblem, wanted: dict[str, list[str]]) -> dict[tuple[str, int], IntArray]:
    """The residual rows (indices in :meth:`evaluate`'s order) of each (measurement key, row of the model) whose kind
    ``wanted`` lists, with a row seen at least once."""
    out: dict[tuple[str, int], IntArray] = {}
    start = 0
    for m in problem.measurements:
        taken = int(np.count_nonzero(problem.seen(m.key)))
        block = start + m.size * np.arange(taken)
        for kind in wanted.get(m.key, []):
            part = _rows(m, kind)
            for row in range(m.size)[part]:
                if taken:
                    out[(m.key, row)] = (block + row).astype(np.intp)
        start += m.size * taken
    return out


def _variance_components(problem: CalibrationProblem, result: CalibrationResult,
                         groups: dict[tuple[str, int], IntArray], prior: Array | None) -> dict[tuple[str, int], float]:
    """Each group's variance factor (σ² over its current σ²) by :data:`ITERATIONS` rounds of variance-component
    estimation on ``result``'s fit linearised at its estimate (its identified parameters, robust weights, and the prior
    σ ``prior``); the rows of no group keep their factor 1."""
    final = result.final
    assert final is not None and final.jacobian is not None
    columns = list(result.identified)
    scales = problem.parameters.scales[columns]
    jacobian = final.jacobian[:, columns] * scales
    residual = final.residual
    robust = result.sample_weights[problem.row_samples()]
    sigma = np.full(len(columns), np.inf) if prior is None else np.asarray(prior, dtype=float)[columns]
    precision = np.where(np.isfinite(sigma), (scales / np.where(np.isfinite(sigma), sigma, 1.0)) ** 2, 0.0)
    factor = np.ones(residual.size)
    estimates = dict.fromkeys(groups, 1.0)
    for _ in range(ITERATIONS):
        weights = robust / factor
        weighted = jacobian * weights[:, None]
        normal = jacobian.T @ weighted + np.diag(precision)
        inverse = np.linalg.pinv(normal, rcond=1e-12, hermitian=True)
        errors = residual - jacobian @ (inverse @ (weighted.T @ residual))  # the weighted fit's residual, linearised
        leverage = np.einsum("ij,jk,ik->i", weighted, inverse, jacobian)
        for group, rows in groups.items():
            redundancy = float(np.sum(1.0 - leverage[rows]))
            squares = float(np.sum(robust[rows] * errors[rows] ** 2))
            estimates[group] = squares / redundancy if redundancy > 1e-9 else estimates[group]
            factor[rows] = max(estimates[group], 1e-300)
    return estimates


def with_noise(dataset: Dataset, estimates: dict[str, EstimatedSigma], models: list[Measurement]) -> Dataset:
    """``dataset`` with ``# sigma`` lines stating ``estimates`` (:func:`estimate_noise`): one σ per residual row of
    each key estimated, its rows not estimated at the σ ``models`` (the measurement models as prepared) give them."""
    metadata = dict(dataset.metadata)
    for m in models:
        if m.key not in estimates:
            continue
        rows = estimates[m.key].rows
        values = [rows.get(name, float(current)) for name, current in zip(m.row_names(), m.row_sigmas(), strict=True)]
        kind, _, name = m.key.partition(":")
        metadata[f"sigma {kind} {name}"] = "[" + ", ".join(repr(float(v)) for v in values) + "]"
    return replace(dataset, metadata=metadata)


def provisional_noise(problem: CalibrationProblem, metadata: dict[str, str],
                      options: CalibrationOptions) -> dict[str, EstimatedSigma]:
    """The noise of the readings whose σ is stated nowhere (:func:`unstated`), from a provisional fit of every
    identifiable parameter (by ``options``' solver, loss, iterations and prior, the automatic prior as the kinds' σ);
    empty when every σ is stated or the provisional fit fails (the defaults then stay)."""
    wanted = unstated(list(problem.measurements), metadata, options)
    if not wanted:
        return {}
    try:
        result = identify_with(problem, options.fitting)
    except PincalError:
        return {}
    return estimate_noise(problem, result, wanted, prior_sigma(problem.parameters, options.fitting.fixed_prior()))
