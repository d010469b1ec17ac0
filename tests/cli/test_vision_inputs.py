"""What the camera commands refuse or warn of, as a user runs them: ``detect --measure pixel:NAME`` of a frame the
robot lacks, the pixel noise a camera simulation draws without ``--noise``, a ``simulate --shift`` beyond what a
robot is plausibly off by."""

from __future__ import annotations

from pathlib import Path

import numpy as np
from conftest import run_pincal

from pincal.io.dataset_reader import read_dataset

BOARD = "charuco:8x6:0.03:0.022:DICT_4X4_50"


def _ok(done: object) -> str:
    assert done.returncode == 0, done.stdout + done.stderr  # type: ignore[attr-defined]
    return str(done.stdout)  # type: ignore[attr-defined]


def test_detect_refuses_a_frame_the_robot_lacks_before_any_work(tmp_path: Path) -> None:
    _ok(run_pincal("simulate", "ur10", "--measure", "pixel:tool0", "--samples", "2", "--images", "imgs", "--seed",
                   "1", "--out", "sim", cwd=tmp_path))
    files = sorted(str(p) for p in (tmp_path / "imgs").glob("*.png"))
    done = run_pincal("detect", *files, "--board", BOARD, "--joints", "sim/joints.csv", "--measure", "pixel:tool9",
                      "--out", "d.csv", cwd=tmp_path)  # the joints file's '# robot: ur10'
    assert done.returncode == 2 and len(done.stderr.splitlines()) == 1
    assert done.stderr.startswith("pincal: error: --measure: frame 'tool9' does not exist in robot 'ur10'")
    assert not (tmp_path / "d.csv").exists()
    done = run_pincal("detect", *files, "--board", BOARD, "--joints", "sim/joints.csv", "--robot", "panda",
                      "--measure", "board_pixel:tool0", "--out", "d.csv", cwd=tmp_path)
    assert done.returncode == 2 and "frame 'tool0' does not exist in robot 'panda'" in done.stderr
    text = (tmp_path / "sim" / "joints.csv").read_text()
    (tmp_path / "anonymous.csv").write_text("\n".join(line for line in text.splitlines()
                                                      if not line.startswith("# robot")) + "\n")
    out = _ok(run_pincal("detect", *files, "--board", BOARD, "--joints", "anonymous.csv", "--measure", "pixel:tool0",
                         "--out", "d.csv", cwd=tmp_path))
    assert "note: frame 'tool0' not checked: the joints file names no robot" in out


def test_a_camera_simulation_draws_pixel_noise_by_default(tmp_path: Path) -> None:
    common = ("simulate", "ur10", "--measure", "pixel:tool0", "--samples", "6", "--seed", "4")
    out = _ok(run_pincal(*common, "--out", "noisy", cwd=tmp_path))
    _ok(run_pincal(*common, "--noise", "0", "--out", "exact", cwd=tmp_path))
    assert "pixel noise σ 0.3 px" in out
    noisy, exact = read_dataset(tmp_path / "noisy" / "measurements.csv"), read_dataset(tmp_path / "exact" /
                                                                                      "measurements.csv")
    assert noisy.metadata["sigma pixel"] == "0.3"
    gaps = np.concatenate([(noisy.measurements[k] - exact.measurements[k]).ravel() for k in exact.measurements])
    gaps = gaps[np.isfinite(gaps)]
    assert gaps.size > 100 and 0.2 < float(np.std(gaps)) < 0.4  # [px] per axis


def test_simulate_warns_of_a_shift_beyond_a_plausible_robot(tmp_path: Path) -> None:
    out = _ok(run_pincal("simulate", "ur10", "--measure", "position", "--samples", "8", "--shift",
                         "shoulder_lift_joint.offset=2", "--shift", "elbow_joint.offset=0.01", "--out", "s",
                         cwd=tmp_path))
    warnings = [line for line in out.splitlines() if line.startswith("warning: --shift")]
    assert len(warnings) == 1 and warnings[0].startswith("warning: --shift shoulder_lift_joint.offset=2 [rad] is "
                                                         "beyond the 0.0873 rad")
