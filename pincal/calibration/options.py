"""The options of a calibration, spelled once: :class:`CalibrationOptions`.

Each option is one field of a frozen dataclass whose metadata (:class:`Option`) carries its command-line flag, its
job-file key, its choices, its unit and its help text. The ``pincal`` parser (:mod:`pincal.cli.arguments`), the job-file
reader (:mod:`pincal.calibration.job`), the keywords of :func:`pincal.calibration.calibrate`, ``view``/``report``/
``fleet`` and the check of a ``--result`` JSON are made from these fields, so an option added here reaches all of
them.
"""

from __future__ import annotations

import functools
import math
import re
from collections.abc import Callable, Mapping
from dataclasses import MISSING, field, fields
from pathlib import Path
from typing import TYPE_CHECKING, Any, Literal, NamedTuple, get_args

from pincal import validation
from pincal.errors import ArgumentError, DataError, NotFoundError, PincalError, listing, not_found
from pincal.identification.choices import LOSSES, MARKER_FITS, SOLVERS, Loss, MarkerFit, Solver
from pincal.identification.fit_options import AUTO_PRIOR, FitOptions
from pincal.records import record

if TYPE_CHECKING:
    from pincal.identification.corrections import Payload

#: How the residuals are formed: forward kinematics (measured − predicted) or implicit loop residuals (IKM).
Formulation = Literal["fkm", "ikm"]
FORMULATIONS: tuple[Formulation, ...] = get_args(Formulation)
#: Model selection: ``auto`` (``evidence`` for the default parameter set with the automatic prior, ``bic`` with a prior
#: of the user's, ``none`` for a named set), ``evidence``, ``bic``, ``cv`` or ``none``.
SELECT_CHOICES = ("auto", "evidence", "bic", "cv", "none")

PARAMETERS_HELP = ("named sets (default, model24, model24i, hexapod42, hexapod44) and name patterns, combined in "
                   "order; !pattern removes (default: the default set, docs/dataset.md 'Parameters')")
PLAUSIBLE_HELP = ("refuse (exit 1) a result whose corrections exceed F times the plausible size of their kind: "
                  "joint and loop-anchor placements 20 mm and 2 deg, reading offsets 5 deg (20 mm), harmonics 1 deg "
                  "(5 mm); the measurement frame, markers, cameras and targets have no bound; and data whose "
                  "positions spread more than 1 + F/2 times as far as the nominal robot's (or less than its "
                  "inverse); the run names the parameters and the likely cause (default 1; off: no such check; "
                  "docs/calibrated_urdf.md, 'Plausible corrections')")
PRIOR_HELP = ("keep what the data barely see near the URDF: a prior about nominal of F times each kind's prior σ "
              "(joint and loop-anchor placements 5 mm and 0.5 deg, reading offsets 1 deg (5 mm), harmonics 0.2 deg "
              "(1 mm); the measurement frame, markers, cameras and targets have none), the maximum a posteriori fit; "
              "auto (default): each group's factor chosen by the data's evidence; off: least squares "
              "(docs/calibrated_urdf.md, 'The prior')")
SIGMA_HELP = ("one measurement σ [m, rad] for weighting every channel, or one per residual row as A,B,C (e.g. "
              "1e-3,1e-3,3e-3 for a camera's depth noise three times its lateral noise), over the file's '# sigma' "
              "lines (default: those lines, else estimated from the data: docs/dataset.md 'Noise')")

FORCE_HELP = ("write the calibrated URDF even of a fit that explains nothing (residuals beyond 1000 × σ after "
              "calibration, more than half the start's error left), which is otherwise not written; the exit status "
              "stays 1 (docs/calibrated_urdf.md, 'A fit that explains nothing')")


@record(frozen=True)
class Option:
    """How one option is written where a user gives it.

    Attributes:
        flag: The command-line flag (``--max-iter``).
        key: The job-file key (``max_iter``), or None when a job file cannot give it.
        help: The help text (units in brackets).
        choices: The values allowed, or None.
        kind: ``text``, ``texts`` (one or more), ``int`` (≥ 1), ``seed`` (≥ 0), ``sigma`` (finite > 0),
            ``sigmas`` (one, or one per residual row), ``plan``
            (``K``, ``KxR`` or ``loo``), ``payload``, ``factor`` (finite > 0, or ``off``), ``flag`` (a switch: given
            or not).
        metavar: The value's name in the help, or None.
        api_only: Given only through the library (not on the command line, not in a job file).
    """

    flag: str
    key: str | None
    help: str
    choices: tuple[str, ...] | None = None
    kind: str = "text"
    metavar: str | None = None
    api_only: bool = False


