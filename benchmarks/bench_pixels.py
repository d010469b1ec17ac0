"""50 images detected and calibrated: ``pincal detect`` then ``pincal calibrate`` as a user runs them (issue 39 asks
for under 10 s).

A UR10 eye-in-hand campaign of 50 images (40 to calibrate from, 10 held out) is simulated and rendered once
(``pincal simulate ur10 --measure pixel:tool0 --images``, not timed); then each command is run ``--repeats`` times
in turns as the console script, and the medians of its wall time and its CPU time (user + sys of the process and
its children) are printed beside the floor ``python -c "import numpy, scipy.linalg, pinocchio, cv2"``.

Run: ``python benchmarks/bench_pixels.py --repeats 5``.
"""

from __future__ import annotations

import argparse
import os
import shutil
import subprocess
import sys
import tempfile
import time
from pathlib import Path

PINCAL = Path(sys.executable).with_name("pincal")
BOARD = "charuco:8x6:0.03:0.022:DICT_4X4_50"


def timed(command: list[str], cwd: Path) -> tuple[float, float]:
    """(wall, CPU) [s] of one run of ``command`` in ``cwd`` (CPU: user + sys of its children)."""
    before = os.times()
    started = time.perf_counter()
    done = subprocess.run(command, cwd=cwd, capture_output=True, text=True, check=False)
    wall = time.perf_counter() - started
    after = os.times()
    if done.returncode not in (0, 1):
        raise SystemExit(f"{' '.join(command)} failed: {done.stderr}")
    return wall, (after.children_user - before.children_user) + (after.children_system - before.children_system)


def median(values: list[float]) -> float:
    """The median."""
    ordered = sorted(values)
    mid = len(ordered) // 2
    return ordered[mid] if len(ordered) % 2 else 0.5 * (ordered[mid - 1] + ordered[mid])


def main() -> int:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--repeats", type=int, default=5)
    args = parser.parse_args()
    root = Path(tempfile.mkdtemp(prefix="bench_pixels_"))
    try:
        subprocess.run([str(PINCAL), "simulate", "ur10", "--measure", "pixel:tool0", "--samples", "40",
                        "--test-samples", "10", "--images", "imgs", "--seed", "5", "--out", "sim"], cwd=root,
                       check=True, capture_output=True)
        images = sorted(str(p) for p in (root / "imgs").glob("*.png"))
        commands = {
            "floor: import numpy, scipy.linalg, pinocchio, cv2": [sys.executable, "-c",
                                                                 "import numpy, scipy.linalg, pinocchio, cv2"],
            f"pincal detect ({len(images)} images)": [str(PINCAL), "detect", *images, "--board", BOARD, "--joints",
                                                      "sim/joints.csv", "--measure", "pixel:tool0", "--out",
                                                      "det.csv"],
            "pincal calibrate ur10 det.csv": [str(PINCAL), "calibrate", "ur10", "det.csv", "--report", "r.json"],
        }
        runs: dict[str, list[tuple[float, float]]] = {name: [] for name in commands}
        for _ in range(args.repeats):
            for name, command in commands.items():
                runs[name].append(timed(command, root))
        print(f"medians of {args.repeats} runs, in turns; load {os.getloadavg()[0]:.1f}")
        print("| command | wall [s] | CPU [s] |")
        print("|---|---|---|")
        total_wall = total_cpu = 0.0
        for name, values in runs.items():
            wall, cpu = median([v[0] for v in values]), median([v[1] for v in values])
            if name.startswith("pincal"):
                total_wall, total_cpu = total_wall + wall, total_cpu + cpu
            print(f"| {name} | {wall:.2f} | {cpu:.2f} |")
        print(f"| detect + calibrate | {total_wall:.2f} | {total_cpu:.2f} |")
    finally:
        shutil.rmtree(root, ignore_errors=True)
    return 0


if __name__ == "__main__":
    sys.exit(main())
