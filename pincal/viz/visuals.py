"""How pincal draws in meshcat: a robot's URDF visuals as meshcat shapes, and the scene's colours.

Boxes, cylinders and spheres become meshcat primitives; meshes are embedded from local files only
(``package://``, ``file://`` or relative to the URDF; nothing is ever downloaded) and only when small
enough to keep a static page light, else the link's collision mesh stands in. A binary STL mesh is embedded as
an indexed triangle mesh, simplified by vertex clustering to at most :data:`MAX_MESH_TRIANGLES` triangles (a
picture of the robot needs no finer: TIAGo's page went from 7.9 MB to under 2 MB). A robot with nothing
drawable is drawn as a skeleton of its joints. Poses are (4, 4) homogeneous matrices [m].
"""

from __future__ import annotations

import importlib.util
import math
import sys
import xml.etree.ElementTree as ET
from functools import lru_cache
from pathlib import Path
from typing import Any

import numpy as np
import numpy.typing as npt
import pinocchio as pin

from pincal.errors import RobotFileError
from pincal.model.catalog import resolve_mesh_file
from pincal.model.robot import Robot
from pincal.model.urdf import origin_to_se3
from pincal.records import record
from pincal.viz.colormaps import colormap

Array = npt.NDArray[np.float64]

NOMINAL_COLOR = 0x4f86c6
CALIBRATED_COLOR = 0xe8833a
POINT_COLOR = 0x1e1e1e
CURRENT_COLOR = 0xffd21f
GHOST_OPACITY = 0.3
#: Colour map of the error segments, from 0 to the largest error before calibration.
ERROR_COLORMAP = "RdYlGn_r"
#: Mesh files larger than this are not embedded (the link's collision mesh is tried instead).
MAX_MESH_BYTES = 400_000
#: Triangles a binary STL mesh keeps at most on a page (vertex clustering, :func:`clustered_mesh`).
MAX_MESH_TRIANGLES = 400
#: A binary STL triangle: normal, three corners [file units], attribute.
STL_TRIANGLE = np.dtype([("normal", "<f4", 3), ("corners", "<f4", (3, 3)), ("attribute", "<u2")])


def error_colors(values: Array, scale: float) -> list[int]:
    """Colours (0xRRGGBB) of errors ``values`` [m] on :data:`ERROR_COLORMAP` from 0 to ``scale``."""
    rgba = colormap(ERROR_COLORMAP, np.clip(np.asarray(values) / (scale or 1.0), 0.0, 1.0))
    return [int(r * 255) << 16 | int(g * 255) << 8 | int(b * 255) for r, g, b, _ in np.atleast_2d(rgba)]


def bound_colors(values: Array, low: float, high: float) -> Array:
    """RGB colours (N, 3) in [0, 1] of predicted bounds ``values`` (N,) [m] on the colour map of the report's
    uncertainty figure (:data:`pincal.viz.svg_figures.BOUND_COLORMAP`), from ``low`` to ``high`` [m]."""
    from pincal.viz.svg_figures import BOUND_COLORMAP

    span = high - low if high > low else 1.0
    return colormap(BOUND_COLORMAP, np.clip((np.asarray(values) - low) / span, 0.0, 1.0))[:, :3]


@record(frozen=True)
class Visual:
    """One shape fixed to a Pinocchio frame.

    Attributes:
        frame_id: The frame (a URDF link, or a joint for the skeleton fallback).
        name: Node name, unique within the frame.
        geometry: A ``meshcat.geometry`` geometry.
        placement: (4, 4) pose of the shape in the frame [m] (mesh scale included).
    """

    frame_id: int
    name: str
    geometry: Any
    placement: Array


def _cylinder_along_z(origin: pin.SE3) -> Array:
    # meshcat cylinders run along y, URDF ones along z
    homogeneous: Array = origin.homogeneous @ pin.SE3(pin.utils.rotate("x", math.pi / 2), np.zeros(3)).homogeneous
    return homogeneous


def binary_stl_corners(path: Path) -> Array | None:
    """The triangles' corners (3·T, 3) [file units] of a binary STL file, three per triangle; None for a file that
    is not one (ASCII STL)."""
    data = path.read_bytes()
    count = int.from_bytes(data[80:84], "little") if len(data) >= 84 else -1
    if count < 0 or len(data) != 84 + STL_TRIANGLE.itemsize * count:
        return None
    triangles = np.frombuffer(data, dtype=STL_TRIANGLE, count=count, offset=84)
    return np.asarray(triangles["corners"].reshape(-1, 3), dtype=np.float64)


