"""The command line as a user runs it: info, simulate, calibrate, demo; errors as one line."""

from __future__ import annotations

import json
import re
from pathlib import Path

import numpy as np
import pytest
from conftest import ROBOTS, run_pincal
from mechanisms import crank_rocker_urdf, four_bar_urdf

import pincal
from pincal.cli.app import main


def test_info_describes_the_delta(capsys: pytest.CaptureFixture[str]) -> None:
    assert main(["info", str(ROBOTS / "delta.urdf")]) == 0
    out = capsys.readouterr().out
    assert "leg_1_platform" in out and "spherical" in out
    assert "mobility 3" in out and "actuated joints (3): arm_1_joint, arm_2_joint, arm_3_joint" in out


def test_info_names_the_default_measured_frame_or_why_there_is_none(tmp_path: Path) -> None:
    chain, cut = tmp_path / "crank_rocker.urdf", tmp_path / "four_bar.urdf"
    chain.write_text(crank_rocker_urdf())
    cut.write_text(four_bar_urdf())
    done = run_pincal("info", str(chain))
    assert done.returncode == 0, done.stderr
    assert done.stdout.splitlines()[-1].startswith("measured frame (default): rocker, moved by the actuated joints "
                                                   "(the one moving link with none below it); at (")
    done = run_pincal("info", str(cut))  # described all the same, with the reason
    assert done.returncode == 0, done.stderr
    last = done.stdout.splitlines()[-1]
    assert last.startswith("measured frame (default): none: robot 'four_bar' has no frame named like an end effector")
    assert "moving links have no moving link below them: coupler, rocker" in last and "--frame" in last
    done = run_pincal("info", "delta")
    assert "measured frame (default): end_effector, moved by the actuated joints (named like an end effector)" \
        in done.stdout


def test_info_bad_file_is_one_line(tmp_path: Path, capsys: pytest.CaptureFixture[str]) -> None:
    bad = tmp_path / "bad.urdf"
    bad.write_text((ROBOTS / "delta.urdf").read_text().replace('type="spherical"', 'type="ball"', 1))
    assert main(["info", str(bad)]) == 2
    err = capsys.readouterr().err.strip().splitlines()
    assert len(err) == 1 and err[0].startswith("pincal: error:") and "type 'ball'" in err[0]
    with pytest.raises(pincal.LoopError):
        main(["--debug", "info", str(bad)])


def test_simulate_then_calibrate(tmp_path: Path, capsys: pytest.CaptureFixture[str]) -> None:
    sim = tmp_path / "sim"
    assert main(["simulate", "delta", "--samples", "40", "--test-samples", "10", "--measure", "position",
                 "--perturb", "1e-3", "--noise", "0", "--seed", "2", "--parameters", "model24", "--out", str(sim)]) == 0
    assert {p.name for p in sim.iterdir()} == {"measurements.csv", "truth.urdf", "truth.json"}
    truth = pincal.load_robot(sim / "truth.urdf")  # the true robot closes at zero: it loads
    assert truth.mobility() == 3
    out_urdf, report = tmp_path / "cal.urdf", tmp_path / "report.json"
    assert main(["calibrate", "delta", str(sim / "measurements.csv"), "--parameters", "model24",
                 "--out", str(out_urdf), "--report", str(report)]) == 0
    data = json.loads(report.read_text())
    for key in ("rms_before", "rms_after", "max_before", "max_after", "n_samples", "n_parameters", "n_identifiable",
                "condition_number", "iterations", "converged", "parameters"):
        assert key in data
    assert data["n_samples"] == 40 and data["n_parameters"] == 24 and data["n_identifiable"] == 21
    assert data["converged"] and data["rms_after"] < 1e-9 < 1e-4 < data["rms_before"]
    assert data["test_rms_after"] < 1e-9
    assert len(data["unidentifiable"]) == 3
    # the calibrated file loads and predicts what the truth does, at the same readings
    calibrated = pincal.load_robot(out_urdf)
    rng = np.random.default_rng(0)
    for _ in range(5):
        qa = rng.uniform(-0.3, 0.6, 3)
        p_cal = calibrated.placement(calibrated.solve_fk(qa), "end_effector").translation
        p_true = truth.placement(truth.solve_fk(qa), "end_effector").translation
        np.testing.assert_allclose(p_cal, p_true, atol=1e-9)
    text = out_urdf.read_text()
    assert "<loop" in text and "<transmission" in text and "calibrated by pincal" in text


