"""Measurement kinds: one class per sensor, each owning its maths and its data (:mod:`.base`).

The kinds register themselves in the order their modules are imported here (the order the messages list them).
"""

from pincal.identification.measurements.base import (
    KIND_CLASSES,
    KINDS,
    MARKER_NAME,
    PLACEMENT_COMPONENTS,
    QUATERNION,
    Attachment,
    KeyParser,
    Measurement,
    NominalReadings,
    StartPlacements,
    parse_key,
    point_derivative,
)
from pincal.identification.measurements.context import (
    WORLD_TARGET,
    AttachedPlacement,
    IntrinsicTerms,
    MarkerPoint,
    SampleContext,
    camera_name,
    split_target,
    target_name,
)

# isort: off
# the kinds register as their modules are first imported: in this order (not sorted), the order messages list them
from pincal.identification.measurements.positions import Position, position
from pincal.identification.measurements.poses import Pose, pose
from pincal.identification.measurements.camera import CameraPoint, CameraPose, camera_point, camera_pose
from pincal.identification.measurements.distances import Distance, distance
from pincal.identification.measurements.joint import JointReading, joint_reading
from pincal.identification.measurements.planes import (
    PLANE,
    PLANE_COMPONENTS,
    PlaneContact,
    PlanePoint,
    plane_contact,
    plane_name,
    plane_point,
)
from pincal.identification.measurements.pixels import (
    BOARD_DEFAULT,
    INTRINSICS,
    Board,
    BoardPixel,
    Pixel,
    intrinsics_name,
    parse_board,
    pixel,
    project,
)
from pincal.identification.measurements.cross_pixels import CrossPixel, cross_pixel
# isort: on

__all__ = [
    "BOARD_DEFAULT",
    "INTRINSICS",
    "KINDS",
    "KIND_CLASSES",
    "MARKER_NAME",
    "PLACEMENT_COMPONENTS",
    "PLANE",
    "PLANE_COMPONENTS",
    "QUATERNION",
    "WORLD_TARGET",
    "AttachedPlacement",
    "Attachment",
    "Board",
    "BoardPixel",
    "CameraPoint",
    "CameraPose",
    "CrossPixel",
    "Distance",
    "IntrinsicTerms",
    "JointReading",
    "KeyParser",
    "MarkerPoint",
    "Measurement",
    "NominalReadings",
    "Pixel",
    "PlaneContact",
    "PlanePoint",
    "Pose",
    "Position",
    "SampleContext",
    "StartPlacements",
    "camera_name",
    "camera_point",
    "camera_pose",
    "cross_pixel",
    "distance",
    "intrinsics_name",
    "joint_reading",
    "parse_board",
    "parse_key",
    "pixel",
    "plane_contact",
    "plane_name",
    "plane_point",
    "point_derivative",
    "pose",
    "position",
    "project",
    "split_target",
    "target_name",
]
