"""Study 000 (Delta robot, FKM vs IKM calibration): the paper's cases side by side with pincal.

Run: ``python examples/study_000_delta.py`` (full: about 8 CPU-minutes, spread over 2 processes) or
``--quick`` (seconds, one process).
Prints the tables and the whole results page; the full run writes ``results/000_delta.md`` and two
figures under ``results/figures/`` (``--out DIR`` to write elsewhere, ``--publish`` for ``docs/results``).
``--quick`` writes nothing unless ``--out`` is given.

Settings follow the paper (Section 4): Delta with La = 260 mm, Lb = 480 mm, Rb = 194 mm, Rn = 30 mm;
Model 24 parameters; random configurations in the workspace; initial parameter errors of the stated
size (σ of a normal draw); position measured on the platform (laser tracker) and arm angles read by the
encoders, with the stated noise. Each case is a median over several random draws (seeds). G is Eq. 4.1
over all parameters, in the units the error sizes are read in; "mean per-parameter gain" is the average
of the per-parameter gains, which is how the paper words its noisy cases.

The paper leaves two things open, and the variants try both: which configurations are measured
(random, or chosen D-optimally from random candidates with :func:`pincal.study.pose_selection.select_poses`), and in
which unit its angle errors are stated ("1 mm" read as 1 mm and 1 mrad, or as 1 mm and 1°, the
reading of its Fig. 4 caption: "0.1mm/degrees for lengths/angles").
"""

from __future__ import annotations

import argparse
import inspect
import math
import os
import sys
import time
from collections.abc import Sequence
from dataclasses import dataclass, replace
from pathlib import Path
from typing import Any

import numpy as np
import numpy.typing as npt

import pincal
from pincal.errors import PincalError
from pincal.identification import measurements as ms
from pincal.identification.identifiability import RANK_TOLERANCE, analyse
from pincal.identification.ikm import ImplicitProblem
from pincal.identification.metrics import calibration_gain, error_norms
from pincal.identification.parameters import NAMED_SETS, ParameterSet
from pincal.identification.problem import CalibrationProblem, Observations
from pincal.identification.solver import identify
from pincal.study.pose_selection import jacobian_blocks, select_poses
from pincal.study.simulation import random_actuated, simulate_observations

Array = npt.NDArray[np.float64]
ROOT = Path(__file__).resolve().parents[1]
DEG = math.pi / 180.0
LENGTH_UNIT = 1e-3  # [m]: the paper states its error sizes in mm
#: The angle error [rad] that goes with "1 mm" of stated error, per reading of the paper.
ANGLE_READINGS = {"mrad": 1e-3, "deg": DEG}
TRACKER_SIGMA = 1e-6  # [m]: the weight of a position row when the data are noise-free
N_CANDIDATES = 1000  # random candidates per draw for the D-optimal design
N_TEST = 50  # held-out configurations per draw
N_IDENTIFIABILITY = 60  # configurations per set in the identifiability section
CANDIDATE_STREAM = 1  # seeds of the candidate pools: (draw, 1); of the identifiability sets: (draw, 2)
IDENTIFIABILITY_STREAM = 2
ARM_SPREAD = 1.0  # [rad]: arm angles are drawn within ±1 rad of the reference (within the URDF's [-1.2, 1.6])
METHODS = ("FKM", "IKM")


@dataclass(frozen=True)
class Case:
    """One simulated calibration of the paper.

    Attributes:
        label: The paper's wording of the case.
        n_configs: Calibration configurations.
        error: Stated size of the initial parameter errors: σ [m] of the length errors; the angle errors
            have σ ``error / 1 mm`` times the ``angles`` unit.
        noise: Tracker noise σ [m].
        joint_noise: Encoder noise σ [rad].
        paper_fkm, paper_ikm: The paper's result ("—": not reported).
        design: ``random`` configurations, or ``d-optimal`` ones chosen from ``N_CANDIDATES`` random candidates.
        angles: ``mrad`` (1 mm ↔ 1 mrad) or ``deg`` (1 mm ↔ 1°): how the stated size applies to angles.
    """

    label: str
    n_configs: int
    error: float
    noise: float
    joint_noise: float
    paper_fkm: str
    paper_ikm: str
    design: str = "random"
    angles: str = "mrad"


CASES = [
    Case("noise-free, 1 mm errors", 8, 1e-3, 0.0, 0.0, "G ≈ 100 % (0.91 s)", "G ≈ 100 % (2.91 s)"),
    Case("noise-free, 1 cm errors", 8, 1e-2, 0.0, 0.0, "diverges (1.40 s)", "G = 99.9 % (3.39 s)"),
    Case("1 µm / 0.01°, 0.1 mm errors", 8, 1e-4, 1e-6, 0.01 * DEG, "−38.5 %", "—"),
    Case("1 µm / 0.01°, 0.1 mm errors", 20, 1e-4, 1e-6, 0.01 * DEG, "20 % (4.26 s)", "—"),
    Case("1 µm / 0.01°, 0.1 mm errors", 40, 1e-4, 1e-6, 0.01 * DEG, "38 % (5.25 s)", "—"),
    Case("1 µm / 0.01°, 0.1 mm errors", 60, 1e-4, 1e-6, 0.01 * DEG, "45.4 % (10.9 s)", "—"),
    Case("1 µm / 0.01°, 1 mm errors", 8, 1e-3, 1e-6, 0.01 * DEG, "—", "−6.2 % (2.58 s)"),
    Case("1 µm / 0.01°, 1 mm errors", 20, 1e-3, 1e-6, 0.01 * DEG, "—", "62.5 % (5.78 s)"),
    Case("1 µm / 0.01°, 1 mm errors", 40, 1e-3, 1e-6, 0.01 * DEG, "—", "87.6 % (8.88 s)"),
    Case("1 µm / 0.01°, 1 mm errors", 60, 1e-3, 1e-6, 0.01 * DEG, "—", "86.5 % (11.9 s)"),
]
#: The paper's noisy gains [%] by (method, case index in CASES).
PAPER_GAINS = {("FKM", 2): -38.54, ("FKM", 3): 20.0, ("FKM", 4): 38.0, ("FKM", 5): 45.38,
               ("IKM", 6): -6.17, ("IKM", 7): 62.54, ("IKM", 8): 87.58, ("IKM", 9): 86.5}
