"""Model selection: the default command against ``--select bic`` and ``--select cv``, in held-out error and time.

Run: ``python examples/selection.py`` (about ten minutes) or ``--quick`` (seconds: the TIAGo file with one shuffle of
five folds, one camera campaign of one seed, one timing each). Writes ``selection.md`` under ``results/`` (``--out
DIR`` elsewhere, ``--publish`` for ``docs/results``, ``--json`` for the numbers).

Issue 37, item 5: the default model selection (the evidence, each group held as firmly as it says, with the range
guard: docs/predicted_accuracy.md) loses to neither BIC nor ``--select cv`` by more than 3 % in held-out error on the
project's benchmarks, at no more than twice the time of the default before issue 37 (``--select bic --prior 1``,
:data:`extrapolation.BEFORE`); and the σ it estimates per measurement kind and axis is reported. Four models, each
fitted by :func:`pincal.calibration.calibrate` as ``pincal calibrate`` fits it:

- **default**: no option; **bic**: ``--select bic`` (the default prior, each kept group held by the evidence's
  factor); **cv**: ``--select cv``; **before**: ``--select bic --prior 1``.

Benchmarks, each with its held-out error:

- **TIAGo, one marker** (``examples/data/tiago_mocap_marker1.csv``) and the **TALOS table contact** (the left and right
  arm's job files): the cross-validated RMS (``--cv 5x4``: every model refitted, its selection included, in each of
  five folds of four shuffles; plane distances for TALOS).
- **Simulated cameras**: the pixel campaigns of ``examples/pixels_handeye.py`` (UR10 eye-in-hand, Panda eye-to-hand,
  seeds 1–3), their held-out error as that page defines it (the camera's position in the board's frame at the held-out
  postures against the truth), pooled over the seeds.

Each benchmark also once without its ``# sigma`` line, so that the default estimates σ (the camera campaigns'
simulated noise is known: 0.3 px on both axes).

CPU time: :func:`time.process_time` around each fit (no cross-validation), one BLAS thread; the default's and
before's the median of :data:`REPEATS` fits.
"""

from __future__ import annotations

import re
import statistics
import sys
import time
from dataclasses import dataclass, replace
from pathlib import Path
from typing import Any

import numpy as np
from extrapolation import BEFORE
from pixels_handeye import CASES, N_TEST, N_TRAIN, NOISE, PERTURB, SEEDS, camera_in_board, on, position_errors
from study_cli import ROOT, study_main
from threadpoolctl import threadpool_limits

import pincal
from pincal.calibration import CalibrationOptions, calibrate
from pincal.calibration.from_files import read_inputs
from pincal.calibration.pipeline import Calibration
from pincal.calibration.pixel_campaign import simulate_pixels
from pincal.identification.measurements import pixel
from pincal.io.dataset import Dataset

#: The models compared: name -> its options of ``pincal calibrate`` (over a job file's) and the flags that give them.
MODELS: dict[str, tuple[CalibrationOptions, str]] = {
    "default": (CalibrationOptions(), ""),
    "bic": (CalibrationOptions(select="bic"), "--select bic"),
    "cv": (CalibrationOptions(select="cv"), "--select cv"),
    "before": (BEFORE, f"--select {BEFORE.select} --prior {BEFORE.prior:g}"),
}
#: Item 5's targets: the default's held-out error no more than this above the better of bic and cv; its CPU time no
#: more than this many times before's.
LOSS, TIME = 0.03, 2.0
#: Fits timed per benchmark for the default and before (page, --quick): per camera seed, per real file (whose fits
#: take tenths of a second); the median counts.
REPEATS, REAL_REPEATS, QUICK_REPEATS = 3, 11, 1
#: Cross-validation plan of the real files (page, --quick).
PLAN, QUICK_PLAN = "5x4", "5"
#: The pixel model's default σ [px]: pincal.calibration.noise never takes an estimate below a model's default.
PIXEL_DEFAULT = pixel("tool0", 0).sigma
#: The real files: (name, ROBOT or job file, DATA or None).
REAL: tuple[tuple[str, str, str | None], ...] = (
    ("TIAGo, one marker (34 postures)", "tiago_no_hand", "examples/data/tiago_mocap_marker1.csv"),
    ("TALOS, left arm on the table (21 rows)", "examples/data/talos_table_contact/left_job.toml", None),
    ("TALOS, right arm on the table (29 rows)", "examples/data/talos_table_contact/right_job.toml", None))


