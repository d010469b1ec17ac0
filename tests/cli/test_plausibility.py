"""Implausible results are refused, through the command line: data of another robot (a UR5's calibrated as a UR10),
positions in another unit (a Delta's multiplied by 3), a fit that explains nothing (residuals beyond 1000 × σ), a
measurement of a frame no joint moves, while healthy simulated runs, the TIAGo mocap data and the TALOS contacts pass;
``--plausible`` changes the limits or turns the check off; the report JSON holds what was found."""

from __future__ import annotations

import json
from pathlib import Path

import numpy as np
import pytest
from conftest import ROOT, run_pincal

import pincal

#: The documented plausible correction of a joint placement's translation [m] (docs/calibrated_urdf.md).
PLACEMENT_LIMIT = 0.020
#: The documented prior σ of a joint placement's translation [m] (docs/calibrated_urdf.md, "The prior").
PLACEMENT_PRIOR = 0.005


def _simulate(folder: Path, robot: str, samples: int = 30, test_samples: int = 0) -> Path:
    done = run_pincal("simulate", robot, "--samples", str(samples), "--test-samples", str(test_samples), "--seed", "1",
                      "--quiet", "--out", str(folder))
    assert done.returncode == 0, done.stderr
    return folder / "measurements.csv"


def _rewritten(source: Path, target: Path, factor: float = 1.0, drop_robot_line: bool = False) -> Path:
    """``source`` with its position cells multiplied by ``factor`` (its '# units' line kept), and without its
    '# robot:' line when ``drop_robot_line``."""
    lines, header = [], None
    for line in source.read_text(encoding="utf-8").splitlines():
        if line.startswith("#"):
            if not (drop_robot_line and line.startswith("# robot:")):
                lines.append(line)
            continue
        cells = line.split(",")
        if header is None:
            header = cells
        else:
            cells = [repr(float(c) * factor) if name.startswith("position:") and c else c
                     for name, c in zip(header, cells, strict=True)]
        lines.append(",".join(cells))
    target.write_text("\n".join(lines) + "\n", encoding="utf-8")
    return target


@pytest.fixture(scope="module")
def ur5_data(tmp_path_factory: pytest.TempPathFactory) -> Path:
    """A UR5's simulated measurements with no '# robot:' line: nothing says they are not a UR10's."""
    folder = tmp_path_factory.mktemp("ur5")
    return _rewritten(_simulate(folder / "sim", "ur5", 40, 10), folder / "ur5.csv", drop_robot_line=True)


@pytest.fixture(scope="module")
def delta_data(tmp_path_factory: pytest.TempPathFactory) -> Path:
    folder = tmp_path_factory.mktemp("delta")
    return _simulate(folder / "sim", "delta", 30, 10)


def _placement(robot: str, joint: str) -> np.ndarray:
    model = pincal.load_robot(robot).model
    return np.array(model.jointPlacements[model.getJointId(joint)].translation)


def test_a_ur5_calibrated_as_a_ur10_is_refused_naming_the_arm_s_lengths(ur5_data: Path, tmp_path: Path) -> None:
    report = tmp_path / "r.json"
    done = run_pincal("calibrate", "ur10", str(ur5_data), "--report", str(report), "--out", str(tmp_path / "c.urdf"))
    assert done.returncode == 1, done.stderr
    first = done.stdout.splitlines()[0]
    assert first.startswith("IMPLAUSIBLE"), done.stdout
    assert "wrong robot model" in done.stdout
    content = json.loads(report.read_text(encoding="utf-8"))
    found = {c["parameter"]: c for c in content["implausible"]}
    # the upper arm and the forearm: the UR5's are shorter than the UR10's by what its URDF says
    for joint, axis in (("elbow_joint", 2), ("wrist_1_joint", 2)):
        shorter = _placement("ur5", joint)[axis] - _placement("ur10", joint)[axis]
        assert abs(shorter) > 5 * PLACEMENT_LIMIT
        flagged = [c for name, c in found.items() if name.startswith(f"{joint}.")]
        assert flagged, (joint, sorted(found))
        assert abs(abs(flagged[0]["value"]) - abs(shorter)) < 0.01, (joint, flagged, shorter)
        assert f"{flagged[0]['parameter']} corrected by" in done.stdout
    for entry in found.values():
        assert entry["limit"] == pytest.approx(PLACEMENT_LIMIT) and entry["unit"] == "m"
        assert abs(entry["value"]) > entry["limit"]
        assert content["parameters"][entry["parameter"]]["value"] == pytest.approx(entry["fitted"])
    assert content["implausible_scale"] == [] and "wrong robot model" in content["implausible_cause"]
    assert content["rms_after"] < 1e-4  # the fit itself looks perfect: only the corrections give it away
    assert "IMPLAUSIBLE" in (tmp_path / "c.urdf").read_text(encoding="utf-8")


