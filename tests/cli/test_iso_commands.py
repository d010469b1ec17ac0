"""``pincal iso9283`` as a user runs it: ``evaluate`` on a runs file (its report and page, the warning of an RP the
instrument cannot resolve, bad files refused in one line) and ``plan`` on the UR10, the Panda, the Delta and the
hexapod (the commands' forward kinematics is the planned poses)."""

from __future__ import annotations

import csv
import json
import math
from pathlib import Path

import numpy as np
import pinocchio as pin
import pytest
from conftest import run_pincal

import pincal

HEADER = ["pose", "cycle", "direction", "cmd_x", "cmd_y", "cmd_z", "x", "y", "z"]


def _write_runs(path: Path, rows: list[list[object]], header: list[str] = HEADER) -> None:
    with path.open("w", newline="", encoding="utf-8") as stream:
        stream.write("# robot: ur10\n")
        writer = csv.writer(stream)
        writer.writerow(header)
        writer.writerows([[repr(c) if isinstance(c, float) else c for c in row] for row in rows])


def _simulated_rows(rng: np.random.Generator) -> tuple[list[list[object]], dict[str, np.ndarray]]:
    commanded = {"P1": np.array([0.6, 0.1, 0.4]), "P2": np.array([0.7, 0.2, 0.3])}
    bias = np.array([2e-4, -1e-4, 0.0])
    attained = {name: c + bias + rng.normal(scale=2e-5, size=(30, 3)) for name, c in commanded.items()}
    rows = [[name, cycle, "", *commanded[name].tolist(), *attained[name][cycle].tolist()]
            for cycle in range(30) for name in commanded]
    return rows, attained


def test_evaluate_prints_writes_and_warns_as_the_standard_computes(tmp_path: Path) -> None:
    rows, attained = _simulated_rows(np.random.default_rng(7))
    _write_runs(tmp_path / "runs.csv", rows)
    done = run_pincal("iso9283", "evaluate", "ur10", "runs.csv", "--report", "iso.json", "--html", "iso.html",
                      "--instrument-uncertainty", "1e-4", cwd=tmp_path)
    assert done.returncode == 0, done.stderr
    report = json.loads((tmp_path / "iso.json").read_text(encoding="utf-8"))
    assert report["units"] == "SI: m, rad" and [p["pose"] for p in report["poses"]] == ["P1", "P2"]
    for pose, name in zip(report["poses"], ("P1", "P2"), strict=True):
        mean = attained[name].mean(axis=0)
        lengths = np.linalg.norm(attained[name] - mean, axis=1)
        assert pose["ap"] == pytest.approx(np.linalg.norm(mean - rows[0 if name == "P1" else 1][3:6]), rel=1e-9)
        assert pose["rp"] == pytest.approx(lengths.mean() + 3 * lengths.std(ddof=1), rel=1e-9)
    distances = np.linalg.norm(attained["P1"] - attained["P2"], axis=1)
    (pair,) = report["distances"]
    assert pair["ad"] == pytest.approx(distances.mean() - math.sqrt(0.03), rel=1e-6)
    assert pair["rd"] == pytest.approx(3 * distances.std(ddof=1), rel=1e-9)
    assert "warning: RP of P1, P2 is below the instrument's stated uncertainty 0.1 mm" in done.stdout
    page = (tmp_path / "iso.html").read_text(encoding="utf-8")
    assert "<h2>Pose accuracy and repeatability</h2>" in page and f"{report['poses'][0]['rp'] * 1e3:.4f}" in page
    assert f"{report['poses'][0]['rp'] * 1e3:.4f}" in done.stdout


