"""``pincal --version`` prints the installed package's version, the one pyproject.toml declares and
``pincal.__version__`` holds."""

from __future__ import annotations

import tomllib

from conftest import ROOT, run_pincal

import pincal


def test_version_prints_the_declared_version() -> None:
    declared = tomllib.loads((ROOT / "pyproject.toml").read_text(encoding="utf-8"))["project"]["version"]
    done = run_pincal("--version")
    assert done.returncode == 0, done.stderr
    assert done.stdout == f"pincal {declared}\n" and done.stderr == ""
    assert pincal.__version__ == declared


def test_version_comes_before_any_command() -> None:
    """``--version`` answers alone; with a command after it, it still answers and runs nothing."""
    done = run_pincal("--version", "info", "no-such-robot")
    assert done.returncode == 0 and done.stdout.startswith("pincal ") and done.stderr == ""
