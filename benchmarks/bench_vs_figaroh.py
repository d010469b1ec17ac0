"""pincal beside FIGAROH 1.0.2 on the same synthetic UR10 data, measured side by side in one run.

Run: ``python benchmarks/bench_vs_figaroh.py`` (``--quick``: N = 50 only). FIGAROH comes with the optional
extra ``pip install -e .[bench]``; without it the FIGAROH columns read "not run".

The robot is example-robot-data's UR10 with a tracker target ("marker", a fixed link 3 cm, -2 cm, 10 cm
from ``tool0``). The true robot differs from the nominal one by

- every movable joint's placement: translations σ = 1 mm, rotations σ = 0.5 mrad;
- every joint's reading offset: σ = 1 mrad;
- with *unknown frames*, also the tracker's frame (base: 1.8 m away, turned 2.5 rad about z, a little
  tilted) and the target's offset on the tool (1.5, -1, 2 mm; for 6D also 3, -2, 4 mrad).

Measurements: the target's position (3D) or pose (6D) at N random postures (uniform within the joint limits,
at most ±π), noise σ = 0.1 mm and, for 6D, 0.1 mrad; 500 other postures are held out. *Known frames*: the base
and the target's placement are given, exactly; *unknown*: both are estimated with the robot.

Each tool identifies the same data its own way, as its documentation shows:

- pincal: ``CalibrationProblem`` + ``identify`` (analytic Jacobian, LM restricted to the identifiable
  directions) over the 6 joints' placements and offsets, plus ``base.*`` and the target's fixed-joint origin
  when the frames are unknown. Timed: problem construction + identification.
- FIGAROH: a ``BaseCalibration`` subclass (the UR10 example's, weighted by 1/σ) on a unified config
  (``full_params``, tool frame = the target), data from a CSV file in FIGAROH's layout (RPY angles for 6D),
  ``known_baseframe``/``known_tipframe`` set as its examples do, then ``initialize()`` (structural base
  parameters, elimination of frame-absorbed ones) and ``solve_optimisation()`` (SciPy LM on
  finite differences). Timed: ``initialize`` + ``solve_optimisation`` (the CSV is written beforehand).

Held-out error: each calibrated model's prediction against the true (noise-free) target on the 500 held-out
postures, RMS over postures [mm] (and orientation [mrad] for 6D). "kept" is the number of parameters the tool
estimates; "identifiable" the rank of the data's full identification Jacobian (pincal's analysis).

Times are medians of this process's CPU time (``--clock wall`` for elapsed time): both tools run on one
thread, BLAS included (``OPENBLAS_NUM_THREADS=1`` unless set), so CPU time is their cost whatever else the
machine runs. On a 2-core machine shared with other jobs, multithreaded OpenBLAS made pincal's SVDs of tall
Jacobians up to 100× slower and erratic.
"""

from __future__ import annotations

import os

for _var in ("OPENBLAS_NUM_THREADS", "OMP_NUM_THREADS", "MKL_NUM_THREADS"):
    os.environ.setdefault(_var, "1")

import argparse  # noqa: E402
import contextlib  # noqa: E402
import csv  # noqa: E402
import io  # noqa: E402
import logging  # noqa: E402
import platform  # noqa: E402
import statistics  # noqa: E402
import tempfile  # noqa: E402
import time  # noqa: E402
import warnings  # noqa: E402
from collections.abc import Callable  # noqa: E402
from dataclasses import dataclass  # noqa: E402
from pathlib import Path  # noqa: E402
from types import SimpleNamespace  # noqa: E402
from typing import Any  # noqa: E402

import numpy as np  # noqa: E402
import numpy.typing as npt  # noqa: E402
import pinocchio as pin  # noqa: E402

import pincal  # noqa: E402
from pincal.identification.measurements import Measurement, pose, position  # noqa: E402
from pincal.identification.parameters import ParameterSet, choose_parameters  # noqa: E402
from pincal.identification.problem import CalibrationProblem, Observations  # noqa: E402
from pincal.identification.solver import identify  # noqa: E402
from pincal.study.simulation import random_actuated, simulate_observations  # noqa: E402

