"""Real data: the TIAGo arm measured by motion capture, one and three markers, geometric and non-geometric models.

Run: ``python examples/tiago_mocap.py`` (a few minutes) or ``--quick`` (seconds: one case, 5 folds once). Writes
``tiago_mocap.md`` under ``results/`` (``--out DIR`` elsewhere, ``--publish`` for ``docs/results``, ``--json`` for the
numbers).

Every figure of the table is what ``pincal calibrate`` prints for the same data and options: the fit and held-out RMS
of the default command, and its ``--cv loo`` and ``--cv 5x4`` figures. Cross-validation redoes everything in every
fold (parameters, model selection, robust starts) without the fold's postures, so no fold sees its test postures. The
comparison with FIGAROH 1.0.2 on the same folds is measured by ``benchmarks/bench_tiago_figaroh.py`` and quoted; the
floor of noise (what cross-validation would give if the fit's residuals were noise) is measured here.
"""

from __future__ import annotations

import statistics
import sys
import time
from dataclasses import dataclass, replace
from pathlib import Path
from typing import Any

import numpy as np
from study_cli import ROOT, study_main

import pincal
from pincal.calibration.options import CalibrationOptions
from pincal.calibration.pipeline import calibrate
from pincal.calibration.samples import read_robot_dataset
from pincal.identification.parameters import choose_parameters
from pincal.identification.problem import CalibrationProblem
from pincal.identification.selection import select_and_fit
from pincal.io.adapters import measurements_for, observations_from

DATA = ROOT / "examples" / "data"
ONE = DATA / "tiago_mocap_marker1.csv"
THREE = DATA / "tiago_mocap_markers.csv"
#: pincal's default command and FIGAROH 1.0.2 cross-validated on the same folds, as measured by
#: ``python benchmarks/bench_tiago_figaroh.py`` (benchmarks/RESULTS.md; about 6 minutes, not rerun here): plan →
#: (pincal, FIGAROH) RMS [mm], every marker counted, and for three markers (pincal, FIGAROH) marker 1's alone.
SIDE_BY_SIDE = {
    "1 marker": {"leave-one-out": (3.506, 4.378), "seeds 0–3": (4.010, 5.287), "seeds 4–7": (4.160, 5.047),
                 "seeds 8–11": (4.103, 5.922), "seeds 12–15": (3.819, 4.563), "seeds 16–19": (3.959, 4.869)},
    "3 markers": {"leave-one-out": (4.092, 4.170), "seeds 0–3": (4.806, 5.120), "seeds 4–7": (4.903, 4.958),
                  "seeds 8–11": (4.884, 5.746), "seeds 12–15": (4.233, 4.498), "seeds 16–19": (4.843, 5.316)},
}
MARKER_1 = {"leave-one-out": (3.745, 3.861), "seeds 0–3": (4.450, 4.801), "seeds 4–7": (4.469, 4.515),
            "seeds 8–11": (4.697, 5.405), "seeds 12–15": (3.896, 4.178), "seeds 16–19": (4.506, 4.893)}
#: FIGAROH's figures quoted with the targets of issue 13 (leave-one-out, 5-fold × 4 [mm]); its folds are not recorded.
QUOTED_FIGAROH = {"1 marker": (4.378, 4.690), "3 markers": (3.861, 4.419)}
#: Relative difference of two cross-validated figures below which they are the same (their third decimal in mm).
SAME = 0.005
#: The targets of issue 13, 5-fold × 4 RMS [mm].
TARGETS = {"1 marker": 4.0, "3 markers": 3.6}


@dataclass(frozen=True)
class Case:
    """One line of the table: the data, the parameters (None: the default set) and the selection."""

    markers: str
    path: Path
    model: str
    parameters: tuple[str, ...] | None
    select: str

    @property
    def command(self) -> str:
        """The ``pincal calibrate`` options that give this line."""
        words = [f"'{p}'" if "*" in p or "!" in p else p for p in self.parameters or ()]
        options = (f" --parameters {' '.join(words)}" if words else "") + (
            f" --select {self.select}" if self.select != "auto" else "")
        return f"pincal calibrate tiago_no_hand {self.path.relative_to(ROOT)}{options}"


