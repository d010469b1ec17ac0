"""``pincal calibrate ROBOT.urdf DATA --out o/cal.urdf --meshes copy`` copies the robot's own meshes and nothing else.

The robot is a ROS package ``my_robot`` (package.xml; urdf/arm.urdf; meshes/base.stl named ``package://my_robot/...``,
meshes/upper.dae named ``../meshes/upper.dae``, urdf/parts/fore.obj named ``parts/fore.obj``). A URDF that also names a
file outside the package (``/etc/passwd``, ``file:///etc/hostname``, a ``../`` escape, a link out of the package, a
``package://`` name climbing out) or a file of the package that is not a mesh is refused in one line naming the link,
the mesh and the path reached, exit 2, and nothing is written: ``o/`` is not even created.
"""

from __future__ import annotations

import os
import xml.etree.ElementTree as ET
from pathlib import Path

import pytest
from conftest import LIGHT_ARM_URDF, run_pincal

#: An ASCII STL, a Collada file and a Wavefront OBJ of one triangle, as a CAD tool writes them.
STL = b"solid base\n facet normal 0 0 1\n  outer loop\n   vertex 0 0 0\n   vertex 1 0 0\n   vertex 0 1 0\n  endloop\n" \
      b" endfacet\nendsolid base\n"
DAE = b'<?xml version="1.0" encoding="utf-8"?>\n<COLLADA xmlns="http://www.collada.org/2005/11/COLLADASchema" ' \
      b'version="1.4.1"><asset/></COLLADA>\n'
OBJ = b"# one triangle\no fore\nv 0 0 0\nv 1 0 0\nv 0 1 0\nf 1 2 3\n"
#: The meshes of the robot's own links: mesh name -> (the file, relative to the package; its bytes).
OWN = {"package://my_robot/meshes/base.stl": ("meshes/base.stl", STL),
       "../meshes/upper.dae": ("meshes/upper.dae", DAE),
       "parts/fore.obj": ("urdf/parts/fore.obj", OBJ)}
BASE, UPPER, FORE = OWN


def _with_meshes(meshes: dict[str, str]) -> str:
    """The light arm (tests/conftest.py) with a visual mesh on each link named: link -> mesh file name."""
    tree = ET.fromstring(LIGHT_ARM_URDF)
    for link in tree.findall("link"):
        if link.get("name") in meshes:
            ET.SubElement(ET.SubElement(ET.SubElement(link, "visual"), "geometry"), "mesh",
                          filename=meshes[link.get("name", "")])
    return ET.tostring(tree, encoding="unicode")


@pytest.fixture(scope="module")
def package(tmp_path_factory: pytest.TempPathFactory) -> dict[str, Path]:
    """The package, a file outside it that looks like a mesh (outside/secret.stl), and 30 postures of the arm
    (``pincal simulate``). Read-only for the tests."""
    root = tmp_path_factory.mktemp("meshes")
    package = root / "ws" / "my_robot"
    for relative, content in OWN.values():
        (package / relative).parent.mkdir(parents=True, exist_ok=True)
        (package / relative).write_bytes(content)
    (package / "package.xml").write_text("<package format='3'><name>my_robot</name></package>\n")
    (root / "outside").mkdir()
    (root / "outside" / "secret.stl").write_bytes(b"solid secret\nendsolid secret\n")
    (package / "meshes" / "notes.txt").write_text("not a mesh\n")
    (package / "meshes" / "fake.stl").write_text("user=root password=hunter2\n")
    os.symlink("/etc/shadow", package / "meshes" / "shadow.stl")
    os.mkfifo(package / "meshes" / "fifo.stl")  # opened for reading, it would block
    os.symlink(root / "outside" / "secret.stl", package / "meshes" / "secret.stl")
    urdf = package / "urdf" / "arm.urdf"
    urdf.write_text(_with_meshes({"base": BASE, "upper": UPPER, "fore": FORE}))
    done = run_pincal("simulate", str(urdf), "--samples", "30", "--seed", "1", "--quiet", "--out", str(root / "sim"))
    assert done.returncode == 0, done.stderr
    return {"root": root, "urdf": urdf, "data": root / "sim" / "measurements.csv"}


