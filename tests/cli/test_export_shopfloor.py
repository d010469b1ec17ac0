"""``pincal export`` as a user may run it by mistake: ``--out`` naming the calibration's data file, which the export
reads (its fitted postures prove the export), is refused as any other input: one line, exit 2, the file intact."""

from __future__ import annotations

from pathlib import Path

from conftest import run_pincal


def test_export_refuses_to_write_over_the_calibration_data_it_reads(tmp_path: Path) -> None:
    done = run_pincal("simulate", "ur5", "--measure", "pose", "--samples", "12", "--seed", "3", "--quiet", "--out",
                      str(tmp_path))
    assert done.returncode == 0, done.stderr
    data = tmp_path / "measurements.csv"
    done = run_pincal("calibrate", "ur5", str(data), "--out", str(tmp_path / "cal.urdf"))
    assert done.returncode == 0, done.stderr
    before = data.read_bytes()
    done = run_pincal("export", str(tmp_path / "cal.urdf"), "--out", str(data))
    assert done.returncode == 2, done.stdout + done.stderr
    assert done.stderr.strip() == (f"pincal: error: --out '{data}' is the input file '{data}': pincal never writes "
                                   "over its input; choose another output name")
    assert data.read_bytes() == before
