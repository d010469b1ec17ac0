"""Portable outputs through the command line: the calibrated URDF's mesh names (``--meshes keep|copy``) and
``pincal export`` (per-joint YAML, DH and modified-DH tables), on a simulated UR10, the TIAGo mocap data and the
Delta. Expected values come from the files themselves (XML parsed here), plain Pinocchio, DH products written here
and UR's published DH parameters — never from the code under test."""

from __future__ import annotations

import json
import math
import xml.etree.ElementTree as ET
from pathlib import Path

import numpy as np
import pinocchio as pin
import pytest
import yaml
from conftest import ROOT, run_pincal

import pincal
from pincal.model.catalog import robot_path
from pincal.viz.visuals import robot_visuals

TIAGO_DATA = ROOT / "examples" / "data" / "tiago_mocap_marker1.csv"
#: UR10's DH parameters as Universal Robots publish them: d1, a2, a3, d4, d5, d6 [m].
UR10_DH = {"d1": 0.1273, "a2": 0.612, "a3": 0.5723, "d4": 0.163941, "d5": 0.1157, "d6": 0.0922}


@pytest.fixture(scope="module")
def ur10(tmp_path_factory: pytest.TempPathFactory) -> dict[str, Path]:
    """A simulated UR10 (40 postures, seed 2) calibrated twice: meshes kept (``cal.urdf``) and copied
    (``copied/calc.urdf``). Read-only for the tests."""
    root = tmp_path_factory.mktemp("ur10")
    done = run_pincal("simulate", "ur10", "--samples", "40", "--seed", "2", "--quiet", "--out", str(root / "sim"))
    assert done.returncode == 0, done.stderr
    data = root / "sim" / "measurements.csv"
    for out, extra in ((root / "cal.urdf", []), (root / "copied" / "calc.urdf", ["--meshes", "copy"])):
        done = run_pincal("calibrate", "ur10", str(data), "--out", str(out), *extra)
        assert done.returncode in (0, 1), done.stderr
    return {"root": root, "data": data, "cal": root / "cal.urdf", "copied": root / "copied" / "calc.urdf"}


def _mesh_names(path: Path) -> list[str]:
    return [m.get("filename", "") for m in ET.parse(path).getroot().iter("mesh")]


def _package_file(name: str) -> Path:
    """``package://example-robot-data/<rest>``: the installed example-robot-data share folder holds ``robots/``."""
    share = robot_path("ur10").parents[3]  # .../example-robot-data/robots/ur_description/urdf/ur10_robot.urdf
    assert share.name == "example-robot-data"
    return share / name.removeprefix("package://example-robot-data/")


def _all_meshes_drawn(path: Path) -> None:
    """pincal's 3D scene finds every visual mesh of the file (no size limit here)."""
    visuals, notes = robot_visuals(pincal.load_robot(path), max_mesh_bytes=10**9)
    assert notes == []
    assert len(visuals) == len(ET.parse(path).getroot().findall("link/visual"))


def test_the_calibrated_urdf_keeps_the_package_meshes(ur10: dict[str, Path]) -> None:
    text = ur10["cal"].read_text()
    source = _mesh_names(robot_path("ur10"))
    assert _mesh_names(ur10["cal"]) == source
    assert len(source) == 14 and all(n.startswith("package://example-robot-data/") for n in source)
    assert _mesh_names(ur10["root"] / "sim" / "truth.urdf") == source  # pincal simulate writes by the same rule
    for machine_path in ("file://", str(robot_path("ur10").parents[3]), str(ur10["root"])):
        assert machine_path not in text
    _all_meshes_drawn(ur10["cal"])  # the package resolves from any folder (example-robot-data is installed)


def test_meshes_copy_writes_them_beside_the_urdf(ur10: dict[str, Path]) -> None:
    names = _mesh_names(ur10["copied"])
    assert len(names) == 14 and all(n.startswith("calc_meshes/") for n in names)
    for copied, original in zip(names, _mesh_names(robot_path("ur10")), strict=True):
        assert (ur10["copied"].parent / copied).read_bytes() == _package_file(original).read_bytes()
    assert "file://" not in ur10["copied"].read_text()
    _all_meshes_drawn(ur10["copied"])


