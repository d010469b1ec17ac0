"""``pincal import``: a ROS bag's static postures written as the measurement CSV a calibration reads (docs/bags.md)."""

from __future__ import annotations

import argparse

from pincal.cli.arguments import add_robot, positive_float
from pincal.errors import DataError

#: pincal.io.postures's STILL_TOLERANCE [rad or m], STILL_TIME [s] and DRIFT [m, rad], and pincal.io.bags's TF_TOPIC,
#: spelled here so that parsing imports no NumPy (tests/cli/test_bag_import.py holds them equal).
STILL_TOLERANCE = 1e-3
STILL_TIME = 1.0
DRIFT = 1e-3
TF_TOPIC = "/tf"


def cmd_import(args: argparse.Namespace) -> int:
    """``pincal import``: find the bag's static postures, print each (kept, or dropped and why) and write the kept
    ones as a dataset CSV (docs/dataset.md), the table in its header."""
    from pincal.io.bag_dataset import bag_dataset
    from pincal.io.bags import MeasurementSource
    from pincal.io.dataset import write_dataset
    from pincal.io.files import check_outputs
    from pincal.io.postures import StillRule
    from pincal.model.robot import load_robot

    check_outputs([("--out", args.out)], [args.bag])
    robot = load_robot(args.robot)
    if args.pose:
        source = MeasurementSource("pose", args.pose)
    elif args.point:
        source = MeasurementSource("point", args.point)
    else:
        source = MeasurementSource("tf", args.tf_topic, *args.tf)
    rule = StillRule(args.still_tolerance, args.still_time, args.drift)
    done = bag_dataset(robot, args.bag, args.joints, source, args.frame, rule, progress=not args.quiet)
    from pincal.calibration.summary import robot_named

    print(f"{args.bag}: joints from {args.joints} ({len(done.joints)} of '{robot_named(args.robot, robot.name)}'"
          + (f"; not read: {', '.join(done.extra)}" if done.extra else "") + f"), {done.key} from "
          f"{source.describe()}")
    if done.absent:
        print(f"  not on {args.joints}: {', '.join(done.absent)} (they move no measured frame: calibrate takes them at "
              "their reference value)")
    print(f"postures (joints within {rule.tolerance:g} rad or m for {rule.time:g} s or more):")
    for posture in done.postures:
        print(f"  {posture.sample_id:>5}  {posture.line()}")
    kept = sum(p.kept for p in done.postures)
    print(f"kept {kept} of {len(done.postures)}")
    if not kept:
        raise DataError(f"no posture of '{args.bag}' kept; nothing written (the table above says why each was "
                        "dropped)")
    write_dataset(done.dataset, args.out)
    print(f"wrote {args.out} ({kept} samples; the table as '# posture' lines of its header)")
    return 0


def register(sub: argparse._SubParsersAction[argparse.ArgumentParser]) -> None:
    """Add ``import`` to the ``pincal`` subcommands."""
    parser = sub.add_parser(
        "import", help="a ROS bag's static postures as a measurement CSV",
        description="Read a ROS 1 bag, a ROS 2 bag (directory, sqlite3 or mcap) or an .mcap file without ROS: the "
                    "joint states (sensor_msgs/JointState, joints mapped by name onto the robot's actuated joints, "
                    "extra ones ignored) and one measurement (--pose, --tf or --point). Find the static postures "
                    "(every joint within --still-tolerance for --still-time or more), average each (joints, "
                    "position, orientation), and write the kept ones as a measurement CSV (docs/dataset.md); every "
                    "posture is printed, kept or dropped with its reason, and recorded in the CSV's header "
                    "(docs/bags.md). Times: header stamps when set, else the bag's.",
        epilog="example: pincal import ur10 run.bag --joints /joint_states --pose /mocap/tool --frame tool0 "
               "--out data.csv; then pincal calibrate ur10 data.csv")
    add_robot(parser)
    parser.add_argument("bag", help="the bag: a ROS 1 .bag, a ROS 2 bag directory, or an .mcap file")
    parser.add_argument("--joints", required=True, metavar="TOPIC",
                        help="the joint-state topic (sensor_msgs/JointState), e.g. /joint_states")
    what = parser.add_mutually_exclusive_group(required=True)
    what.add_argument("--pose", metavar="TOPIC", help="the measurement: a geometry_msgs/PoseStamped topic (a "
                                                      "motion-capture rigid body): pose:FRAME columns")
    what.add_argument("--tf", nargs=2, metavar=("PARENT", "CHILD"),
                      help="the measurement: the transform PARENT -> CHILD of tf2_msgs/TFMessage (on --tf-topic): "
                           "pose:FRAME columns")
    what.add_argument("--point", metavar="TOPIC", help="the measurement: a geometry_msgs/PointStamped topic (one "
                                                       "marker): position:FRAME columns, its offset estimated")
    parser.add_argument("--tf-topic", default=TF_TOPIC, metavar="TOPIC",
                        help=f"with --tf: the topic (default {TF_TOPIC})")
    parser.add_argument("--frame", help="the robot frame the measurement follows (default: the robot's measured frame, "
                                        "as pincal info prints it)")
    parser.add_argument("--out", required=True, help="the measurement CSV to write")
    parser.add_argument("--still-tolerance", type=positive_float, default=STILL_TOLERANCE, metavar="TOL",
                        help="a posture: every joint's readings within a band this wide (max - min) [rad or m] "
                             f"(default {STILL_TOLERANCE:g})")
    parser.add_argument("--still-time", type=positive_float, default=STILL_TIME, metavar="SECONDS",
                        help=f"a posture: the joints still for this long at least [s] (default {STILL_TIME:g}); a "
                             "stop of a fifth of it or more, but shorter, is listed as too short")
    parser.add_argument("--drift", type=positive_float, default=DRIFT,
                        help="largest change of the measurement between a posture's two halves [m; rad for an "
                             f"orientation] (default {DRIFT:g}); more: dropped as moving")
    parser.add_argument("--quiet", action="store_true", help="no progress bar (it is shown only on a terminal, one per "
                                                             "topic read)")
    parser.set_defaults(func=cmd_import)
