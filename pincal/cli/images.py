"""``pincal detect`` (a ChArUco board's corners in images, paired with joint readings) and ``pincal simulate``'s
camera campaigns (``--measure pixel:FRAME`` or ``board_pixel:FRAME``, with ``--images``): argparse and printing."""

from __future__ import annotations

import argparse
from pathlib import Path
from typing import Any

from pincal.errors import DataError

BOARD_HELP = ("the board: charuco:COLSxROWS:SQUARE:MARKER:DICT (e.g. charuco:8x6:0.03:0.022:DICT_4X4_50, the default "
              "of simulate) or a grid of ArUco or AprilTag markers aruco:COLSxROWS:MARKER:SEPARATION:DICT (e.g. "
              "aruco:4x3:0.05:0.012:DICT_APRILTAG_36h11); lengths in metres")


def is_camera(measure: list[str]) -> bool:
    """Whether ``--measure`` asks for pixels (``pixel:FRAME``, ``board_pixel:FRAME``, ``cross_pixel:CAM-BOARD``)."""
    return any(m.partition(":")[0] in ("pixel", "board_pixel", "cross_pixel") for m in measure)


def add_camera_arguments(parser: argparse.ArgumentParser) -> None:
    """``--board`` and ``--images`` of ``pincal simulate``."""
    parser.add_argument("--board", help="with --measure pixel:FRAME or board_pixel:FRAME (--noise is then the corners' "
                                        "σ in px): " + BOARD_HELP)
    parser.add_argument("--images", help="with --measure pixel:FRAME or board_pixel:FRAME: render the images into "
                                         "this directory and write DIR/joints.csv (--out); measurements.csv then "
                                         "holds the exact corners")


#: The corners' noise σ [px] of a simulated camera campaign without --noise: sub-pixel corners of sharp images.
PIXEL_NOISE = 0.3


def shift_warnings(parameters: Any, shift: dict[str, float]) -> list[str]:
    """A warning for each ``--shift`` beyond the largest correction a robot of the model plausibly needs (its kind's
    ``plausible`` limit [m, rad]), which calibrate's checks of plausibility hold to."""
    out = []
    for p in parameters:
        limit = p.kind_class.plausible_limit(p.unit) if p.name in shift else None
        if limit is not None and abs(shift[p.name]) > limit:
            out.append(f"warning: --shift {p.name}={shift[p.name]:g} [{p.unit}] is beyond the {limit:.3g} {p.unit} a "
                       "robot of this model is plausibly off by (calibrate's limit, docs/calibrated_urdf.md): its data "
                       "are of a robot a calibration will not take as one of this model")
    return out


#: The file names taken for images in an --images folder (lower case).
IMAGE_SUFFIXES = (".png", ".jpg", ".jpeg", ".bmp", ".tif", ".tiff")


