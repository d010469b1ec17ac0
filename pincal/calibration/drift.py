"""``pincal drift``: has a calibrated robot changed since its calibration? Sessions of new measurements, in time order,
each judged against what the calibration predicts (docs/drift.md).

Per session, on MODEL (a calibrated URDF: its robot as calibrated, the parameters' deviations from it at zero):

1. The measurement setup (measurement frame, markers, cameras, targets: :mod:`pincal.calibration.check_setup`) is
   re-registered on the session by least squares, the robot held: a tracker moved between sessions is no change of the
   robot.
2. The σ-weighted residual r (m rows, σ the session's own where its file states one, else the calibration's per row)
   is compared with its predicted spread
   ``V = I + J_C C J_Cᵀ`` (the noise, and the calibration's covariance C carried by MODEL propagated by the Jacobian of
   its identified robot parameters). With ``V = L Lᵀ``, ``ỹ = L⁻¹ r`` and the setup's columns ``S̃ = L⁻¹ J_S``, the
   statistic ``T = |(I − P_S̃) ỹ|²`` is χ² with ``m − rank S̃`` degrees of freedom when the robot has not changed; the
   session is a change at level α when ``T`` exceeds that χ²'s upper α quantile.
3. A changed session names the parameter groups that moved (a joint's offset; a joint's placement; a loop's anchors),
   by forward selection: of the groups whose columns ``G̃`` added to the model leave ``T_g`` within its own
   threshold, the one of fewest parameters (the simplest explanation the data allow); when none does, the one that
   lowers ``T`` the most for its size (``T_g + k_g ln m``); then, in its place, the smallest group it does not beat
   significantly (``T_h − T_g`` within χ²'s upper ``α / (groups left)`` quantile with ``k_g − k_h`` degrees of
   freedom). A group is kept while ``T`` still exceeds its own threshold and its drop is significant against
   what it leaves: ``((T − T_g) / k_g) / (T_g / (m − rank − k_g))`` beyond F's upper ``α / (groups left)`` quantile
   with (k_g, m − rank − k_g) degrees of freedom, so a session merely noisier than the calibration's σ names no group;
   each group's shift [m, rad] is the generalised least squares estimate with its σ.

Setup parameters never count as a change. SI units throughout: m, rad.
"""

from __future__ import annotations

import math
from collections.abc import Sequence
from dataclasses import asdict, field, replace
from typing import Any

import numpy as np
import numpy.typing as npt

from pincal.calibration.check_setup import file_setup, model_intrinsics, setup_kinds
from pincal.calibration.options import CalibrationOptions
from pincal.calibration.report_sections import Covariance
from pincal.calibration.setup import prepare
from pincal.calibration.setup_parameters import setup_columns
from pincal.errors import DataError
from pincal.identification.chi2 import chi2_upper
from pincal.identification.metrics import error_norms, pixel_error_norms, rms
from pincal.identification.problem import CalibrationProblem
from pincal.identification.solver import identify_with
from pincal.io.dataset import Dataset
from pincal.linalg import svd
from pincal.model.robot import Robot
from pincal.records import record

Array = npt.NDArray[np.float64]

#: Relative cut of the singular values of a design's columns: below it a column adds nothing the others do not.
RANK_CUT = 1e-9


@record(frozen=True)
class GroupShift:
    """A parameter group that moved in a session.

    Attributes:
        group: Its name (``arm_1_joint.offset``, ``arm_1_joint`` for the joint's placement).
        parameters: Its parameters' names.
        shifts: Each one's estimated change since the calibration [m or rad].
        std: Each one's σ [m or rad].
        drop: How much the group lowered the statistic T.
        dof: The degrees of freedom it took (its columns beyond what the model held before).
    """

    group: str
    parameters: list[str]
    shifts: list[float]
    std: list[float]
    drop: float
    dof: int