#: (design, angles) of the variants; the first is the paper-as-read of the main table.
VARIANTS = [("random", "mrad"), ("d-optimal", "mrad"), ("random", "deg"), ("d-optimal", "deg")]
VARIANT_TITLES = {("random", "mrad"): "random configurations, errors read as mm / mrad",
                  ("d-optimal", "mrad"): "D-optimal configurations, errors read as mm / mrad",
                  ("random", "deg"): "random configurations, errors read as mm / degrees",
                  ("d-optimal", "deg"): "D-optimal configurations, errors read as mm / degrees"}
VARIANT_SHORT = {("random", "mrad"): "random, mm/mrad", ("d-optimal", "mrad"): "D-opt, mm/mrad",
                 ("random", "deg"): "random, mm/deg", ("d-optimal", "deg"): "D-opt, mm/deg"}


def reading_units(pset: ParameterSet, angles: str) -> Array:
    """Per parameter, the unit its error size is stated in [m or rad]: 1 mm, and 1 mrad or 1°."""
    return np.array([ANGLE_READINGS[angles] if p.unit == "rad" else LENGTH_UNIT for p in pset])


def per_parameter_gain(x_true: Array, x_cal: Array) -> Array:
    """Per-parameter gain [%]: 100 (|Pr − Pn| − |Pr − Pc|) / |Pr − Pn| (nominal Pn = 0)."""
    return np.asarray(100.0 * (np.abs(x_true) - np.abs(x_true - x_cal)) / np.abs(x_true))


def _position_models(noise: float) -> list[Any]:
    return [ms.position("end_effector", sigma=max(noise, TRACKER_SIGMA))]


def _noise_free_observations(robot: pincal.Robot, pset: ParameterSet, qa: Array, noise: float) -> Observations:
    return simulate_observations(robot, pset, np.zeros(len(pset)), _position_models(noise), qa,
                                 np.random.default_rng(0))


_POOLS: dict[tuple[int, int], Array] = {}
_DESIGNS: dict[tuple[str, int, int, float, float, int], Array] = {}
_INFORMATION: dict[tuple[str, int, int, str, float, float, int], tuple[float, float]] = {}


def candidate_pool(robot: pincal.Robot, seed: int, n_candidates: int = N_CANDIDATES) -> Array:
    """The draw's random candidate configurations (n_candidates, 3) [rad], within ±ARM_SPREAD."""
    key = (seed, n_candidates)
    if key not in _POOLS:
        _POOLS[key], _ = random_actuated(robot, n_candidates, np.random.default_rng((seed, CANDIDATE_STREAM)),
                                         spread=ARM_SPREAD)
    return _POOLS[key]


def designed_configurations(robot: pincal.Robot, set_name: str, seed: int, k: int, noise: float,
                            joint_noise: float, n_candidates: int = N_CANDIDATES) -> Array:
    """``k`` configurations (k, 3) [rad] chosen D-optimally from the draw's candidate pool.

    The information is the FKM's: nominal parameters, rows whitened by each sample's covariance (tracker
    noise and the encoders' noise carried through the kinematics), columns scaled by the parameters'
    typical sizes; the design maximises ``log det(J_sᵀ J_s)`` (greedy, then exchange passes).
    """
    key = (set_name, seed, k, noise, joint_noise, n_candidates)
    if key not in _DESIGNS:
        pool = candidate_pool(robot, seed, n_candidates)
        pset = NAMED_SETS[set_name](robot)
        observations = _noise_free_observations(robot, pset, pool, noise)
        problem = CalibrationProblem(robot, pset, _position_models(noise), observations,
                                     joint_sigma=joint_noise or None)
        blocks = jacobian_blocks(problem)[:, :, :len(pset)]
        selection = select_poses(blocks, k, criterion="d-optimal", scales=pset.scales, names=pset.names)
        _DESIGNS[key] = pool[selection.indices]
    return _DESIGNS[key]


def information(robot: pincal.Robot, pset: ParameterSet, qa: Array, noise: float,
                joint_noise: float) -> tuple[float, float]:
    """(log det(J_sᵀJ_s) of the FKM-weighted information, κ of the geometric Jacobian) at nominal.

    ``log det`` is ``-inf`` (printed "singular") when J_s is rank-deficient by the analysis' rank tolerance.

    The first is the D-optimal design's criterion (rows whitened as the FKM weights them, encoder noise
    included); the second is the condition number of the scaled Jacobian with every position row
    weighted alike (the "identification Jacobian" of the identifiability section).
    """
    obs = _noise_free_observations(robot, pset, qa, noise)
    models = _position_models(noise)
    weighted = CalibrationProblem(robot, pset, models, obs, joint_sigma=joint_noise or None)
    jac = weighted.evaluate(np.zeros(len(pset))).jacobian
    assert jac is not None
    singular_values = np.linalg.svd(jac[:, :len(pset)] * pset.scales, compute_uv=False)
    full_rank = singular_values.size == len(pset) and singular_values[-1] > RANK_TOLERANCE * singular_values[0]
    log_det = float(2.0 * np.sum(np.log(singular_values))) if full_rank else float("-inf")
    geometric = CalibrationProblem(robot, pset, models, obs).evaluate(np.zeros(len(pset))).jacobian
    assert geometric is not None
    kappa = analyse(geometric, pset.names, pset.scales).condition_number
    return log_det, float(kappa)


