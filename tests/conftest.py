"""Shared fixtures: repository paths and robots loaded once per session."""

from __future__ import annotations

import atexit
import contextlib
import json
import os
import select
import signal
import subprocess
import sys
import tempfile
import threading
from pathlib import Path
from typing import Any

import numpy as np
import pytest
from threadpoolctl import threadpool_limits

import pincal
from pincal.__main__ import THREAD_VARIABLES

ROOT = Path(__file__).resolve().parents[1]
ROBOTS = ROOT / "robots_urdf"
#: The installed console script, beside the interpreter running the tests (the venv's bin/).
PINCAL = Path(sys.executable).parent / "pincal"
#: One BLAS and OpenMP thread in each test process, as the ``pincal`` command runs: with one test worker per core
#: (``-n auto``), more threads only contend for the same cores.
SINGLE_THREADED = threadpool_limits(limits=1)


def readme_four_bar() -> str:
    """The four-bar URDF the README shows ("A closed-loop URDF from scratch"), as a user copies it."""
    text = (ROOT / "README.md").read_text(encoding="utf-8")
    blocks = [b for b in text.split("```xml\n")[1:] if '<robot name="four_bar">' in b]
    assert len(blocks) == 1, "the README shows one four-bar URDF"
    return blocks[0].split("```")[0]


def page_elsewhere(script: Path, published: Path, tmp_path: Path, *args: str,
                   timeout: float | None = None) -> str:
    """Run a results page's ``script`` (with ``args``, e.g. ``--quick``) writing its page into ``tmp_path / "page"``,
    on one BLAS thread; check it succeeds and leaves the ``published`` page untouched (only ``--publish`` writes into
    docs/); the page it wrote."""
    before = published.read_bytes()
    env = dict(os.environ, OMP_NUM_THREADS="1", OPENBLAS_NUM_THREADS="1")
    done = subprocess.run([sys.executable, str(script), *args, "--out", str(tmp_path / "page")], capture_output=True,
                          text=True, timeout=timeout, env=env, cwd=tmp_path, check=False)
    assert done.returncode == 0, done.stderr
    assert published.read_bytes() == before  # only --publish writes into docs/
    return (tmp_path / "page" / published.name).read_text(encoding="utf-8")


def run_pincal(*args: str, timeout: float = 300, cwd: Path | None = None) -> subprocess.CompletedProcess[str]:
    """``pincal ARGS`` as a user runs it, in a process of its own (in ``cwd``, made if missing), output captured as
    text; ``subprocess.TimeoutExpired`` after ``timeout`` seconds, as ``subprocess.run`` raises it.

    The process is forked from :mod:`command_server`, which has imported pincal once, and runs the console script's
    entry point (``pincal.__main__.main``) with its own folder, environment, output files and exit code; with
    ``PINCAL_TEST_EXEC=1`` in the environment it is the console script started from scratch instead. How a process
    starts (its imports) is tested on processes started from scratch (``tests/cli/test_start.py``)."""
    if cwd is not None:
        cwd.mkdir(parents=True, exist_ok=True)
    if os.environ.get("PINCAL_TEST_EXEC") == "1":
        return subprocess.run([str(PINCAL), *args], capture_output=True, text=True, timeout=timeout, check=False,
                              cwd=cwd)
    return _SERVER.run([str(PINCAL), *args], cwd or Path.cwd(), timeout)


class _CommandServer:
    """The client of one :mod:`command_server` process, started at the first command and ended with the tests."""

    def __init__(self) -> None:
        self.process: subprocess.Popen[bytes] | None = None
        self.lock = threading.Lock()

    def _started(self) -> subprocess.Popen[bytes]:
        if self.process is None or self.process.poll() is not None:
            environment = {**os.environ, **{name: os.environ.get(name, "1") for name in THREAD_VARIABLES}}
            self.process = subprocess.Popen([sys.executable, str(Path(__file__).with_name("command_server.py"))],
                                            stdin=subprocess.PIPE, stdout=subprocess.PIPE, env=environment,
                                            bufsize=0)  # unbuffered: a reply read is never one select cannot see
            atexit.register(self.stop)
        return self.process

    def stop(self) -> None:
        """End the server: its stdin closed, it leaves its loop (killed if it does not within 10 s)."""
        if self.process is not None and self.process.poll() is None:
            assert self.process.stdin is not None
            self.process.stdin.close()
            try:
                self.process.wait(timeout=10)
            except subprocess.TimeoutExpired:
                self.process.kill()
                self.process.wait()

    def _reply(self, process: subprocess.Popen[bytes], timeout: float | None) -> dict[str, int] | None:
        assert process.stdout is not None
        if timeout is not None and not select.select([process.stdout], [], [], timeout)[0]:
            return None
        line = process.stdout.readline()
        if not line:
            raise RuntimeError(f"the command server ended (exit code {process.wait()}); see its stderr above")
        return json.loads(line)

    def run(self, command: list[str], cwd: Path, timeout: float) -> subprocess.CompletedProcess[str]:
        with self.lock, tempfile.TemporaryDirectory(prefix="pincal-command-") as folder:
            process = self._started()
            assert process.stdin is not None
            out, err = Path(folder, "stdout"), Path(folder, "stderr")
            request = {"program": command[0], "args": command[1:], "cwd": str(cwd), "env": dict(os.environ),
                       "stdout": str(out), "stderr": str(err)}
            process.stdin.write((json.dumps(request) + "\n").encode())
            process.stdin.flush()
            pid = self._reply(process, None)["pid"]  # type: ignore[index]
            ended = self._reply(process, timeout)
            if ended is None:
                with contextlib.suppress(ProcessLookupError):  # it may have ended since
                    os.kill(pid, signal.SIGKILL)
                self._reply(process, None)
                raise subprocess.TimeoutExpired(command, timeout, out.read_text(), err.read_text())
            return subprocess.CompletedProcess(command, ended["code"], out.read_text(), err.read_text())


