"""The calibrated-URDF writer: new origins land exactly, and everything else in the file survives."""

from __future__ import annotations

import math
import xml.etree.ElementTree as ET
from pathlib import Path

import numpy as np
import pinocchio as pin
import pytest
from conftest import ROOT
from hypothesis import given, settings
from hypothesis import strategies as st

import pincal
from pincal.errors import RobotFileError
from pincal.model.urdf import read_extensions
from pincal.model.urdf_writer import (
    SENSOR_COMMENT,
    FixedLink,
    calibrated_urdf_text,
    format_float,
    origin_attributes,
    write_calibrated_urdf,
)

DELTA = ROOT / "robots_urdf" / "delta.urdf"
NEW_JOINT = pin.SE3(pin.rpy.rpyToMatrix(0.01, -0.02, 0.03), np.array([0.1951, -0.0007, 0.0012]))
NEW_ANCHOR = pin.SE3(pin.rpy.rpyToMatrix(-0.3, 0.2, 1.1), np.array([0.0003, -0.0002, -0.4812]))


def _gap(a: pin.SE3, b: pin.SE3) -> float:
    return float(np.max(np.abs(a.homogeneous - b.homogeneous)))


def _placements(model: pin.Model) -> dict[str, pin.SE3]:
    out = {f"joint {model.names[j]}": model.jointPlacements[j] for j in range(1, model.njoints)}
    out.update({f"frame {f.name}": f.placement for f in model.frames})
    return out


@pytest.fixture(scope="module")
def written(tmp_path_factory: pytest.TempPathFactory) -> Path:
    path = tmp_path_factory.mktemp("urdf") / "delta_calibrated.urdf"
    write_calibrated_urdf(DELTA.read_text(), path, {"arm_1_joint": NEW_JOINT},
                          {("leg_1_platform", "predecessor"): NEW_ANCHOR}, header_note="calibrated by pincal (test)")
    return path


def test_joint_origin_is_written_exactly(written: Path) -> None:
    model = pin.buildModelFromUrdf(str(written))
    before = pin.buildModelFromUrdf(str(DELTA))
    assert _gap(model.jointPlacements[model.getJointId("arm_1_joint")], NEW_JOINT) <= 1e-15
    for name in ("arm_2_joint", "rod_1_pitch", "platform_x"):
        j = model.getJointId(name)
        assert _gap(model.jointPlacements[j], before.jointPlacements[j]) == 0.0


def test_loops_and_transmissions_survive_with_the_new_anchor(written: Path) -> None:
    ext = read_extensions(written.read_text())
    original = read_extensions(DELTA.read_text())
    assert [loop.name for loop in ext.loops] == ["leg_1_platform", "leg_2_platform", "leg_3_platform"]
    assert ext.transmitted_joints == ["arm_1_joint", "arm_2_joint", "arm_3_joint"]
    assert _gap(ext.loops[0].predecessor_origin, NEW_ANCHOR) <= 1e-15
    assert _gap(ext.loops[0].successor_origin, original.loops[0].successor_origin) == 0.0
    assert _gap(ext.loops[1].predecessor_origin, original.loops[1].predecessor_origin) == 0.0


def test_comments_and_visuals_survive(written: Path) -> None:
    source, text = DELTA.read_text(), written.read_text()
    comment = source[source.index("<!--"):source.index("-->") + 3]
    assert comment in text
    assert text.startswith('<?xml version="1.0"?>\n<!-- calibrated by pincal (test) -->\n<!--\npincal reference')
    root, original = ET.fromstring(text), ET.fromstring(source)
    for tag in ("link/visual", "link/visual/geometry/*", "link/inertial", "loop[2]", "loop[3]",
                "loop[1]/successor", "transmission", "transmission/actuator"):
        kept = [ET.tostring(e) for e in original.findall(tag)]
        assert kept and [ET.tostring(e) for e in root.findall(tag)] == kept, tag
    # Only the two edited lines and the note differ.
    changed = [line for line in text.splitlines() if line not in source.splitlines()]
    assert len(changed) == 3 and "arm_1_joint" in changed[1] and "leg_1_platform" in changed[2]


