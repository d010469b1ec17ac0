"""The command line shared by the study examples (``--quick``, ``--out``, ``--json``, ``--serial``), and how their
pages print an error at the level of round-off."""

from __future__ import annotations

import argparse
import contextlib
import io
import json
from collections.abc import Callable
from pathlib import Path
from typing import Any

import numpy as np

from pincal.cli.app import main as pincal_main

ROOT = Path(__file__).resolve().parents[1]
#: Below this [mm or °], an error after a noise-free fit is the round-off of the solves, whose digits differ from one
#: machine to another (BLAS): a page says so rather than print them.
ROUND_OFF = 1e-8


def run_pincal(*argv: str) -> tuple[int, str]:
    """``pincal ARGV`` in this process: its exit status and what it printed."""
    out = io.StringIO()
    with contextlib.redirect_stdout(out):
        code = pincal_main(list(argv))
    return code, out.getvalue()


def run_ok(*argv: str, codes: tuple[int, ...] = (0,)) -> str:
    code, text = run_pincal(*argv)
    if code not in codes:
        raise SystemExit(f"pincal {' '.join(argv)} exited {code}:\n{text}")
    return text


def round_off(value: float) -> str:
    """``value`` [mm or °] to two digits, or "< 1e-8" at the level of round-off."""
    return "< 1e-8" if abs(value) < ROUND_OFF else f"{value:.1e}"


def _jsonable(value: Any) -> Any:
    return value.tolist() if isinstance(value, np.ndarray) else float(value)


def study_main(run: Callable[[bool, Path, str | None], dict[str, Any]], doc: str | None, quick_help: str,
               argv: list[str] | None = None) -> dict[str, Any]:
    """Parse the common options, call ``run(quick, out, executor)`` and optionally write its numbers as JSON."""
    parser = argparse.ArgumentParser(description=(doc or "").split("\n")[0])
    parser.add_argument("--quick", action="store_true", help=quick_help)
    where = parser.add_mutually_exclusive_group()
    where.add_argument("--out", type=Path, default=Path("results"),
                       help="output directory for the page and its figures (default: ./results)")
    where.add_argument("--publish", action="store_const", const=ROOT / "docs" / "results", dest="out",
                       help="write the committed page and figures under docs/results instead")
    parser.add_argument("--json", type=Path, help="also write the numbers as JSON here")
    parser.add_argument("--serial", action="store_true", help="no process pool")
    args = parser.parse_args(argv)
    summary = run(args.quick, args.out, None if args.serial else "process")
    if args.json:
        args.json.write_text(json.dumps(summary, indent=1, default=_jsonable), encoding="utf-8")
    return summary