@record(frozen=True)
class SessionDrift:
    """One session judged against the calibration.

    Attributes:
        source: The session's file.
        n_samples: Its samples used.
        rms: RMS [m] of the samples' length errors, the setup re-registered; of a session of pixels only (``unit``
            ``px``), the RMS reprojection error [px] of its corners.
        expected_rms: The RMS [m or px, as ``rms``] the calibration predicts for these samples (noise and
            covariance), had nothing changed.
        statistic: T (this module's docstring).
        dof: Its degrees of freedom.
        threshold: χ²'s upper ``level`` quantile at ``dof``.
        changed: ``statistic > threshold``.
        moved: The groups named, in the order chosen (empty when nothing changed).
        dropped: The samples left out, with the reason.
        setup: The setup's parameters, re-registered on the session.
        unit: ``m``, or ``px`` for a session of pixels only (a camera's board corners).
    """

    source: str
    n_samples: int
    rms: float
    expected_rms: float
    statistic: float
    dof: int
    threshold: float
    changed: bool
    moved: list[GroupShift]
    dropped: list[dict[str, str]] = field(default_factory=list)
    setup: list[str] = field(default_factory=list)
    unit: str = "m"


@record(frozen=True)
class Drift:
    """Sessions of a calibrated robot judged in time order.

    Attributes:
        level: The test's level α (the chance of a false alarm per session when nothing changed).
        sessions: Each session's judgement.
        groups: The groups named in any session, in the order first named.
        parameters: Their parameters' names: what to recalibrate.
    """

    level: float
    sessions: list[SessionDrift]

    @property
    def groups(self) -> list[str]:
        """The groups named in any session, in the order first named."""
        return list(dict.fromkeys(g.group for s in self.sessions for g in s.moved))

    @property
    def parameters(self) -> list[str]:
        """The parameters of :attr:`groups` (what to recalibrate)."""
        return list(dict.fromkeys(n for s in self.sessions for g in s.moved for n in g.parameters))

    def as_dict(self) -> dict[str, Any]:
        """As JSON values (SI: m, rad)."""
        return {"units": "SI: m, rad", "level": self.level, "sessions": [asdict(s) for s in self.sessions],
                "groups": self.groups, "parameters": self.parameters}


def group_of(name: str) -> str:
    """The group of a robot parameter: a joint offset on its own (``arm_1_joint.offset``), else the placement it
    belongs to (``arm_1_joint.tx`` → ``arm_1_joint``)."""
    return name if name.endswith(".offset") else name.rsplit(".", 1)[0]


def _fit(design: Array, y: Array) -> tuple[float, int, Array, Array]:
    """Least squares of ``y`` on ``design``'s columns (scaled, rank-revealing): residual sum of squares, rank, the
    estimate and its σ (unit variance)."""
    if design.shape[1] == 0:
        return float(y @ y), 0, np.zeros(0), np.zeros(0)
    scale = np.linalg.norm(design, axis=0)
    scale[scale == 0.0] = 1.0
    u, s, vt = svd(design / scale, "a drift design")
    keep = s > RANK_CUT * s[0] if s.size and s[0] > 0 else np.zeros(len(s), dtype=bool)
    u, s, vt = u[:, keep], s[keep], vt[keep]
    estimate = (vt.T @ ((u.T @ y) / s)) / scale
    residual = y - u @ (u.T @ y)
    std = np.sqrt(np.sum((vt.T / s) ** 2, axis=1)) / scale
    return float(residual @ residual), int(keep.sum()), estimate, std


def _covariance_columns(names: Sequence[str], carried: Covariance | None) -> tuple[list[int], Array]:
    """The problem's columns of the calibration's identified robot parameters and their covariance (m², m·rad,
    rad²); none without a carried covariance."""
    if carried is None or not carried.parameters:
        return [], np.zeros((0, 0))
    index = {n: k for k, n in enumerate(names)}
    kept = [(i, index[n]) for i, n in enumerate(carried.parameters)
            if n in index and n.split(".", 1)[0] not in setup_kinds()]
    matrix = np.array([[np.nan if v is None else v for v in row] for row in carried.matrix], dtype=float)
    rows = [i for i, _ in kept]
    sub = matrix[np.ix_(rows, rows)] if rows else np.zeros((0, 0))
    if not np.all(np.isfinite(sub)):
        return [], np.zeros((0, 0))
    return [k for _, k in kept], sub


