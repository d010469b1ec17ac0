"""One Robot shared by threads: each thread works in scratch of its own (:mod:`pincal.model.per_thread`), so every
answer is the one the same call gives alone."""

from __future__ import annotations

import copy
import gc
import pickle
import threading
import weakref

import numpy as np
import pytest
from concurrent_calls import in_threads

import pincal
from pincal.model.per_thread import per_thread

THREADS = 4


class Counted:
    """An object with a per-thread list, counting how many it made."""

    def __init__(self) -> None:
        self.made = 0

    @per_thread
    def scratch(self) -> list[str]:
        self.made += 1
        return []


def test_a_per_thread_value_is_made_once_in_each_thread() -> None:
    held = Counted()
    held.scratch.append("main")

    def work(k: int) -> list[str]:
        held.scratch.append(f"thread {k}")
        return held.scratch

    seen = in_threads(work, threads=THREADS, calls=2)
    assert seen == [[[f"thread {k}"] * 2] * 2 for k in range(THREADS)]  # the same list twice, the thread's own
    assert all(answers[0] is answers[1] for answers in seen)
    assert held.scratch == ["main"]
    assert held.made == THREADS + 1


def test_a_per_thread_value_goes_with_its_thread() -> None:
    held = Counted()
    thread = threading.Thread(target=lambda: held.scratch.append("gone"))
    thread.start()
    thread.join()
    assert held.scratch == []
    assert held.made == 2


class _Scratch:
    """A value a weak reference can follow."""


class Held:
    @per_thread
    def scratch(self) -> _Scratch:
        return _Scratch()


def test_a_thread_s_value_is_freed_when_the_thread_ends() -> None:
    held, seen = Held(), []
    thread = threading.Thread(target=lambda: seen.append(weakref.ref(held.scratch)))
    thread.start()
    thread.join()
    gc.collect()
    assert len(seen) == 1 and seen[0]() is None and held.scratch is not None


def test_deep_copies_and_pickles_start_without_the_values() -> None:
    """Scratch is made again, not carried (a Robot copies and pickles as before); a shallow copy shares it, as it
    shares every attribute."""
    held = Counted()
    held.scratch.append("kept here")
    for other in (copy.deepcopy(held), pickle.loads(pickle.dumps(held))):
        assert other.scratch == []
    assert copy.copy(held).scratch is held.scratch
    assert held.scratch == ["kept here"]


@pytest.fixture(scope="module")
def delta() -> pincal.Robot:
    return pincal.load_robot("delta")


def actuated_values(k: int, n: int = 30) -> np.ndarray:
    """Thread ``k``'s own Delta arm angles [rad]: n samples within ±0.4 rad."""
    return np.random.default_rng(k).uniform(-0.4, 0.4, (n, 3))


def test_serial_placements_from_threads_as_alone() -> None:
    """A UR10's frame placements (Pinocchio's Data written, then read), each thread at configurations of its own."""
    robot = pincal.load_robot("ur10")
    configurations = [np.random.default_rng(k).uniform(-3.0, 3.0, (50, robot.model.nq)) for k in range(THREADS)]

    def placements(k: int) -> np.ndarray:
        return np.array([robot.placement(q, robot.end_effector).homogeneous for q in configurations[k]])

    alone = [placements(k) for k in range(THREADS)]
    seen = in_threads(placements, threads=THREADS, calls=8)
    assert all(np.array_equal(answer, alone[k]) for k in range(THREADS) for answer in seen[k])


def test_closed_loop_solves_from_threads_as_alone(delta: pincal.Robot) -> None:
    """A Delta's forward kinematics (Newton through the loops' constraint data) and its closure Jacobian, each thread
    at arm angles of its own."""
    def solves(k: int) -> list[np.ndarray]:
        q = np.array([delta.solve_fk(qa) for qa in actuated_values(k)])
        return [q, *(delta.kinematics.closure_jacobian(one)[1] for one in q)]

    alone = [solves(k) for k in range(THREADS)]
    seen = in_threads(solves, threads=THREADS, calls=2)
    assert all(np.array_equal(got, want) for k in range(THREADS) for answer in seen[k]
               for got, want in zip(answer, alone[k], strict=True))


def test_batched_warm_solves_from_threads_as_alone(delta: pincal.Robot) -> None:
    """A Delta's batched warm solve and the loops linearised at its answers (the last Newton pass, kept between the
    two), each thread at arm angles of its own."""
    batch, model, closure = delta.batch, delta.model, delta.closure
    starts = [batch.continuation(model, closure, actuated_values(k), 1e-11)[0] for k in range(THREADS)]

    def warm(k: int) -> tuple[np.ndarray, np.ndarray]:
        q, converged = batch.warm_solve(model, closure, actuated_values(k) + 0.01, starts[k], 1e-11)
        assert converged.all()
        return q, batch.linearised(model, closure, q).passive

    alone = [warm(k) for k in range(THREADS)]
    seen = in_threads(warm, threads=THREADS, calls=10)
    assert all(np.array_equal(got, want) for k in range(THREADS) for answer in seen[k]
               for got, want in zip(answer, alone[k], strict=True))
