"""Real data: TALOS presses its gripper flush onto a table, joint readings only (no external sensor).

Run: ``python examples/talos_table_contact.py`` (about a minute) or ``--quick`` (seconds: the left arm's default
command, 5 folds once). Writes ``talos_table_contact.md`` under ``results/`` (``--out DIR`` elsewhere, ``--publish``
for ``docs/results``, ``--json`` for the numbers).

Every figure is what ``pincal calibrate`` prints for the job files beside the data
(``examples/data/talos_table_contact/{left,right}_job.toml``), with the parameters and ``--cv`` of each line: the
held-out rows' plane residuals before (the nominal robot, the plane fitted to the training contacts) and after, and
the 5-fold × 4 cross-validated residuals (every fold refits everything without its rows).
"""

from __future__ import annotations

import sys
import time
from dataclasses import dataclass
from pathlib import Path
from typing import Any

from study_cli import ROOT, study_main

from pincal.calibration.job import Job, load_job_robot, read_job
from pincal.calibration.job_data import job_dataset
from pincal.calibration.pipeline import calibrate
from pincal.calibration.report import CalibrationReport

DATA = ROOT / "examples" / "data" / "talos_table_contact"
SIDES = ("left", "right")
#: The lines of each arm's table: what is estimated, and the ``--parameters`` that say it (None: the default set).
MODELS: dict[str, tuple[str, ...] | None] = {
    "the plane alone (the nominal robot)": ("plane.*",),
    "joint offsets and the plane": ("*.offset", "plane.*"),
    "default set": None,
}
#: The cross-validation of the page, and of ``--quick``.
CV, QUICK_CV = "5x4", "5x1"


@dataclass(frozen=True)
class Line:
    """One line of an arm's table: the figures ``pincal calibrate`` printed for it [m, rad]."""

    side: str
    model: str
    command: str
    report: CalibrationReport
    seconds: float

    def figures(self) -> dict[str, Any]:
        """The line's figures [m, rad]: held-out before and after, cross-validated, counts."""
        r, cv = self.report, self.report.cv
        return {"side": self.side, "model": self.model, "command": self.command, "n_fitted": r.n_samples,
                "n_held_out": r.n_test_samples, "n_parameters": r.n_parameters, "n_identifiable": r.n_identifiable,
                "held_distance": (r.test_rms_before, r.test_rms_after),
                "held_tilt": (r.test_rms_angle_before, r.test_rms_angle_after),
                "cv_distance": cv.rms if cv else None, "cv_tilt": cv.rms_angle if cv else None,
                "cv_plan": cv.plan if cv else None, "cv_failed": len(cv.failed_folds) if cv else 0,
                "cv_predictions": cv.n_predictions if cv else None}


def job_path(side: str) -> Path:
    """The job file of one arm."""
    return DATA / f"{side}_job.toml"


def command(side: str, parameters: tuple[str, ...] | None, cv: str) -> str:
    """The ``pincal calibrate`` command of a line."""
    words = " ".join(f"'{p}'" for p in parameters or ())
    return (f"pincal calibrate {job_path(side).relative_to(ROOT)}" + (f" --parameters {words}" if words else "")
            + f" --cv {cv}")


def run_line(job: Job, side: str, model: str, parameters: tuple[str, ...] | None, cv: str) -> Line:
    """Calibrate one line as the command does: the job's robot, data and options, the line's parameters and cv."""
    robot = load_job_robot(job)
    options = job.options.over({"cv": cv, "parameter_spec": list(parameters) if parameters else None}).calibration
    start = time.perf_counter()
    report = calibrate(robot, job_dataset(job, robot), options).report
    return Line(side, model, command(side, parameters, cv), report, time.perf_counter() - start)


def mm(value: float | None, digits: int = 1) -> str:
    """A length [m] in mm, to 0.1 mm (``digits`` decimals)."""
    return "–" if value is None else f"{value * 1e3:.{digits}f}"


def mrad(value: float | None) -> str:
    """An angle [rad] in mrad, to 0.1 mrad."""
    return "–" if value is None else f"{value * 1e3:.1f}"


def ratio(before: float, after: float) -> str:
    """How many times smaller ``after`` is than ``before``, to 0.1 (what the rounded figures show)."""
    return f"{round(before * 1e3, 1) / round(after * 1e3, 1):.1f}"


def table(lines: list[Line]) -> list[str]:
    """An arm's table, one row per line."""
    rows = ["| estimated | parameters (identifiable) | held-out distance RMS [mm] before → after | held-out tilt RMS "
            "[mrad] before → after | cross-validated distance / tilt RMS [mm / mrad] |",
            "|---|---|---|---|---|"]
    for line in lines:
        f = line.figures()
        failed = f" ({f['cv_failed']} fold fits failed)" if f["cv_failed"] else ""
        rows.append(f"| {line.model} | {f['n_parameters']} ({f['n_identifiable']}) | "
                    f"{mm(f['held_distance'][0])} → {mm(f['held_distance'][1])} | "
                    f"{mrad(f['held_tilt'][0])} → {mrad(f['held_tilt'][1])} | "
                    f"{mm(f['cv_distance'])} / {mrad(f['cv_tilt'])}{failed} |")
    return rows


