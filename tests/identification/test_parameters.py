"""Dataset-to-problem plumbing: per-channel σ from metadata, parameter choice, report fields."""

from __future__ import annotations

import pytest

import pincal
from pincal.errors import DataError, NotFoundError
from pincal.identification.measurements import JointReading, Pose
from pincal.identification.parameters import choose_parameters
from pincal.io.adapters import channel_sigma, measurements_for


def test_channel_sigma_from_metadata() -> None:
    meta = {"sigma position end_effector": "2e-5", "sigma pose": "3e-5", "sigma pose angle": "1e-4",
            "sigma joint device_lvdt": "1e-6"}
    assert channel_sigma("position:end_effector", meta, None) == 2e-5
    assert channel_sigma("pose:tool0", meta, None) == 3e-5
    assert channel_sigma("pose:tool0", meta, None, angle=True) == 1e-4
    assert channel_sigma("distance:a-b", meta, 7e-6) == 7e-6
    with pytest.raises(DataError, match="'sigma position' is 'abc', not a number"):
        channel_sigma("position:x", {"sigma position": "abc"}, None)
    with pytest.raises(DataError, match="must lie between 1e-15 and 1e3"):
        channel_sigma("position:x", {"sigma position": "-1"}, None)


def test_measurements_for_weights_each_channel() -> None:
    robot = pincal.load_robot("hexapod_device")
    meta = {"sigma pose": "1e-5", "sigma pose angle": "2e-5", "sigma joint device_lvdt": "3e-6"}
    models = measurements_for(robot, ["pose:end_effector"], [*robot.actuated_joints, "device_lvdt"], None, meta)
    pose = next(m for m in models if isinstance(m, Pose))
    lvdt = next(m for m in models if isinstance(m, JointReading))
    assert (pose.sigma, pose.sigma_angle, lvdt.sigma) == (1e-5, 2e-5, 3e-6)
    # an explicit σ overrides the metadata
    models = measurements_for(robot, ["pose:end_effector"], ["device_lvdt"], 5e-5, meta)
    assert {m.sigma for m in models} == {5e-5}
    with pytest.raises(DataError, match="column 'device_lvdtt' is not a joint"):
        measurements_for(robot, [], ["device_lvdtt"])


def test_parameter_choice_named_patterns_and_default() -> None:
    robot = pincal.load_robot("delta")
    models = measurements_for(robot, ["position:end_effector"], robot.actuated_joints)
    assert len(choose_parameters(robot, models, ["model24"])) == 24
    offsets = choose_parameters(robot, models, ["*.offset"])
    assert offsets.names == ["arm_1_joint.offset", "arm_2_joint.offset", "arm_3_joint.offset"]
    everything = choose_parameters(robot, models)
    assert "base.tx" in everything and "leg_1_platform.predecessor.tz" in everything
    with pytest.raises(NotFoundError, match=r"pattern 'leg_9_\*' matches nothing"):
        choose_parameters(robot, models, ["leg_9_*"])


def test_simulated_noise_per_measurement() -> None:
    import numpy as np

    from pincal.identification import measurements as ms
    from pincal.study.simulation import random_actuated, simulate_observations

    robot = pincal.load_robot("hexapod_device")
    models = [ms.joint_reading("device_lvdt"), ms.joint_reading("device_incl_x")]
    pset = choose_parameters(robot, models, ["hexapod44"])
    rng = np.random.default_rng(0)
    qa, _ = random_actuated(robot, 200, rng)
    clean = simulate_observations(robot, pset, np.zeros(len(pset)), models, qa, np.random.default_rng(1))
    noisy = simulate_observations(robot, pset, np.zeros(len(pset)), models, qa, np.random.default_rng(1),
                                  noise={"joint:device_lvdt": 1e-6, "joint:device_incl_x": 1e-4})
    lvdt = noisy.values["joint:device_lvdt"] - clean.values["joint:device_lvdt"]
    incl = noisy.values["joint:device_incl_x"] - clean.values["joint:device_incl_x"]
    assert 0.7e-6 < lvdt.std() < 1.3e-6 and 0.7e-4 < incl.std() < 1.3e-4
    with pytest.raises(DataError, match="noise given for joint:device_rotary, which is not measured"):
        simulate_observations(robot, pset, np.zeros(len(pset)), models, qa, rng, noise={"joint:device_rotary": 1.0})


