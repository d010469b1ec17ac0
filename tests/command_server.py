"""The process the tests' ``pincal`` commands are forked from: it imports pincal and its heavy dependencies once,
then runs each command in a child of its own, as the console script would.

Started by ``conftest.run_pincal`` (one per test worker) as ``python command_server.py``, with one BLAS thread as the
``pincal`` command starts. It reads one JSON request per line on stdin (``args``, ``cwd``, ``env``, ``stdout``,
``stderr``: the command's arguments, folder, whole environment and the two files its output goes to) and answers on
the standard output it had at start, a JSON line each: ``{"pid": …}`` when the child is forked, ``{"code": …}`` when
it has ended (its exit code; ``-N`` when signal N killed it).

The child is a process of its own: its own folder, environment, file descriptors and exit, through
``pincal.__main__.main`` (the console script's entry, with its Ctrl-C handling and one line per error), ended by the
interpreter's own exit (``atexit`` handlers, flushed streams). What it does not repeat is the imports: how a ``pincal``
process starts (lazy imports, ``--help`` without Pinocchio) is tested by ``tests/cli/test_start.py`` on processes
started from scratch. ``PINCAL_TEST_EXEC=1`` makes ``run_pincal`` start every command from scratch instead.
"""

from __future__ import annotations

import json
import os
import sys
import traceback

#: The modules preloaded: what a command imports that takes time (Pinocchio, SciPy, matplotlib, meshcat), by way of
#: the command line and the pages.
PRELOADED = ("pincal.__main__", "pincal.cli.app", "pincal.calibration.pipeline", "pincal.viz.html_report",
             "pincal.viz.scene")


def child(request: dict, replies: int) -> None:
    """Run the command of ``request`` in this (forked) process; never returns."""
    os.close(replies)
    code: object = 1
    try:
        os.chdir(request["cwd"])
        os.environ.clear()
        os.environ.update(request["env"])
        for fd, path, flags in ((0, os.devnull, os.O_RDONLY),
                                (1, request["stdout"], os.O_WRONLY | os.O_CREAT | os.O_TRUNC),
                                (2, request["stderr"], os.O_WRONLY | os.O_CREAT | os.O_TRUNC)):
            opened = os.open(path, flags, 0o644)
            os.dup2(opened, fd)
            os.close(opened)
        sys.stdin = open(0, encoding=sys.stdin.encoding, closefd=False)
        sys.argv = [request["program"], *request["args"]]
        from pincal.__main__ import main

        code = main()
    except SystemExit as exc:  # argparse's exit, as the interpreter would end with it
        code = exc.code
    except BaseException:
        traceback.print_exc()
        code = 1
    sys.exit(code)


def serve() -> None:
    """Import :data:`PRELOADED`, then fork a child per request line until stdin closes."""
    for name in PRELOADED:
        __import__(name)
    replies = os.dup(1)
    os.dup2(os.open(os.devnull, os.O_WRONLY), 1)  # nothing of this process' own reaches the replies

    def reply(message: dict) -> None:
        os.write(replies, (json.dumps(message) + "\n").encode())

    for line in sys.stdin:
        request = json.loads(line)
        sys.stdout.flush()
        sys.stderr.flush()
        pid = os.fork()
        if pid == 0:
            child(request, replies)
        reply({"pid": pid})
        _, status = os.waitpid(pid, 0)
        reply({"code": os.waitstatus_to_exitcode(status)})


if __name__ == "__main__":
    serve()