def _how(**how: Any) -> dict[str, Option]:
    """A field's metadata: how its option is written (:class:`Option`)."""
    return {"option": Option(**how)}


@record(frozen=True)
class CalibrationOptions:
    """Every option of a calibration, with its default; the same for the API, the CLI and job files.

    Attributes:
        parameter_spec: Named sets and name patterns of the parameters to fit; None: the default set.
        solver: ``lm`` (Levenberg–Marquardt on the identifiable directions), ``tsvd`` or ``ridge``.
        loss: ``auto`` (least squares, then a Cauchy refit when the data hold implausible samples), ``linear``,
            ``cauchy``.
        sigma: One measurement σ [m, rad] over the data's ``# sigma`` lines, or one per residual row (a tuple); None:
            those lines, else estimated from the data.
        pose_sigma_angle: σ of pose orientations [rad] over the data's; None: the data's (library only).
        formulation: ``fkm`` (measured − predicted by forward kinematics) or ``ikm`` (implicit loop residuals).
        max_iter: The solver's iteration limit.
        select: Model selection: ``auto``, ``bic``, ``cv`` or ``none``.
        cv: Cross-validation plan: ``K``, ``KxR`` or ``loo``; None: none.
        cv_seed: Seed of the first cross-validation shuffle (K-fold plans only).
        markers: ``each`` marker's offset, or one rigid ``cluster`` placement of a frame's markers.
        payload: A point mass the robot carried, for the joint compliances; None: none.
        plausible: A factor (> 0) on the plausible size of each kind's corrections
            (:attr:`~pincal.identification.parameters.kinds.ParameterKind.plausible`), or ``"off"``: no check.
        prior: A factor (> 0) on each kind's prior σ about nominal
            (:attr:`~pincal.identification.parameters.kinds.ParameterKind.prior`, :mod:`pincal.identification.prior`),
            ``"auto"``: each group's factor chosen by the data's evidence (:mod:`pincal.identification.evidence`), or
            ``"off"``: least squares.
        force: Write the calibrated URDF of a fit that explains nothing (residuals beyond 1000 × σ, most of the start's
            error left: :data:`~pincal.calibration.plausibility.EXPLAINS_NOTHING`), which is otherwise not written;
            the result stays unusable (exit status 1). It changes no figure: only what
            :mod:`~pincal.calibration.from_files` writes.
    """

    parameter_spec: tuple[str, ...] | None = field(default=None, metadata=_how(
        flag="--parameters", key="parameters", help=PARAMETERS_HELP, kind="texts"))
    select: str = field(default="auto", metadata=_how(
        flag="--select", key="select", choices=SELECT_CHOICES,
        help="model selection: evidence leaves out the groups of parameters (joint translations, rotations, reading "
             "offsets, compliances) whose evidence (marginal likelihood) the data do not raise, and holds the others "
             "as firmly as it says (with --prior auto); bic leaves out the groups the Bayesian information criterion "
             "rejects, then refits; cv leaves out the groups whose combination predicts unseen samples best (5-fold "
             "cross-validation, one seeded shuffle; a fit per combination and fold); none fits every identifiable "
             "parameter; auto (default): evidence for the default parameters (bic with a --prior factor of your "
             "own), none for --parameters you name"))
    loss: Loss = field(default=FitOptions.loss, metadata=_how(
        flag="--loss", key="loss", choices=LOSSES,
        help="auto (default): least squares, then a robust (Cauchy) refit if the data hold samples their own noise "
             "level makes implausible, which are listed; linear: least squares only; cauchy: robust from the start"))
    solver: Solver = field(default=FitOptions.solver, metadata=_how(
        flag="--solver", key="solver", choices=SOLVERS,
        help="lm: Levenberg-Marquardt on the identifiable directions (default); tsvd; ridge"))
    sigma: float | tuple[float, ...] | None = field(default=None, metadata=_how(
        flag="--sigma", key="sigma", kind="sigmas", metavar="SIGMA[,SIGMA...]", help=SIGMA_HELP))
    max_iter: int = field(default=FitOptions.max_iter, metadata=_how(
        flag="--max-iter", key="max_iter", kind="int",
        help=f"iteration limit of the solver (default {FitOptions.max_iter}); a run that reaches it exits 1"))
    formulation: Formulation = field(default="fkm", metadata=_how(
        flag="--formulation", key="formulation", choices=FORMULATIONS,
        help="fkm: measured - predicted by forward kinematics; ikm: implicit loop residuals with the measured pose "
             "held fixed (study 000; closed-loop robots)"))
    cv: str | None = field(default=None, metadata=_how(
        flag="--cv", key="cv", kind="plan", metavar="K|KxR|loo",
        help="cross-validate the whole fit over every usable sample of the file: K folds, KxR (R shuffles, e.g. "
             "5x4) or loo (leave one out); prints the cross-validated RMS"))
    cv_seed: int = field(default=0, metadata=_how(
        flag="--cv-seed", key="cv_seed", kind="seed", metavar="N",
        help="seed of the first --cv shuffle (the R shuffles are seeded N, N+1, …; default 0): the cross-validated "
             "figure depends on how the samples fall into folds, and other seeds show by how much; K-fold plans "
             "only (--cv loo has no shuffle)"))
    payload: Payload | None = field(default=None, metadata=_how(
        flag="--payload", key="payload", kind="payload", metavar="MASS@FRAME[:X,Y,Z]",
        help="a point mass the robot carries: MASS [kg] on FRAME (a link or frame of the URDF), at X,Y,Z [m] in "
             "that frame (default 0,0,0); its gravity torque adds to the links' in the joint compliances "
             "('*.compliance'), and is refused without one; the corrections file and the report record it"))

    plausible: float | str = field(default=1.0, metadata=_how(
        flag="--plausible", key="plausible", kind="factor", metavar="F|off", help=PLAUSIBLE_HELP))
    prior: float | str = field(default="auto", metadata=_how(
        flag="--prior", key="prior", kind="prior", metavar="F|auto|off", help=PRIOR_HELP))

    markers: MarkerFit = field(default="each", metadata=_how(
        flag="--markers", key=None, choices=MARKER_FITS,
        help="markers declared on a frame (position:<frame>@<marker> columns): each (default) fits each marker's "
             "offset on its frame; cluster fits one rigid placement of the frame's markers, whose nominal offsets "
             "the file declares ('# marker m1 on <frame>: x y z' [m])"))
    force: bool = field(default=False, metadata=_how(
        flag="--force", key=None, kind="flag", help=FORCE_HELP))
    pose_sigma_angle: float | None = field(default=None, metadata=_how(
        flag="--pose-sigma-angle", key=None, kind="sigma", api_only=True,
        help="σ of pose orientations [rad] over the data's"))

    def __post_init__(self) -> None:
        """Check every value (DataError naming the option and the values allowed)."""
        object.__setattr__(self, "parameter_spec", validation.optional_texts("parameter_spec", self.parameter_spec))
        for name, option in OPTIONS.items():
            value = getattr(self, name)
            if option.choices is not None and value not in option.choices:
                raise DataError(f"unknown {name} '{value}'; {_plural(name)} are: {listing(option.choices)}",
                                option=name)
        if isinstance(self.sigma, list | tuple):
            object.__setattr__(self, "sigma", tuple(self.sigma))
        for name in ("sigma", "pose_sigma_angle"):
            value = getattr(self, name)
            values = value if isinstance(value, tuple) and name == "sigma" and value else (value,)
            if value is not None and not all(isinstance(v, int | float) and not isinstance(v, bool)
                                             and 0.0 < v < math.inf for v in values):
                raise DataError(f"{name}={value!r}: a σ is a finite number > 0 [m, rad], or for sigma one per residual "
                                "row (or None for the data's)", option=name)
        if isinstance(self.max_iter, bool) or not isinstance(self.max_iter, int) or self.max_iter < 1:
            raise DataError(f"max_iter is {self.max_iter}: at least one iteration is needed", option="max_iter")
        if plausible_factor(self.plausible) is None and self.plausible != "off":
            raise DataError(f"plausible={self.plausible!r}: give a factor > 0 on the plausible corrections, or 'off'",
                            option="plausible")
        if plausible_factor(self.prior) is None and self.prior not in ("off", "auto"):
            raise DataError(f"prior={self.prior!r}: give a factor > 0 on the prior σ, 'auto' or 'off'", option="prior")
        if isinstance(self.cv_seed, bool) or not isinstance(self.cv_seed, int) or self.cv_seed < 0:
            raise DataError(f"cv_seed={self.cv_seed!r}: give a whole number ≥ 0", option="cv_seed")
        if not isinstance(self.force, bool):
            raise DataError(f"force={validation.shown(self.force)}: give True or False", option="force")
        self._check_objects()
        # the options that only make sense together, checked here once for every caller (options_given words the
        # error as the user wrote each option)
        check_cv_seed(self.cv, self.cv_seed)
        check_select_cv(self.select, self.cv)

    def _check_objects(self) -> None:
        """Check the options that are objects: the cross-validation plan's form and the payload's type."""
        if self.cv is not None and (not isinstance(self.cv, str)
                                    or re.fullmatch(r"\s*(loo|[0-9]+(x[0-9]+)?)\s*", self.cv.lower()) is None):
            raise DataError(f"cv={validation.shown(self.cv)}: give K (folds), KxR (K folds, R shuffles, e.g. '5x4') "
                            "or 'loo' as a string, or None", option="cv")
        if self.payload is not None:
            from pincal.identification.corrections import Payload

            validation.instance("payload", self.payload, Payload, "a Payload or None")

    def replace(self, **changes: Any) -> CalibrationOptions:
        """These options with ``changes`` (keywords of :class:`CalibrationOptions`); unknown names are refused.

        Raises:
            NotFoundError: a name that is not an option, listing the options.
        """
        for name in changes:
            if name not in OPTIONS:
                raise not_found("option", name, OPTIONS, " of calibrate()")
        return CalibrationOptions(**{**{name: getattr(self, name) for name in OPTIONS}, **changes})

    @functools.cached_property
    def fitting(self) -> FitOptions:
        """The identification layer's options these make (:class:`~pincal.identification.fit_options.FitOptions`),
        once: the solver, loss, iteration limit and prior (a factor,
        :data:`~pincal.identification.fit_options.AUTO_PRIOR` or, ``off``, None); every other at its default."""
        prior = AUTO_PRIOR if self.prior == AUTO_PRIOR else plausible_factor(self.prior)
        return FitOptions(solver=self.solver, loss=self.loss, max_iter=self.max_iter, prior=prior)

    @property
    def named_parameters(self) -> bool:
        """True when the parameters are named (not the default set): ``select="auto"`` then fits them as named."""
        return bool(self.parameter_spec) and list(self.parameter_spec or ()) != ["default"]

    @property
    def selection(self) -> str:
        """The selection policy ``select`` stands for: ``auto`` is ``evidence`` for the default parameter set of an
        ``fkm`` fit with the automatic prior (``bic`` with a prior factor of the user's, or none), ``none``
        otherwise."""
        if self.select != "auto":
            return self.select
        if self.named_parameters or self.formulation != "fkm":
            return "none"
        return "evidence" if self.prior == "auto" else "bic"


