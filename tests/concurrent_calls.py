"""Calls made from several threads at once, the interpreter switching between them often, so that they interleave
at many points (what a thread pool sharing one Robot does)."""

from __future__ import annotations

import sys
import threading
from collections.abc import Callable
from concurrent.futures import ThreadPoolExecutor
from typing import TypeVar

T = TypeVar("T")

#: How often the interpreter switches threads while :func:`in_threads` runs [s] (its default: 5 ms).
SWITCH_INTERVAL = 1e-5


def in_threads(work: Callable[[int], T], threads: int = 4, calls: int = 2) -> list[list[T]]:
    """``work(k)`` called ``calls`` times in each thread ``k`` of ``threads`` started together; each thread's answers,
    in order (an exception in any call is raised here)."""
    start = threading.Barrier(threads)

    def thread(k: int) -> list[T]:
        start.wait()
        return [work(k) for _ in range(calls)]

    interval = sys.getswitchinterval()
    sys.setswitchinterval(SWITCH_INTERVAL)
    try:
        with ThreadPoolExecutor(threads) as pool:
            futures = [pool.submit(thread, k) for k in range(threads)]
            return [future.result() for future in futures]
    finally:
        sys.setswitchinterval(interval)
