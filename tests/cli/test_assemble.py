"""``pincal assemble`` as a user runs it: the README's four-bar drawn roughly, assembled, then loaded, simulated and
calibrated; and what it refuses."""

from __future__ import annotations

import subprocess
import sys
from pathlib import Path

from conftest import PINCAL, readme_four_bar, run_pincal
from many_four_bars import many_four_bars_urdf
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


#: Runs a command and writes its exit code and peak memory [kB] to a file. The peak is measured in a process started by
#: this small one: Linux counts a process's peak from before its ``exec`` (the forked copy of its parent), and the test
#: process may be large.
PEAK = ("import os, sys\n"
        "pid = os.posix_spawn(sys.argv[2], sys.argv[2:], os.environ)\n"
        "_, status, usage = os.wait4(pid, 0)\n"
        "open(sys.argv[1], 'w').write(f'{os.waitstatus_to_exitcode(status)} {usage.ru_maxrss}')\n")


def peak_memory(*args: str, cwd: Path) -> tuple[int, str, float]:
    """``pincal ARGS`` started from scratch: its exit code, its standard output and its peak resident memory [MB]."""
    result = cwd / "peak.txt"
    done = subprocess.run([sys.executable, "-c", PEAK, str(result), str(PINCAL), *args], cwd=cwd, capture_output=True,
                          text=True, check=False)
    code, peak = result.read_text(encoding="utf-8").split()
    return int(code), done.stdout, int(peak) / 1024


def test_independent_loops_give_each_loops_answer(tmp_path: Path) -> None:
    source = draft(tmp_path, many_four_bars_urdf(3, assembled=False))
    out = tmp_path / "three.urdf"
    done = run_pincal("assemble", str(source), "--out", str(out))
    assert done.returncode == 0, done.stderr
    lines = done.stdout.splitlines()  # the README four-bar's figures, once per loop
    assert lines[0].startswith("loops closed at the zero configuration: largest residual 0.00315 m/rad before, ")
    assert lines[0].endswith(" after (3 Gauss-Newton steps on the passive joints)")
    for k in range(3):
        assert (f"  coupler_joint_{k}: closes the loops at +12.7135 mrad, its new zero; origin moved 0.0000 mm, "
                "turned 12.7135 mrad") in lines
        assert (f"  rocker_joint_{k}: closes the loops at +8.5072 mrad, its new zero; origin moved 0.0000 mm, "
                "turned 8.5072 mrad") in lines
    info = run_pincal("info", str(out))
    assert info.returncode == 0, info.stderr
    assert "configuration: nq 15, nv 9; closure rows 15; mobility 3" in info.stdout
    assert ("measured frame (default): end_effector, moved by the actuated joints (named like an end effector); at "
            "(0.099127, 0.191098, 0.000000) m at the reference") in info.stdout


def test_66_independent_loops_cost_memory_linear_in_the_loops(tmp_path: Path) -> None:
    # 198 joints, inside the 200-joint limit: one Pinocchio data of the whole model holds 198³ × 4 numbers (250 MB),
    # and assemble held three of them (0.9 GB); each block of 3 joints needs a few kB
    (tmp_path / "66_draft.urdf").write_text(many_four_bars_urdf(66, assembled=False), encoding="utf-8")
    (tmp_path / "one.urdf").write_text(many_four_bars_urdf(1), encoding="utf-8")
    code, _, floor = peak_memory("info", "one.urdf", cwd=tmp_path)  # the imports: what every command holds
    assert code == 0
    code, text, assembling = peak_memory("assemble", "66_draft.urdf", "--out", "66.urdf", cwd=tmp_path)
    assert code == 0 and text.count("closes the loops at +12.7135 mrad") == 66
    couplers = {line.strip() for line in (tmp_path / "66.urdf").read_text(encoding="utf-8").splitlines()
                if line.strip().startswith('<origin xyz="0.0 0.1 0.0"')}
    assert len(couplers) == 1  # every loop closed as it is closed alone (one solve of all mixed their last digits)
    code, text, describing = peak_memory("info", "66.urdf", cwd=tmp_path)
    assert code == 0 and "configuration: nq 330, nv 198; closure rows 330; mobility 66" in text
    assert "actuated joints (66): crank_joint_0, crank_joint_1, " in text
    assert assembling - floor < 60 and describing - floor < 60, (floor, assembling, describing)


def test_info_on_a_draft_names_the_command_that_assembles_it(tmp_path: Path) -> None:
    draft(tmp_path)
    line = one_line_error(run_pincal("info", "four_bar_draft.urdf", cwd=tmp_path))
    assert line.startswith("pincal: error: four_bar_draft.urdf: loop 'coupler_rocker' does not close at the reference "
                           "configuration (all joints zero): residual 0.00315 m/rad > 1e-09; ")
    assert "assemble it: pincal assemble four_bar_draft.urdf --out ROBOT.urdf turns the passive joints" in line