def plausible_factor(value: object) -> float | None:
    """The factor on the plausible corrections ``value`` gives (a finite number > 0), else None (``"off"`` or not a
    factor)."""
    if isinstance(value, bool) or not isinstance(value, int | float) or not 0.0 < value < math.inf:
        return None
    return float(value)


def _plural(name: str) -> str:
    return {"select": "selections", "loss": "losses", "markers": "marker fits"}.get(name, f"{name}s")


#: Each option's :class:`Option`, by its keyword, in the dataclass's order.
OPTIONS: dict[str, Option] = {f.name: f.metadata["option"] for f in fields(CalibrationOptions)}
#: Each option's default, by its keyword.
DEFAULTS: dict[str, Any] = {f.name: f.default for f in fields(CalibrationOptions) if f.default is not MISSING}
#: Job-file keys of the options a job file can give, and the keyword each becomes.
JOB_OPTIONS: dict[str, str] = {o.key: name for name, o in OPTIONS.items() if o.key is not None}


#: Where the user gave an option: on the command line, as a keyword argument of
#: :func:`~pincal.calibration.calibrate`, or in a job file (its path). A message names the option as it is written
#: there.
OptionSource = Literal["command line", "keyword"] | Path


def written(key: str, value: str | int, source: OptionSource, in_file: bool = True) -> str:
    """Option ``key`` (a keyword of :class:`CalibrationOptions`) set to ``value`` as the user writes it at ``source``:
    ``--cv-seed 5``, ``cv_seed=5``, or ``cv_seed = 5 in job.toml`` (without the file when not ``in_file``)."""
    if source == "command line":
        return f"{OPTIONS[key].flag} {value}"
    if source == "keyword":
        return f"{key}={value!r}"
    shown = f'"{value}"' if isinstance(value, str) else str(value)  # TOML's quotes
    return f"{OPTIONS[key].key} = {shown}" + (f" in {source}" if in_file else "")


