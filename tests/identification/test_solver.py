"""Perturb-then-recover: simulate a robot with known errors, calibrate, and check what comes back.

The parameters perturbed are the identifiable (base) set of each robot under its study's
measurements, so every one of them must return to within 1e-9 (m, rad) from the nominal start and
stay there from the true start. With the full redundant candidate set the fit must still be exact
and the unidentifiable combinations must be reported, not silently fitted.
"""

from __future__ import annotations

from typing import get_args

import numpy as np
import pinocchio as pin
import pytest

import pincal
from pincal.errors import DataError, IdentifiabilityError
from pincal.identification import measurements as ms
from pincal.identification.choices import LOSSES, SOLVERS, Loss, Solver
from pincal.identification.derivatives import marker_points
from pincal.identification.fitting import METHODS
from pincal.identification.identifiability import analyse
from pincal.identification.losses import IMPLEMENTED_LOSSES, TRIMMED
from pincal.identification.metrics import error_norms
from pincal.identification.parameters import choose_parameters, default_parameters
from pincal.identification.problem import CalibrationProblem, Observations
from pincal.identification.solver import identify
from pincal.study.simulation import perturbation, random_actuated, simulate_observations

DEVICE = [ms.joint_reading(j) for j in ("device_incl_x", "device_incl_y", "device_lvdt", "device_rotary")]

CASES = [
    ("delta", lambda: [ms.position("end_effector")], ["model24"], 40),
    ("hexapod_device", lambda: DEVICE, ["hexapod44"], 40),
    ("five_bar", lambda: [ms.distance("base_link", "end_effector", increment=True)], ["*.offset"], 12),
    ("ucr3", lambda: [ms.pose("end_effector")], None, 30),
    ("ur10", lambda: [ms.position("tool0")], None, 40),
    ("ur10", lambda: [ms.pose("tool0")], None, 30),
    ("panda", lambda: [ms.position("panda_hand")], None, 40),
    ("panda", lambda: [ms.pose("panda_hand")], None, 30),
]


def _setup(name: str, models: list, spec: list[str] | None, n: int, seed: int = 3):
    robot = pincal.load_robot(name)
    rng = np.random.default_rng(seed)
    pool = choose_parameters(robot, models, spec)
    qa, _ = random_actuated(robot, n, rng)
    # the identifiable set at the nominal robot, for these postures and measurements
    blank = simulate_observations(robot, pool, np.zeros(len(pool)), models, qa, rng)
    jac = CalibrationProblem(robot, pool, models, blank).evaluate(np.zeros(len(pool))).jacobian
    assert jac is not None
    base = analyse(jac, pool.names, pool.scales).base_indices
    pset = pool.subset(base)
    x_true = perturbation(pset, 1e-3, rng)
    obs = simulate_observations(robot, pset, x_true, models, qa, rng)
    return robot, pset, x_true, CalibrationProblem(robot, pset, models, obs)


#: Relative round-off of an exact fit's residual (the loops close to ~1e-13) that the condition number amplifies.
ROUND_OFF = 1e-13


@pytest.mark.parametrize(("name", "models", "spec", "n"), CASES,
                         ids=[f"{c[0]}-{c[1]()[0].key.split(':')[0]}" for c in CASES])
def test_identifiable_parameters_come_back(name: str, models, spec, n: int) -> None:
    _robot, pset, x_true, problem = _setup(name, models(), spec, n)
    for start in (np.zeros(len(pset)), x_true):
        result = identify(problem, x0=start)
        assert result.converged, result.message
        assert result.identifiability.rank == len(pset)
        # exact data: what is left is the solves' round-off (the loops close to ~1e-13), amplified by the scaled
        # Jacobian's condition number (the 3-UCR with poses: κ ≈ 1.7e5, errors ≈ 1.6e-9)
        atol = max(1e-9, ROUND_OFF * result.identifiability.condition_number)
        np.testing.assert_allclose(result.x, x_true, atol=atol, rtol=0)
        assert not result.identifiability.unidentifiable


def test_hexapod_device_identifies_all_44_parameters() -> None:
    """Study 001's claim: with the measuring device, the 42 robot parameters plus D0 and ψ are all
    identifiable."""
    _robot, pset, _x_true, problem = _setup("hexapod_device", DEVICE, ["hexapod44"], 40)
    assert len(pset) == 44
    result = identify(problem)
    assert result.identifiability.rank == 44 and result.identifiability.condition_number < 1e4