def _clusters(corners: Array, divisions: int) -> tuple[Array, npt.NDArray[np.int64]]:
    """The corners (3·T, 3), scaled to [0, 1] along the mesh's longest side, merged per cell of a grid of
    ``divisions`` cells along it: each cluster's mean (V, 3) and the triangles (T', 3) as indices into it, without
    the triangles a merge collapsed or repeated."""
    cells = np.minimum(corners * divisions, divisions).astype(np.int64)
    keys = (cells[:, 0] * (divisions + 1) + cells[:, 1]) * (divisions + 1) + cells[:, 2]
    _, inverse, counts = np.unique(keys, return_inverse=True, return_counts=True)
    vertices = np.column_stack([np.bincount(inverse, corners[:, c], len(counts)) for c in range(3)]) / counts[:, None]
    faces = inverse.reshape(-1, 3).astype(np.int64)
    faces = faces[(faces[:, 0] != faces[:, 1]) & (faces[:, 1] != faces[:, 2]) & (faces[:, 0] != faces[:, 2])]
    ordered = np.sort(faces, axis=1)
    _, first = np.unique((ordered[:, 0] * len(counts) + ordered[:, 1]) * len(counts) + ordered[:, 2],
                         return_index=True)
    return vertices, faces[np.sort(first)]


