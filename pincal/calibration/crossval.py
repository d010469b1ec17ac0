"""K-fold and leave-one-out cross-validation of a whole calibration (selection and robust starts included).
"""

from __future__ import annotations

import re
from collections.abc import Sequence

import numpy as np
import numpy.typing as npt

from pincal.calibration.report_sections import CrossValidation
from pincal.errors import DataError, PincalError, listing
from pincal.identification.corrections import Payload
from pincal.identification.fit_options import FitOptions
from pincal.identification.measurements import Measurement
from pincal.identification.metrics import angle_error_norms, error_norms, length_columns, rms
from pincal.identification.parameters import (
    ParameterSet,
)
from pincal.identification.problem import CalibrationProblem, Observations
from pincal.identification.selection import select_and_fit
from pincal.model.robot import Robot
from pincal.progress import Progress
from pincal.records import record

Array = npt.NDArray[np.float64]

@record(frozen=True)
class Folds:
    """A cross-validation plan: ``k`` folds (``k`` = the sample count for leave-one-out), ``repeats`` shuffles, the
    ``r``-th drawn from a permutation seeded ``seed + r``."""

    k: int
    repeats: int
    leave_one_out: bool = False
    seed: int = 0

    @property
    def label(self) -> str:
        """How the plan reads in a report: ``5-fold × 4`` or ``leave-one-out``."""
        if self.leave_one_out:
            return "leave-one-out"
        label = f"{self.k}-fold" + (f" × {self.repeats}" if self.repeats > 1 else "")
        if self.seed:
            last = self.seed + self.repeats - 1
            label += f", shuffle seed {self.seed}" if last == self.seed else f", shuffle seeds {self.seed}–{last}"
        return label


def parse_cv(text: str, n_samples: int, seed: int = 0) -> Folds:
    """``K``, ``KxR`` (K folds, R shuffles, seeded ``seed``, ``seed + 1``, …) or ``loo`` as a :class:`Folds`, for
    ``n_samples`` usable samples.

    Raises:
        DataError: another text, K < 2, K above the sample count, R outside 1..100, or a negative seed, naming the
            option (``cv``, ``cv_seed``).
    """
    if seed < 0:
        raise DataError(f"cv_seed={seed}: give a whole number ≥ 0", option="cv_seed")
    word = text.strip().lower()
    if word == "loo":
        return Folds(n_samples, 1, leave_one_out=True)
    match = re.fullmatch(r"([0-9]+)(?:x([0-9]+))?", word)
    if match is None:
        raise DataError(f"cv={text!r}: give K (folds), KxR (K folds, R shuffles, e.g. '5x4') or 'loo'", option="cv")
    k, repeats = int(match.group(1)), int(match.group(2) or 1)
    if not 2 <= k <= n_samples or not 1 <= repeats <= 100:
        raise DataError(f"cv={text!r}: K must lie between 2 and the {n_samples} usable samples, R between 1 and 100",
                        option="cv")
    return Folds(k, repeats, seed=seed)


def check_cross_validation(models: Sequence[Measurement], formulation: str, cv: str) -> None:
    """Refuse a cross-validation ``cv`` (its plan) that would not mean what it says (DataError naming why and the
    option ``cv``): of the ``ikm`` formulation (the folds fit by forward kinematics), of incremental data (each
    reading the change since the previous sample, ``distance_increment``: a fold breaks the chain of readings), or of
    data with no position, pose or distance (the figure is a position error)."""
    if formulation != "fkm":
        raise DataError(f"cv={cv!r} cross-validates the fkm formulation; give it without formulation={formulation!r}",
                        option="cv")
    chained = [m.key for m in models if m.incremental]
    if chained:
        raise DataError(f"cv={cv!r} cannot split {listing(chained)}: each reading is the change since the previous "
                        "sample, so a fold would break the chain", option="cv")
    if not any(length_columns(m.key) for m in models):
        raise DataError(f"cv={cv!r} reports the position error of unseen samples, and these data measure no position, "
                        "pose or distance", option="cv")


def cross_validate(robot: Robot, pset: ParameterSet, models: Sequence[Measurement], obs: Observations, folds: Folds,
                   select: str = "bic", *, options: FitOptions | None = None, progress: bool = False,
                   payload: Payload | None = None) -> CrossValidation:
    """K-fold cross-validation of the whole fit (selection and robust starts included): each fold is fitted
    without its samples and predicts them (with the ``payload`` of the compliance terms, if any). ``options`` (default:
    every default) go to :func:`~pincal.identification.selection.select_and_fit`.

    The ``r``-th shuffle is a permutation seeded ``folds.seed + r``: the plan holds the seed (``parse_cv(text,
    n_samples, seed)``; its label in the report names it). The arguments after ``select`` are keyword-only. A fold
    whose fit fails is listed and left out; one whose fit stopped short of convergence is counted. Returns the plan,
    the RMS position error of the predictions [m] (``rms``, pooled over every fold and repeat; None when no fold
    could be fitted), the same per length-type reading when there are several (``rms_by_reading``, e.g. each marker of
    a body) and of the orientation [rad] for poses (``rms_angle``), the predictions' count, the failed fits and the
    unconverged ones.
    """
    n = obs.n_samples
    lengths, angles, failed, unconverged = [], [], [], 0
    by_reading: dict[str, list[Array]] = {m.key: [] for m in models if length_columns(m.key)}
    with Progress(f"cross-validation ({folds.label})", folds.k * folds.repeats, quiet=not progress) as bar:
        for repeat in range(folds.repeats):
            order = (np.arange(n) if folds.leave_one_out
                     else np.random.default_rng(folds.seed + repeat).permutation(n))
            for f in range(folds.k):
                bar.advance()
                test = np.sort(order[f::folds.k])
                train = np.setdiff1d(np.arange(n), test)
                try:
                    fitted = select_and_fit(CalibrationProblem(robot, pset, models, obs.subset(train),
                                                               payload=payload), select, options)
                    held = CalibrationProblem(robot, fitted.problem.parameters, models, obs.subset(test),
                                              payload=payload)
                    errors = held.evaluate(fitted.result.x, jacobian=False).errors
                except PincalError as exc:
                    failed.append(f"repeat {repeat + 1}, fold {f + 1}: {exc}")
                    continue
                unconverged += not fitted.result.converged
                lengths.append(error_norms(errors))
                angles.append(angle_error_norms(errors))
                for key, parts in by_reading.items():
                    parts.append(error_norms(errors, [key]))
    pooled = np.concatenate(lengths) if lengths else np.zeros(0)
    by_key = None
    if len(by_reading) > 1 and pooled.size:
        joined = {key: np.concatenate(parts) for key, parts in by_reading.items()}
        by_key = {key: rms(v) if v.size else None for key, v in joined.items()}
    turned = np.concatenate(angles) if angles else np.zeros(0)
    return CrossValidation(plan=folds.label, n_samples=n, n_predictions=int(pooled.size),
                           rms=rms(pooled) if pooled.size else None, failed_folds=failed,
                           unconverged_folds=int(unconverged), rms_by_reading=by_key,
                           rms_angle=rms(turned) if turned.size else None)
