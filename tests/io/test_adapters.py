"""Dataset columns to measurement models: σ per channel and the markers the data declare."""

from __future__ import annotations

import pytest

import pincal
from pincal.errors import DataError
from pincal.identification.measurements import Position
from pincal.io.adapters import declared_marker_offsets, measurements_for

KEYS = ["position:tool0@m1", "position:tool0@m2", "position:tool0"]


def test_declared_markers_take_their_nominal_offsets_and_sigma() -> None:
    robot = pincal.load_robot("ur10")
    metadata = {"marker m1 on tool0": "0.01 0 0.05", "marker m2 on tool0": "-0.02, 0.03, 0",
                "sigma position tool0@m2": "2e-4", "sigma position": "1e-3"}
    models = measurements_for(robot, KEYS, list(robot.actuated_joints), metadata=metadata)
    assert all(isinstance(m, Position) for m in models)
    m1, m2, origin = models
    assert (m1.frame, m1.marker, m1.marker_key) == ("tool0", "m1", "tool0@m1")
    assert (m1.nominal, m1.sigma) == ((0.01, 0.0, 0.05), 1e-3)
    assert (m2.nominal, m2.sigma) == ((-0.02, 0.03, 0.0), 2e-4)
    assert (origin.marker, origin.marker_key, origin.nominal) == ("", "tool0", None)


@pytest.mark.parametrize(("metadata", "message"), [
    ({"marker m3 on tool0": "0 0 0"}, r"metadata 'marker m3 on tool0' declares a marker the data have no columns for "
                                      r"\(no position:tool0@m3:x\|y\|z\); markers measured: tool0@m1, tool0@m2"),
    ({"marker m1 tool0": "0 0 0"}, r"metadata 'marker m1 tool0' is not '# marker <marker> on <frame>: x y z'"),
    ({"marker m-1 on tool0": "0 0 0"}, r"metadata 'marker m-1 on tool0' is not '# marker <marker> on <frame>"),
    ({"marker m1 on tool0": "0 0"}, r"metadata 'marker m1 on tool0' is '0 0'; a marker's nominal offset is three "
                                    r"numbers x y z \[m\] in its frame"),
    ({"marker m1 on tool0": "0 nan 0"}, r"is '0 nan 0'; a marker's nominal offset is three numbers"),
    ({"marker m1 on tool0": "10 0 50"}, r"metadata 'marker m1 on tool0': 10 0 50 looks like millimetres"),
])
def test_a_wrong_marker_declaration_is_named(metadata: dict[str, str], message: str) -> None:
    robot = pincal.load_robot("ur10")
    with pytest.raises(DataError, match=message):
        measurements_for(robot, KEYS, list(robot.actuated_joints), metadata=metadata)


def test_metadata_without_markers_declares_none() -> None:
    assert declared_marker_offsets({"robot": "ur10", "markers": "see the lab book"}) == {}