#: Where each option was given, by its keyword: one place for all, or a function of the option's keyword.
OptionSources = OptionSource | Callable[[str], OptionSource]


def options_given(values: Mapping[str, Any], sources: OptionSources = "keyword") -> CalibrationOptions:
    """The :class:`CalibrationOptions` that ``values`` give (keywords of its fields) over the defaults, each checked
    once as the options are made; a cross-validation seed or plan that does not go with the other options is named as
    the user wrote each at its source (``--cv-seed 5`` on the command line, ``cv_seed = 5`` in a job file).

    Raises:
        NotFoundError: a name that is not an option.
        DataError: a value out of range, naming the option.
    """
    where: Callable[[str], OptionSource] = sources if callable(sources) else (lambda _name: sources)
    try:
        return CalibrationOptions().replace(**values)
    except PincalError as exc:
        if exc.option in ("cv", "cv_seed") and not isinstance(exc, NotFoundError):  # worded where it was written
            cv, seed, select = values.get("cv"), values.get("cv_seed", 0), values.get("select", "auto")
            if isinstance(seed, int) and not isinstance(seed, bool) and (cv is None or isinstance(cv, str)):
                check_cv_seed(cv, seed, where("cv"), where("cv_seed"))
                check_select_cv(select, cv, where("select"), where("cv"))
        raise


