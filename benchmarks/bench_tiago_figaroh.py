"""pincal against FIGAROH 1.0.2 on the real TIAGo mocap data, cross-validated on the same folds (issue 13, item 5).

Run: ``python benchmarks/bench_tiago_figaroh.py`` (about 15 minutes; ``--quick``: one fold plan, no leave-one-out).
FIGAROH comes with the optional ``bench`` extra (``pip install -e ".[bench]"``); without it only pincal's half runs.

The data: the Qualisys file ``qualysis_base_hand_calibration.csv`` of the public repository
thanhndv212/figaroh-examples (copied byte for byte as ``examples/data/tiago_mocap_raw.csv``) as pincal reads it from
``examples/data/tiago_mocap_marker1.csv`` (marker 1) and ``examples/data/tiago_mocap_markers.csv`` (markers 1–3 on
``wrist_ft_tool_link``), 34 postures, the mocap frame and the marker offsets unknown. pincal: the default command,
``pincal calibrate tiago_no_hand FILE --cv 5x4 --cv-seed S`` (and ``--cv loo``), through
:func:`pincal.calibration.calibrate`. FIGAROH: its ``full_params`` model with the base frame and one position offset
per marker unknown (its structural base parameters: 30 for one marker, 39 for three), least squares from its
closed-form frame start, the residual in metres over 1 mm.

Both tools see the same folds: plan ``S`` shuffles the 34 postures four times, with permutations seeded S, S + 1,
S + 2 and S + 3, and cuts each shuffle into 5 folds (``order[f::5]``), as ``--cv 5x4 --cv-seed S`` does. Every figure
[mm] is the RMS of the 3D errors of the held-out marker readings, every marker counted, and, for three markers, of
marker 1 alone. Plans 0, 4, 8, … use disjoint seeds: their spread shows how much a 5-fold × 4 figure on 34 postures
depends on the folds.
"""

from __future__ import annotations

import contextlib
import csv
import io
import logging
import statistics
import sys
import tempfile
import time
import warnings
from dataclasses import dataclass
from pathlib import Path
from types import SimpleNamespace
from typing import Any

import numpy as np
import numpy.typing as npt
import pinocchio as pin

import pincal
from pincal.calibration.pipeline import calibrate
from pincal.calibration.samples import read_robot_dataset

Array = npt.NDArray[np.float64]
ROOT = Path(__file__).resolve().parents[1]
DATA = ROOT / "examples" / "data"
FILES = {1: DATA / "tiago_mocap_marker1.csv", 3: DATA / "tiago_mocap_markers.csv"}
ACTIVE = ["torso_lift_joint"] + [f"arm_{i}_joint" for i in range(1, 8)]
TOOL = "wrist_ft_tool_link"
FOLDS, SHUFFLES = 5, 4


@dataclass
class Figures:
    """One tool's cross-validated RMS [m]: every marker reading, and marker 1's alone."""

    all: float
    marker1: float


def plan(n: int, seed: int) -> list[npt.NDArray[np.intp]]:
    """The test postures of every fold of plan ``seed`` (as ``--cv 5x4 --cv-seed seed``)."""
    tests = []
    for repeat in range(SHUFFLES):
        order = np.random.default_rng(seed + repeat).permutation(n)
        tests += [np.sort(order[f::FOLDS]) for f in range(FOLDS)]
    return tests


def rms(values: Array) -> float:
    return float(np.sqrt(np.mean(values**2)))


# --- pincal -----------------------------------------------------------------------------------------------
def pincal_cv(markers: int, cv: str, seed: int) -> Figures:
    """The default command's cross-validated RMS: ``--cv cv --cv-seed seed``."""
    robot = pincal.load_robot("tiago_no_hand")
    report = calibrate(robot, read_robot_dataset(FILES[markers], robot), cv=cv, cv_seed=seed).report.cv
    assert report is not None and report.rms is not None, "no fold could be fitted"
    first = (report.rms_by_reading or {}).get(f"position:{TOOL}@m1", report.rms)
    return Figures(report.rms, first)


