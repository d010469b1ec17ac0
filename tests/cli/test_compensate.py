"""``pincal compensate`` as a user runs it: a simulated truth robot, driven with the commands computed on its
calibrated URDF, reaches the targets to the calibration's held-out accuracy, where the nominal robot's commands miss by
millimetres (Delta, UR10, hexapod); the corrections file inverted; unreachable targets listed; the targets for a nominal
controller; errors as one line."""

from __future__ import annotations

import csv
import json
import re
import shutil
from dataclasses import dataclass
from pathlib import Path

import numpy as np
import pinocchio as pin
import pytest
from conftest import run_pincal

import pincal
from pincal.io.corrections_file import corrected_readings, read_corrections
from pincal.study.simulation import random_actuated

#: robot -> what is measured and aimed at (a pose for the hexapod: six legs place the platform's orientation too).
CASES = {"delta": "position", "ur10": "position", "hexapod": "pose"}
TARGETS = 12


@dataclass(frozen=True)
class Campaign:
    """A simulated robot calibrated from the CLI, and targets drawn on its truth."""

    robot: str
    kind: str
    folder: Path
    truth: pincal.Robot
    frame: str  # the truth's frame the measurements read
    targets: Path
    values: np.ndarray  # (N, 3) or (N, 7): x, y, z [m], qx, qy, qz, qw
    held_out_rms: float  # [m]

    @property
    def calibrated(self) -> Path:
        return self.folder / "cal.urdf"


def _write_targets(path: Path, key: str, values: np.ndarray) -> None:
    components = ["x", "y", "z"] + (["qx", "qy", "qz", "qw"] if values.shape[1] == 7 else [])
    with path.open("w", newline="", encoding="utf-8") as stream:
        writer = csv.writer(stream)
        writer.writerow(["sample", *(f"{key}:{c}" for c in components)])
        writer.writerows([f"t{k}", *map(repr, row.tolist())] for k, row in enumerate(values))


def _placements(robot: pincal.Robot, q: np.ndarray, frame: str, width: int) -> np.ndarray:
    out = []
    for config in q:
        m = robot.placement(config, frame)
        out.append(np.concatenate([m.translation, pin.Quaternion(m.rotation).coeffs()])[:width])
    return np.array(out)


def _campaign(root: Path, robot: str, kind: str, *extra: str) -> Campaign:
    folder = root / robot
    done = run_pincal("simulate", robot, "--measure", kind, "--samples", "30", "--test-samples", "10", "--seed", "3",
                      "--quiet", *extra, "--out", str(folder))
    assert done.returncode == 0, done.stderr
    done = run_pincal("calibrate", robot, str(folder / "measurements.csv"), *extra, "--out",
                      str(folder / "cal.urdf"), "--report", str(folder / "report.json"))
    assert done.returncode == 0, done.stdout + done.stderr
    truth = pincal.load_robot(folder / "truth.urdf")
    end = truth.end_effector if robot != "ur10" else "tool0"
    # a position reads the point the truth's marker link holds (docs/calibrated_urdf.md); a pose reads the frame
    frame = f"{end}_marker" if kind == "position" else end
    _, q = random_actuated(truth, TARGETS, np.random.default_rng(11))
    values = _placements(truth, q, frame, 3 if kind == "position" else 7)
    targets = folder / "targets.csv"
    _write_targets(targets, f"{kind}:{end}", values)
    report = json.loads((folder / "report.json").read_text(encoding="utf-8"))
    return Campaign(robot, kind, folder, truth, frame, targets, values, report["test_rms_after"])


@pytest.fixture(scope="module")
def campaigns(tmp_path_factory: pytest.TempPathFactory) -> dict[str, Campaign]:
    root = tmp_path_factory.mktemp("compensate")
    return {robot: _campaign(root, robot, kind) for robot, kind in CASES.items()}


def _read(path: Path) -> tuple[dict[str, str], list[dict[str, str]]]:
    lines = path.read_text(encoding="utf-8").splitlines()
    metadata = dict(line[2:].split(": ", 1) for line in lines if line.startswith("# "))
    return metadata, list(csv.DictReader(line for line in lines if not line.startswith("#")))