class GivenOption(NamedTuple):
    """One option a user gave: its keyword (a field of :class:`CalibrationOptions`), its value and where it was
    given."""

    name: str
    value: Any
    source: OptionSource


@record(frozen=True)
class GivenOptions:
    """The options a user gave (in a job file, on the command line, as keywords), each with where it was given; the
    others stand at their defaults. The :class:`CalibrationOptions` they make are checked when first read
    (:attr:`calibration`), once every source is laid over the others, so a job file's seed may go with a plan the
    command line gives.

    Attributes:
        given: Each option given, in the order first given, with the value and source last given.
    """

    given: tuple[GivenOption, ...] = ()

    @classmethod
    def of(cls, values: Mapping[str, Any], source: OptionSource = "keyword") -> GivenOptions:
        """The options ``values`` give (keywords of :class:`CalibrationOptions`; a None is not given) at
        ``source``.

        Raises:
            NotFoundError: a name that is not an option.
        """
        return cls().over(values, source)

    def over(self, values: Mapping[str, Any] | GivenOptions, source: OptionSource = "keyword") -> GivenOptions:
        """These options with ``values`` (keywords at ``source``, a None not given; or other given options, each
        at its own source) in place of theirs.

        Raises:
            NotFoundError: a name that is not an option.
        """
        if isinstance(values, GivenOptions):
            laid = values.given
        else:
            for name in values:
                if name not in OPTIONS:
                    raise not_found("option", name, OPTIONS, " of calibrate()")
            laid = tuple(GivenOption(k, v, source) for k, v in values.items() if v is not None)
        merged = {option.name: option for option in self.given} | {option.name: option for option in laid}
        return GivenOptions(tuple(merged.values()))  # as a dict merges: a name given again keeps its place

    @property
    def values(self) -> dict[str, Any]:
        """Each given option's value, by keyword (as a provenance records them)."""
        return {option.name: option.value for option in self.given}

    def value(self, name: str, default: Any = None) -> Any:
        """The value given for option ``name`` (a keyword of :class:`CalibrationOptions`), else ``default``."""
        return next((option.value for option in self.given if option.name == name), default)

    def without(self, name: str) -> GivenOptions:
        """These options but ``name``, as if it was not given."""
        return GivenOptions(tuple(option for option in self.given if option.name != name))

    def source(self, name: str) -> OptionSource:
        """Where option ``name`` was given (``"keyword"`` for one not given)."""
        return next((option.source for option in self.given if option.name == name), "keyword")

    @functools.cached_property
    def calibration(self) -> CalibrationOptions:
        """The :class:`CalibrationOptions` these give over the defaults (:func:`options_given`), errors worded as
        each option was written at its source.

        Raises:
            NotFoundError: a name that is not an option.
            DataError: a value out of range, naming the option.
        """
        return options_given(self.values, self.source)


