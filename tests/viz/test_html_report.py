"""The offline HTML report: its numbers, tables, combinations, figures and scene, in a real browser too."""

from __future__ import annotations

import html
import json
import re
from pathlib import Path

import numpy as np
import pytest
from browser import orange_pixels, pixel_variance, render, served
from conftest import LIGHT_ARM_OPTIONS, ROBOTS, run_pincal

import pincal
from pincal.calibration.campaign import simulate, write_simulation
from pincal.calibration.pipeline import calibrate
from pincal.cli.app import main
from pincal.viz.html_report import write_demo_report

N_TRAIN, N_TEST = 30, 10


@pytest.fixture(scope="module")
def case(tmp_path_factory: pytest.TempPathFactory) -> dict[str, Path]:
    """A simulated Delta campaign, its calibration JSON (calibrate) and its HTML report (report)."""
    folder = tmp_path_factory.mktemp("report")
    robot = pincal.load_robot(ROBOTS / "delta.urdf")
    sim = simulate(robot, ["position"], N_TRAIN, N_TEST, perturb=1e-3, noise=1e-5, seed=5, parameter_spec=["model24"])
    write_simulation(sim, folder)
    data, truth = folder / "measurements.csv", folder / "truth.json"
    result, report = folder / "result.json", folder / "report.html"
    assert main(["calibrate", "delta", str(data), "--parameters", "model24", "--report", str(result)]) == 0
    assert main(["report", "delta", str(data), "--parameters", "model24", "--truth", str(truth),
                 "--out", str(report), "--quiet"]) == 0
    return {"folder": folder, "data": data, "truth": truth, "result": result, "report": report}


def _mm(value: float) -> str:
    return f"{value * 1e3:.4f} mm"


def test_report_states_the_summary_numbers(case: dict[str, Path]) -> None:
    page = case["report"].read_text(encoding="utf-8")
    result = json.loads(case["result"].read_text())
    for key in ("rms_before", "rms_after", "max_before", "max_after", "test_rms_before", "test_rms_after",
                "test_max_before", "test_max_after"):
        assert _mm(result[key]) in page, key
    assert f"{N_TRAIN} / {N_TEST}" in page  # fit / held-out samples
    assert f"<td>identifiable</td><td>{result['n_identifiable']} of {result['n_parameters']}</td>" in page
    assert f"<td>condition number (scaled)</td><td>{result['condition_number']:.3g}</td>" in page
    ratio = result["test_rms_before"] / result["test_rms_after"]
    assert f"{ratio:.3g}× smaller" in page  # the headline a person reads first


def test_report_parameter_table_and_combinations(case: dict[str, Path]) -> None:
    page = case["report"].read_text(encoding="utf-8")
    result = json.loads(case["result"].read_text())
    truth = json.loads(case["truth"].read_text())["parameters"]
    rows = dict(re.findall(r"<tr(?: class=\"unidentified\")?><td>([^<]+)</td>((?:<td>[^<]*</td>){6})</tr>", page))
    assert set(rows) == set(result["parameters"]) and len(rows) == 24
    for name, entry in result["parameters"].items():
        cells = re.findall(r"<td>([^<]*)</td>", rows[name])
        unit, estimate, std, identifiable, true = cells[0], cells[1], cells[2], cells[3], cells[4]
        factor = 1e3 if unit == "mm" else 180 / np.pi
        assert unit == ("deg" if name.endswith((".rz", ".offset")) else "mm")
        assert float(estimate) == pytest.approx(entry["value"] * factor, abs=1e-4)
        assert float(true) == pytest.approx(truth[name] * factor, abs=1e-4)
        assert identifiable == ("yes" if entry["identified"] else "no")
        if entry["identified"]:
            assert float(std) == pytest.approx(entry["std"] * factor, rel=6e-3)
    assert len(result["unidentifiable"]) == 3
    for combination in result["unidentifiable"]:
        assert f"<li>{html.escape(combination)}</li>" in page