def test_a_recalibration_elsewhere_keeps_relative_meshes_reachable(ur10: dict[str, Path]) -> None:
    """The copied file as the input of a calibration written to another folder: its relative mesh names are made
    relative to the new file, and reach the same copies."""
    out = ur10["root"] / "again" / "cal2.urdf"
    done = run_pincal("calibrate", str(ur10["copied"]), str(ur10["data"]), "--out", str(out))
    assert done.returncode in (0, 1), done.stderr
    names = _mesh_names(out)
    assert all(n.startswith("../copied/calc_meshes/") for n in names)
    assert [(out.parent / n).resolve() for n in names] == \
        [(ur10["copied"].parent / n).resolve() for n in _mesh_names(ur10["copied"])]


def test_meshes_copy_refuses_a_mesh_found_nowhere(tmp_path: Path) -> None:
    robot = tmp_path / "arm.urdf"
    robot.write_text(
        "<robot name='arm'><link name='base'><visual><geometry><mesh filename='package://nowhere/base.stl'/>"
        "</geometry></visual></link><link name='tool'/><joint name='j' type='revolute'><parent link='base'/>"
        "<child link='tool'/><origin xyz='0 0 0.3'/><axis xyz='0 1 0'/>"
        "<limit lower='-1' upper='1' effort='1' velocity='1'/></joint></robot>")
    done = run_pincal("simulate", str(robot), "--out", str(tmp_path / "sim"), "--meshes", "copy", "--quiet")
    assert done.returncode == 2
    assert done.stderr.splitlines() == [done.stderr.strip()]
    assert done.stderr.startswith("pincal: error: --meshes copy: mesh 'package://nowhere/base.stl' is not found")
    assert not (tmp_path / "sim").exists()


def _origin(node: ET.Element | None) -> list[float]:
    if node is None:
        return [0.0] * 6
    return [float(v) for v in node.get("xyz", "0 0 0").split()] + [float(v) for v in node.get("rpy", "0 0 0").split()]


def test_yaml_export_holds_every_joint_origin(ur10: dict[str, Path], tmp_path: Path) -> None:
    out = tmp_path / "kinematics.yaml"
    done = run_pincal("export", str(ur10["cal"]), "--format", "yaml", "--out", str(out))
    assert done.returncode == 0, done.stderr
    written = yaml.safe_load(out.read_text())["kinematics"]
    joints = ET.parse(ur10["cal"]).getroot().findall("joint")
    assert list(written) == [j.get("name") for j in joints]
    for joint in joints:
        entry = written[joint.get("name")]
        assert [entry[k] for k in ("x", "y", "z", "roll", "pitch", "yaw")] == _origin(joint.find("origin"))
        assert (entry["parent"], entry["child"], entry["type"]) == \
            (joint.find("parent").get("link"), joint.find("child").get("link"), joint.get("type"))
    assert written["measurement_frame_joint"]["parent"] == "measurement_frame"


def test_yaml_export_of_a_closed_loop_robot_holds_its_loops(tmp_path: Path) -> None:
    out = tmp_path / "delta.yaml"
    assert run_pincal("export", "delta", "--out", str(out)).returncode == 0
    written = yaml.safe_load(out.read_text())
    tree = ET.parse(robot_path("delta")).getroot()
    assert len(written["kinematics"]) == len(tree.findall("joint"))
    for loop in tree.findall("loop"):
        for role in ("predecessor", "successor"):
            entry = written["loops"][loop.get("name")][role]
            assert entry["link"] == loop.find(role).get("link")
            assert [entry[k] for k in ("x", "y", "z", "roll", "pitch", "yaw")] == _origin(loop.find(f"{role}/origin"))


