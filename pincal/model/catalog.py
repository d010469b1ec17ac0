"""Robots reachable by name: the reference robots shipped with pincal and example-robot-data's URDFs.

example-robot-data 6 ships URDF files but no Python loader; its data directory is found through the
installed distribution's file list (its ``RECORD``, as ``importlib.metadata`` reads it), never through a hard-coded
path. The same lookup resolves its ``package://example-robot-data/...`` mesh references to local files.
"""

from __future__ import annotations

import csv
import importlib.util
import os
import sys
from collections.abc import Iterator
from functools import cache
from pathlib import Path

from pincal.errors import NotFoundError, listing

#: Robot name -> path inside example-robot-data's ``robots/`` directory: every URDF it ships that has a joint to
#: calibrate and loads (``ur3.urdf`` has no robot name, ``alex_psyonic_hands.urdf`` a ``<mimic>`` naming a joint it
#: lacks; ``quadrotor_base.urdf``, ``iris*.urdf`` are drones: no joint, or only propellers). A floating-base robot
#: is loaded with its root link fixed.
EXAMPLE_ROBOT_DATA: dict[str, str] = {
    "a1": "a1_description/urdf/a1.urdf",
    "alex": "alex_description/urdf/alex_nub_hands.urdf",
    "alex_sake_hands": "alex_description/urdf/alex_sake_hands.urdf",
    "alexander": "alexander_description/urdf/alexander_v1.lowerBodyOnly.urdf",
    "allegro_left_hand": "allegro_hand_description/urdf/allegro_left_hand.urdf",
    "allegro_right_hand": "allegro_hand_description/urdf/allegro_right_hand.urdf",
    "anymal": "anymal_b_simple_description/robots/anymal.urdf",
    "anymal_kinova": "anymal_b_simple_description/robots/anymal-kinova.urdf",
    "anymal_c": "anymal_c_simple_description/urdf/anymal.urdf",
    "asr_twodof": "asr_twodof_description/urdf/TwoDofs.urdf",
    "b1": "b1_description/urdf/b1.urdf",
    "b1_z1": "b1_description/urdf/b1-z1.urdf",
    "baxter": "baxter_description/urdf/baxter.urdf",
    "bolt": "bolt_description/robots/bolt.urdf",
    "borinot": "borinot_description/urdf/borinot_flying_arm_2.urdf",
    "centauro": "centauro_description/urdf/centauro.urdf",
    "double_pendulum": "double_pendulum_description/urdf/double_pendulum.urdf",
    "double_pendulum_continuous": "double_pendulum_description/urdf/double_pendulum_continuous.urdf",
    "double_pendulum_simple": "double_pendulum_description/urdf/double_pendulum_simple.urdf",
    "finger_edu": "finger_edu_description/robots/finger_edu.urdf",
    "g1": "g1_description/urdf/g1_29dof_rev_1_0.urdf",
    "g1_with_hands": "g1_description/urdf/g1_29dof_with_hand_rev_1_0.urdf",
    "go1": "go1_description/urdf/go1.urdf",
    "go2": "go2_description/urdf/go2.urdf",
    "hextilt": "hextilt_description/urdf/hextilt_flying_arm_5.urdf",
    "human": "human_description/robots/human.urdf",
    "hyq": "hyq_description/robots/hyq_no_sensors.urdf",
    "icub": "icub_description/robots/icub.urdf",
    "icub_reduced": "icub_description/robots/icub_reduced.urdf",
    "kinova": "kinova_description/robots/kinova.urdf",
    "laikago": "laikago_description/urdf/laikago.urdf",
    "panda": "panda_description/urdf/panda.urdf",
    "panda_collision": "panda_description/urdf/panda_collision.urdf",
    "pr2": "pr2_description/urdf/pr2.urdf",
    "quadruped": "quadruped_description/urdf/quadruped.urdf",
    "romeo": "romeo_description/urdf/romeo.urdf",
    "romeo_laas_small": "romeo_description/urdf/romeo_laas_small.urdf",
    "romeo_small": "romeo_description/urdf/romeo_small.urdf",
    "simple_humanoid": "simple_humanoid_description/urdf/simple_humanoid.urdf",
    "simple_humanoid_classical": "simple_humanoid_description/urdf/simple_humanoid_classical.urdf",
    "so100": "so_arm_description/urdf/so100.urdf",
    "so101": "so_arm_description/urdf/so101.urdf",
    "solo8": "solo_description/robots/solo.urdf",
    "solo12": "solo_description/robots/solo12.urdf",
    "talos": "talos_data/robots/talos_full_v2.urdf",
    "talos_box": "talos_data/robots/talos_full_v2_box.urdf",
    "talos_arm": "talos_data/robots/talos_left_arm.urdf",
    "talos_reduced": "talos_data/robots/talos_reduced.urdf",
    "talos_reduced_box": "talos_data/robots/talos_reduced_box.urdf",
    "talos_reduced_corrected": "talos_data/robots/talos_reduced_corrected.urdf",
    "tiago": "tiago_description/robots/tiago.urdf",
    "tiago_dual": "tiago_description/robots/tiago_dual.urdf",
    "tiago_no_hand": "tiago_description/robots/tiago_no_hand.urdf",
    "tiago_pro": "tiago_pro_description/robots/tiago_pro.urdf",
    "ur3": "ur_description/urdf/ur3_robot.urdf",
    "ur3_gripper": "ur_description/urdf/ur3_gripper.urdf",
    "ur3_limited": "ur_description/urdf/ur3_joint_limited_robot.urdf",
    "ur5": "ur_description/urdf/ur5_robot.urdf",
    "ur5_gripper": "ur_description/urdf/ur5_gripper.urdf",
    "ur5_limited": "ur_description/urdf/ur5_joint_limited_robot.urdf",
    "ur10": "ur_description/urdf/ur10_robot.urdf",
    "ur10_limited": "ur_description/urdf/ur10_joint_limited_robot.urdf",
    "xarm7": "xarm_description/urdf/xarm7.urdf",
    "z1": "z1_description/urdf/z1.urdf",
}


