"""The solver and loss names are readable without loading the numerical stack (a command-line parser reads them)."""

from __future__ import annotations

import subprocess
import sys


def test_the_names_load_without_scipy_or_pinocchio() -> None:
    code = ("import sys; from pincal.identification.choices import LOSSES, SOLVERS; "
            "print(SOLVERS, LOSSES, sorted(m for m in ('scipy', 'pinocchio', 'numpy') if m in sys.modules))")
    done = subprocess.run([sys.executable, "-c", code], capture_output=True, text=True, check=True)
    assert done.stdout.strip() == "('lm', 'tsvd', 'ridge') ('auto', 'linear', 'cauchy') []"