def verdict(lines: list[Line]) -> list[str]:
    """The comparing sentences of an arm, computed from its lines."""
    plane = lines[0].figures()
    out = []
    for line in lines[1:]:
        f = line.figures()
        held, cv, alone = f["held_distance"], f["cv_distance"], plane["cv_distance"]
        out.append(f"- {line.model}: the held-out distance RMS goes from {mm(held[0])} to {mm(held[1])} mm "
                   f"({ratio(held[0], held[1])}× smaller); cross-validated, {mm(cv)} mm against {mm(alone)} mm "
                   f"with the plane alone ({ratio(alone, cv)}× smaller), the tilts {mrad(f['cv_tilt'])} against "
                   f"{mrad(plane['cv_tilt'])} mrad.")
    shown = {line.model: round(line.figures()["cv_distance"] * 1e4) for line in lines}  # [0.1 mm], as printed
    best = [model for model, figure in shown.items() if figure == min(shown.values())]
    smallest = mm(min(shown.values()) * 1e-4)
    out.append(f"- Cross-validated, the smallest distance RMS is that of {best[0]} ({smallest} mm)." if len(best) == 1
               else f"- Cross-validated, {' and '.join(best)} share the smallest distance RMS to 0.1 mm "
                    f"({smallest} mm).")
    return out


def residuals(lines: list[Line]) -> list[str]:
    """What the fits leave on their own rows, and what they cannot see, per line."""
    out = ["What each fit leaves on its own (fitted) rows, and the candidates it cannot see (the analysis lists their "
           "combinations as unidentifiable; the fit does not move them):", ""]
    for line in lines:
        r = line.report
        out.append(f"- {line.side} arm, {line.model}: distance RMS {mm(r.rms_after, 2)} mm, tilt RMS "
                   f"{mrad(r.rms_angle_after)} mrad; {r.n_parameters - r.n_identifiable} of {r.n_parameters} "
                   "candidates unseen.")
    return out


def page(lines: list[Line], cv: str) -> str:
    """The results page."""
    text = ["# TALOS table contact: calibration from joint readings alone", "",
            "Written by `python examples/talos_table_contact.py --publish` (every figure and every comparing sentence "
            "below is computed by it; lengths rounded to 0.1 mm, angles to 0.1 mrad, the fits' own residuals to "
            "0.01 mm).", "",
            "The data: the public TALOS campaign of thanhndv212/figaroh-examples (commit 4aeca84; "
            "`examples/data/talos_table_contact/README.md`). TALOS stands on both feet and presses a rigid gripper "
            "flush onto a flat table at numbered spots; nothing else is measured. Each row says that the gripper's "
            "frame lies on the table plane with its z axis along the plane's normal: a `plane` measurement, three "
            "equations per row (the distance and two tilts, read as 0), the table's offset and tilts estimated with "
            "the robot from the plane fitted to the nominal contact points.", "",
            "The chain: the plane is fixed relative to the left sole (`left_sole_link`: both feet stand, the left one "
            "is taken as the base), so the contact is predicted through the left leg, the torso and the arm to the "
            "gripper (`gripper_left_base_link` or `gripper_right_base_link`, whose contact frame on the gripper is "
            "estimated with the default set). Where on the table the gripper touched, the rotation about the normal, "
            "and every correction that only moves the gripper along the table are not seen by such data (the counts "
            "are at the end of the page).", "",
            "Held out: rows 4, 9, 14, … (every 5th row from row 4, counted from 0: `held_out = \"every 5th from 4\"` "
            "in the job files) are predicted, never fitted. Before = the nominal robot with the plane fitted to the "
            "training rows' contact points; after = the calibrated robot and plane.", ""]
    for side in SIDES:
        mine = [line for line in lines if line.side == side]
        if not mine:
            continue
        first = mine[0].figures()
        text += [f"## The {side} arm", "",
                 f"{first['n_fitted']} rows fitted, {first['n_held_out']} held out; cross-validation "
                 f"{first['cv_plan']} over all {first['n_fitted'] + first['n_held_out']} rows.", "",
                 *table(mine), "", *(verdict(mine) if len(mine) > 1 else []), "", "Commands:", "", "```",
                 *(line.command for line in mine), "```", ""]
    text += [*residuals(lines), "", f"This page took {sum(line.seconds for line in lines):.0f} s to compute "
             f"(cross-validation {cv}).", ""]
    return "\n".join(text)


def run(quick: bool, out: Path, executor: str | None) -> dict[str, Any]:
    """Calibrate every line, write the page, return the numbers."""
    cv = QUICK_CV if quick else CV
    models = {"default set": None} if quick else MODELS
    lines = [run_line(read_job(job_path(side)), side, model, parameters, cv)
             for side in (SIDES[:1] if quick else SIDES) for model, parameters in models.items()]
    out.mkdir(parents=True, exist_ok=True)
    (out / "talos_table_contact.md").write_text(page(lines, cv), encoding="utf-8")
    for line in lines:
        f = line.figures()
        print(f"{line.side:5} {line.model:38} held-out {mm(f['held_distance'][0])} → {mm(f['held_distance'][1])} mm, "
              f"cv {mm(f['cv_distance'])} mm / {mrad(f['cv_tilt'])} mrad  ({line.seconds:.0f} s)")
    return {"lines": [line.figures() for line in lines]}


if __name__ == "__main__":
    study_main(run, __doc__, "the left arm's default command only, 5 folds once (seconds)", sys.argv[1:])
