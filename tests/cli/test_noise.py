"""The measurement noise as a user states it, or does not: σ estimated from the data, σ per residual row (files, job
files, the API), a σ stated far too large, and model selection by cross-validated error."""

from __future__ import annotations

import json
from pathlib import Path
from typing import Any

import numpy as np
import pytest
from conftest import run_pincal

TIAGO_DATA = Path(__file__).resolve().parents[2] / "examples" / "data" / "tiago_mocap_marker1.csv"


def calibrated(tmp_path: Path, name: str, *args: str) -> tuple[dict[str, Any], str]:
    """``pincal calibrate ARGS --report``: the report and the standard output (the run must succeed)."""
    report = tmp_path / f"{name}.json"
    done = run_pincal("calibrate", *args, "--report", str(report))
    assert done.returncode == 0, done.stdout + done.stderr
    return json.loads(report.read_text()), done.stdout


def test_without_sigma_lines_the_noise_is_estimated_and_said(tmp_path: Path) -> None:
    """The TIAGo file without its '# sigma position: 1e-3' line: the noise is estimated from the data per axis (the
    mocap data fit to about a millimetre on each), said in the summary and the report, and the run keeps the model
    the file's 1 mm gives and predicts the held-out postures as well, within 3 %; the σ estimated weigh the fit
    exactly as a '# sigma' line stating them would (docs/dataset.md, "Noise")."""
    bare = tmp_path / "tiago_no_sigma.csv"
    bare.write_text("".join(line for line in TIAGO_DATA.read_text().splitlines(keepends=True)
                            if not line.startswith("# sigma")))
    stated, _ = calibrated(tmp_path, "stated", "tiago_no_hand", str(TIAGO_DATA))
    estimated, out = calibrated(tmp_path, "estimated", "tiago_no_hand", str(bare))
    sigma = estimated["estimated_sigma"]["position:wrist_ft_tool_link"]
    rows = [sigma["rows"][axis] for axis in "xyz"]
    assert sigma["units"] == {"x": "m", "y": "m", "z": "m"}
    assert 0.5e-3 < sigma["length"] < 3e-3 and all(0.3e-3 < value < 3e-3 for value in rows)
    assert sigma["length"] == pytest.approx(float(np.sqrt(np.mean(np.square(rows)))), rel=1e-12)  # their RMS
    said = ", ".join(f"{axis} {value * 1e3:.3g} mm" for axis, value in zip("xyz", rows, strict=True))
    assert f"σ estimated from the data, per axis (no '# sigma' line): position:wrist_ft_tool_link {said}" in out
    assert "estimated_sigma" not in stated
    assert estimated["n_estimated"] == stated["n_estimated"]
    assert estimated["selection"]["removed_groups"] == stated["selection"]["removed_groups"]
    # the prior toward nominal weighs against σ, and each axis weighs by its own: the prediction moves a little
    assert estimated["test_rms_after"] == pytest.approx(stated["test_rms_after"], rel=0.03)
    # the very figures of a file whose '# sigma' line states the σ estimated, with the prior and by least squares
    least = calibrated(tmp_path, "estimated_off", "tiago_no_hand", str(bare), "--prior", "off")[0]
    for extra, ours in (((), estimated), (("--prior", "off"), least)):
        axes = tmp_path / f"tiago_axes{len(extra)}.csv"
        said = " ".join(repr(ours["estimated_sigma"]["position:wrist_ft_tool_link"]["rows"][axis]) for axis in "xyz")
        axes.write_text(f"# sigma position: {said}\n" + bare.read_text())
        theirs = calibrated(tmp_path, f"axes{extra}", "tiago_no_hand", str(axes), *extra)[0]
        assert "estimated_sigma" not in theirs and ours["selection"] == theirs["selection"]
        for key in ("n_estimated", "rms_after", "test_rms_after", "sigma2"):
            assert ours[key] == pytest.approx(theirs[key], rel=1e-6), (key, extra)


def test_a_sigma_stated_100_times_too_large_converges_to_the_same_fit(tmp_path: Path) -> None:
    """The TIAGo file states 1 mm, about its noise; stating 10 mm or 0.1 m (100×) gives the same fit by least squares
    (``--prior off``): the noise stop judges what remains to gain by the noise the residual shows, not by a σ stated
    larger. With the prior (the default), weighed against the noise the data show (1.35 mm, not the 1 mm stated),
    the same model and figures within 3 %."""
    for extra, tolerance in ((("--prior", "off"), 1e-6), ((), 0.03)):
        reports = {sigma: calibrated(tmp_path, f"{sigma}{extra}", "tiago_no_hand", str(TIAGO_DATA), "--sigma", sigma,
                                     *extra)[0] for sigma in ("0.1", "1e-2")}
        stated, _ = calibrated(tmp_path, f"stated{extra}", "tiago_no_hand", str(TIAGO_DATA), *extra)
        for report in reports.values():
            assert report["converged"]
            assert report["n_estimated"] == stated["n_estimated"]
            assert report["rms_after"] == pytest.approx(stated["rms_after"], rel=tolerance)
            assert report["test_rms_after"] == pytest.approx(stated["test_rms_after"], rel=tolerance)


