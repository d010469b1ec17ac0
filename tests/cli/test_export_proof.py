"""Every ``pincal export`` proved by reloading it: the URDF by plain Pinocchio and yourdfpy, the per-joint YAML
composed back into joint origins, a DH table read back into forward kinematics; each against the model at the
calibration data's postures and random ones, the deviation printed and in the file's header, an export off by more
than the tolerance refused; a file changed by a micrometre is caught."""

from __future__ import annotations

import re
from pathlib import Path

import pytest
from conftest import run_pincal

import pincal
from pincal.calibration.export_proof import dh_deviation, proof_postures, yaml_deviation

PROOF = re.compile(r"proved by reloading, against the model at the (\d+) postures of the calibration data and 100 "
                   r"random ones within the joint limits \(seed 0\): (.*)")


@pytest.fixture(scope="module")
def calibrated(tmp_path_factory: pytest.TempPathFactory) -> Path:
    folder = tmp_path_factory.mktemp("ur10_proof")
    assert run_pincal("simulate", "ur10", "--measure", "position", "--samples", "30", "--seed", "3", "--quiet",
                      "--out", str(folder)).returncode == 0
    assert run_pincal("calibrate", "ur10", str(folder / "measurements.csv"), "--out",
                      str(folder / "cal.urdf")).returncode == 0
    return folder / "cal.urdf"


@pytest.mark.parametrize("fmt", ["yaml", "dh", "mdh"])
def test_each_export_is_reloaded_and_its_deviation_printed(calibrated: Path, tmp_path: Path, fmt: str) -> None:
    out = tmp_path / f"{fmt}.yaml"
    done = run_pincal("export", str(calibrated), "--format", fmt, "--out", str(out))
    assert done.returncode == 0, done.stderr
    found = PROOF.search(done.stdout)
    assert found is not None and found.group(1) == "30"
    readers = dict(re.findall(r"([^:;]+): ([0-9.e+-]+) m", found.group(2)))
    assert {r.strip() for r in readers} == {"Pinocchio", "yourdfpy", (
        "the YAML composed into joint origins, by Pinocchio" if fmt == "yaml" else
        f"the {fmt} table read back, as forward kinematics")}
    assert all(float(v) <= 1e-9 for v in readers.values())
    assert "# " + found.group(0) in out.read_text(encoding="utf-8").splitlines()


def test_an_export_beyond_the_tolerance_is_refused(calibrated: Path, tmp_path: Path) -> None:
    out = tmp_path / "k.yaml"
    done = run_pincal("export", str(calibrated), "--format", "yaml", "--tolerance", "1e-30", "--out", str(out))
    assert done.returncode == 2 and "not written" in done.stderr and " reads the yaml export " in done.stderr
    assert done.stderr.count("\n") == 1 and not out.exists()


def test_a_file_changed_by_a_micrometre_is_caught(calibrated: Path, tmp_path: Path) -> None:
    robot = pincal.load_robot(calibrated)
    postures = proof_postures(robot, calibrated, 5)
    text = calibrated.read_text(encoding="utf-8")
    for fmt in ("yaml", "dh"):
        out = tmp_path / f"{fmt}.yaml"
        assert run_pincal("export", str(calibrated), "--format", fmt, "--out", str(out)).returncode == 0
        written = out.read_text(encoding="utf-8")
        key = "    z: " if fmt == "yaml" else "d: "
        at = written.index(key, written.index("elbow_joint")) + len(key)
        end = min(i for i in (written.find(c, at) for c in ",\n}") if i > 0)
        changed = written[:at] + repr(float(written[at:end]) + 1e-6) + written[end:]
        deviation = (yaml_deviation(changed, text, robot, postures) if fmt == "yaml"
                     else dh_deviation(changed, robot, postures))
        assert 1e-7 < deviation.position < 1e-5
        same = (yaml_deviation(written, text, robot, postures) if fmt == "yaml"
                else dh_deviation(written, robot, postures))
        assert same.position <= 1e-9


