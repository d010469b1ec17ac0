"""Truncated SVD (``solver="tsvd"``, study 003's method): the undamped Gauss–Newton step over the singular values of the
scaled Jacobian above ``tsvd_rcond · s₁``, ``δz = -Σ_i v_i / s_i u_iᵀ r``; a rejected trial halves the step.
"""

from __future__ import annotations

from typing import ClassVar, Self

from pincal.identification.steps import Method, StepOptions
from pincal.records import record


@record(frozen=True)
class TruncatedSVD(Method):
    """Gauss–Newton on the singular values above ``rcond · s₁``, no damping; a rejected trial halves the step.

    Attributes:
        rcond: Truncation relative to the largest singular value (``tsvd_rcond``).
    """

    name: ClassVar[str] = "tsvd"
    rcond: float = 1e-6

    @classmethod
    def configured(cls, options: StepOptions) -> Self:
        """``tsvd_rcond``."""
        return cls(options.tsvd_rcond)

    def threshold(self, largest: float) -> float:
        """``rcond · s₁`` (never below 0)."""
        return max(self.rcond * largest, 0.0)

    def damping(self, lam: float, largest: float) -> float:
        """None: the truncation alone regularises the step."""
        return 0.0