def _commands(rows: list[dict[str, str]], joints: list[str]) -> np.ndarray:
    return np.array([[float(r[j]) if r[j] else np.nan for j in joints] for r in rows])


def _errors(truth: pincal.Robot, frame: str, commands: np.ndarray, values: np.ndarray) -> np.ndarray:
    """Distance [m] from where the truth puts ``frame`` at each command to its target (NaN without a command)."""
    out = np.full(len(commands), np.nan)
    for k, command in enumerate(commands):
        if np.all(np.isfinite(command)):
            out[k] = np.linalg.norm(truth.placement(truth.solve_fk(command), frame).translation - values[k, :3])
    return out


def _rms(errors: np.ndarray) -> float:
    return float(np.sqrt(np.nanmean(errors**2)))


@pytest.mark.parametrize("robot", list(CASES))
def test_the_truth_reaches_the_targets_with_the_compensated_commands(campaigns, robot: str, tmp_path: Path) -> None:
    c = campaigns[robot]
    out = tmp_path / "commands.csv"
    done = run_pincal("compensate", str(c.calibrated), str(c.targets), "--out", str(out))
    assert done.returncode == 0, done.stdout + done.stderr
    assert f"reached {TARGETS} of {TARGETS}" in done.stdout and done.stderr == ""
    metadata, rows = _read(out)
    assert [r["sample"] for r in rows] == [f"t{k}" for k in range(TARGETS)]
    assert {r["status"] for r in rows} == {"ok"}
    assert max(float(r["residual_position"]) for r in rows) < 1e-9
    assert ("residual_orientation" in rows[0]) == (c.kind == "pose")
    assert metadata["targets in"].startswith("the measurement frame")
    commands = _commands(rows, c.truth.actuated_joints)
    after = _errors(c.truth, c.frame, commands, c.values)
    assert _rms(after) < 3 * c.held_out_rms  # the calibration's held-out accuracy
    if c.kind == "pose":
        angles = [np.linalg.norm(pin.log3(pin.Quaternion(*np.roll(c.values[k, 3:], 1)).matrix().T
                                          @ c.truth.placement(c.truth.solve_fk(command), c.frame).rotation))
                  for k, command in enumerate(commands)]
        assert max(angles) < 1e-4  # [rad]; the truth's orientation errors are 1 mrad
    # the nominal robot's commands (no calibration) miss by millimetres
    nominal = tmp_path / "nominal.csv"
    done = run_pincal("compensate", robot, str(c.targets), "--out", str(nominal))
    assert done.returncode in (0, 1), done.stderr
    before = _errors(c.truth, c.frame, _commands(_read(nominal)[1], c.truth.actuated_joints), c.values)
    assert _rms(before) > 1e-3 and _rms(before) > 30 * _rms(after)


def test_targets_in_the_base_frame(campaigns, tmp_path: Path) -> None:
    """Targets given in the robot's own base frame, the calibrated URDF's: below its measurement frame, the UR10's root
    link 'world' placed by measurement_frame_joint (tracker data fix the robot in the tracker's frame, not where its
    base link is: that is the calibrated file's registration)."""
    c = campaigns["ur10"]
    calibrated = pincal.load_robot(c.calibrated)
    world_from_base = calibrated.placement(calibrated.q_reference, "world")
    in_base = np.array([world_from_base.actInv(p) for p in c.values])
    targets = tmp_path / "base_targets.csv"
    _write_targets(targets, "position:tool0", in_base)
    out = tmp_path / "commands.csv"
    done = run_pincal("compensate", str(c.calibrated), str(targets), "--targets-in", "base", "--out", str(out))
    assert done.returncode == 0, done.stdout + done.stderr
    metadata, rows = _read(out)
    assert metadata["targets in"] == "the robot's base frame, link 'world'"
    after = _errors(c.truth, c.frame, _commands(rows, c.truth.actuated_joints), c.values)
    assert _rms(after) < 3 * c.held_out_rms