def test_calibrate_missing_column_is_one_line(tmp_path: Path, capsys: pytest.CaptureFixture[str]) -> None:
    data = tmp_path / "m.csv"
    data.write_text("arm_1_joint,arm_2_joint,position:end_effector:x,position:end_effector:y,position:end_effector:z\n"
                    "0,0,0,0,-0.2\n0.1,0,0,0,-0.3\n")
    assert main(["calibrate", "delta", str(data)]) == 2
    err = capsys.readouterr().err
    assert err.count("\n") == 1 and "arm_3_joint" in err


def test_demo_writes_its_files(tmp_path: Path, capsys: pytest.CaptureFixture[str]) -> None:
    assert main(["demo", "--out", str(tmp_path / "demo"), "--samples", "30", "--test-samples", "10"]) == 0
    out = capsys.readouterr().out
    assert "RMS position error (held out)" in out and "wrote" in out
    report = json.loads((tmp_path / "demo" / "report.json").read_text())
    assert report["test_rms_after"] < 0.1 * report["test_rms_before"]
    assert pincal.load_robot(tmp_path / "demo" / "delta_calibrated.urdf").mobility() == 3


def test_calibrate_with_the_implicit_formulation(tmp_path: Path) -> None:
    sim = tmp_path / "sim"
    assert main(["simulate", "delta", "--samples", "30", "--test-samples", "10", "--noise", "0", "--seed", "4",
                 "--parameters", "model24", "--out", str(sim)]) == 0
    report = tmp_path / "r.json"
    assert main(["calibrate", "delta", str(sim / "measurements.csv"), "--parameters", "model24", "--formulation", "ikm",
                 "--report", str(report)]) == 0
    data = json.loads(report.read_text())
    assert data["formulation"] == "ikm" and data["converged"]
    assert data["test_rms_after"] < 1e-9 < 1e-4 < data["test_rms_before"]


def test_unknown_frame_is_one_line(tmp_path: Path, capsys: pytest.CaptureFixture[str]) -> None:
    assert main(["simulate", "delta", "--measure", "pose", "--frame", "nope", "--out", str(tmp_path)]) == 2
    err = capsys.readouterr().err.strip().splitlines()
    assert len(err) == 1 and "frame 'nope' does not exist" in err[0] and "end_effector" in err[0]


TIAGO_DATA = Path(__file__).resolve().parents[2] / "examples" / "data" / "tiago_mocap_marker1.csv"


def _identifiability_block(stdout: str) -> list[str]:
    """The summary's lines from 'not seen by these data' to the end (empty when there is none)."""
    lines = stdout.splitlines()
    start = next((k for k, line in enumerate(lines) if line.startswith("not seen by these data")), None)
    return [] if start is None else [line for line in lines[start:]
                                     if not line.startswith(("wrote ", "the calibrated URDF reloaded"))]


