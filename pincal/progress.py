"""A one-line progress bar for long work: simulations, Monte Carlo studies, pose selection, scenes.

Shown on stderr only when stderr is a terminal (so logs and pipes stay clean), and never with
``quiet=True``. Library functions keep it off unless asked (``progress=True``); the command line turns
it on unless ``--quiet``.
"""

from __future__ import annotations

import sys
from typing import TextIO

#: Characters of the bar between the brackets.
WIDTH = 30


class Progress:
    """A one-line progress bar for long loops, on stderr when it is a terminal (or on ``stream``).

    Use as a context manager and call :meth:`advance` once per finished step; ``quiet=True``
    silences it. The line is redrawn only when the bar grows, so a tick costs next to nothing.
    """

    def __init__(self, label: str, total: int, quiet: bool = False, stream: TextIO | None = None) -> None:
        self.label, self.total, self.done = label, total, 0
        self.stream = sys.stderr if stream is None else stream
        self.active = not quiet and total > 0 and (stream is not None or self.stream.isatty())
        self._shown = -1

    def __enter__(self) -> Progress:
        self._draw()
        return self

    def advance(self, n: int = 1) -> None:
        """Count ``n`` more finished steps (the count stops at ``total``)."""
        self.done = min(self.total, self.done + n)
        self._draw()

    def finish(self) -> None:
        """Fill the bar: the work ended before the ``total`` planned steps (e.g. a search converged)."""
        self.advance(self.total - self.done)

    def _draw(self) -> None:
        if not self.active:
            return
        filled = WIDTH * self.done // self.total
        if filled == self._shown and self.done != self.total:
            return
        self._shown = filled
        self.stream.write(f"\r{self.label} [{'#' * filled}{'.' * (WIDTH - filled)}] {self.done}/{self.total}")
        self.stream.flush()

    def __exit__(self, *exc: object) -> None:
        if self.active:
            self.stream.write("\n")
            self.stream.flush()
