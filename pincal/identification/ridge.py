"""Ridge (Tikhonov) steps (``solver="ridge"``): ``(J_sᵀJ_s + μI) δz = -J_sᵀ r`` over every parameter, ``μ`` the ridge
parameter in scaled units; a rejected trial halves the step.
"""

from __future__ import annotations

from typing import ClassVar, Self

from pincal.identification.steps import Method, StepOptions
from pincal.records import record


@record(frozen=True)
class Ridge(Method):
    """Every singular value kept, each damped by ``μ``: ``δz = -Σ_i v_i s_i/(s_i² + μ) u_iᵀ r``.

    Attributes:
        mu: The ridge parameter ``μ`` in scaled units (``ridge``).
    """

    name: ClassVar[str] = "ridge"
    mu: float = 1e-6

    @classmethod
    def configured(cls, options: StepOptions) -> Self:
        """``ridge``."""
        return cls(options.ridge)

    def threshold(self, largest: float) -> float:
        """0: every direction with a positive singular value."""
        return 0.0

    def damping(self, lam: float, largest: float) -> float:
        """The ridge parameter, whatever ``lam``."""
        return self.mu