@pytest.mark.parametrize(("name", "frame"), [("delta", "end_effector"), ("hexapod_device", "end_effector"),
                                              ("ur10", "tool0")])
def test_written_urdf_reproduces_the_calibrated_model(name: str, frame: str) -> None:
    """Load the calibrated URDF back: FK equals the calibrated model's (offsets folded in) to 1e-12."""
    import numpy as np

    from pincal.identification import measurements as ms
    from pincal.identification.problem import CalibrationProblem, Observations
    from pincal.io.calibrated_urdf import calibrated_robot_text, source_text
    from pincal.model.robot import robot_from_urdf_text
    from pincal.study.simulation import perturbation, random_actuated

    robot = pincal.load_robot(name)
    models = [ms.position(frame)]
    pset = choose_parameters(robot, models)
    pset = pset.select(["!base.*"]) if "base.tx" in pset else pset  # the base is the tracker's, not in the URDF
    rng = np.random.default_rng(3)
    x = perturbation(pset, 1e-3, rng)
    qa, _ = random_actuated(robot, 10, rng)
    problem = CalibrationProblem(robot, pset, models, Observations(qa, {f"position:{frame}": np.zeros((10, 3))}))
    calibrated = problem.robot_at(x)
    readings_true = problem.actuated_values(x)  # readings + calibrated offsets
    text, _ = calibrated_robot_text(robot, source_text(robot), pset, x)
    reloaded = robot_from_urdf_text(text)
    for k in range(10):
        # loops closed to 1e-13 on both sides, so that 1e-12 measures the file and not the solver
        expected = calibrated.placement(calibrated.solve_fk(readings_true[k], tol=1e-13), frame)
        got = reloaded.placement(reloaded.solve_fk(qa[k], tol=1e-13), frame)  # the file takes raw readings
        np.testing.assert_allclose(got.homogeneous, expected.homogeneous, atol=1e-12, rtol=0)


def test_calibrated_urdf_folds_a_planar_passive_joint() -> None:
    """Re-assembly folds a multi-DOF passive joint's motion (here planar, nq = 4) into its origin."""
    import numpy as np
    from mechanisms import planar_coupler_urdf

    from pincal.identification.parameters import ParameterSet, apply_parameters, candidate_parameters
    from pincal.io.calibrated_urdf import calibrated_robot_text
    from pincal.model.robot import robot_from_urdf_text

    text = planar_coupler_urdf()
    robot = robot_from_urdf_text(text)
    pset = ParameterSet([p for p in candidate_parameters(robot)
                         if p.name in ("coupler_rocker.predecessor.tx", "crank_joint.offset")])
    x = np.array([0.002, 0.01])
    calibrated = robot_from_urdf_text(calibrated_robot_text(robot, text, pset, x)[0])  # closes at zero: loads
    truth = apply_parameters(robot, pset, x)
    for crank in (-0.1, 0.0, 0.2):
        expected = truth.placement(truth.solve_fk(np.array([crank + 0.01])), "coupler")
        got = calibrated.placement(calibrated.solve_fk(np.array([crank])), "coupler")
        np.testing.assert_allclose(got.homogeneous, expected.homogeneous, atol=1e-12)


def test_default_set_only_what_moves_the_measured_frame() -> None:
    """TIAGo, marker on the hand: no head, wheel or caster parameters; no rotation about a joint's own axis
    (it is the offset); the torso's placement left to the base (one chain from the root); a marker offset."""
    from pincal.identification import measurements as ms
    from pincal.identification.parameters import influencing_joints

    robot = pincal.load_robot("tiago_no_hand")
    models = [ms.position("wrist_ft_tool_link")]
    assert influencing_joints(robot, ["wrist_ft_tool_link"]) == ["torso_lift_joint"] + [f"arm_{i}_joint"
                                                                                       for i in range(1, 8)]
    default = choose_parameters(robot, models)
    names = set(default.names)
    assert not any(n.startswith(("head", "wheel", "caster")) for n in names)
    assert not any(n.endswith(".rz") and n.startswith("arm_") for n in names)  # arm axes are z in their frames
    assert not any(n.startswith("torso_lift_joint.t") or n.startswith("torso_lift_joint.r") for n in names)
    assert {"torso_lift_joint.offset", "base.rz", "marker.wrist_ft_tool_link.z"} <= names
    assert len(default) == 7 * 5 + 8 + 6 + 3
    # patterns reach further than the default set: a rotation about an axis is still there to name
    assert choose_parameters(robot, models, ["arm_1_joint.rz"]).names == ["arm_1_joint.rz"]