def test_unchanged_write_loads_to_the_same_robot(tmp_path: Path) -> None:
    path = tmp_path / "delta.urdf"
    write_calibrated_urdf(DELTA.read_text(), path, {}, {}, header_note="unchanged")
    before, after = _placements(pin.buildModelFromUrdf(str(DELTA))), _placements(pin.buildModelFromUrdf(str(path)))
    assert list(before) == list(after)
    assert max(_gap(before[k], after[k]) for k in before) <= 1e-15
    robot = pincal.load_robot(path)
    assert robot.actuated_joints == ["arm_1_joint", "arm_2_joint", "arm_3_joint"]
    assert calibrated_urdf_text(DELTA.read_text(), {}, {}) == DELTA.read_text()


def test_formatting_namespaces_and_missing_origin() -> None:
    source = ("<robot name='r' xmlns:xacro=\"http://www.ros.org/wiki/xacro\">\n"
              "  <!-- keep me -->\n"
              "  <link name='a'/>\n  <link name='b'/>\n  <link name='c'/>\n"
              "  <joint name='j1' type='revolute'>\n    <parent link='a'/>\n    <child link='b'/>\n"
              "    <origin rpy='0 0 0' xyz='1 2 3' />\n    <axis xyz='0 0 1'/>\n  </joint>\n"
              "  <joint name='j2' type='fixed'>\n    <parent link='b'/>\n    <child link='c'/>\n  </joint>\n"
              "  <joint name='j3' type='fixed'><parent link='b'/><origin xyz='0 0 1'></origin></joint>\n"
              "</robot>\n")
    m = pin.SE3(np.eye(3), np.array([0.5, -0.0, 0.25]))
    text = calibrated_urdf_text(source, {"j1": m, "j2": m, "j3": m}, {})
    assert "<origin rpy=\"0.0 0.0 0.0\" xyz=\"0.5 0.0 0.25\" />" in text  # attribute order and spacing kept
    assert "<joint name='j2' type='fixed'>\n    <origin xyz=\"0.5 0.0 0.25\" rpy=\"0.0 0.0 0.0\"/>\n" \
           "    <parent link='b'/>" in text  # created, indented like its siblings
    assert "<origin xyz=\"0.5 0.0 0.25\" rpy=\"0.0 0.0 0.0\"></origin>" in text  # rpy added
    assert text.startswith("<robot name='r' xmlns:xacro=\"http://www.ros.org/wiki/xacro\">\n  <!-- keep me -->")
    assert text.replace(" rpy=\"0.0 0.0 0.0\"", "").count("0.5 0.0 0.25") == 3
    noted = calibrated_urdf_text(source, {}, {}, header_note="note")
    assert noted == "<!-- note -->\n" + source


def test_unknown_names_are_refused() -> None:
    source = DELTA.read_text()
    with pytest.raises(RobotFileError, match=r"joints arm_4_joint are not in the URDF; joints are: arm_1_joint,"):
        calibrated_urdf_text(source, {"arm_4_joint": NEW_JOINT}, {})
    with pytest.raises(RobotFileError, match=r"loops leg_4_platform \(successor\) are not in the URDF; loops are: "
                                             r"leg_1_platform, leg_2_platform, leg_3_platform"):
        calibrated_urdf_text(source, {}, {("leg_4_platform", "successor"): NEW_ANCHOR})
    with pytest.raises(RobotFileError, match=r"roles middle are not valid; roles are: predecessor, successor"):
        calibrated_urdf_text(source, {}, {("leg_1_platform", "middle"): NEW_ANCHOR})
    with pytest.raises(RobotFileError, match="root element is <sdf>"):
        calibrated_urdf_text("<sdf/>", {}, {})
    with pytest.raises(ValueError, match="cannot be an XML comment"):
        calibrated_urdf_text(source, {}, {}, header_note="a -- b")


def test_format_float() -> None:
    assert format_float(-0.0) == "0.0"
    assert format_float(np.float64(0.1)) == "0.1"
    assert float(format_float(1 / 3)) == 1 / 3


