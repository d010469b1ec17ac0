"""Worker processes the benchmarks time in turns: each runs one revision's ``pincal/`` on one BLAS thread, reads a
line per task on its stdin and answers a line on its stdout."""

from __future__ import annotations

import os
import subprocess
import sys
from collections.abc import Iterable
from pathlib import Path


def start_worker(code: str, source: Path, cwd: Path, *args: str) -> subprocess.Popen[str]:
    """A process running ``code`` (``python -c``, with ``args``) with the ``pincal`` under ``source``, started in
    ``cwd`` (not the repository: ``python -c`` puts the folder it starts in first on the path). ``code``'s first line
    out is the folder it imported pincal from; a worker that imported another one is refused."""
    env = dict(os.environ, PYTHONPATH=str(source), OPENBLAS_NUM_THREADS="1", OMP_NUM_THREADS="1",
               MKL_NUM_THREADS="1")
    process = subprocess.Popen([sys.executable, "-c", code, *args], env=env, cwd=cwd, stdin=subprocess.PIPE,
                               stdout=subprocess.PIPE, text=True)
    assert process.stdout is not None
    loaded = process.stdout.readline().strip()
    if not loaded.startswith(str(source)):
        raise SystemExit(f"the worker for {source} imported pincal from {loaded}")
    return process


def stop_workers(workers: Iterable[subprocess.Popen[str]]) -> None:
    """Close each worker's stdin (its loop ends) and wait for it."""
    for process in workers:
        assert process.stdin is not None
        process.stdin.close()
        process.wait()
