"""The identification layer's options, one object: :class:`FitOptions`, each default written here once.

:func:`~pincal.identification.solver.identify` takes them as keywords and makes one :class:`FitOptions`;
:func:`~pincal.identification.solver.identify_with`, model selection
(:func:`~pincal.identification.selection.select_and_fit`) and the calibration layer (which makes it once from its
:class:`~pincal.calibration.options.CalibrationOptions`) carry the object. The methods read its
:class:`StepOptions` part. No import beyond the standard library and the names of
:mod:`~pincal.identification.choices`: the ``pincal`` parser reads the defaults here without loading NumPy.
"""

from __future__ import annotations

from dataclasses import replace
from typing import TYPE_CHECKING, Literal

from pincal.errors import ArgumentError
from pincal.identification.choices import Loss, Solver
from pincal.records import record

if TYPE_CHECKING:
    from typing import TypeAlias

    import numpy as np
    import numpy.typing as npt

    #: A prior as :class:`FitOptions` holds it: a factor, each parameter's σ [its unit], :data:`AUTO_PRIOR` or None.
    FitPrior: TypeAlias = float | npt.NDArray[np.float64] | Literal["auto"] | None

#: The prior that asks the evidence for each group's factor (model selection,
#: :func:`~pincal.identification.selection.select_and_fit`); a single fit holds each kind by its prior σ (factor 1).
AUTO_PRIOR: Literal["auto"] = "auto"


@record(frozen=True, kw_only=True)
class StepOptions:
    """The options that shape a method's steps (:class:`~pincal.identification.steps.Method`).

    Attributes:
        identifiable_only: Move only along directions identifiable at the current estimate (recommended); otherwise
            LM damping alone keeps the unidentifiable directions in check.
        rank_tol: Relative singular-value threshold for identifiability (dimensionless; see
            :mod:`pincal.identification.identifiability`).
        min_information: Absolute floor on the singular values of the weighted, scaled Jacobian (dimensionless): a
            direction below it has an a-priori standard deviation over 1/min_information times the parameters'
            typical size (e.g. 1e-2: 100 × 1 mm or 1 mrad), so these data do not identify it in practice, whatever
            its numerical rank. Off (0) by default.
        tsvd_rcond: TSVD truncation, relative to the largest singular value (dimensionless).
        ridge: Ridge parameter in scaled units (dimensionless).
    """

    identifiable_only: bool = True
    rank_tol: float = 1e-8
    min_information: float = 0.0
    tsvd_rcond: float = 1e-6
    ridge: float = 1e-6


@record(frozen=True, kw_only=True)
class FitOptions(StepOptions):
    """Every option of an identification, with its default; the step options (:class:`StepOptions`) included.

    Attributes:
        solver: ``lm``, ``tsvd`` or ``ridge`` (:data:`~pincal.identification.fitting.METHODS`).
        loss: ``auto`` (least squares, then a Cauchy refit when a sample is implausible:
            :func:`~pincal.identification.solver.identify`), ``linear`` or ``cauchy``.
        max_iter: Iteration limit (steps taken); reaching it is reported as not converged.
        tol: Stop when the relative cost decrease or the scaled step falls below ``tol`` (dimensionless), or when the
            Gauss–Newton model predicts a relative decrease below it (:func:`~pincal.identification.fitting.fit`).
        strict: Refuse (IdentifiabilityError) when not every parameter is identifiable.
        prior: A factor (dimensionless) on each parameter kind's prior σ about nominal, or each parameter's prior σ
            [its unit] (inf: none) (:mod:`pincal.identification.prior`): the maximum a posteriori estimate; None: least
            squares, no prior; :data:`AUTO_PRIOR`: each group's factor chosen by its evidence in model selection, the
            kinds' σ (factor 1) in a single fit.
    """

    solver: Solver = "lm"
    loss: Loss = "auto"
    max_iter: int = 100
    tol: float = 1e-9
    strict: bool = False
    prior: FitPrior = None

    @property
    def automatic_prior(self) -> bool:
        """Whether the prior is :data:`AUTO_PRIOR` (each group's factor chosen by its evidence)."""
        return isinstance(self.prior, str) and self.prior == AUTO_PRIOR

    def single(self) -> FitOptions:
        """These options for a single fit: the automatic prior as the kinds' own prior σ (factor 1)."""
        return replace(self, prior=1.0) if self.automatic_prior else self

    def fixed_prior(self) -> float | npt.NDArray[np.float64] | None:
        """The prior of a single fit (:meth:`single`): a factor, each parameter's σ, or None.

        Raises:
            ArgumentError: a text other than :data:`AUTO_PRIOR`, naming the option ``prior``.
        """
        prior = self.single().prior
        if isinstance(prior, str):
            raise ArgumentError(f"prior={prior!r}: give a factor > 0 on each kind's prior σ, one σ > 0 per parameter "
                                f"[its unit], '{AUTO_PRIOR}' or None", option="prior")
        return prior
