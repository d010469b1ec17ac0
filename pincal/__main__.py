"""``python -m pincal`` and the ``pincal`` console script: a start that imports nothing heavy before it can
answer a Ctrl-C with one line, and one BLAS thread for the whole command unless the user chose."""

from __future__ import annotations

import os
import signal
import sys
from types import FrameType

_interrupted = False

#: The variables that set how many threads the BLAS and OpenMP libraries NumPy, SciPy and Pinocchio load start.
THREAD_VARIABLES = ("OMP_NUM_THREADS", "OPENBLAS_NUM_THREADS", "MKL_NUM_THREADS", "BLIS_NUM_THREADS",
                    "VECLIB_MAXIMUM_THREADS", "NUMEXPR_NUM_THREADS")


def one_blas_thread() -> None:
    """Start the numerical libraries with one thread each, unless the user set any of :data:`THREAD_VARIABLES`.

    pincal's dense algebra is small (hundreds × tens): threads only add overhead, and on a loaded machine they made
    whole commands several times slower. The libraries read the variables once, when they load, so this runs
    before anything imports NumPy; the worker processes of ``pincal fleet`` inherit it."""
    if not any(name in os.environ for name in THREAD_VARIABLES):
        os.environ.update(dict.fromkeys(THREAD_VARIABLES, "1"))


def _on_interrupt(signum: int, frame: FrameType | None) -> None:
    """Remember the Ctrl-C, then raise it as Python's own handler does.

    CPython raises a pending ``KeyboardInterrupt`` wherever the interpreter next checks for signals; when that
    happens inside a C extension that clears errors (Boost.Python's converters do), the exception is lost and
    the command would run on as if no key had been pressed. The flag lets :func:`main` honour it anyway."""
    global _interrupted
    _interrupted = True
    raise KeyboardInterrupt


def main() -> int:
    """Run the command line (:func:`pincal.cli.app.main`); an interrupt at any point ends with exit code 130."""
    one_blas_thread()
    if signal.getsignal(signal.SIGINT) is signal.default_int_handler:  # not when started with SIGINT ignored
        signal.signal(signal.SIGINT, _on_interrupt)
    try:
        from pincal.cli.app import main as run

        code = run()  # answers an interrupt it sees with one line and 130 itself
    except KeyboardInterrupt:  # one during the imports, before the command line could answer it
        code = 130
        print("pincal: interrupted", file=sys.stderr)
    if _interrupted and code != 130:  # an interrupt some library swallowed still ends the command as interrupted
        print("pincal: interrupted", file=sys.stderr)
        return 130
    return code


if __name__ == "__main__":
    sys.exit(main())