@dataclass
class Draw:
    """One draw of one case, shared by the FKM and the IKM: true errors, configurations, data, references."""

    pset: ParameterSet
    units: Array  # [m or rad] per parameter: the unit its error size is read in
    x_true: Array  # [m, rad]
    train: Observations
    test: Observations
    log_det: float
    kappa: float
    before: Array  # held-out position errors [m] of the nominal model
    floor: Array  # held-out position errors [m] of the true model (the test readings' own noise)


_DRAWS: dict[tuple[str, Case, int, int, int], Draw] = {}


def simulate_draw(robot: pincal.Robot, set_name: str, case: Case, seed: int, n_test: int = N_TEST,
                  n_candidates: int = N_CANDIDATES) -> Draw:
    """The draw's errors (σ per the reading), configurations (random or D-optimal) and noisy data."""
    key = (set_name, case, seed, n_test, n_candidates)
    if key in _DRAWS:
        return _DRAWS[key]
    rng = np.random.default_rng(seed)
    pset = NAMED_SETS[set_name](robot)
    units = reading_units(pset, case.angles)
    x_true = rng.normal(size=len(pset)) * (case.error / LENGTH_UNIT * units)
    models = _position_models(case.noise)
    qa, _ = random_actuated(robot, case.n_configs + n_test, rng, spread=ARM_SPREAD)  # the held-out ones stay random
    if case.design == "d-optimal":
        qa[:case.n_configs] = designed_configurations(robot, set_name, seed, case.n_configs, case.noise,
                                                      case.joint_noise, n_candidates)
    elif case.design != "random":
        raise ValueError(f"unknown design '{case.design}'; designs are: random, d-optimal")
    obs = simulate_observations(robot, pset, x_true, models, qa, rng, noise=case.noise, joint_noise=case.joint_noise)
    train, test = obs.subset(np.arange(case.n_configs)), obs.subset(np.arange(case.n_configs, case.n_configs + n_test))
    info_key = (set_name, seed, case.n_configs, case.design, case.noise, case.joint_noise, n_candidates)
    if info_key not in _INFORMATION:  # the same configurations for every error size and reading
        _INFORMATION[info_key] = information(robot, pset, qa[:case.n_configs], case.noise, case.joint_noise)
    fkm_test = CalibrationProblem(robot, pset, models, test)
    before = error_norms(fkm_test.evaluate(np.zeros(len(pset)), jacobian=False).errors)
    floor = error_norms(fkm_test.evaluate(x_true, jacobian=False).errors)
    _DRAWS[key] = Draw(pset, units, x_true, train, test, *_INFORMATION[info_key], before, floor)
    return _DRAWS[key]


def run_case(robot: pincal.Robot, set_name: str, case: Case, method: str, seed: int, n_test: int = N_TEST,
             n_candidates: int = N_CANDIDATES) -> dict[str, Any]:
    """One draw of one case: simulate, identify by ``method``, evaluate on ``n_test`` random configurations."""
    draw = simulate_draw(robot, set_name, case, seed, n_test, n_candidates)
    pset, units, x_true = draw.pset, draw.units, draw.x_true
    models = _position_models(case.noise)
    sizes = case.error / LENGTH_UNIT * units
    start = time.perf_counter()
    std_ratio = float("nan")
    try:
        if method == "IKM":
            problem: CalibrationProblem = ImplicitProblem(robot, pset, models, draw.train)
        else:  # FKM weights each sample by its covariance, encoder noise included
            problem = CalibrationProblem(robot, pset, models, draw.train, joint_sigma=case.joint_noise or None)
        result = identify(problem)
        converged, x_cal = result.converged, result.x
        assert result.std_apriori is not None
        ratios = result.std_apriori / sizes
        if not (case.noise or case.joint_noise):
            std_ratio = 0.0
        elif np.any(np.isfinite(ratios)):
            std_ratio = float(np.nanmedian(ratios))
    except PincalError:
        converged, x_cal = False, np.zeros(len(pset))
    seconds = time.perf_counter() - start
    if converged:
        after = error_norms(CalibrationProblem(robot, pset, models, draw.test).evaluate(x_cal, jacobian=False).errors)
    else:
        after = draw.before
    gains = per_parameter_gain(x_true, x_cal)
    return {"G": calibration_gain(x_true / units, np.zeros(len(pset)), x_cal / units),
            "mean_gain": float(np.mean(gains)), "per_param": gains, "converged": converged, "seconds": seconds,
            "before": draw.before, "after": after, "floor": draw.floor, "names": pset.names,
            "std_ratio": std_ratio, "log_det": draw.log_det, "kappa": draw.kappa, "x_true": x_true, "x_cal": x_cal}


def _rms(values: Array) -> float:
    return float(np.sqrt(np.mean(values**2)))


def summarise(runs: list[dict[str, Any]]) -> dict[str, Any]:
    """Medians over the draws (gains, RMS after and std / error over the converged ones only)."""
    ok = [r for r in runs if r["converged"]]

    def median(key: str, rows: list[dict[str, Any]]) -> float:
        return float(np.median([r[key] for r in rows])) if rows else float("nan")

    return {"converged": f"{len(ok)}/{len(runs)}", "n_converged": len(ok), "n": len(runs),
            "G": median("G", ok), "mean_gain": median("mean_gain", ok), "seconds": median("seconds", runs),
            "rms_before": float(np.median([_rms(r["before"]) for r in runs])),
            "rms_after": float(np.median([_rms(r["after"]) for r in ok])) if ok else float("nan"),
            "rms_floor": float(np.median([_rms(r["floor"]) for r in runs])),
            "std_ratio": median("std_ratio", ok), "log_det": median("log_det", runs), "kappa": median("kappa", runs)}


