"""Units per column as a user meets them: a job file with the mocap in mm and the torso in m, and every unit
mismatch refused before the fit in one line naming the column and the likely unit (``pincal calibrate``)."""

from __future__ import annotations

import csv
from pathlib import Path

from conftest import ROOT, run_pincal
from test_job_file import copy_job, one_line_error

RAW = ROOT / "examples" / "data" / "tiago_mocap_raw.csv"
CONVERTED = ROOT / "examples" / "data" / "tiago_mocap_marker1.csv"
#: A refused run ends well within this [s]; today's fits of such data ran for minutes.
TIMEOUT = 60.0


def mocap_in_mm(folder: Path) -> Path:
    """The raw TIAGo file with the marker columns (x1 … z4) in mm, the joints as recorded (torso in m, arm in rad)."""
    rows = list(csv.reader(RAW.read_text(encoding="utf-8").splitlines()))
    header = rows[0]
    scaled = [[repr(float(v) * 1e3) if c[0] in "xyz" else v for c, v in zip(header, row, strict=True)]
              for row in rows[1:]]
    path = folder / "mocap_mm.csv"
    path.write_text("\n".join(",".join(r) for r in [header, *scaled]) + "\n", encoding="utf-8")
    return path


def scaled_csv(folder: Path, source: Path, factor: float) -> Path:
    """A CSV in pincal's format with its position columns ``factor`` times too large."""
    lines = source.read_text(encoding="utf-8").splitlines()
    out, header = [], None
    for line in lines:
        if line.startswith("#"):
            out.append(line)
            continue
        cells = line.split(",")
        if header is None:
            header = cells
            out.append(line)
            continue
        out.append(",".join(repr(float(v) * factor) if h.startswith("position:") and v else v
                            for h, v in zip(header, cells, strict=True)))
    path = folder / f"x{factor:g}.csv"
    path.write_text("\n".join(out) + "\n", encoding="utf-8")
    return path


def mm_job(folder: Path, length: str = "mm", torso: str | None = "m") -> Path:
    """The example job on the mocap file in mm, reading lengths in ``length`` and, with ``torso``, the torso in it."""
    mocap_in_mm(folder)
    job = copy_job(folder, data="mocap_mm.csv",
                   **{'units = { length = "m", angle = "rad" }': f'units = {{ length = "{length}", angle = "rad" }}'})
    if torso is not None:
        job.write_text(job.read_text(encoding="utf-8") + f'\n[joints]\ntorso_lift_joint = {{ units = "{torso}" }}\n',
                       encoding="utf-8")
    return job


def test_mocap_in_mm_with_the_torso_in_m_calibrates_as_the_file_in_metres(tmp_path: Path) -> None:
    """The job states mm for the file and m for the torso column: the fit is that of the file in metres (the figures
    docs/job_file.md quotes)."""
    runs = [run_pincal("calibrate", str(mm_job(tmp_path)), timeout=TIMEOUT),
            run_pincal("calibrate", "tiago_no_hand", str(CONVERTED))]
    rms = []
    for done in runs:
        assert done.returncode == 0, done.stderr
        rms.append({line.split("  ")[0]: line.split()[-4:] for line in done.stdout.splitlines()
                    if line.startswith("RMS position error")})
    assert sorted(rms[0]) == ["RMS position error (fit)", "RMS position error (held out)"]
    assert rms[0] == rms[1]  # before and after, to 0.1 µm


def test_the_torso_read_in_mm_is_named_before_the_fit(tmp_path: Path) -> None:
    """The file-wide mm read the torso 1000x too small: one line names its column and the likely unit."""
    done = run_pincal("calibrate", str(mm_job(tmp_path, torso=None)), timeout=TIMEOUT)
    line = one_line_error(done)
    assert "joint 'torso_lift_joint' (column 'torso_lift_joint', read in mm)" in line
    assert "the column is likely in m, not mm" in line and '[joints] torso_lift_joint = { units = "m" }' in line
    assert "NOT CONVERGED" not in done.stdout and done.stdout == ""


def test_cm_for_a_file_in_mm_is_named_before_the_fit(tmp_path: Path) -> None:
    line = one_line_error(run_pincal("calibrate", str(mm_job(tmp_path, length="cm")), timeout=TIMEOUT))
    assert "the measured positions 'position:wrist_ft_tool_link' (columns x1, y1, z1, read in cm)" in line
    assert "the columns are likely in mm, not cm" in line


def test_positions_10x_in_a_plain_csv_are_named_before_the_fit(tmp_path: Path) -> None:
    """10x is no unit's ratio to the metre: the line says so, with the columns and the band."""
    line = one_line_error(run_pincal("calibrate", "tiago_no_hand", str(scaled_csv(tmp_path, CONVERTED, 10.0)),
                                     timeout=TIMEOUT))
    assert "the measured positions 'position:wrist_ft_tool_link' (columns position:wrist_ft_tool_link:x" in line
    assert ", read in m) spread" in line and "no length unit explains a factor of" in line


def test_positions_10x_on_a_closed_loop_robot_end_in_one_line(tmp_path: Path, five_bar_csv: Path) -> None:
    line = one_line_error(run_pincal("calibrate", "five_bar", str(scaled_csv(tmp_path, five_bar_csv, 10.0)),
                                     timeout=TIMEOUT))
    assert "spread" in line and "no length unit explains a factor of 10" in line


def test_plausible_off_leaves_a_10x_csv_to_the_fit(tmp_path: Path) -> None:
    """--plausible off says the data are right for this robot: only beyond 30x are they refused before the fit."""
    done = run_pincal("calibrate", "tiago_no_hand", str(scaled_csv(tmp_path, CONVERTED, 10.0)), "--plausible", "off",
                      timeout=TIMEOUT)
    assert done.returncode == 0, done.stderr
    line = one_line_error(run_pincal("calibrate", str(mm_job(tmp_path, length="um")), "--plausible", "off",
                                     timeout=TIMEOUT))
    assert "(columns x1, y1, z1, read in um)" in line and "beyond 30× either way" in line
    assert "the columns are likely in mm, not um" in line
