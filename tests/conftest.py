"""Shared fixtures: repository paths and robots loaded once per session."""

from __future__ import annotations

from pathlib import Path

import pytest

import pincal

ROOT = Path(__file__).resolve().parents[1]
ROBOTS = ROOT / "robots_urdf"


@pytest.fixture(scope="session")
def delta() -> pincal.Robot:
    return pincal.load_robot(ROBOTS / "delta.urdf")


@pytest.fixture(scope="session")
def delta_text() -> str:
    return (ROBOTS / "delta.urdf").read_text()
