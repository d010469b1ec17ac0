"""Model selection: the information criterion, the choice among parameter groups, and the refit."""

from __future__ import annotations

import math

import numpy as np
import pytest

import pincal
from pincal.calibration.campaign import simulate
from pincal.calibration.pipeline import Calibration, calibrate
from pincal.calibration.report_sections import ModelSelection
from pincal.errors import DataError
from pincal.identification.criterion import group_of, information_criterion, select_groups
from pincal.identification.problem import CalibrationProblem
from pincal.identification.selection import select_and_fit
from pincal.io.adapters import measurements_for, observations_from


def test_information_criterion_is_the_bic_of_the_least_squares_fit() -> None:
    rng = np.random.default_rng(0)
    J = rng.normal(size=(60, 4))
    y0 = rng.normal(size=60)
    x, *_ = np.linalg.lstsq(J, -y0, rcond=None)
    rss = float(np.sum((y0 + J @ x) ** 2))
    assert information_criterion(J, y0) == pytest.approx(60 * math.log(rss / 60) + 4 * math.log(60), rel=1e-12)
    assert information_criterion(J[:, :0], y0) == pytest.approx(60 * math.log(float(y0 @ y0) / 60), rel=1e-12)


def test_a_group_without_effect_is_left_out_and_one_with_effect_kept() -> None:
    rng = np.random.default_rng(1)
    m = 300
    J = rng.normal(size=(m, 6))
    truth = np.array([1.0, -2.0, 0.5, 0.0, 0.0, 3.0])  # the "rotations" (columns 3, 4) carry nothing
    y0 = -J @ truth + 0.1 * rng.normal(size=m)
    groups: list[str | None] = ["translations", "translations", "translations", "rotations", "rotations", None]
    choice = select_groups(J, y0, groups)
    assert choice.removed_groups == ("rotations",)
    assert choice.kept == [0, 1, 2, 5]
    assert min(choice.scores, key=choice.scores.__getitem__) == ("rotations",)
    # with an effect on the rotations, nothing is left out
    y1 = -J @ np.array([1.0, -2.0, 0.5, 0.3, -0.4, 3.0]) + 0.1 * rng.normal(size=m)
    assert select_groups(J, y1, groups).removed_groups == ()


def test_a_group_that_adds_no_direction_ties_and_stays() -> None:
    """The rotations' columns lie in the translations' span (as a joint offset's and the next joint's rz do): leaving
    them out scores exactly what keeping them does (one score for one span, computed once), and they stay, whatever
    the columns' scale: a group is left out only where that lowers the criterion, not on round-off."""
    rng = np.random.default_rng(7)
    m = 300
    base = rng.normal(size=(m, 3))
    y0 = -base @ np.array([1.0, -2.0, 0.5]) + 0.1 * rng.normal(size=m)
    groups: list[str | None] = ["translations", "translations", "translations", "rotations", "rotations", None]
    for scale in (1.0, 1e-3, 7.0):
        J = np.column_stack([base, scale * (base[:, 0] + base[:, 1]), -scale * base[:, 2], rng.normal(size=m)])
        choice = select_groups(J, y0, groups)
        assert choice.scores[("rotations",)] == choice.scores[()]
        assert min(choice.scores.values()) == choice.scores[()]
        assert choice.removed_groups == () and choice.kept == [0, 1, 2, 3, 4, 5]


def test_groups_of_parameters() -> None:
    robot = pincal.load_robot("ur10")
    models = measurements_for(robot, ["position:tool0"], robot.actuated_joints)
    pset = pincal.identification.parameters.choose_parameters(robot, models)
    kinds = {p.name: group_of(p) for p in pset}
    assert kinds["elbow_joint.tx"] == "translations" and kinds["elbow_joint.rx"] == "rotations"
    assert kinds["elbow_joint.offset"] == "offsets"
    assert kinds["base.tx"] is None and kinds["marker.tool0.x"] is None