def simulate_camera(args: argparse.Namespace, robot: Any) -> int:
    """``pincal simulate ROBOT --measure pixel:FRAME``: a simulated camera campaign (its images with
    ``--images``)."""
    from pincal.calibration.campaign import simulation_outputs, write_simulation
    from pincal.calibration.pixel_campaign import camera_outputs, simulate_pixels, write_images
    from pincal.identification.measurements import BOARD_DEFAULT
    from pincal.io.detections import pixel_frames, pixel_kind

    if len(args.measure) != 1:
        raise DataError(f"--measure {' '.join(args.measure)}: a camera simulation measures one pixel:FRAME or "
                        "board_pixel:FRAME alone")
    kind, frame = pixel_kind(args.measure[0])
    frames = pixel_frames(kind, frame)
    ignored = [flag for flag, value in (("--frame", args.frame), ("--posture-seed", args.posture_seed),
                                        ("--shift", args.shift), ("--spread", args.spread),
                                        ("--parameters", args.parameters), ("--payload", args.payload))
               if value is not None]
    if ignored:
        raise DataError(f"{', '.join(ignored)}: not taken by a camera simulation (--measure {args.measure[0]}), "
                        "which draws its own robot errors, postures and camera; leave "
                        f"{'them' if len(ignored) > 1 else 'it'} out")
    for name in frames:
        robot.frame_id(name, "--measure: ")
    out = Path(args.out)
    simulation_outputs(robot, out, args.meshes)
    if args.images is not None:
        from pincal.io.vision import opencv

        opencv()  # before any work: images need OpenCV
        camera_outputs(out, Path(args.images))
    noise = 0.0 if args.images is not None else args.noise
    if kind == "cross_pixel":
        from pincal.calibration.cross_campaign import simulate_cross_pixels

        sim = simulate_cross_pixels(robot, frames[0], frames[1], args.samples, args.test_samples,
                                    board=args.board or BOARD_DEFAULT, perturb=args.perturb, noise=noise,
                                    seed=args.seed)
    else:
        sim = simulate_pixels(robot, frame, args.samples, args.test_samples, eye_to_hand=kind == "board_pixel",
                              board=args.board or BOARD_DEFAULT, perturb=args.perturb, noise=noise, seed=args.seed)
    paths = write_simulation(sim, out, args.meshes, given=args.robot)
    notes = []
    if args.images is not None:
        images = Path(args.images)  # made when the images are written (a refused command makes none)
        before = {p.name for p in images.iterdir() if p.is_file()} if images.is_dir() else set()
        paths += write_images(sim, out, Path(args.images), args.seed)
        written = {p.name for p in paths if p.parent == Path(args.images)}
        if before & written:
            notes.append(f"note: replaced {len(before & written)} existing images in {args.images}/")
        stale = sorted(name for name in before - written if name.lower().endswith(IMAGE_SUFFIXES))
        if stale:
            notes.append(f"warning: {args.images}/ holds {len(stale)} other images ({', '.join(stale[:3])}"
                         f"{', …' if len(stale) > 3 else ''}) from before, not of this simulation: 'pincal detect "
                         f"{args.images}/*' would read them too")
    seen = sum(int((v[:, 0] == v[:, 0]).sum()) for v in sim.dataset.measurements.values())
    where = {"board_pixel": f"fixed in the cell, the board on '{frame}'",
             "cross_pixel": f"on '{frames[0]}', the board on '{frames[-1]}'"}.get(kind, f"on '{frame}'")
    print(f"simulated {args.samples} + {args.test_samples} images of board {sim.board.spec if sim.board else ''} "
          f"seen by a camera {where} of "
          f"'{robot.name}', with robot errors of σ {args.perturb:g} (m, rad); {seen} corners seen, pixel noise σ "
          f"{noise:g} px")
    for path in paths[:4]:
        print(f"wrote {path}")
    if len(paths) > 4:
        print(f"wrote {len(paths) - 4} images into {args.images}/")
    for note in notes:
        print(note)
    return 0


def cmd_detect(args: argparse.Namespace) -> int:
    """``pincal detect``: the board's corners in each image, paired with the joint readings by name."""
    from pincal.identification.measurements import parse_board
    from pincal.io.dataset import dataset_text
    from pincal.io.dataset_reader import read_dataset
    from pincal.io.detections import bag_joints, is_bag, pair, pixel_frames, pixel_kind
    from pincal.io.files import check_outputs, write_texts
    from pincal.io.vision import detect_corners, opencv, read_camera_file

    board = parse_board(args.board)
    frames = pixel_frames(*pixel_kind(args.measure))
    inputs = [*args.images, args.joints, *([args.camera_file] if args.camera_file else [])]
    check_outputs([("--out", args.out)], inputs)
    from pincal.model.robot import load_robot

    if is_bag(args.joints):  # joint states streamed while the images were taken: paired by time
        if args.pair != "time" or not args.robot:
            raise DataError(f"--joints '{args.joints}' is a ROS bag: its joint states pair with the images by time "
                            "and are read by the robot's joint names: give --pair time and --robot ROBOT")
        joints = bag_joints(args.joints, args.joints_topic, load_robot(args.robot).actuated_joints)
        joints.metadata["robot"] = args.robot
    else:
        joints = read_dataset(args.joints)
    robot = args.robot or joints.metadata.get("robot")
    if robot:  # the frames named, before any work
        for frame in frames:
            load_robot(robot).frame_id(frame, "--measure: ")
    else:
        print(f"note: frame '{'-'.join(frames)}' not checked: the joints file names no robot ('# robot: …'); "
              "give --robot ROBOT")
    opencv()
    held = read_camera_file(args.camera_file) if args.camera_file else None
    detections = detect_corners(args.images, board, args.min_corners, args.min_sharpness)
    paired = pair(detections, joints, args.measure, board, held, args.tolerance if args.pair == "time" else None)
    left_out = paired.left_out
    if is_bag(args.joints):  # a stream: most joint states were taken between images, none is missing
        left_out = {what: why for what, why in left_out.items() if not what.startswith("joints row ")}
        print(f"paired {paired.dataset.n_samples} of the bag's {joints.n_samples} joint states on "
              f"'{args.joints_topic}' with images (within {args.tolerance:g} s)")
    for what, why in left_out.items():
        print(f"left out {what}: {why}")
    write_texts([(args.out, dataset_text(paired.dataset))])
    data = paired.dataset
    corners = sum(int((v[:, 0] == v[:, 0]).sum()) for v in data.measurements.values())
    print(f"detected {corners} corners in {data.n_samples} of {len(args.images)} images "
          f"({len(left_out)} left out); wrote {args.out}")
    return 0