Array = npt.NDArray[np.float64]

SIGMA_POSITION = 1e-4  # m
SIGMA_ANGLE = 1e-4  # rad
N_HELD_OUT = 500
N_TRAIN = 1000
MARKER_LINK = "marker"
MARKER_JOINT = "tool0-marker_fixed_joint"
MARKER_ORIGIN = "0.03 -0.02 0.1"
#: The tracker's frame w.r.t. the robot's (unknown-frames case): tx, ty, tz [m], rx, ry, rz [rad] of exp6.
TRUE_BASE = (1.8, -0.5, 0.2, 0.02, -0.01, 2.5)
#: The target's placement error on the tool (unknown-frames case) [m, rad].
TRUE_MARKER = (1.5e-3, -1.0e-3, 2.0e-3, 3e-3, -2e-3, 4e-3)
COMPONENTS = ("tx", "ty", "tz", "rx", "ry", "rz")
#: The clock: this process's CPU time by default (both tools run single-threaded, so it is their cost
#: independent of other jobs on the machine); ``--clock wall`` for wall time.
CLOCKS: dict[str, Callable[[], float]] = {"cpu": time.process_time, "wall": time.perf_counter}
CLOCK = CLOCKS["cpu"]


# --- the robot and the truth -----------------------------------------------------------------------
def ur10_with_target(directory: Path) -> pincal.Robot:
    """example-robot-data's UR10 plus a tracker target on the tool, written to ``directory``."""
    text = Path(str(pincal.robot_path("ur10"))).read_text(encoding="utf-8")
    target = (f'  <link name="{MARKER_LINK}"/>\n  <joint name="{MARKER_JOINT}" type="fixed">\n'
              f'    <parent link="tool0"/>\n    <child link="{MARKER_LINK}"/>\n'
              f'    <origin xyz="{MARKER_ORIGIN}" rpy="0 0 0"/>\n  </joint>\n')
    path = directory / "ur10_target.urdf"
    path.write_text(text.replace("</robot>", target + "</robot>"), encoding="utf-8")
    return pincal.load_robot(str(path))


def geometric(joints: list[str]) -> list[str]:
    """The patterns of the joints' placements and reading offsets (``<joint>.*`` would also name their harmonics
    and compliance, which neither tool estimates here)."""
    return [f"{j}.{c}" for j in joints for c in ("[tr]?", "offset")]


def truth(robot: pincal.Robot, unknown_frames: bool, six_d: bool,
          rng: np.random.Generator) -> tuple[ParameterSet, Array]:
    """The true deviations over joints, offsets, base and target (base and target zero when known; the
    target's rotation, which no position shows, only for 6D)."""
    joints = robot.actuated_joints
    pset = choose_parameters(robot, [position(MARKER_LINK)],
                             [*geometric(joints), "base.*", f"{MARKER_JOINT}.*"])
    x = np.zeros(len(pset))
    for k, p in enumerate(pset):
        if p.kind == "offset":
            x[k] = rng.normal(scale=1e-3)
        elif p.kind == "joint" and p.owner in joints:
            x[k] = rng.normal(scale=1e-3 if p.unit == "m" else 0.5e-3)
    if unknown_frames:
        for c, value in enumerate(TRUE_BASE):
            x[pset.index(f"base.{COMPONENTS[c]}")] = value
        for c, value in enumerate(TRUE_MARKER[:6 if six_d else 3]):
            x[pset.index(f"{MARKER_JOINT}.{COMPONENTS[c]}")] = value
    return pset, x


def estimated_set(robot: pincal.Robot, unknown_frames: bool, six_d: bool) -> ParameterSet:
    """pincal's unknowns: the joints' placements and offsets (+ base and target when unknown)."""
    patterns = geometric(robot.actuated_joints)
    if unknown_frames:
        patterns += ["base.*", f"{MARKER_JOINT}.*" if six_d else f"{MARKER_JOINT}.t?"]
    return choose_parameters(robot, [position(MARKER_LINK)], patterns)