def _placement(fields: dict[str, float]) -> np.ndarray:
    out = np.eye(4)
    out[:3, :3] = pin.rpy.rpyToMatrix(fields["roll"], fields["pitch"], fields["yaw"])
    out[:3, 3] = [fields["x"], fields["y"], fields["z"]]
    return out


def _rot(axis: str, angle: float) -> np.ndarray:
    c, s = math.cos(angle), math.sin(angle)
    out = np.eye(4)
    i, j = (1, 2) if axis == "x" else (0, 1)
    out[i, i], out[i, j], out[j, i], out[j, j] = c, -s, s, c
    return out


def _shift(axis: str, length: float) -> np.ndarray:
    out = np.eye(4)
    out["xyz".index(axis), 3] = length
    return out


def _table_fk(table: dict, q: np.ndarray) -> np.ndarray:
    """The DH product, as the textbooks write it (Denavit–Hartenberg 1955; Craig, Introduction to Robotics)."""
    out = _placement(table["base"])
    for row, value in zip(table["joints"], q, strict=True):
        theta = row["theta"] + (value if row["type"] == "revolute" else 0.0)
        d = row["d"] + (value if row["type"] == "prismatic" else 0.0)
        if table["convention"] == "dh":
            out = out @ _rot("z", theta) @ _shift("z", d) @ _shift("x", row["a"]) @ _rot("x", row["alpha"])
        else:
            out = out @ _rot("x", row["alpha"]) @ _shift("x", row["a"]) @ _rot("z", theta) @ _shift("z", d)
    return out @ _placement(table["tool"])


def _check_table(urdf: Path, table: dict, samples: int = 30) -> float:
    """Largest gap [m] between the table and plain Pinocchio on ``urdf`` (the table's chain, random postures within
    the limits); orientations to 1e-9 rad."""
    model = pin.buildModelFromUrdf(str(urdf))
    data = model.createData()
    rng = np.random.default_rng(7)
    base, end = model.getFrameId(table["base_frame"]), model.getFrameId(table["end_frame"])
    names = [row["name"] for row in table["joints"]]
    worst = 0.0
    for _ in range(samples):
        q = pin.neutral(model)
        values = []
        for name in names:
            jm = model.joints[model.getJointId(name)]
            values.append(rng.uniform(max(model.lowerPositionLimit[jm.idx_q], -3.0),
                                      min(model.upperPositionLimit[jm.idx_q], 3.0)))
            q[jm.idx_q] = values[-1]
        pin.framesForwardKinematics(model, data, q)
        expected = (data.oMf[base].inverse() * data.oMf[end]).homogeneous
        got = _table_fk(table, np.array(values))
        worst = max(worst, float(np.linalg.norm(got[:3, 3] - expected[:3, 3])))
        assert np.linalg.norm(pin.log3(got[:3, :3].T @ expected[:3, :3])) < 1e-9
    return worst


@pytest.mark.parametrize("convention", ["dh", "mdh"])
def test_dh_table_of_the_calibrated_ur10(ur10: dict[str, Path], tmp_path: Path, convention: str) -> None:
    out = tmp_path / f"{convention}.yaml"
    done = run_pincal("export", str(ur10["cal"]), "--format", convention, "--out", str(out))
    assert done.returncode == 0, done.stderr
    table = yaml.safe_load(out.read_text())
    assert (table["convention"], table["base_frame"], table["end_frame"]) == (convention, "world", "tool0")
    assert [row["name"] for row in table["joints"]] == ["shoulder_pan_joint", "shoulder_lift_joint", "elbow_joint",
                                                        "wrist_1_joint", "wrist_2_joint", "wrist_3_joint"]
    stated = table["residual"]
    assert stated["postures"] == 100 and stated["position"] <= 1e-6 and stated["orientation"] <= 1e-6
    assert f"{stated['position']:.3g} m" in done.stdout
    assert _check_table(ur10["cal"], table) <= max(stated["position"], 1e-12) * 10
    assert "from parallel" in done.stdout  # the calibrated shoulder, elbow and wrist axes are no longer parallel