def test_real_tiago_data_with_the_default_command(tmp_path: Path) -> None:
    """The mocap file carries the torso and arm readings only: the head and wheels, which cannot move the marker,
    stay at their reference; the default parameters are chosen, held near nominal by the evidence group by group
    (docs/calibrated_urdf.md, "The prior") and fitted; the identifiability listing is short; the held-out postures
    are predicted better than by the nominal robot with its frame and marker registered ("before"), and far better
    than from the fit's start (frame in closed form, marker at nominal)."""
    from conftest import run_pincal

    report = tmp_path / "report.json"
    done = run_pincal("calibrate", "tiago_no_hand", str(TIAGO_DATA), "--report", str(report))
    assert done.returncode == 0, done.stderr
    out = done.stdout
    assert "not in the file, at their reference (they move nothing measured): head_1_joint, head_2_joint" in out
    assert all(len(line) <= 120 for line in out.splitlines() if not line.startswith("(before:"))
    data = json.loads(report.read_text())
    selection = data["selection"]
    assert selection["policy"] == "evidence" and selection["prior"] == "auto"
    factors = selection["prior_factors"]
    assert sorted(factors) == ["offsets", "rotations", "translations"]  # the default set's groups of the robot
    left_out = [group for group, factor in factors.items() if factor == 0.0]
    assert left_out == selection["removed_groups"]
    kept = {group: factor for group, factor in factors.items() if factor > 0.0}
    assert kept and all(1e-3 * 1.5 < factor <= 10.0 for factor in kept.values())  # within the searched range
    line = " ".join(line.strip() for line in out.split("model selection (evidence): ", 1)[1].split(" (docs/", 1)[0]
                    .splitlines())
    held = ", ".join(f"{group} {factor:.2g}×" for group, factor in kept.items())
    assert line == (f"left out the {', '.join(left_out)} ({len(selection['removed'])} parameters at nominal); "
                    if left_out else "") + f"the prior holds the {held} of their kinds' σ"
    block = _identifiability_block(out)
    assert 1 <= len(block) <= 3 and all(len(line) <= 120 for line in block)
    assert block[0].startswith("not seen by these data: 19 of 52 candidate directions, as expected")
    assert " ".join(line.strip() for line in block).endswith("listed in the report's 'unidentifiable'")
    assert data["n_parameters"] == 52 and data["n_identifiable"] == 33 and data["no_effect"] == []
    assert len(data["unidentifiable"]) == 52 - 33  # the report has every direction
    assert data["n_estimated"] <= data["n_identifiable"]
    assert data["bad_readings"] == [] and "bad joint readings" not in out  # real residuals, no wrong reading
    held_out = next(line for line in out.splitlines() if line.startswith("RMS position error (held out)"))
    before, after = (float(v) for v in held_out.split()[-4::2])
    assert after < 5.0 and after < before  # [mm]; the nominal robot with its frame and marker registered
    assert (before, after) == tuple(float(f"{data[k] * 1e3:.4f}") for k in ("test_rms_before", "test_rms_after"))
    start = " ".join(out.split("(the fit's start, ", 1)[1].split(")\n", 1)[0].split())
    fitted, held = (float(v) for v in re.findall(r"([\d.]+) mm \((?:fit|held out)\)", start))
    assert (fitted, held) == tuple(float(f"{data[k] * 1e3:.4f}") for k in ("rms_start", "test_rms_start"))
    assert held > 10 * after  # [mm]: the marker at its nominal offset is centimetres off


def test_cross_validation_through_the_cli(tmp_path: Path) -> None:
    from conftest import run_pincal

    report = tmp_path / "report.json"
    done = run_pincal("calibrate", "tiago_no_hand", str(TIAGO_DATA), "--cv", "5", "--report", str(report))
    assert done.returncode == 0, done.stderr
    line = next(line for line in done.stdout.splitlines() if line.startswith("RMS position error (cross-val.)"))
    assert "(5-fold, 34 samples, 34 predictions)" in line
    cv = json.loads(report.read_text())["cv"]
    assert cv["plan"] == "5-fold" and cv["n_predictions"] == 34 and not cv["failed_folds"]
    fit = json.loads(report.read_text())["rms_after"]
    assert fit < cv["rms"] < 3 * fit  # predicting unseen postures is harder than fitting them, not hopeless
    assert ("warning: the cross-validated error is" in done.stdout) == (cv["rms"] > 1.5 * fit)
    for bad, words in (("1", "K must lie between 2 and the 34 usable samples"), ("five", "give K (folds), KxR")):
        done = run_pincal("calibrate", "tiago_no_hand", str(TIAGO_DATA), "--cv", bad)
        assert done.returncode == 2 and done.stderr.count("\n") == 1 and words in done.stderr, done.stderr