_SERVER = _CommandServer()


@pytest.fixture(scope="session")
def five_bar_csv(tmp_path_factory: pytest.TempPathFactory) -> Path:
    """A five-bar dataset written by ``pincal simulate`` (12 postures, seed 1): read-only for the tests."""
    out = tmp_path_factory.mktemp("five_bar")
    done = run_pincal("simulate", "five_bar", "--samples", "12", "--seed", "1", "--quiet", "--out", str(out))
    assert done.returncode == 0, done.stderr
    return out / "measurements.csv"


#: A three-joint arm whose links carry no <inertial> mass, with a link named with XML's special characters (escaped in
#: the file: ``load<&>``) to hang a payload on. Lengths [m], limits [rad].
LIGHT_ARM_URDF = """<?xml version="1.0"?>
<robot name="light_arm">
  <link name="base"/><link name="upper"/><link name="fore"/><link name="hand"/><link name="tool"/>
  <link name="load&lt;&amp;&gt;"/>
  <joint name="yaw" type="revolute"><parent link="base"/><child link="upper"/>
    <origin xyz="0 0 0.1"/><axis xyz="0 0 1"/><limit lower="-2" upper="2" effort="10" velocity="1"/></joint>
  <joint name="shoulder" type="revolute"><parent link="upper"/><child link="fore"/>
    <origin xyz="0 0 0.3"/><axis xyz="0 1 0"/><limit lower="-1.5" upper="1.5" effort="10" velocity="1"/></joint>
  <joint name="elbow" type="revolute"><parent link="fore"/><child link="hand"/>
    <origin xyz="0.4 0 0"/><axis xyz="0 1 0"/><limit lower="-2" upper="2" effort="10" velocity="1"/></joint>
  <joint name="flange" type="fixed"><parent link="hand"/><child link="tool"/><origin xyz="0.3 0 0"/></joint>
  <joint name="grip" type="fixed"><parent link="tool"/><child link="load&lt;&amp;&gt;"/>
    <origin xyz="0.05 0 0"/></joint>
</robot>
"""
#: The options the light arm's data are simulated and calibrated with: joint compliances under 2 kg on ``load<&>``.
LIGHT_ARM_OPTIONS = ("--parameters", "default", "*.compliance", "--payload", "2@load<&>")


@pytest.fixture(scope="session")
def light_arm(tmp_path_factory: pytest.TempPathFactory) -> tuple[Path, Path]:
    """The light arm's URDF and 30 + 6 postures of it written by ``pincal simulate`` (seed 1) with
    :data:`LIGHT_ARM_OPTIONS`: (URDF, measurements CSV), read-only for the tests."""
    folder = tmp_path_factory.mktemp("light_arm")
    urdf = folder / "light_arm.urdf"
    urdf.write_text(LIGHT_ARM_URDF, encoding="utf-8")
    done = run_pincal("simulate", str(urdf), "--measure", "position:tool", "--samples", "30", "--test-samples", "6",
                      *LIGHT_ARM_OPTIONS, "--seed", "1", "--quiet", "--out", str(folder / "sim"))
    assert done.returncode == 0, done.stderr
    return urdf, folder / "sim" / "measurements.csv"


@pytest.fixture(scope="session")
def delta() -> pincal.Robot:
    return pincal.load_robot(ROBOTS / "delta.urdf")


@pytest.fixture(scope="session")
def delta_text() -> str:
    return (ROBOTS / "delta.urdf").read_text()


def finite_difference_jacobian(problem: Any, x: np.ndarray, eps: float = 1e-7) -> np.ndarray:
    """Central differences of ``problem.evaluate(x).residual`` w.r.t. each parameter: what the analytic
    Jacobians are checked against (finite differences nowhere else)."""
    columns = []
    for k in range(x.size):
        step = np.zeros(x.size)
        step[k] = eps
        plus = problem.evaluate(x + step, jacobian=False).residual
        minus = problem.evaluate(x - step, jacobian=False).residual
        columns.append((plus - minus) / (2 * eps))
    return np.column_stack(columns)


def random_readings(models: Any, n: int, rng: np.random.Generator) -> dict[str, np.ndarray]:
    """Arbitrary readings of ``models`` for ``n`` samples (what a prediction is compared with, not what a robot
    would read): normal values, unit quaternions for poses, the first increment and the third sample of an
    occludable reading left out (NaN)."""
    values = {}
    for m in models:
        width = len(m.columns)
        data = rng.normal(scale=0.3, size=(n, width))
        if width == 7:  # a pose: a random unit quaternion
            data[:, 3:] = rng.normal(size=(n, 4))
            data[:, 3:] /= np.linalg.norm(data[:, 3:], axis=1)[:, None]
        if m.incremental:
            data[0] = np.nan
        if m.occludable:
            data[2] = np.nan  # a reading not taken
        values[m.key] = data
    return values
