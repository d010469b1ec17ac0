"""The solvers, losses and marker fits :func:`~pincal.identification.solver.identify` takes, by name.

Names only, and no import beyond the standard library, so that a command-line parser can read its choices here
without loading SciPy or Pinocchio. Each name is an entry of a registry: a solver of
:data:`pincal.identification.fitting.METHODS` (one module per method), a loss of
:data:`pincal.identification.losses.IMPLEMENTED_LOSSES` or ``auto`` (:func:`~pincal.identification.solver.identify`'s
own plan on top of them); a test holds the names and the registries together.
"""

from __future__ import annotations

from typing import Literal, get_args

#: Identification solvers: Levenberg–Marquardt, truncated SVD, ridge (Tikhonov).
Solver = Literal["lm", "tsvd", "ridge"]
#: Losses: least squares, Cauchy (robust), or ``auto`` (least squares, then Cauchy if a sample is implausible).
Loss = Literal["auto", "linear", "cauchy"]
SOLVERS: tuple[Solver, ...] = get_args(Solver)
LOSSES: tuple[Loss, ...] = get_args(Loss)
#: How the declared markers of a frame (``position:<frame>@<marker>``) are fitted: ``each`` marker's offset on its
#: own (``marker.<frame>@<marker>.*``), or one rigid placement of the frame's ``cluster`` of markers, whose nominal
#: offsets the data declare (``cluster.<frame>.*``).
MarkerFit = Literal["each", "cluster"]
MARKER_FITS: tuple[MarkerFit, ...] = get_args(MarkerFit)