@dataclass
class Data:
    """Postures and exact/noisy measurements: ``actuated`` (N, 6) [rad]; ``exact``/``noisy`` (N, 7) or
    (N, 3) as pincal's observations (x, y, z [m], then qx, qy, qz, qw)."""

    actuated: Array
    exact: Array
    noisy: Array


def simulate(robot: pincal.Robot, pset: ParameterSet, x: Array, model: Measurement, n: int,
             rng: np.random.Generator) -> Data:
    qa, _ = random_actuated(robot, n, rng, spread=np.pi)  # ±π about zero: the draws RESULTS.md was measured on
    exact = simulate_observations(robot, pset, x, [model], qa, rng, noise=0.0).values[model.key]
    noisy = exact.copy()
    noisy[:, :3] += rng.normal(scale=SIGMA_POSITION, size=(n, 3))
    if exact.shape[1] == 7:
        for k in range(n):
            rot = quaternion_matrix(exact[k]) @ pin.exp3(rng.normal(scale=SIGMA_ANGLE, size=3))
            noisy[k, 3:] = pin.Quaternion(rot).coeffs()  # x, y, z, w
    return Data(qa, exact, noisy)


def quaternion_matrix(row: Array) -> Array:
    return np.asarray(pin.Quaternion(row[6], row[3], row[4], row[5]).normalized().matrix())


# --- one run of each tool --------------------------------------------------------------------------
@dataclass
class Outcome:
    seconds: float
    held_out_position: float  # RMS [m]
    held_out_angle: float  # RMS [rad], NaN for 3D
    kept: int
    identifiable: int | None = None
    converged: bool = True
    setup_seconds: float = float("nan")  # FIGAROH: initialize() (parameter selection) within ``seconds``


def held_out_errors(positions: Array, rotations: list[Array] | None, exact: Array) -> tuple[float, float]:
    pos = float(np.sqrt(np.mean(np.sum((positions - exact[:, :3]) ** 2, axis=1))))
    if rotations is None:
        return pos, float("nan")
    angles = [np.linalg.norm(pin.log3(quaternion_matrix(e).T @ r)) for e, r in zip(exact, rotations, strict=True)]
    return pos, float(np.sqrt(np.mean(np.square(angles))))


def run_pincal(robot: pincal.Robot, pset: ParameterSet, truth_set: ParameterSet, x_true: Array,
               model: Measurement, train: Data, test: Data, loss: str | None) -> Outcome:
    """Identify with pincal (``loss``: None for ``identify``'s default); the parameters not estimated stay
    at their (known) true values."""
    start = CLOCK()
    problem = CalibrationProblem(robot, pset, [model], Observations(train.actuated, {model.key: train.noisy}))
    result = identify(problem) if loss is None else identify(problem, loss=loss)
    seconds = CLOCK() - start
    known = {n: x_true[truth_set.index(n)] for n in truth_set.names if n not in pset}
    assert not any(known.values()), "known parameters must be nominal in this benchmark"
    test_problem = CalibrationProblem(robot, pset, [model], Observations(test.actuated, {model.key: test.exact}))
    predicted = test_problem.evaluate(result.x, jacobian=False).predicted[model.key]
    rotations = None
    if predicted.shape[1] == 6:  # pose: (p, log3(R_measᵀ R)) with R_meas the exact rotation
        rotations = [quaternion_matrix(e) @ pin.exp3(p[3:]) for e, p in zip(test.exact, predicted, strict=True)]
    pos, ang = held_out_errors(predicted[:, :3], rotations, test.exact)
    return Outcome(seconds, pos, ang, len(result.identified), result.identifiability.rank, result.converged)


def figaroh_available() -> bool:
    try:
        import figaroh.calibration.base_calibration  # noqa: F401
    except ImportError:
        return False
    return True