TIAGO_MARKERS = TIAGO_DATA.with_name("tiago_mocap_markers.csv")


def test_cross_validation_seed_and_each_markers_figure(tmp_path: Path) -> None:
    """``--cv-seed`` moves the folds (other postures fall together, another figure, the seeds in the plan's name);
    with three markers the cross-validated RMS of each marker is printed and reported, and pooling them gives the
    figure of all readings."""
    from conftest import run_pincal

    figures = {}
    for seed in ("0", "7"):
        report = tmp_path / f"report{seed}.json"
        done = run_pincal("calibrate", "tiago_no_hand", str(TIAGO_MARKERS), "--cv", "3x2", "--cv-seed", seed,
                          "--report", str(report))
        assert done.returncode == 0, done.stderr
        cv = json.loads(report.read_text())["cv"]
        assert cv["plan"] == ("3-fold × 2" if seed == "0" else "3-fold × 2, shuffle seeds 7–8")
        assert f"({cv['plan']}, 34 samples, 204 predictions)" in done.stdout
        by_marker = cv["rms_by_reading"]
        assert sorted(by_marker) == [f"position:wrist_ft_tool_link@m{k}" for k in (1, 2, 3)]
        for key, value in by_marker.items():
            assert f"  {key}" in done.stdout and f"{value * 1e3:.4f} mm" in done.stdout
        # 68 predictions per marker: the pooled RMS is the root of the markers' mean square
        assert np.isclose(cv["rms"], np.sqrt(np.mean(np.square(list(by_marker.values())))), rtol=1e-12)
        figures[seed] = cv["rms"]
    assert figures["0"] != figures["7"]
    done = run_pincal("calibrate", "tiago_no_hand", str(TIAGO_MARKERS), "--cv-seed", "3")
    assert done.returncode == 2 and done.stderr.count("\n") == 1 and "give --cv too" in done.stderr, done.stderr
    done = run_pincal("calibrate", "tiago_no_hand", str(TIAGO_MARKERS), "--cv", "5", "--cv-seed", "-1")
    assert done.returncode == 2 and "--cv-seed" in done.stderr and "Traceback" not in done.stderr, done.stderr


def test_real_tiago_data_with_three_markers(tmp_path: Path) -> None:
    """The TIAGo hand's markers 1–3 as m1, m2, m3 on wrist_ft_tool_link (marker 4 duplicates 3): the default command
    fits each marker's offset with the robot and the mocap frame, reports its RMS over the 84 marker readings of
    the fit (18 held out), writes one link per marker, and predicts the held-out postures within 5 mm."""
    from conftest import run_pincal

    report, out = tmp_path / "report.json", tmp_path / "cal.urdf"
    done = run_pincal("calibrate", "tiago_no_hand", str(TIAGO_MARKERS), "--report", str(report), "--out", str(out))
    assert done.returncode == 0, done.stderr
    lines = done.stdout.splitlines()
    assert "position readings: fitted 84 (wrist_ft_tool_link: m1 28, m2 28, m3 28), not seen 0; held out 18" in lines
    assert "  (each RMS position error is over the readings taken: one 3D error per marker seen)" in lines
    data = json.loads(report.read_text())
    assert data["readings"] == {f"position:wrist_ft_tool_link@m{k}": 28 for k in (1, 2, 3)}
    assert {f"marker.wrist_ft_tool_link@m{k}.{a}" for k in (1, 2, 3) for a in "xyz"} <= set(data["parameters"])
    assert data["n_residuals"] == 84 * 3
    assert data["bad_readings"] == []  # a large real residual is not a wrong joint reading
    fit = next(line for line in lines if line.startswith("RMS position error (fit)"))
    held_out = next(line for line in lines if line.startswith("RMS position error (held out)"))
    assert float(fit.split()[-2]) < 3.0 and float(held_out.split()[-2]) < 5.0  # [mm]; 2.23 and 4.20 on this file
    text = out.read_text()
    assert all(f'<link name="wrist_ft_tool_link_marker_m{k}"/>' in text for k in (1, 2, 3))