def identifiability(robot: pincal.Robot, set_name: str, seeds: Sequence[int], spread: float | None = None,
                    n: int = N_IDENTIFIABILITY) -> dict[str, Any]:
    """Rank and κ of the geometric identification Jacobian at ``n`` random configurations, per draw."""
    pset = NAMED_SETS[set_name](robot)
    ranks, kappas, combinations = [], [], []
    for seed in seeds:
        qa, _ = random_actuated(robot, n, np.random.default_rng((seed, IDENTIFIABILITY_STREAM)),
                                spread=ARM_SPREAD if spread is None else spread)
        obs = _noise_free_observations(robot, pset, qa, 0.0)
        jac = CalibrationProblem(robot, pset, _position_models(0.0), obs).evaluate(np.zeros(len(pset))).jacobian
        assert jac is not None
        analysis = analyse(jac, pset.names, pset.scales, units=[p.unit for p in pset])
        ranks.append(analysis.rank)
        kappas.append(analysis.condition_number)
        if not combinations:
            combinations = [c.description for c in analysis.unidentifiable]
    return {"ranks": ranks, "kappa": float(np.median(kappas)), "kappa_min": float(np.min(kappas)),
            "kappa_max": float(np.max(kappas)), "combinations": combinations, "n_parameters": len(pset)}


def figures(robot: pincal.Robot, out: Path, seed: int) -> list[Path]:
    import matplotlib

    matplotlib.use("Agg")
    import matplotlib.pyplot as plt

    case = Case("", 60, 1e-4, 1e-6, 0.01 * DEG, "", "")
    runs = {m: run_case(robot, "model24i", case, m, seed) for m in METHODS}
    names = runs["FKM"]["names"]
    fig, ax = plt.subplots(figsize=(11, 4))
    width = 0.4
    idx = np.arange(len(names))
    for k, method in enumerate(METHODS):
        ax.bar(idx + (k - 0.5) * width, np.clip(runs[method]["per_param"], -200, 100), width, label=method)
    ax.set_xticks(idx, [n.replace("_joint", "").replace("_platform.predecessor", "") for n in names],
                  rotation=75, fontsize=7)
    ax.set_ylabel("gain per parameter [%]")
    ax.set_xlabel("parameter (Model 24, identifiable reading model24i)")
    ax.set_title("Study 000, Delta: per-parameter gain, 60 random configurations, 0.1 mm / 0.1 mrad errors, "
                 "1 µm / 0.01° noise (bars clipped at −200 %)", fontsize=9)
    ax.axhline(0, color="black", linewidth=0.5)
    ax.legend()
    fig.tight_layout()
    out.mkdir(parents=True, exist_ok=True)
    p1 = out / "000_delta_parameter_gain.png"
    fig.savefig(p1, dpi=120)
    plt.close(fig)
    fig, axes = plt.subplots(1, 2, figsize=(11, 4), sharey=True)
    for ax, method in zip(axes, METHODS, strict=True):
        r = runs[method]
        ax.plot(r["before"] * 1e3, "o", color="tab:blue", label="before")
        ax.plot(r["after"] * 1e3, "o", color="tab:red", label="after")
        ax.set_yscale("log")
        ax.set_xlabel("operating point (held-out configuration)")
        ax.set_title(f"{method}: position error at {N_TEST} operating points")
        ax.legend()
    axes[0].set_ylabel("position error [mm]")
    fig.tight_layout()
    p2 = out / "000_delta_operating_points.png"
    fig.savefig(p2, dpi=120)
    plt.close(fig)
    return [p1, p2]


# --- the page -----------------------------------------------------------------------------------------
TABLE_HEAD = ["| case | configs | paper FKM | pincal FKM: G (mean gain) | paper IKM | pincal IKM: G (mean gain) | "
              "held-out RMS before → after FKM / IKM (floor) | std / error (FKM) | log det / κ | time FKM / IKM |",
              "|---|---|---|---|---|---|---|---|---|---|"]


def _gain(x: dict[str, Any]) -> str:
    return f"{x['G']:.1f} % ({x['mean_gain']:.1f} %), {x['converged']} conv."


def table_row(case: Case, s: dict[str, dict[str, Any]]) -> str:
    f, i = s["FKM"], s["IKM"]
    return (f"| {case.label} | {case.n_configs} | {case.paper_fkm} | {_gain(f)} | {case.paper_ikm} | {_gain(i)} | "
            f"{f['rms_before'] * 1e6:.1f} → {f['rms_after'] * 1e6:.2f} / {i['rms_after'] * 1e6:.2f} "
            f"({f['rms_floor'] * 1e6:.2f}) µm | {f['std_ratio']:.2g} | {_log_det(f['log_det'])} / {f['kappa']:.0f} | "
            f"{f['seconds'] * 1e3:.0f} / {i['seconds'] * 1e3:.0f} ms |")


def _log_det(value: float) -> str:
    return f"{value:.1f}" if math.isfinite(value) else "singular"


def _fmt(value: float) -> str:
    return f"{value:.1f} %" if math.isfinite(value) else "n/a"


def _span(values: Sequence[float], scale: float = 1.0, digits: int = 0) -> str:
    lo, hi = min(values) * scale, max(values) * scale
    return f"{lo:.{digits}f}" if round(lo, digits) == round(hi, digits) else f"{lo:.{digits}f}–{hi:.{digits}f}"


