"""Whole commands as a user waits for them: process start to exit, CPU time (user + sys) and wall time, medians of
several runs, beside the imports no command can avoid, and a revision before beside the working tree, in one run.

Run: ``python benchmarks/bench_commands.py`` (``--before REV``, default ``e429d2a``: main before issue 27's work;
``--repeats K``, default 5; ``--only NAME ...``, e.g. ``--only TIAGo`` for the TIAGo job's report and calibrations).
Both copies of ``pincal/`` (REV's by ``git archive``, the working tree's copied), each byte-compiled as ``pip install``
leaves a package, are run in turns by the same interpreter, as the console script runs them
(``pincal.__main__.main``), with no thread variable set, as a user's shell has none. The
machine may be shared: CPU time is the figure to read (a busy machine stretches the wall time far more), and ratios
measured side by side in one run are what carry over to another machine. The data are simulated once, by the
working tree's ``pincal simulate``.

Printed: per command, the median CPU time before and after, their ratio, the median wall time after, and the CPU
time after as a multiple of the floor beside it (``python -c "import numpy"`` for what needs no numerical library,
``python -c "import numpy, scipy.linalg, pinocchio"`` for the rest, ``python -c "import numpy, pinocchio"`` for the
TIAGo job's calibrations, issue 42's floor); for ``report``, the page's size.
"""

from __future__ import annotations

import argparse
import compileall
import os
import platform
import resource
import shutil
import statistics
import subprocess
import sys
import tempfile
import time
from pathlib import Path

ROOT = Path(__file__).resolve().parent.parent
BEFORE = "e429d2a"  # main before issue 27's work
LAUNCH = "import sys; from pincal.__main__ import main; sys.argv[0] = 'pincal'; sys.exit(main())"
THREADS = ("OMP_NUM_THREADS", "OPENBLAS_NUM_THREADS", "MKL_NUM_THREADS", "BLIS_NUM_THREADS", "VECLIB_MAXIMUM_THREADS",
           "NUMEXPR_NUM_THREADS")
#: The TIAGo job's calibrations (34 fitted postures of real data: the robust path, with a bad-reading search in every
#: fit): the default, cross-validated, and with model selection by cross-validation.
TIAGO = {"": [], ", --cv 5x4": ["--cv", "5x4"], ", --cv loo": ["--cv", "loo"], ", --select cv": ["--select", "cv"]}
#: Issue 42's goals: a command's CPU time at most this many times ``python -c "import numpy, pinocchio"``'s.
GOALS = {"pincal calibrate delta (60 + 40 samples)": 1.6, "pincal calibrate ur10 (1000 samples)": 1.7,
         "pincal calibrate (TIAGo job, --cv 5x4)": 6.0, "pincal calibrate (TIAGo job, --cv loo)": 12.0,
         "pincal report (TIAGo job)": 4.0}
#: Issue 42's goal for ``--select cv``: at most this many times the default's CPU time.
SELECT_CV_GOAL = 3.0
FLOORS = {"numpy": "import numpy", "numpy+scipy+pin": "import numpy, scipy.linalg, pinocchio",
          "numpy+pin": "import numpy, pinocchio"}


def export(revision: str | None, into: Path) -> Path:
    """``pincal/`` with its robot files (``pincal/robots_urdf``) as of ``revision`` (None: the working tree),
    byte-compiled as ``pip install`` leaves it (without the ``.pyc`` files every run would compile pincal's modules
    first: 0.14 s of a 0.6 s command here, where ``PYTHONDONTWRITEBYTECODE`` is set and no import writes them)."""
    into.mkdir(parents=True)
    if revision is None:
        shutil.copytree(ROOT / "pincal", into / "pincal", ignore=shutil.ignore_patterns("__pycache__"))
        shutil.copytree(ROOT / "robots_urdf", into / "robots_urdf")
    else:
        archive = subprocess.run(["git", "-C", str(ROOT), "archive", revision, "pincal", "robots_urdf"], check=True,
                                 capture_output=True).stdout
        subprocess.run(["tar", "-x", "-C", str(into)], input=archive, check=True)
    (into / "robots_urdf").rename(into / "pincal" / "robots_urdf")
    compileall.compile_dir(into / "pincal", quiet=1)
    return into


def environment(source: Path | None) -> dict[str, str]:
    """The environment of a run: ``source`` first on the Python path, no thread variable."""
    env = {k: v for k, v in os.environ.items() if k not in THREADS and k != "PYTHONPATH"}
    if source is not None:
        env["PYTHONPATH"] = str(source)
    return env


def timed(command: list[str], env: dict[str, str], cwd: Path) -> tuple[float, float]:
    """One run of ``command``: (CPU time [s] of the process and its children, wall time [s])."""
    before, start = resource.getrusage(resource.RUSAGE_CHILDREN), time.perf_counter()
    done = subprocess.run(command, env=env, cwd=cwd, capture_output=True, text=True, check=False)
    wall, after = time.perf_counter() - start, resource.getrusage(resource.RUSAGE_CHILDREN)
    if done.returncode != 0:
        raise SystemExit(f"{' '.join(command)} failed:\n{done.stderr}")
    return after.ru_utime + after.ru_stime - before.ru_utime - before.ru_stime, wall