def register(sub: Any) -> None:
    """Add ``pincal detect`` to the subcommands."""
    from pincal.cli.arguments import non_negative_float, positive_int

    det = sub.add_parser("detect", help="find a calibration board's corners in images; write a measurement CSV",
                         description="Detect the board's corners (OpenCV's aruco module: pip install "
                                     "\"pincal[vision]\") in each image, pair each image with the row of the joints "
                                     "CSV whose sample is the image's file name without its extension, and write "
                                     "the pixels as a measurement CSV for pincal calibrate. Images unpaired, "
                                     "duplicated, blurred or with too few corners are named and left out.",
                         epilog="example: pincal detect images/*.png --board charuco:8x6:0.03:0.022:DICT_4X4_50 "
                                "--joints joints.csv --measure pixel:tool0 --out detections.csv")
    det.add_argument("images", nargs="+", help="image files (PNG, JPEG, …)")
    det.add_argument("--board", required=True, help=BOARD_HELP)
    det.add_argument("--joints", required=True, help="CSV of joint readings: sample (the image's name), optional "
                                                     "set, one column per joint [rad or m]; or a ROS bag (.bag, "
                                                     ".mcap, a ROS 2 bag directory) whose joint states pair with the "
                                                     "images by time (--pair time, --robot)")
    det.add_argument("--joints-topic", default="/joint_states",
                     help="with a bag: the sensor_msgs/JointState topic (default /joint_states)")
    det.add_argument("--measure", required=True, help="pixel:FRAME (the camera on FRAME, the board fixed in the "
                                                      "cell) or board_pixel:FRAME (the board on FRAME, the camera "
                                                      "fixed)")
    det.add_argument("--robot", help="the robot (URDF or known name) whose frame --measure names, checked before any "
                                     "work (default: the joints file's '# robot:' line)")
    det.add_argument("--pair", choices=("name", "time"), default="name",
                     help="pair each image with the joint row of its name (default), or of its time: the image's name "
                          "is its time [s], the joints file's 'time' column the rows' (nearest within --tolerance)")
    det.add_argument("--tolerance", type=non_negative_float, default=0.05,
                     help="with --pair time: the largest gap [s] between an image and its joint row (default 0.05)")
    det.add_argument("--camera-file", help="hold the intrinsics at an OpenCV calibration file's (YAML/XML) or a ROS "
                                           "camera_info YAML's (default: estimated with the robot)")
    det.add_argument("--min-corners", type=positive_int, default=6, help="fewest corners an image must show "
                                                                         "(default 6)")
    det.add_argument("--min-sharpness", type=non_negative_float, default=30.0,
                     help="least variance of an image's Laplacian [grey levels²]: below it an image is blurred and "
                          "left out (default 30)")
    det.add_argument("--out", required=True, help="the detections CSV to write")
    det.set_defaults(func=cmd_detect)