def test_dh_table_of_the_nominal_ur10_is_the_published_one(tmp_path: Path) -> None:
    out = tmp_path / "dh.yaml"
    assert run_pincal("export", "ur10", "--format", "dh", "--out", str(out)).returncode == 0
    table = yaml.safe_load(out.read_text())
    rows = table["joints"]
    got = {"d1": rows[0]["d"], "a2": rows[1]["a"], "a3": rows[2]["a"], "d4": rows[3]["d"], "d5": rows[4]["d"],
           "d6": rows[5]["d"]}
    assert {k: abs(v) for k, v in got.items()} == pytest.approx(UR10_DH, abs=1e-9)
    assert [abs(r["alpha"]) for r in rows] == pytest.approx([math.pi / 2, 0, 0, math.pi / 2, math.pi / 2, 0], abs=1e-9)
    assert _check_table(robot_path("ur10"), table) < 1e-12


def test_tiago_calibrated_from_its_mocap_data(tmp_path: Path) -> None:
    """The TIAGo example: the calibrated URDF names its meshes as example-robot-data does, and its arm (torso lift,
    prismatic, and 7 revolute joints) exports as a modified DH table that reproduces it."""
    cal = tmp_path / "tiago.urdf"
    done = run_pincal("calibrate", "tiago_no_hand", str(TIAGO_DATA), "--out", str(cal))
    assert done.returncode == 0, done.stderr
    assert _mesh_names(cal) == _mesh_names(robot_path("tiago_no_hand"))
    assert "file://" not in cal.read_text()
    out = tmp_path / "mdh.yaml"
    done = run_pincal("export", str(cal), "--format", "mdh", "--out", str(out))
    assert done.returncode == 0, done.stderr
    table = yaml.safe_load(out.read_text())
    assert table["base_frame"] == "base_footprint"  # the robot's root below the measurement frame
    assert [r["type"] for r in table["joints"]] == ["prismatic"] + ["revolute"] * 7
    assert _check_table(cal, table) <= max(table["residual"]["position"], 1e-12) * 10


def test_the_parser_spells_the_library_choices() -> None:
    from pincal.cli import arguments, export_formats
    from pincal.io import export as library
    from pincal.io.mesh_files import MESH_MODES

    assert arguments.MESH_MODES == MESH_MODES
    assert (export_formats.FORMATS, export_formats.DEFAULT_TOLERANCE, export_formats.DEFAULT_POSTURES) == \
        (library.FORMATS, library.TOLERANCE, library.POSTURES)


@pytest.mark.parametrize(("args", "message"), [
    (["delta", "--format", "dh"], "robot 'delta' has closed loops"),
    (["ur10", "--format", "mdh", "--tolerance", "1e-30"], "misses the URDF by"),
    (["ur10", "--format", "dh", "--frame", "nowhere"], "frame 'nowhere' does not exist"),
    (["ur10", "--format", "dh", "--base", "tool0", "--frame", "base_link"], "'tool0' is not on the path"),
])
def test_export_refusals_are_one_line(tmp_path: Path, args: list[str], message: str) -> None:
    out = tmp_path / "x.yaml"
    done = run_pincal("export", *args, "--out", str(out))
    assert done.returncode == 2
    assert done.stderr.startswith("pincal: error: ") and message in done.stderr
    assert len(done.stderr.strip().splitlines()) == 1
    assert not out.exists()


#: Names that would end a ``#`` comment or a line of YAML (a line feed, a carriage return, YAML 1.1's next line, a
#: Unicode line separator), each followed by what would become a key of its own.
HOSTILE = ["yaw\ninjected_key: 666", "shoulder\rcr_key: 7", "elbow\x85nel_key: 8", "wrist\u2028ls_key: 9"]
HOSTILE_ROBOT, HOSTILE_TOOL = "arm\nrobot_key: 1", "tool\ntool_key: 3"


