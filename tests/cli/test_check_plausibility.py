"""``pincal check`` runs calibrate's checks of the data (docs/check.md, "Plausibility"), through the command line.

A UR10 calibrated on its own simulated positions is checked on data no UR10 can give as they stand: a UR5's positions
(with no '# robot:' line to say so), two joint columns swapped, a joint read with the other sign, positions ten times
too large. Each is what ``pincal calibrate`` refuses on the same file: the wrong unit before any work (exit 2, the same
line), the others as implausible (exit 1) with the likely cause calibrate names, instead of a verdict on two robots
that are both metres off.
"""

from __future__ import annotations

import json
from pathlib import Path
from typing import Any

import pytest
from conftest import run_pincal

#: The documented plausible correction of a joint placement's translation [m] (docs/calibrated_urdf.md).
PLACEMENT_LIMIT = 0.020


def _ok(done: object, *codes: int) -> None:
    assert done.returncode in (codes or (0,)), done.stdout + done.stderr  # type: ignore[attr-defined]


def _edited(source: Path, target: Path, *, swap: tuple[str, str] | None = None, negate: str | None = None,
            scale: float = 1.0, drop_robot_line: bool = False) -> Path:
    """``source`` (a measurement CSV) with the header names of the joint columns ``swap`` exchanged, the readings of
    joint ``negate`` negated, the position cells times ``scale``, and its '# robot:' line dropped when asked."""
    lines: list[str] = []
    header: list[str] | None = None
    for line in source.read_text(encoding="utf-8").splitlines():
        if line.startswith("#"):
            if not (drop_robot_line and line.startswith("# robot:")):
                lines.append(line)
            continue
        cells = line.split(",")
        if header is None:
            header = list(cells)
            if swap is not None:
                a, b = cells.index(swap[0]), cells.index(swap[1])
                cells[a], cells[b] = cells[b], cells[a]
        else:
            cells = [repr(-float(c)) if name == negate else
                     repr(float(c) * scale) if name.startswith("position:") and c else c
                     for name, c in zip(header, cells, strict=True)]
        lines.append(",".join(cells))
    target.write_text("\n".join(lines) + "\n", encoding="utf-8")
    return target


@pytest.fixture(scope="module")
def ur10(tmp_path_factory: pytest.TempPathFactory) -> Path:
    """cal.urdf: a UR10 calibrated on 40 simulated positions (fit/measurements.csv); ur5.csv: a UR5's 40 positions
    without their '# robot:' line."""
    root = tmp_path_factory.mktemp("plausibility")
    _ok(run_pincal("simulate", "ur10", "--measure", "position", "--samples", "40", "--seed", "1", "--out",
                   str(root / "fit"), "--quiet"))
    _ok(run_pincal("calibrate", "ur10", str(root / "fit" / "measurements.csv"), "--out", str(root / "cal.urdf")))
    _ok(run_pincal("simulate", "ur5", "--measure", "position", "--samples", "40", "--seed", "2", "--out",
                   str(root / "ur5"), "--quiet"))
    _edited(root / "ur5" / "measurements.csv", root / "ur5.csv", drop_robot_line=True)
    return root


def _check(ur10: Path, data: Path, *extra: str, codes: tuple[int, ...]) -> dict[str, Any]:
    """``pincal check cal.urdf DATA EXTRA --report``: its exit status checked, its report read (with its stdout)."""
    report = data.with_suffix(f".check{len(extra)}.json")
    done = run_pincal("check", str(ur10 / "cal.urdf"), str(data), *extra, "--report", str(report))
    assert done.returncode in codes, done.stdout + done.stderr
    content: dict[str, Any] = json.loads(report.read_text(encoding="utf-8"))
    content["stdout"] = done.stdout
    return content


def _calibrated_cause(data: Path) -> str:
    """What ``pincal calibrate ur10 DATA`` finds: its exit status is 1 (implausible), its likely cause returned."""
    report = data.with_suffix(".calibrate.json")
    done = run_pincal("calibrate", "ur10", str(data), "--report", str(report))
    assert done.returncode == 1, done.stdout + done.stderr
    content = json.loads(report.read_text(encoding="utf-8"))
    assert content["implausible"], content["implausible_cause"]
    return str(content["implausible_cause"])


def _one_line(text: str) -> str:
    return " ".join(text.split())


def test_the_calibration_s_own_data_are_plausible(ur10: Path) -> None:
    """The control: the data the model was calibrated on pass calibrate's checks in check too."""
    out = _check(ur10, ur10 / "fit" / "measurements.csv", codes=(0,))
    assert out["implausible"] is None and "IMPLAUSIBLE" not in out["stdout"]
    assert out["rms"] < 1e-4 < PLACEMENT_LIMIT


