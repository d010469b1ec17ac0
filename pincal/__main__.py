"""``python -m pincal`` and the ``pincal`` console script: a start that imports nothing before it can answer a Ctrl-C
with one line, and one BLAS thread for the whole command unless the user chose.

Between the interpreter's own SIGINT handler (installed before its ``site`` module runs) and :func:`main`'s, a Ctrl-C
prints Python's traceback. That window is kept to what the interpreter itself needs: the console script imports
``pincal`` (which imports only :mod:`pincal.errors` and :mod:`pincal.lazy`, and they nothing the interpreter has not
loaded) and this module, which takes the handler from ``_signal``, the built-in module the interpreter loads at start
(``signal`` adds enums over it, and importing them cost more than everything else before the handler, on a machine
busy enough to make a 0.15 s Ctrl-C land there).
"""

from __future__ import annotations

import _signal  # the built-in under ``signal``, loaded with the interpreter: see the module's docstring
import os
import sys

TYPE_CHECKING = False  # typing.TYPE_CHECKING without importing typing (see the module's docstring)
if TYPE_CHECKING:
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
    """Run the command line (:func:`pincal.cli.app.main`); an interrupt at any point ends with exit code 130.

    A command started with SIGINT ignored (a background job of a shell script, ``nohup``) keeps ignoring it, as the
    interpreter and every Unix tool do: a Ctrl-C at the terminal is not meant for it."""
    if _signal.getsignal(_signal.SIGINT) is _signal.default_int_handler:  # not when started with SIGINT ignored
        _signal.signal(_signal.SIGINT, _on_interrupt)
    one_blas_thread()
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