def test_the_limit_is_a_factor_and_can_be_turned_off(ur5_data: Path, tmp_path: Path) -> None:
    wide = tmp_path / "wide.json"
    done = run_pincal("calibrate", "ur10", str(ur5_data), "--plausible", "4", "--report", str(wide))
    assert done.returncode == 1, done.stderr
    limits = [c["limit"] for c in json.loads(wide.read_text(encoding="utf-8"))["implausible"]]
    assert limits and limits == pytest.approx([4 * PLACEMENT_LIMIT] * len(limits))
    off = tmp_path / "off.json"
    done = run_pincal("calibrate", "ur10", str(ur5_data), "--plausible", "off", "--report", str(off))
    assert done.returncode == 0, done.stdout
    assert "IMPLAUSIBLE" not in done.stdout
    content = json.loads(off.read_text(encoding="utf-8"))
    assert content["implausible"] == [] and content["plausible"] == "off"
    done = run_pincal("calibrate", "ur10", str(ur5_data), "--plausible", "50")  # limits of a metre: let through
    assert done.returncode == 0, done.stdout
    for wrong in ("0", "-1", "never"):
        done = run_pincal("calibrate", "ur10", str(ur5_data), "--plausible", wrong)
        assert done.returncode == 2 and "--plausible" in done.stderr, done.stderr


def test_view_report_and_fleet_refuse_it_too(ur5_data: Path, tmp_path: Path) -> None:
    done = run_pincal("view", "ur10", str(ur5_data), "--out", str(tmp_path / "v.html"), "--quiet")
    assert done.returncode == 1 and "IMPLAUSIBLE" in done.stderr, done.stderr
    fleet = tmp_path / "fleet"
    fleet.mkdir()
    (fleet / "arm.csv").write_bytes(ur5_data.read_bytes())
    done = run_pincal("fleet", "ur10", str(fleet), "--out", str(tmp_path / "out"), "--workers", "1")
    assert done.returncode == 1, done.stderr
    assert "IMPLAUSIBLE (elbow_joint" in done.stdout


def test_positions_three_times_too_large_are_refused_before_the_fit(delta_data: Path, tmp_path: Path) -> None:
    """Beyond the plausible band (1.5x) the run ends before any fit, naming the columns and the factor."""
    scaled = _rewritten(delta_data, tmp_path / "feet.csv", factor=3.0)
    report = tmp_path / "r.json"
    done = run_pincal("calibrate", "delta", str(scaled), "--report", str(report))
    assert done.returncode == 2 and done.stdout == "" and not report.exists(), done.stderr
    line = done.stderr.strip()
    assert line.startswith("pincal: error: the measured positions 'position:end_effector' (columns "
                           "position:end_effector:x, position:end_effector:y, position:end_effector:z, read in m)")
    assert "(3× as much, beyond 1.5× either way): no length unit explains a factor of 3" in line


def test_positions_twice_too_large_name_the_placements_the_fit_stretched(delta_data: Path, tmp_path: Path) -> None:
    """Twice the size within a band widened by --plausible 3 (2.5x), the Delta's fit converges by stretching its
    legs: the placements are named with the data's scale; by default the run ends before the fit."""
    scaled = _rewritten(delta_data, tmp_path / "twice.csv", factor=2.0)
    assert "(2× as much, beyond 1.5× either way)" in run_pincal("calibrate", "delta", str(scaled)).stderr
    report = tmp_path / "r.json"
    done = run_pincal("calibrate", "delta", str(scaled), "--report", str(report), "--plausible", "3")
    assert done.returncode == 1, done.stderr
    content = json.loads(report.read_text(encoding="utf-8"))
    assert content["converged"] and content["implausible_scale"] == []
    assert content["length_scale"]["position:end_effector"] == pytest.approx(2.0, rel=0.05)
    assert "spread 2 times as far as this robot's would" in content["implausible_cause"]
    largest = max(abs(c["value"]) for c in content["implausible"])
    assert largest > 0.1  # tenths of a metre: a Delta twice its size
    assert content["implausible"][0]["parameter"] in done.stdout