def test_default_set_tool_placement_by_measurement() -> None:
    """UR10: a pose of tool0 needs the tool's whole fixed placement; a position without a marker its translation;
    with a marker offset (the default for positions) none, the marker stands for it."""
    from pincal.identification import measurements as ms

    robot = pincal.load_robot("ur10")
    tool = "wrist_3_link-tool0_fixed_joint"
    pose = choose_parameters(robot, [ms.pose("tool0")])
    assert [n for n in pose.names if n.startswith(tool)] == [f"{tool}.{c}" for c in ("tx", "ty", "tz", "rx", "ry",
                                                                                        "rz")]
    position = choose_parameters(robot, [ms.position("tool0")])
    assert not any(n.startswith(tool) for n in position.names) and "marker.tool0.x" in position.names
    distance = choose_parameters(robot, [ms.distance("tool0", "base_link")])
    assert [n for n in distance.names if n.startswith(tool)] == [f"{tool}.{c}" for c in ("tx", "ty", "tz")]


def test_loops_bring_every_leg_and_sets_combine_with_patterns() -> None:
    from pincal.identification.parameters import influencing_joints

    robot = pincal.load_robot("delta")
    models = measurements_for(robot, ["position:end_effector"], robot.actuated_joints)
    assert {"arm_1_joint", "arm_2_joint", "arm_3_joint", "rod_3_roll"} <= set(influencing_joints(robot,
                                                                                                 ["end_effector"]))
    default = choose_parameters(robot, models)
    assert "arm_1_joint.ry" not in default and "arm_1_joint.offset" in default  # arm_1 turns about its y axis
    combined = choose_parameters(robot, models, ["model24", "base.*"])
    assert combined.names[:24] == choose_parameters(robot, models, ["model24"]).names
    assert combined.names[24:] == [f"base.{c}" for c in ("tx", "ty", "tz", "rx", "ry", "rz")]
    without = choose_parameters(robot, models, ["model24", "!arm_*.offset"])
    assert len(without) == 21 and not any(n.endswith(".offset") for n in without.names)
    assert choose_parameters(robot, models, ["!base.*"]).names == [n for n in default.names
                                                                    if not n.startswith("base.")]
    assert choose_parameters(robot, models, ["default"]).names == default.names
    with pytest.raises(NotFoundError, match="named sets are default, model24"):
        choose_parameters(robot, models, ["model25"])


def test_sets_can_be_removed_and_a_leading_exclusion_starts_from_the_default() -> None:
    from pincal.identification import measurements as ms

    robot = pincal.load_robot("ur10")
    models = [ms.position("tool0")]
    default = choose_parameters(robot, models)
    with pytest.raises(NotFoundError, match="leave no parameter"):
        choose_parameters(robot, models, ["!default"])
    kept = choose_parameters(robot, models, ["!base.*", "base.tz"])
    assert kept.names == [n for n in default.names if not n.startswith("base.")] + ["base.tz"]
    with pytest.raises(NotFoundError, match=r"\(\+\d+ more;"):  # hundreds of names are not all listed
        choose_parameters(robot, models, ["nothing*"])


def test_groups_and_kinds_are_found_once_and_handed_out_as_copies() -> None:
    """A set's placements per kind and its parameters of a kind (asked at every evaluation of a fit) are those of the
    parameters themselves, the same at every call whatever a caller did to an earlier answer."""
    from pincal.identification.parameters.kinds import MarkerOffset, parameter_kind

    robot = pincal.load_robot("ur10")
    pset = choose_parameters(robot, measurements_for(robot, ["position:tool0"], {}))
    expected: dict[tuple[str, str, str], list[int]] = {}
    for k, p in enumerate(pset):
        if p.kind in ("joint", "anchor"):
            expected.setdefault(p.group, []).append(k)
    markers = [k for k, p in enumerate(pset) if issubclass(parameter_kind(p.kind), MarkerOffset)]
    assert expected and markers
    for _ in range(2):
        groups, found = pset.groups("joint", "anchor"), pset.indices_of(MarkerOffset)
        assert groups == expected and found == markers
        next(iter(groups.values())).append(-1)
        found.clear()