def test_redundant_set_fits_exactly_and_names_the_combinations() -> None:
    robot = pincal.load_robot("ur10")
    models = [ms.position("tool0")]
    rng = np.random.default_rng(8)
    pset = choose_parameters(robot, models)
    x_true = perturbation(pset, 1e-3, rng)
    qa, _ = random_actuated(robot, 50, rng)
    problem = CalibrationProblem(robot, pset, models, simulate_observations(robot, pset, x_true, models, qa, rng))
    result = identify(problem)
    assert result.converged
    assert np.max(error_norms(result.errors_after)) < 1e-9
    # a 6R arm with 3D data: 27 identifiable directions (the FIGAROH count) out of the 40 default candidates (no
    # rotation about a joint's own axis, no first placement beside the base, a marker offset instead of the tool)
    assert len(pset) == 40 and result.identifiability.rank == 27
    assert len(result.identifiability.unidentifiable) == 40 - 27
    assert any("base.rz" in c.description or "tool0" in c.description for c in result.identifiability.unidentifiable)
    # held-out postures are predicted as well as the fitted ones
    qa_test, _ = random_actuated(robot, 20, rng)
    test = CalibrationProblem(robot, pset, models, simulate_observations(robot, pset, x_true, models, qa_test, rng))
    assert np.max(error_norms(test.evaluate(result.x, jacobian=False).errors)) < 1e-9


def test_noisy_fit_reports_standard_deviations() -> None:
    robot, pset, x_true, _ = _setup("delta", [ms.position("end_effector")], ["model24"], 60)
    rng = np.random.default_rng(4)
    qa, _ = random_actuated(robot, 60, rng)
    models = [ms.position("end_effector", sigma=1e-5)]
    obs = simulate_observations(robot, pset, x_true, models, qa, rng, noise=1e-5)
    result = identify(CalibrationProblem(robot, pset, models, obs))
    z = (result.x - x_true) / result.std
    assert np.all(np.isfinite(result.std)) and 0.5 < result.sigma2 < 1.5
    assert np.max(np.abs(z)) < 5.0  # estimates within 5 σ of the truth


@pytest.mark.parametrize("solver", ["tsvd", "ridge"])
def test_tsvd_and_ridge_variants_recover(solver: str) -> None:
    _, _pset, x_true, problem = _setup("five_bar", [ms.distance("base_link", "end_effector", increment=True)],
                                      ["*.offset"], 12)
    result = identify(problem, solver=solver, ridge=1e-12)
    np.testing.assert_allclose(result.x, x_true, atol=1e-9, rtol=0)


def test_the_registries_hold_the_names_the_choices_list() -> None:
    """The solver names are the method registry's, the loss names ``auto`` and the loss registry's (but the trimmed
    start, internal to ``auto``), in the order of the ``Solver`` and ``Loss`` types."""
    assert tuple(METHODS) == SOLVERS == get_args(Solver)
    assert all(method.name == name for name, method in METHODS.items())
    assert ("auto", *(name for name in IMPLEMENTED_LOSSES if name != TRIMMED)) == LOSSES == get_args(Loss)


@pytest.mark.parametrize("loss", LOSSES)
@pytest.mark.parametrize("solver", SOLVERS)
def test_identify_takes_every_registered_solver_and_loss(solver: str, loss: str) -> None:
    _, _pset, x_true, problem = _setup("five_bar", [ms.distance("base_link", "end_effector", increment=True)],
                                      ["*.offset"], 12)
    result = identify(problem, solver=solver, loss=loss, ridge=1e-12)  # type: ignore[arg-type]
    assert result.solver == solver and result.loss.split(" ")[0] == loss
    np.testing.assert_allclose(result.x, x_true, atol=1e-9, rtol=0)


def test_unknown_solver_and_loss_names_list_the_registered_ones() -> None:
    _, _pset, _x_true, problem = _setup("five_bar", [ms.distance("base_link", "end_effector", increment=True)],
                                       ["*.offset"], 12)
    with pytest.raises(DataError, match=r"^unknown solver 'gn'; solvers are: lm, tsvd, ridge$"):
        identify(problem, solver="gn")  # type: ignore[arg-type]
    with pytest.raises(DataError, match=r"^unknown loss 'huber'; losses are: auto, linear, cauchy$"):
        identify(problem, loss="huber")  # type: ignore[arg-type]


