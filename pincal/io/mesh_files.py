"""Mesh file names of a written URDF: portable, never an absolute path of this machine.

A URDF pincal writes (the calibrated URDF, a simulation's ``truth.urdf``) is the source URDF edited, its meshes
included. Where it lands, its mesh names must still resolve, on this machine and on the robot's:

- ``keep`` (the default): ``package://`` names stay exactly as in the source (ROS and pincal resolve them through
  the package: :func:`pincal.model.catalog.resolve_mesh_file`); a name relative to the source file is rewritten
  relative to the output's folder, so it reaches the same file; ``file://`` and absolute names, the source's own,
  stay as written.
- ``copy``: every mesh file the URDF names is copied into a folder beside the output (``cal.urdf`` →
  ``cal_meshes/``, laid out as the files were below their common folder), and named by its path relative to the
  output: the output and that folder move together. A mesh found nowhere here is refused before any work. A
  Collada file's own references (textures) are not followed.

A folder meant to travel with a robot must hold nothing else than the robot's meshes, whatever a URDF names. So
``copy`` copies a file only when it is a mesh, and is the robot's own (:func:`plan_meshes` refuses anything else,
before any work, naming the link, the mesh name and the path it reached):

- it is a regular file (a folder, a FIFO or a device is named as such, and never opened);
- its name ends in a mesh format's suffix (:data:`MESH_FORMATS`, any case), and its first bytes are that format's
  (an STL's ``solid`` or its binary size, a Collada root, Wavefront OBJ statements, a PLY, glTF or Ogre header);
- the file, every symbolic link on its way followed, lies inside the folder tree it belongs to: for
  ``package://PKG/...``, the folder of the package ``PKG`` it was found in; for a relative, ``file://`` or absolute
  name, the URDF's folder, or the ROS package holding the URDF (the nearest folder above it with a
  ``package.xml``), so that ``../meshes/a.stl`` of ``my_robot/urdf/r.urdf`` is the package's own. ``/etc/passwd``,
  ``../../../../etc/passwd`` and a link ``meshes/x.stl -> /etc/shadow`` are not.

Each file is checked again when it is read for the copy (the same file: device, inode and change time; still a mesh),
so one swapped or rewritten during a calibration is refused too.
"""

from __future__ import annotations

import errno
import os
import re
import stat
import struct
import xml.etree.ElementTree as ET
from collections.abc import Callable
from dataclasses import field
from pathlib import Path
from typing import Literal

from pincal.errors import NotFoundError, RobotFileError, listing
from pincal.io.files import resolved
from pincal.model.catalog import package_directories
from pincal.records import record

MeshMode = Literal["keep", "copy"]
#: The choices of ``--meshes``, the default first.
MESH_MODES: tuple[MeshMode, ...] = ("keep", "copy")


def mesh_folder(out: str | Path) -> Path:
    """The folder ``--meshes copy`` fills beside ``out``: ``<stem>_meshes`` (``cal.urdf`` → ``cal_meshes``)."""
    path = Path(out)
    return path.parent / f"{path.stem}_meshes"


@record(frozen=True)
class MeshPlan:
    """What a written URDF's meshes become.

    Attributes:
        filenames: Mesh ``filename`` of the source -> its name in the output (only the names that change).
        copies: (the file found here, its copy beside the output), for ``copy``; empty for ``keep``.
        checked: Each file found -> (its identity: device, inode, change time [ns]; what to name it by) as it was
            checked, for ``copy``.
    """

    filenames: dict[str, str]
    copies: tuple[tuple[Path, Path], ...] = ()
    checked: dict[Path, tuple[tuple[int, int, int], str]] = field(default_factory=dict, repr=False)

    def text(self, urdf_text: str) -> str:
        """``urdf_text`` (the source's meshes in it) with its mesh names as the output holds them."""
        from pincal.model.urdf_writer import calibrated_urdf_text

        return calibrated_urdf_text(urdf_text, {}, {}, mesh_filenames=self.filenames) if self.filenames else urdf_text

    def files(self) -> list[tuple[Path, bytes]]:
        """The copies to write: (destination, the found file's bytes).

        Raises:
            RobotFileError: a file is no longer the one checked (replaced, rewritten, or a link changed since the
                plan), or no longer a mesh.
        """
        return [(dest, _read_checked(found, *self.checked[found])) for found, dest in self.copies]


def _identity(info: os.stat_result) -> tuple[int, int, int]:
    return info.st_dev, info.st_ino, info.st_ctime_ns


