"""The command line starts light: parsing the arguments (``--help``, ``--version``-like help of every command, an
argument error) imports neither Pinocchio nor SciPy (nor NumPy, nor rosbags); the work's modules load when a command
runs."""

from __future__ import annotations

import argparse
import os
import subprocess
import sys
from pathlib import Path

import pytest
from conftest import PINCAL

from pincal.cli.app import build_parser

HEAVY = ("pinocchio", "scipy", "matplotlib", "meshcat", "numpy", "rosbags")

PROBE = """
import sys
from pincal.cli.app import main
try:
    code = main({argv!r})
except SystemExit as exc:
    code = exc.code
print(code, sorted(m for m in {heavy!r} if m in sys.modules))
"""


def _loaded(argv: list[str], heavy: tuple[str, ...] = HEAVY) -> tuple[str, str]:
    done = subprocess.run([sys.executable, "-P", "-c", PROBE.format(argv=argv, heavy=heavy)], capture_output=True,
                          text=True, timeout=120, check=False)
    code, _, modules = done.stdout.strip().splitlines()[-1].partition(" ")
    return code, modules


COMMANDS = ("info", "simulate", "calibrate", "demo", "fleet", "view", "report", "design", "check", "montecarlo",
            "compensate", "export", "import")


@pytest.mark.parametrize("argv", [["--help"], ["--version"], *([c, "--help"] for c in COMMANDS)])
def test_help_imports_no_numerical_library(argv: list[str]) -> None:
    assert _loaded(argv) == ("0", "[]")


@pytest.mark.parametrize("argv", [[], ["calibrate", "delta", "d.csv", "--solver", "gn"], ["simulate", "delta"],
                                  ["report", "delta", "d.csv", "--max-iter", "0", "--out", "x.html"],
                                  ["compensate", "delta", "t.csv"], ["import", "ur10", "r.bag", "--joints", "/j"]])
def test_an_argument_error_imports_no_numerical_library(argv: list[str]) -> None:
    assert _loaded(argv) == ("2", "[]")


def test_a_command_that_works_loads_them() -> None:
    """The probe can fail: a command that does its work imports Pinocchio."""
    code, modules = _loaded(["info", "delta"])
    assert code == "0" and "pinocchio" in modules


def test_a_calibration_loads_no_statistics_nor_special_functions_nor_plots(tmp_path: Path) -> None:
    """The calibrate path takes its χ² quantiles without ``scipy.stats`` or ``scipy.special`` (each a tenth of a second
    or more of every start), its LAPACK routines without ``scipy.linalg``'s Python layer (as long to import as NumPy
    and Pinocchio) and draws nothing; the report command loads neither matplotlib (its colour maps are tables, a
    camera section alone draws with it) nor meshcat's server stack (500 modules), but does load meshcat's geometry
    (the probe can fail)."""
    data = tmp_path / "d"
    done = subprocess.run([str(PINCAL), "simulate", "delta", "--samples", "30", "--test-samples", "10", "--quiet",
                           "--out", str(data)], capture_output=True, text=True, timeout=300, check=False)
    assert done.returncode == 0, done.stderr
    light = ("scipy.stats", "scipy.special", "scipy.linalg", "matplotlib")
    csv = str(data / "measurements.csv")
    assert _loaded(["calibrate", "delta", csv, "--out", str(tmp_path / "cal.urdf")], light) == ("0", "[]")
    # the page's 3D scene is meshcat's drawing commands, recorded without its server (tornado, zmq, IPython)
    server = ("meshcat.visualizer", "tornado", "zmq", "IPython")
    code, modules = _loaded(["report", "delta", csv, "--quiet", "--out", str(tmp_path / "r.html")],
                            light + server + ("meshcat.geometry",))
    assert (code, modules) == ("0", "['meshcat.geometry']")
    # the console script's start: one BLAS thread from the start, so no threadpoolctl; a shipped robot, so no
    # distribution metadata (its e-mail parser)
    probe = ("import sys; from pincal.__main__ import main; sys.argv[0] = 'pincal'; code = main(); "
             "print(code, [m for m in ('threadpoolctl', 'importlib.metadata') if m in sys.modules])")
    env = {k: v for k, v in os.environ.items() if not k.endswith("_NUM_THREADS")}
    done = subprocess.run([sys.executable, "-P", "-c", probe, "calibrate", "delta", csv], capture_output=True,
                          text=True, timeout=120, check=False, env=env)
    assert done.stdout.strip().splitlines()[-1] == "0 []", done.stderr