@dataclass
class Study:
    """Everything the page states, as computed."""

    seeds: int
    variant_seeds: int
    n_candidates: int
    ident: dict[str, dict[str, Any]]
    spread: dict[float, dict[str, Any]]
    main: dict[str, list[tuple[int, Case, dict[str, dict[str, Any]]]]]  # set name -> rows
    variants: dict[tuple[str, str], list[tuple[int, Case, dict[str, dict[str, Any]]]]]  # model24i, noisy cases
    seconds: float = float("nan")
    workers: int = 1
    options: str = ""  # the command-line options that differ from the defaults


def _by_index(rows: list[tuple[int, Case, dict[str, dict[str, Any]]]]) -> dict[int, dict[str, dict[str, Any]]]:
    return {k: s for k, _, s in rows}


def comparison_table(study: Study) -> list[str]:
    """The paper's noisy gains against pincal's, per variant (model24i): one row per noisy case."""
    by_variant = {v: _by_index(study.variants[v]) for v in VARIANTS}
    lines = ["| case | configs | paper FKM / IKM | " + " | ".join(f"{VARIANT_SHORT[v]}: FKM / IKM" for v in VARIANTS)
             + " | variants reaching the paper's G (its method) |",
             "|---|---|---|" + "---|" * len(VARIANTS) + "---|"]
    for k, case in enumerate(CASES):
        if not case.noise or not all(k in rows for rows in by_variant.values()):
            continue
        paper = {m: PAPER_GAINS.get((m, k)) for m in METHODS}
        cells = [" / ".join(_fmt(by_variant[v][k][m]["G"]) for m in METHODS) for v in VARIANTS]
        reached = [f"{VARIANT_SHORT[v]} ({m})" for m in METHODS for v in VARIANTS
                   if paper[m] is not None and by_variant[v][k][m]["G"] >= paper[m]]
        lines.append(f"| {case.label} | {case.n_configs} | "
                     + " / ".join("—" if paper[m] is None else f"{paper[m]:.1f} %" for m in METHODS) + " | "
                     + " | ".join(cells) + f" | {', '.join(reached) or 'none'} |")
    return lines


def reached_counts(study: Study) -> dict[tuple[str, str], tuple[int, int]]:
    """Per variant: (paper gains reached by pincal's same method, paper gains compared)."""
    out = {}
    for v in VARIANTS:
        rows = _by_index(study.variants[v])
        compared = [(m, k) for (m, k) in PAPER_GAINS if k in rows]
        out[v] = (sum(rows[k][m]["G"] >= PAPER_GAINS[(m, k)] for m, k in compared), len(compared))
    return out


def page(study: Study, figure_names: Sequence[str] = ()) -> str:
    """The results page, every number from ``study``."""
    m24, m24i = study.ident["model24"], study.ident["model24i"]
    default_spread = ARM_SPREAD
    lines = [
        "# Study 000 — Delta robot, FKM vs IKM (paper vs pincal)",
        "",
        f"Command: `python examples/study_000_delta.py{study.options}` ({study.seeds} random draws per case in the "
        f"first table, {study.variant_seeds} per case in the variant tables; medians). This page is written by that "
        "script; "
        f"the run that wrote it took {study.seconds:.0f} s ({study.workers} "
        f"{'process' if study.workers == 1 else 'processes'} on {os.cpu_count()} cores).",
        "Paper: Bentaleb and Iqbal, *On the improvement of calibration accuracy of parallel robots – modeling and "
        "optimization*, Journal of Theoretical and Applied Mechanics 58(1), 2020, doi:10.15632/jtam-pl/115863: Delta "
        "robot calibration by forward (FKM) and inverse (IKM) kinematic models,",
        "Section 4 (simulations; Jacobians by differentiating the model equations, Section 3.5; non-linear least "
        "squares). pincal: the same robot (`robots_urdf/delta.urdf`), analytic Jacobians through the loops "
        "(implicit function theorem), Levenberg–Marquardt on the identifiable directions.",
        "",
        f"**Identifiability first.** With position measurements at {N_IDENTIFIABILITY} random configurations (arm "
        f"angles within ±{default_spread:g} rad; {len(m24['ranks'])} draws), the paper's Model 24 (Dx, Dy, Dz, θ, "
        "α, Lax, Lay, Lb per leg, Lax/Lay read as the arm vector's components in its plane of motion) has rank "
        f"**{_span(m24['ranks'])}** of {m24['n_parameters']}. pincal's analysis names what the data cannot see:",
        "",
    ]
    lines += [f"- `{c}`" for c in m24["combinations"]] or ["- (nothing: every parameter is identifiable)"]
    main24 = _by_index(study.main["model24"])
    main24i = _by_index(study.main["model24i"])
    lines += [
        "",
        "pincal's steps move only along the directions the data can see, so from the nominal it returns the "
        "minimum-norm split of each such combination (in scaled variables), and G over all 24 parameters cannot reach "
        f"100 % even without noise (noise-free, 8 configurations: G = {main24[0]['FKM']['G']:.1f} % from 1 mm "
        f"errors, {main24[1]['FKM']['G']:.1f} % from 1 cm), while the held-out error falls to "
        f"{main24[0]['FKM']['rms_after'] * 1e6:.2f} µm. Replacing Lay by the eighth error that position data "
        f"*can* see — the motor axis' tilt (`model24i`) — gives rank **{_span(m24i['ranks'])}** of "
        f"{m24i['n_parameters']}, median κ = {m24i['kappa']:.0f} ({m24i['kappa_min']:.0f}–{m24i['kappa_max']:.0f} "
        f"over the draws; Model 24: {m24['kappa']:.0f} on its identifiable columns). κ is the condition number of "
        "the identification Jacobian, columns scaled per 1 mm and per 1 mrad, every position row weighted alike.",
        "",
        "**How the cases are read.** The error sizes (σ of a normal draw per parameter) apply to lengths in mm and, "
        "in the first table, to angles in mrad (\"1 mm\" = 1 mm and 1 mrad). The paper's Fig. 4 caption writes "
        "\"0.1mm/degrees for lengths/angles\": the variant tables also read \"1 mm\" as 1 mm and 1°. G (Eq. 4.1) is "
        "computed in the units of the reading (mm and mrad, or mm and degrees), so that every parameter's error "
        "counts alike; the mean per-parameter gain (in parentheses) does not depend on units. *D-optimal* "
        f"configurations are chosen, per draw, from {study.n_candidates} random candidates by "
        "`pincal.study.pose_selection.select_poses(..., criterion=\"d-optimal\")` on the FKM's information "
        "(nominal parameters, "
        "rows whitened by each sample's covariance, encoder noise included); the held-out configurations stay "
        "random. *floor*: the held-out RMS error at the true parameters (the test readings' own noise). "
        "*std / error*: the FKM-identified parameters' median a-priori standard deviation (from the stated noise, "
        "√diag((JᵀJ)⁻¹) of the whitened Jacobian) over the size of the errors sought. *log det / κ*: "
        "log det(J_sᵀJ_s) of the training configurations' FKM-weighted, scaled Jacobian (the D-optimal criterion) "
        "and the κ defined above, at nominal.",
        "",
        f"## The paper's noisy gains against pincal (model24i; median G over {study.variant_seeds} draws, "
        "all 24 parameters)",
        "",
    ]
    lines += comparison_table(study)
    counts = reached_counts(study)
    base = counts[VARIANTS[0]]
    lines += [
        "",
        f"With random configurations and the errors read as mm / mrad, pincal's median G with the paper's method "
        f"reaches {base[0]} of the paper's {base[1]} noisy gains; with D-optimal configurations "
        f"{counts[VARIANTS[1]][0]}, with the "
        f"errors read as mm / degrees {counts[VARIANTS[2]][0]}, with both {counts[VARIANTS[3]][0]}. "
        + _paper_sentences(study),
        "",
        f"## All cases, random configurations, errors read as mm / mrad ({study.seeds} draws per case)",
        "",
    ]
    lines += TABLE_HEAD
    for set_name, rows in study.main.items():
        lines.append(f"| **parameter set {set_name}** | | | | | | | | | |")
        lines += [table_row(case, s) for _, case, s in rows]
    lines += ["", f"## Variants (parameter set model24i, noisy cases, {study.variant_seeds} draws per case)", ""]
    if study.variant_seeds == study.seeds:
        lines += ["Random configurations with the errors read as mm / mrad: the first table's model24i rows.", ""]
    lines += TABLE_HEAD
    for v in VARIANTS if study.variant_seeds != study.seeds else VARIANTS[1:]:  # else the first table has it
        lines.append(f"| **{VARIANT_TITLES[v]}** | | | | | | | | | |")
        lines += [table_row(case, s) for _, case, s in study.variants[v]]
    lines += ["", "Reading the tables:"]
    lines += _reading(study, main24i)
    lines += [""] + [f"![{name}](figures/{name})\n" for name in figure_names]
    return "\n".join(lines).rstrip() + "\n"