def _read_checked(found: Path, identity: tuple[int, int, int], culprit: str) -> bytes:
    """The bytes of ``found``, the file checked as ``identity`` (:func:`_identity`), read without following a link."""
    try:
        handle = os.open(found, os.O_RDONLY | getattr(os, "O_NOFOLLOW", 0) | getattr(os, "O_NONBLOCK", 0))
    except OSError as exc:
        why = "was replaced by a symbolic link since it was checked" if exc.errno == errno.ELOOP else \
            f"cannot be read now: {exc.strerror or exc}"
        raise RobotFileError(f"meshes='copy': {culprit}: '{found}' {why}; nothing written", option="meshes") from None
    with os.fdopen(handle, "rb") as stream:
        info = os.fstat(stream.fileno())
        if _identity(info) != identity or not stat.S_ISREG(info.st_mode):
            raise RobotFileError(f"meshes='copy': {culprit}: '{found}' was replaced or changed since it was checked; "
                                 "nothing written", option="meshes")
        data = stream.read()
    if not _looks_like(found, data[:_HEAD], len(data)):
        raise RobotFileError(f"meshes='copy': {culprit}: '{found}' is no longer a mesh file; nothing written",
                             option="meshes")
    return data


def _mesh_names(source_text: str) -> dict[str, str]:
    """Every mesh file name of the URDF's links, once each, in order -> the first link naming it."""
    names: dict[str, str] = {}
    for link in ET.fromstring(source_text).findall("link"):
        for mesh in link.iter("mesh"):
            names.setdefault(mesh.get("filename", ""), link.get("name", ""))
    names.pop("", None)
    return names


#: Bytes read from a mesh file's start to recognise its format.
_HEAD = 4096
#: Statements of a Wavefront OBJ file (its first lines begin with these, or are comments).
_OBJ_STATEMENTS = frozenset(b"v vt vn vp f l p o g s mtllib usemtl cstype deg bmat step curv curv2 surf parm trim "
                            b"hole scrv sp end con mg bevel c_interp d_interp lod shadow_obj trace_obj maplib usemap "
                            b"ctech stech call csh".split())


def _stl(head: bytes, size: int) -> bool:
    """ASCII (``solid ...``) or binary STL: an 80-byte header, a triangle count, 50 bytes per triangle."""
    if head.lstrip()[:5].lower() == b"solid":
        return True
    return size >= 84 and size == 84 + 50 * struct.unpack("<I", head[80:84])[0]


def _obj(head: bytes, size: int) -> bool:
    lines = head.splitlines()[:-1] if size > len(head) else head.splitlines()  # the last may be cut
    words = [line.split(None, 1)[0] for line in lines if line.strip()]
    return b"\x00" not in head and any(words) and all(w.startswith(b"#") or w in _OBJ_STATEMENTS for w in words)


#: The mesh formats ``--meshes copy`` copies: file name suffix (lower case) -> whether a file's first bytes and size
#: [bytes] are of that format.
MESH_FORMATS: dict[str, Callable[[bytes, int], bool]] = {
    ".stl": _stl,
    ".dae": lambda head, size: b"<COLLADA" in head,
    ".obj": _obj,
    ".ply": lambda head, size: re.match(rb"ply\r?\n", head) is not None,
    ".glb": lambda head, size: head.startswith(b"glTF"),
    ".gltf": lambda head, size: head.lstrip().startswith(b"{"),
    ".mesh": lambda head, size: b"[MeshSerializer_" in head[:64],  # Ogre's binary mesh
}


def _looks_like(path: Path, head: bytes, size: int) -> bool:
    """Whether ``path``'s suffix is a mesh format's and its first bytes ``head`` (of ``size`` in all) are of it."""
    recognise = MESH_FORMATS.get(path.suffix.lower())
    return recognise is not None and recognise(head, size)


def _own_root(source_dir: Path) -> Path:
    """The folder tree a URDF's relative and absolute mesh names must stay in: the ROS package holding the URDF
    (the nearest folder with a ``package.xml`` at or above its folder), else the URDF's folder; links followed."""
    folder = resolved(source_dir)
    return next((f for f in (folder, *folder.parents) if (f / "package.xml").is_file()), folder)


def _located(name: str, source_dir: Path | None) -> tuple[Path, Path | None] | None:
    """Where the mesh ``name`` is: (the path it spells, links not followed; the folder tree that file must lie in,
    links followed, or None for a URDF given as text), or None when found nowhere here (as
    :func:`~pincal.model.catalog.resolve_mesh_file` looks)."""
    if name.startswith("package://"):
        package, _, rest = name[len("package://"):].partition("/")
        for folder in package_directories(package, source_dir):
            if (folder / rest).exists():  # a file, or a folder or device that :func:`_refusal` names as such
                return folder / rest, resolved(folder)
        return None
    path = Path(name.removeprefix("file://"))
    if "://" in name.removeprefix("file://") or (name.startswith("file://") and not path.is_absolute()):  # a URL
        return None
    if not path.is_absolute():
        if source_dir is None:  # a relative name without a folder
            return None
        path = source_dir / path
    if not path.exists():  # missing, or a link to nothing
        return None
    return path, _own_root(source_dir) if source_dir is not None else None


