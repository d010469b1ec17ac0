"""The calibrated URDF ``pincal calibrate`` writes, proved by reloading it: plain Pinocchio reads it back (yourdfpy
too in ``pincal export``) and is compared with the calibrated model at some fitted postures and some random ones;
the bound is printed and in the file's header comment, a URDF off by a micrometre is caught."""

from __future__ import annotations

import re
from pathlib import Path

import numpy as np
import pytest
from conftest import run_pincal

from pincal.calibration.export_proof import bound, calibrated_proof, with_comment
from pincal.errors import PincalError
from pincal.model.catalog import robot_path
from pincal.model.robot import robot_from_urdf_text

LINE = ("the calibrated URDF reloaded by plain Pinocchio: within 1e-12 m, 1e-12 rad of the calibrated model at "
        "20 postures")


@pytest.fixture(scope="module")
def data(tmp_path_factory: pytest.TempPathFactory) -> Path:
    folder = tmp_path_factory.mktemp("ur10_calibrated_proof")
    assert run_pincal("simulate", "ur10", "--measure", "position", "--samples", "30", "--seed", "3", "--quiet",
                      "--out", str(folder)).returncode == 0
    return folder / "measurements.csv"


def test_calibrate_prints_the_proof_and_writes_it_in_the_header(data: Path, tmp_path: Path) -> None:
    out = tmp_path / "cal.urdf"
    done = run_pincal("calibrate", "ur10", str(data), "--out", str(out))
    assert done.returncode == 0, done.stderr
    assert LINE in done.stdout.splitlines()
    lines = out.read_text(encoding="utf-8").splitlines()
    assert lines[0].startswith("<?xml") and lines[1].startswith("<!-- calibrated by pincal from 30 samples")
    assert lines[2] == f"<!-- {LINE} -->"


def test_calibrate_refuses_a_urdf_a_reader_reads_off(data: Path, tmp_path: Path, monkeypatch: pytest.MonkeyPatch,
                                                    capsys: pytest.CaptureFixture[str]) -> None:
    """A reader 2 µm off (as if the writer had slipped): one line naming it, exit 2, nothing written."""
    from pincal.calibration import export_proof
    from pincal.cli.app import main

    off = [export_proof.Deviation("Pinocchio", 0.0, 0.0), export_proof.Deviation("yourdfpy", 2e-6, 0.0)]
    monkeypatch.setattr(export_proof, "urdf_deviations", lambda *_, **__: off)
    out, report = tmp_path / "cal.urdf", tmp_path / "report.json"
    assert main(["calibrate", "ur10", str(data), "--out", str(out), "--report", str(report)]) == 2
    error = capsys.readouterr().err.strip()
    assert error == ("pincal: error: calibrate: yourdfpy reads the calibrated URDF 2e-06 m, 0 rad away from the "
                     "calibrated model (tolerance 1e-09): not written")
    assert not out.exists() and not report.exists()


def _moved(text: str, joint: str, dz: float) -> str:
    """``text`` with ``joint``'s origin z moved by ``dz`` [m]."""
    start = text.index(f'<joint name="{joint}"')
    found = re.compile(r'xyz="([^"]*)"').search(text, start)
    assert found is not None
    x, y, z = (float(v) for v in found.group(1).split())
    return text[:found.start(1)] + f"{x!r} {y!r} {z + dz!r}" + text[found.end(1):]


@pytest.mark.parametrize("name, joint", [("ur10", "elbow_joint"), ("delta", None), ("hexapod", None),
                                        ("panda", None)])  # panda: its fingers <mimic> one another
def test_a_urdf_moved_by_a_micrometre_is_refused(name: str, joint: str | None) -> None:
    text = Path(robot_path(name)).read_text(encoding="utf-8")
    robot = robot_from_urdf_text(text)
    readings = np.zeros((0, len(robot.actuated_joints)))  # no fitted postures: the 10 random ones
    assert calibrated_proof(text, robot, list(robot.actuated_joints), readings) == LINE.replace("20", "10")
    joint = joint or next(j for j in re.findall(r'<joint name="([^"]+)"', text)
                          if re.search(rf'<joint name="{j}"[^>]*>\s*(?:<[^>]*>\s*)*?<origin[^>]*xyz=', text))
    with pytest.raises(PincalError, match=r"^calibrate: (Pinocchio|yourdfpy) reads the calibrated URDF 1e-06 m"):
        calibrated_proof(_moved(text, joint, 1e-6), robot, list(robot.actuated_joints), readings)


def test_the_bound_does_not_depend_on_round_off() -> None:
    assert [bound(v) for v in (0.0, 2.2e-16, 1e-12, 3e-12, 1e-11, 4.4e-10)] == [
        "1e-12", "1e-12", "1e-12", "1e-11", "1e-11", "1e-09"]


def test_the_comment_goes_after_the_declaration_and_the_note() -> None:
    text = '<?xml version="1.0"?>\n<!-- note -->\n<robot name="r"/>\n'
    assert with_comment(text, "proof") == '<?xml version="1.0"?>\n<!-- note -->\n<!-- proof -->\n<robot name="r"/>\n'
    assert with_comment('<robot name="r"/>\n', "proof") == '<!-- proof -->\n<robot name="r"/>\n'