def test_bad_data_raises_a_pincal_error() -> None:
    robot = pincal.load_robot("delta")
    models = [ms.position("end_effector")]
    pset = choose_parameters(robot, models, ["model24"])
    qa = np.zeros((3, 3))
    values = {"position:end_effector": np.zeros((3, 3))}
    values["position:end_effector"][1, 2] = np.nan
    with pytest.raises(DataError, match="sample 1 is NaN"):
        CalibrationProblem(robot, pset, models, Observations(qa, values))
    with pytest.raises(DataError, match="no data for measurement 'position:end_effector'"):
        CalibrationProblem(robot, pset, models, Observations(qa, {}))
    with pytest.raises(DataError, match=r"actuated readings have shape \(3, 2\)"):
        CalibrationProblem(robot, pset, models, Observations(np.zeros((3, 2)), {"position:end_effector": qa}))
    # too few samples for the parameters (3 measured values, 24 parameters)
    single = Observations(np.zeros((1, 3)), {"position:end_effector": np.zeros((1, 3))})
    one = CalibrationProblem(robot, pset, models, single)
    with pytest.raises(DataError, match="residuals cannot identify"):
        identify(one)
    with pytest.raises(DataError, match="unknown solver 'gauss'"):
        identify(one, solver="gauss")


def test_rank_deficient_pose_set_is_reported_in_strict_mode() -> None:
    """The same posture measured ten times cannot identify Model 24: strict mode says which combinations."""
    robot = pincal.load_robot("delta")
    models = [ms.position("end_effector")]
    pset = choose_parameters(robot, models, ["model24"])
    qa = np.tile([0.2, 0.3, 0.1], (10, 1))
    obs = simulate_observations(robot, pset, np.zeros(len(pset)), models, qa, np.random.default_rng(0))
    with pytest.raises(IdentifiabilityError, match=r"3 of 24 parameters are identifiable.*not identifiable"):
        identify(CalibrationProblem(robot, pset, models, obs), strict=True)


def test_unknown_measurement_frame_far_away_is_registered_in_closed_form() -> None:
    """A tracker 1.8 m away and turned 2.5 rad: the Kabsch start makes it an ordinary fit."""
    robot = pincal.load_robot("ur10")
    models = [ms.position("tool0")]
    pool = choose_parameters(robot, models)  # includes base.* (the tracker frame)
    rng = np.random.default_rng(12)
    x_true = perturbation(pool, 1e-3, rng)
    base = pool.placement_delta(x_true, [pool.index(f"base.{c}") for c in ("tx", "ty", "tz", "rx", "ry", "rz")])
    far = pin.log6(pin.SE3(pin.utils.rotate("z", 2.5), np.array([1.8, -0.4, 0.3])) * pin.exp6(base)).vector
    for c, value in zip(("tx", "ty", "tz", "rx", "ry", "rz"), far, strict=True):
        x_true[pool.index(f"base.{c}")] = value
    qa, _ = random_actuated(robot, 50, rng)
    problem = CalibrationProblem(robot, pool, models, simulate_observations(robot, pool, x_true, models, qa, rng))
    guess = problem.initial_guess()
    assert np.max(error_norms(problem.evaluate(guess, jacobian=False).errors)) < 0.05  # registered to cm level
    result = identify(problem)
    assert result.converged and result.iterations <= 15
    assert np.max(error_norms(result.errors_after)) < 1e-9


def test_numpy_svd_failure_falls_back_to_gesvd_with_the_same_result(monkeypatch: pytest.MonkeyPatch) -> None:
    """numpy's SVD can fail ("SVD did not converge") on Jacobians with many near-zero singular values; LM,
    the identifiability analysis and the covariance then use SciPy's gesvd and give the same answer."""
    robot = pincal.load_robot("ur10")
    models = [ms.position("tool0")]
    pset = choose_parameters(robot, models, ["*_joint.*"])  # redundant: many exactly zero singular values
    rng = np.random.default_rng(21)
    x_true = perturbation(pset, 1e-3, rng)
    qa, _ = random_actuated(robot, 25, rng)
    obs = simulate_observations(robot, pset, x_true, models, qa, rng, noise=1e-5)
    reference = identify(CalibrationProblem(robot, pset, models, obs), x0=np.zeros(len(pset)), loss="linear")
    calls: list[int] = []

    def failing(*args: object, **kwargs: object) -> None:
        calls.append(1)
        raise np.linalg.LinAlgError("SVD did not converge")

    monkeypatch.setattr(np.linalg, "svd", failing)
    fallback = identify(CalibrationProblem(robot, pset, models, obs), x0=np.zeros(len(pset)), loss="linear")
    assert calls
    assert fallback.iterations == reference.iterations and fallback.converged == reference.converged
    assert fallback.identifiability.rank == reference.identifiability.rank < len(pset)
    np.testing.assert_allclose(fallback.identifiability.singular_values, reference.identifiability.singular_values,
                               rtol=1e-9, atol=1e-12 * reference.identifiability.singular_values[0])
    np.testing.assert_allclose(fallback.x, reference.x, atol=1e-12, rtol=0)
    np.testing.assert_allclose(fallback.std, reference.std, rtol=1e-6, equal_nan=True)


