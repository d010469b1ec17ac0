"""The same inputs and seed give bit-identical results and files."""

from __future__ import annotations

from pathlib import Path

from conftest import run_pincal

from pincal.cli.app import main


def _run(out: Path) -> dict[str, bytes]:
    assert main(["simulate", "delta", "--samples", "30", "--test-samples", "10", "--noise", "1e-5", "--seed", "7",
                 "--parameters", "model24", "--out", str(out / "sim")]) == 0
    assert main(["calibrate", "delta", str(out / "sim" / "measurements.csv"), "--parameters", "model24",
                 "--out", str(out / "cal.urdf"), "--report", str(out / "report.json")]) == 0
    return {str(p.relative_to(out)): p.read_bytes() for p in sorted(out.rglob("*")) if p.is_file()}


def test_same_seed_same_bytes(tmp_path: Path) -> None:
    first, second = _run(tmp_path / "a"), _run(tmp_path / "b")
    assert sorted(first) == ["cal.urdf", "report.json", "sim/measurements.csv", "sim/truth.json", "sim/truth.urdf"]
    assert first == second


def test_another_seed_other_data(tmp_path: Path) -> None:
    a = tmp_path / "a"
    assert main(["simulate", "delta", "--samples", "5", "--seed", "1", "--out", str(a)]) == 0
    b = tmp_path / "b"
    assert main(["simulate", "delta", "--samples", "5", "--seed", "2", "--out", str(b)]) == 0
    assert (a / "measurements.csv").read_bytes() != (b / "measurements.csv").read_bytes()


def test_report_and_scene_pages_are_byte_identical_across_runs(tmp_path: Path) -> None:
    """meshcat names objects by time-based uuids: the pages must not depend on when they were written."""
    sim = tmp_path / "sim"
    assert run_pincal("simulate", "five_bar", "--samples", "12", "--test-samples", "4", "--seed", "1", "--quiet",
                      "--out", str(sim)).returncode == 0
    pages = []
    for run in ("a", "b"):
        for command in ("view", "report"):
            out = tmp_path / f"{command}_{run}.html"
            done = run_pincal(command, "five_bar", str(sim / "measurements.csv"), "--parameters", "*.offset",
                              "--quiet", "--out", str(out))
            assert done.returncode == 0, done.stderr
            pages.append(out.read_bytes())
    scene_a, report_a, scene_b, report_b = pages
    assert scene_a == scene_b and report_a == report_b
    assert b"MeshCat.Viewer" in scene_a and len(scene_a) > 100_000  # a real scene, not an empty page
