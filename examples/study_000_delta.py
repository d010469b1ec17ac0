"""Study 000 (Delta robot, FKM vs IKM calibration): the paper's cases side by side with pincal.

Run: ``python examples/study_000_delta.py`` (full, ~1-2 min) or ``--quick`` (a few seconds).
Prints the tables, writes ``docs/results/000_delta.md`` and two figures under
``docs/results/figures/``.

Settings follow the paper (Section 4): Delta with La = 260 mm, Lb = 480 mm, Rb = 194 mm, Rn = 30 mm;
Model 24 parameters; random configurations in the workspace; initial parameter errors of the stated
size (metres for lengths, radians for angles, σ of a normal draw); position measured on the platform
(laser tracker) and arm angles read by the encoders, with the stated noise. Each case is averaged
over several random draws (seeds). G is Eq. 4.1 over all parameters; "mean per-parameter gain" is
the average of the per-parameter gains, which is how the paper reports its noisy cases.
"""

from __future__ import annotations

import argparse
import math
import time
from dataclasses import dataclass
from pathlib import Path

import numpy as np

import pincal
from pincal import measurements as ms
from pincal.errors import PincalError
from pincal.identification import calibration_gain, error_norms, identify
from pincal.implicit import ImplicitProblem
from pincal.parameters import NAMED_SETS
from pincal.problem import CalibrationProblem
from pincal.simulation import random_actuated, simulate_observations

ROOT = Path(__file__).resolve().parents[1]
DEG = math.pi / 180.0


@dataclass
class Case:
    label: str
    n_configs: int
    error: float  # σ of the initial parameter errors [m, rad]
    noise: float  # tracker noise σ [m]
    joint_noise: float  # encoder noise σ [rad]
    paper_fkm: str
    paper_ikm: str


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


def per_parameter_gain(x_true: np.ndarray, x_cal: np.ndarray) -> np.ndarray:
    """Per-parameter gain [%]: 100 (|Pr − Pn| − |Pr − Pc|) / |Pr − Pn| (nominal Pn = 0)."""
    return 100.0 * (np.abs(x_true) - np.abs(x_true - x_cal)) / np.abs(x_true)


def run_case(robot: pincal.Robot, set_name: str, case: Case, method: str, seed: int, n_test: int = 50) -> dict:
    rng = np.random.default_rng(seed)
    pset = NAMED_SETS[set_name](robot)
    x_true = rng.normal(scale=case.error, size=len(pset))
    models = [ms.position("end_effector", sigma=max(case.noise, 1e-6))]
    qa, _ = random_actuated(robot, case.n_configs + n_test, rng)
    obs = simulate_observations(robot, pset, x_true, models, qa, rng, noise=case.noise, joint_noise=case.joint_noise)
    train, test = obs.subset(np.arange(case.n_configs)), obs.subset(np.arange(case.n_configs, case.n_configs + n_test))
    start = time.perf_counter()
    std_ratio = float("nan")
    try:
        if method == "IKM":
            problem = ImplicitProblem(robot, pset, models, train)
        else:  # FKM weights each sample by its covariance, encoder noise included
            problem = CalibrationProblem(robot, pset, models, train, joint_sigma=case.joint_noise or None)
        result = identify(problem)
        converged, x_cal = result.converged, result.x
        assert result.std_apriori is not None
        std_ratio = float(np.nanmedian(result.std_apriori / case.error)) if case.noise or case.joint_noise else 0.0
    except PincalError:
        converged, x_cal = False, np.zeros(len(pset))
    seconds = time.perf_counter() - start
    fkm_test = CalibrationProblem(robot, pset, models, test)
    before = error_norms(fkm_test.evaluate(np.zeros(len(pset)), jacobian=False).errors)
    after = error_norms(fkm_test.evaluate(x_cal, jacobian=False).errors) if converged else before
    return {"G": calibration_gain(x_true, np.zeros(len(pset)), x_cal), "mean_gain": float(np.mean(
        per_parameter_gain(x_true, x_cal))), "per_param": per_parameter_gain(x_true, x_cal),
        "converged": converged, "seconds": seconds, "before": before, "after": after, "names": pset.names,
        "std_ratio": std_ratio}


