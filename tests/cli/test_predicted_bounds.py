"""Predicted accuracy as a user runs it (docs/predicted_accuracy.md): ``pincal calibrate`` gives each held-out posture
a predicted 95 % bound and records the fitted joint ranges; ``pincal check`` with the report JSON or the calibrated URDF
gives each posture its bound and the coverage, grown with the distance beyond the fitted range, with a warning;
``pincal compensate`` warns for commands beyond it and gives each target its bound.

A Delta is simulated with its arms within ±0.3 rad of the reference and calibrated; a second simulation of the same
truth (same seed: the truth is drawn before the postures) within the whole joint limits is the new data, many of its
postures beyond the fitted range.
"""

from __future__ import annotations

import csv
import json
import re
from pathlib import Path

import pytest
from conftest import run_pincal


def _ok(done: object) -> None:
    assert done.returncode == 0, done.stdout + done.stderr  # type: ignore[attr-defined]


@pytest.fixture(scope="module")
def delta(tmp_path_factory: pytest.TempPathFactory) -> Path:
    """D/: 40 + 30 postures within ±0.3 rad, calibrated (cal.urdf, r.json); N/: 30 postures of the same truth within
    the joint limits."""
    root = tmp_path_factory.mktemp("predicted")
    _ok(run_pincal("simulate", "delta", "--samples", "40", "--test-samples", "30", "--spread", "0.3", "--seed", "4",
                   "--quiet", "--out", str(root / "D")))
    _ok(run_pincal("simulate", "delta", "--samples", "30", "--seed", "4", "--quiet", "--out", str(root / "N")))
    done = run_pincal("calibrate", "delta", str(root / "D" / "measurements.csv"), "--out", str(root / "cal.urdf"),
                      "--report", str(root / "r.json"))
    _ok(done)
    (root / "calibrate.txt").write_text(done.stdout, encoding="utf-8")
    return root


def test_calibrate_predicts_each_held_out_error(delta: Path) -> None:
    report = json.loads((delta / "r.json").read_text(encoding="utf-8"))
    held = report["predicted_held_out"]
    errors = {e["sample"]: e["after"] for e in report["sample_errors"] if e["set"] == "test"}
    assert len(held["samples_predicted"]) == len(errors) == 30
    inside = sum(errors[s["sample"]] <= s["bound"] for s in held["samples_predicted"])
    assert held["inside"] == inside and held["samples"] == 30
    assert inside >= 26  # 95 % of 30, less two binomial standard deviations
    for entry in held["samples_predicted"]:
        sigma = entry["sigma"]
        assert len(sigma) == 3 and all(5e-6 < s < 5e-5 for s in sigma)  # about the 10 µm noise per axis
        assert 2.0 * max(sigma) < entry["bound"] < 4.0 * max(sigma)  # √χ²₃(95 %) = 2.80 for isotropic errors
    line = next(x for x in (delta / "calibrate.txt").read_text(encoding="utf-8").splitlines()
                if x.startswith("predicted 95 % bound (held out)"))
    assert f"{inside} of 30 errors within their bound" in line
    space = report["predicted_workspace"]
    assert space["postures"] > 50 and len(space["bounds"]) == len(space["positions"]) == space["postures"]
    assert space["outside_fitted_range"] > 0  # the whole joint limits reach beyond ±0.3 rad
    assert space["max_bound"] > space["median_bound"] > 0


def test_the_fitted_ranges_are_recorded_in_the_report_and_the_urdf(delta: Path) -> None:
    report = json.loads((delta / "r.json").read_text(encoding="utf-8"))
    ranges = report["fitted_range"]
    assert set(ranges) == {"arm_1_joint", "arm_2_joint", "arm_3_joint"}
    assert all(-0.3 <= low < high <= 0.3 for low, high in ranges.values())
    urdf = (delta / "cal.urdf").read_text(encoding="utf-8")
    recorded = re.search(r"<pincal_provenance [^>]*fitted_range='([^']*)'", urdf)
    assert recorded is not None and json.loads(recorded.group(1)) == ranges


