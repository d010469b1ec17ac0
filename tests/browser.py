"""Headless Chromium for the tests: a screenshot of a page and its DOM after the page's JavaScript ran.

Debian's ``chromium`` package is required (``.ci/run`` installs it); without it the browser tests
fail with the command to install it.
"""

from __future__ import annotations

import contextlib
import functools
import http.server
import shutil
import subprocess
import tempfile
import threading
from collections.abc import Iterator
from dataclasses import dataclass
from pathlib import Path

import numpy as np
import numpy.typing as npt
import pytest
from PIL import Image

INSTALL = "apt-get update && apt-get install -y chromium   (as root; .ci/run does this)"
FLAGS = ("--headless", "--no-sandbox", "--disable-gpu", "--disable-quic", "--no-first-run",
         "--disable-background-networking", "--disable-component-update", "--disable-sync",
         # WebGL on the CPU: recent Chromium no longer falls back to SwiftShader on its own
         "--enable-unsafe-swiftshader")


def chromium() -> str:
    """Path of the chromium executable; fails the test (no skip) when it is missing."""
    path = shutil.which("chromium") or shutil.which("chromium-browser")
    if path is None and Path("/usr/bin/chromium").is_file():
        path = "/usr/bin/chromium"
    if path is None:
        pytest.fail(f"the browser tests need Debian's chromium, which is not installed: {INSTALL}")
    return path


@dataclass
class Page:
    """What the browser showed: the screenshot (H, W, 3) uint8 and the DOM after scripts ran."""

    screenshot: npt.NDArray[np.uint8]
    dom: str
    png: Path


def render(url: str, png: Path, size: tuple[int, int] = (1200, 900), budget_ms: int = 5000) -> Page:
    """Open ``url`` in headless Chromium; screenshot to ``png`` and return the page's final DOM."""
    with tempfile.TemporaryDirectory() as profile:
        command = [chromium(), *FLAGS, f"--user-data-dir={profile}", f"--screenshot={png}",
                   f"--window-size={size[0]},{size[1]}", f"--virtual-time-budget={budget_ms}", "--dump-dom", url]
        done = subprocess.run(command, capture_output=True, text=True, timeout=120, check=False)
    if done.returncode != 0 or not png.is_file():
        tail = "\n".join(done.stderr.splitlines()[-15:])
        pytest.fail(f"chromium failed on {url} (exit {done.returncode}):\n{tail}")
    image = np.asarray(Image.open(png).convert("RGB"))
    return Page(image, done.stdout, png)


def pixel_variance(image: npt.NDArray[np.uint8]) -> float:
    """Variance of the grey levels: 0 for a blank page."""
    return float(np.var(image.astype(float).mean(axis=2)))


def orange_pixels(image: npt.NDArray[np.uint8]) -> int:
    """Pixels of the calibrated robot's colour family (orange, lit or shaded)."""
    r, g, b = (image[..., k].astype(int) for k in range(3))
    return int(np.count_nonzero((r > 110) & (r - b > 60) & (g > 0.35 * r) & (g < 0.8 * r)))


class _QuietHandler(http.server.SimpleHTTPRequestHandler):
    def log_message(self, format: str, *args: object) -> None:
        pass


@contextlib.contextmanager
def served(directory: Path) -> Iterator[str]:
    """Serve ``directory`` on a free localhost port; yields the base URL."""
    handler = functools.partial(_QuietHandler, directory=str(directory))
    server = http.server.ThreadingHTTPServer(("127.0.0.1", 0), handler)
    thread = threading.Thread(target=server.serve_forever, daemon=True)
    thread.start()
    try:
        yield f"http://127.0.0.1:{server.server_address[1]}/"
    finally:
        server.shutdown()
        server.server_close()