def _paper_sentences(study: Study) -> str:
    rows = {v: _by_index(study.variants[v]) for v in VARIANTS}
    parts = []
    for k in (8, 9):  # the paper's IKM at 40 and 60 configurations, 1 mm errors
        if all(k in rows[v] for v in VARIANTS):
            parts.append(k)
    if not parts:
        return ""
    def gains(v: tuple[str, str], method: str) -> str:
        return " / ".join(f"{rows[v][k][method]['G']:.1f}" for k in parts)
    counts = " / ".join(str(CASES[k].n_configs) for k in parts)
    paper = " / ".join(f"{PAPER_GAINS[('IKM', k)]:.1f}" for k in parts)
    return (f"At {counts} configurations with 1 mm errors (paper IKM: {paper} %), pincal's FKM reaches "
            + ", ".join(f"{gains(v, 'FKM')} % ({VARIANT_SHORT[v]})" for v in VARIANTS)
            + "; its IKM " + ", ".join(f"{gains(v, 'IKM')} % ({VARIANT_SHORT[v]})" for v in VARIANTS) + ".")


def _reading(study: Study, main24i: dict[int, dict[str, dict[str, Any]]]) -> list[str]:
    out: list[str] = []
    if 0 not in main24i or 1 not in main24i:
        return out
    conv_1cm = main24i[1]["FKM"]["converged"]
    noise_free = [s for _, c, s in study.main["model24i"] + study.main["model24"] if not c.noise]
    times = [s[m]["seconds"] for s in noise_free for m in METHODS]
    out.append(
        f"- Noise-free (model24i, 8 configurations): the FKM converges from 1 cm errors in {conv_1cm} draws (the "
        f"paper's FKM diverged), and G = {main24i[0]['FKM']['G']:.1f} / {main24i[0]['IKM']['G']:.1f} % (FKM / IKM) "
        f"from 1 mm errors, {main24i[1]['FKM']['G']:.1f} / {main24i[1]['IKM']['G']:.1f} % from 1 cm. Median "
        f"identification times in the noise-free rows are {_span(times, 1e3)} ms (paper: 0.91–3.39 s).")
    noisy = [(c, s) for _, c, s in study.main["model24i"] if c.noise]
    if noisy:
        floors = [s["FKM"]["rms_floor"] for _, s in noisy]
        tracker_only = math.sqrt(3.0) * noisy[0][0].noise
        out.append(
            f"- With {noisy[0][0].label.split(',')[0]} noise the encoders dominate: at the true parameters the "
            f"held-out RMS error is already {_span(floors, 1e6, 1)} µm (the *floor*); the tracker noise alone would "
            f"give √3 · {noisy[0][0].noise * 1e6:g} µm = {tracker_only * 1e6:.1f} µm.")
    for label, rows in (("20 or more", [(c, s) for c, s in noisy if c.n_configs >= 20]),
                        ("8", [(c, s) for c, s in noisy if c.n_configs < 20])):
        if not rows:
            continue
        after = [s[m]["rms_after"] for _, s in rows for m in METHODS]
        ratios = [s[m]["rms_after"] / s["FKM"]["rms_floor"] for _, s in rows for m in METHODS]
        equations = f" ({3 * rows[0][0].n_configs} equations for 24 unknowns)" if label == "8" else ""
        out.append(
            f"  From {label} configurations{equations} the held-out RMS after calibration (model24i, first table) is "
            f"{_span(after, 1e6, 1)} µm, {_span(ratios, 1.0, 2)} times the floor.")
    all_rows = [(f"{name}, {c.label}, {c.n_configs} configurations", s) for name in ("model24", "model24i")
                for _, c, s in study.main[name] if c.noise]
    all_rows += [(f"{VARIANT_SHORT[v]}, {c.label}, {c.n_configs} configurations", s)
                 for v in VARIANTS for _, c, s in study.variants[v]]
    above = [(label, s) for label, s in all_rows if s["FKM"]["std_ratio"] > 1]
    exceptions = [label for label, s in above if not s["FKM"]["G"] < 0]
    below = [s for _, s in all_rows if s["FKM"]["std_ratio"] < 0.2]
    positive = sum(s["FKM"]["G"] > 0 for s in below)
    out.append(
        "- Where *std / error* exceeds 1, the data cannot pin the parameters down better than their initial "
        "error: an unbiased estimate is then, on average, further from the truth than the nominal (G < 0). Of the "
        f"{len(above)} noisy rows of the tables above with std / error > 1, {len(above) - len(exceptions)} have a "
        "negative median FKM G" + (f" (not: {'; '.join(exceptions)})" if exceptions else "")
        + f"; of the {len(below)} with std / error < 0.2, {positive} have a positive one.")
    out += _design_sentences(study)
    weighted = "joint_sigma" in inspect.signature(ImplicitProblem).parameters
    out.append(
        "- The FKM weights each sample by its full covariance, encoder noise included (`joint_sigma`); "
        + ("the IKM does too." if weighted else "the IKM has no such weighting yet."))
    s06, s10 = study.spread[0.6], study.spread[default_spread_value()]
    out.append(
        f"- Configurations are drawn with arm angles within ±{default_spread_value():g} rad. At ±0.6 rad the "
        f"median κ of {N_IDENTIFIABILITY} random configurations (model24i) is {s06['kappa']:.0f} against "
        f"{s10['kappa']:.0f} at ±{default_spread_value():g} rad ({s06['kappa'] / s10['kappa']:.1f} times larger): the "
        "paper's \"number and quality of measurement configurations\" matter.")
    return out


