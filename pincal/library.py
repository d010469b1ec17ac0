"""Robots reachable by name: the reference robots shipped with pincal and example-robot-data's URDFs.

example-robot-data 6 ships URDF files but no Python loader; its data directory is found through the
installed distribution's file list (``importlib.metadata``), never through a hard-coded path.
"""

from __future__ import annotations

import importlib.metadata
import importlib.resources
from functools import cache
from pathlib import Path

from pincal.errors import NotFoundError, listing

#: Robot name -> (distribution, path suffix inside it) for example-robot-data robots.
EXAMPLE_ROBOT_DATA: dict[str, str] = {
    "ur3": "ur_description/urdf/ur3_robot.urdf",
    "ur5": "ur_description/urdf/ur5_robot.urdf",
    "ur10": "ur_description/urdf/ur10_robot.urdf",
    "panda": "panda_description/urdf/panda.urdf",
    "tiago": "tiago_description/robots/tiago.urdf",
    "tiago_no_hand": "tiago_description/robots/tiago_no_hand.urdf",
    "kinova": "kinova_description/robots/kinova.urdf",
    "iiwa": "iiwa_description/urdf/iiwa.urdf",
}


def shipped_robots() -> dict[str, Path]:
    """The URDF files shipped in ``robots_urdf/``, by stem (``delta``, ``hexapod``, ...)."""
    root = importlib.resources.files("pincal.robots_urdf")
    return {Path(str(p)).stem: Path(str(p)) for p in root.iterdir() if str(p).endswith(".urdf")}


@cache
def example_robot_data_dir() -> Path | None:
    """The ``robots/`` directory of the installed example-robot-data distribution, if any."""
    try:
        files = importlib.metadata.files("example-robot-data") or []
    except importlib.metadata.PackageNotFoundError:
        return None
    for f in files:
        parts = Path(str(f)).parts
        if "example-robot-data" in parts and "robots" in parts and str(f).endswith(".urdf"):
            located = Path(str(f.locate()))
            idx = located.parts.index("robots")
            return Path(*located.parts[: idx + 1])
    return None


def known_robot_names() -> list[str]:
    """Every name :func:`robot_path` accepts."""
    return sorted(shipped_robots()) + sorted(EXAMPLE_ROBOT_DATA)


def robot_path(name: str) -> Path:
    """Path of a robot's URDF given its name (a shipped robot or an example-robot-data one).

    Raises:
        NotFoundError: unknown name, or example-robot-data is not installed.
    """
    shipped = shipped_robots()
    if name in shipped:
        return shipped[name]
    if name in EXAMPLE_ROBOT_DATA:
        root = example_robot_data_dir()
        if root is None:
            raise NotFoundError(f"robot '{name}' comes from example-robot-data, which is not installed "
                                "(pip install example-robot-data)")
        path = root / EXAMPLE_ROBOT_DATA[name]
        if not path.is_file():
            raise NotFoundError(f"robot '{name}': {path} is missing from example-robot-data")
        return path
    raise NotFoundError(f"no robot file or known robot named '{name}'; known robots are: "
                        f"{listing(known_robot_names())}")