@pytest.mark.parametrize(("header", "cells", "message"), [
    (["pose", "cycle", "x", "y", "z"], ["P1", "0", "0", "0", "0"], "no column cmd_x, cmd_y, cmd_z"),
    (HEADER, ["P1", "zero", "", "0", "0", "0", "0", "0", "0"], "line 3: cycle 'zero' is not a whole number"),
    (HEADER, ["P1", "0", "", "0", "0", "0", "1500", "0", "0"], "a position beyond"),
    ([*HEADER, "qw"], ["P1", "0", "", "0", "0", "0", "0", "0", "0", "1"], "orientation columns qw without"),
])
def test_evaluate_refuses_a_bad_runs_file_in_one_line(tmp_path: Path, header: list[str], cells: list[str],
                                                      message: str) -> None:
    _write_runs(tmp_path / "runs.csv", [cells, [*cells[:1], "1", *cells[2:]]], header)
    done = run_pincal("iso9283", "evaluate", "ur10", "runs.csv", cwd=tmp_path)
    assert done.returncode == 2 and done.stderr.startswith("pincal: error: runs.csv: ") and message in done.stderr
    assert done.stderr.count("\n") == 1


def test_evaluate_writes_no_report_over_its_input(tmp_path: Path) -> None:
    rows, _ = _simulated_rows(np.random.default_rng(1))
    _write_runs(tmp_path / "runs.csv", rows)
    before = (tmp_path / "runs.csv").read_bytes()
    done = run_pincal("iso9283", "evaluate", "ur10", "runs.csv", "--report", "runs.csv", cwd=tmp_path)
    assert done.returncode == 2 and "runs.csv" in done.stderr and (tmp_path / "runs.csv").read_bytes() == before


def _plan_rows(path: Path) -> tuple[dict[str, str], list[dict[str, str]]]:
    lines = path.read_text(encoding="utf-8").splitlines()
    metadata = dict(line[2:].split(": ", 1) for line in lines if line.startswith("# "))
    return metadata, list(csv.DictReader(line for line in lines if not line.startswith("#")))


def _quaternion_matrix(w: float, x: float, y: float, z: float) -> np.ndarray:
    return np.asarray(pin.Quaternion(w, x, y, z).matrix())


@pytest.mark.parametrize("robot", ["ur10", "panda", "delta", "hexapod"])
def test_plan_places_p1_to_p5_as_the_standard_and_its_commands_reach_them(tmp_path: Path, robot: str) -> None:
    """P1 at the cube's centre, P2–P5 at 10 % of the diagonal plane's diagonals from C1, C2, C7, C8; the forward
    kinematics of each row's joint commands (and of its approach's) puts the frame on the planned point."""
    done = run_pincal("iso9283", "plan", robot, "--cycles", "2", "--out", "plan.csv", cwd=tmp_path)
    assert done.returncode == 0, done.stderr
    metadata, rows = _plan_rows(tmp_path / "plan.csv")
    centre_text, side_text = metadata["cube"].removeprefix("centre ").split(" m, side ")
    centre, side = np.array(centre_text.split(), dtype=float), float(side_text.removesuffix(" m"))
    c1 = centre - side / 2
    c2, c7, c8 = (c1 + np.array(step) for step in ([side, 0, 0], [side, side, side], [0, side, side]))
    expected = {"P1": centre, "P2": 0.9 * c1 + 0.1 * c7, "P3": 0.9 * c2 + 0.1 * c8, "P4": 0.9 * c7 + 0.1 * c1,
                "P5": 0.9 * c8 + 0.1 * c2}
    assert side > 0.05
    nominal = pincal.load_robot(robot)
    frame = metadata["iso9283"].split("frame ")[1].split(";")[0]
    joints = list(nominal.actuated_joints)
    assert len(rows) == 2 * 5 + 3 * 3 * 2 and [r["pose"] for r in rows[:5]] == ["P1", "P5", "P4", "P3", "P2"]
    for row in rows:
        commanded = np.array([float(row[f"cmd_{c}"]) for c in "xyz"])
        assert commanded == pytest.approx(expected[row["pose"]], abs=1e-12)
        points = [(commanded, [float(row[j]) for j in joints])]
        if row["direction"]:
            approach = np.array([float(row[f"approach_{c}"]) for c in "xyz"])
            assert np.linalg.norm(approach - commanded) == pytest.approx(0.1 * side)
            points.append((approach, [float(row[f"approach:{j}"]) for j in joints]))
        for point, command in points:
            placement = nominal.placement(nominal.solve_fk(np.array(command)), frame)
            assert np.linalg.norm(placement.translation - point) < 1e-7
            if "cmd_qw" in row:
                wanted = _quaternion_matrix(*(float(row[f"cmd_q{c}"]) for c in "wxyz"))
                assert np.linalg.norm(pin.log3(placement.rotation @ wanted.T)) < 1e-7