@pytest.mark.parametrize("robot", ["delta", "hexapod", "five_bar", "ur10", "panda"])
def test_a_healthy_simulated_run_is_not_flagged(robot: str, tmp_path: Path) -> None:
    data = _simulate(tmp_path / "sim", robot, 25)
    report = tmp_path / "r.json"
    done = run_pincal("calibrate", robot, str(data), "--report", str(report))
    assert done.returncode == 0, done.stdout
    content = json.loads(report.read_text(encoding="utf-8"))
    assert content["implausible"] == [] and content["implausible_scale"] == [] and content["implausible_cause"] == ""
    assert content["explains_nothing"] is False
    for scale in content["length_scale"].values():
        assert abs(scale - 1.0) < 0.02  # true errors of 1 mm on a robot tens of centimetres wide
    assert "IMPLAUSIBLE" not in done.stdout


def test_the_tiago_mocap_data_are_not_flagged(tmp_path: Path) -> None:
    """Real data: the arm is fitted with its mocap frame and marker metres and centimetres away, and its
    arm_1_joint.ty moves with the frame: by the default command (the evidence holds the translations firmer than
    their kinds' σ) beyond that σ, by BIC's selection with the prior at its kinds' σ (``--select bic --prior 1``)
    beyond twice that σ, near the plausible limit; none of it needed, neither flagged."""
    for name, options in (("default", ()), ("bic", ("--select", "bic", "--prior", "1"))):
        report = tmp_path / f"{name}.json"
        done = run_pincal("calibrate", "tiago_no_hand", str(ROOT / "examples" / "data" / "tiago_mocap_marker1.csv"),
                          *options, "--report", str(report))
        assert done.returncode == 0, done.stdout
        content = json.loads(report.read_text(encoding="utf-8"))
        assert content["implausible"] == [] and content["implausible_scale"] == []
        assert content["explains_nothing"] is False and "IMPLAUSIBLE" not in done.stdout
        fitted = content["parameters"]
        assert abs(fitted["base.tz"]["value"]) > 10 * PLACEMENT_LIMIT  # the setup: unbounded
        moved = max(abs(v["value"]) for key, v in fitted.items() if key.startswith("arm_1_joint.t"))
        assert moved > (PLACEMENT_PRIOR if name == "default" else 2 * PLACEMENT_PRIOR)
    done = run_pincal("calibrate", str(ROOT / "examples" / "tiago_job.toml"))
    assert done.returncode == 0 and "IMPLAUSIBLE" not in done.stdout, done.stdout
    # the TALOS contacts (σ estimated from the data, the left arm's fit at 3.75 σ): a result, as before
    done = run_pincal("calibrate", str(ROOT / "examples" / "data" / "talos_table_contact" / "left_job.toml"))
    assert done.returncode == 0 and "EXPLAINS NOTHING" not in done.stdout, done.stdout


def _shuffled(source: Path, target: Path) -> Path:
    """``source`` with its rows' position cells in another order (a fixed permutation): readings that belong to no
    posture of theirs."""
    lines = source.read_text(encoding="utf-8").splitlines()
    start = next(k for k, line in enumerate(lines) if not line.startswith("#"))
    header, rows = lines[start].split(","), [line.split(",") for line in lines[start + 1:]]
    order = np.random.default_rng(3).permutation(len(rows))
    rows = [[rows[order[k]][c] if name.startswith("position:") else cell for c, (name, cell)
             in enumerate(zip(header, row, strict=True))] for k, row in enumerate(rows)]
    target.write_text("\n".join([*lines[:start + 1], *(",".join(row) for row in rows)]) + "\n", encoding="utf-8")
    return target