# --- FIGAROH ----------------------------------------------------------------------------------------------
def figaroh_available() -> bool:
    try:
        import figaroh.calibration.base_calibration  # noqa: F401
    except ImportError:
        return False
    return True


class Figaroh:
    """FIGAROH 1.0.2 fitted to a subset of the postures, predicting the others."""

    def __init__(self, markers: int, points: Array, joints: Array, directory: Path) -> None:
        self.markers, self.points, self.joints, self.directory = markers, points, joints, directory
        self.model = pin.buildModelFromUrdf(str(pincal.load_robot("tiago_no_hand").source))

    def _config(self, n: int) -> Path:
        import yaml

        marker = {"reference_joint": "arm_7_joint", "measurable_dof": [True] * 3 + [False] * 3}
        config = {"robot": {"name": "tiago", "properties": {"joints": {"active_joints": ACTIVE}}},
                  "tasks": {"calibration": {
                      "enabled": True,
                      "parameters": {"calibration_level": "full_params", "include_non_geometric": False},
                      "kinematics": {"base_frame": "universe", "tool_frame": TOOL},
                      "measurements": {"markers": [dict(marker, name=f"m{k + 1}") for k in range(self.markers)],
                                       "poses": {"base_pose": [0.0] * 6, "tool_pose": [0.0] * 6}},
                      "data": {"source_file": str(self.directory / "train.csv"), "number_of_samples": n}}}}
        path = self.directory / "figaroh.yaml"
        path.write_text(yaml.safe_dump(config), encoding="utf-8")
        return path

    def fit(self, rows: npt.NDArray[np.intp]) -> tuple[Any, Any, Array]:
        """FIGAROH's calibration on the postures ``rows``: (calibration, its robot, the parameters)."""
        from figaroh.calibration.base_calibration import BaseCalibration
        from figaroh.calibration.calibration_tools import calc_updated_fkm

        class TiagoCalibration(BaseCalibration):
            """Marker position residuals [m] over the stated 1 mm."""

            def cost_function(self, var: Array) -> Array:
                predicted = calc_updated_fkm(self.model, self.data, var, self.q_measured, self.calib_config)
                return np.asarray((predicted - self.PEE_measured) / 1e-3)

        header = [f"{a}{k + 1}" for k in range(self.markers) for a in "xyz"] + ACTIVE
        with (self.directory / "train.csv").open("w", newline="", encoding="utf-8") as f:
            writer = csv.writer(f)
            writer.writerow(header)
            for r in rows:
                writer.writerow([repr(float(v)) for v in (*self.points[r].ravel(), *self.joints[r])])
        model = pin.Model(self.model)
        robot = SimpleNamespace(model=model, data=model.createData(), q0=pin.neutral(model))
        with contextlib.redirect_stdout(io.StringIO()):
            calibration = TiagoCalibration(robot, str(self._config(len(rows))))
            calibration.calib_config["known_baseframe"] = False
            calibration.calib_config["known_tipframe"] = False
            calibration.initialize()
            result, _ = calibration.solve_optimisation()
        return calibration, robot, np.asarray(result.x)

    def errors(self, fitted: tuple[Any, Any, Array], rows: npt.NDArray[np.intp]) -> Array:
        """The 3D errors [m] of the postures ``rows``' marker readings, (posture, marker)."""
        from figaroh.calibration.calibration_tools import calc_updated_fkm

        calibration, robot, x = fitted
        q = np.tile(pin.neutral(robot.model), (len(rows), 1))
        q[:, calibration.calib_config["config_idx"]] = self.joints[rows]
        config = dict(calibration.calib_config, NbSample=len(rows))
        predicted = calc_updated_fkm(robot.model, robot.data, x, q, config).reshape(self.markers, 3, len(rows))
        return np.asarray(np.linalg.norm(np.transpose(predicted, (2, 0, 1)) - self.points[rows], axis=2))

    def cross_validate(self, tests: list[npt.NDArray[np.intp]]) -> Figures:
        n = len(self.joints)
        errors = np.concatenate([self.errors(self.fit(np.setdiff1d(np.arange(n), t)), t) for t in tests])
        return Figures(rms(errors), rms(errors[:, 0]))


