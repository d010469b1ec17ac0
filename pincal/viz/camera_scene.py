"""The 3D scene's cameras read from pixels: each calibrated camera as its frustum (the pyramid its image sees, from
its intrinsics) and the board it saw as its outline, where the calibration placed them, moving with the robot where
they ride on it. Lengths in m; the scene is in the measurement frame.
"""

from __future__ import annotations

from typing import Any

import numpy as np
import numpy.typing as npt
import pinocchio as pin

from pincal.identification.measurements.cross_pixels import CrossPixel
from pincal.identification.measurements.pixels import BoardPixel, Pixel, parse_board

Array = npt.NDArray[np.float64]

#: The frustum's and the board's colours.
CAMERA_COLOR = 0x7d3c98
BOARD_COLOR = 0x2e4053


def frustum(intrinsics: dict[str, float], depth: float) -> Array:
    """(16, 3) the end points of the frustum's 8 segments [m] in the camera's frame (z forward): the apex to each
    corner of the image at ``depth`` [m], and the image's outline there (an image of ``2 cx × 2 cy`` px)."""
    fx, fy, cx, cy = (intrinsics[c] for c in ("fx", "fy", "cx", "cy"))
    corners = [np.array([(u - cx) / fx * depth, (v - cy) / fy * depth, depth])
               for u, v in ((0.0, 0.0), (2 * cx, 0.0), (2 * cx, 2 * cy), (0.0, 2 * cy))]
    segments = [p for c in corners for p in (np.zeros(3), c)]
    segments += [p for k in range(4) for p in (corners[k], corners[(k + 1) % 4])]
    return np.array(segments)


def outline(spec: str) -> Array:
    """(8, 3) the end points of the board's outline [m] in its frame (z = 0)."""
    width, height = parse_board(spec).extent
    corners = [np.array(c) for c in ((0.0, 0.0, 0.0), (width, 0.0, 0.0), (width, height, 0.0), (0.0, height, 0.0))]
    return np.array([p for k in range(4) for p in (corners[k], corners[(k + 1) % 4])])


def _attached(view: Any, kind: str, owner: str) -> Array:
    """The calibrated placement (4 × 4) of a camera or target group: ``exp6(δ)`` (the identity without one)."""
    parameters = view.problem.parameters
    indices = parameters.groups(kind).get((kind, owner, ""), [])
    return np.asarray(pin.exp6(parameters.placement_delta(view.x, indices)).homogeneous, dtype=float)


def _frame_poses(robot: Any, qs: Array, frame: str, base: Array) -> Array:
    """(N, 4, 4) ``frame``'s placement at each configuration, in the measurement frame."""
    data, fid = robot.model.createData(), robot.frame_id(frame)
    out = np.empty((len(qs), 4, 4))
    for k, q in enumerate(qs):
        pin.forwardKinematics(robot.model, data, q)
        out[k] = base @ pin.updateFramePlacement(robot.model, data, fid).homogeneous
    return out


def camera_placements(view: Any, calibrated: Any, q: Array, base: Array) -> list[tuple[str, Array, Array, int]]:
    """What to draw of each camera: ``(name, segments (M, 3) [m] in its own frame, placements (N or 1, 4, 4) in the
    measurement frame, colour)``: its frustum (a tenth of a metre deep) and its board."""
    cameras = view.report.cameras or {}
    out: list[tuple[str, Array, Array, int]] = []
    done: set[str] = set()
    for m in view.problem.measurements:
        if not isinstance(m, Pixel) or m.board is None or m.frame in done:
            continue
        done.add(m.frame)
        record = cameras.get(f"intrinsics.{m.frame}" if not isinstance(m, BoardPixel) else "intrinsics")
        intrinsics = record.intrinsics if record is not None else None
        board = outline(m.board.spec)
        if isinstance(m, BoardPixel):  # the camera is the measurement frame; the board rides on the frame
            camera = np.eye(4)[None]  # the scene's own frame
            boards = _frame_poses(calibrated, q, m.frame, base) @ _attached(view, "target", f"{m.frame}@board")
        else:  # the camera rides on the frame; the board is fixed in the robot's world, or on another frame
            camera = _frame_poses(calibrated, q, m.frame, base) @ _attached(view, "camera", m.frame)
            if isinstance(m, CrossPixel):
                boards = (_frame_poses(calibrated, q, m.board_frame, base)
                          @ _attached(view, "target", f"{m.board_frame}@board"))
            else:
                boards = (base @ _attached(view, "target", ""))[None]
        name = m.frame.replace("/", "_")
        if intrinsics:
            out.append((f"{name}_frustum", frustum(intrinsics, 0.1), camera, CAMERA_COLOR))
        out.append((f"{name}_board", board, boards, BOARD_COLOR))
    return out


def draw_cameras(node: Any, drawings: list[tuple[str, Array, Array, int]]) -> dict[str, Array]:
    """Draw ``drawings`` (:func:`camera_placements`) under ``node`` at the first sample; return the moving ones'
    placements (name → (N, 4, 4)) for the animation."""
    import meshcat.geometry as mg

    moving = {}
    for name, segments, placements, color in drawings:
        node[name].set_object(mg.LineSegments(mg.PointsGeometry(segments.T.astype(np.float32)),
                                              mg.LineBasicMaterial(color=color)))
        node[name].set_transform(placements[0])
        if len(placements) > 1 and np.ptp(placements, axis=0).max() > 1e-12:
            moving[name] = placements
    return moving
