"""The planning commands ``pincal design`` and ``pincal montecarlo``, run through ``pincal.cli.app.main``; and the
progress bars of long work: shown on a terminal unless ``--quiet``, never by library defaults."""

from __future__ import annotations

import io
import re
import sys
from pathlib import Path

import numpy as np
import pytest
from conftest import run_pincal
from mechanisms import crank_rocker_urdf

import pincal
import pincal.cli.app
from pincal.cli.app import main
from pincal.identification import measurements as ms
from pincal.identification.parameters import choose_parameters
from pincal.identification.problem import CalibrationProblem, Observations
from pincal.io.dataset_reader import read_dataset
from pincal.study.montecarlo import run_monte_carlo
from pincal.study.pose_selection import jacobian_blocks, select_poses
from pincal.study.simulation import random_actuated

DESIGN = ["design", "delta", "--candidates", "150", "--poses", "12", "--measure", "position",
          "--parameters", "model24", "--seed", "1"]
MONTE_CARLO = ["montecarlo", "five_bar", "--trials", "3", "--samples", "10", "--test-samples", "5",
               "--measure", "distance:base_link-end_effector", "--parameters", "*.offset",
               "--noise", "0", "1e-6", "1e-5", "--seed", "4"]


class Terminal(io.StringIO):
    """A stderr that says it is a terminal, so progress bars draw into it."""

    def isatty(self) -> bool:
        return True


def _number(line: str, position: int) -> float:
    return float(re.findall(r"-?[\d.]+(?:e[-+]?\d+)?", line)[position])


def test_design_beats_random_sets_and_writes_the_chosen_postures(tmp_path: Path,
                                                                 capsys: pytest.CaptureFixture[str]) -> None:
    out = tmp_path / "poses.csv"
    assert main([*DESIGN, "--out", str(out), "--quiet"]) == 0
    text = capsys.readouterr().out
    kappa_line = next(line for line in text.splitlines() if line.startswith("condition number κ"))
    chosen, random_median = _number(kappa_line, 0), _number(kappa_line, 1)
    assert chosen < 0.5 * random_median
    # the CSV: K rows of the actuated joints only, SI, readable by pincal (measurement columns to be filled in)
    robot = pincal.load_robot("delta")
    data = read_dataset(out, robot.actuated_joints)
    assert data.n_samples == 12 and data.joint_names == list(robot.actuated_joints) and data.measurements == {}
    header = next(line for line in out.read_text(encoding="utf-8").splitlines() if not line.startswith("#"))
    assert header == "sample,set,arm_1_joint,arm_2_joint,arm_3_joint"
    assert data.metadata["robot"] == "delta" and data.metadata["units"] == "SI (m, rad)"
    # they are the candidates the library's selection chooses, and their κ is the one printed
    models = [ms.position("end_effector", 1e-5)]
    pset = choose_parameters(robot, models, ["model24"])
    qa, _ = random_actuated(robot, 150, np.random.default_rng(1))
    blocks = jacobian_blocks(CalibrationProblem(robot, pset, models, Observations.neutral(models, qa)))
    selection = select_poses(blocks, 12, scales=pset.scales)
    np.testing.assert_array_equal(data.joints, qa[selection.indices])
    assert chosen == pytest.approx(selection.condition_number, rel=1e-3)


def test_design_for_a_scale_reset_uses_differences_and_prints_without_out(
        capsys: pytest.CaptureFixture[str]) -> None:
    code = main(["design", "five_bar", "--candidates", "40", "--poses", "6", "--measure",
                 "distance_increment:scale_body-scale_slider", "--parameters", "*.offset", "--criterion", "d-optimal",
                 "--quiet"])
    text = capsys.readouterr().out
    assert code == 0 and "measuring distance_increment:scale_body-scale_slider, by d-optimal" in text
    log_det = next(line for line in text.splitlines() if line.startswith("log det"))
    assert _number(log_det, 0) > _number(log_det, 1)
    rows = text.splitlines()[text.splitlines().index("chosen postures, in measuring order (actuated values):") + 2:]
    assert len(rows) == 6 and all(len(row.split()) == 2 for row in rows)


def _table(text: str) -> list[list[str]]:
    lines = text.splitlines()
    start = next(k for k, line in enumerate(lines) if line.lstrip().startswith("noise σ"))
    return [re.split(r"\s{2,}", line.strip()) for line in lines[start + 1:]]