@pytest.mark.parametrize("register", [(), ("--register",)])
def test_a_ur5_s_data_checked_on_a_ur10_calibration_is_implausible(ur10: Path, register: tuple[str, ...]) -> None:
    """Both robots are ~220 mm RMS off a UR5's positions: which of them is worse says nothing. Check names what
    calibrate names on the same file: a wrong robot model, the UR10's upper arm and forearm corrected by the UR5's
    difference (far beyond 20 mm); exit 1, and no verdict on MODEL."""
    out = _check(ur10, ur10 / "ur5.csv", *register, codes=(1,))
    found = out["implausible"]
    assert found["quantity"] == "length" and found["nominal_rms"] > 5 * found["limit"]
    assert found["limit"] == pytest.approx(PLACEMENT_LIMIT)
    assert {c["parameter"] for c in found["corrections"]} >= {"elbow_joint.tz", "wrist_1_joint.tx"}
    assert all(abs(c["value"]) > 5 * PLACEMENT_LIMIT for c in found["corrections"])
    assert "wrong robot model" in found["cause"]
    assert found["cause"] == _calibrated_cause(ur10 / "ur5.csv")
    stdout = _one_line(out["stdout"])
    assert "IMPLAUSIBLE:" in stdout and f"likely cause: {found['cause']}" in stdout
    assert "no worse than the nominal robot" not in stdout and "verdict: none" in stdout
    page = (ur10 / f"ur5{len(register)}.html")
    _ok(run_pincal("check", str(ur10 / "cal.urdf"), str(ur10 / "ur5.csv"), *register, "--html", str(page)), 1)
    text = _one_line(page.read_text(encoding="utf-8"))
    assert "IMPLAUSIBLE" in text and "no worse" not in text and "wrong robot model" in text


@pytest.mark.parametrize(("edit", "words"), [
    ({"swap": ("shoulder_lift_joint", "elbow_joint")},
     "the columns of joints 'shoulder_lift_joint' and 'elbow_joint' look exchanged"),
    ({"negate": "elbow_joint"}, "joint 'elbow_joint' looks read with the other sign"),
])
def test_swapped_columns_and_a_flipped_sign_are_implausible(ur10: Path, edit: dict[str, Any], words: str) -> None:
    """Two joint columns swapped, or a joint read with the other sign: metre-size errors on both sides. Check names
    the mistake calibrate refuses the same file for (exit 1, no verdict), not the hint that the tracker moved; with
    ``--plausible off`` the two robots are compared as they stand."""
    name = "swapped" if "swap" in edit else "flipped"
    data = _edited(ur10 / "fit" / "measurements.csv", ur10 / f"{name}.csv", **edit)
    out = _check(ur10, data, codes=(1,))
    found = out["implausible"]
    assert found["nominal_rms"] > 0.1 and found["cause"].startswith(words)  # [m]
    refused = run_pincal("calibrate", "ur10", str(data))
    assert refused.returncode == 2 and words in refused.stderr, refused.stdout + refused.stderr
    stdout = _one_line(out["stdout"])
    assert f"likely cause: {words}" in stdout and "check with --register" not in stdout
    assert "no worse than the nominal robot" not in stdout and "verdict: none" in stdout
    off = _check(ur10, data, "--plausible", "off", codes=(0, 1))  # the check turned off: the two robots compared
    assert off["implausible"] is None and "IMPLAUSIBLE" not in off["stdout"]


def test_positions_ten_times_too_large_are_refused_before_any_work_as_calibrate_refuses_them(ur10: Path) -> None:
    data = _edited(ur10 / "fit" / "measurements.csv", ur10 / "x10.csv", scale=10.0)
    checked = run_pincal("check", str(ur10 / "cal.urdf"), str(data))
    calibrated = run_pincal("calibrate", "ur10", str(data))
    lines = checked.stderr.strip().splitlines()
    assert checked.returncode == 2 and len(lines) == 1 and not checked.stdout, checked.stdout + checked.stderr
    assert "'position:tool0'" in lines[0] and "10× as much" in lines[0]
    assert calibrated.returncode == 2 and lines == calibrated.stderr.strip().splitlines()  # the same line


def test_few_samples_that_model_explains_are_not_called_another_robot_s(tmp_path: Path) -> None:
    """The TALOS left arm calibrated from its job file, checked on its own 4 held-out rows: too few to calibrate on
    alone (12 readings, 98 parameters) and the nominal robot's tilt beyond 2°, but MODEL, a calibrated robot of this
    model, predicts them within the limits: DATA are plausible, and the verdict is MODEL's against the nominal robot,
    not "DATA are not of a robot of this model". A UR5's 4 positions on a UR10 calibration stay implausible: MODEL
    is as far off them as the nominal robot."""
    job = Path(__file__).resolve().parents[2] / "examples" / "data" / "talos_table_contact" / "left_job.toml"
    cal = tmp_path / "cal.urdf"
    _ok(run_pincal("calibrate", str(job), "--out", str(cal)), 0, 1)
    report = tmp_path / "check.json"
    done = run_pincal("check", str(cal), str(job), "--set", "test", "--report", str(report))
    content = json.loads(report.read_text(encoding="utf-8"))
    assert content["n_samples"] == 4 and content["implausible"] is None, done.stdout
    assert content["nominal_rms_angle"] > 0.0349 > content["rms_angle"]  # [rad]: the nominal robot beyond 2°
    assert done.returncode == 0 and "verdict: MODEL predicts DATA no worse than the nominal robot" in done.stdout


def test_a_few_positions_of_another_robot_stay_implausible(ur10: Path) -> None:
    lines = (ur10 / "ur5.csv").read_text(encoding="utf-8").splitlines()
    header = next(k for k, line in enumerate(lines) if line.startswith("sample,"))
    few = ur10 / "ur5_few.csv"
    few.write_text("\n".join(lines[:header + 5]) + "\n", encoding="utf-8")
    out = _check(ur10, few, codes=(1,))
    assert out["n_samples"] == 4 and out["implausible"] is not None and "verdict: none" in out["stdout"]
