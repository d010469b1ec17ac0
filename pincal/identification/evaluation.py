"""What a calibration problem's evaluations read and keep, apart from the problem that runs them.

:class:`Observations` are the data, :class:`Prediction` one evaluation's answer. :class:`SolveState` is the problem's
solve state: every sample's configuration on the reference assembly, remembered from one evaluation to the next as
the warm start of its next solve. :class:`Evaluated` is the problem as its evaluation paths
(:mod:`~pincal.identification.predictions`) and its starting point (:mod:`~pincal.identification.starts`) read it;
:class:`~pincal.identification.problem.CalibrationProblem` is one. So the problem builds on these modules, and none of
them on the problem.
"""

from __future__ import annotations

from collections.abc import Sequence
from typing import Any, Protocol

import numpy as np
import numpy.typing as npt

from pincal.errors import ConvergenceError
from pincal.identification.loop_batch import LoopBatch
from pincal.identification.measurements import Measurement
from pincal.identification.neighbours import SolvedInputs
from pincal.identification.parameters import ParameterSet
from pincal.identification.tree_batch import TreeBatch
from pincal.model.kinematics import CONTINUATION_STEP
from pincal.model.robot import SOLVE_TOLERANCE, Robot
from pincal.records import record

Array = npt.NDArray[np.float64]
BoolArray = npt.NDArray[np.bool_]


@record
class Observations:
    """What was read and measured, one row per sample.

    Attributes:
        actuated: (N, na) actuated joint readings [rad or m], in ``robot.actuated_joints`` order.
        values: measurement key -> (N, k): position (N, 3) [m]; pose (N, 7) as x, y, z [m] and a unit
            quaternion qx, qy, qz, qw; distance (N, 1) [m]; joint reading (N, 1) [rad or m]. For
            ``distance_increment`` the first row is ignored. A row of NaN is a reading not taken (an occluded
            marker), allowed for the measurements that may miss one (``occludable``: positions).
    """

    actuated: Array
    values: dict[str, Array]

    @property
    def n_samples(self) -> int:
        """The number of samples N."""
        return int(self.actuated.shape[0])

    def subset(self, rows: Sequence[int] | npt.NDArray[np.integer] | Array) -> Observations:
        """The samples at ``rows``, in that order."""
        return Observations(self.actuated[rows], {k: v[rows] for k, v in self.values.items()})

    @classmethod
    def neutral(cls, measurements: Sequence[Measurement], actuated: Array) -> Observations:
        """Observations at ``actuated`` (N, na) [rad or m] with every measured value the model's neutral reading
        (zeros, an identity quaternion for poses): the problem then predicts absolute values, and its Jacobian,
        which does not depend on the readings, can be taken there."""
        return cls(actuated, {m.key: m.neutral(actuated.shape[0]) for m in measurements})


@record
class Prediction:
    """Residuals (weighted), their Jacobian, and unweighted errors per sample and measurement."""

    residual: Array
    jacobian: Array | None
    errors: dict[str, Array]  # key -> (N, rows) predicted - measured [m, rad]; NaN rows: readings not taken
    predicted: dict[str, Array]  # key -> (N, rows) absolute predictions (pose: p, log3(R_measᵀ R))


#: Evaluations a tree's problem keeps (:class:`Recalled`): a fit's refits start where earlier fits started or ended, and
#: a third of a cross-validation's evaluations were at a vector the same problem had evaluated already. The start's
#: is kept besides them: the refits of model selection and the setup's fit for "before" start there again after a
#: fit's steps have pushed it out.
RECALLED = 4


def _copied(arrays: dict[str, Array]) -> dict[str, Array]:
    return {key: value.copy() for key, value in arrays.items()}


