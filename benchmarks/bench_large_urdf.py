"""``pincal simulate`` of a robot file bloated by blanks, comments or visual elements (issue 36: a 50 MB URDF was read
far too slowly), a revision before beside the working tree, in one run: CPU time and peak memory of the command.

Run: ``python benchmarks/bench_large_urdf.py`` (``--before REV``, default ``10551e0``: main when issue 36 was taken up;
``--repeats K``, default 3). The robot is example-robot-data's UR10 (12 kB), as shipped and with, before its
``</robot>``: 0.1 MB of blanks (a run of blanks was rescanned from each of its characters: quadratic), a 10 MB comment,
10 MB of ``<visual>`` boxes on its base link (both under the 10 MiB cap) and a 50 MB comment (above it: refused before
it is read). Each case is ``pincal simulate FILE --samples 10 --seed 1 --quiet --out DIR`` in a process of its own, as
``bench_many_loops.py`` runs commands (CPU time and peak memory from ``wait4``), before and after in turns.
"""

from __future__ import annotations

import argparse
import os
import platform
import shutil
import statistics
import tempfile
from pathlib import Path

from bench_commands import environment, export
from bench_many_loops import measured

BEFORE = "10551e0"  # main when issue 36 was taken up
VISUAL = '<visual><origin xyz="0 0 0" rpy="0 0 0"/><geometry><box size="0.1 0.1 0.1"/></geometry></visual>'


def robot_files(folder: Path) -> dict[str, Path]:
    """The UR10's URDF as shipped and bloated, each written in ``folder``; by case name."""
    from pincal.model.catalog import robot_path  # the working tree's catalog finds example-robot-data

    text = robot_path("ur10").read_text(encoding="utf-8")
    end, base = text.index("</robot>"), text.index('<link name="base_link">') + len('<link name="base_link">')
    variants = {"as shipped (12 kB)": text,
                "+ 0.1 MB of blanks": text[:end] + " " * 100_000 + text[end:],
                "+ a 10 MB comment": text[:end] + "<!-- " + "x" * 10_000_000 + " -->" + text[end:],
                "+ 10 MB of <visual> boxes": text[:base] + VISUAL * (10_000_000 // len(VISUAL)) + text[base:],
                "+ a 50 MB comment": text[:end] + "<!-- " + "x" * 50_000_000 + " -->" + text[end:]}
    files = {}
    for k, (name, variant) in enumerate(variants.items()):
        files[name] = folder / f"ur10_{k}.urdf"
        files[name].write_text(variant, encoding="utf-8")
    return files


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--before", default=BEFORE, help=f"the revision to compare with (default {BEFORE})")
    parser.add_argument("--repeats", type=int, default=3)
    args = parser.parse_args()
    cpu: dict[tuple[str, str], list[float]] = {}
    memory: dict[tuple[str, str], list[float]] = {}
    with tempfile.TemporaryDirectory() as folder:
        work = Path(folder)
        sources = {"before": export(args.before, work / "before"), "after": export(None, work / "after")}
        files = robot_files(work)
        for _ in range(args.repeats):  # interleaved: every case before and after, then again
            for name, path in files.items():
                for side, source in sources.items():
                    shutil.rmtree(work / "sim", ignore_errors=True)
                    argv = ["simulate", str(path), "--samples", "10", "--seed", "1", "--quiet", "--out", "sim"]
                    seconds, peak = measured(argv, environment(source), work, codes=(0, 2))
                    cpu.setdefault((name, side), []).append(seconds)
                    memory.setdefault((name, side), []).append(peak)
        sizes = {name: path.stat().st_size / 1e6 for name, path in files.items()}
    print(f"python {platform.python_version()}, {os.cpu_count()} cores, load {os.getloadavg()[0]:.1f}; medians of "
          f"{args.repeats} runs; before = {args.before}, after = the working tree")
    print()
    print("| `pincal simulate` of the UR10 | file [MB] | CPU before [s] | CPU after [s] | after / before | "
          "peak memory before [MB] | peak memory after [MB] |")
    print("|---|---|---|---|---|---|---|")
    for name in files:
        c = {side: statistics.median(cpu[(name, side)]) for side in sources}
        m = {side: statistics.median(memory[(name, side)]) for side in sources}
        print(f"| {name} | {sizes[name]:.2f} | {c['before']:.2f} | {c['after']:.2f} | {c['after'] / c['before']:.2f} | "
              f"{m['before']:.0f} | {m['after']:.0f} |")


if __name__ == "__main__":
    main()