def test_report_figures_are_inline_svg_with_content(case: dict[str, Path]) -> None:
    page = case["report"].read_text(encoding="utf-8")
    figures = re.findall(r'<figure><svg [^>]*aria-label="([^"]+)"[^>]*>(.*?)</svg></figure>', page, re.S)
    assert len(figures) == 5  # histograms, per sample, predicted uncertainty, parameters, convergence
    assert "data:image/png" not in page
    result = json.loads(case["result"].read_text())
    marks = {alt.split(":")[0]: len(re.findall(r"<(?:circle|rect|path) ", body)) for alt, body in figures}
    for alt, body in figures:
        assert f"<title>{alt}</title>" in body  # the text alternative, read by a screen reader
        assert len(re.findall(r"<text ", body)) > 8, f"figure '{alt}' has no axes"
    # every fitted sample has a point before and after in the per-sample figure, every parameter a marker
    assert marks["position error of each sample before and after calibration"] > 2 * result["n_samples"]
    assert marks["estimated parameter deviations with error bars"] > len(result["parameters"])


def test_report_embeds_the_scene_and_needs_no_network(case: dict[str, Path]) -> None:
    page = case["report"].read_text(encoding="utf-8")
    match = re.search(r'<iframe id="scene"[^>]*srcdoc="([^"]*)"', page)
    assert match, "no embedded scene"
    scene = html.unescape(match.group(1))
    assert "MeshCat.Viewer" in scene and "pincal-scene-status" in scene and "pincal-sample" in scene
    for document in (page, scene):
        assert not re.search(r"""(?:src|href)\s*=\s*["']?\s*(?:https?:)?//""", document)
        assert "url(http" not in document and "@import" not in document


def test_report_in_a_real_browser(case: dict[str, Path], tmp_path: Path) -> None:
    with served(case["folder"]) as base:
        shown = render(f"{base}report.html", tmp_path / "report.png")
    assert "Calibration of delta" in shown.dom
    match = re.search(r'id="scene-status" data-status="([^"]*)"', shown.dom)
    assert match, "the embedded scene did not report back to the report page"
    status = json.loads(html.unescape(match.group(1)))
    assert status["webgl"] and status["robot_calibrated"] == status["robot_nominal"] == 15
    assert {"arm_1", "rod_1", "platform"} <= set(status["frames"])
    assert status["points"] == status["error_before"] == status["error_after"] == N_TRAIN
    assert pixel_variance(shown.screenshot) > 100
    # the scene sits below the headline numbers, in the first screen: the robot is drawn there
    assert orange_pixels(shown.screenshot[330:]) > 2000


def test_report_from_a_saved_result_matches(case: dict[str, Path], tmp_path: Path) -> None:
    again = tmp_path / "again.html"
    assert main(["report", "delta", str(case["data"]), "--parameters", "model24", "--result", str(case["result"]),
                 "--out", str(again), "--quiet"]) == 0
    table = re.compile(r"<h2>Parameters</h2>.*?(<table>.*?</table>)", re.S)
    first, second = table.search(case["report"].read_text()), table.search(again.read_text())
    assert first and second and first.group(1).replace("<th>truth</th><th>error</th>", "").count("<tr") == \
        second.group(1).count("<tr")
    estimates = re.compile(r"<tr(?: class=\"unidentified\")?><td>([^<]+)</td><td>[^<]*</td><td>([^<]*)</td>")
    assert estimates.findall(first.group(1)) == estimates.findall(second.group(1))


def test_bad_truth_file_is_one_line(case: dict[str, Path], tmp_path: Path, capsys: pytest.CaptureFixture[str]
                                    ) -> None:
    bad = tmp_path / "truth.json"
    bad.write_text('{"robot": "delta"}')
    assert main(["report", "delta", str(case["data"]), "--parameters", "model24", "--result", str(case["result"]),
                 "--truth", str(bad), "--out", str(tmp_path / "r.html"), "--quiet"]) == 2
    err = capsys.readouterr().err.strip().splitlines()
    assert len(err) == 1 and "truth.json of pincal simulate" in err[0]