def judge_session(robot: Robot, dataset: Dataset, source: str, options: CalibrationOptions,
                  covariance: Covariance | None, level: float) -> SessionDrift:
    """One session against the calibrated ``robot`` (this module's docstring).

    Args:
        robot: The calibrated robot (MODEL loaded).
        dataset: The session's measurements.
        source: The session's file, as shown.
        options: The calibration's options (its σ per row, loss, solver).
        covariance: The calibration's covariance ([m², m·rad, rad²]), or None: the noise alone.
        level: The test's level α, 0 < α < 1.
    """
    prepared = prepare(robot, dataset, options, part=None)
    problem = prepared.problem
    parameters = problem.parameters
    names = list(parameters.names)
    setup = setup_columns(parameters)
    x = file_setup(problem, register=True)
    if setup:
        joint_sigma = None if problem.joint_sigma is None else list(problem.joint_sigma)
        reduced = CalibrationProblem(robot, parameters.subset(setup), problem.measurements, problem.observations,
                                     joint_sigma, problem.payload)
        fitted = identify_with(reduced, replace(options.fitting, loss="linear", prior=None), x[setup])
        x[setup] = fitted.x
    prediction = problem.evaluate(x, jacobian=True)
    assert prediction.jacobian is not None
    finite = np.isfinite(prediction.residual)
    r, jacobian = prediction.residual[finite], prediction.jacobian[finite]
    m = len(r)
    columns, matrix = _covariance_columns(names, covariance)
    spread = np.eye(m)
    if columns:
        jc = jacobian[:, columns]
        spread += jc @ matrix @ jc.T
    factor = np.linalg.cholesky(spread)
    y = np.linalg.solve(factor, r)
    whitened = np.linalg.solve(factor, jacobian)
    statistic, rank, _, _ = _fit(whitened[:, setup], y)
    dof = m - rank
    threshold = float(chi2_upper(level, dof))
    changed = statistic > threshold
    moved: list[GroupShift] = []
    if changed:
        moved = _named_groups(names, setup, whitened, y, statistic, rank, level)
    pixels = not any(m.length_rows for m in problem.measurements)
    if pixels:  # a camera's corners: their reprojection errors [px]
        observed, count = pixel_error_norms(prediction.errors), None
    else:
        observed, count = error_norms(prediction.errors), prepared.samples.n_samples
    expected = _expected_rms(problem, spread, jacobian[:, setup], count)
    return SessionDrift(source, prepared.samples.n_samples, float(rms(observed)), expected, statistic, dof, threshold,
                        bool(changed), moved, list(prepared.dropped), [names[k] for k in setup],
                        "px" if pixels else "m")


def _expected_rms(problem: CalibrationProblem, spread: Array, setup_jacobian: Array, n_samples: int | None) -> float:
    """The RMS [m] of the samples' length errors the calibration predicts, the setup registered by least squares:
    √(Σ σ_i² K_ii / N) over the length rows i, ``K = (I − H) V (I − H)ᵀ`` with ``H`` the projection on the setup's
    σ-weighted columns (the joint readings' own noise left out); with ``n_samples`` None, of a session of pixels,
    the RMS [px] of its corners' reprojection errors: over the pixel rows, N the corners seen."""
    sigmas, lengths = [], []
    corners = 0
    for m in problem.measurements:
        seen = int(np.sum(problem.seen(m.key)))
        sigmas.append(np.tile(m.row_sigmas(), seen))
        if n_samples is None:
            pixel = m.row_units()[:2] == ["px", "px"]
            corners += seen if pixel else 0
            lengths.append(np.full(m.size * seen, pixel))
        else:
            lengths.append(np.tile(np.arange(m.size) < m.length_rows, seen))
    sigma, length = np.concatenate(sigmas), np.concatenate(lengths)
    n_samples = corners if n_samples is None else n_samples
    if len(sigma) != len(spread) or not n_samples or not length.any():
        return math.nan
    u = np.zeros((len(spread), 0))
    if setup_jacobian.shape[1]:
        u, s, _ = svd(setup_jacobian, "the setup's Jacobian")
        u = u[:, s > RANK_CUT * s[0]] if s.size and s[0] > 0 else u[:, :0]
    residual = spread - u @ (u.T @ spread)
    kept = residual - (residual @ u) @ u.T
    return float(np.sqrt(np.sum((sigma**2 * np.diag(kept))[length]) / n_samples))


