"""Robots by name: every name ``pincal robots`` lists loads, simulates and calibrates; what a file says that pincal
ignores is said (``pincal info``)."""

from __future__ import annotations

import subprocess
import sys
from pathlib import Path

import numpy as np
import pinocchio as pin
import pytest
from conftest import run_pincal

import pincal
from pincal.calibration.campaign import simulate
from pincal.calibration.pipeline import calibrate
from pincal.model.catalog import EXAMPLE_ROBOT_DATA, example_robot_data_dir, known_robot_names


def _measured_frame(robot: pincal.Robot) -> str:
    """The default measured frame, else the moving end with the longest chain of joints above it."""
    choice = robot.measured_frame_choice
    if choice.frame is not None:
        return choice.frame
    model = robot.model
    return max(choice.candidates, key=lambda f: len(model.supports[model.frames[model.getFrameId(f)].parentJoint]))


def test_every_known_robot_loads_simulates_and_calibrates() -> None:
    """One process for every name, 30 postures each (≈ 30 s: 69 robots)."""
    names = known_robot_names()
    assert {"talos", "kinova", "pr2", "romeo", "baxter", "tiago_pro", "delta", "hexapod"} <= set(names)
    for name in names:
        robot = pincal.load_robot(name)
        sim = simulate(robot, ["position"], 30, 0, frame=_measured_frame(robot), seed=0)
        report = calibrate(robot, sim.dataset).report
        assert report.converged, name
        assert report.rms_before is not None and report.rms_after is not None
        # [m]: a tenth of the start, or down to the noise (σ 1e-5 m), on all but solo8 (0.13 of its start: the evidence
        # holds its placements' translations at the smallest factor, which its 30 postures do not see through)
        assert report.rms_after < max((0.2 if name == "solo8" else 0.1) * report.rms_before, 5e-5), name


def test_every_example_robot_data_file_named_is_there() -> None:
    root = example_robot_data_dir()
    assert root is not None
    assert all((root / file).is_file() for file in EXAMPLE_ROBOT_DATA.values())
    assert "iiwa" not in known_robot_names()  # example-robot-data ships no iiwa.urdf


def test_example_robot_data_s_files_are_the_distribution_s_record_without_its_metadata_parser(tmp_path: Path) -> None:
    import importlib.metadata

    from pincal.model.catalog import _installed_files

    listed = importlib.metadata.files("example-robot-data") or []
    assert _installed_files("example-robot-data") == [Path(str(f.locate())) for f in listed]
    assert _installed_files("no-such-distribution-here") == []
    done = subprocess.run([sys.executable, "-c", "import sys, pincal; pincal.load_robot('ur10'); "
                           "print(sorted({'importlib.metadata', 'email'} & set(sys.modules)))"],
                          capture_output=True, text=True, check=False, cwd=tmp_path)  # the installed pincal
    assert done.returncode == 0, done.stderr
    assert done.stdout.strip() == "[]"


def test_a_transmission_on_a_fixed_or_missing_joint_is_ignored_with_a_note() -> None:
    kinova = pincal.load_robot("kinova")
    assert kinova.n_actuated == 6
    assert any("'j2s6s200_joint_finger_1' of type 'fixed': ignored" in note for note in kinova.notes)
    arm = pincal.load_robot("talos_arm")
    assert any("names joint 'arm_left_1_joint', which does not exist: ignored" in note for note in arm.notes)
    done = run_pincal("info", "kinova")
    assert done.returncode == 0, done.stderr
    assert "note: transmission 'j2s6s200_joint_finger_1_trans' names joint 'j2s6s200_joint_finger_1' of type " \
           "'fixed': ignored" in done.stdout


def test_pincal_robots_lists_the_names_with_their_joints_and_files() -> None:
    done = run_pincal("robots")
    assert done.returncode == 0, done.stderr
    rows = {line.split()[0]: line.split() for line in done.stdout.splitlines() if line.startswith("  ")}
    assert set(known_robot_names()) <= set(rows)
    talos = pin.buildModelFromXML(pincal.robot_path("talos").read_text())  # every joint free: 44, of which 12 mimic
    assert rows["talos"][1:5] == [str(talos.njoints - 1), "32", "0", "example-robot-data:"]
    assert rows["talos"][5] == "talos_data/robots/talos_full_v2.urdf"
    assert rows["delta"][1:5] == ["12", "3", "3", "robots_urdf/delta.urdf"]


@pytest.mark.parametrize(("name", "frame"), [("kinova", "j2s6s200_end_effector"), ("romeo", "LWristYawLink")])
def test_robots_of_example_robot_data_calibrate_through_the_cli(tmp_path: pytest.TempPathFactory, name: str,
                                                                 frame: str) -> None:
    sim = tmp_path / "sim"  # type: ignore[operator]
    done = run_pincal("simulate", name, "--samples", "30", "--test-samples", "10", "--frame", frame, "--seed", "3",
                      "--quiet", "--out", str(sim))
    assert done.returncode == 0, done.stderr
    done = run_pincal("calibrate", name, str(sim / "measurements.csv"), "--out", str(sim / "cal.urdf"))
    assert done.returncode == 0, done.stderr
    held_out = next(line for line in done.stdout.splitlines() if line.startswith("RMS position error (held out)"))
    before, after = (float(v) for v in held_out.split()[-4::2])
    assert after < 0.1 * before  # [mm]
    assert np.isfinite(before)


def test_an_installed_version_is_importlib_metadata_s_without_its_metadata_parser(tmp_path: Path) -> None:
    """The version a report and a calibrated URDF record is the distribution's, read without the e-mail parser."""
    import importlib.metadata

    from pincal.model.catalog import installed_version

    for distribution in ("pincal", "numpy", "pin", "example-robot-data"):
        assert installed_version(distribution) == importlib.metadata.version(distribution)
    with pytest.raises(importlib.metadata.PackageNotFoundError):
        installed_version("no-such-distribution-here")
    done = subprocess.run([sys.executable, "-c", "import sys; from pincal.calibration.provenance import version; "
                           "print(version(), sorted({'importlib.metadata', 'email'} & set(sys.modules)))"],
                          capture_output=True, text=True, check=False, cwd=tmp_path)  # the installed pincal
    assert done.returncode == 0, done.stderr
    assert done.stdout.strip() == f"{importlib.metadata.version('pincal')} []"


def test_the_shipped_robots_are_the_urdf_files_of_the_package_s_robots_folder() -> None:
    import importlib.resources

    from pincal.model.catalog import shipped_robots

    files = importlib.resources.files("pincal.robots_urdf")
    listed = sorted(Path(str(p)).name for p in files.iterdir() if str(p).endswith(".urdf"))
    assert sorted(p.name for p in shipped_robots().values()) == listed
    assert {"delta", "hexapod", "five_bar"} <= set(shipped_robots())
    assert all(p.is_file() for p in shipped_robots().values())


def test_example_robot_data_s_folder_is_found_from_the_first_robot_file_its_record_lists() -> None:
    """The ``robots/`` folder is the one above the first URDF of the distribution's file list, read only that far."""
    from pincal.model.catalog import _installed_files

    first = next(f for f in _installed_files("example-robot-data")
                 if "example-robot-data" in f.parts and "robots" in f.parts and f.suffix == ".urdf")
    assert example_robot_data_dir() == Path(*first.parts[: first.parts.index("robots") + 1])
    assert (example_robot_data_dir() / EXAMPLE_ROBOT_DATA["ur10"]).is_file()