def summarise(runs: list[dict]) -> dict:
    ok = [r for r in runs if r["converged"]]
    return {"converged": f"{len(ok)}/{len(runs)}",
            "G": float(np.median([r["G"] for r in ok])) if ok else float("nan"),
            "mean_gain": float(np.median([r["mean_gain"] for r in ok])) if ok else float("nan"),
            "seconds": float(np.median([r["seconds"] for r in runs])),
            "rms_before": float(np.median([np.sqrt(np.mean(r["before"] ** 2)) for r in runs])),
            "rms_after": float(np.median([np.sqrt(np.mean(r["after"] ** 2)) for r in ok])) if ok else float("nan"),
            "std_ratio": float(np.median([r["std_ratio"] for r in ok])) if ok else float("nan")}


def figures(robot: pincal.Robot, out: Path, seed: int) -> list[Path]:
    import matplotlib

    matplotlib.use("Agg")
    import matplotlib.pyplot as plt

    case = Case("", 60, 1e-4, 1e-6, 0.01 * DEG, "", "")
    runs = {m: run_case(robot, "model24i", case, m, seed) for m in ("FKM", "IKM")}
    names = runs["FKM"]["names"]
    fig, ax = plt.subplots(figsize=(11, 4))
    width = 0.4
    idx = np.arange(len(names))
    for k, method in enumerate(("FKM", "IKM")):
        ax.bar(idx + (k - 0.5) * width, np.clip(runs[method]["per_param"], -200, 100), width, label=method)
    ax.set_xticks(idx, [n.replace("_joint", "").replace("_platform.predecessor", "") for n in names],
                  rotation=75, fontsize=7)
    ax.set_ylabel("gain per parameter [%]")
    ax.set_xlabel("parameter (Model 24, identifiable reading model24i)")
    ax.set_title("Study 000, Delta: per-parameter gain, 60 configurations, 0.1 mm errors, 1 µm / 0.01° noise "
                 "(bars clipped at −200 %)", fontsize=10)
    ax.axhline(0, color="black", linewidth=0.5)
    ax.legend()
    fig.tight_layout()
    p1 = out / "000_delta_parameter_gain.png"
    fig.savefig(p1, dpi=120)
    plt.close(fig)
    fig, axes = plt.subplots(1, 2, figsize=(11, 4), sharey=True)
    for ax, method in zip(axes, ("FKM", "IKM"), strict=True):
        r = runs[method]
        ax.plot(r["before"] * 1e3, "o", color="tab:blue", label="before")
        ax.plot(r["after"] * 1e3, "o", color="tab:red", label="after")
        ax.set_yscale("log")
        ax.set_xlabel("operating point (held-out configuration)")
        ax.set_title(f"{method}: position error at 50 operating points")
        ax.legend()
    axes[0].set_ylabel("position error [mm]")
    fig.tight_layout()
    p2 = out / "000_delta_operating_points.png"
    fig.savefig(p2, dpi=120)
    plt.close(fig)
    return [p1, p2]