@dataclass
class Bench:
    """One benchmark's figures: per model the held-out RMS [m] and CPU time [s]; the σ the default estimated; what
    each selection left out; the fold fits that failed; the command."""

    name: str
    command: str
    held: dict[str, float | None]
    cpu: dict[str, float]
    sigma: str
    left_out: dict[str, str]
    failed: dict[str, int]
    floored: bool = False
    failures: dict[str, list[str]] | None = None

    @property
    def loss(self) -> float | None:
        """The default's held-out RMS over the better of bic's and cv's, minus 1 (None without the figures)."""
        best = [v for k, v in self.held.items() if k in ("bic", "cv") and v is not None]
        default = self.held["default"]
        return None if default is None or not best else default / min(best) - 1.0

    @property
    def ratio(self) -> float:
        """The default's CPU time over before's."""
        return self.cpu["default"] / self.cpu["before"]


def without_sigma(dataset: Dataset) -> Dataset:
    """``dataset`` without its ``# sigma`` lines: the default then estimates σ from the data."""
    return replace(dataset, metadata={k: v for k, v in dataset.metadata.items() if not k.startswith("sigma")})


def stated(dataset: Dataset) -> str:
    """The data's ``# sigma`` lines, as a note."""
    lines = [f"`# {k}: {v}`" for k, v in dataset.metadata.items() if k.startswith("sigma")]
    return "stated: " + ", ".join(lines) if lines else "—"


def with_model(base: CalibrationOptions, model: str) -> CalibrationOptions:
    """``base`` (a job file's options) with the selection and prior of ``model``."""
    chosen = MODELS[model][0]
    return base.replace(select=chosen.select, prior=chosen.prior)


def timed(robot: pincal.Robot, dataset: Dataset, options: CalibrationOptions) -> tuple[Calibration, float]:
    """A calibration and the CPU time it took [s]."""
    start = time.process_time()
    cal = calibrate(robot, dataset, options)
    return cal, time.process_time() - start


def fits(robot: pincal.Robot, dataset: Dataset, base: CalibrationOptions,
         repeats: int) -> tuple[dict[str, Calibration], dict[str, float]]:
    """Each model's calibration of ``dataset`` and its CPU time [s] (the default's and before's the median of
    ``repeats``, alternated)."""
    cals, seconds = {}, {}
    times: dict[str, list[float]] = {"default": [], "before": []}
    for _ in range(repeats):
        for model in times:
            cals[model], spent = timed(robot, dataset, with_model(base, model))
            times[model].append(spent)
    for model in ("bic", "cv"):
        cals[model], seconds[model] = timed(robot, dataset, with_model(base, model))
    seconds.update({model: statistics.median(spent) for model, spent in times.items()})
    return cals, seconds


def left_out(cal: Calibration) -> str:
    """The groups selection left out, or —."""
    selection = cal.report.selection
    return ", ".join(selection.removed_groups) if selection is not None and selection.removed_groups else "—"


def _unit(unit: str) -> tuple[float, str]:
    return {"m": (1e3, "mm"), "rad": (1e3, "mrad")}.get(unit, (1.0, unit))


def sigma_text(cals: list[Calibration], given: str) -> str:
    """The σ the default estimated per measurement kind and axis (over the keys of a kind, e.g. a board's corners,
    and the calibrations given: their range), else the data's stated σ ``given``."""
    found: dict[tuple[str, str, str], list[float]] = {}
    for cal in cals:
        for key, sigma in (cal.report.estimated_sigma or {}).items():
            kind = re.sub(r"@[0-9]+$", "", key)
            for row, value in sigma.rows.items():
                found.setdefault((kind, row, sigma.units.get(row, "")), []).append(value)
    if not found:
        return given
    parts: dict[str, list[str]] = {}
    for (kind, row, unit), values in found.items():
        scale, shown = _unit(unit)
        low, high = min(values) * scale, max(values) * scale
        figure = f"{low:.3g}" if f"{low:.3g}" == f"{high:.3g}" else f"{low:.3g}–{high:.3g}"
        parts.setdefault(kind, []).append(f"{row} {figure} {shown}")
    return "; ".join(f"`{kind}` {', '.join(rows)}" for kind, rows in parts.items())


