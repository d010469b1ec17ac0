"""The mesh names of a written URDF (pincal.io.mesh_files): ``keep`` leaves ``package://`` names as they are and
makes relative ones relative to the output; ``copy`` copies every mesh beside the output; no absolute path either
way."""

from __future__ import annotations

import xml.etree.ElementTree as ET
from pathlib import Path

import pytest

from pincal.errors import NotFoundError, RobotFileError
from pincal.io.mesh_files import mesh_folder, plan_meshes

MESHES = ["../meshes/a.stl", "package://my_robot/meshes/a.stl", "package://other/b.stl", "file:///abs/c.stl"]


def _urdf(meshes: list[str]) -> str:
    visuals = "".join(f"<visual><geometry><mesh filename='{m}'/></geometry></visual>" for m in meshes)
    return f"<robot name='r'><link name='a'>{visuals}</link></robot>"


@pytest.fixture
def workspace(tmp_path: Path, monkeypatch: pytest.MonkeyPatch) -> Path:
    """A ROS package ``my_robot`` (package.xml, urdf/, meshes/a.stl) and a package ``other`` on ROS_PACKAGE_PATH."""
    package = tmp_path / "ws" / "my_robot"
    (package / "urdf").mkdir(parents=True)
    (package / "meshes").mkdir()
    (package / "package.xml").write_text("<package format='3'><name>my_robot</name></package>\n")
    (package / "meshes" / "a.stl").write_bytes(b"solid a\nendsolid a\n")
    (tmp_path / "ros" / "other").mkdir(parents=True)
    (tmp_path / "ros" / "other" / "b.stl").write_bytes(b"solid b\x00\xff\nendsolid b\n")
    monkeypatch.setenv("ROS_PACKAGE_PATH", str(tmp_path / "ros"))
    return package / "urdf"


def _names(text: str) -> list[str]:
    return [m.get("filename", "") for m in ET.fromstring(text).iter("mesh")]


def test_keep_rewrites_relative_names_only(workspace: Path, tmp_path: Path) -> None:
    source = _urdf(MESHES)
    out = tmp_path / "elsewhere" / "deep" / "cal.urdf"
    plan = plan_meshes(source, workspace, out, "keep")
    assert _names(plan.text(source)) == ["../../ws/my_robot/meshes/a.stl", *MESHES[1:]]
    assert (out.parent / "../../ws/my_robot/meshes/a.stl").resolve() == (workspace / "../meshes/a.stl").resolve()
    assert plan.copies == () and plan.files() == []
    assert plan_meshes(source, workspace, workspace / "cal.urdf", "keep").filenames == {}  # beside the source
    assert plan_meshes(source, None, out, "keep").filenames == {}  # a URDF given as text: nothing to be relative to


def test_copy_copies_every_mesh_beside_the_output(workspace: Path, tmp_path: Path) -> None:
    source = _urdf(MESHES[:3])
    out = tmp_path / "out" / "cal.urdf"
    plan = plan_meshes(source, workspace, out, "copy")
    names = _names(plan.text(source))
    assert len(set(names)) == 2  # two names of one file: one copy
    assert all(n.startswith("cal_meshes/") for n in names)
    files = dict(plan.files())
    assert sorted(files.values()) == sorted([b"solid a\nendsolid a\n", b"solid b\x00\xff\nendsolid b\n"])
    assert all(path.parent.is_relative_to(mesh_folder(out).resolve()) for path in files)
    assert {(out.parent / n).resolve() for n in names} == {p.resolve() for p in files}


def test_copy_refuses_a_mesh_found_nowhere(workspace: Path, tmp_path: Path) -> None:
    with pytest.raises(NotFoundError, match=r"mesh 'package://gone/c.stl' is not found on this machine \(and 1 more: "
                                            r"file:///abs/c.stl\)"):
        plan_meshes(_urdf([*MESHES[:2], "package://gone/c.stl", MESHES[3]]), workspace, tmp_path / "c.urdf", "copy")


def test_a_mesh_replaced_after_the_plan_is_refused_when_copied(workspace: Path, tmp_path: Path) -> None:
    """The copy reads the very file the plan checked: one replaced since (here by a link to a file outside the
    package, as a swap during a long calibration would) is refused, not copied."""
    plan = plan_meshes(_urdf(MESHES[:1]), workspace, tmp_path / "out" / "cal.urdf", "copy")
    mesh = (workspace.parent / "meshes" / "a.stl").resolve()
    assert [content for _, content in plan.files()] == [b"solid a\nendsolid a\n"]
    (tmp_path / "secret.stl").write_bytes(b"solid secret\nendsolid secret\n")
    mesh.unlink()
    mesh.symlink_to(tmp_path / "secret.stl")
    with pytest.raises(RobotFileError, match=f"link 'a' mesh '../meshes/a.stl': '{mesh}' was replaced by a symbolic "
                                             "link since it was checked; nothing written"):
        plan.files()
    mesh.unlink()
    mesh.write_bytes(b"solid a\nendsolid a\n")  # another file of the same name and content: not the one checked
    with pytest.raises(RobotFileError, match="was replaced or changed since it was checked; nothing written"):
        plan.files()
