"""``pincal robots``: the robots known by name, their joint counts and the file each comes from."""

from __future__ import annotations

import argparse


def cmd_robots(args: argparse.Namespace) -> int:
    """``pincal robots``: one line per known robot: name, movable and actuated joints, loops, origin and file."""
    from pincal.model.catalog import example_robot_data_dir
    from pincal.model.robot_table import known_robots

    robots = known_robots()
    print(f"known robots ({len(robots)}): give the name where a robot file is asked for (pincal info NAME)")
    print(f"  {'name':<28}{'joints':>7}{'actuated':>9}{'loops':>6}  file")
    for robot in robots:
        where = "robots_urdf/" if robot.origin == "pincal" else "example-robot-data: "
        if robot.problem:
            print(f"  {robot.name:<28}{'-':>7}{'-':>9}{'-':>6}  {where}{robot.file} ({robot.problem})")
        else:
            print(f"  {robot.name:<28}{robot.joints:>7}{robot.actuated:>9}{robot.loops:>6}  {where}{robot.file}")
    folder = example_robot_data_dir()
    print(f"example-robot-data: {folder if folder is not None else 'not installed (pip install example-robot-data)'}")
    print("joints: movable joints, <mimic> followers included; a floating-base robot is loaded with its root fixed")
    return 0


def register(sub: argparse._SubParsersAction[argparse.ArgumentParser]) -> None:
    """Add ``robots`` to the ``pincal`` subcommands."""
    parser = sub.add_parser("robots", help="list the robots known by name, their joints and files",
                            description="The robots a name reaches: pincal's own (robots_urdf/) and those of the "
                                        "installed example-robot-data, each loaded to count its movable joints "
                                        "(mimic followers included), actuated joints and loops.",
                            epilog="example: pincal robots")
    parser.set_defaults(func=cmd_robots)