def run_real(name: str, robot_or_job: str, data: str | None, plan: str, repeats: int, quick: bool) -> list[Bench]:
    """A real file: each model's cross-validated RMS (``plan``) and CPU time of the fit as the command runs it; and
    again without the file's ``# sigma`` lines, if it has any (not ``quick``)."""
    inputs = read_inputs("calibrate", str(ROOT / robot_or_job) if robot_or_job.endswith(".toml") else robot_or_job,
                         str(ROOT / data) if data else None)
    base = inputs.options.replace(cv=None)
    variants = [False, True] if not quick and any(k.startswith("sigma") for k in inputs.dataset.metadata) else [False]
    out = []
    for unstated in variants:
        dataset = without_sigma(inputs.dataset) if unstated else inputs.dataset
        cals, seconds = fits(inputs.robot, dataset, base, repeats)
        held: dict[str, float | None] = {}
        failed, failures = {}, {}
        for model in MODELS:
            cv = calibrate(inputs.robot, dataset, with_model(base, model).replace(cv=plan)).report.cv
            assert cv is not None
            held[model], failed[model], failures[model] = cv.rms, len(cv.failed_folds), list(cv.failed_folds)
        command = f"pincal calibrate {robot_or_job}{' ' + data if data else ''}"
        if unstated:
            command = (f"grep -v '^# sigma' {data} > nosigma.csv && pincal calibrate {robot_or_job} nosigma.csv"
                       if data else command + " (its data without `# sigma` lines)")
        out.append(Bench(name + (", σ unstated" if unstated else ""), f"{command} --cv {plan}", held, seconds,
                         sigma_text([cals["default"]], stated(dataset)), {m: left_out(c) for m, c in cals.items()},
                         failed, failures=failures))
    return out


def run_camera(case: tuple[str, str, str, bool], seed: int, unstated: bool, repeats: int) -> dict[str, Any]:
    """One pixel campaign of ``examples/pixels_handeye.py``: each model's held-out errors [m] of the camera's position
    in the board's frame, CPU time [s], what its selection left out, and the default's calibration."""
    _, robot_name, frame, eye_to_hand = case
    robot = pincal.load_robot(robot_name)
    sim = simulate_pixels(robot, frame, N_TRAIN, N_TEST, eye_to_hand=eye_to_hand, perturb=PERTURB, noise=NOISE,
                          seed=seed)
    dataset = without_sigma(sim.dataset) if unstated else sim.dataset
    test = dataset.of_set("test")
    truth = camera_in_board(robot, sim.parameters, sim.x_true, frame, eye_to_hand, test.joints)
    cals, seconds = fits(robot, dataset, CalibrationOptions(), repeats)
    errors = {}
    for model, cal in cals.items():
        x = on(sim.parameters, dict(zip(cal.result.names, cal.result.x.tolist(), strict=True)))
        errors[model] = position_errors(truth, camera_in_board(robot, sim.parameters, x, frame, eye_to_hand,
                                                                test.joints))
    return {"seed": seed, "errors": errors, "cpu": seconds, "left_out": {m: left_out(c) for m, c in cals.items()},
            "default": cals["default"], "stated": stated(dataset)}