def test_occluded_markers_are_counted_and_a_sample_that_saw_none_is_dropped(tmp_path: Path) -> None:
    """The three-marker TIAGo file with cells emptied: a marker not seen leaves its sample's other markers in the
    fit, the summary counts the readings taken per marker, and a sample that saw no marker is dropped with that
    reason; one empty cell of three is refused, naming it."""
    from conftest import run_pincal

    lines = TIAGO_MARKERS.read_text().splitlines()
    header = next(k for k, line in enumerate(lines) if not line.startswith("#"))
    columns = lines[header].split(",")
    blanks = {2: ["m1"], 5: ["m2", "m3"], 11: ["m3"], 7: ["m1", "m2", "m3"], 9: ["m2"]}  # sample 9 is held out
    rows = [line.split(",") for line in lines[header + 1:]]
    for sample, markers in blanks.items():
        for marker in markers:
            for axis in "xyz":
                rows[sample][columns.index(f"position:wrist_ft_tool_link@{marker}:{axis}")] = ""
    data = tmp_path / "occluded.csv"
    data.write_text("\n".join(lines[:header + 1] + [",".join(row) for row in rows]) + "\n")
    report = tmp_path / "report.json"
    done = run_pincal("calibrate", "tiago_no_hand", str(data), "--report", str(report))
    assert done.returncode == 0, done.stderr
    out = done.stdout.splitlines()
    assert any(line.startswith("samples in the file 34: fitted 27, held out 6, dropped 1") for line in out)
    assert "  - sample 7: no reading: the cells of any of the 3 markers are all empty (not seen)" in out
    assert "position readings: fitted 77 (wrist_ft_tool_link: m1 26, m2 26, m3 25), not seen 4; held out 17" in out
    result = json.loads(report.read_text())
    assert result["readings_not_seen"] == {"position:wrist_ft_tool_link@m1": 1, "position:wrist_ft_tool_link@m2": 1,
                                           "position:wrist_ft_tool_link@m3": 2}
    assert result["n_residuals"] == 77 * 3 and result["test_readings"]["position:wrist_ft_tool_link@m2"] == 5
    assert all(v is None or v == v for v in (result["rms_after"], result["test_rms_after"]))  # no NaN figure
    rows[3][columns.index("position:wrist_ft_tool_link@m2:y")] = ""
    data.write_text("\n".join(lines[:header + 1] + [",".join(row) for row in rows]) + "\n")
    done = run_pincal("calibrate", "tiago_no_hand", str(data))
    assert done.returncode == 2 and done.stderr.count("\n") == 1
    line = header + 1 + 3 + 1  # the fourth data row, counted from 1 like an editor's lines
    assert f"column 'position:wrist_ft_tool_link@m2:y', line {line}: the cell is empty but" in done.stderr


def test_a_joint_that_moves_the_marker_must_have_a_column(tmp_path: Path) -> None:
    from conftest import run_pincal

    lines = TIAGO_DATA.read_text().splitlines()
    header_at = next(k for k, line in enumerate(lines) if line.startswith("sample,"))
    column = lines[header_at].split(",").index("arm_4_joint")
    cut = [",".join(c for k, c in enumerate(line.split(",")) if k != column) if n >= header_at else line
           for n, line in enumerate(lines)]
    data = tmp_path / "no_arm_4.csv"
    data.write_text("\n".join(cut) + "\n")
    done = run_pincal("calibrate", "tiago_no_hand", str(data))
    assert done.returncode == 2 and done.stderr.count("\n") == 1
    assert "no column for actuated joint(s) arm_4_joint, which move the measured wrist_ft_tool_link" in done.stderr