def _hostile_arm() -> str:
    """A four-joint arm whose robot, joints and end link are named with :data:`HOSTILE` names (XML escapes)."""
    robot = ET.Element("robot", name=HOSTILE_ROBOT)
    links = ["base", "l1", "l2", "l3", "l4", HOSTILE_TOOL]
    for link in links:
        ET.SubElement(robot, "link", name=link)
    for k, name in enumerate(HOSTILE):
        joint = ET.SubElement(robot, "joint", name=name, type="revolute")
        ET.SubElement(joint, "parent", link=links[k])
        ET.SubElement(joint, "child", link=links[k + 1])
        ET.SubElement(joint, "origin", xyz=f"0 0 {0.1 + 0.1 * k}", rpy=f"{0.3 * k} 0 0")
        ET.SubElement(joint, "axis", xyz="0 0 1" if k % 2 == 0 else "0 1 0")
        ET.SubElement(joint, "limit", lower="-2", upper="2", effort="1", velocity="1")
    flange = ET.SubElement(robot, "joint", name="flange", type="fixed")
    ET.SubElement(flange, "parent", link="l4")
    ET.SubElement(flange, "child", link=HOSTILE_TOOL)
    ET.SubElement(flange, "origin", xyz="0.2 0 0")
    return ET.tostring(robot, encoding="unicode")


@pytest.mark.parametrize("convention", ["yaml", "dh", "mdh"])
def test_no_name_can_add_a_key_to_an_export(tmp_path: Path, convention: str) -> None:
    """A line break in the robot's, a joint's or a frame's name stays inside its comment or its quoted string: the
    file parsed by yaml.safe_load has exactly the export's keys, the names exactly as the URDF has them."""
    urdf = tmp_path / "arm.urdf"
    urdf.write_text(_hostile_arm(), encoding="utf-8")
    out = tmp_path / f"{convention}.yaml"
    done = run_pincal("export", str(urdf), "--format", convention, "--out", str(out))
    assert done.returncode == 0, done.stderr
    written = yaml.safe_load(out.read_text(encoding="utf-8"))
    if convention == "yaml":
        assert list(written) == ["kinematics"]
        assert list(written["kinematics"]) == [*HOSTILE, "flange"]
        assert written["kinematics"]["flange"]["child"] == HOSTILE_TOOL
    else:
        assert list(written) == ["convention", "base_frame", "end_frame", "base", "joints", "tool", "residual"]
        assert [row["name"] for row in written["joints"]] == HOSTILE
        assert (written["base_frame"], written["end_frame"]) == ("base", HOSTILE_TOOL)
        assert len(done.stdout.splitlines()) == 2 + 1 + len(HOSTILE) + 1  # a line per joint; the reloads' line


def test_info_shows_each_name_on_its_own_line(tmp_path: Path) -> None:
    """``pincal info`` printed a line break inside a joint's name as it is, breaking its table; each name with a
    control character is now quoted with its escapes, as the exports quote it."""
    urdf = tmp_path / "arm.urdf"
    urdf.write_text(_hostile_arm(), encoding="utf-8")
    done = run_pincal("info", str(urdf))
    assert done.returncode == 0, done.stderr
    lines = done.stdout.splitlines()
    assert lines[0] == f"robot: {json.dumps(HOSTILE_ROBOT)}  ({urdf})"
    assert lines[2] == "joints (4 movable):" and lines[7] == "loops (0):"
    for k, name in enumerate(HOSTILE):
        assert lines[3 + k].startswith(f"  {json.dumps(name)} ") and lines[3 + k].endswith("nq=1  actuated")
    assert lines[8] == f"actuated joints (4): {', '.join(json.dumps(name) for name in HOSTILE)}"
    keys = {"injected_key", "cr_key", "nel_key", "ls_key", "robot_key", "tool_key"}  # the names' second halves
    assert not [line for line in lines if line.partition(":")[0] in keys]