def camera_bench(case: tuple[str, str, str, bool], seeds: tuple[int, ...], unstated: bool,
                 repeats: int) -> tuple[Bench, list[dict[str, Any]]]:
    """A camera case over ``seeds``: the held-out errors pooled (RMS over every seed's held-out postures), the CPU
    times summed; and the per-seed runs."""
    runs = [run_camera(case, seed, unstated, repeats) for seed in seeds]
    held: dict[str, float | None] = {
        m: float(np.sqrt(np.mean(np.concatenate([r["errors"][m] for r in runs]) ** 2))) for m in MODELS}
    cpu = {m: float(sum(r["cpu"][m] for r in runs)) for m in MODELS}
    name = f"{case[0]}, seed{'s' if len(seeds) > 1 else ''} {', '.join(map(str, seeds))}"
    name += ", σ unstated" if unstated else ""
    sigma = sigma_text([r["default"] for r in runs], runs[0]["stated"])
    estimates = [v for r in runs for each in (r["default"].report.estimated_sigma or {}).values()
                 for v in each.rows.values()]
    if unstated:
        sigma += f" (simulated: {NOISE:g} px on both axes)"
    for r in runs:  # the calibrations are not needed beyond here (nor JSON-able)
        del r["default"]
    bench = Bench(name, "`python examples/selection.py --publish` (library: `simulate_pixels`, then `calibrate`)",
                  held, cpu, sigma, {}, dict.fromkeys(MODELS, 0),
                  floored=bool(estimates) and all(abs(v - PIXEL_DEFAULT) < 1e-12 for v in estimates))
    return bench, runs


def _mm(value: float | None) -> str:
    return "–" if value is None else f"{value * 1e3:.3f}"


def _seconds(value: float) -> str:
    """A CPU time [s] to two digits (1.0, not 1)."""
    return f"{value:#.2g}".rstrip(".")


def _loss_cell(b: Bench) -> str:
    loss = b.loss
    if loss is None:
        return "– | –"
    return f"{100 * loss:+.1f} % | {'met' if loss <= LOSS else 'NOT met'}"


def table(benches: list[Bench]) -> list[str]:
    """One row per benchmark: held-out RMS, the default's loss and its judgment, CPU times and their ratio."""
    lines = ["| benchmark | held-out RMS [mm]: default / bic / cv / before | default against the better of bic and cv "
             f"| loss ≤ {100 * LOSS:.0f} % | CPU [s]: default / before / bic / cv | default / before "
             f"| ≤ {TIME:g}× |",
             "|---|---|---|---|---|---|---|"]
    for b in benches:
        failed = [f"{m} {n}" for m, n in b.failed.items() if n]
        note = f" (fold fits failed: {', '.join(failed)})" if failed else ""
        lines.append(f"| {b.name} | " + " / ".join(_mm(b.held[m]) for m in MODELS) + note + f" | {_loss_cell(b)} | "
                     + " / ".join(_seconds(b.cpu[m]) for m in ("default", "before", "bic", "cv"))
                     + f" | {b.ratio:.2f} | {'met' if b.ratio <= TIME else 'NOT met'} |")
    return lines


def sigma_table(benches: list[Bench]) -> list[str]:
    lines = ["| benchmark | σ the default estimated, per measurement kind and axis (else the data's stated σ) |",
             "|---|---|"]
    return lines + [f"| {b.name} | {b.sigma} |" for b in benches]


def verdicts(benches: list[Bench]) -> list[str]:
    """The sentences that judge item 5's two goals, computed from the figures."""
    judged = [b for b in benches if b.loss is not None]
    lost = [b for b in judged if b.loss is not None and b.loss > LOSS]
    slow = [b for b in benches if b.ratio > TIME]
    worst = max(judged, key=lambda b: b.loss or 0.0) if judged else None
    out = []
    if worst is not None and worst.loss is not None:
        out.append(f"- **Held-out error: {'met' if not lost else 'NOT met'}.** The default loses by more than "
                   f"{100 * LOSS:.0f} % to the better of bic and cv on {len(lost)} of {len(judged)} benchmarks"
                   + (f" ({'; '.join(f'{b.name}: {100 * (b.loss or 0):+.1f} %' for b in lost)})" if lost else "")
                   + f"; the largest difference is {100 * worst.loss:+.1f} % ({worst.name}).")
    ratios = [b.ratio for b in benches]
    out.append(f"- **Time: {'met' if not slow else 'NOT met'}.** The default's CPU time is "
               f"{min(ratios):.2f}–{max(ratios):.2f}× before's (`--select bic --prior 1`); above {TIME:g}× on "
               f"{len(slow)} of {len(benches)} benchmarks" + (f" ({', '.join(b.name for b in slow)})" if slow else "")
               + ".")
    firmer = [b for b in benches if b.held["before"] is not None and b.held["default"] is not None
              and b.held["before"] < b.held["default"]]
    out.append(f"- Before (`--select bic --prior 1`) predicts better than the default on {len(firmer)} of "
               f"{len(benches)} benchmarks" + (f" ({', '.join(b.name for b in firmer)})" if firmer else "") + ".")
    cv_ratio = [b.cpu["cv"] / b.cpu["before"] for b in benches]
    out.append(f"- `--select cv` takes {min(cv_ratio):.1f}–{max(cv_ratio):.1f}× before's CPU time.")
    return out