@pytest.fixture(scope="module")
def deep_noise(tmp_path_factory: pytest.TempPathFactory) -> tuple[Path, list[str], list[str]]:
    """A simulated Delta (40 + 20 postures, noise 10 µm) whose fitted postures read z with 2 mm more noise, as a
    camera's depth: the directory, the file's header lines without σ, and its table."""
    out = tmp_path_factory.mktemp("deep_noise")
    assert run_pincal("simulate", "delta", "--samples", "40", "--test-samples", "20", "--seed", "2", "--quiet",
                      "--out", str(out)).returncode == 0
    lines = (out / "measurements.csv").read_text().splitlines()
    header = [line for line in lines if line.startswith("#") and not line.startswith("# sigma")]
    table = [line for line in lines if not line.startswith("#")]
    columns = table[0].split(",")
    z, part = columns.index("position:end_effector:z"), columns.index("set")
    rng = np.random.default_rng(0)
    rows = [table[0]]
    for line in table[1:]:
        cells = line.split(",")
        if cells[part] == "train":
            cells[z] = repr(float(cells[z]) + rng.normal(scale=2e-3))
        rows.append(",".join(cells))
    return out, header, rows


def test_a_sigma_per_component_in_a_file_and_a_job_file(tmp_path: Path,
                                                         deep_noise: tuple[Path, list[str], list[str]]) -> None:
    """σ = [1e-5, 1e-5, 2e-3] (x, y, z) weights the noisy depth down: the held-out error is several times smaller
    than with one σ for every axis (1 mm, about the pooled noise), from a data file's '# sigma' line and from a job
    file's [[measure]] alike."""
    _, header, rows = deep_noise
    files = {}
    for name, line in (("one", "# sigma position: 1e-3"), ("each", "# sigma position: [1e-5, 1e-5, 2e-3]")):
        files[name] = tmp_path / f"{name}.csv"
        files[name].write_text("\n".join([*header, line, *rows]) + "\n")
    one, _ = calibrated(tmp_path, "one", "delta", str(files["one"]))
    each, _ = calibrated(tmp_path, "each", "delta", str(files["each"]))
    assert each["test_rms_after"] < one["test_rms_after"] / 3
    bare = tmp_path / "bare.csv"
    bare.write_text("\n".join([*header, *rows]) + "\n")
    job = tmp_path / "job.toml"
    job.write_text(f'robot = "delta"\n\n[data]\nfile = "{bare}"\nsample = "sample"\nheld_out = "set"\n\n'
                   '[[measure]]\nkind = "position"\nframe = "end_effector"\n'
                   'columns = ["position:end_effector:x", "position:end_effector:y", "position:end_effector:z"]\n'
                   'sigma = [1e-5, 1e-5, 2e-3]\n')
    from_job, _ = calibrated(tmp_path, "job", str(job))
    assert from_job["test_rms_after"] == pytest.approx(each["test_rms_after"], rel=1e-6)
    done = run_pincal("calibrate", "delta", str(files["one"]), "--sigma", "1e-5,2e-3")
    assert done.returncode == 2 and done.stderr.count("\n") == 1
    assert "must give one finite value > 0 per residual row, 3: x [m], y [m], z [m]" in done.stderr


def test_a_sigma_per_component_through_the_api(deep_noise: tuple[Path, list[str], list[str]]) -> None:
    """``CalibrationOptions(sigma=(…))`` weights as the file's line does."""
    import pincal
    from pincal.calibration import calibrate

    out, header, rows = deep_noise
    path = out / "bare_api.csv"
    path.write_text("\n".join([*header, *rows]) + "\n")
    robot, data = pincal.load_robot("delta"), pincal.read_dataset(path)
    each = calibrate(robot, data, sigma=[1e-5, 1e-5, 2e-3]).report
    one = calibrate(robot, data, sigma=1e-3).report
    assert each.test_rms_after is not None and one.test_rms_after is not None
    assert each.test_rms_after < one.test_rms_after / 3
    with pytest.raises(pincal.DataError, match="a σ is a finite number > 0"):
        calibrate(robot, data, sigma=[1e-5, -1.0, 2e-3])


def test_select_cv_chooses_the_groups_by_cross_validated_error(tmp_path: Path) -> None:
    """--select cv on small simulated Deltas: with the geometry perturbed (1 mm, 1 mrad) every group predicts
    better and stays; with the nominal geometry measured (no error to find) none does and all are left out; the
    same choice on every run (seeded folds)."""
    choices = {}
    for perturb in ("1e-3", "0"):
        sim = tmp_path / f"sim_{perturb}"
        assert run_pincal("simulate", "delta", "--samples", "30", "--seed", "3", "--perturb", perturb, "--quiet",
                          "--out", str(sim)).returncode == 0
        report, _ = calibrated(tmp_path, f"cv_{perturb}", "delta", str(sim / "measurements.csv"), "--select", "cv")
        assert report["selection"]["policy"] == "cv"
        choices[perturb] = report["selection"]["removed_groups"]
        if perturb == "0":
            again, _ = calibrated(tmp_path, "again", "delta", str(sim / "measurements.csv"), "--select", "cv")
            assert again["selection"] == report["selection"] and again["rms_after"] == report["rms_after"]
    assert choices["1e-3"] == []
    assert choices["0"] == ["translations", "rotations", "offsets"]