def figaroh_config(directory: Path, robot: pincal.Robot, n: int, six_d: bool) -> Path:
    import yaml

    config = {
        "robot": {"name": "ur10", "properties": {"joints": {"active_joints": list(robot.actuated_joints)}}},
        "tasks": {"calibration": {
            "enabled": True,
            "parameters": {"calibration_level": "full_params", "include_non_geometric": False,
                           "outlier_threshold": 0.05},
            "kinematics": {"base_frame": "universe", "tool_frame": MARKER_LINK},
            "measurements": {"markers": [{"name": "target", "reference_joint": "wrist_3_joint",
                                          "measurable_dof": [True] * 3 + [six_d] * 3}],
                             "poses": {"base_pose": [0.0] * 6, "tool_pose": [0.0] * 6}},
            "data": {"source_file": str(directory / "train.csv"), "number_of_samples": n},
        }},
    }
    path = directory / "figaroh.yaml"
    path.write_text(yaml.safe_dump(config), encoding="utf-8")
    return path


def figaroh_csv(path: Path, robot: pincal.Robot, data: Data) -> None:
    """FIGAROH's layout: x1, y1, z1 [m] (phix1, phiy1, phiz1: roll-pitch-yaw [rad]) and one column per joint."""
    columns: dict[str, Array] = {"x1": data.noisy[:, 0], "y1": data.noisy[:, 1], "z1": data.noisy[:, 2]}
    if data.noisy.shape[1] == 7:
        rpy = np.array([pin.rpy.matrixToRpy(quaternion_matrix(row)) for row in data.noisy])
        columns.update({"phix1": rpy[:, 0], "phiy1": rpy[:, 1], "phiz1": rpy[:, 2]})
    for k, joint in enumerate(robot.actuated_joints):
        columns[joint] = data.actuated[:, k]
    with path.open("w", newline="", encoding="utf-8") as f:
        writer = csv.writer(f)
        writer.writerow(list(columns))
        writer.writerows(zip(*(map(repr, map(float, c)) for c in columns.values()), strict=True))


def run_figaroh(robot: pincal.Robot, config: Path, unknown_frames: bool, six_d: bool, test: Data) -> Outcome:
    from figaroh.calibration.base_calibration import BaseCalibration
    from figaroh.calibration.calibration_tools import calc_updated_fkm

    class UR10Calibration(BaseCalibration):
        """The UR10 example's cost function (SE3 log-map residuals), weighted by 1/σ."""

        def cost_function(self, var: Array) -> Array:
            estimated = calc_updated_fkm(self.model, self.data, var, self.q_measured, self.calib_config)
            raw = self._compute_logmap_residuals(self.PEE_measured, estimated)
            return np.asarray(self.apply_measurement_weighting(raw, pos_weight=1.0 / SIGMA_POSITION,
                                                               orient_weight=1.0 / SIGMA_ANGLE))

    model = pin.Model(robot.model)
    fig_robot = SimpleNamespace(model=model, data=model.createData(), q0=pin.neutral(model))
    with contextlib.redirect_stdout(io.StringIO()):
        start = CLOCK()
        calibration = UR10Calibration(fig_robot, str(config))
        calibration.calib_config["known_baseframe"] = not unknown_frames
        calibration.calib_config["known_tipframe"] = not unknown_frames
        calibration.initialize()
        setup = CLOCK() - start
        result, _ = calibration.solve_optimisation()
        seconds = CLOCK() - start
    n = test.actuated.shape[0]
    q = np.tile(pin.neutral(model), (n, 1))
    q[:, calibration.calib_config["config_idx"]] = test.actuated
    predicted = calc_updated_fkm(model, fig_robot.data, result.x, q, dict(calibration.calib_config, NbSample=n))
    predicted = predicted.reshape(6 if six_d else 3, n).T
    rotations = [pin.rpy.rpyToMatrix(row[3:]) for row in predicted] if six_d else None
    pos, ang = held_out_errors(predicted[:, :3], rotations, test.exact)
    return Outcome(seconds, pos, ang, len(calibration.calib_config["param_name"]), None, bool(result.success),
                   setup)