def check_cv_seed(cv: str | None, cv_seed: int, cv_source: OptionSource = "keyword",
                  seed_source: OptionSource = "keyword") -> None:
    """Refuse a shuffle seed that would seed nothing: a ``cv_seed`` other than 0 (the default) with no ``cv``, or
    with ``cv="loo"`` (leave-one-out leaves each sample out in turn, with no shuffle to seed); and a negative one.
    The message names each option as the user gave it, at ``cv_source`` and ``seed_source``: ``--cv-seed 5`` on
    the command line, ``cv_seed=5`` to :func:`~pincal.calibration.calibrate`; a job file's own seed is blamed on the
    file and its key, as the job reader's errors are (``job.toml: cv_seed: 5 ...``).

    Raises:
        DataError: naming the seed and, with ``loo``, the ``cv`` that has no shuffle.
    """
    job = seed_source if isinstance(seed_source, Path) else None
    culprit = f"{job}: cv_seed: {cv_seed}" if job is not None else written("cv_seed", cv_seed, seed_source)
    seed_option = "--cv-seed" if seed_source == "command line" else "cv_seed"
    file = str(job) if job is not None else None
    if cv_seed < 0:
        raise DataError(f"{culprit}: give a whole number ≥ 0", option="cv_seed", file=file)
    if not cv_seed:
        return
    if cv is None:
        if seed_source == "command line":
            raise DataError(f"{culprit} seeds the shuffles of --cv; give --cv too (e.g. --cv 5x4)", option="cv_seed",
                            file=file)
        raise DataError(f"{culprit} seeds the shuffles of a K-fold cross-validation, and no cv is given; give cv too "
                        f"(e.g. {written('cv', '5x4', seed_source, in_file=False)})", option="cv_seed", file=file)
    if cv.strip().lower() == "loo":
        loo = written("cv", cv, cv_source, in_file=cv_source != job)
        folds = written("cv", "5x4", cv_source, in_file=False)
        raise DataError(f"{culprit} seeds the shuffles of K-fold plans; {loo} has none (it leaves each sample out in "
                        f"turn): drop {seed_option}, or cross-validate by K folds (e.g. {folds})", option="cv_seed",
                        file=file)


#: The most folds a cross-validation of ``select="cv"`` may have (``--cv 5x4``): each repeats the whole selection,
#: itself a 5-fold cross-validation of every combination of parameter groups.
MAX_SELECTION_FOLDS = 20


def check_select_cv(select: str, cv: str | None, select_source: OptionSource = "keyword",
                    cv_source: OptionSource = "keyword") -> None:
    """Refuse, before any fit, a cross-validation of ``select="cv"`` by leave-one-out or by more than
    :data:`MAX_SELECTION_FOLDS` folds: each fold repeats the selection's own 5-fold cross-validation of every
    combination of parameter groups (60 samples left out in turn: minutes of fitting). The message names each option
    as the user gave it, at ``select_source`` and ``cv_source`` (as :func:`check_cv_seed`'s).

    Raises:
        ArgumentError: given as keywords of :func:`~pincal.calibration.calibrate`; DataError: on the command line or
            in a job file.
    """
    if select != "cv" or not isinstance(cv, str):
        return
    word = cv.strip().lower()
    plan = re.fullmatch(r"([0-9]+)(?:x([0-9]+))?", word)
    if word == "loo":
        folds = "each of its folds (one per sample)"
    elif plan is not None and int(plan.group(1)) * int(plan.group(2) or 1) > MAX_SELECTION_FOLDS:
        folds = f"each of its {int(plan.group(1)) * int(plan.group(2) or 1)} folds"
    else:
        return
    given = (f"{written('select', 'cv', select_source, in_file=select_source != cv_source)} with "
             f"{written('cv', cv, cv_source)}")
    fewer = " or ".join(written("cv", k, cv_source, in_file=False) for k in ("5", "5x4"))
    default = "--select" if select_source == "command line" else "select"
    error = ArgumentError if (select_source, cv_source) == ("keyword", "keyword") else DataError
    raise error(f"{given} would repeat the cv selection (its own 5-fold cross-validation of every combination of "
                f"parameter groups) in {folds}: minutes to hours of fitting; cross-validate by fewer folds "
                f"({fewer}), or leave {default} at its default", option="cv",
                file=str(cv_source) if isinstance(cv_source, Path) else None)