def shipped_robots() -> dict[str, Path]:
    """The URDF files shipped in ``robots_urdf/``, by stem (``delta``, ``hexapod``, ...)."""
    spec = importlib.util.find_spec("pincal.robots_urdf")  # not importlib.resources: its zipfile, tempfile, ...
    if spec is None or spec.origin is None:
        return {}
    return {p.stem: p for p in Path(spec.origin).parent.iterdir() if p.name.endswith(".urdf")}


@cache
def example_robot_data_dir() -> Path | None:
    """The ``robots/`` directory of the installed example-robot-data distribution, if any."""
    for f in _installed_files_in_order("example-robot-data"):  # the first robot file is near the top: read no more
        parts = f.parts
        if "example-robot-data" in parts and "robots" in parts and str(f).endswith(".urdf"):
            idx = f.parts.index("robots")
            return Path(*f.parts[: idx + 1])
    return None


def _dist_info_file(distribution: str, name: str) -> Path | None:
    """The file ``name`` (``RECORD``, ``METADATA``) of the first ``.dist-info`` folder of ``distribution`` on
    ``sys.path`` that holds one, found as ``importlib.metadata`` finds it, without its e-mail parser (a tenth of a
    calibration's start); None if there is none."""
    prefix = distribution.replace("-", "_").replace(".", "_").lower() + "-"
    for entry in sys.path:
        folder = Path(entry or ".")
        try:
            names = sorted(e.name for e in os.scandir(folder) if e.name.lower().startswith(prefix)
                           and e.name.endswith(".dist-info"))
        except OSError:  # not a folder (a zip file, a missing entry)
            continue
        for found in names:
            if (folder / found / name).is_file():
                return folder / found / name
    return None


