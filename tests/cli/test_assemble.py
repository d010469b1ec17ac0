"""``pincal assemble`` as a user runs it: the README's four-bar drawn roughly, assembled, then loaded, simulated and
calibrated; and what it refuses."""

from __future__ import annotations

from pathlib import Path

from conftest import readme_four_bar, run_pincal
from test_job_file import one_line_error


def draft(folder: Path, text: str | None = None) -> Path:
    path = folder / "four_bar_draft.urdf"
    path.write_text(text if text is not None else readme_four_bar(), encoding="utf-8")
    return path


def test_the_readme_four_bar_assembles_loads_and_simulates(tmp_path: Path) -> None:
    source = draft(tmp_path)
    refused = one_line_error(run_pincal("info", str(source)))
    assert "loop 'coupler_rocker' does not close at the reference configuration" in refused
    out = tmp_path / "four_bar.urdf"
    done = run_pincal("assemble", str(source), "--out", str(out))
    assert done.returncode == 0, done.stderr
    lines = done.stdout.splitlines()  # the figures the README quotes
    assert lines[0].startswith("loops closed at the zero configuration: largest residual 0.00315 m/rad before, ")
    assert ("  coupler_joint: closes the loops at +12.7135 mrad, its new zero; origin moved 0.0000 mm, turned "
            "12.7135 mrad") in lines
    assert ("  rocker_joint: closes the loops at +8.5072 mrad, its new zero; origin moved 0.0000 mm, turned "
            "8.5072 mrad") in lines
    before, after = source.read_text(encoding="utf-8").splitlines(), out.read_text(encoding="utf-8").splitlines()
    changed = [(a, b) for a, b in zip(before, after, strict=True) if a != b]
    assert [a.strip() for a, _ in changed] == ['<origin xyz="0 0.1 0" rpy="0 0 0.35"/><axis xyz="0 0 1"/>',
                                               '<origin xyz="0.3 0 0" rpy="0 0 1.9"/><axis xyz="0 0 1"/>']
    info = run_pincal("info", str(out))
    assert info.returncode == 0, info.stderr
    assert "mobility 1" in info.stdout and "actuated joints (1): crank_joint" in info.stdout
    residual = next(line for line in info.stdout.splitlines() if line.startswith("closure residual"))
    assert float(residual.split(": ")[1].split()[0]) < 1e-15
    sim = run_pincal("simulate", str(out), "--samples", "12", "--quiet", "--out", str(tmp_path / "sim"))
    assert sim.returncode == 0, sim.stderr
    again = run_pincal("assemble", str(out), "--out", str(tmp_path / "again.urdf"))
    assert "no passive joint moved" in again.stdout and (tmp_path / "again.urdf").read_text() == out.read_text()


def test_assemble_refuses_output_over_input_a_serial_robot_and_lengths_that_do_not_fit(tmp_path: Path) -> None:
    source = draft(tmp_path)
    line = one_line_error(run_pincal("assemble", str(source), "--out", str(source)))
    assert "is the input file" in line
    serial = tmp_path / "serial.urdf"
    serial.write_text('<robot name="arm"><link name="a"/><link name="b"/><joint name="j" type="revolute">'
                      '<parent link="a"/><child link="b"/><axis xyz="0 0 1"/>'
                      '<limit lower="-1" upper="1" effort="1" velocity="1"/></joint></robot>', encoding="utf-8")
    assert "declares no <loop>: a serial robot has nothing to assemble" in one_line_error(
        run_pincal("assemble", str(serial), "--out", str(tmp_path / "o.urdf")))
    short = draft(tmp_path, readme_four_bar().replace('<successor link="rocker"><origin xyz="0.2 0 0"',
                                                      '<successor link="rocker"><origin xyz="0.02 0 0"'))
    line = one_line_error(run_pincal("assemble", str(short), "--out", str(tmp_path / "o.urdf")))
    assert "no values of the passive joints close loop 'coupler_rocker'" in line
    assert not (tmp_path / "o.urdf").exists()
    assert "does not exist" in one_line_error(run_pincal("assemble", str(tmp_path / "none.urdf"), "--out",
                                                         str(tmp_path / "o.urdf")))