def failures(benches: list[Bench]) -> list[str]:
    """Per benchmark whose cross-validation lost fold fits: which folds, whether the same for every model, and the
    first one's reason."""
    out = []
    for b in benches:
        lost = {m: [f.split(":")[0] for f in fs] for m, fs in (b.failures or {}).items() if fs}
        if not lost:
            continue
        first = next(fs[0] for fs in (b.failures or {}).values() if fs)
        same = len(lost) == len(MODELS) and all(folds == lost["default"] for folds in lost.values())
        out.append(f"- {b.name}: " + (f"the fold fits that failed ({'; '.join(lost['default'])}) are the same for "
                                      "every model, so every figure of the row leaves out the same predictions"
                                      if same else "the fold fits that failed are not the same for every model")
                   + f"; the first's reason: \"{first.split(': ', 1)[1]}\".")
    return ["", *out] if out else []


def told(benches: list[Bench]) -> list[str]:
    """Per benchmark run with and without its ``# sigma`` lines: the default's held-out RMS each way, computed."""
    by_name = {b.name: b for b in benches}
    out = []
    for b in benches:
        given = by_name.get(b.name.removesuffix(", σ unstated")) if b.name.endswith(", σ unstated") else None
        if given is None or b.held["default"] is None or given.held["default"] is None:
            continue
        change = b.held["default"] / given.held["default"] - 1.0
        out.append(f"- {given.name}: without its `# sigma` lines the default's held-out RMS is "
                   f"{_mm(b.held['default'])} mm, against {_mm(given.held['default'])} mm when the data state σ "
                   f"({100 * change:+.1f} %); the two runs differ only in the σ the data are weighed by.")
    return out


def seed_table(runs: dict[str, list[dict[str, Any]]]) -> list[str]:
    lines = ["| campaign | seed | held-out RMS [mm]: default / bic / cv / before | left out by selection: default / "
             "bic / cv / before | CPU [s]: default / before / bic / cv |", "|---|---|---|---|---|"]
    for name, rs in runs.items():
        for r in rs:
            rms = {m: float(np.sqrt(np.mean(r["errors"][m] ** 2))) for m in MODELS}
            lines.append(f"| {name} | {r['seed']} | " + " / ".join(_mm(rms[m]) for m in MODELS) + " | "
                         + " / ".join(r["left_out"][m] for m in MODELS) + " | "
                         + " / ".join(_seconds(r["cpu"][m]) for m in ("default", "before", "bic", "cv")) + " |")
    return lines