def test_unreachable_targets_are_listed_with_their_reason(campaigns, tmp_path: Path) -> None:
    c = campaigns["delta"]
    targets = tmp_path / "targets.csv"
    far = c.values[:3].copy()
    far[1] += [2.0, 0.0, 0.0]  # two metres beside a reachable target
    _write_targets(targets, "position:end_effector", far)
    out = tmp_path / "commands.csv"
    done = run_pincal("compensate", str(c.calibrated), str(targets), "--out", str(out))
    assert done.returncode == 1, done.stdout + done.stderr
    assert "reached 2 of 3" in done.stdout and "unreachable 1 of 3" in done.stdout
    assert "  sample t1: inverse kinematics did not converge" in done.stdout
    _, rows = _read(out)
    assert [r["sample"] for r in rows] == ["t0", "t1", "t2"]
    assert rows[1]["status"].startswith("unreachable: inverse kinematics did not converge")
    assert all(rows[1][j] == "" for j in c.truth.actuated_joints) and rows[1]["residual_position"] == ""
    assert rows[0]["status"] == rows[2]["status"] == "ok"


@pytest.mark.parametrize("robot", ["delta", "hexapod"])
def test_nominal_targets_bring_a_nominal_controller_to_the_targets(campaigns, robot: str, tmp_path: Path) -> None:
    """A controller that keeps the nominal model solves its own inverse kinematics on the targets written for it; the
    truth, at those joint values, is on the real targets. The nominal model is the one MODEL records, or --nominal."""
    c = campaigns[robot]
    out = tmp_path / "nominal_targets.csv"
    given = ("--nominal", robot) if robot == "delta" else ()
    done = run_pincal("compensate", str(c.calibrated), str(c.targets), *given, "--nominal-targets", "--out", str(out))
    assert done.returncode == 0, done.stdout + done.stderr
    metadata, rows = _read(out)
    assert metadata["nominal"] == robot + ("" if given else " (recorded in MODEL)")
    key = f"{c.kind}:{c.frame.removesuffix('_marker')}"
    assert metadata["frame"] == c.frame.removesuffix("_marker")
    components = ["x", "y", "z"] + (["qx", "qy", "qz", "qw"] if c.kind == "pose" else [])
    sent = np.array([[float(r[f"{key}:{k}"]) for k in components] for r in rows])
    nominal = pincal.load_robot(robot)
    commands = []
    for target in sent:
        goal = (pin.SE3(pin.Quaternion(*np.roll(target[3:], 1)).matrix(), target[:3]) if c.kind == "pose"
                else target)
        commands.append(nominal.actuated_values(nominal.solve_ik(goal, metadata["frame"])))
    after = _errors(c.truth, c.frame, np.array(commands), c.values)
    assert _rms(after) < 3 * c.held_out_rms
    # sent unchanged, the targets would be missed by millimetres
    assert float(np.sqrt(np.mean(np.sum((sent[:, :3] - c.values[:, :3]) ** 2, axis=1)))) > 1e-3