def test_a_fit_that_explains_nothing_exits_1_and_writes_no_calibrated_urdf(tmp_path: Path) -> None:
    """Readings shuffled between the postures, with the file's σ of 10 µm: the measurement frame alone (unbounded,
    so nothing is implausible) converges at tens of thousands of σ. It is not a result: exit 1, said first, no URDF;
    --force writes it, saying so in its header."""
    data = _shuffled(_simulate(tmp_path / "sim", "ur10"), tmp_path / "shuffled.csv")
    out, report = tmp_path / "cal.urdf", tmp_path / "r.json"
    done = run_pincal("calibrate", "ur10", str(data), "--parameters", "base.*", "--out", str(out), "--report",
                      str(report))
    assert done.returncode == 1, done.stderr
    first = done.stdout.splitlines()[0]
    assert first.startswith("THE FIT EXPLAINS NOTHING: residuals ") and "beyond 1000 × σ" in first, done.stdout
    assert f"not written: {out} (the fit explains nothing; --force writes it)" in done.stdout
    assert not out.exists() and f"wrote {report}" in done.stdout
    content = json.loads(report.read_text(encoding="utf-8"))
    assert content["explains_nothing"] is True and content["converged"] and content["implausible"] == []
    assert content["sigma2"] > 1e6
    forced = run_pincal("calibrate", "ur10", str(data), "--parameters", "base.*", "--out", str(out), "--force")
    assert forced.returncode == 1 and f"wrote {out}" in forced.stdout, forced.stdout
    assert "EXPLAINS NOTHING (residuals" in out.read_text(encoding="utf-8").splitlines()[1]
    fleet = tmp_path / "fleet"
    fleet.mkdir()
    (fleet / "arm.csv").write_bytes(data.read_bytes())
    done = run_pincal("fleet", "ur10", str(fleet), "--out", str(tmp_path / "out"), "--workers", "1", "--parameters",
                      "base.*")
    assert done.returncode == 1 and "EXPLAINS NOTHING (residuals" in done.stdout, done.stdout
    assert not (tmp_path / "out" / "arm.urdf").exists() and (tmp_path / "out" / "arm.json").exists()


def test_a_camera_on_a_frame_no_joint_moves_is_refused_before_the_fit(tmp_path: Path) -> None:
    """A camera declared on base_link sees the world target from one place whatever the joints do: once the fit ran
    to 9.8e4 σ and wrote a calibrated URDF; now one line names the measurement and the frame, nothing written."""
    done = run_pincal("simulate", "ur10", "--measure", "camera:tool0", "--samples", "20", "--seed", "1", "--quiet",
                      "--out", str(tmp_path / "sim"))
    assert done.returncode == 0, done.stderr
    data = tmp_path / "on_base.csv"
    data.write_text((tmp_path / "sim" / "measurements.csv").read_text(encoding="utf-8").replace("tool0", "base_link"),
                    encoding="utf-8")
    out = tmp_path / "cal.urdf"
    done = run_pincal("calibrate", "ur10", str(data), "--out", str(out))
    assert done.returncode == 2 and done.stdout == "" and not out.exists(), done.stdout
    assert done.stderr == ("pincal: error: measurement 'camera:base_link' reads frame 'base_link', which no actuated "
                           "joint of 'ur10' moves: its readings are the same in every posture and can calibrate "
                           "nothing; measure a frame the joints move (e.g. 'tool0', the default measured frame)\n")


@pytest.mark.parametrize("command", ["view", "report"])
def test_view_and_report_refuse_implausible_data_in_one_stderr_line(delta_data: Path, tmp_path: Path,
                                                                   command: str) -> None:
    """Their progress line ('calibrating ... from N samples ...') went to stderr before the error: two lines where
    calibrate gives one; it is on stdout now."""
    scaled = _rewritten(delta_data, tmp_path / "feet.csv", factor=3.0)
    page = tmp_path / "page.html"
    done = run_pincal(command, "delta", str(scaled), "--out", str(page))
    assert done.returncode == 2 and not page.exists(), done.stderr
    assert len(done.stderr.splitlines()) == 1, done.stderr
    assert done.stderr.startswith("pincal: error: the measured positions 'position:end_effector' (columns ")
    assert done.stdout == "calibrating 'delta' from 40 samples ...\n"  # 30 to fit, 10 held out
