"""The same inputs and seed give bit-identical results and files."""

from __future__ import annotations

from pathlib import Path

from pincal.cli import main


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