def tiago_readings(markers: int) -> tuple[Array, Array]:
    """The marker points [m] (posture, marker, xyz) and the torso and arm joints [m, rad] of the 34 postures, as
    pincal reads them from the example file (every posture sees every marker)."""
    robot = pincal.load_robot("tiago_no_hand")
    dataset = read_robot_dataset(FILES[markers], robot)
    keys = [f"position:{TOOL}"] if markers == 1 else [f"position:{TOOL}@m{k + 1}" for k in range(markers)]
    points = np.stack([dataset.measurements[k] for k in keys], axis=1)
    joints = dataset.joints[:, [dataset.joint_names.index(j) for j in ACTIVE]]
    return points, joints


# --- the table --------------------------------------------------------------------------------------------
def main(argv: list[str]) -> None:
    quick = "--quick" in argv
    seeds = [0] if quick else [0, 4, 8, 12, 16]
    with_figaroh = figaroh_available()
    if not with_figaroh:
        print("FIGAROH is not installed (pip install -e '.[bench]'): pincal's half only")
    logging.getLogger("figaroh").setLevel(logging.ERROR)
    logging.getLogger("calibration").setLevel(logging.ERROR)
    warnings.filterwarnings("ignore")
    start = time.perf_counter()
    lines = []
    with tempfile.TemporaryDirectory(prefix="pincal_tiago_figaroh_") as tmp:
        for markers in (1, 3):
            points, joints = tiago_readings(markers)
            n = len(joints)
            figaroh = Figaroh(markers, points, joints, Path(tmp)) if with_figaroh else None
            label = "1 marker" if markers == 1 else f"{markers} markers"
            rows: list[tuple[str, Figures, Figures | None]] = []
            if not quick:
                loo = [np.array([i]) for i in range(n)]
                rows.append(("leave-one-out", pincal_cv(markers, "loo", 0),
                             figaroh.cross_validate(loo) if figaroh else None))
            for seed in seeds:
                rows.append((f"5-fold × 4, seeds {seed}–{seed + SHUFFLES - 1}",
                             pincal_cv(markers, f"{FOLDS}x{SHUFFLES}", seed),
                             figaroh.cross_validate(plan(n, seed)) if figaroh else None))
            for name, ours, theirs in rows:
                lines.append(_row(label, name, ours, theirs, markers))
            folds = [r for r in rows if r[0].startswith("5-fold")]
            if len(folds) > 1:
                ours_median = statistics.median(r[1].all for r in folds)
                theirs_all = [r[2].all for r in folds if r[2] is not None]
                theirs_median = statistics.median(theirs_all) if theirs_all else None
                lines.append(_row(label, f"5-fold × 4, median of {len(folds)} plans",
                                  Figures(ours_median, statistics.median(r[1].marker1 for r in folds)),
                                  Figures(theirs_median, statistics.median(r[2].marker1 for r in folds
                                                                           if r[2] is not None))
                                  if theirs_median is not None else None, markers))
            print(f"{label} done ({time.perf_counter() - start:.0f} s)", file=sys.stderr)
    print("| markers | cross-validation | pincal, every marker | FIGAROH 1.0.2, every marker | FIGAROH / pincal | "
          "pincal, marker 1 | FIGAROH, marker 1 |")
    print("|---|---|---|---|---|---|---|")
    print("\n".join(lines))
    print(f"\n{time.perf_counter() - start:.0f} s in all")


def _row(label: str, name: str, ours: Figures, theirs: Figures | None, markers: int) -> str:
    def mm(value: float | None) -> str:
        return "—" if value is None else f"{value * 1e3:.3f}"

    ratio = f"{theirs.all / ours.all:.2f}" if theirs else "—"
    first_ours, first_theirs = (mm(ours.marker1), mm(theirs.marker1 if theirs else None)) if markers > 1 else ("—", "—")
    return (f"| {label} | {name} | {mm(ours.all)} | {mm(theirs.all if theirs else None)} | {ratio} | {first_ours} | "
            f"{first_theirs} |")


if __name__ == "__main__":
    main(sys.argv[1:])