def cases(quick: bool) -> list[Case]:
    """The table's lines."""
    models = [("geometric (default)", None, "auto"),
              ("geometric, every identifiable parameter", None, "none"),
              ("geometric + harmonics", ("default", "*.sin1", "*.cos1"), "bic"),
              ("geometric + compliance", ("default", "*.compliance"), "bic")]
    out = [Case(markers, path, model, parameters, select) for markers, path in (("1 marker", ONE), ("3 markers", THREE))
           for model, parameters, select in models]
    return out[:1] if quick else out


def _cv_rms(report: pincal.CalibrationReport) -> float | None:
    """The cross-validated RMS length error [m] of ``report`` (None: no cross-validation, or no fold fitted)."""
    return report.cv.rms if report.cv is not None else None


def measure(case: Case, quick: bool) -> dict[str, Any]:
    """Fit, held-out, leave-one-out and 5-fold × 4 figures of one case [m]."""
    robot = pincal.load_robot("tiago_no_hand")
    dataset = read_robot_dataset(case.path, robot)
    options: dict[str, Any] = {"parameter_spec": list(case.parameters) if case.parameters else None,
                               "select": case.select}
    start = time.perf_counter()
    folds = calibrate(robot, dataset, cv="5" if quick else "5x4", **options)
    loo = None if quick else _cv_rms(calibrate(robot, dataset, cv="loo", **options).report)
    report = folds.report.as_dict()
    return {"markers": case.markers, "model": case.model, "command": case.command,
            "candidates": report["n_parameters"], "identifiable": report["n_identifiable"],
            "estimated": report["n_estimated"], "left_out": report["selection"]["removed_groups"],
            "fit": report["rms_after"], "held_out": report["test_rms_after"], "loo": loo,
            "cv": report["cv"]["rms"], "cv_plan": report["cv"]["plan"], "sigma_ratio": report["sigma2"] ** 0.5,
            "seconds": time.perf_counter() - start}


def _mm(value: float | None) -> str:
    return "—" if value is None else f"{value * 1e3:.3f}"


