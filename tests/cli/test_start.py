"""The command line starts light: parsing the arguments (``--help``, ``--version``-like help of every command, an
argument error) imports neither Pinocchio nor SciPy (nor NumPy, nor rosbags); the work's modules load when a command
runs."""

from __future__ import annotations

import subprocess
import sys

import pytest

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


def _loaded(argv: list[str]) -> tuple[str, str]:
    done = subprocess.run([sys.executable, "-P", "-c", PROBE.format(argv=argv, heavy=HEAVY)], capture_output=True,
                          text=True, timeout=120, check=False)
    code, _, modules = done.stdout.strip().splitlines()[-1].partition(" ")
    return code, modules


@pytest.mark.parametrize("argv", [["--help"], *([c, "--help"] for c in ("info", "simulate", "calibrate", "demo",
                                                                          "fleet", "view", "report", "design", "check",
                                                                          "montecarlo", "compensate", "export",
                                                                          "import"))])
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
