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
"""

from __future__ import annotations

import os
import xml.etree.ElementTree as ET
from dataclasses import dataclass
from pathlib import Path
from typing import Literal

from pincal.errors import NotFoundError, listing
from pincal.io.files import resolved
from pincal.model.catalog import resolve_mesh_file

MeshMode = Literal["keep", "copy"]
#: The choices of ``--meshes``, the default first.
MESH_MODES: tuple[MeshMode, ...] = ("keep", "copy")


def mesh_folder(out: str | Path) -> Path:
    """The folder ``--meshes copy`` fills beside ``out``: ``<stem>_meshes`` (``cal.urdf`` → ``cal_meshes``)."""
    path = Path(out)
    return path.parent / f"{path.stem}_meshes"


@dataclass(frozen=True)
class MeshPlan:
    """What a written URDF's meshes become.

    Attributes:
        filenames: Mesh ``filename`` of the source -> its name in the output (only the names that change).
        copies: (the file found here, its copy beside the output), for ``copy``; empty for ``keep``.
    """

    filenames: dict[str, str]
    copies: tuple[tuple[Path, Path], ...] = ()

    def text(self, urdf_text: str) -> str:
        """``urdf_text`` (the source's meshes in it) with its mesh names as the output holds them."""
        from pincal.model.urdf_writer import calibrated_urdf_text

        return calibrated_urdf_text(urdf_text, {}, {}, mesh_filenames=self.filenames) if self.filenames else urdf_text

    def files(self) -> list[tuple[Path, bytes]]:
        """The copies to write: (destination, the found file's bytes)."""
        return [(dest, found.read_bytes()) for found, dest in self.copies]


def _mesh_names(source_text: str) -> list[str]:
    """Every mesh file name of the URDF's links, once each, in order."""
    names = (m.get("filename", "") for link in ET.fromstring(source_text).findall("link") for m in link.iter("mesh"))
    return list(dict.fromkeys(name for name in names if name))


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
    """
    names = _mesh_names(source_text)
    out_dir = resolved(out).parent
    if mode == "keep":
        if source_dir is None:
            return MeshPlan({})
        moved = {name: Path(os.path.relpath(Path(source_dir).resolve() / name, out_dir)).as_posix()
                 for name in names if _is_relative(name)}
        return MeshPlan({name: new for name, new in moved.items() if new != name})
    found = {name: resolve_mesh_file(name, source_dir) for name in names}
    missing = [name for name, path in found.items() if path is None]
    if missing:
        more = f" (and {len(missing) - 1} more: {listing(missing[1:])})" if len(missing) > 1 else ""
        raise NotFoundError(f"--meshes copy: mesh '{missing[0]}' is not found on this machine{more}; give "
                            "ROS_PACKAGE_PATH, or use --meshes keep", "mesh", missing[0])
    paths = {name: path.resolve() for name, path in found.items() if path is not None}
    common = Path(os.path.commonpath([p.parent for p in paths.values()])) if paths else Path()
    folder = mesh_folder(Path(out).expanduser().resolve())
    copies = {path: folder / path.relative_to(common) for path in paths.values()}
    filenames = {name: Path(os.path.relpath(copies[path], out_dir)).as_posix() for name, path in paths.items()}
    return MeshPlan(filenames, tuple(copies.items()))