def page(rows: list[dict[str, Any]], seconds: float, quick: bool, parts: dict[str, Any] | None = None,
         floors: dict[str, Any] | None = None, beyond: dict[str, Any] | None = None) -> str:
    """The results page."""
    lines = [
        "# Real data — TIAGo arm, motion capture",
        "",
        f"Command: `python examples/tiago_mocap.py --publish`{' (--quick: one case, 5 folds once)' if quick else ''}. "
        f"This page is written by that script; the run that wrote it took {seconds:.0f} s.",
        "",
        "**The data.** 34 static postures of a TIAGo arm: the robot reads the torso and 7 arm joints, and a Qualisys "
        "system tracks markers on the hand. The raw file is `examples/data/tiago_mocap_raw.csv`, a verbatim copy of "
        "`qualysis_base_hand_calibration.csv` from the public repository thanhndv212/figaroh-examples "
        "(`examples/tiago/data/calibration/mocap/`, commit c0b5c7f). It has four markers; marker 4 duplicates "
        "marker 3.",
        "",
        "- `examples/data/tiago_mocap_marker1.csv` holds marker 1 as `position:wrist_ft_tool_link`.",
        "- `examples/data/tiago_mocap_markers.csv` holds markers 1–3 as `position:wrist_ft_tool_link@m1`, `@m2` and "
        "`@m3`, each with its own unknown offset.",
        "- The mocap frame is unknown. The robot is example-robot-data's `tiago_no_hand`; its head and wheels have no "
        "column and stay at their reference.",
        "- Every fifth posture (4, 9, …, 29) is held out (`set=test`).",
        "",
        "**The figures** [mm] are RMS position errors, one 3D error per marker reading:",
        "",
        "- *fit*: the 28 fitted postures;",
        "- *held out*: the 6 postures marked `set=test`;",
        "- *leave-one-out* (`--cv loo`) and *5-fold × 4* (`--cv 5x4`, 4 shuffles, seeds 0–3): cross-validation over "
        "all 34 postures, with everything redone in every fold (parameters, model selection, robust starts).",
        "",
        "Each line is the command in its last column, plus `--cv 5x4` (or `--cv loo`).",
        "",
        "| markers | model | estimated (of identifiable) | left out by selection | fit | held out | leave-one-out | "
        "5-fold × 4 | a-posteriori σ / stated | command |",
        "|---|---|---|---|---|---|---|---|---|---|",
    ]
    for r in rows:
        lines.append(f"| {r['markers']} | {r['model']} | {r['estimated']} (of {r['identifiable']}) | "
                     f"{', '.join(r['left_out']) or '—'} | {_mm(r['fit'])} | {_mm(r['held_out'])} | {_mm(r['loo'])} | "
                     f"{_mm(r['cv'])} | {r['sigma_ratio']:.2f} | `{r['command']}` |")
    lines += ["", *side_by_side(), "", "## Against the targets", ""]
    for markers, target in TARGETS.items():
        best = min((r for r in rows if r["markers"] == markers and r["cv_plan"] == "5-fold × 4"),
                   key=lambda r: r["cv"], default=None)
        if best is None:
            continue
        plans = [ours for name, (ours, _) in SIDE_BY_SIDE[markers].items() if name.startswith("seeds")]
        verdict = "reached" if best["cv"] * 1e3 <= target else "not reached"
        lines.append(f"- {markers}: target ≤ {target} mm (5-fold × 4); best here {_mm(best['cv'])} mm "
                     f"({best['model']}): {verdict}. The default command over the five fold plans: median "
                     f"{statistics.median(plans):.3f} mm, {min(plans):.3f}–{max(plans):.3f} mm.")
    lines.append("- A fold plan that happens to fall below a target is not a result: picking it would be tuning to "
                 "the folds. Why the targets are out of reach on these data is below.")
    lines += ["", *extrapolation_section(beyond)] if beyond else []
    lines += ["", "## What limits it", "", *limits(rows, parts, floors)]
    return "\n".join(lines) + "\n"