def test_monte_carlo_table_has_a_row_per_noise_level_and_depends_only_on_the_seed(
        capsys: pytest.CaptureFixture[str]) -> None:
    assert main([*MONTE_CARLO, "--workers", "1", "--quiet"]) == 0
    serial = capsys.readouterr()
    assert main([*MONTE_CARLO, "--workers", "2", "--quiet"]) == 0
    pooled = capsys.readouterr()
    assert serial.out == pooled.out and serial.err == pooled.err == ""
    rows = _table(serial.out)
    assert [float(row[0]) for row in rows] == [0.0, 1e-6, 1e-5]
    for row in rows:
        before, after, _, _, converged = row[1:]
        assert converged == "3/3"
        assert _number(after, 0) < _number(before, 0)  # medians [mm]
    # noise-free: the offsets come back exactly; the gain drops as the noise grows
    assert rows[0][2].startswith("0.0000") and rows[0][3].startswith("100.0")
    assert _number(rows[2][3], 0) < _number(rows[1][3], 0) <= 100.0


def test_progress_shows_on_a_terminal_and_quiet_silences_it(monkeypatch: pytest.MonkeyPatch,
                                                           capsys: pytest.CaptureFixture[str]) -> None:
    for args, bars in ((DESIGN, ["postures of 'delta' [", "pose selection ["]),
                       ([*MONTE_CARLO[:3], "1", *MONTE_CARLO[4:], "--workers", "1"], ["Monte Carlo trials ["])):
        terminal = Terminal()
        monkeypatch.setattr(sys, "stderr", terminal)
        assert main(args) == 0
        assert all(bar in terminal.getvalue() for bar in bars)
        terminal = Terminal()
        monkeypatch.setattr(sys, "stderr", terminal)
        assert main([*args, "--quiet"]) == 0
        assert terminal.getvalue() == ""
    capsys.readouterr()


def test_library_functions_stay_silent_unless_asked(monkeypatch: pytest.MonkeyPatch) -> None:
    terminal = Terminal()
    monkeypatch.setattr(sys, "stderr", terminal)
    robot = pincal.load_robot("five_bar")
    random_actuated(robot, 5, np.random.default_rng(0))
    select_poses(np.random.default_rng(0).normal(size=(20, 2, 3)), 4)
    run_monte_carlo(lambda seed, level: {"x": float(seed)}, [0, 1], executor=None)
    assert terminal.getvalue() == ""
    random_actuated(robot, 5, np.random.default_rng(0), progress=True)
    assert "postures of 'five_bar' [" in terminal.getvalue()


@pytest.mark.parametrize("args", [["design", "deltax", "--poses", "4"], ["montecarlo", "deltax"],
                                  ["montecarlo", "delta", "--measure", "pose", "--frame", "tool0"],
                                  ["design", "delta", "--poses", "20", "--candidates", "10"]])
def test_bad_requests_exit_2_with_one_line(args: list[str], capsys: pytest.CaptureFixture[str]) -> None:
    assert main(args) == 2
    captured = capsys.readouterr()
    assert captured.out == ""
    assert len(captured.err.splitlines()) == 1 and captured.err.startswith("pincal: error: ")
    assert ("known robots are: delta" in captured.err or "frames are: base" in captured.err
            or "cannot choose --poses 20 of --candidates 10" in captured.err)


@pytest.mark.parametrize("command", ["design", "montecarlo"])
def test_help_has_an_example_and_units(command: str, capsys: pytest.CaptureFixture[str]) -> None:
    with pytest.raises(SystemExit) as exit_info:
        main([command, "--help"])
    text = capsys.readouterr().out
    assert exit_info.value.code == 0
    assert f"example: pincal {command} " in text
    assert re.search(r"\[(m|rad)\b[^\]]*\]", text) and "rad" in text  # units stated


# --- the range of the random postures ------------------------------------------------------------------------------
def test_design_and_montecarlo_take_a_spread_about_the_reference(tmp_path: Path) -> None:
    robot = tmp_path / "crank_rocker.urdf"
    robot.write_text(crank_rocker_urdf((-0.3, 0.8)))  # narrow URDF limits [rad]
    chosen = {}
    for label, extra in (("limits", []), ("spread", ["--spread", "0.1"])):
        done = run_pincal("design", str(robot), "--candidates", "40", "--poses", "10", "--quiet", "--out",
                          str(tmp_path / f"{label}.csv"), *extra)
        assert done.returncode == 0, done.stderr
        chosen[label] = read_dataset(tmp_path / f"{label}.csv", ["crank_joint"]).joints[:, 0]
    assert -0.3 <= chosen["limits"].min() and chosen["limits"].max() <= 0.8 and np.ptp(chosen["limits"]) > 0.5
    assert np.abs(chosen["spread"]).max() <= 0.1
    tables = {}
    for label, extra in (("limits", []), ("spread", ["--spread", "0.1"])):
        done = run_pincal("montecarlo", str(robot), "--trials", "2", "--samples", "10", "--test-samples", "5",
                          "--workers", "1", "--quiet", *extra)
        assert done.returncode == 0, done.stderr
        tables[label] = done.stdout.splitlines()[-1]
    assert tables["limits"] != tables["spread"]  # other postures, other errors