# --- the table -------------------------------------------------------------------------------------
@dataclass
class Row:
    frames: str
    data: str
    n: int
    pincal: Outcome
    figaroh: Outcome | None


def repeats_for(n: int, large: int) -> int:
    return 5 if n <= 50 else 3 if n <= 200 else large


def median_outcome(runs: list[Outcome]) -> Outcome:
    last = runs[-1]
    return Outcome(statistics.median(r.seconds for r in runs), last.held_out_position, last.held_out_angle,
                   last.kept, last.identifiable, all(r.converged for r in runs),
                   statistics.median(r.setup_seconds for r in runs))


def run_case(robot: pincal.Robot, unknown_frames: bool, six_d: bool, sizes: list[int], seed: int,
             with_figaroh: bool, large_repeats: int, directory: Path, loss: str | None) -> list[Row]:
    rng = np.random.default_rng(seed)
    truth_set, x_true = truth(robot, unknown_frames, six_d, rng)
    model = pose(MARKER_LINK, SIGMA_POSITION, SIGMA_ANGLE) if six_d else position(MARKER_LINK, SIGMA_POSITION)
    test = simulate(robot, truth_set, x_true, model, N_HELD_OUT, rng)
    train_all = simulate(robot, truth_set, x_true, model, N_TRAIN, rng)  # N samples: the first N (--quick too)
    pset = estimated_set(robot, unknown_frames, six_d)
    rows = []
    for n in sizes:
        train = Data(train_all.actuated[:n], train_all.exact[:n], train_all.noisy[:n])
        repeats = repeats_for(n, large_repeats)
        mine = median_outcome([run_pincal(robot, pset, truth_set, x_true, model, train, test, loss)
                               for _ in range(max(repeats, 3))])
        theirs = None
        if with_figaroh:
            case_dir = directory / f"{'unknown' if unknown_frames else 'known'}_{'6d' if six_d else '3d'}_{n}"
            case_dir.mkdir()
            config = figaroh_config(case_dir, robot, n, six_d)
            figaroh_csv(case_dir / "train.csv", robot, train)
            theirs = median_outcome([run_figaroh(robot, config, unknown_frames, six_d, test)
                                     for _ in range(repeats)])
        rows.append(Row("unknown" if unknown_frames else "known", "6D" if six_d else "3D", n, mine, theirs))
        print(f"  done: {rows[-1].frames} frames, {rows[-1].data}, N = {n} "
              f"(pincal {mine.seconds:.3f} s" + (f", FIGAROH {theirs.seconds:.2f} s of which initialize() "
                                                  f"{theirs.setup_seconds:.2f} s)" if theirs else ")"),
              flush=True)
    return rows


def fmt_time(seconds: float) -> str:
    return f"{seconds * 1e3:.0f} ms" if seconds < 1.0 else f"{seconds:.2f} s"


def table(rows: list[Row]) -> str:
    lines = ["| frames | data | N | pincal | FIGAROH | FIGAROH / pincal | held-out pos. RMS pincal / FIGAROH [mm] "
             "| held-out orient. RMS pincal / FIGAROH [mrad] | kept pincal / FIGAROH (identifiable) |",
             "|---|---|---|---|---|---|---|---|---|"]
    for r in rows:
        p, f = r.pincal, r.figaroh
        orient = (f"{p.held_out_angle * 1e3:.4f} / " + (f"{f.held_out_angle * 1e3:.4f}" if f else "not run")
                  if r.data == "6D" else "–")
        flag = "" if p.converged else " (not converged)"
        fflag = "" if f is None or f.converged else " (not converged)"
        lines.append(
            f"| {r.frames} | {r.data} | {r.n} | {fmt_time(p.seconds)}{flag} | "
            + (f"{fmt_time(f.seconds)}{fflag} | {f.seconds / p.seconds:.0f}× | " if f else "not run | – | ")
            + f"{p.held_out_position * 1e3:.4f} / " + (f"{f.held_out_position * 1e3:.4f}" if f else "not run")
            + f" | {orient} | {p.kept} / " + (f"{f.kept}" if f else "not run") + f" ({p.identifiable}) |")
    return "\n".join(lines)