def _installed_files(distribution: str) -> list[Path]:
    """Each file an installed distribution lists, located ([] if it is not installed): its ``RECORD``, as
    ``importlib.metadata.files`` reads it; else ``importlib.metadata``'s own answer (an egg or another layout)."""
    return list(_installed_files_in_order(distribution))


def _installed_files_in_order(distribution: str) -> Iterator[Path]:
    """:func:`_installed_files` one at a time, in the ``RECORD``'s order, read only as far as the caller asks."""
    record = _dist_info_file(distribution, "RECORD")
    if record is not None:
        with open(record, encoding="utf-8", newline="") as stream:
            yield from (record.parent.parent / row[0] for row in csv.reader(stream) if row)
        return
    import importlib.metadata  # here: with its e-mail parser, for a distribution installed otherwise

    try:
        files = importlib.metadata.files(distribution) or []
    except importlib.metadata.PackageNotFoundError:
        return
    yield from (Path(str(f.locate())) for f in files)


def installed_version(distribution: str) -> str:
    """An installed distribution's version: the ``Version:`` line of its ``METADATA``, as
    ``importlib.metadata.version`` reads it; else ``importlib.metadata``'s own answer (an egg or another layout).

    Raises:
        importlib.metadata.PackageNotFoundError: ``distribution`` is not installed.
    """
    metadata = _dist_info_file(distribution, "METADATA")
    if metadata is not None:
        with open(metadata, encoding="utf-8") as stream:
            for line in stream:
                if line.startswith("Version:"):
                    return line.removeprefix("Version:").strip()
                if not line.strip():  # the headers end at the first blank line
                    break
    import importlib.metadata  # here: with its e-mail parser, for a distribution installed otherwise

    return importlib.metadata.version(distribution)


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
                        f"{listing(known_robot_names())}; 'pincal robots' lists them with their files")


def package_directories(package: str, near: Path | None = None) -> list[Path]:
    """Local directories that may hold ROS package ``package``, most likely first.

    Looked for: a directory of that name holding ``near`` (a URDF's directory) or beside one of its
    parents (the layouts of example-robot-data and of ROS workspaces); the installed
    example-robot-data's data directory for ``example-robot-data``; each ``ROS_PACKAGE_PATH`` entry.
    Nothing is downloaded.
    """
    out: list[Path] = []
    if near is not None:
        for folder in (near, *near.parents):
            out += [folder] if folder.name == package else [folder / package]
    if package == "example-robot-data":
        robots = example_robot_data_dir()
        if robots is not None:
            out.append(robots.parent)
    for entry in os.environ.get("ROS_PACKAGE_PATH", "").split(os.pathsep):
        if entry:
            out += [Path(entry)] if Path(entry).name == package else [Path(entry) / package]
    return [folder for folder in dict.fromkeys(out) if folder.is_dir()]


def resolve_mesh_file(filename: str, urdf_dir: Path | None = None) -> Path | None:
    """The local file a URDF ``<mesh filename>`` refers to, or None if it cannot be found here.

    Args:
        filename: ``package://<package>/<path>``, ``file://<absolute path>``, an absolute path, or a
            path relative to the URDF's directory.
        urdf_dir: Directory of the URDF the file name comes from (for relative names and to find
            packages beside it); None if unknown.
    """
    if filename.startswith("file://"):
        path = Path(filename[len("file://"):])
        return path if path.is_absolute() and path.is_file() else None
    if filename.startswith("package://"):
        package, _, rest = filename[len("package://"):].partition("/")
        for folder in package_directories(package, urdf_dir):
            if (folder / rest).is_file():
                return (folder / rest).resolve()
        return None
    if "://" in filename:  # another scheme (http, ...): never fetched
        return None
    path = Path(filename)
    if not path.is_absolute():
        if urdf_dir is None:
            return None
        path = urdf_dir / path
    return path.resolve() if path.is_file() else None