def test_check_gives_each_posture_its_bound_widened_beyond_the_fitted_range(delta: Path) -> None:
    out = delta / "check.json"
    done = run_pincal("check", str(delta / "r.json"), str(delta / "N" / "measurements.csv"), "--report", str(out))
    assert done.returncode in (0, 1), done.stderr
    content = json.loads(out.read_text(encoding="utf-8"))
    predicted = content["predicted"]
    beyond = [s for s in content["samples"] if s["distance"] > 0.0]
    within = [s for s in content["samples"] if s["distance"] == 0.0]
    assert beyond and within and set(predicted["beyond"]) == {s["sample"] for s in beyond}
    assert all(s["outside_range"] for s in beyond)  # the same postures the fitted-range check flags
    assert predicted["samples"] == 30 and predicted["inside"] == sum(s["error"] <= s["bound"]
                                                                     for s in content["samples"])
    assert predicted["beyond_range"]["samples"] == len(beyond) and predicted["in_range"]["samples"] == len(within)
    assert min(s["bound"] for s in beyond) > max(s["bound"] for s in within)  # extrapolation is less certain
    farthest = max(beyond, key=lambda s: s["distance"])
    assert farthest["bound"] == max(s["bound"] for s in content["samples"])  # the bound grows with the distance
    assert all(s["bound"] <= s["nominal_bound"] + 1e-3 for s in content["samples"])  # never past the nominal's own
    assert re.search(r"^predicted 95 % bound: median [\d.]+ mm; \d+ of 30 errors of MODEL within", done.stdout, re.M)
    assert re.search(rf"^warning: {len(beyond)} postures lie beyond the joint ranges the calibration fitted",
                     done.stdout, re.M)
    assert "range widths beyond the fitted range)" in done.stdout


def test_check_of_a_calibrated_urdf_gives_the_bounds_the_report_gives(delta: Path) -> None:
    """The calibrated URDF carries its calibration: check gives each posture the bound it gives with the report JSON;
    a robot name carries none, and the summary says why."""
    bounds = {}
    for model in ("cal.urdf", "r.json"):
        out = delta / f"check_{model}.json"
        done = run_pincal("check", str(delta / model), str(delta / "N" / "measurements.csv"), "--report", str(out))
        assert done.returncode in (0, 1), done.stderr
        bounds[model] = [s["bound"] for s in json.loads(out.read_text(encoding="utf-8"))["samples"]]
    assert bounds["cal.urdf"] == pytest.approx(bounds["r.json"], rel=1e-6) and all(b > 0 for b in bounds["cal.urdf"])
    done = run_pincal("check", "delta", str(delta / "N" / "measurements.csv"), "--nominal", "delta")
    assert done.returncode in (0, 1), done.stderr
    assert "predicted errors: not known: MODEL carries no calibration" in done.stdout


def test_compensate_warns_for_commands_beyond_the_fitted_range(delta: Path) -> None:
    lines = (delta / "N" / "measurements.csv").read_text(encoding="utf-8").splitlines()
    rows = list(csv.DictReader(line for line in lines if not line.startswith("#")))
    targets = delta / "targets.csv"
    with targets.open("w", newline="", encoding="utf-8") as stream:
        writer = csv.writer(stream)
        key = "position:end_effector"
        writer.writerow(["sample", *(f"{key}:{c}" for c in "xyz")])
        writer.writerows([f"t{k}", *(row[f"{key}:{c}"] for c in "xyz")] for k, row in enumerate(rows))
    done = run_pincal("compensate", str(delta / "cal.urdf"), str(targets), "--out", str(delta / "commands.csv"))
    assert done.returncode in (0, 1), done.stdout + done.stderr  # 1: a target unreachable
    assert re.search(r"^warning: the commands of \d+ targets \(t\d+.*leave the joint ranges the calibration fitted",
                     done.stdout, re.M)
    assert re.search(r"^predicted 95 % bound at the targets .*: median [\d.]+ mm, largest [\d.]+ mm", done.stdout,
                     re.M)
    lines = [x for x in (delta / "commands.csv").read_text(encoding="utf-8").splitlines() if not x.startswith("#")]
    commands = list(csv.DictReader(lines))
    reached = [row for row in commands if row["status"] == "ok"]
    assert reached and all(float(row["bound"]) > 0.0 and float(row["nominal_bound"]) > 0.0 for row in reached)
    marked = sum(float(row["bound"]) > float(row["nominal_bound"]) for row in reached)
    if marked:
        assert re.search(rf"^warning: at {marked} targets .* the calibrated model's bound exceeds the nominal robot's",
                         done.stdout, re.M)
