"""``pincal assemble`` and ``pincal info`` on a robot of N independent four-bars (issue 36: 66 loops held 0.9 GB), a
revision before beside the working tree, in one run: CPU time and peak memory of each whole command.

Run: ``python benchmarks/bench_many_loops.py`` (``--before REV``, default ``10551e0``: main when issue 36 was taken up;
``--loops N ...``, default 10 20 40 66; ``--repeats K``, default 3). The robot is ``tests/many_four_bars.py``'s: N
copies of the README's four-bar on one base, 3 joints each (66 loops: 198 joints, inside the 200-joint limit);
``assemble`` reads the draft (passive joints at the README's rough angles), ``info`` the assembled file. Both copies of
``pincal/`` are exported as ``bench_commands.py`` exports them and run in turns by the same interpreter, as the console
script runs them. Each run is one process; its CPU time (user + sys) and peak resident memory come from ``wait4``,
in a small process that starts it (:data:`PEAK`). Printed: the medians per command and size, before and after, and
their ratios; the floor is ``pincal info`` of one four-bar (the imports every command holds).
"""

from __future__ import annotations

import argparse
import os
import platform
import statistics
import subprocess
import sys
import tempfile
from pathlib import Path

from bench_commands import LAUNCH, environment, export

ROOT = Path(__file__).resolve().parent.parent
sys.path.insert(0, str(ROOT / "tests"))
from many_four_bars import many_four_bars_urdf  # noqa: E402  (the tests' generator, one definition)

BEFORE = "10551e0"  # main when issue 36 was taken up


#: Runs a command and writes its exit code, CPU time [s] and peak memory [kB] to a file. Peak memory is measured in a
#: process started by this small one: Linux counts a process's peak from before its ``exec`` (the forked copy of its
#: parent), so a command started by a large process would report that process's peak.
PEAK = ("import os, sys\n"
        "pid = os.posix_spawn(sys.argv[2], sys.argv[2:], os.environ)\n"
        "_, status, usage = os.wait4(pid, 0)\n"
        "open(sys.argv[1], 'w').write(f'{os.waitstatus_to_exitcode(status)} {usage.ru_utime + usage.ru_stime} "
        "{usage.ru_maxrss}')\n")


def measured(argv: list[str], env: dict[str, str], cwd: Path, codes: tuple[int, ...] = (0,)) -> tuple[float, float]:
    """One run of ``pincal ARGV``: (CPU time [s], peak resident memory [MB]) of its process, which must end with
    one of the exit ``codes``."""
    result = cwd / "measured.txt"
    done = subprocess.run([sys.executable, "-c", PEAK, str(result), sys.executable, "-c", LAUNCH, *argv], env=env,
                          cwd=cwd, stdout=subprocess.DEVNULL, stderr=subprocess.PIPE, check=False)
    code, seconds, peak = result.read_text(encoding="utf-8").split()
    if int(code) not in codes:
        raise SystemExit(f"pincal {' '.join(argv)} failed:\n{done.stderr.decode(errors='replace')}")
    return float(seconds), int(peak) / 1024


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--before", default=BEFORE, help=f"the revision to compare with (default {BEFORE})")
    parser.add_argument("--loops", type=int, nargs="*", default=[10, 20, 40, 66])
    parser.add_argument("--repeats", type=int, default=3)
    args = parser.parse_args()
    with tempfile.TemporaryDirectory() as folder:
        work = Path(folder)
        sources = {"before": export(args.before, work / "before"), "after": export(None, work / "after")}
        cases: dict[str, list[str]] = {"info, 1 loop (the floor)": ["info", "one.urdf"]}
        (work / "one.urdf").write_text(many_four_bars_urdf(1), encoding="utf-8")
        for n in args.loops:
            (work / f"draft_{n}.urdf").write_text(many_four_bars_urdf(n, assembled=False), encoding="utf-8")
            (work / f"robot_{n}.urdf").write_text(many_four_bars_urdf(n), encoding="utf-8")
            cases[f"assemble, {n} loops"] = ["assemble", f"draft_{n}.urdf", "--out", f"out_{n}.urdf"]
            cases[f"info, {n} loops"] = ["info", f"robot_{n}.urdf"]
        cpu: dict[tuple[str, str], list[float]] = {}
        memory: dict[tuple[str, str], list[float]] = {}
        for _ in range(args.repeats):  # interleaved: every case before and after, then again
            for name, argv in cases.items():
                for side, source in sources.items():
                    for stale in work.glob("out_*.urdf"):
                        stale.unlink()
                    seconds, peak = measured(argv, environment(source), work)
                    cpu.setdefault((name, side), []).append(seconds)
                    memory.setdefault((name, side), []).append(peak)
    print(f"python {platform.python_version()}, {os.cpu_count()} cores, load {os.getloadavg()[0]:.1f}; medians of "
          f"{args.repeats} runs; before = {args.before}, after = the working tree")
    print()
    print("| command | CPU before [s] | CPU after [s] | after / before | peak memory before [MB] | "
          "peak memory after [MB] | after / before |")
    print("|---|---|---|---|---|---|---|")
    for name in cases:
        cpu_of = {side: statistics.median(cpu[(name, side)]) for side in sources}
        memory_of = {side: statistics.median(memory[(name, side)]) for side in sources}
        c, m = cpu_of, memory_of
        print(f"| `pincal {name}` | {c['before']:.2f} | {c['after']:.2f} | {c['after'] / c['before']:.2f} | "
              f"{m['before']:.0f} | {m['after']:.0f} | {m['after'] / m['before']:.2f} |")


if __name__ == "__main__":
    main()