def cases(work: Path) -> dict[str, tuple[list[str], str]]:
    """Each command's arguments and the floor it is compared with."""
    return {
        "pincal --help": (["--help"], "numpy"),
        "pincal calibrate delta (60 + 40 samples)": (["calibrate", "delta", str(work / "delta/measurements.csv")],
                                                     "numpy+scipy+pin"),
        "pincal calibrate ur10 (1000 samples)": (["calibrate", "ur10", str(work / "ur10/measurements.csv")],
                                                 "numpy+scipy+pin"),
        "pincal demo": (["demo", "--out", str(work / "demo")], "numpy+scipy+pin"),
        "pincal report (TIAGo job)": (["report", str(ROOT / "examples/tiago_job.toml"), "--out",
                                       str(work / "tiago.html")], "numpy+scipy+pin"),
        **{f"pincal calibrate (TIAGo job{label})": (["calibrate", str(ROOT / "examples/tiago_job.toml"), *extra],
                                                    "numpy+pin") for label, extra in TIAGO.items()},
    }


def simulate(work: Path, after: Path) -> None:
    """The datasets, written once by the working tree's ``pincal simulate``."""
    env = environment(after)
    for robot, samples, tests in (("delta", 60, 40), ("ur10", 1000, 0)):
        timed([sys.executable, "-c", LAUNCH, "simulate", robot, "--samples", str(samples), "--test-samples", str(tests),
               "--seed", "1", "--quiet", "--out", str(work / robot)], env, work)


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--before", default=BEFORE, help=f"the revision to compare with (default {BEFORE})")
    parser.add_argument("--repeats", type=int, default=5)
    parser.add_argument("--only", nargs="*", help="commands whose name contains one of these words")
    args = parser.parse_args()
    with tempfile.TemporaryDirectory() as folder:
        work = Path(folder)
        sources = {"before": export(args.before, work / "before"), "after": export(None, work / "after")}
        simulate(work, sources["after"])
        chosen = {name: case for name, case in cases(work).items()
                  if not args.only or any(word in name for word in args.only)}
        cpu: dict[tuple[str, str], list[float]] = {}
        wall: dict[tuple[str, str], list[float]] = {}
        for _ in range(args.repeats):  # interleaved: every command before and after, then again
            for name, code in FLOORS.items():
                c, w = timed([sys.executable, "-c", code], environment(None), work)
                cpu.setdefault((name, "floor"), []).append(c)
                wall.setdefault((name, "floor"), []).append(w)
            for name, (argv, _) in chosen.items():
                for side, source in sources.items():
                    c, w = timed([sys.executable, "-c", LAUNCH, *argv], environment(source), work)
                    cpu.setdefault((name, side), []).append(c)
                    wall.setdefault((name, side), []).append(w)
        report(args, chosen, cpu, wall, work)


def report(args: argparse.Namespace, chosen: dict[str, tuple[list[str], str]],
           cpu: dict[tuple[str, str], list[float]], wall: dict[tuple[str, str], list[float]], work: Path) -> None:
    """The table of medians."""
    med = {key: statistics.median(values) for key, values in cpu.items()}
    med_wall = {key: statistics.median(values) for key, values in wall.items()}
    print(f"python {platform.python_version()}, {os.cpu_count()} cores, load {os.getloadavg()[0]:.1f}; "
          f"medians of {args.repeats} runs; before = {args.before}, after = the working tree")
    for name in FLOORS:
        print(f"floor `python -c \"{FLOORS[name]}\"`: CPU {med[(name, 'floor')]:.3f} s, "
              f"wall {med_wall[(name, 'floor')]:.3f} s")
    print()
    print("| command | CPU before [s] | CPU after [s] | after / before | wall after [s] | CPU after / floor |")
    print("|---|---|---|---|---|---|")
    for name, (_, floor) in chosen.items():
        before, after = med[(name, "before")], med[(name, "after")]
        print(f"| `{name}` | {before:.2f} | {after:.2f} | {after / before:.2f} | {med_wall[(name, 'after')]:.2f} | "
              f"{after / med[(floor, 'floor')]:.2f} × `{floor}` |")
    print()
    floor = med[("numpy+pin", "floor")]
    for name, goal in GOALS.items():
        if name in chosen:
            ratio = med[(name, "after")] / floor
            verdict = "met" if ratio <= goal else "not met"
            print(f"issue 42: `{name}` {ratio:.1f} × `numpy+pin` (goal ≤ {goal:g}: {verdict})")
    default, selected = "pincal calibrate (TIAGo job)", "pincal calibrate (TIAGo job, --select cv)"
    if default in chosen and selected in chosen:
        after = med[(selected, "after")] / med[(default, "after")]
        print(f"issue 42: `--select cv` / the default (TIAGo job): before "
              f"{med[(selected, 'before')] / med[(default, 'before')]:.2f}, after {after:.2f} "
              f"(goal ≤ {SELECT_CV_GOAL:g}: {'met' if after <= SELECT_CV_GOAL else 'not met'})")
    page = work / "tiago.html"
    if page.exists():
        size = page.stat().st_size / 1e6
        verdict = "met" if size <= 1.2 else "not met"
        print(f"\nTIAGo report page (after): {size:.2f} MB (issue 42's goal ≤ 1.2 MB: {verdict})")
    demo = work / "demo" / "report.html"
    if demo.exists():
        print(f"Delta demo report page (after): {demo.stat().st_size / 1e6:.2f} MB")


if __name__ == "__main__":
    main()