def test_the_corrections_file_is_inverted(tmp_path: Path) -> None:
    """A UR10 whose encoders have once-per-turn errors (harmonics): the commands are raw readings, which the truth's
    own corrections turn into the joint values that reach the targets; the same URDF without its corrections file
    misses."""
    c = _campaign(tmp_path, "ur10", "position", "--parameters", "default", "*.sin1", "*.cos1")
    assert (c.folder / "cal.corrections.json").is_file()
    truth_corrections = read_corrections(c.folder / "truth.corrections.json")
    out = tmp_path / "commands.csv"
    done = run_pincal("compensate", str(c.calibrated), str(c.targets), "--out", str(out))
    assert done.returncode == 0, done.stdout + done.stderr
    assert "corrections inverted to" in done.stdout
    metadata, rows = _read(out)
    assert metadata["corrections"].startswith(str(c.folder / "cal.corrections.json"))
    raw = _commands(rows, c.truth.actuated_joints)
    after = _errors(c.truth, c.frame, corrected_readings(truth_corrections, c.truth, raw), c.values)
    assert _rms(after) < 3 * c.held_out_rms
    alone = tmp_path / "alone"
    alone.mkdir()
    shutil.copy(c.calibrated, alone / "cal.urdf")  # without its corrections file, which it names: refused
    done = run_pincal("compensate", str(alone / "cal.urdf"), str(c.targets), "--out", str(alone / "commands.csv"))
    assert done.returncode == 2 and "cal.corrections.json', which is not there" in done.stderr, done.stderr
    for command in (("check", str(alone / "cal.urdf"), str(c.folder / "measurements.csv")),
                    ("export", str(c.calibrated), "--format", "yaml", "--out", str(c.folder / "cal.corrections.json"))):
        done = run_pincal(*command)  # check refuses it too; no output replaces a model's corrections file
        assert done.returncode == 2 and done.stderr.count("\n") == 1, done.stderr
    assert read_corrections(c.folder / "cal.corrections.json").joints
    text = (alone / "cal.urdf").read_text(encoding="utf-8")  # a URDF that does not know of its corrections
    (alone / "cal.urdf").write_text(re.sub(r"\n\s*<pincal_provenance[^>]*/>", "", text), encoding="utf-8")
    done = run_pincal("compensate", str(alone / "cal.urdf"), str(c.targets), "--out", str(alone / "commands.csv"))
    assert done.returncode == 0 and "corrections: none" in done.stdout
    plain = _commands(_read(alone / "commands.csv")[1], c.truth.actuated_joints)
    missed = _errors(c.truth, c.frame, corrected_readings(truth_corrections, c.truth, plain), c.values)
    assert _rms(missed) > 10 * _rms(after)


POSITION = "sample,position:end_effector:x,position:end_effector:y,position:end_effector:z"
POSE = "sample," + ",".join(f"pose:end_effector:{c}" for c in ("x", "y", "z", "qx", "qy", "qz", "qw"))


@pytest.mark.parametrize(("text", "extra", "message"), [
    ("sample,position:end_effector:x,position:end_effector:y\nt0,0.1,0.2", (),
     "lacks the columns position:end_effector:z"),
    ("sample,arm_1_joint,position:end_effector:x,position:end_effector:y,position:end_effector:z\nt0,0,0,0,-0.4", (),
     "column 'arm_1_joint' is not a target"),
    (f"{POSITION}\nt0,0,0,-0.4", ("--nominal-targets",), "records none (no pincal provenance in it)"),
    ("sample,position:nowhere:x,position:nowhere:y,position:nowhere:z\nt0,0,0,-0.4", (),
     "frame 'nowhere' does not exist"),
    (f"{POSE}\nt0,0,0,-0.4,0,0,0,1", (), "which has 3 degrees of freedom: give position targets"),
    (f"{POSE}\nt0,0,0,-0.4,0,0,0.5,1", (), "line 2: quaternion (qx, qy, qz, qw) of norm 1.11803"),
    (f"{POSITION}\nt0,0,0,-400", (), "it looks like millimetres"),
    (f"# units: mm\n{POSITION}\nt0,0,0,-400", (), "metadata 'units: mm' names mm"),
    (f"# robot: five_bar\n{POSITION}\nt0,0,0,-0.4", (), "says the data are of robot 'five_bar', not of 'delta'"),
])
def test_bad_input_is_one_line_and_exit_2(tmp_path: Path, text: str, extra: tuple[str, ...], message: str) -> None:
    targets = tmp_path / "targets.csv"
    targets.write_text(text + "\n", encoding="utf-8")
    done = run_pincal("compensate", "delta", str(targets), *extra, "--out", str(tmp_path / "out.csv"))
    assert done.returncode == 2 and done.stdout == ""
    assert done.stderr.startswith("pincal: error: ") and done.stderr.count("\n") == 1, done.stderr
    assert message in done.stderr
    assert not (tmp_path / "out.csv").exists()