#: A plugin (loaded before the command runs) that reports the thread count of every BLAS library loaded.
BLAS_PROBE = """
import sys

import numpy
from threadpoolctl import threadpool_info

print("blas threads", sorted({p["num_threads"] for p in threadpool_info() if p["user_api"] == "blas"}),
      file=sys.stderr)
"""


@pytest.mark.parametrize(("variables", "threads"), [({}, "[1]"), ({"OPENBLAS_NUM_THREADS": "2"}, "[2]")])
def test_a_command_runs_blas_on_one_thread_unless_the_user_chose(tmp_path: Path, variables: dict[str, str],
                                                                  threads: str) -> None:
    plugin = tmp_path / "blas_probe.py"
    plugin.write_text(BLAS_PROBE, encoding="utf-8")
    env = {k: v for k, v in os.environ.items() if not k.endswith("_NUM_THREADS")}
    env |= {"PINCAL_PLUGINS": str(plugin), **variables}
    done = subprocess.run([str(PINCAL), "info", "delta"], capture_output=True, text=True, timeout=120, check=False,
                          env=env)
    assert done.returncode == 0, done.stderr
    assert f"blas threads {threads}" in done.stderr


def test_the_console_script_takes_ctrl_c_before_importing_anything() -> None:
    """Between the interpreter's SIGINT handler and pincal's, a Ctrl-C prints Python's traceback: the console script
    imports ``pincal`` and ``pincal.__main__`` before :func:`pincal.__main__.main` installs its own, so they import
    nothing the interpreter has not loaded (once ``typing``, ``signal`` and ``collections.abc`` were imported there:
    on a busy machine a Ctrl-C 0.15 s after the start landed in them 1 time in 6 and printed a traceback)."""
    probe = ("import sys; before = set(sys.modules); from pincal.__main__ import main; "
             "print(sorted(set(sys.modules) - before))")
    done = subprocess.run([sys.executable, "-P", "-c", probe], capture_output=True, text=True, timeout=120,
                          check=False)
    assert done.returncode == 0, done.stderr
    assert set(eval(done.stdout)) <= {"__future__", "pincal", "pincal.__main__", "pincal.errors", "pincal.lazy"}


def _commands(parser: argparse.ArgumentParser) -> dict[str, argparse.ArgumentParser]:
    action = next(a for a in parser._actions if isinstance(a, argparse._SubParsersAction))
    return dict(action.choices)


def test_a_command_line_builds_the_parser_of_its_command_alone() -> None:
    """The other commands' parsers are not built; what the command's parser reads is what the whole parser reads."""
    every = _commands(build_parser())
    assert list(_commands(build_parser("calibrate"))) == ["calibrate"]
    assert list(_commands(build_parser("iso9283"))) == ["iso9283"]
    assert list(_commands(build_parser("nonesuch"))) == list(every)  # the error lists every command
    for argv in (["calibrate", "delta", "data.csv", "--cv", "5x4", "--out", "cal.urdf"],
                 ["iso9283", "plan", "ur10", "--out", "plan.csv"], ["robots"]):
        assert vars(build_parser(argv[0]).parse_args(argv)) == vars(build_parser().parse_args(argv))
        assert _commands(build_parser(argv[0]))[argv[0]].format_help() == every[argv[0]].format_help()