def default_spread_value() -> float:
    return ARM_SPREAD


def _design_sentences(study: Study) -> list[str]:
    rand = _by_index(study.variants[("random", "mrad")])
    dopt = _by_index(study.variants[("d-optimal", "mrad")])
    ks = [k for k, c in enumerate(CASES) if c.noise and c.error == 1e-3 and k in rand and k in dopt]
    if not ks:
        return []
    delta = ", ".join(f"{dopt[k]['FKM']['log_det'] - rand[k]['FKM']['log_det']:+.1f}" for k in ks)
    kappa = ", ".join(f"{dopt[k]['FKM']['kappa']:.0f} vs {rand[k]['FKM']['kappa']:.0f}" for k in ks)
    std = ", ".join(f"{dopt[k]['FKM']['std_ratio']:.2g} vs {rand[k]['FKM']['std_ratio']:.2g}" for k in ks)
    counts = " / ".join(str(CASES[k].n_configs) for k in ks)
    ikm = ", ".join(f"{dopt[k]['IKM']['G'] - rand[k]['IKM']['G']:+.1f}" for k in ks)
    fkm = ", ".join(f"{dopt[k]['FKM']['G'] - rand[k]['FKM']['G']:+.1f}" for k in ks)
    return [
        f"- D-optimal against random configurations at {counts} configurations (1 mm errors, mm / mrad): "
        f"log det(J_sᵀJ_s) changes by {delta} (the confidence ellipsoid's volume scales by e^(−Δ/2)); "
        f"std / error {std}; geometric κ {kappa} (D-optimality maximises the determinant, not 1/κ). FKM G "
        f"changes by {fkm} points, IKM G by {ikm}: the design is D-optimal for the FKM's weighting, which the "
        "IKM does not use."]


def print_block(lines: Sequence[str]) -> None:
    print("\n".join(lines))


Job = tuple[str, Case, str]  # (parameter set, case, method)
_WORKER_ROBOT: list[pincal.Robot] = []


def draw_jobs(seed: int, jobs: Sequence[Job], n_candidates: int) -> dict[tuple[str, Case, str, int], dict[str, Any]]:
    """Every job of one draw (one process; the draw's candidate pool and designs are made once)."""
    if not _WORKER_ROBOT:
        _WORKER_ROBOT.append(pincal.load_robot("delta"))
        run_case(_WORKER_ROBOT[0], "model24i", CASES[0], "FKM", 0)  # warm-up: the first solve pays for set-up
    robot = _WORKER_ROBOT[0]
    return {(set_name, case, method, seed): run_case(robot, set_name, case, method, seed, n_candidates=n_candidates)
            for set_name, case, method in jobs}