class Recalled:
    """A tree's last :data:`RECALLED` evaluations, by their parameter vector (its bytes: the same numbers exactly), and
    the start's (:meth:`keep` with ``start``).

    A tree's evaluation is a function of the vector alone (a closed-loop robot's follows its samples' warm starts,
    and is never recalled), so an evaluation recalled is the one computed anew, to the last bit. What is kept and
    what is handed out are copies: a caller may write into the arrays it gets (a prior its rows).
    """

    def __init__(self) -> None:
        self._kept: dict[bytes, Prediction] = {}
        self._start: tuple[bytes, Prediction] | None = None

    def recall(self, x: Array, jacobian: bool, spare_rows: int) -> Prediction | None:
        """The kept evaluation at ``x`` as :meth:`CalibrationProblem.evaluate` gives it (the Jacobian, if asked,
        with ``spare_rows`` rows of zeros after its own), else None (not kept, or kept without a Jacobian asked)."""
        key = x.tobytes()
        kept = self._kept.get(key)
        if kept is None and self._start is not None and self._start[0] == key:
            kept = self._start[1]
        if kept is None or (jacobian and kept.jacobian is None):
            return None
        full = None
        if jacobian and kept.jacobian is not None:
            full = np.zeros((kept.jacobian.shape[0] + spare_rows, kept.jacobian.shape[1]))
            full[:kept.jacobian.shape[0]] = kept.jacobian
        return Prediction(kept.residual.copy(), full, _copied(kept.errors), _copied(kept.predicted))

    def keep(self, x: Array, prediction: Prediction, spare_rows: int, start: bool = False) -> None:
        """Keep a copy of ``prediction``, the evaluation at ``x`` (its Jacobian without the ``spare_rows`` last rows),
        forgetting the oldest beyond :data:`RECALLED`; ``start``: ``x`` is the problem's start, kept until another
        start's evaluation with its Jacobian replaces it."""
        jacobian = prediction.jacobian
        rows = None if jacobian is None else jacobian[:jacobian.shape[0] - spare_rows].copy()
        key = x.tobytes()
        copy = Prediction(prediction.residual.copy(), rows, _copied(prediction.errors), _copied(prediction.predicted))
        if start and (self._start is None or self._start[1].jacobian is None or rows is not None):
            self._start = (key, copy)
        self._kept.pop(key, None)
        self._kept[key] = copy
        while len(self._kept) > RECALLED:
            del self._kept[next(iter(self._kept))]