def side_by_side() -> list[str]:
    """The section comparing pincal and FIGAROH 1.0.2 on the same folds (:data:`SIDE_BY_SIDE`)."""
    lines = ["## Against FIGAROH 1.0.2, on the same folds", "",
             "Measured by `python benchmarks/bench_tiago_figaroh.py` (benchmarks/RESULTS.md; not rerun by this page's "
             "command). Both tools cross-validate the same folds: plan *seeds S–S+3* is `--cv 5x4 --cv-seed S`. "
             "pincal: the default command; FIGAROH: its `full_params` model with the base frame and each marker's "
             "offset unknown (30 parameters for one marker, 39 for three), least squares. RMS [mm] of the held-out "
             "marker readings:", "",
             "| markers | cross-validation | pincal | FIGAROH 1.0.2 | FIGAROH / pincal | pincal, marker 1 | "
             "FIGAROH, marker 1 |", "|---|---|---|---|---|---|---|"]
    for markers, plans in SIDE_BY_SIDE.items():
        for name, (ours, theirs) in plans.items():
            first = MARKER_1[name] if markers == "3 markers" else None
            lines.append(f"| {markers} | {name if name == 'leave-one-out' else '5-fold × 4, ' + name} | {ours:.3f} | "
                         f"{theirs:.3f} | {theirs / ours:.2f} | {f'{first[0]:.3f}' if first else '—'} | "
                         f"{f'{first[1]:.3f}' if first else '—'} |")
    pairs = [pair for plans in SIDE_BY_SIDE.values() for pair in plans.values()]
    better = sum(ours < theirs for ours, theirs in pairs)
    ours_plans = {m: [o for n, (o, _) in p.items() if n.startswith("seeds")] for m, p in SIDE_BY_SIDE.items()}
    theirs_plans = {m: [t for n, (_, t) in p.items() if n.startswith("seeds")] for m, p in SIDE_BY_SIDE.items()}
    first_theirs = [t for n, (_, t) in MARKER_1.items() if n.startswith("seeds")]
    spread = "; ".join(f"{m}: pincal {min(ours_plans[m]):.3f}–{max(ours_plans[m]):.3f}, FIGAROH "
                       f"{min(theirs_plans[m]):.3f}–{max(theirs_plans[m]):.3f} mm" for m in SIDE_BY_SIDE)
    lines += ["", f"- **pincal predicts better in {better} of the {len(pairs)} comparisons**, by "
              f"{min(t / o for o, t in pairs):.2f}–{max(t / o for o, t in pairs):.2f} ×.",
              f"- **A 5-fold × 4 figure on 34 postures depends on the folds** by up to a millimetre: {spread}. Compare "
              "two models or two tools on the same folds (`--cv-seed`).",
              f"- **FIGAROH's figures quoted with the targets (issue 13).** Its three-marker leave-one-out figure, "
              f"{QUOTED_FIGAROH['3 markers'][0]:.3f} mm, is marker 1's alone: FIGAROH's fit to three markers "
              f"predicts marker 1 to {MARKER_1['leave-one-out'][1]:.3f} mm, all three to "
              f"{SIDE_BY_SIDE['3 markers']['leave-one-out'][1]:.3f} mm. Its one-marker leave-one-out figure is "
              f"reproduced ({SIDE_BY_SIDE['1 marker']['leave-one-out'][1]:.3f} mm). Its 5-fold × 4 figures, "
              f"{QUOTED_FIGAROH['1 marker'][1]:.3f} mm (one marker) and {QUOTED_FIGAROH['3 markers'][1]:.3f} mm "
              f"(three, marker 1), were measured on folds not recorded; they lie within FIGAROH's own spread over "
              f"the plans above ({min(theirs_plans['1 marker']):.3f}–{max(theirs_plans['1 marker']):.3f} and "
              f"{min(first_theirs):.3f}–{max(first_theirs):.3f} mm)."]
    return lines


def anatomy(repeats: int = 4) -> dict[str, Any]:
    """What the three markers' 5-fold × ``repeats`` error is made of, with the default command's fit in every fold
    (as ``--cv 5x4``, the same folds): the error of the markers' centroid (the hand's position) and of each marker
    about it (the hand's orientation), each marker's error, and how rigid the markers are in the data (the spread
    of their distances over the 34 postures) [m]."""
    robot = pincal.load_robot("tiago_no_hand")
    dataset = read_robot_dataset(THREE, robot)
    models = measurements_for(robot, list(dataset.measurements), dataset.joint_names, None, dataset.metadata)
    obs = observations_from(robot, dataset.joint_names, dataset.joints, dataset.measurements, models)
    pset = choose_parameters(robot, models)
    n = obs.n_samples
    errors = np.full((repeats, n, len(models), 3), np.nan)  # (repeat, posture, marker, xyz)
    for repeat in range(repeats):
        order = np.random.default_rng(repeat).permutation(n)
        for fold in range(5):
            test = np.sort(order[fold::5])
            fitted = select_and_fit(CalibrationProblem(robot, pset, models, obs.subset(np.setdiff1d(np.arange(n),
                                                                                                      test))),
                                    options=CalibrationOptions().fitting)
            held = CalibrationProblem(robot, fitted.problem.parameters, models, obs.subset(test))
            predicted = held.evaluate(fitted.result.x, jacobian=False).errors
            for k, m in enumerate(models):
                errors[repeat, test, k] = predicted[m.key]
    centroid = errors.mean(axis=2)
    points = [dataset.measurements[m.key] for m in models]
    spreads = [float(np.std(np.linalg.norm(points[a] - points[b], axis=1), ddof=1))
               for a in range(len(points)) for b in range(a + 1, len(points))]
    return {"all": float(np.sqrt(np.mean(np.sum(errors**2, axis=3)))),
            "centroid": float(np.sqrt(np.mean(np.sum(centroid**2, axis=2)))),
            "about_centroid": float(np.sqrt(np.mean(np.sum((errors - centroid[:, :, None]) ** 2, axis=3)))),
            "markers": [float(np.sqrt(np.mean(np.sum(errors[:, :, k] ** 2, axis=2)))) for k in range(len(models))],
            "distance_spread": max(spreads)}