_ANGLE = st.floats(-math.pi, math.pi)
_NEAR_LOCK = st.tuples(_ANGLE, st.sampled_from([-1.0, 1.0]), st.sampled_from([0.0, 1e-17, 1e-12, 1e-8, 1e-5]),
                       _ANGLE).map(lambda t: (t[0], t[1] * (math.pi / 2 - t[2]), t[3]))


@settings(max_examples=60, deadline=None)
@given(xyz=st.tuples(*[st.floats(-2.0, 2.0)] * 3),
       rotation=st.one_of(st.tuples(*[st.floats(-1.0, 1.0)] * 4).filter(lambda q: sum(v * v for v in q) > 1e-3),
                          _NEAR_LOCK))
def test_any_placement_round_trips(xyz: tuple[float, float, float], rotation: tuple[float, ...]) -> None:
    if len(rotation) == 4:
        R = pin.Quaternion(np.array(rotation) / np.linalg.norm(rotation)).toRotationMatrix()
    else:
        R = pin.rpy.rpyToMatrix(*rotation)
    m = pin.SE3(R, np.array(xyz))
    text = calibrated_urdf_text(DELTA.read_text(), {"rod_2_pitch": m}, {("leg_3_platform", "successor"): m})
    model = pin.buildModelFromXML(text)
    assert _gap(model.jointPlacements[model.getJointId("rod_2_pitch")], m) <= 1e-12
    assert _gap(read_extensions(text).loops[2].successor_origin, m) <= 1e-12


_SMALL = ("<?xml version='1.0'?>\n<robot name='r'>\n  <material name='grey'><color rgba='.5 .5 .5 1'/></material>\n"
          "  <link name='a'><visual><geometry><mesh filename='package://p/a.stl'/></geometry></visual></link>\n"
          "  <link name='b'>\n    <collision><geometry><mesh filename=\"m/b &amp; c.stl\" scale='1 1 1'/></geometry>"
          "</collision>\n  </link>\n"
          "  <joint name='j' type='revolute'><parent link='a'/><child link='b'/><axis xyz='0 0 1'/>"
          "<limit lower='-1' upper='1' effort='1' velocity='1'/></joint>\n"
          "</robot>\n")


def test_new_root_and_child_links_are_inserted_and_nothing_else_changes() -> None:
    m = pin.SE3(pin.rpy.rpyToMatrix(0.1, -0.2, 0.3), np.array([1.0, -2.0, 0.5]))
    links = [FixedLink("tracker_joint", "tracker", "a", m, comment="the tracker"),
             FixedLink("b_marker_joint", "b", "b_marker", pin.SE3(np.eye(3), np.array([0.0, 0.0, 0.01])))]
    text = calibrated_urdf_text(_SMALL, {}, {}, fixed_links=links, sensor_zeros={"j": -0.25})
    xyz, rpy = origin_attributes(m)
    added = ["  <!-- the tracker -->", '  <link name="tracker"/>',
             f'  <joint name="tracker_joint" type="fixed"><parent link="tracker"/><child link="a"/>'
             f'<origin xyz="{xyz}" rpy="{rpy}"/></joint>',
             '  <link name="b_marker"/>',
             '  <joint name="b_marker_joint" type="fixed"><parent link="b"/><child link="b_marker"/>'
             '<origin xyz="0.0 0.0 0.01" rpy="0.0 0.0 0.0"/></joint>',
             f"  <!-- {SENSOR_COMMENT} -->", '  <joint_sensor joint="j" zero="-0.25"/>']
    lines = text.splitlines()
    assert [line for line in lines if line not in _SMALL.splitlines()] == added
    assert [line for line in lines if line not in added] == _SMALL.splitlines()
    assert lines.index(added[1]) < lines.index("  <link name='a'><visual><geometry><mesh "
                                               "filename='package://p/a.stl'/></geometry></visual></link>")
    model = pin.buildModelFromXML(text)
    data = model.createData()
    pin.framesForwardKinematics(model, data, pin.neutral(model))
    assert _gap(data.oMf[model.getFrameId("a")], m) <= 1e-15  # the new root is the world frame
    marker = data.oMf[model.getFrameId("b_marker")].translation
    np.testing.assert_allclose(marker, m.act(np.array([0.0, 0.0, 0.01])), atol=1e-15)
    again = calibrated_urdf_text(text, {}, {}, sensor_zeros={"j": 0.5})
    assert again == text.replace('zero="-0.25"', 'zero="0.5"')  # an existing sensor element gets the new value