@pytest.mark.parametrize(("robot", "measure"), [("delta", "position"), ("hexapod", "pose"), ("ur10", "position")])
def test_default_identifiability_listing_is_short(tmp_path: Path, robot: str, measure: str) -> None:
    """The default command says in at most three lines what the data cannot identify, none over 120 characters."""
    from conftest import run_pincal

    sim = tmp_path / "sim"
    done = run_pincal("simulate", robot, "--samples", "40", "--test-samples", "10", "--measure", measure,
                      "--seed", "5", "--quiet", "--out", str(sim))
    assert done.returncode == 0, done.stderr
    done = run_pincal("calibrate", robot, str(sim / "measurements.csv"))
    assert done.returncode == 0, done.stderr
    block = _identifiability_block(done.stdout)
    assert 1 <= len(block) <= 3, done.stdout
    assert all(len(line) <= 120 for line in block), block
    assert " ".join(line.strip() for line in block).endswith("--report FILE lists each")


def test_named_set_combines_with_patterns(tmp_path: Path) -> None:
    """Model 24 with an unknown tracker frame: the set and the pattern together."""
    from conftest import run_pincal

    sim = tmp_path / "sim"
    assert run_pincal("simulate", "delta", "--samples", "40", "--test-samples", "10", "--parameters", "model24",
                      "base.*", "--seed", "2", "--quiet", "--out", str(sim)).returncode == 0
    report = tmp_path / "r.json"
    done = run_pincal("calibrate", "delta", str(sim / "measurements.csv"), "--parameters", "model24", "base.*",
                      "--report", str(report))
    assert done.returncode == 0, done.stderr
    names = list(json.loads(report.read_text())["parameters"])
    assert len(names) == 30 and names[-6:] == [f"base.{c}" for c in ("tx", "ty", "tz", "rx", "ry", "rz")]


def test_a_file_without_measurements_is_refused_in_one_line(tmp_path: Path) -> None:
    from conftest import run_pincal

    data = tmp_path / "postures.csv"
    data.write_text("arm_1_joint,arm_2_joint,arm_3_joint\n0,0,0\n0.1,0.1,0\n")
    done = run_pincal("calibrate", "delta", str(data))
    assert done.returncode == 2 and done.stderr.count("\n") == 1
    assert "the data has no measurement columns" in done.stderr and "Traceback" not in done.stderr


def test_the_html_report_shows_selection_and_cross_validation(tmp_path: Path) -> None:
    from conftest import run_pincal

    page, report = tmp_path / "report.html", tmp_path / "report.json"
    done = run_pincal("report", "tiago_no_hand", str(TIAGO_DATA), "--cv", "3", "--quiet", "--out", str(page))
    assert done.returncode == 0, done.stderr
    assert run_pincal("calibrate", "tiago_no_hand", str(TIAGO_DATA), "--report", str(report)).returncode == 0
    text, calibrated = page.read_text(), json.loads(report.read_text())
    left_out = calibrated["selection"]["removed_groups"]
    assert left_out  # the default's selection leaves a group of this file's out (the evidence: at its smallest factor)
    assert (f"estimated (after model selection)</td><td>{calibrated['n_estimated']} (left out: "
            f"{', '.join(left_out)})") in text
    assert "RMS position error (cross-validated, 3-fold, 34 samples)" in text
    assert page.stat().st_size <= 2_000_000  # the meshes simplified: a page that opens fast


def test_the_html_report_shows_the_payload_and_each_markers_cross_validated_error(tmp_path: Path) -> None:
    from conftest import run_pincal

    page, report = tmp_path / "report.html", tmp_path / "report.json"
    options = ["--parameters", "default", "*.compliance", "--payload", "2@arm_7_link:0,0,0.05", "--cv", "3"]
    done = run_pincal("report", "tiago_no_hand", str(TIAGO_MARKERS), *options, "--quiet", "--out", str(page))
    assert done.returncode == 0, done.stderr
    assert run_pincal("calibrate", "tiago_no_hand", str(TIAGO_MARKERS), *options, "--report",
                      str(report)).returncode == 0
    text, cv = page.read_text(), json.loads(report.read_text())["cv"]
    assert ("<tr><td>payload (in the gravity torque of the compliances)</td>"
            "<td>2 kg on arm_7_link at (0, 0, 0.05) m</td></tr>") in text
    for key, value in cv["rms_by_reading"].items():
        assert f"<tr><td>&nbsp;&nbsp;{key}</td><td></td><td class='after'>{value * 1e3:.4f} mm</td></tr>" in text