def clustered_mesh(corners: Array, max_triangles: int = MAX_MESH_TRIANGLES) -> tuple[Array, npt.NDArray[np.int64]]:
    """A triangle soup's corners (3·T, 3) [file units] as an indexed mesh (vertices (V, 3) [file units], triangles
    (T', 3)) of at most ``max_triangles`` triangles, by vertex clustering (Rossignac & Borrel 1993): corners merged
    per cell of a grid over the mesh's extent, 4096 cells along its longest side (which shares the corners of
    neighbouring triangles and changes nothing visible), coarser until the triangles fit; a surface's triangles go
    as the square of the cells along a side, so each try aims below the limit directly."""
    low = corners.min(axis=0)
    extent = float(np.ptp(corners, axis=0).max()) or 1.0
    unit = (corners - low) / extent
    divisions = 4096
    vertices, faces = _clusters(unit, divisions)
    while len(faces) > max_triangles and divisions > 2:
        divisions = max(2, min(divisions // 2, int(divisions * 0.8 * math.sqrt(max_triangles / len(faces)))))
        vertices, faces = _clusters(unit, divisions)
    return vertices * extent + low, faces


#: What meshcat's ``__init__`` itself defines: asking the package for one runs it (:func:`lean_meshcat`).
MESHCAT_OWN_NAMES = ("Visualizer", "viewer_assets_path", "visualizer", "servers")


def lean_meshcat() -> None:
    """Let ``import meshcat.geometry`` (and ``commands``, ``animation``, ``path``) load those modules alone: meshcat's
    own ``__init__`` imports its visualizer and server (tornado, zmq, IPython: some 500 modules, about a third of
    ``pincal report``'s start), which drawing into a page never uses. Unless meshcat is imported already, its package
    is registered here without running its ``__init__``, which runs the first time a name only it defines
    (``meshcat.Visualizer``) is asked of the package."""
    if "meshcat" in sys.modules:
        return
    spec = importlib.util.find_spec("meshcat")
    if spec is None or spec.loader is None:
        return  # not installed: the import that follows says so
    package = importlib.util.module_from_spec(spec)
    loader = spec.loader

    def complete(name: str) -> Any:  # PEP 562: a name the package's __init__ defines, else a submodule not loaded
        if name not in MESHCAT_OWN_NAMES:
            raise AttributeError(f"module 'meshcat' has no attribute '{name}'")
        del package.__dict__["__getattr__"]
        loader.exec_module(package)
        return getattr(package, name)

    setattr(package, "__getattr__", complete)  # noqa: B010 (a module's attribute, not a method)
    sys.modules["meshcat"] = package


@lru_cache(maxsize=64)
def _stl_mesh(path: str, mtime_ns: int, size: int) -> tuple[Array, npt.NDArray[np.int64]] | None:
    """:func:`clustered_mesh` of a binary STL file, None for another (an ASCII STL, an empty one); kept by the file's
    path, time and size: a robot draws one mesh on several links (TIAGo's four casters, its two wheels), decimated
    once. Each caller gets the arrays read-only (a geometry made of them only reads them)."""
    corners = binary_stl_corners(Path(path))
    if corners is None or not len(corners):
        return None
    vertices, faces = clustered_mesh(corners)
    vertices.flags.writeable = faces.flags.writeable = False
    return vertices, faces


def _mesh_geometry(path: Path) -> Any:
    lean_meshcat()
    import meshcat.geometry as mg

    if path.suffix.lower() == ".stl":
        stat = path.stat()
        mesh = _stl_mesh(str(path), stat.st_mtime_ns, stat.st_size)
        if mesh is not None:
            return mg.TriangularMeshGeometry(*mesh)
    loaders = {".stl": mg.StlMeshGeometry, ".obj": mg.ObjMeshGeometry, ".dae": mg.DaeMeshGeometry}
    return loaders[path.suffix.lower()].from_file(str(path))


def _mesh_visual(link: ET.Element, visual: ET.Element, urdf_dir: Path, budget: int) -> tuple[Any, Array] | None:
    """The visual's mesh, or the link's collision mesh, that meshcat can load within ``budget`` bytes.

    STL and OBJ come first: three.js's Collada loader re-orients Z-up files.
    """
    candidates = [visual, *link.findall("collision")]
    found = []
    for element in candidates:
        mesh = element.find("geometry/mesh")
        if mesh is None:
            continue
        path = resolve_mesh_file(mesh.get("filename", ""), urdf_dir)
        if path is None or path.suffix.lower() not in (".stl", ".obj", ".dae") or path.stat().st_size > budget:
            continue
        scale = _numbers(mesh, "scale", 3, "1 1 1", signed=True)
        if isinstance(scale, str):
            continue
        placement = origin_to_se3(element.find("origin"), f"link '{link.get('name')}' mesh").homogeneous
        found.append((path.suffix.lower() == ".dae", path, placement @ np.diag([*scale, 1.0])))
    if not found:
        return None
    _, path, placement = min(found, key=lambda item: item[0])
    return _mesh_geometry(path), placement


def _numbers(shape: ET.Element, attribute: str, count: int, default: str | None = None,
             signed: bool = False) -> list[float] | str:
    """The ``count`` finite numbers [m, or a scale factor] of a geometry attribute, ≥ 0 unless ``signed`` (a mesh's
    scale may mirror it), or why there are none."""
    written = shape.get(attribute, default)
    if written is None:
        return f"no {attribute}"
    try:
        values = [float(v) for v in written.split()]
    except ValueError:
        values = []
    if len(values) != count or not all(math.isfinite(v) and (signed or v >= 0) for v in values):
        plural = "s" if count > 1 else ""
        return f'{attribute}="{written[:40]}" is not {count} finite number{plural}{"" if signed else " ≥ 0"}'
    return values


def _visual(link: ET.Element, visual: ET.Element, source: Path | None,
            budget: int) -> tuple[Any, Array] | str:
    """One URDF visual as a meshcat geometry and its (4, 4) pose in the link frame [m], or why it is not drawn."""
    lean_meshcat()
    import meshcat.geometry as mg

    shape = visual.find("geometry/*")
    try:
        origin = origin_to_se3(visual.find("origin"), "its")
    except RobotFileError as exc:
        return str(exc)
    tag = shape.tag if shape is not None else "none"
    if shape is not None and tag == "box":
        size = _numbers(shape, "size", 3)
        return size if isinstance(size, str) else (mg.Box(size), origin.homogeneous)
    if shape is not None and tag == "cylinder":
        length, radius = _numbers(shape, "length", 1), _numbers(shape, "radius", 1)
        if isinstance(length, str) or isinstance(radius, str):
            return length if isinstance(length, str) else str(radius)
        return mg.Cylinder(length[0], radius[0]), _cylinder_along_z(origin)
    if shape is not None and tag == "sphere":
        radius = _numbers(shape, "radius", 1)
        return radius if isinstance(radius, str) else (mg.Sphere(radius[0]), origin.homogeneous)
    if shape is not None and tag == "mesh" and source is not None:
        scale = _numbers(shape, "scale", 3, "1 1 1", signed=True)
        if isinstance(scale, str):
            return scale
        mesh = _mesh_visual(link, visual, Path(source).parent, budget)
        if mesh is None:
            return (f"mesh '{shape.get('filename', '')}' not found locally, or over {budget // 1000} kB")
        return mesh
    return "not a shape pincal draws"


def robot_visuals(robot: Robot, max_mesh_bytes: int = MAX_MESH_BYTES) -> tuple[list[Visual], list[str]]:
    """The robot's URDF visuals as meshcat shapes, and notes on what could not be drawn.

    Boxes, cylinders and spheres are drawn as such; meshes are embedded when their file is found
    locally and is small enough, else the link's collision mesh, else they are skipped (noted). A robot
    with nothing drawable gets a skeleton (:func:`_skeleton`): its joints, links, loops and frames as bars.
    """

    model = robot.model
    visuals: list[Visual] = []
    notes: list[str] = []
    root = None
    if robot.source is not None:
        try:
            root = ET.fromstring(Path(robot.source).read_text(encoding="utf-8"))
        except (OSError, ET.ParseError) as exc:
            raise RobotFileError(f"cannot read the visuals of '{robot.source}': {exc}") from None
    for link in root.findall("link") if root is not None else []:
        name = link.get("name", "")
        if not model.existFrame(name, pin.FrameType.BODY):
            continue
        fid = int(model.getFrameId(name, pin.FrameType.BODY))
        for k, visual in enumerate(link.findall("visual")):
            shape = visual.find("geometry/*")
            tag = shape.tag if shape is not None else "none"
            drawn = _visual(link, visual, robot.source, max_mesh_bytes)
            if isinstance(drawn, str):
                notes.append(f"link '{name}': visual {k} ({tag}) not drawn: {drawn}")
            else:
                visuals.append(Visual(fid, f"visual_{k}", *drawn))
    if not visuals:
        visuals = _skeleton(robot)
        notes.append("no drawable visuals: the robot is drawn as a skeleton of its joints, loops and frames")
    return visuals, notes


def _skeleton(robot: Robot) -> list[Visual]:
    """A robot without visuals as bars: a sphere per joint, a rod from each joint to each child joint, to each loop
    anchor on its link (so a loop's coupler and rocker meet where the loop closes, marked by a sphere) and to each
    link frame away from its joint (a measured frame, a tool); all fixed to the joints' frames, sizes [m] from the
    robot's reach."""
    lean_meshcat()
    import meshcat.geometry as mg

    model = robot.model
    data = model.createData()
    pin.forwardKinematics(model, data, robot.q_reference)
    size = max((float(np.linalg.norm(data.oMi[j].translation)) for j in range(model.njoints)), default=0.0) or 1.0
    radius = 0.012 * size
    out = []
    for j in range(1, model.njoints):
        out.append(Visual(_joint_frame(model, j), "joint", mg.Sphere(2 * radius), np.eye(4)))
        out += _rod(model, model.parents[j], f"rod_to_{model.names[j]}", model.jointPlacements[j].translation, radius)
    for spec, (j1, m1, j2, m2) in zip(robot.loops, robot.closure.anchors() if robot.loops else [], strict=True):
        for role, joint, anchor in (("predecessor", j1, m1), ("successor", j2, m2)):
            out += _rod(model, joint, f"loop_{spec.name}_{role}", anchor.translation, radius)
        out.append(Visual(_joint_frame(model, j1), f"loop_{spec.name}", mg.Sphere(1.5 * radius),
                          translation_pose(m1.translation)))
    for frame in model.frames:
        if frame.type == pin.FrameType.BODY and frame.parentJoint > 0:
            out += _rod(model, frame.parentJoint, f"to_{frame.name}", frame.placement.translation, radius)
    return out


def _joint_frame(model: pin.Model, joint: int) -> int:
    """The Pinocchio frame of joint ``joint`` (the universe's frame 0 for joint 0)."""
    return 0 if joint == 0 else int(model.getFrameId(model.names[joint], pin.FrameType.JOINT))


def _rod(model: pin.Model, joint: int, name: str, end: Array, radius: float) -> list[Visual]:
    """A rod of ``radius`` [m] from joint ``joint``'s origin to ``end`` (3,) [m] in its frame; none when they meet."""
    lean_meshcat()
    import meshcat.geometry as mg

    length = float(np.linalg.norm(end))
    if length <= 1e-9:
        return []
    return [Visual(_joint_frame(model, joint), name, mg.Cylinder(length, radius), segment_pose(np.zeros(3), end))]


def segment_pose(start: Array, end: Array) -> Array:
    """Pose of a meshcat cylinder (axis y, centred) spanning ``start`` → ``end``."""
    axis = end - start
    length = float(np.linalg.norm(axis))
    y = axis / length if length > 0 else np.array([0.0, 0.0, 1.0])
    helper = np.array([1.0, 0.0, 0.0]) if abs(y[0]) < 0.9 else np.array([0.0, 1.0, 0.0])
    x = np.cross(helper, y)
    x /= np.linalg.norm(x)
    pose = np.eye(4)
    pose[:3, :3] = np.column_stack([x, y, np.cross(x, y)])
    pose[:3, 3] = (start + end) / 2
    return pose


def translation_pose(p: Array) -> Array:
    """Pose (4, 4) of a pure translation by ``p`` (3,) [m]."""
    pose = np.eye(4)
    pose[:3, 3] = p
    return pose

