"""The robots known by name, each loaded: their joint counts and the file each comes from (``pincal robots``).

The names and files are :mod:`pincal.model.catalog`'s; loading each is :func:`~pincal.model.robot.load_robot`'s, which
reads a name through the catalog: this table stands above both.
"""

from __future__ import annotations

from pincal.errors import PincalError
from pincal.model.catalog import EXAMPLE_ROBOT_DATA, known_robot_names, robot_path, shipped_robots
from pincal.model.robot import load_robot
from pincal.records import record


@record(frozen=True)
class KnownRobot:
    """A robot reachable by name, as ``pincal robots`` lists it.

    Attributes:
        name: The name :func:`~pincal.model.catalog.robot_path` takes.
        origin: ``pincal`` (``robots_urdf/``) or ``example-robot-data``.
        file: The URDF's path within its origin (``delta.urdf``, ``talos_data/robots/talos_full_v2.urdf``).
        joints: Its movable joints, ``<mimic>`` followers included; None when it does not load.
        actuated: Its actuated joints; None when it does not load.
        loops: Its loop closures; None when it does not load.
        problem: Why it does not load (example-robot-data not installed, ...); empty when it does.
    """

    name: str
    origin: str
    file: str
    joints: int | None
    actuated: int | None
    loops: int | None
    problem: str = ""


def known_robots() -> list[KnownRobot]:
    """Every name :func:`~pincal.model.catalog.robot_path` accepts with the file it comes from, each loaded for its
    joint counts."""
    out: list[KnownRobot] = []
    for name in known_robot_names():
        origin = "pincal" if name in shipped_robots() else "example-robot-data"
        file = f"{name}.urdf" if origin == "pincal" else EXAMPLE_ROBOT_DATA[name]
        try:
            robot = load_robot(robot_path(name))
        except PincalError as exc:
            out.append(KnownRobot(name, origin, file, None, None, None, str(exc)))
            continue
        out.append(KnownRobot(name, origin, file, robot.model.njoints - 1, robot.n_actuated, len(robot.loops)))
    return out