def main() -> None:
    parser = argparse.ArgumentParser(description="Study 000: FKM vs IKM calibration of the Delta robot.")
    parser.add_argument("--quick", action="store_true", help="few cases and draws, no figures; writes nothing "
                        "unless --out is given")
    parser.add_argument("--seeds", type=int, default=10, help="random draws per case, first table (default 10)")
    parser.add_argument("--variant-seeds", type=int, default=5, help="random draws per case, variant tables "
                        "(default 5: the run stays under ~10 minutes on 2 shared cores)")
    parser.add_argument("--candidates", type=int, default=N_CANDIDATES, help="candidates per draw for the "
                        f"D-optimal design (default {N_CANDIDATES})")
    parser.add_argument("--workers", type=int, default=2, help="processes, one draw each at a time (default 2; "
                        "1: serial)")
    where = parser.add_mutually_exclusive_group()
    where.add_argument("--out", type=Path, help="write the page (and, full run only, the figures) here; "
                       "default: ./results for the full run, nothing for --quick")
    where.add_argument("--publish", action="store_true", help="write the committed page and figures under "
                       "docs/results instead")
    args = parser.parse_args()
    start = time.perf_counter()
    robot = pincal.load_robot("delta")
    seeds = list(range(2 if args.quick else args.seeds))
    variant_seeds = list(range(1 if args.quick else args.variant_seeds))
    n_candidates = min(args.candidates, 200) if args.quick else args.candidates
    main_cases = [0, 1, 2, 6] if args.quick else list(range(len(CASES)))
    variant_cases = [6] if args.quick else [k for k, c in enumerate(CASES) if c.noise]
    workers = 1 if args.quick else max(1, args.workers)
    print(f"Study 000, Delta robot: medians over {len(seeds)} random draws per case ({len(variant_seeds)} in the "
          "variant tables). G: Eq. 4.1 in the reading's units; mean gain: mean per-parameter gain; floor: held-out "
          "RMS at the true parameters; std / error: a-priori σ over the size of the errors sought; log det / κ: "
          "of the training configurations at nominal\n")

    ident_seeds = seeds[:1] if args.quick else seeds[:5]
    ident = {name: identifiability(robot, name, ident_seeds) for name in ("model24", "model24i")}
    spread = {0.6: identifiability(robot, "model24i", ident_seeds, spread=0.6),
              default_spread_value(): ident["model24i"]}
    for name, r in ident.items():
        print(f"{name}: rank {r['ranks']} of {r['n_parameters']}, κ median {r['kappa']:.0f} "
              f"({r['kappa_min']:.0f}–{r['kappa_max']:.0f})")
        for c in r["combinations"]:
            print(f"  not identifiable: {c}")
    print(f"model24i, κ at ±0.6 rad: {spread[0.6]['kappa']:.0f}; at ±{default_spread_value():g} rad: "
          f"{spread[default_spread_value()]['kappa']:.0f}\n", flush=True)

    # what each table needs: (set, case) and its draws; every (set, case, method, draw) is run once
    tables: dict[str, list[tuple[str, int, Case, list[int]]]] = {
        f"parameter set {name}": [(name, k, CASES[k], seeds) for k in main_cases] for name in ("model24", "model24i")}
    for design, angles in VARIANTS:
        tables[VARIANT_TITLES[(design, angles)]] = [
            ("model24i", k, replace(CASES[k], design=design, angles=angles), variant_seeds) for k in variant_cases]
    per_draw: dict[int, list[Job]] = {}
    for rows in tables.values():
        for set_name, _, case, draws in rows:
            for seed in draws:
                jobs = per_draw.setdefault(seed, [])
                jobs += [(set_name, case, m) for m in METHODS if (set_name, case, m) not in jobs]
    runs: dict[tuple[str, Case, str, int], dict[str, Any]] = {}
    if workers == 1:
        for seed, jobs in per_draw.items():
            runs.update(draw_jobs(seed, jobs, n_candidates))
    else:
        import concurrent.futures

        with concurrent.futures.ProcessPoolExecutor(max_workers=workers) as pool:
            futures = {pool.submit(draw_jobs, seed, jobs, n_candidates): seed for seed, jobs in per_draw.items()}
            for future in concurrent.futures.as_completed(futures):
                runs.update(future.result())
                print(f"draw {futures[future]} done ({time.perf_counter() - start:.0f} s)", flush=True)

    summaries: dict[str, list[tuple[int, Case, Any]]] = {}
    print_block(TABLE_HEAD)
    for title, rows in tables.items():
        print(f"| **{title}** | | | | | | | | | |")
        summaries[title] = []
        for set_name, k, case, draws in rows:
            s = {m: summarise([runs[(set_name, case, m, seed)] for seed in draws]) for m in METHODS}
            summaries[title].append((k, case, s))
            print(table_row(case, s))
    main_rows = {name: summaries[f"parameter set {name}"] for name in ("model24", "model24i")}
    variants = {v: summaries[VARIANT_TITLES[v]] for v in VARIANTS}

    study = Study(len(seeds), len(variant_seeds), n_candidates, ident, spread, main_rows, variants)
    out = ROOT / "docs" / "results" if args.publish else args.out
    if out is None and not args.quick:
        out = Path("results")
    figs = figures(robot, out / "figures", seed=7) if out is not None and not args.quick else []
    study.seconds = time.perf_counter() - start
    study.workers = workers
    study.options = "".join(f" {a}" for a in sys.argv[1:] if a != "--out" and Path(a) != args.out)
    text = page(study, [f.name for f in figs])
    print("\n" + text)
    if out is not None:
        out.mkdir(parents=True, exist_ok=True)
        doc = out / "000_delta.md"
        doc.write_text(text, encoding="utf-8")
        print(f"wrote {doc}" + "".join(f", {f}" for f in figs))
    print(f"total {study.seconds:.0f} s")


if __name__ == "__main__":
    main()