UR_CHAIN = """<robot name="ur_description_chain">
  <link name="base_link_inertia"/>{links}
  <link name="flange"/><link name="tool0"/>{joints}
  <joint name="wrist_3-flange" type="fixed"><parent link="wrist_3_link"/><child link="flange"/>
    <origin xyz="0 0 0" rpy="0 -1.5707963267948966 -1.5707963267948966"/></joint>
  <joint name="flange-tool0" type="fixed"><parent link="flange"/><child link="tool0"/>
    <origin xyz="0 0 0" rpy="1.5707963267948966 0 1.5707963267948966"/></joint>
</robot>"""
UR_LINKS = ["shoulder_link", "upper_arm_link", "forearm_link", "wrist_1_link", "wrist_2_link", "wrist_3_link"]
UR_JOINTS = ["shoulder_pan_joint", "shoulder_lift_joint", "elbow_joint", "wrist_1_joint", "wrist_2_joint",
             "wrist_3_joint"]


def _ur_description_chain(kinematics: dict[str, dict[str, float]]) -> pincal.Robot:
    """The arm as ur_description's macro builds it from a kinematics file: each joint's origin its entry, axis z."""
    keys = ["shoulder", "upper_arm", "forearm", "wrist_1", "wrist_2", "wrist_3"]
    parents = ["base_link_inertia", *UR_LINKS[:-1]]
    joints = "".join(
        f'\n  <joint name="{name}" type="revolute"><parent link="{parent}"/><child link="{child}"/>'
        f'<origin xyz="{e["x"]!r} {e["y"]!r} {e["z"]!r}" rpy="{e["roll"]!r} {e["pitch"]!r} {e["yaw"]!r}"/>'
        '<axis xyz="0 0 1"/><limit lower="-6.3" upper="6.3" effort="1" velocity="1"/></joint>'
        for name, parent, child, e in zip(UR_JOINTS, parents, UR_LINKS, (kinematics[k] for k in keys), strict=True))
    links = "".join(f'\n  <link name="{name}"/>' for name in UR_LINKS)
    from pincal.model.robot import robot_from_urdf_text

    return robot_from_urdf_text(UR_CHAIN.format(links=links, joints=joints))


@pytest.mark.parametrize("measured", ["position", "pose"])
def test_ur_kinematics_compose_in_ur_descriptions_chain(calibrated: Path, tmp_path: Path, measured: str) -> None:
    """Calibrated from points, the tool frame is not corrected; from poses it is, and the export names the TCP."""
    import numpy as np
    import pinocchio as pin
    import yaml

    if measured == "pose":
        assert run_pincal("simulate", "ur10", "--measure", "pose", "--samples", "30", "--seed", "1", "--quiet",
                          "--out", str(tmp_path)).returncode == 0
        calibrated = tmp_path / "cal.urdf"
        assert run_pincal("calibrate", "ur10", str(tmp_path / "measurements.csv"), "--out",
                          str(calibrated)).returncode == 0
    out = tmp_path / "kinematics.yaml"
    done = run_pincal("export", str(calibrated), "--format", "ur", "--out", str(out))
    assert done.returncode == 0, done.stderr
    assert "ur_description's chain composed from the YAML, with the TCP: " in done.stdout
    text = out.read_text(encoding="utf-8")
    kinematics = yaml.safe_load(text)["kinematics"]
    assert list(kinematics) == ["shoulder", "upper_arm", "forearm", "wrist_1", "wrist_2", "wrist_3", "hash"]
    assert kinematics["hash"].startswith("pincal_")
    tcp_lines = [line for line in text.splitlines() if "set it as the TCP" in line]
    assert len(tcp_lines) == (measured == "pose") and ("set the TCP" in done.stdout) == (measured == "pose")
    values = [float(v) for v in tcp_lines[0].split("p[")[1].rstrip("]").split(",")] if tcp_lines else [0.0] * 6
    tcp = pin.SE3(pin.exp3(np.array(values[3:])), np.array(values[:3]))
    chain, cal = _ur_description_chain(kinematics), pincal.load_robot(calibrated)
    rng = np.random.default_rng(5)
    for q in rng.uniform(-3, 3, size=(20, 6)):
        expected = cal.placement(q, "base").inverse() * cal.placement(q, "tool0")
        got = chain.placement(q, "base_link_inertia").inverse() * chain.placement(q, "tool0") * tcp
        assert np.linalg.norm(got.translation - expected.translation) < 2e-9  # the TCP written to 1e-9
        assert np.linalg.norm(pin.log3(got.rotation.T @ expected.rotation)) < 2e-9


