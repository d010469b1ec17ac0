"""Library ``calibrate()`` as a Python user calls it: in a process started with no BLAS thread variable, before and
after, side by side.

Run: ``python benchmarks/bench_threads.py`` (``--before REV``, default ``7a3a1be``: main before ``calibrate()`` held
BLAS at one thread for its whole work; ``--repeats K``, default 5 rounds; ``--busy B``, default 1: B processes that
spin on a core of their own while it measures, as another user's job loads a shared machine; 0 for none). The
``pincal`` command starts its libraries on one thread (``pincal/__main__.py``), and ``identify`` limits them while it
fits; a script that imports pincal starts them with as many threads as the machine has, and the rest of
``calibrate()`` (model selection, the range guard, the bound's hold-outs: hundreds of small eigen-decompositions) ran
on them. Each case is one process per
round, each revision's ``pincal/`` alternating, with no thread variable set (:func:`bench_commands.environment`).

Cases (real data shipped in ``examples/``): the TIAGo job (34 postures, motion capture) and the TALOS left arm's
table-contact job (21 rows), each calibrated :data:`CALLS` times in one process (the imports and the reading of the
files excluded). Printed: per case, the median CPU time [s] of the first call and of the later ones, before and after,
their ratios, and the median wall time of the later calls after; and whether the two revisions' report JSONs are the
same bytes. The later calls are where it shows: SciPy's BLAS, loaded by the first call, kept both its threads.
"""

from __future__ import annotations

import argparse
import json
import os
import platform
import statistics
import subprocess
import sys
import tempfile
from pathlib import Path

sys.path.insert(0, str(Path(__file__).resolve().parent))
from bench_commands import environment, export

ROOT = Path(__file__).resolve().parent.parent
BEFORE = "7a3a1be"
CASES = {"TIAGo job (34 postures)": ROOT / "examples" / "tiago_job.toml",
         "TALOS left arm on the table (21 rows)": ROOT / "examples" / "data" / "talos_table_contact" / "left_job.toml"}
#: One process: read the job, then call ``calibrate()`` CALLS times, as a study script does; print each call's CPU and
#: wall time and the last report's JSON.
CALLS = 6
RUN = r"""
import json, sys, time
from pincal.calibration import calibrate
from pincal.calibration.from_files import read_inputs
inputs = read_inputs("calibrate", sys.argv[1], None)
cpu, wall = [], []
for _ in range(int(sys.argv[2])):
    c, w = time.process_time(), time.perf_counter()
    done = calibrate(inputs.robot, inputs.dataset, inputs.options)
    cpu.append(time.process_time() - c)
    wall.append(time.perf_counter() - w)
print(json.dumps({"cpu": cpu, "wall": wall, "report": done.report.to_json()}))
"""


def once(source: Path, job: Path) -> dict[str, object]:
    """One process of ``source``'s ``pincal/`` (started in its parent folder, not in ROOT: ``python -c`` puts the
    folder it starts in first on the path, and ROOT's ``pincal/`` would be imported instead)."""
    done = subprocess.run([sys.executable, "-c", RUN, str(job), str(CALLS)], env=environment(source), cwd=source,
                          capture_output=True, text=True, check=False)
    if done.returncode != 0:
        raise SystemExit(f"calibrate() of {job} failed:\n{done.stderr}")
    found: dict[str, object] = json.loads(done.stdout.strip().splitlines()[-1])
    return found


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    parser.add_argument("--before", default=BEFORE)
    parser.add_argument("--repeats", type=int, default=5)
    parser.add_argument("--busy", type=int, default=1)
    args = parser.parse_args()
    spinning = [subprocess.Popen([sys.executable, "-c", "while True: pass"]) for _ in range(args.busy)]
    try:
        measure(args)
    finally:
        for process in spinning:
            process.kill()


def measure(args: argparse.Namespace) -> None:
    with tempfile.TemporaryDirectory() as work:
        trees = {"before": export(args.before, Path(work) / "before"), "after": export(None, Path(work) / "after")}
        print(f"python {platform.python_version()}, {os.cpu_count()} cores, load {os.getloadavg()[0]:.1f}; "
              f"medians of {args.repeats} runs; before = {args.before}, after = the working tree; no thread variable; "
              f"{args.busy} busy process(es) beside")
        print("| case | CPU before: first / later call [s] | CPU after: first / later [s] | after / before: first / "
              "later | wall after, later calls [s] | same report JSON |")
        print("|---|---|---|---|---|---|")
        for name, job in CASES.items():
            runs: dict[str, list[dict[str, object]]] = {"before": [], "after": []}
            for _ in range(args.repeats):
                for side, tree in trees.items():
                    runs[side].append(once(tree, job))
            first = {side: statistics.median(float(r["cpu"][0]) for r in found)  # type: ignore[index]
                     for side, found in runs.items()}
            later = {side: statistics.median(c for r in found for c in r["cpu"][1:])  # type: ignore[attr-defined]
                     for side, found in runs.items()}
            wall = statistics.median(w for r in runs["after"] for w in r["wall"][1:])  # type: ignore[attr-defined]
            same = runs["before"][0]["report"] == runs["after"][0]["report"]
            ratios = f"{first['after'] / first['before']:.2f} / {later['after'] / later['before']:.2f}"
            print(f"| {name} | {first['before']:.2f} / {later['before']:.2f} | {first['after']:.2f} / "
                  f"{later['after']:.2f} | {ratios} | {wall:.2f} | {'yes' if same else 'NO'} |")


if __name__ == "__main__":
    main()