#: What a URDF's ``hand`` link names besides the robot's own meshes -> the path it reaches (``{root}``: the test's
#: folder), which the one line names, and why it is refused.
OUTSIDE = ", outside {root}/ws/my_robot/ (the robot's own folder tree)"
ATTACKS = {
    "/etc/passwd": ("/etc/passwd", OUTSIDE),
    "file:///etc/hostname": ("/etc/hostname", OUTSIDE),
    "../" * 40 + "etc/passwd": ("/etc/passwd", OUTSIDE),
    "../meshes/shadow.stl": ("/etc/shadow", " through a symbolic link" + OUTSIDE),
    "../meshes/secret.stl": ("{root}/outside/secret.stl", " through a symbolic link" + OUTSIDE),
    "package://my_robot/../../outside/secret.stl": ("{root}/outside/secret.stl", ", outside {root}/ws/my_robot/ "
                                                    "(the robot's own folder tree)"),
    "../meshes/notes.txt": ("{root}/ws/my_robot/meshes/notes.txt", ", not a mesh file (formats: STL, DAE, OBJ, "
                                                                     "PLY, GLB, GLTF, MESH)"),
    "../meshes/fake.stl": ("{root}/ws/my_robot/meshes/fake.stl", ", whose content is not STL"),
    "/dev/zero": ("/dev/zero", OUTSIDE),
    "/dev/null": ("/dev/null", OUTSIDE),
    "../meshes": ("{root}/ws/my_robot/meshes", ", which is a folder, not a regular mesh file"),
    "../meshes/fifo.stl": ("{root}/ws/my_robot/meshes/fifo.stl", ", which is a FIFO, not a regular mesh file"),
    "package://my_robot/meshes/fifo.stl": ("{root}/ws/my_robot/meshes/fifo.stl",
                                           ", which is a FIFO, not a regular mesh file"),
}


@pytest.mark.parametrize("mesh", list(ATTACKS), ids=["absolute", "file-uri", "dot-dot", "link-to-shadow", "link-out",
                                                     "package-climbing-out", "not-a-mesh", "not-an-stl", "dev-zero",
                                                     "dev-null", "folder", "fifo", "package-fifo"])
def test_meshes_copy_refuses_a_file_that_is_not_the_robots_own_mesh(package: dict[str, Path], mesh: str) -> None:
    urdf = package["urdf"].with_name("attack.urdf")
    urdf.write_text(_with_meshes({"base": BASE, "upper": UPPER, "hand": mesh}))
    out = package["root"] / "o"
    done = run_pincal("calibrate", str(urdf), str(package["data"]), "--out", str(out / "cal.urdf"), "--meshes",
                      "copy")
    assert done.returncode == 2, done.stdout + done.stderr
    reached, why = (text.format(root=package["root"].resolve()) for text in ATTACKS[mesh])
    assert done.stderr.splitlines() == [f"pincal: error: --meshes copy: link 'hand' names mesh '{mesh}', which "
                                        f"resolves to '{reached}'{why}: refused, nothing written (--meshes keep "
                                        "leaves the names as they are)"]
    assert not out.exists()


def test_meshes_copy_copies_the_package_and_relative_meshes_of_the_robot(package: dict[str, Path]) -> None:
    out = package["root"] / "own" / "cal.urdf"
    done = run_pincal("calibrate", str(package["urdf"]), str(package["data"]), "--out", str(out), "--meshes", "copy")
    assert done.returncode in (0, 1), done.stderr
    names = [m.get("filename", "") for m in ET.parse(out).getroot().iter("mesh")]
    assert names == ["cal_meshes/meshes/base.stl", "cal_meshes/meshes/upper.dae", "cal_meshes/urdf/parts/fore.obj"]
    assert [(out.parent / name).read_bytes() for name in names] == [content for _, content in OWN.values()]
    assert sorted(p.name for p in (out.parent / "cal_meshes").rglob("*") if p.is_file()) == \
        ["base.stl", "fore.obj", "upper.dae"]