def test_cross_validation_and_selection_refuse_what_they_cannot_mean(five_bar_csv: Path) -> None:
    from conftest import run_pincal

    for extra, words in ((["--formulation", "ikm", "--cv", "3"],
                          "--cv 3 cross-validates the fkm formulation; give it without --formulation ikm"),
                         (["--formulation", "ikm", "--select", "bic"],
                          "--select bic chooses among fkm fits; with --formulation ikm use --select none or --select "
                          "auto"),
                         (["--cv", "5x"], "--cv 5x: give K (folds), KxR")):
        done = run_pincal("calibrate", "five_bar", str(five_bar_csv), *extra)
        assert done.returncode == 2 and done.stderr.count("\n") == 1 and words in done.stderr, done.stderr


def test_the_library_names_options_by_keyword_and_the_command_line_by_flag(five_bar_csv: Path) -> None:
    """A library error names the option as a library caller gives it; the command line shows its flag instead."""
    import pincal
    from pincal.cli.arguments import in_flags

    robot = pincal.load_robot("five_bar")
    with pytest.raises(pincal.DataError) as caught:
        pincal.calibrate(robot, pincal.read_dataset(five_bar_csv), formulation="ikm", select="bic")
    assert str(caught.value).startswith("select='bic' chooses among fkm fits; with formulation='ikm' use "
                                        "select='none'") and caught.value.option == "select"
    assert in_flags(str(caught.value)).startswith("--select bic chooses among fkm fits; with --formulation ikm")
    assert in_flags("cv_seed=3 and cv='loo'; max_iter=7, sigma=1e-05") == \
        "--cv-seed 3 and --cv loo; --max-iter 7, --sigma 1e-05"


def test_a_figure_of_the_before_after_table_never_runs_into_the_one_before_it() -> None:
    """The table's columns are 14 wide; a figure of 14 characters (a nominal model metres off) keeps a space."""
    from pincal.calibration.summary import _column
    assert _column("1.8378 mm") == "     1.8378 mm"
    assert _column("1570.5827 mrad") == " 1570.5827 mrad"


@pytest.mark.parametrize("robot", ["delta", "five_bar"])
def test_a_cautious_sigma_converges_to_the_same_calibration(robot: str, tmp_path: Path) -> None:
    """A σ stated 10× and 100× larger than the noise (10 µm): the closed-loop fits level off below the stated noise
    level and used to crawl to the iteration limit (exit 1, 'NOT CONVERGED'); they stop at the residual's own noise
    level, with the estimate the stated σ would give."""
    sim = tmp_path / "sim"
    assert run_pincal("simulate", robot, "--samples", "30", "--test-samples", "10", "--seed", "1", "--quiet",
                      "--out", str(sim)).returncode == 0
    reports = {}
    for sigma in (None, "1e-4", "1e-3"):
        report = tmp_path / f"report_{sigma}.json"
        extra = ["--sigma", sigma] if sigma else []
        done = run_pincal("calibrate", robot, str(sim / "measurements.csv"), *extra, "--report", str(report))
        assert done.returncode == 0, done.stdout + done.stderr
        reports[sigma] = json.loads(report.read_text())
        assert reports[sigma]["converged"] and reports[sigma]["iterations"] < 20, reports[sigma]["message"]
    for sigma in ("1e-4", "1e-3"):
        assert reports[sigma]["test_rms_after"] == pytest.approx(reports[None]["test_rms_after"], rel=0.2)