def test_design_says_why_the_nominal_ur10_identifies_fewer_directions_than_calibrate(tmp_path: Path) -> None:
    # the nominal UR10's shoulder, elbow and first wrist axes are exactly parallel: 2 directions are invisible there,
    # and calibrate, which counts at its estimate (the axes slightly off), sees them
    done = run_pincal("design", "ur10", "--candidates", "100", "--poses", "30", "--quiet")
    assert done.returncode == 0, done.stderr
    lines = done.stdout.splitlines()
    assert lines[1] == "parameters: 40; designed for the 25 the candidates can identify at the nominal geometry"
    note = " ".join(line.strip() for line in lines[2:lines.index(next(line for line in lines
                                                                        if line.startswith("  left out")))])
    assert note.startswith("27 on the robot off it (every parameter off by σ 0.001 m or rad, as a real robot is): the "
                           "nominal's exactly parallel joint axes (shoulder_lift_joint, elbow_joint, wrist_1_joint) "
                           "hide 2 directions that a robot slightly off shows weakly, and which pincal calibrate, "
                           "counting at its estimate, can count")
    assert max(len(line) for line in lines[:lines.index("chosen postures, in measuring order (actuated values):")]
               if not line.startswith("  left out")) <= 120
    simulated = run_pincal("simulate", "ur10", "--samples", "40", "--seed", "2", "--quiet", "--out", "sim",
                           cwd=tmp_path)
    assert simulated.returncode == 0, simulated.stderr
    calibrated = run_pincal("calibrate", "ur10", "sim/measurements.csv", cwd=tmp_path)
    assert calibrated.returncode == 0, calibrated.stderr
    assert calibrated.stdout.startswith("samples 40, parameters 40, identifiable 27, ")  # the count design names


def test_design_adds_no_note_where_the_nominal_hides_nothing(capsys: pytest.CaptureFixture[str]) -> None:
    assert main([*DESIGN, "--quiet"]) == 0
    lines = capsys.readouterr().out.splitlines()
    assert re.fullmatch(r"parameters: 24; designed for the \d+ the candidates can identify", lines[1]), lines[1]
    assert lines[2].startswith("  left out") or lines[2].startswith("scaled identification Jacobian"), lines[2]


@pytest.mark.parametrize("measure", ["camera:base_link", "camera_point:world", "position:base_link"])
def test_simulate_warns_of_a_keyed_frame_no_actuated_joint_moves(measure: str, tmp_path: Path) -> None:
    """``--measure KIND:FRAME`` of a frame the UR10's joints do not move warns as ``--frame`` does (its data can
    calibrate nothing; calibrate refuses them), and is simulated as asked (issue 36)."""
    done = run_pincal("simulate", "ur10", "--samples", "5", "--measure", measure, "--quiet", "--out",
                      str(tmp_path / "sim"))
    assert done.returncode == 0, done.stderr
    frame = measure.split(":")[1]
    assert done.stderr.splitlines() == [f"pincal: warning: the actuated joints of 'ur10' do not move frame '{frame}': "
                                        "its measurements can identify only the measurement frame"]
    assert (tmp_path / "sim" / "measurements.csv").is_file()


@pytest.mark.parametrize("measure", [["--measure", "camera:base_link"], ["--measure", "position", "--frame",
                                                                           "base_link"]])
def test_design_refuses_a_frame_no_actuated_joint_moves(measure: list[str], tmp_path: Path) -> None:
    """A design of postures for measuring a frame nothing moves would mean nothing: one line, exit 2, no file."""
    out = tmp_path / "d.csv"
    done = run_pincal("design", "ur10", "--poses", "5", "--candidates", "10", *measure, "--out", str(out))
    assert done.returncode == 2, done.stdout + done.stderr
    key = "camera:base_link" if "camera:base_link" in measure else "position:base_link"
    assert done.stderr.splitlines() == [f"pincal: error: measurement '{key}' reads frame 'base_link', which no "
                                        "actuated joint of 'ur10' moves: its readings are the same in every posture "
                                        "and can calibrate nothing; measure a frame the joints move (e.g. 'tool0', "
                                        "the default measured frame)"]
    assert not out.exists()


def test_design_and_montecarlo_name_the_robot_as_typed(tmp_path: Path) -> None:
    """``tiago_no_hand`` (whose URDF says ``<robot name="tiago">``, the name of another robot of the list) is named as
    the user typed it, with the URDF's name beside it, as calibrate names it."""
    typed = 'tiago_no_hand\' (URDF <robot name="tiago">)'
    design = run_pincal("design", "tiago_no_hand", "--poses", "12", "--candidates", "30", "--out",
                        str(tmp_path / "d.csv"), "--quiet")
    assert design.returncode == 0, design.stderr
    assert f"design for '{typed}:" in design.stdout
    carlo = run_pincal("montecarlo", "tiago_no_hand", "--trials", "1", "--samples", "20", "--quiet")
    assert carlo.returncode == 0, carlo.stderr
    assert f"Monte Carlo on '{typed}:" in carlo.stdout