def noise_floor(path: Path, draws: int = 3) -> dict[str, Any]:
    """The default command's 5-fold × 4 error [m] if what the model leaves were noise, independent of the posture:
    the model fitted to all 34 postures predicts each posture; a draw adds to the predictions the fit's residuals of
    postures shuffled at random (each posture's residuals of every marker together, scaled by √(n / (n − p)) for the
    n residuals and p parameters of the fit, as the fit shrinks them), and ``pincal calibrate --cv 5x4`` runs on the
    result. Returns each draw's figure and the measured one."""
    robot = pincal.load_robot("tiago_no_hand")
    dataset = read_robot_dataset(path, robot)
    everything = replace(dataset, sets=np.array(["train"] * dataset.n_samples))
    fitted = calibrate(robot, everything)
    errors = fitted.problem.evaluate(fitted.result.x, jacobian=False).errors
    report = fitted.report.as_dict()
    scale = np.sqrt(report["n_residuals"] / (report["n_residuals"] - report["n_estimated"]))
    figures = []
    for draw in range(draws):
        order = np.random.default_rng(100 + draw).permutation(dataset.n_samples)
        readings = {key: dataset.measurements[key] + errors[key] - scale * errors[key][order]
                    for key in dataset.measurements}
        figures.append(_cv_rms(calibrate(robot, replace(dataset, measurements=readings), cv="5x4").report))
    return {"draws": figures, "fit": report["rms_after"], "scale": float(scale)}


#: The models of the extrapolation test: name, the options of ``pincal calibrate``, the same as keywords.
EXTRAPOLATION: list[tuple[str, str, dict[str, Any]]] = [
    ("the nominal robot, its frame and marker registered", "--parameters 'base.*' 'marker.*'",
     {"parameter_spec": ("base.*", "marker.*")}),
    ("the default command", "", {}),
    ("every identifiable parameter", "--select none", {"select": "none"}),
    ("every identifiable parameter, no prior", "--select none --prior off", {"select": "none", "prior": "off"})]


def extrapolation() -> dict[str, Any]:
    """Calibrated on the one-marker postures whose ``arm_1_joint`` reading lies below its median, tested on the others
    (beyond the range fitted): each model of :data:`EXTRAPOLATION`'s fit and held-out RMS [m]."""
    robot = pincal.load_robot("tiago_no_hand")
    dataset = read_robot_dataset(ONE, robot)
    arm_1 = dataset.joints[:, dataset.joint_names.index("arm_1_joint")]
    median = float(np.median(arm_1))
    split = replace(dataset, sets=np.where(arm_1 < median, "train", "test"))
    rows = []
    for name, words, keywords in EXTRAPOLATION:
        report = calibrate(robot, split, **keywords).report
        rows.append({"model": name, "options": words, "estimated": report.n_estimated,
                     "fit": report.rms_after, "held_out": report.test_rms_after})
    return {"median": median, "n_train": int(np.sum(arm_1 < median)), "n_test": int(np.sum(arm_1 >= median)),
            "rows": rows}