# --- several markers on one body, some not seen -------------------------------------------------------------------
MARKERS = {"m1": (0.06, 0.0, 0.03), "m2": (-0.04, 0.05, 0.01), "m3": (0.0, -0.05, 0.07)}


def _marker_points(problem: CalibrationProblem, x: np.ndarray) -> dict[str, np.ndarray]:
    return {t: p.point for t, p in marker_points(problem.parameters, x, problem.marker_nominals).items()}


@pytest.mark.parametrize("fit", ["each", "cluster"])
def test_three_markers_on_one_body_come_back_with_occluded_readings(fit: str) -> None:
    """UR10, three markers on tool0 at declared nominal offsets, the true robot off by 1 mm / 1 mrad everywhere
    (markers or cluster included), a fifth of the readings not seen: the fit is exact on every reading taken, and
    the markers' distances to one another come back (their common offset trades with the tool, and their
    orientation about the last joint's axis with that joint's offset)."""
    robot = pincal.load_robot("ur10")
    models = [ms.position("tool0", marker=m, nominal=n) for m, n in MARKERS.items()]
    pset = default_parameters(robot, models, markers=fit)
    kinds = {p.kind for p in pset}
    assert ("cluster" in kinds) == (fit == "cluster") and ("marker" in kinds) == (fit == "each")
    rng = np.random.default_rng(8)
    qa, _ = random_actuated(robot, 30, rng)
    x_true = perturbation(pset, 1e-3, rng)
    obs = simulate_observations(robot, pset, x_true, models, qa, rng)
    unseen = rng.random((30, 3)) < 0.2
    unseen[unseen.all(axis=1), 0] = False  # every sample keeps one marker
    for j, m in enumerate(models):
        obs.values[m.key][unseen[:, j]] = np.nan
    problem = CalibrationProblem(robot, pset, models, obs)
    assert sum(problem.n_readings().values()) == 90 - int(unseen.sum())
    result = identify(problem)
    assert result.converged, result.message
    assert error_norms(result.errors_after).size == 90 - int(unseen.sum())
    assert error_norms(result.errors_after).max() < 1e-8
    assert all(np.isnan(result.errors_after[m.key][unseen[:, j]]).all() for j, m in enumerate(models))
    found, truth = _marker_points(problem, result.x), _marker_points(problem, x_true)
    for a, b in (("m1", "m2"), ("m1", "m3"), ("m2", "m3")):
        apart = np.linalg.norm(found[f"tool0@{a}"] - found[f"tool0@{b}"])
        assert apart == pytest.approx(np.linalg.norm(truth[f"tool0@{a}"] - truth[f"tool0@{b}"]), abs=1e-9)


def test_blas_runs_on_one_thread_while_identifying(monkeypatch: pytest.MonkeyPatch) -> None:
    """Started with one thread in every BLAS variable (as the command line starts), identification has nothing to
    limit; otherwise threadpoolctl holds every BLAS library loaded at one thread while it runs."""
    import contextlib

    from threadpoolctl import threadpool_info, threadpool_limits

    from pincal.identification import solver

    for name in solver.ONE_THREAD:
        monkeypatch.setenv(name, "1")
    assert isinstance(solver.one_blas_thread(), contextlib.nullcontext)
    monkeypatch.delenv("OPENBLAS_NUM_THREADS")
    solver._threadpools.cache_clear()  # the libraries loaded now (found once per process: a test may load more)
    with threadpool_limits(limits=2, user_api="blas"), solver.one_blas_thread():
        assert {pool["num_threads"] for pool in threadpool_info() if pool["user_api"] == "blas"} == {1}


def test_overlapping_limits_give_the_caller_its_threads_back(monkeypatch: pytest.MonkeyPatch) -> None:
    """Two calibrations that overlap in threads (the first leaves while the second is still inside) hold BLAS at one
    thread until the last one leaves, then give back what the caller had."""
    from threadpoolctl import threadpool_info, threadpool_limits

    from pincal.identification import solver

    def blas_threads() -> set[int]:
        return {pool["num_threads"] for pool in threadpool_info() if pool["user_api"] == "blas"}

    for name in solver.ONE_THREAD:
        monkeypatch.delenv(name, raising=False)
    solver._threadpools.cache_clear()
    with threadpool_limits(limits=2, user_api="blas"):
        first, second = solver.one_blas_thread(), solver.one_blas_thread()
        first.__enter__()
        second.__enter__()
        assert blas_threads() == {1}
        first.__exit__(None, None, None)
        assert blas_threads() == {1}
        second.__exit__(None, None, None)
        assert blas_threads() == {2}