def page(real: list[Bench], cameras: list[Bench], runs: dict[str, list[dict[str, Any]]], seconds: float,
         quick: bool, plan: str, repeats: tuple[int, int]) -> str:
    benches = real + cameras
    flags = "; ".join(f"**{m}**: `pincal calibrate …{' ' + f if f else ''}`" for m, (_, f) in MODELS.items())
    lines = ["# Model selection: the default against BIC and `--select cv`", "",
             f"Command: `python examples/selection.py{' --quick' if quick else ''} --publish`. "
             f"This page is written by that script; the run that wrote it took {seconds:.0f} s"
             + (" (**a quick run**: fewer benchmarks, folds and timings than the full page)" if quick else "")
             + ". Every comparing sentence below is computed by it.", "",
             "Issue 37, item 5: the default model selection (the evidence, with the range guard: "
             "docs/predicted_accuracy.md) should lose to neither BIC nor `--select cv` by more than "
             f"{100 * LOSS:.0f} % in held-out error on the project's benchmarks, at no more than {TIME:g}× today's "
             f"time (the default before issue 37, `--select bic --prior 1`). Models: {flags}.", "",
             f"Held-out error [mm]: for the real files, the cross-validated RMS (`--cv {plan}`: every model refitted, "
             "its selection included, in each fold; position errors of the TIAGo marker, plane distances for TALOS); "
             "for the simulated cameras, the camera's position in the board's frame at the held-out postures against "
             f"the truth, as docs/results/pixels_handeye.md defines it ({N_TRAIN} images fitted, {N_TEST} held out), "
             "pooled over the seeds. *σ unstated*: the same data without their `# sigma` lines, so that the default "
             "estimates σ per measurement kind and axis. CPU time: `time.process_time()` around each fit without "
             f"cross-validation, one BLAS thread; the default's and before's the median of {repeats[0]} "
             f"fit{'s' if repeats[0] > 1 else ''} of a real file, of {repeats[1]} fit{'s' if repeats[1] > 1 else ''} "
             "of a camera seed, summed over the seeds of a camera case (CPU times depend on the machine; their "
             "ratio is the figure).", "",
             *table(benches), "", *verdicts(benches), "",
             "## σ per measurement kind and axis", "",
             "What the default reports in `estimated_sigma` (`pincal calibrate --report`), per measurement kind and "
             "axis; over a board's corners and a case's seeds, the range:", "",
             *sigma_table(benches), ""]
    lines += told(benches)
    floor = [b.name for b in cameras if b.floored]
    if floor:
        lines += [f"- {'; '.join(floor)}: every estimate is {PIXEL_DEFAULT:g} px, where the simulated noise is "
                  f"{NOISE:g} px: {PIXEL_DEFAULT:g} px is the pixel model's default σ, below which "
                  "`pincal.calibration.noise` never takes an estimate."]
    lines += ["", "## Commands and what each selection left out", "",
              "| benchmark | command (plus the model's options) | left out: default / bic / cv / before |",
              "|---|---|---|"]
    lines += [f"| {b.name} | `{b.command}` | " + " / ".join(b.left_out[m] for m in MODELS) + " |" for b in real]
    lines += failures(real)
    if runs:
        lines += ["", "## Camera campaigns per seed", "", *seed_table(runs)]
    return "\n".join(lines) + "\n"


def run(quick: bool, out: Path, executor: str | None = None) -> dict[str, Any]:
    start = time.perf_counter()
    real_repeats, repeats = (QUICK_REPEATS, QUICK_REPEATS) if quick else (REAL_REPEATS, REPEATS)
    plan = QUICK_PLAN if quick else PLAN
    with threadpool_limits(limits=1):
        real = [b for entry in (REAL[:1] if quick else REAL)
                for b in run_real(*entry, plan, real_repeats, quick)]
        cameras, runs = [], {}
        for unstated in (False,) if quick else (False, True):
            for case in CASES[:1] if quick else CASES:
                bench, seeds = camera_bench(case, SEEDS[:1] if quick else SEEDS, unstated, repeats)
                cameras.append(bench)
                runs[bench.name] = seeds
    seconds = time.perf_counter() - start
    out.mkdir(parents=True, exist_ok=True)
    text = page(real, cameras, runs, seconds, quick, plan, (real_repeats, repeats))
    (out / "selection.md").write_text(text, encoding="utf-8")
    return {"benchmarks": [vars(b) | {"loss": b.loss, "ratio": b.ratio} for b in real + cameras],
            "seconds": seconds}


def main(argv: list[str] | None = None) -> dict[str, Any]:
    return study_main(run, __doc__, "the TIAGo file with --cv 5 and one camera campaign of one seed, timed once", argv)


if __name__ == "__main__":
    main(sys.argv[1:])
