"""σ per axis: data whose axes are not equally noisy, with no '# sigma' line, get a σ per residual row by variance
components, said in the summary and the report, and weighed in the fit as '# sigma' lines would."""

from __future__ import annotations

import json
from pathlib import Path

import numpy as np
import pytest
from conftest import run_pincal

import pincal
from pincal.io.dataset import dataset_text


def test_a_noisier_axis_gets_its_own_sigma(tmp_path: Path) -> None:
    """A UR10 campaign measured without noise, then 0.05 mm added on x and y and 0.2 mm on z (a camera's depth, a
    tracker's worse axis), the '# sigma' lines removed: ``pincal calibrate`` estimates each axis within 15 % and says
    so; fitted with those weights, it predicts the held-out postures at least as well as with one σ for all axes."""
    sim = tmp_path / "sim"
    assert run_pincal("simulate", "ur10", "--samples", "80", "--test-samples", "40", "--noise", "0", "--seed", "5",
                      "--quiet", "--out", str(sim)).returncode == 0
    data = pincal.read_dataset(str(sim / "measurements.csv"))
    key = next(iter(data.measurements))
    rng = np.random.default_rng(0)
    truth = np.array([5e-5, 5e-5, 2e-4])
    noisy = data.measurements[key] + rng.normal(size=data.measurements[key].shape) * truth
    metadata = {k: v for k, v in data.metadata.items() if not k.startswith("sigma")}
    bare = tmp_path / "axes.csv"
    bare.write_text(dataset_text(type(data)(data.joint_names, data.joints, {key: noisy}, data.sample_ids, data.sets,
                                            metadata)))
    report = tmp_path / "r.json"
    done = run_pincal("calibrate", "ur10", str(bare), "--report", str(report))
    assert done.returncode == 0, done.stderr
    estimated = json.loads(report.read_text())["estimated_sigma"][key]
    assert [estimated["rows"][axis] for axis in "xyz"] == pytest.approx(truth.tolist(), rel=0.15)
    assert estimated["units"] == {"x": "m", "y": "m", "z": "m"}
    assert f"{key} x {estimated['rows']['x'] * 1e3:.3g} mm" in done.stdout and "per axis" in done.stdout
    # one σ for every axis, the RMS of the three: the noisier axis then weighs as much as the others
    one = tmp_path / "one.csv"
    single = float(np.sqrt(np.mean(truth**2)))
    one.write_text(bare.read_text().replace("# robot:", f"# sigma position: {single!r}\n# robot:", 1))
    other = tmp_path / "one.json"
    assert run_pincal("calibrate", "ur10", str(one), "--report", str(other)).returncode == 0
    per_axis, isotropic = (json.loads(p.read_text())["test_rms_after"] for p in (report, other))
    assert per_axis <= isotropic * 1.01