def _named_groups(names: Sequence[str], setup: Sequence[int], whitened: Array, y: Array, statistic: float,
                  rank: int, level: float) -> list[GroupShift]:
    """Forward selection of the groups that moved (this module's docstring)."""
    m = len(y)
    groups: dict[str, list[int]] = {}
    for k, name in enumerate(names):
        if k not in setup:
            groups.setdefault(group_of(name), []).append(k)
    held = list(setup)
    chosen: list[tuple[str, float, int]] = []
    while groups and statistic > float(chi2_upper(level, m - rank)):
        tried = []
        for group, cols in groups.items():
            t, r, _, _ = _fit(whitened[:, held + cols], y)
            if r > rank:
                tried.append((group, t, r - rank))
        if not tried:
            break
        # the simplest group that leaves the session within the predicted spread, else the best for its size; then a
        # smaller group the chosen one does not beat significantly (a likelihood ratio at α / groups left)
        enough = [g for g in tried if g[1] <= float(chi2_upper(level, m - rank - g[2]))]
        group, t, k = (min(enough, key=lambda g: (g[2], g[1])) if enough
                       else min(tried, key=lambda g: g[1] + g[2] * math.log(m)))
        simpler = [g for g in tried if g[2] < k and g[1] - t <= float(chi2_upper(level / len(groups), k - g[2]))]
        if simpler:
            group, t, k = min(simpler, key=lambda g: (g[2], g[1]))
        if not _significant(statistic - t, k, t, m - rank - k, level / len(groups)):
            break
        chosen.append((group, statistic - t, k))
        held += groups.pop(group)
        statistic, rank = t, rank + k
    _, _, estimate, std = _fit(whitened[:, held], y)
    position = {c: i for i, c in enumerate(held)}
    out = []
    for group, drop, k in chosen:
        cols = [c for c, n in enumerate(names) if c not in setup and group_of(n) == group]
        # the estimate cancels the residual (predicted − measured): the robot moved by its opposite
        out.append(GroupShift(group, [names[c] for c in cols], [-float(estimate[position[c]]) for c in cols],
                              [float(std[position[c]]) for c in cols], float(drop), int(k)))
    return out


def _significant(drop: float, k: int, remaining: float, dof: int, tail: float) -> bool:
    """Whether a group's drop ``T − T_g`` (k parameters) is beyond the noise at ``tail``, the residual's scale
    estimated from what the group leaves (``T_g`` over its ``dof``): F's upper ``tail`` quantile with (k, dof) degrees
    of freedom. A session noisier than the calibration's σ inflates every drop by the same factor as ``T_g``, so noise
    alone names no group (a χ² test of the drop at the assumed σ would)."""
    if dof <= 0 or remaining <= 0.0:  # the group leaves nothing to scale by: it explains every row
        return drop > 0.0
    from scipy.special import fdtri  # the F quantile; only a changed session with a candidate group comes here

    return bool((drop / k) / (remaining / dof) > float(fdtri(k, dof, 1.0 - tail)))


def recalibration_command(model: str, session: str, parameters: Sequence[str], setup: Sequence[str]) -> str:
    """The ``pincal calibrate`` command that recalibrates ``parameters`` from MODEL on ``session``'s data, the setup
    (``setup``: its parameters' names, given as one quoted pattern per kind, ``'base.*'``) estimated with them."""
    stem = model.rsplit(".", 1)[0]
    patterns = [f"'{kind}.*'" for kind in dict.fromkeys(name.split(".", 1)[0] for name in setup)]
    return (f"pincal calibrate {model} {session} --parameters {' '.join([*parameters, *patterns])} "
            f"--out {stem}_recalibrated.urdf")


def statistic_text(statistic: float) -> str:
    """A session's test statistic T [dimensionless] as the command and the page print it: one decimal below 1000,
    two significant digits above, enough to say how far beyond its threshold it lies (a changed session's T of
    thousands varies in its third digit with the BLAS build, through the calibration it is judged against: 5164, 5167
    and 5168 on three OpenBLAS kernels)."""
    if not math.isfinite(statistic) or abs(statistic) < 1000.0:
        return f"{statistic:.1f}"
    return f"{round(statistic, 1 - math.floor(math.log10(abs(statistic)))):.0f}"


def shift_text(shift: float, std: float) -> str:
    """A named parameter's shift and its σ [m or rad] as the command and the page print them: ``+1.996 ± 0.028`` [mm
    or mrad], to the micrometre or microradian (the fourth decimal varies with the BLAS build)."""
    return f"{shift * 1e3:+.3f} ± {std * 1e3:.3f}"


def check_level(level: float) -> None:
    """Refuse a level outside (0, 0.5).

    Raises:
        DataError: naming it.
    """
    if not 0.0 < level < 0.5:
        raise DataError(f"level={level:g}: the chance of a false alarm per session must lie between 0 and 0.5 "
                        "(e.g. 0.01)", option="level")