def test_one_line_files_get_inline_elements() -> None:
    source = "<robot name='r'><link name='a'/><link name='b'/><joint name='j' type='fixed'><parent link='a'/>" \
             "<child link='b'/></joint></robot>"
    text = calibrated_urdf_text(source, {}, {}, fixed_links=[FixedLink("w_j", "w", "a", pin.SE3.Identity())])
    assert text.startswith("<robot name='r'><link name=\"w\"/> <joint name=\"w_j\" type=\"fixed\">")
    assert text.count("\n") == 0 and pin.buildModelFromXML(text).frames[1].name == "w"


def test_mesh_file_names_are_rewritten_with_quoting() -> None:
    text = calibrated_urdf_text(_SMALL, {}, {}, mesh_filenames={"package://p/a.stl": "file:///x/a.stl",
                                                                "m/b & c.stl": "file:///y/b & \"c\".stl"})
    assert '<mesh filename="file:///x/a.stl"/>' in text
    assert '<mesh filename="file:///y/b &amp; &quot;c&quot;.stl" scale=\'1 1 1\'/>' in text
    names = [e.get("filename") for e in ET.fromstring(text).iter("mesh")]
    assert names == ["file:///x/a.stl", 'file:///y/b & "c".stl']
    with pytest.raises(RobotFileError, match=r"mesh files package://p/z.stl are not in the URDF; meshes are: "
                                             r"m/b & c.stl, package://p/a.stl"):
        calibrated_urdf_text(_SMALL, {}, {}, mesh_filenames={"package://p/z.stl": "x"})


def test_bad_new_elements_are_refused() -> None:
    one = pin.SE3.Identity()
    with pytest.raises(RobotFileError, match=r"cannot give link 'b' the new parent 'w': it already has parent joint "
                                             r"'j'; only the root link \(a\) can"):
        calibrated_urdf_text(_SMALL, {}, {}, fixed_links=[FixedLink("w_j", "w", "b", one)])
    with pytest.raises(RobotFileError, match="exactly one of the two links must be new, both exist"):
        calibrated_urdf_text(_SMALL, {}, {}, fixed_links=[FixedLink("w_j", "a", "b", one)])
    with pytest.raises(RobotFileError, match="exactly one of the two links must be new, neither exists"):
        calibrated_urdf_text(_SMALL, {}, {}, fixed_links=[FixedLink("w_j", "v", "w", one)])
    with pytest.raises(RobotFileError, match="cannot add joint 'j': the URDF already has a joint of that name"):
        calibrated_urdf_text(_SMALL, {}, {}, fixed_links=[FixedLink("j", "b", "c", one)])
    with pytest.raises(RobotFileError, match="cannot add link 'c' twice"):
        calibrated_urdf_text(_SMALL, {}, {}, fixed_links=[FixedLink("j1", "b", "c", one),
                                                          FixedLink("j2", "a", "c", one)])
    with pytest.raises(RobotFileError, match="cannot add a second new root 'v': a URDF has one root"):
        calibrated_urdf_text(_SMALL, {}, {}, fixed_links=[FixedLink("w_j", "w", "a", one),
                                                          FixedLink("v_j", "v", "a", one)])
    with pytest.raises(RobotFileError, match="joint sensor of joint 'k': no such joint; joints are: j"):
        calibrated_urdf_text(_SMALL, {}, {}, sensor_zeros={"k": 0.0})
    with pytest.raises(ValueError, match="cannot be an XML comment"):
        calibrated_urdf_text(_SMALL, {}, {}, fixed_links=[FixedLink("w_j", "w", "a", one, comment="a -- b")])
