"""The detections CSV of ``pincal detect``: each image's board corners [px] paired with its joint readings by name.

An image pairs with the row of the joints CSV whose ``sample`` is the image file's stem (``0003.png`` with sample
``0003``). Images without a row, rows without an image, and the images :func:`~pincal.io.vision.detect_corners`
leaves out are named with the reason, never dropped silently. The result is a measurement CSV
(docs/dataset.md): the joint columns, then ``pixel:<frame>@<corner>:u|v`` (eye-in-hand) or
``board_pixel:<frame>@<corner>:u|v`` (eye-to-hand) or ``cross_pixel:<camera frame>-<board frame>@<corner>:u|v`` (a
camera on one chain, the board on another) for every corner seen at least once, empty where an image did
not show it; its metadata name the board (``# board: …``), the image size, and, from a camera file, the intrinsics
held (``# intrinsics <frame> held: …``).
"""

from __future__ import annotations

from collections.abc import Sequence
from dataclasses import field
from pathlib import Path

import numpy as np
import numpy.typing as npt

from pincal.errors import Culprit, DataError, listing
from pincal.identification.measurements import Board
from pincal.io.dataset import Dataset
from pincal.io.vision import Detections, intrinsics_text
from pincal.records import record

Array = npt.NDArray[np.float64]

#: The measurement kinds a detections file holds: a camera on the frame, a board on the frame, or a camera on one
#: frame and the board on another.
PIXEL_KINDS = ("pixel", "board_pixel", "cross_pixel")


@record
class Paired:
    """The detections paired with the joints.

    Attributes:
        dataset: The measurement CSV's content.
        left_out: Image or joint row -> why it is not in the dataset.
    """

    dataset: Dataset
    left_out: dict[str, str] = field(default_factory=dict)


def pixel_kind(measure: str) -> tuple[str, str]:
    """``(kind, frame)`` of ``pixel:<frame>``, ``board_pixel:<frame>`` or ``cross_pixel:<camera frame>-<board
    frame>`` (its frame the two joined by ``-``).

    Raises:
        DataError: another form.
    """
    kind, _, frame = measure.partition(":")
    pair = frame.split("-")
    if (kind not in PIXEL_KINDS or not frame or "@" in frame
            or (kind == "cross_pixel") != (len(pair) == 2) or not all(pair)):
        raise DataError(f"measure='{measure}' is not pixel:<frame> (a camera on the frame), "
                        "board_pixel:<frame> (a board on the frame, seen by a fixed camera) nor "
                        "cross_pixel:<camera frame>-<board frame> (a camera on one frame sees a board on another; "
                        "frame names without '-')", option="measure")
    if kind == "cross_pixel" and pair[0] == pair[1]:
        raise DataError(f"measure='{measure}': the camera and the board are on the same frame (nothing moves "
                        "between them): give two frames on different chains", option="measure")
    return kind, frame


def pixel_frames(kind: str, frame: str) -> list[str]:
    """The robot frames of :func:`pixel_kind`'s answer: its frame, or a ``cross_pixel``'s two."""
    return frame.split("-") if kind == "cross_pixel" else [frame]


def pair(detections: Detections, joints: Dataset, measure: str, board: Board,
         held: Sequence[float] | None = None, tolerance: float | None = None) -> Paired:
    """The measurement dataset of ``detections`` paired by name with the rows of ``joints``.

    Args:
        detections: The corners found.
        joints: The joint readings, one row per image (``sample`` the image's stem; a ``set`` column is kept).
        measure: ``pixel:<frame>``, ``board_pixel:<frame>`` or ``cross_pixel:<camera frame>-<board frame>``.
        board: The board the corners are of.
        held: Intrinsics to hold the camera at (from a camera file), or None: estimated.
        tolerance: Pair by time instead of by name (:func:`by_time`): the largest gap [s] between an image's time
            and its joint row's.

    Raises:
        DataError: no image pairs with a joint row, or ``measure`` is malformed.
    """
    kind, frame = pixel_kind(measure)
    if tolerance is not None:
        detections, joints = by_time(detections, joints, tolerance)
    left_out = dict(detections.left_out)
    rows = {sample: k for k, sample in enumerate(joints.sample_ids)}
    for stem in detections.corners:
        if stem not in rows:
            left_out[stem] = f"image '{stem}' has no row in the joints file (sample '{stem}')"
    kept = [k for k, sample in enumerate(joints.sample_ids) if sample in detections.corners]
    for sample in joints.sample_ids:
        if sample not in detections.corners and not any(_stem(p) == sample for p in detections.left_out):
            left_out[f"joints row {sample}"] = (f"no image named '{sample}'" if tolerance is None
                                                else "no image within the tolerance of its time")
    if not kept:
        why = "; ".join(f"{what}: {reason}" for what, reason in list(detections.left_out.items())[:3])
        more = len(detections.left_out) - 3
        raise DataError(f"no image pairs with a joint row by name (images: "
                        f"{listing(sorted(detections.corners)) or 'none kept'}; samples: "
                        f"{listing(joints.sample_ids[:8])})"
                        + (f"; left out {why}" if why else "") + (f" and {more} more" if more > 0 else ""))
    ids = sorted({int(i) for k in kept for i in detections.corners[joints.sample_ids[k]][0]})
    values = {f"{kind}:{frame}@{i}": np.full((len(kept), 2), np.nan) for i in ids}
    for r, k in enumerate(kept):
        corner_ids, uv = detections.corners[joints.sample_ids[k]]
        for i, point in zip(corner_ids.tolist(), uv, strict=True):
            values[f"{kind}:{frame}@{i}"][r] = point
    metadata = {**{key: value for key, value in joints.metadata.items() if key == "robot"}, "board": board.spec,
                "image size": f"{detections.size[0]} {detections.size[1]}"}
    if held is not None:
        camera = {"pixel": frame, "cross_pixel": frame.partition("-")[0]}.get(kind, "")
        metadata[f"intrinsics {camera}".strip() + " held"] = intrinsics_text(held)
    dataset = Dataset(list(joints.joint_names), joints.joints[kept], values,
                      [joints.sample_ids[k] for k in kept], [joints.sets[k] for k in kept], metadata)
    return Paired(dataset, left_out)