def test_selection_drops_what_the_truth_lacks_and_predicts_no_worse() -> None:
    """UR10 with errors on translations only: BIC leaves the rotations and offsets out, the refit predicts held-out
    postures at least as well as fitting every identifiable parameter; the evidence (the default) leaves the rotations
    out (their factor at the smallest) and predicts as well."""
    robot = pincal.load_robot("ur10")
    sim = simulate(robot, ["position"], 40, 100, perturb=1e-3, noise=1e-4, seed=3,
                   parameter_spec=["*.tx", "*.ty", "*.tz"])
    selected = calibrate(robot, sim.dataset, select="bic", prior=1.0)
    everything = calibrate(robot, sim.dataset, select="none", prior=1.0)
    evidence = calibrate(robot, sim.dataset)
    factors = _selection(evidence).prior_factors
    assert _selection(evidence).policy == "evidence"
    assert factors["rotations"] == 0.0 and "rotations" in _selection(evidence).removed_groups
    assert evidence.report.test_rms_after <= 1.05 * selected.report.test_rms_after
    assert _selection(selected).removed_groups == ["rotations", "offsets"]
    assert selected.report.n_estimated < everything.report.n_estimated
    assert selected.report.test_rms_after <= everything.report.test_rms_after
    assert selected.report.test_rms_after < 0.1 * selected.report.test_rms_before
    # a named parameter set is fitted as named unless selection is asked for
    named = calibrate(robot, sim.dataset, parameter_spec=["default", "!base.rz"])
    assert _selection(named).policy == "none" and not _selection(named).removed
    default = calibrate(robot, sim.dataset, parameter_spec=["default"])  # the default set by its name: selected
    assert _selection(default).policy == "evidence"


def _selection(cal: Calibration) -> ModelSelection:
    """The model selection account of ``cal``'s report."""
    assert cal.report.selection is not None
    return cal.report.selection


def test_select_and_fit_refits_the_kept_groups_and_keeps_the_base() -> None:
    robot = pincal.load_robot("ur10")
    sim = simulate(robot, ["position"], 40, 0, perturb=1e-3, noise=1e-4, seed=4, parameter_spec=["*.tx", "*.ty"])
    models = measurements_for(robot, list(sim.dataset.measurements), sim.dataset.joint_names)
    obs = observations_from(robot, sim.dataset.joint_names, sim.dataset.joints, sim.dataset.measurements, models)
    pset = pincal.identification.parameters.choose_parameters(robot, models)
    fitted = select_and_fit(CalibrationProblem(robot, pset, models, obs))
    kept = fitted.problem.parameters.names
    assert all(name in kept for name in pset.names if name.startswith(("base.", "marker.")))
    assert not any(name in kept for name in fitted.removed)
    assert len(kept) + len(fitted.removed) == len(pset)
    assert fitted.first.names == pset.names and fitted.result.names == kept
    with pytest.raises(DataError, match="unknown selection 'aic'; selections are: evidence, bic, cv, none"):
        select_and_fit(CalibrationProblem(robot, pset, models, obs), "aic")


def test_a_choice_the_nonlinear_refit_does_not_bear_out_is_undone() -> None:
    """The planar crank-rocker: at the estimate its anchor rotations stand in for the translations, so the
    linearized criterion leaves the translations out; from the nominal start they cannot, and the refit would stop at
    10 × the noise. The fit over every parameter is kept."""
    import sys
    from pathlib import Path

    sys.path.insert(0, str(Path(__file__).resolve().parents[1]))
    from mechanisms import crank_rocker_urdf

    from pincal.model.robot import robot_from_urdf_text

    robot = robot_from_urdf_text(crank_rocker_urdf())
    sim = simulate(robot, ["position"], 30, 0, perturb=1e-3, noise=1e-5, seed=1)
    models = measurements_for(robot, list(sim.dataset.measurements), sim.dataset.joint_names)
    obs = observations_from(robot, sim.dataset.joint_names, sim.dataset.joints, sim.dataset.measurements, models)
    fitted = select_and_fit(CalibrationProblem(robot, sim.parameters, models, obs))
    assert min(fitted.scores, key=fitted.scores.__getitem__) == ("translations",)  # what the linearization says
    assert fitted.removed == [] and fitted.result is fitted.first
    assert fitted.result.sigma2 < 2.0  # at the noise level
