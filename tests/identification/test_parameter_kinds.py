"""Parameter kinds are classes in one registry, each owning what differs: where it acts, its names and units, its
selection group, and whether a calibrated URDF or the corrections file holds it."""

from __future__ import annotations

import pytest

import pincal
from pincal.errors import NotFoundError
from pincal.identification import measurements as ms
from pincal.identification.parameters import (
    PARAMETER_KINDS,
    CameraPlacement,
    Compliance,
    JointPlacement,
    ParameterKind,
    ParameterSet,
    PlanePlacement,
    ReadingOffset,
    TargetPlacement,
    choose_parameters,
    compliance_parameter,
    harmonic_parameters,
    kinds_where,
    offset_parameter,
    parameter_kind,
    parameter_pool,
    placement_parameters,
)
from pincal.identification.selection import group_of


def test_the_registry_holds_every_kind_in_the_order_they_were_declared() -> None:
    assert list(PARAMETER_KINDS) == ["joint", "anchor", "offset", "base", "marker", "cluster", "camera", "target",
                                     "plane", "intrinsics", "harmonic", "compliance"]
    assert all(kind.name == name for name, kind in PARAMETER_KINDS.items())


def test_kinds_say_where_they_act_and_where_a_calibration_writes_them() -> None:
    assert kinds_where(kinematic=True) == ("joint", "anchor")
    assert kinds_where(in_corrections=True) == ("harmonic", "compliance")
    # what the calibrated URDF holds, listed in its refusal of a kind it cannot hold
    assert kinds_where(in_urdf=True) == ("joint", "anchor", "offset", "base", "marker", "cluster", "camera", "target",
                                         "plane")
    assert {name for name, kind in PARAMETER_KINDS.items() if kind.acts_in == "reading"} == {
        "offset", "harmonic", "compliance"}
    assert [name for name, kind in PARAMETER_KINDS.items() if kind.in_report] == ["intrinsics"]


def test_a_kind_names_and_measures_its_parameters() -> None:
    assert [p.name for p in placement_parameters("anchor", "leg_1", "successor", ["tx", "rz"])] == [
        "leg_1.successor.tx", "leg_1.successor.rz"]
    assert [p.unit for p in placement_parameters("camera", "tool0", components=["tz", "rx"])] == ["m", "rad"]
    assert placement_parameters("camera", "tool0")[0].name == "camera.tool0.tx"
    assert placement_parameters("target", "")[0].name == "target.tx"
    assert placement_parameters("target", "tool0@t1")[0].name == "target.tool0@t1.tx"
    assert placement_parameters("base", "base")[5].name == "base.rz"
    assert offset_parameter("slider", "m").unit == "m" and compliance_parameter("slider", "m").unit == "m/N"
    assert compliance_parameter("elbow", "rad").unit == "rad/(N m)"
    assert parameter_kind("cluster").prefix("tool0") == "cluster.tool0"


def test_selection_groups_come_from_the_kinds() -> None:
    robot = pincal.load_robot("ur10")
    pool = parameter_pool(robot, [ms.position("tool0")])
    groups = {p.name: group_of(p) for p in pool}
    assert groups["shoulder_lift_joint.tx"] == "translations" and groups["shoulder_lift_joint.ry"] == "rotations"
    assert groups["elbow_joint.offset"] == "offsets" and groups["elbow_joint.sin1"] == "harmonics"
    assert groups["elbow_joint.compliance"] == "compliance"
    assert groups["base.tx"] is None and groups["marker.tool0.x"] is None
    assert [group_of(p) for p in harmonic_parameters("elbow_joint", "rad", 1)] == ["harmonics"] * 2


def test_an_unknown_kind_is_refused_listing_the_kinds() -> None:
    with pytest.raises(NotFoundError, match=r"parameter kind 'tilt' does not exist.*joint, anchor, offset"):
        parameter_kind("tilt")
    with pytest.raises(NotFoundError, match="parameter kind 'tilt'"):
        placement_parameters("tilt", "elbow_joint")


def test_a_new_kind_is_one_class_that_registers_itself() -> None:
    class Scale(ParameterKind):
        """``scale.<device>``: a device's scale factor error (dimensionless, written as a length here)."""

        name = "scale"

        @classmethod
        def prefix(cls, target: str, side: str = "") -> str:
            return f"scale.{target}"

    try:
        assert PARAMETER_KINDS["scale"] is Scale and "scale" not in kinds_where(in_urdf=True)
        param = placement_parameters("scale", "lvdt", components=["tx"])[0]
        assert (param.name, param.kind_class, group_of(param)) == ("scale.lvdt.tx", Scale, None)
        robot = pincal.load_robot("ur10")
        pset = ParameterSet([*choose_parameters(robot, [ms.position("tool0")]), param])
        assert pset.of_kind("scale") == [len(pset) - 1]
    finally:
        PARAMETER_KINDS.pop("scale", None)


def test_a_parameter_is_asked_its_kind_by_class() -> None:
    offset = offset_parameter("joint1", "rad")
    assert offset.is_a(ReadingOffset) and offset.is_a(ParameterKind)
    assert not offset.is_a(Compliance) and compliance_parameter("joint1", "rad").is_a(Compliance)
    assert all(p.is_a(JointPlacement) for p in placement_parameters("joint", "joint1"))


def test_attached_kinds_name_their_calibrated_urdf_links() -> None:
    assert CameraPlacement.urdf_link("tool0") == "tool0_camera"
    assert TargetPlacement.urdf_link("") == "camera_target"
    assert TargetPlacement.urdf_link("tool0@board") == "tool0_target_board"
    assert PlanePlacement.urdf_link("") == "contact_plane" and PlanePlacement.urdf_link("sole") == "sole_plane"
    with pytest.raises(TypeError, match="offset parameters"):
        ReadingOffset.urdf_link("joint1")


def test_the_setup_is_named_by_its_kinds_words_in_their_order() -> None:
    """``check`` and the report name the setup by the words of the kinds it holds: each once, in the order the kinds
    are declared (the measurement frame first), whatever the parameters' order."""
    from pincal.identification.parameters import setup_phrase

    assert setup_phrase(["plane", "marker", "base", "cluster", "marker"]) == (
        "measurement frame, markers and contact planes")
    assert setup_phrase(["camera"]) == "cameras" and setup_phrase([]) == "nothing"
