"""The cross-validations of the TIAGo job, the command's work alone (no start, no imports), before and after.

Run: ``python benchmarks/bench_crossval.py`` (``--before REV``, default ``e429d2a`` as ``bench_commands.py``;
``--repeats K``, default 5 rounds; ``--runs M``, default 3 calls per round and case). Each revision's ``pincal/``
(exported as ``bench_commands.py`` does) runs in its own process, the two alternating round by round, with one BLAS
thread (as the ``pincal`` command sets it): ``pincal calibrate examples/tiago_job.toml`` with its options
(``--cv 5x4``, ``--cv loo``, none) is called ``M`` times in the process after one warm-up call, each call's CPU time
measured by ``time.process_time``. Printed: per case the median CPU time of a call before and after, their ratio,
and the cross-validation's own time (the case less the job without ``--cv``). ``bench_commands.py`` measures whole
commands, start included; on a machine shared with other work its spread is about the size of the changes made
here, which these calls, in warm processes and many times over, resolve.
"""

from __future__ import annotations

import argparse
import json
import os
import statistics
import subprocess
import sys
import tempfile
from pathlib import Path

sys.path.insert(0, str(Path(__file__).resolve().parent))
from bench_commands import BEFORE, ROOT, environment, export

ROUND = r"""
import contextlib, io, json, statistics, sys, time
from pincal.cli.app import main as run
job, runs, cases = sys.argv[1], int(sys.argv[2]), json.loads(sys.argv[3])
def call(extra):
    sys.argv = ["pincal", "calibrate", job, *extra]
    with contextlib.redirect_stdout(io.StringIO()), contextlib.redirect_stderr(io.StringIO()):
        code = run()
    if code:
        raise SystemExit(f"pincal calibrate {job} {' '.join(extra)} exited with {code}")
out = {}
for name, extra in cases.items():
    call(extra)  # warm-up: the modules the case loads, the robot's files
    times = []
    for _ in range(runs):
        start = time.process_time(); call(extra); times.append(time.process_time() - start)
    out[name] = times
print(json.dumps(out))
"""

#: The cases: the TIAGo job's options.
CASES = {"the job (no --cv)": [], "--cv 5x4": ["--cv", "5x4"], "--cv loo": ["--cv", "loo"]}


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--before", default=BEFORE, help=f"the revision to compare with (default {BEFORE})")
    parser.add_argument("--repeats", type=int, default=5)
    parser.add_argument("--runs", type=int, default=3)
    args = parser.parse_args()
    job = str(ROOT / "examples/tiago_job.toml")
    times: dict[tuple[str, str], list[float]] = {}
    with tempfile.TemporaryDirectory() as folder:
        work = Path(folder)
        sources = {"before": export(args.before, work / "before"), "after": export(None, work / "after")}
        for _ in range(args.repeats):
            for side, source in sources.items():
                env = {**environment(source), "OPENBLAS_NUM_THREADS": "1", "OMP_NUM_THREADS": "1"}
                done = subprocess.run([sys.executable, "-c", ROUND, job, str(args.runs), json.dumps(CASES)], env=env,
                                      capture_output=True, text=True, check=True, cwd=work)
                for name, values in json.loads(done.stdout).items():
                    times.setdefault((name, side), []).extend(values)
    med = {key: statistics.median(values) for key, values in times.items()}
    calls = len(next(iter(times.values())))
    print(f"python {sys.version.split()[0]}, {os.cpu_count()} cores, load {os.getloadavg()[0]:.1f}; medians of "
          f"{calls} calls ({args.repeats} rounds of {args.runs}); before = {args.before}, after = the working tree")
    print()
    print("| case (TIAGo job) | CPU before [s] | CPU after [s] | after / before | cross-validation before [s] | "
          "cross-validation after [s] | after / before |")
    print("|---|---|---|---|---|---|---|")
    plain = next(iter(CASES))
    for name in CASES:
        before, after = med[(name, "before")], med[(name, "after")]
        row = f"| {name} | {before:.3f} | {after:.3f} | {after / before:.2f} |"
        if name != plain:
            cv_before, cv_after = before - med[(plain, "before")], after - med[(plain, "after")]
            row += f" {cv_before:.3f} | {cv_after:.3f} | {cv_after / cv_before:.2f} |"
        else:
            row += " | | |"
        print(row)


if __name__ == "__main__":
    main()
