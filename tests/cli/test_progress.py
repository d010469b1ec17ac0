"""Progress where a user waits: ``pincal import`` reading a bag and ``pincal demo`` writing its report show a bar per
stage on a terminal (stderr a pty here, as in a user's shell), and ``--quiet`` or a pipe shows none."""

from __future__ import annotations

import os
import subprocess
import sys
import threading
from pathlib import Path

from conftest import PINCAL, ROOT, run_pincal


def _on_terminal(*args: str, cwd: Path) -> tuple[subprocess.CompletedProcess[str], str]:
    """``pincal ARGS`` started from scratch with stderr on a pseudo-terminal (stdout a pipe): the run (exit code and
    stdout) and what the terminal received."""
    master, slave = os.openpty()
    received: list[bytes] = []

    def drain() -> None:  # the terminal's buffer is small: read while the command writes
        while True:
            try:
                chunk = os.read(master, 4096)
            except OSError:  # EIO: every writer closed the terminal
                return
            if not chunk:
                return
            received.append(chunk)

    reader = threading.Thread(target=drain)
    reader.start()
    try:
        done = subprocess.run([str(PINCAL), *args], stdout=subprocess.PIPE, stderr=slave, text=True, cwd=cwd,
                              timeout=300, check=False)
    finally:
        os.close(slave)
        reader.join(timeout=30)
        os.close(master)
    return done, b"".join(received).decode("utf-8", errors="replace")


def _bars(terminal: str) -> dict[str, str]:
    """Each bar's label and its last state (``k/n``) as the terminal shows them."""
    bars = {}
    for line in terminal.replace("\r\n", "\n").replace("\r", "\n").split("\n"):
        label, bracket, rest = line.partition(" [")
        if bracket and "] " in rest:
            bars[label.strip()] = rest.rsplit("] ", 1)[1].strip()
    return bars


def test_pincal_import_shows_a_bar_per_topic_read(tmp_path: Path) -> None:
    done = run_pincal("simulate", "ur10", "--measure", "pose", "--samples", "6", "--test-samples", "0", "--seed", "3",
                      "--out", "sim", "--quiet", cwd=tmp_path)
    assert done.returncode == 0, done.stderr
    recorded = subprocess.run([sys.executable, str(ROOT / "examples" / "ros_bag.py"), "sim/measurements.csv",
                               "run.bag"], capture_output=True, text=True, cwd=tmp_path, timeout=300, check=False)
    assert recorded.returncode == 0, recorded.stderr
    common = ["import", "ur10", "run.bag", "--joints", "/joint_states", "--pose", "/mocap/tool", "--out"]
    done, terminal = _on_terminal(*common, "data.csv", cwd=tmp_path)
    assert done.returncode == 0, terminal
    bars = _bars(terminal)
    assert set(bars) == {"reading /joint_states", "reading /mocap/tool"}
    for state in bars.values():  # every message counted, as many as the bag holds
        read, total = state.split("/")
        assert read == total and int(total) > 100
    assert "kept 6 of " in done.stdout  # the six postures, as without a terminal
    quiet, terminal = _on_terminal(*common, "quiet.csv", "--quiet", cwd=tmp_path)
    assert quiet.returncode == 0 and terminal == "" and quiet.stdout == done.stdout.replace("data.csv", "quiet.csv")
    piped = run_pincal(*common, "piped.csv", cwd=tmp_path)  # stderr a pipe: no bar either
    assert piped.returncode == 0 and piped.stderr == ""


def test_pincal_demo_shows_the_report_stages(tmp_path: Path) -> None:
    """The demo's report stage (seconds) has bars of its own after the simulation's and calibration's."""
    done, terminal = _on_terminal("demo", "--out", "demo", "--samples", "20", "--test-samples", "5", cwd=tmp_path)
    assert done.returncode == 0, terminal
    bars = _bars(terminal)
    assert bars["simulate, calibrate"] == "2/2"
    assert bars["figures"] == "4/4"
    assert {"forward kinematics", "scene samples"} <= set(bars)
    assert all(state.split("/")[0] == state.split("/")[1] for state in bars.values())
    assert (tmp_path / "demo" / "report.html").is_file()