class SolveState:
    """Every sample's configuration on the reference assembly, remembered from one evaluation to the next.

    Args:
        n_samples: The number of samples N.
        continuous: (na,) which actuated joints are unbounded revolutes (compared modulo 2π).

    Attributes:
        configurations: Each sample's configuration (nq,) at its last solve, or None: the warm start of its next
            solve (of a first solve, the nearest solved sample's: :meth:`nearest`).
        solved_inputs: The actuated values [rad or m] each sample was solved for.
        travel: (N,) how far each sample's configuration travelled [rad or m] (sum of its largest coordinate
            changes) since it was last known on the reference assembly: only a sample that moved can have left it.
        solved_at: The parameters [m, rad] the configurations were solved at, or None.
        response: (N, n_passive, p) every sample's passive joints' response to the parameters there, ``dv_p/dθ``
            [rad or m per unit parameter], from the last evaluation with the Jacobian (closed loops batched), or
            None: the next warm starts move along it (a first-order prediction, Newton then closes).
        twists: The last closed-loop evaluation's measured-frame placements, twists and joint velocities per unit
            parameter (read-only arrays), with the robot and the block's configurations they were computed at, or
            None: an evaluation at the same robot and configurations, bit for bit, takes them again
            (:func:`pincal.identification.predictions.predict_loops`).
    """

    def __init__(self, n_samples: int, continuous: BoolArray) -> None:
        self.configurations: list[Array | None] = [None] * n_samples
        self.solved_inputs = SolvedInputs(n_samples, continuous, CONTINUATION_STEP)
        self.travel = np.zeros(n_samples)
        self.solved_at: Array | None = None
        self.response: Array | None = None
        self.twists: tuple[Any, tuple[int, bytes], Any] | None = None

    def solve(self, robot: Robot, k: int, qa: Array) -> Array:
        """Sample ``k``'s configuration on the reference assembly of ``robot`` for actuated values ``qa`` [rad or m].

        Warm-started from the sample's own last configuration (at the previous parameters), or for a first solve
        from the nearest solved sample's; the kinematics layer refuses a warm start that jumps and then answers by
        continuation from the reference, so the configuration found does not depend on the order of the samples.
        """
        guess = self.configurations[k]
        if guess is None:
            guess = self.nearest(robot, qa)
        return self.solve_from(robot, k, qa, guess)

    def solve_from(self, robot: Robot, k: int, qa: Array, guess: Array | None) -> Array:
        """:meth:`solve` from the warm start ``guess`` (None: cold), remembering the answer.

        Raises:
            ConvergenceError: naming sample ``k`` and its readings.
        """
        report = robot.kinematics.solve_fk(qa, guess, SOLVE_TOLERANCE)
        if not report.converged:
            raise ConvergenceError(f"sample {k}: forward kinematics did not converge for actuated readings "
                                   f"{np.array2string(qa, precision=6)} (closure residual {report.residual:.3g}); "
                                   "the sample may be outside the workspace or the parameters far off")
        previous = self.configurations[k]
        if previous is not None:
            self.travel[k] += float(np.max(np.abs(report.q - previous)))
        self.configurations[k] = report.q
        self.solved_inputs.record(k, qa)
        return report.q

    def nearest(self, robot: Robot, qa: Array) -> Array | None:
        """The configuration of the solved sample nearest in actuated values ``qa`` [rad or m], if within one
        continuation step, to warm-start a first solve (None otherwise: a cold start).

        Only a shortcut: a neighbour's configuration is on the reference assembly, and a Newton solve from it that
        jumps (moves a passive joint by more than one continuation step) is refused by
        :meth:`pincal.model.kinematics.ClosedLoopKinematics.solve_fk`, which then continues from the reference.
        """
        if not robot.loops:
            return None
        # continuous joints the short way round; ties to the lowest index; a search of the solved inputs' trees
        # (O(log² N)), not a scan of every solved sample (O(N) per cold start, O(N²) over a first evaluation)
        k = self.solved_inputs.nearest(qa, robot.kinematics.actuated_delta)
        return None if k < 0 else self.configurations[k]


class Evaluated(Protocol):
    """The calibration problem as its evaluation paths and its starting point read it (module docstring).

    Attributes:
        robot: The nominal robot.
        parameters: The unknowns.
        all_parameters: The unknowns and the nuisance reading offsets a joint σ adds (dropped on output).
        base: The columns of the measurement frame's placement (``base.*``), or none.
        measurements: The measurement models.
        observations: The data.
        frame_ids: Each measured frame's Pinocchio id.
        actuated_terms: (actuated joint, column, (N,) regressor): the joint's value moves by x[column] × regressor.
        solves: The solve state.
        tree_batch: A tree's batched evaluation, or None.
        loop_batch: A closed-loop robot's batched evaluation, or None.
        placed_in_closed_form: The cameras and targets the last starting point placed in closed form.
        not_in_closed_form: Why the data did not determine a camera's start, one per reading.
    """

    robot: Robot
    parameters: ParameterSet
    all_parameters: ParameterSet
    base: list[int]
    measurements: list[Measurement]
    observations: Observations
    frame_ids: dict[str, int]
    actuated_terms: list[tuple[int, int, Array]]
    solves: SolveState
    tree_batch: TreeBatch | None
    loop_batch: LoopBatch | None
    placed_in_closed_form: list[str]
    not_in_closed_form: list[str]

    def seen(self, key: str) -> BoolArray:
        """(N,) whether each sample holds a reading of measurement ``key``."""

    def forward(self, x: Array) -> Prediction:
        """The forward (FKM) predictions at ``x`` [m, rad], without the Jacobian, whatever the formulation."""

    def drop_start(self) -> None:
        """Forget the kept evaluation of the start: the configurations it was solved from are replaced."""