def _session_warnings(sessions: Sequence[str], calibrated_from: str | None) -> list[str]:
    """Warnings of sessions whose verdict cannot be trusted: the calibration's own data (``calibrated_from``, its
    SHA-256), whose residuals were fitted rather than predicted, and a file given twice."""
    from pincal.calibration.provenance import file_digests

    digests, seen, warnings = file_digests(*sessions), dict[str, str](), list[str]()
    for path in sessions:
        digest = digests.get(str(path))
        if digest is None:
            continue
        if digest == calibrated_from:
            warnings.append(f"session '{path}' is the data MODEL was calibrated from: its residuals were fitted, not "
                            "predicted, and the test holds for new measurements only")
        if digest in seen:
            again = "given twice" if seen[digest] == path else f"the same file as '{seen[digest]}'"
            warnings.append(f"session '{path}' is {again}: judged twice")
        seen.setdefault(digest, path)
    return warnings


def run_drift(model_path: str, sessions: Sequence[str], level: float = 0.01,
              nominal_path: str | None = None) -> tuple[Drift, dict[str, Any]]:
    """``pincal drift`` from files: MODEL (a calibrated URDF that carries its calibration), the sessions (CSV or job
    files) in time order; returns the judgement and the report's content.

    Raises:
        DataError: a level outside (0, 0.5); MODEL not a calibrated URDF of pincal, or recording no nominal robot;
            a session of other measurements than the calibration's, or of pixels.
    """
    from pathlib import Path

    from pincal.calibration.carried import read_carried
    from pincal.calibration.job import read_job
    from pincal.calibration.job_data import job_dataset
    from pincal.calibration.provenance import file_digests, read_provenance, version
    from pincal.calibration.samples import read_robot_dataset
    from pincal.model.robot import load_robot

    check_level(level)
    if Path(model_path).suffix.lower() != ".urdf" or not Path(model_path).is_file():
        raise DataError(f"MODEL '{model_path}' is not a calibrated URDF file ('pincal calibrate --out CAL.urdf')")
    calibration = read_carried(model_path)
    nominal_name = nominal_path or read_provenance(model_path).robot
    if calibration is None or nominal_name is None:
        raise DataError(f"MODEL '{model_path}' carries no pincal calibration (its <pincal_calibration> element): drift "
                        "judges sessions against a calibration's predicted spread; give the URDF 'pincal calibrate "
                        "--out' wrote")
    nominal, model = load_robot(nominal_name), load_robot(model_path)
    judged = []
    for path in sessions:
        job = read_job(path) if path.endswith(".toml") else None
        dataset = job_dataset(job, nominal) if job is not None else read_robot_dataset(path, nominal)
        keys = list(dataset.measurements)
        dataset = model_intrinsics(calibration.cameras, dataset, register=False)  # the camera as calibrated
        if sorted(keys) != sorted(calibration.measurements):
            raise DataError(f"session '{path}' measures {', '.join(keys)}; the calibration measured "
                            f"{', '.join(calibration.measurements)}: drift compares the same measurements")
        # the session's own σ where it states one (another instrument), else the calibration's
        stated = any(key.startswith("sigma ") for key in dataset.metadata)
        rows = {tuple(calibration.row_sigma.get(key, [])) for key in keys}
        # one σ per row of every model alike (a camera's corners, each u, v): the option's form, given once
        sigma = None if stated else (next(iter(rows)) if len(rows) == 1 else
                                     tuple(v for key in keys for v in calibration.row_sigma.get(key, [])))
        options = CalibrationOptions(sigma=sigma or None, markers=calibration.markers)  # type: ignore[arg-type]
        judged.append(judge_session(model, dataset, path, options, calibration.covariance, level))
    drift = Drift(level, judged)
    command = None
    if drift.parameters:
        command = recalibration_command(model_path, sessions[-1], drift.parameters, judged[-1].setup)
    elif any(s.changed for s in judged):  # a change no group explains alone: the whole calibration again
        stem = model_path.rsplit(".", 1)[0]
        command = f"pincal calibrate {nominal_name} {sessions[-1]} --out {stem}_recalibrated.urdf"
    content = {"model": model_path, "nominal": nominal_name, **drift.as_dict(), "command": command,
               "warnings": _session_warnings(sessions, read_provenance(model_path).data_sha256),
               "provenance": {"pincal_version": version(), "options": {"level": level},
                              "sha256": file_digests(model_path, *sessions)}}
    return drift, content