def test_a_report_json_is_not_a_model_to_command(tmp_path: Path) -> None:
    report = tmp_path / "r.json"
    report.write_text("{}", encoding="utf-8")
    targets = tmp_path / "targets.csv"
    targets.write_text(f"{POSITION}\nt0,0,0,-0.4\n", encoding="utf-8")
    done = run_pincal("compensate", str(report), str(targets), "--out", str(tmp_path / "out.csv"))
    assert done.returncode == 2 and done.stderr.count("\n") == 1
    assert "compensate takes the calibrated URDF" in done.stderr


@pytest.mark.parametrize(("name", "text", "words"), [
    ("job.toml", 'robot = "delta"\n\n[data]\nfile = "m.csv"\n', "a job file (TOML)"),
    ("r.json", '{"parameters": {}}\n', "a JSON file"),
    ("cal.urdf", '<?xml version="1.0"?>\n<robot name="delta">\n</robot>\n', "a URDF"),
])
def test_targets_of_the_wrong_kind_are_named_in_one_line(tmp_path: Path, name: str, text: str, words: str) -> None:
    """A job file, a report or a URDF given as TARGETS is named for what it is, not parsed as a CSV whose cells do not
    match its header."""
    given = tmp_path / name
    given.write_text(text, encoding="utf-8")
    done = run_pincal("compensate", "delta", str(given), "--out", str(tmp_path / "out.csv"))
    assert done.returncode == 2 and done.stderr.count("\n") == 1, done.stderr
    assert f"TARGETS '{given}' is {words}" in done.stderr and "where a targets CSV was expected" in done.stderr


def test_the_output_never_overwrites_an_input(tmp_path: Path) -> None:
    targets = tmp_path / "targets.csv"
    targets.write_text("sample,position:end_effector:x,position:end_effector:y,position:end_effector:z\n"
                       "t0,0.0,0.0,-0.4\n", encoding="utf-8")
    before = targets.read_bytes()
    done = run_pincal("compensate", "delta", str(targets), "--out", str(targets))
    assert done.returncode == 2 and "is the input file" in done.stderr
    assert targets.read_bytes() == before


def test_the_tiago_reaches_its_measured_points_within_its_limits(tmp_path: Path) -> None:
    """Real data (examples/data, docs/results/tiago_mocap.md): the calibrated TIAGo, eight joints for a point, reaches
    every measured marker position with commands within its URDF limits (the torso's 0–0.35 m among them)."""
    from conftest import ROOT

    from pincal.io.dataset_reader import read_dataset

    data = ROOT / "examples" / "data" / "tiago_mocap_marker1.csv"
    done = run_pincal("calibrate", "tiago_no_hand", str(data), "--out", str(tmp_path / "cal.urdf"))
    assert done.returncode == 0, done.stdout + done.stderr
    points = read_dataset(data).measurements["position:wrist_ft_tool_link"]
    targets = tmp_path / "targets.csv"
    _write_targets(targets, "position:wrist_ft_tool_link", points)
    out = tmp_path / "commands.csv"
    done = run_pincal("compensate", str(tmp_path / "cal.urdf"), str(targets), "--out", str(out))
    assert done.returncode == 0, done.stdout + done.stderr
    metadata, rows = _read(out)
    assert metadata["frame"] == "wrist_ft_tool_link_marker" and {r["status"] for r in rows} == {"ok"}
    robot = pincal.load_robot(tmp_path / "cal.urdf")
    commands = _commands(rows, robot.actuated_joints)
    lower = np.array([robot.model.lowerPositionLimit[a.idx_q] if a.nq == 1 else -np.inf
                      for a in robot.kinematics.actuated])
    upper = np.array([robot.model.upperPositionLimit[a.idx_q] if a.nq == 1 else np.inf
                      for a in robot.kinematics.actuated])
    assert np.all(commands >= lower - 1e-9) and np.all(commands <= upper + 1e-9)
    reference = robot.actuated_values(robot.q_reference)  # the head and wheels cannot move the hand: left there
    idle = [k for k, name in enumerate(robot.actuated_joints) if name.startswith(("head_", "wheel_"))]
    assert len(idle) == 4 and np.all(commands[:, idle] == reference[idle])
    reached = _errors(robot, "wrist_ft_tool_link_marker", commands, points)
    assert reached.max() < 1e-9