def extrapolation_section(found: dict[str, Any]) -> list[str]:
    """The page's section on predicting beyond the joint range of the fit."""
    rows = found["rows"]
    lines = ["## Beyond the calibrated range", "",
             f"Calibrated on the {found['n_train']} one-marker postures whose `arm_1_joint` reading lies below its "
             f"median ({found['median']:.3f} rad), tested on the {found['n_test']} others, which lie beyond the range "
             "fitted (the file's `set` column rewritten so; measured by this page's command). The nominal robot is "
             "registered on the same training postures (its measurement frame and marker offset fitted). RMS [mm]:",
             "", "| model | estimated | fit | held out (beyond the range) | options of `pincal calibrate` |",
             "|---|---|---|---|---|"]
    for r in rows:
        lines.append(f"| {r['model']} | {r['estimated']} | {_mm(r['fit'])} | {_mm(r['held_out'])} | "
                     f"{'`' + r['options'] + '`' if r['options'] else '(none)'} |")
    nominal, default, every, bare = (r["held_out"] for r in rows)
    worse = default > nominal * (1 + SAME)
    lines += ["", f"- **The default command {'predicts worse than' if worse else 'predicts no worse than'} the nominal "
              f"robot** beyond the range it was calibrated on: {_mm(default)} against {_mm(nominal)} mm.",
              f"- **With every identifiable parameter, the prior {'helps' if every < bare else 'does not help'} "
              f"where the data do not reach**: {_mm(every)} mm with it, {_mm(bare)} mm by least squares "
              f"({bare / every:.2f} ×)."]
    return lines


def _cv(rows: list[dict[str, Any]], markers: str, model: str) -> float | None:
    found = [r["cv"] for r in rows if r["markers"] == markers and r["model"] == model]
    return found[0] if found else None