def _stem(path: str) -> str:
    """A file path's stem (``images/0003.png`` -> ``0003``)."""
    name = path.replace("\\", "/").rsplit("/", 1)[-1]
    return name.rsplit(".", 1)[0] if "." in name else name


#: The joints file's column of each row's time [s] when images are paired by time.
TIME = "time"


def is_bag(path: str) -> bool:
    """Whether ``path`` names a ROS bag (a ROS 1 ``.bag``, an ``.mcap`` file or a ROS 2 bag directory), not a CSV."""
    return Path(path).is_dir() or Path(path).suffix.lower() in (".bag", ".mcap", ".db3")


def bag_joints(path: str, topic: str, joints: Sequence[str]) -> Dataset:
    """The joint rows of a bag's joint-state messages on ``topic``, to pair images with by time: one row per message,
    a ``time`` column [s] (its header stamp, else its bag time) and the ``joints`` named (the robot's actuated
    joints) [rad or m]; each row named by its time.

    Raises:
        DataError: a joint no message carries, a message without one of them, or what reading the bag raises
            (:func:`~pincal.io.bags.read_joint_states`).
    """
    from pincal.io.bags import read_joint_states

    states = read_joint_states(path, topic)
    missing = [j for j in joints if j not in states.names]
    if missing:
        raise DataError(f"bag '{path}': the joint states on '{topic}' carry no {listing(missing)} (they carry "
                        f"{listing(states.names)})", column=missing[0], file=path)
    columns = [states.names.index(j) for j in joints]
    values = states.positions[:, columns]
    with Culprit(file=path):
        states.check_finite(list(joints), topic)
    lacking = np.flatnonzero(np.isnan(values).any(axis=1))
    if lacking.size:
        raise DataError(f"bag '{path}': the joint state on '{topic}' at {states.times[lacking[0]]:.3f} s lacks "
                        f"{listing([j for j, v in zip(joints, values[lacking[0]], strict=True) if np.isnan(v)])}"
                        f" ({lacking.size} messages lack a joint)", file=path, sample=f"{states.times[lacking[0]]:.6f}",
                        column=next(j for j, v in zip(joints, values[lacking[0]], strict=True) if np.isnan(v)))
    ids = [f"{t:.6f}" for t in states.times]
    ids = [s if ids.count(s) == 1 else f"{s}#{k}" for k, s in enumerate(ids)]
    return Dataset([TIME, *joints], np.column_stack([states.times, values]), {}, ids, ["train"] * len(ids), {})


def by_time(detections: Detections, joints: Dataset, tolerance: float) -> tuple[Detections, Dataset]:
    """The detections renamed after the joint rows they pair with by time, and the joints without their time column.

    Each image's name (its file's stem) is its time [s] (``1701950000.125.png``); it pairs with the joint row whose
    ``time`` column is nearest, if within ``tolerance`` [s]. An image whose name is not a time, with no row within
    the tolerance, or whose row is nearer another image, is left out with the reason.

    Raises:
        DataError: the joints file has no ``time`` column.
    """
    if TIME not in joints.joint_names:
        raise DataError(f"pairing by time needs a '{TIME}' column [s] in the joints file; its columns are "
                        f"{listing(joints.joint_names)}", column=TIME)
    column = joints.joint_names.index(TIME)
    times = joints.joints[:, column]
    left_out = dict(detections.left_out)
    nearest: dict[int, tuple[float, str]] = {}
    for stem in detections.corners:
        try:
            when = float(stem)
        except ValueError:
            left_out[stem] = f"image '{stem}': its name is not a time in seconds"
            continue
        row = int(np.argmin(np.abs(times - when)))
        gap = abs(float(times[row]) - when)
        if gap > tolerance:
            left_out[stem] = (f"image '{stem}': the nearest joint row ({joints.sample_ids[row]}) is {gap:.3g} s away, "
                              f"beyond the tolerance {tolerance:g} s")
            continue
        if row in nearest:
            other_gap, other = nearest[row]
            farther, nearer = (stem, other) if gap >= other_gap else (other, stem)
            left_out[farther] = (f"image '{farther}': joint row {joints.sample_ids[row]} pairs with the nearer image "
                                 f"'{nearer}'")
            if farther == stem:
                continue
        nearest[row] = (gap, stem)
    corners = {joints.sample_ids[row]: detections.corners[stem] for row, (_, stem) in nearest.items()}
    keep = [c for c in range(len(joints.joint_names)) if c != column]
    rest = Dataset([joints.joint_names[c] for c in keep], joints.joints[:, keep], {}, list(joints.sample_ids),
                   list(joints.sets), dict(joints.metadata))
    return Detections(corners, left_out, detections.size), rest