def test_demo_report(tmp_path: Path) -> None:
    robot = pincal.load_robot(ROBOTS / "delta.urdf")
    sim = simulate(robot, ["position"], 20, 5, perturb=1e-3, noise=1e-5, seed=1, parameter_spec=["model24"])
    write_simulation(sim, tmp_path)
    cal = calibrate(robot, sim.dataset, parameter_spec=["model24"], x_true=sim.x_true)
    path = write_demo_report(cal, tmp_path)
    assert path == tmp_path / "report.html"
    page = path.read_text(encoding="utf-8")
    assert "Calibration of delta" in page and "held-out samples" in page and "<th>truth</th>" in page
    assert _mm(cal.report.test_rms_after) in page


def test_a_report_on_occluded_markers_counts_the_readings(tmp_path: Path) -> None:
    """Three markers on the UR10's tool0, some not seen, and one sample that saw none: the report (fitted afresh,
    or from a result JSON with the file's marker declarations, where that sample has no error) says how many
    readings its figures are made of."""
    from pincal.io.dataset import write_dataset

    robot = pincal.load_robot("ur10")
    sim = simulate(robot, ["position:tool0@m1", "position:tool0@m2", "position:tool0@m3"], 20, 4, seed=4)
    sim.dataset.measurements["position:tool0@m2"][[1, 3, 21]] = np.nan
    for marker in ("m1", "m2", "m3"):  # sample 5 saw none: dropped from the fit, drawn without an error
        sim.dataset.measurements[f"position:tool0@{marker}"][5] = np.nan
    sim.dataset.metadata["marker m3 on tool0"] = "0 0 0.01"
    data, result = tmp_path / "markers.csv", tmp_path / "result.json"
    write_dataset(sim.dataset, data)
    assert main(["calibrate", "ur10", str(data), "--select", "none", "--report", str(result)]) == 0
    for extra in ([], ["--result", str(result)]):
        page = tmp_path / "report.html"
        assert main(["report", "ur10", str(data), "--select", "none", "--out", str(page), "--quiet", *extra]) == 0
        text = page.read_text()
        assert "<td>position readings (fit / held out; not seen in the fit)</td><td>55 / 11; 2</td>" in text


def test_names_and_values_with_markup_are_escaped(light_arm: tuple[Path, Path], tmp_path: Path) -> None:
    """A payload on a link named ``load<&>`` (a URDF may name it so, escaped in its XML) reads as text in the
    report, as do the robot's and the files' names; so do the values of a ``--result`` JSON, numbers included,
    which a user may hand in from anywhere: none of them becomes markup."""
    urdf, data = light_arm
    odd = tmp_path / "a<b>&c"
    odd.mkdir()
    robot, measurements = odd / "arm.urdf", odd / "data.csv"
    robot.write_bytes(urdf.read_bytes())
    measurements.write_bytes(data.read_bytes())
    page, result = tmp_path / "page.html", tmp_path / "result.json"
    done = run_pincal("report", str(robot), str(measurements), *LIGHT_ARM_OPTIONS, "--quiet", "--out", str(page))
    assert done.returncode == 0, done.stderr
    text = page.read_text(encoding="utf-8")
    assert "<td>2 kg on load&lt;&amp;&gt; at (0, 0, 0) m</td>" in text
    assert f"{html.escape(str(robot))} · {html.escape(str(measurements))}</p>" in text
    assert "load<&>" not in text and "a<b>&c" not in text
    done = run_pincal("calibrate", str(robot), str(measurements), *LIGHT_ARM_OPTIONS, "--report", str(result))
    assert done.returncode == 0, done.stderr
    report = json.loads(result.read_text(encoding="utf-8"))
    report.update({"n_samples": "<b>30</b>", "n_parameters": "<i>25</i>", "n_test_samples": "<u>6</u>",
                   "cv": {"plan": "<s>3-fold</s>", "n_samples": "<em>36</em>", "rms": 1e-5}})
    result.write_text(json.dumps(report), encoding="utf-8")
    done = run_pincal("report", str(robot), str(measurements), *LIGHT_ARM_OPTIONS, "--result", str(result), "--quiet",
                      "--out", str(page))
    assert done.returncode == 0, done.stderr
    text = page.read_text(encoding="utf-8")
    for tag in ("b", "i", "u", "s", "em"):
        assert f"<{tag}>" not in text, tag
        assert f"&lt;{tag}&gt;" in text, tag