def test_plan_refuses_a_region_where_no_cube_fits_and_an_orientation_a_delta_does_not_take(tmp_path: Path) -> None:
    far = run_pincal("iso9283", "plan", "ur10", "--region", "5,5,5,6,6,6", "--out", "plan.csv", cwd=tmp_path)
    assert far.returncode == 2 and far.stderr.count("\n") == 1
    assert "no test cube of side ≥ 20 mm fits inside the reachable workspace in the region [5, 5, 5, 6, 6, 6] m" \
        in far.stderr
    delta = run_pincal("iso9283", "plan", "delta", "--orientation", "1,0,0,0", "--out", "plan.csv", cwd=tmp_path)
    assert delta.returncode == 2 and "'delta' has 3 degrees of freedom" in delta.stderr
    assert not (tmp_path / "plan.csv").exists()


def test_plan_in_a_region_on_a_calibrated_model_commands_the_model(tmp_path: Path) -> None:
    """The commands through compensate on a calibrated URDF (a simulated truth here): its forward kinematics, not
    the nominal robot's, reaches P1–P5 in the region asked."""
    sim = run_pincal("simulate", "delta", "--samples", "4", "--seed", "3", "--quiet", "--out", "sim", cwd=tmp_path)
    assert sim.returncode == 0, sim.stderr
    done = run_pincal("iso9283", "plan", "delta", "--model", "sim/truth.urdf", "--region=-0.2,-0.2,-0.5,0.2,0.2,-0.2",
                      "--cycles", "2", "--out", "plan.csv", cwd=tmp_path)
    assert done.returncode == 0, done.stderr
    assert "through compensate on the calibrated model sim/truth.urdf" in done.stdout
    metadata, rows = _plan_rows(tmp_path / "plan.csv")
    assert "frame end_effector_marker;" in metadata["iso9283"]  # the calibrated marker, as compensate reaches it
    truth, nominal = pincal.load_robot(tmp_path / "sim" / "truth.urdf"), pincal.load_robot("delta")
    base = truth.placement(truth.q_reference, "base").inverse()  # the targets are in the robot's own base
    misses = []
    for row in rows[:5]:
        commanded = np.array([float(row[f"cmd_{c}"]) for c in "xyz"])
        assert np.all(commanded >= [-0.2, -0.2, -0.5]) and np.all(commanded <= [0.2, 0.2, -0.2])
        command = np.array([float(row[j]) for j in truth.actuated_joints])
        reached = base * truth.placement(truth.solve_fk(command), "end_effector_marker")
        assert np.linalg.norm(reached.translation - commanded) < 1e-7
        misses.append(np.linalg.norm(nominal.placement(nominal.solve_fk(command), "end_effector").translation
                                     - commanded))
    assert min(misses) > 1e-5  # the nominal robot would miss: the commands are the model's


def test_plan_holds_the_orientation_given_at_every_pose(tmp_path: Path) -> None:
    """The UR10's tool pointing down (a half turn about x): every row commands that quaternion, and the commands'
    forward kinematics turns tool0 so."""
    done = run_pincal("iso9283", "plan", "ur10", "--orientation", "0,1,0,0", "--cycles", "2", "--out", "plan.csv",
                      cwd=tmp_path)
    assert done.returncode == 0, done.stderr
    assert "orientation: (qw, qx, qy, qz) = (0, 1, 0, 0) as given" in done.stdout
    _, rows = _plan_rows(tmp_path / "plan.csv")
    robot = pincal.load_robot("ur10")
    down = _quaternion_matrix(0.0, 1.0, 0.0, 0.0)
    for row in rows[:5]:
        assert [float(row[f"cmd_q{c}"]) for c in "wxyz"] == [0.0, 1.0, 0.0, 0.0]
        placement = robot.placement(robot.solve_fk(np.array([float(row[j]) for j in robot.actuated_joints])), "tool0")
        assert np.linalg.norm(pin.log3(placement.rotation @ down.T)) < 1e-7