def _refusal(name: str, link: str, spelled: Path, root: Path | None) -> str | None:
    """Why the file the mesh ``name`` of ``link`` spells (``spelled``) may not be copied, when it must lie in the
    folder tree ``root``; None when it may."""
    path = resolved(spelled)
    what = f"link '{link}' names mesh '{name}', which resolves to '{path}'"
    if root is None:
        return f"{what}, with no robot folder to hold it (a URDF given as text)"
    if not path.is_relative_to(root):
        linked = Path(os.path.normpath(spelled.absolute())).is_relative_to(root)
        return f"{what}{' through a symbolic link' if linked else ''}, outside {root}/ (the robot's own folder tree)"
    kind = _not_regular(path)
    if kind:
        return f"{what}, which is {kind}, not a regular mesh file"
    if path.suffix.lower() not in MESH_FORMATS:
        return f"{what}, not a mesh file (formats: {', '.join(s.lstrip('.').upper() for s in MESH_FORMATS)})"
    try:
        with open(path, "rb") as stream:
            head = stream.read(_HEAD)
            size = os.fstat(stream.fileno()).st_size
    except OSError as exc:
        return f"{what}, which cannot be read: {exc.strerror or exc}"
    if not _looks_like(path, head, size):
        return f"{what}, whose content is not {path.suffix.lstrip('.').upper()}"
    return None


def _not_regular(path: Path) -> str | None:
    """What ``path`` (links followed) is when it is not a regular file (``a folder``, ``a FIFO``, ...), else None;
    never opened, so that a FIFO or a device is not read."""
    try:
        mode = path.stat().st_mode
    except OSError as exc:
        return f"unreadable ({exc.strerror or exc})"
    kinds = ((stat.S_ISDIR, "a folder"), (stat.S_ISFIFO, "a FIFO"), (stat.S_ISCHR, "a character device"),
             (stat.S_ISBLK, "a block device"), (stat.S_ISSOCK, "a socket"))
    return None if stat.S_ISREG(mode) else next((what for test, what in kinds if test(mode)), "a special file")


def _is_relative(name: str) -> bool:
    return "://" not in name and not Path(name).is_absolute()


def plan_meshes(source_text: str, source_dir: Path | None, out: str | Path, mode: MeshMode = "keep") -> MeshPlan:
    """The mesh names (and, for ``copy``, the copies) of a URDF written to ``out`` from ``source_text``.

    Args:
        source_text: The source URDF (a written URDF keeps its mesh elements).
        source_dir: The source file's folder (what relative names and nearby packages are found from); None for
            a URDF given as text: its relative names are left as written.
        out: The file to be written.
        mode: ``keep`` or ``copy`` (module docstring).

    Raises:
        NotFoundError: ``copy``, and a mesh is found nowhere here (``package://`` unresolved, a missing file, a
            URL): the first such name, and how many more.
        RobotFileError: ``copy``, and a mesh resolves to a file that is not a mesh, or outside the robot's own folder
            tree (module docstring): the first such, its link, its name and the path it reached.
    """
    links = _mesh_names(source_text)
    names = list(links)
    out_dir = resolved(out).parent
    if mode == "keep":
        if source_dir is None:
            return MeshPlan({})
        moved = {name: Path(os.path.relpath(Path(source_dir).resolve() / name, out_dir)).as_posix()
                 for name in names if _is_relative(name)}
        return MeshPlan({name: new for name, new in moved.items() if new != name})
    found = {name: _located(name, source_dir) for name in names}
    missing = [name for name, place in found.items() if place is None]
    if missing:
        more = f" (and {len(missing) - 1} more: {listing(missing[1:])})" if len(missing) > 1 else ""
        error = NotFoundError(f"meshes='copy': mesh '{missing[0]}' is not found on this machine{more}; give "
                              "ROS_PACKAGE_PATH, or use meshes='keep'", "mesh", missing[0])
        error.option = "meshes"
        raise error
    for name, place in found.items():
        refused = _refusal(name, links[name], *place) if place is not None else None
        if refused:
            raise RobotFileError(f"meshes='copy': {refused}: refused, nothing written (meshes='keep' leaves the "
                                 "names as they are)", option="meshes")
    paths = {name: resolved(place[0]) for name, place in found.items() if place is not None}
    checked = {path: (_identity(path.stat()), f"link '{links[name]}' mesh '{name}'") for name, path in paths.items()}
    common = Path(os.path.commonpath([p.parent for p in paths.values()])) if paths else Path()
    folder = mesh_folder(Path(out).expanduser().resolve())
    copies = {path: folder / path.relative_to(common) for path in paths.values()}
    filenames = {name: Path(os.path.relpath(copies[path], out_dir)).as_posix() for name, path in paths.items()}
    return MeshPlan(filenames, tuple(copies.items()), checked)