def main() -> None:
    parser = argparse.ArgumentParser(description="Study 000: FKM vs IKM calibration of the Delta robot.")
    parser.add_argument("--quick", action="store_true", help="few seeds, no figures, no docs file")
    parser.add_argument("--seeds", type=int, default=10, help="random draws per case (default 10)")
    args = parser.parse_args()
    robot = pincal.load_robot("delta")
    seeds = range(2 if args.quick else args.seeds)
    cases = CASES[:3] + CASES[6:7] if args.quick else CASES
    lines = ["| case | configs | paper FKM | pincal FKM: G (mean gain) | paper IKM | pincal IKM: G (mean gain) | "
             "held-out RMS before → after, FKM / IKM | std / error | time FKM / IKM |",
             "|---|---|---|---|---|---|---|---|---|"]
    print(f"Study 000, Delta robot: median over {len(seeds)} random draws per case (G: Eq. 4.1; mean gain: mean "
          "per-parameter gain; std / error: the identified parameters' a-priori σ over the size of the errors "
          "sought)\n")
    for set_name in ("model24", "model24i"):
        lines.append(f"| **parameter set {set_name}** | | | | | | | | |")
        for case in cases:
            s_ = {m: summarise([run_case(robot, set_name, case, m, seed) for seed in seeds]) for m in ("FKM", "IKM")}
            f, i = s_["FKM"], s_["IKM"]

            def g(x: dict) -> str:
                return f"{x['G']:.1f} % ({x['mean_gain']:.1f} %), {x['converged']} conv."

            lines.append(f"| {case.label} | {case.n_configs} | {case.paper_fkm} | {g(f)} | {case.paper_ikm} | {g(i)} | "
                         f"{f['rms_before'] * 1e6:.1f} → {f['rms_after'] * 1e6:.2f} / {i['rms_after'] * 1e6:.2f} µm | "
                         f"{f['std_ratio']:.2g} | {f['seconds'] * 1e3:.0f} / {i['seconds'] * 1e3:.0f} ms |")
            print(lines[-1])
    if args.quick:
        return
    out = ROOT / "docs" / "results"
    figs = figures(robot, out / "figures", seed=7)
    doc = out / "000_delta.md"
    doc.write_text(HEADER + "\n".join(lines) + "\n" + FOOTER.format(figs=figs[0].name, figs2=figs[1].name))
    print(f"\nwrote {doc} and {', '.join(str(f) for f in figs)}")


HEADER = """# Study 000 — Delta robot, FKM vs IKM (paper vs pincal)

Command: `python examples/study_000_delta.py` (10 random draws per case, medians).
Paper: Bentaleb et al., Delta robot calibration by forward (FKM) and inverse (IKM) kinematic models,
Section 4 (MATLAB, numerical Jacobians). pincal: the same robot (`robots_urdf/delta.urdf`), analytic
Jacobians through the loops, Levenberg–Marquardt on the identifiable directions.

**Identifiability first.** With position measurements, the paper's Model 24 (Dx, Dy, Dz, θ, α, Lax, Lay,
Lb per leg, Lax/Lay read as the arm vector's components in its plane of motion) has rank **21**, not 24:
per leg, Lay and α act only through one combination (turning the elbow about the motor axis is an
arm-angle offset). pincal reports it (`arm_i_joint.offset is not identifiable on its own ...`), keeps
the minimum-norm split, and so G over all 24 parameters cannot reach 100 % even without noise. The
paper's "G ≈ 100 %" is therefore not reproducible as stated with that reading. Replacing Lay by the
eighth error that position data *can* see — the motor axis' tilt (`model24i`) — makes all 24
identifiable (rank 24, κ ≈ 2·10³), and the noise-free gains become 100 %.

"""

FOOTER = """
Reading the table:
- Noise-free: with exact Jacobians **FKM converges from 1 cm errors** (the paper's FKM diverged) and
  both methods recover every identifiable parameter (G = 100 % with `model24i`); times are
  milliseconds against the paper's seconds.
- Noisy cases: the encoder noise (0.01° ≈ 45 µm at the platform) dominates the 1 µm tracker noise.
  The column *std / error* is the identified parameters' median a-priori standard deviation (from the
  stated noise, √diag((JᵀJ)⁻¹) of the whitened Jacobian) divided by the size of the errors sought.
  Where it exceeds about 1, the data
  cannot pin the parameters down better than their initial error, so a negative G is what *any*
  unbiased estimator gets: the paper's positive gains at 20–60 configurations cannot be matched
  under these noise levels as stated (its configuration set and G averaging are not given). What the
  calibration does deliver is the held-out position error: it falls to the noise floor set by the
  test readings' own encoder noise. The FKM weights each sample by its full covariance, encoder noise
  included (`joint_sigma`); the IKM has no such weighting yet.
- Configurations are drawn with arm angles within ±1 rad; at ±0.6 rad the identification Jacobian's
  condition number is ten times worse (≈ 2·10³ against ≈ 350), which is study 000's remark that the
  choice of configurations matters.

![per-parameter gain]({figs})

![operating points]({figs2})
"""


if __name__ == "__main__":
    main()