def test_ur_kinematics_of_the_nominal_ur10_are_urs_published_ones(tmp_path: Path) -> None:
    import yaml

    out = tmp_path / "nominal.yaml"
    done = run_pincal("export", "ur10", "--format", "ur", "--out", str(out))
    assert done.returncode == 0, done.stderr
    assert "set it as the TCP" not in out.read_text(encoding="utf-8")
    got = yaml.safe_load(out.read_text(encoding="utf-8"))["kinematics"]
    published = {("shoulder", "z"): 0.1273, ("forearm", "x"): -0.612, ("wrist_1", "x"): -0.5723,
                 ("wrist_1", "z"): 0.163941, ("wrist_2", "y"): -0.1157, ("wrist_3", "y"): 0.0922,
                 ("upper_arm", "roll"): 1.5707963267948966, ("wrist_2", "roll"): 1.5707963267948966}
    for (key, field), value in published.items():
        assert got[key][field] == pytest.approx(value, abs=1e-9)
    done = run_pincal("export", "panda", "--format", "ur", "--out", str(tmp_path / "p.yaml"))
    assert done.returncode == 2 and "not a Universal Robots arm" in done.stderr and done.stderr.count("\n") == 1


def test_hayati_rows_keep_a_calibrated_ur10s_table_within_its_size(calibrated: Path, tmp_path: Path) -> None:
    """The classic table of the calibrated UR10 has d values of hundreds of metres for its nearly parallel axes;
    ``--format hayati`` writes those rows in Hayati's form: every length within the arm's size, the table exact."""
    import numpy as np
    import pinocchio as pin
    import yaml

    tables = {}
    for fmt in ("dh", "hayati"):
        out = tmp_path / f"{fmt}.yaml"
        done = run_pincal("export", str(calibrated), "--format", fmt, "--out", str(out))
        assert done.returncode == 0, done.stderr
        tables[fmt] = yaml.safe_load(out.read_text(encoding="utf-8"))
        text = out.read_text(encoding="utf-8")
    assert max(abs(row["d"]) for row in tables["dh"]["joints"]) > 50  # the absurd classic table
    rows = tables["hayati"]["joints"]
    assert max(max(abs(row["d"]), abs(row["a"])) for row in rows) < 1.0
    swapped = [row["name"] for row in rows if row["beta"] != 0.0]
    assert swapped == ["shoulder_lift_joint", "elbow_joint"] and all(row["d"] == 0.0 for row in rows
                                                                    if row["beta"] != 0.0)
    assert sum("in Hayati's form (beta about y, d = 0), chosen because its classic d" in line
               for line in text.splitlines()) == 2

    def se3(f: dict[str, float]) -> pin.SE3:
        return pin.SE3(pin.rpy.rpyToMatrix(f["roll"], f["pitch"], f["yaw"]), np.array([f["x"], f["y"], f["z"]]))

    def rot(axis: str, angle: float) -> pin.SE3:
        return pin.SE3(pin.utils.rotate(axis, angle), np.zeros(3))

    robot = pincal.load_robot(calibrated)
    table = tables["hayati"]
    for q in np.random.default_rng(2).uniform(-3, 3, size=(10, 6)):  # A_i = Rz Tz Tx Rx Ry, as the header says
        m = se3(table["base"])
        for row, value in zip(rows, q, strict=True):
            m = (m * rot("z", row["theta"] + value) * pin.SE3(np.eye(3), np.array([row["a"], 0, row["d"]]))
                 * rot("x", row["alpha"]) * rot("y", row["beta"]))
        m = m * se3(table["tool"])
        expected = robot.placement(q, table["base_frame"]).inverse() * robot.placement(q, table["end_frame"])
        assert np.linalg.norm(m.translation - expected.translation) < 1e-9