def targets(rows: list[Row]) -> list[str]:
    out = []
    for r in rows:
        if r.n != 1000 or r.data != "3D":
            continue
        if r.frames == "known" and r.figaroh is not None:
            ratio = r.figaroh.seconds / r.pincal.seconds
            # both reach the same least-squares optimum: "no worse" within 1 % (the 5th digit)
            ok = ratio >= 30 and r.pincal.held_out_position <= 1.01 * r.figaroh.held_out_position
            out.append(f"- known frames, 3D, N = 1000: {ratio:.0f}× faster (target ≥ 30×), held-out "
                       f"{r.pincal.held_out_position * 1e3:.5f} mm vs {r.figaroh.held_out_position * 1e3:.5f} mm "
                       f"(target: no worse, within 1 %) — {'met' if ok else 'NOT met'}")
        if r.frames == "unknown":
            ok = r.pincal.kept == r.pincal.identifiable and r.pincal.held_out_position <= 3e-5
            out.append(f"- unknown frames, 3D, N = 1000: pincal keeps {r.pincal.kept} of {r.pincal.identifiable} "
                       f"identifiable directions, held-out {r.pincal.held_out_position * 1e3:.4f} mm "
                       f"(target: all kept, ≤ 0.03 mm) — {'met' if ok else 'NOT met'}")
    return out


def main(argv: list[str] | None = None) -> None:
    parser = argparse.ArgumentParser(description=__doc__.split("\n", 1)[0])
    parser.add_argument("--quick", action="store_true", help="N = 50 only (smoke run)")
    parser.add_argument("--seed", type=int, default=0)
    parser.add_argument("--repeats-1000", type=int, default=2, help="timed repeats at N = 1000 (default 2)")
    parser.add_argument("--no-figaroh", action="store_true", help="run the pincal half only")
    parser.add_argument("--loss", default=None, help="pincal's loss (default: identify's default)")
    parser.add_argument("--clock", choices=sorted(CLOCKS), default="cpu",
                        help="cpu: this process's CPU time (default); wall: elapsed time")
    args = parser.parse_args(argv)
    global CLOCK
    CLOCK = CLOCKS[args.clock]
    sizes = [50] if args.quick else [50, 200, 1000]
    with_figaroh = not args.no_figaroh and figaroh_available()
    if not with_figaroh and not args.no_figaroh:
        print("FIGAROH is not installed (pip install -e .[bench]): its columns read 'not run'")
    logging.getLogger("figaroh").setLevel(logging.ERROR)
    logging.getLogger("calibration").setLevel(logging.ERROR)
    warnings.filterwarnings("ignore", module="figaroh")
    rows: list[Row] = []
    with tempfile.TemporaryDirectory(prefix="pincal_vs_figaroh_") as tmp:
        directory = Path(tmp)
        robot = ur10_with_target(directory)
        for unknown_frames in (False, True):
            for six_d in (False, True):
                rows += run_case(robot, unknown_frames, six_d, sizes, args.seed, with_figaroh, args.repeats_1000,
                                 directory, args.loss)
    versions: dict[str, Any] = {"pincal": pincal.__version__, "pinocchio": pin.__version__, "numpy": np.__version__}
    if with_figaroh:
        import importlib.metadata

        versions["figaroh"] = importlib.metadata.version("figaroh")
    print(f"\nPython {platform.python_version()}, " + ", ".join(f"{k} {v}" for k, v in versions.items())
          + f", BLAS threads {os.environ['OPENBLAS_NUM_THREADS']}; seed {args.seed}; pincal loss "
          f"{args.loss or 'default'}; median {args.clock} times "
          f"(5 runs at N = 50, 3 at 200, {args.repeats_1000} at 1000; pincal at least 3)\n")
    print(table(rows))
    lines = targets(rows)
    if lines:
        print("\n" + "\n".join(lines))


if __name__ == "__main__":
    main()