def limits(rows: list[dict[str, Any]], parts: dict[str, Any] | None = None,
           floors: dict[str, Any] | None = None) -> list[str]:
    """What the figures say about what limits the result, each sentence from the table's numbers (and from
    :func:`anatomy`'s and :func:`noise_floor`'s, when measured)."""
    fits = [r["fit"] for r in rows]
    ratios = [r["sigma_ratio"] for r in rows]
    out = [f"- **What remains is not the mocap's noise.** The models fit {min(fits) * 1e3:.1f}–{max(fits) * 1e3:.1f} "
           f"mm, {min(ratios):.1f}–{max(ratios):.1f} × the stated 1 mm, far above a mocap's tenths of a millimetre: "
           "it is the robot's, and not in these models."]
    default, every = "geometric (default)", "geometric, every identifiable parameter"
    for markers, floor in (floors or {}).items():
        measured, draws = _cv(rows, markers, default), floor["draws"]
        if measured is None:
            continue
        noise = floor["fit"] * floor["scale"]
        above = measured > max(draws)
        out.append(
            f"- **{markers}: {'above' if above else 'at'} the floor of a random error.** If what the default model "
            f"leaves were a random error of each posture, unrelated to the posture (as the repeatability of a "
            f"posture, or backlash taken up in either direction), of the size the fit leaves "
            f"({noise * 1e3:.2f} mm RMS), the "
            f"default command's 5-fold × 4 would give {min(draws) * 1e3:.3f}–{max(draws) * 1e3:.3f} mm "
            f"({len(draws)} draws: the fit to all 34 postures plus its residuals shuffled across postures, "
            f"`noise_floor` in examples/tiago_mocap.py); measured: {_mm(measured)} mm. "
            + ("The excess is tied to the postures: a model these parameters lack could lower it, toward that floor, "
               "not below it." if above else
               "For prediction, what remains behaves as that random error: no model fitted to 34 postures can "
               "learn it, and a perfect model would still miss each posture by the error itself, about "
               f"{noise * 1e3:.1f} mm."))
    for markers in ("1 marker", "3 markers"):
        base, full = _cv(rows, markers, default), _cv(rows, markers, every)
        extras = [(m, _cv(rows, markers, m)) for m in ("geometric + harmonics", "geometric + compliance")]
        if base is None or full is None:
            continue
        said = ", ".join(f"{m.split('+ ')[1]} {_mm(v)}" for m, v in extras if v is not None)
        effect = "lowers" if base < (1 - SAME) * full else "raises" if base > (1 + SAME) * full else "does not change"
        out.append(f"- **{markers}:** model selection {effect} the "
                   f"cross-validated error ({_mm(base)} against {_mm(full)} mm with every identifiable parameter); "
                   f"with the non-geometric parameters (selection on): {said} mm.")
    one, three = _cv(rows, "1 marker", default), _cv(rows, "3 markers", default)
    if one is not None and three is not None and three > one:
        out.append(f"- **Three markers predict worse than one** ({_mm(three)} against {_mm(one)} mm, every marker "
                   "reading counted).")
    if parts is not None and one is not None:
        markers = ", ".join(f"m{k + 1} {_mm(v)}" for k, v in enumerate(parts["markers"]))
        out += [f"- **The three markers are one rigid body in the data.** Their distances vary by "
                f"{parts['distance_spread'] * 1e6:.2f} µm (largest standard deviation over the 34 postures): they "
                "behave as the markers of a rigid body fitted by the mocap software, so three markers are one "
                "measured pose of the hand, not three points measured independently; their noise is that of one "
                "pose.",
                f"- **What the three markers' error is made of** (default command, the `--cv 5x4` folds): "
                f"{_mm(parts['all'])} mm in all; the markers' centroid, the hand's position, {_mm(parts['centroid'])} "
                f"mm; each marker about the centroid, the hand's orientation, {_mm(parts['about_centroid'])} mm. Per "
                f"marker: {markers} mm."]
        if parts["markers"][0] > one:
            out.append(f"- **Marker 1 is predicted worse when the fit also sees markers 2 and 3** "
                       f"({_mm(parts['markers'][0])} against {_mm(one)} mm alone), although the hand's orientation "
                       "they add is itself predicted to about a millimetre: fitting it with the same geometric "
                       "parameters pulls them away from what predicts the hand's position. What the geometric model "
                       "cannot follow there is not in these models.")
    out.append("- **Not modelled here:** the base's suspension, one of the effects FIGAROH's authors modelled on this "
               "robot.")
    return out


def run(quick: bool, out: Path, executor: str | None = None) -> dict[str, Any]:
    """Measure every case, write the page, return the numbers."""
    start = time.perf_counter()
    rows = [measure(case, quick) for case in cases(quick)]
    parts = None if quick else anatomy()
    floors = None if quick else {"1 marker": noise_floor(ONE, 5), "3 markers": noise_floor(THREE, 5)}
    beyond = extrapolation()
    seconds = time.perf_counter() - start
    out.mkdir(parents=True, exist_ok=True)
    (out / "tiago_mocap.md").write_text(page(rows, seconds, quick, parts, floors, beyond), encoding="utf-8")
    for r in rows:
        print(f"{r['markers']:<10}{r['model']:<42} estimated {r['estimated']:>3}  fit {_mm(r['fit'])}  held out "
              f"{_mm(r['held_out'])}  loo {_mm(r['loo'])}  {r['cv_plan']} {_mm(r['cv'])} mm  ({r['seconds']:.0f} s)")
    return {"rows": rows, "anatomy": parts, "noise_floor": floors, "extrapolation": beyond, "seconds": seconds}


def main(argv: list[str] | None = None) -> dict[str, Any]:
    return study_main(run, __doc__, "one case, 5 folds once (seconds)", argv)


if __name__ == "__main__":
    main(sys.argv[1:])
