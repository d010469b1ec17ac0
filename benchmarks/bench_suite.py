"""The tests' ``pincal`` commands forked from the command server against started from scratch, side by side.

Run: ``python benchmarks/bench_suite.py`` (``--repeats K``, default 3; ``--files PATH ...``, default
``tests/cli/test_check.py``, whose tests run 52 commands). Each round runs the same test files in one pytest process
(``-n 0``) twice: with ``run_pincal`` forking every command from ``tests/command_server.py`` (the suite's way), and with
``PINCAL_TEST_EXEC=1`` (every command the console script started from scratch), the two in turns. Printed: the
median CPU time (the pytest process and every process under it) and wall time of each, and their ratio. The whole
suite's own figure is ``.ci/run``'s (benchmarks/RESULTS.md, "The test suite").
"""

from __future__ import annotations

import argparse
import os
import statistics
import sys
from pathlib import Path

sys.path.insert(0, str(Path(__file__).resolve().parent))
from bench_commands import ROOT, timed

FILES = ("tests/cli/test_check.py",)


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--repeats", type=int, default=3, help="rounds, each way once per round")
    parser.add_argument("--files", nargs="*", default=list(FILES), help="test files, relative to the repository")
    args = parser.parse_args()
    command = [sys.executable, "-m", "pytest", "-q", "-p", "no:cacheprovider", "-n", "0", *args.files]
    ways = {"forked (the suite's way)": {}, "started from scratch (PINCAL_TEST_EXEC=1)": {"PINCAL_TEST_EXEC": "1"}}
    cpu: dict[str, list[float]] = {way: [] for way in ways}
    wall: dict[str, list[float]] = {way: [] for way in ways}
    for _ in range(args.repeats):
        for way, extra in ways.items():
            c, w = timed(command, {**os.environ, **extra}, ROOT)
            cpu[way].append(c)
            wall[way].append(w)
    print(f"python {sys.version.split()[0]}, {os.cpu_count()} cores, load {os.getloadavg()[0]:.1f}; medians of "
          f"{args.repeats} rounds; `pytest -n 0 {' '.join(args.files)}`")
    print("| commands | CPU [s] | wall [s] |")
    print("|---|---|---|")
    for way in ways:
        print(f"| {way} | {statistics.median(cpu[way]):.1f} | {statistics.median(wall[way]):.1f} |")
    forked, scratch = (statistics.median(cpu[way]) for way in ways)
    print(f"\nforked / from scratch: CPU {forked / scratch:.2f}")


if __name__ == "__main__":
    main()
