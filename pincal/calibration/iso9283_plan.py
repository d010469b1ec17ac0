"""The ISO 9283 test of a robot: its test cube, the poses P1–P5 and the cycles to run (``pincal iso9283 plan``).

ISO 9283:1998, 6.8: the test cube is the largest cube, edges parallel to the base frame's axes, inside the
workspace (here: inside the part a user names, ``region``); the poses lie on its diagonal plane C1–C2–C7–C8, P1 at
the cube's centre and P2–P5 on the plane's diagonals at 10 % of their length from the corners C1, C2, C7, C8. With
C1 = (x₀, y₀, z₀) and side s: C2 = C1 + s x̂, C7 = C1 + s (x̂ + ŷ + ẑ), C8 = C1 + s (ŷ + ẑ), so P2 = C1 + 0.1 (C7 − C1),
P3 = C2 + 0.1 (C8 − C2), P4 = C7 + 0.1 (C1 − C7), P5 = C8 + 0.1 (C2 − C8).

How the cube is found: random postures within the joint limits sample the reachable positions of the frame; a few of
them (in the region) are candidate centres, each solved first with the orientation given (:class:`CommandSolver`);
from its solution, the 3 × 3 × 3 grid of a cube about it, P1–P5 and the approach points are solved for sides
shrinking by :data:`SHRINK` (Gauss–Newton over the actuated joints within their limits, one branch: no configuration
flips inside the cube); the largest cube whose points are all reached clear of singular postures, then bisected.
Every planned point (P1–P5 and the approach points) is then solved as ``pincal compensate`` solves a target (on the
calibrated model when one is given), and its residual measured by the model's forward kinematics at the commands.

The cycle sequence: ``cycles`` cycles of P1, P5, P4, P3, P2 (the pose series of AP, RP, AD and RD, 7.2 and 7.4),
then P1, P2 and P4 approached from three directions parallel to the base axes (the multi-directional series of vAP,
7.3): each from the point 10 % of the side away along +x, +y, +z (P1, P2) or −x, −y, −z (P4), inside the cube.
Positions [m] in the robot's base frame.
"""

from __future__ import annotations

import itertools

import numpy as np
import numpy.typing as npt
import pinocchio as pin

from pincal import linalg, validation
from pincal.calibration.compensate import Compensation, compensate, load_model
from pincal.calibration.joint_commands import CommandSolver, Model
from pincal.calibration.provenance import version
from pincal.errors import Culprit, DataError
from pincal.io.targets import Targets
from pincal.model.batch_ik import Goals, actuated_newton
from pincal.model.robot import Robot
from pincal.records import record
from pincal.study.simulation import random_actuated

Array = npt.NDArray[np.float64]

#: Candidate centres tried.
CENTRES = 8
#: Each side tried is this factor of the last.
SHRINK = 0.75
#: Sides tried per centre before the bisection.
SIDES = 12
#: Bisection steps of the best centre's side.
BISECTIONS = 5
#: Smallest ratio of the frame Jacobian's singular values at a checked point: the test stays clear of singular
#: postures, where the commands are ill-conditioned.
CLEAR_RATIO = 1e-3
#: Tolerance [m, rad] of the reachability solves.
REACH_TOLERANCE = 1e-9
#: The pose series' order within a cycle (ISO 9283:1998, 7.2.1).
CYCLE_ORDER = ("P1", "P5", "P4", "P3", "P2")
#: The poses of the multi-directional series and the directions, parallel to the base axes, each is approached from:
#: the side of the cube's inside (P2 lies near the corner C1 of the smallest x, y, z, P4 near C7 of the largest).
MULTI_DIRECTIONAL = {"P1": ("+x", "+y", "+z"), "P2": ("+x", "+y", "+z"), "P4": ("-x", "-y", "-z")}
AXES = {"x": 0, "y": 1, "z": 2}
#: The approach point's distance from its pose, as a fraction of the side (inside the cube).
APPROACH = 0.1


@record(frozen=True)
class Cube:
    """The test cube: its centre [m] in the base frame and its side [m]."""

    centre: Array
    side: float

    def corners(self) -> dict[str, Array]:
        """C1, C2, C7, C8 of the diagonal plane [m] (this module's docstring)."""
        c1 = self.centre - self.side / 2
        s = self.side
        return {"C1": c1, "C2": c1 + np.array([s, 0, 0]), "C7": c1 + np.array([s, s, s]),
                "C8": c1 + np.array([0, s, s])}

    def poses(self) -> Array:
        """(5, 3) P1 … P5 [m] (ISO 9283:1998, 6.8)."""
        c = self.corners()
        return np.array([self.centre, c["C1"] + 0.1 * (c["C7"] - c["C1"]), c["C2"] + 0.1 * (c["C8"] - c["C2"]),
                         c["C7"] + 0.1 * (c["C1"] - c["C7"]), c["C8"] + 0.1 * (c["C2"] - c["C8"])])

    def grid(self) -> Array:
        """(27, 3) the cube's 3 × 3 × 3 grid [m]: corners, edge and face centres, centre."""
        steps = np.array(list(itertools.product((-0.5, 0.0, 0.5), repeat=3)))
        return np.asarray(self.centre + steps * self.side, dtype=float)


@record(frozen=True)
class Plan:
    """A planned ISO 9283 test.

    Attributes:
        robot: The robot the cube was found on.
        frame: The frame tested: the model's (a calibrated URDF's calibrated marker when it has one, as ``pincal
            compensate`` reaches it).
        cube: The test cube.
        names: P1 … P5.
        positions: (5, 3) their positions [m].
        orientation: (3, 3) the commanded orientation, or None (a robot of fewer than 6 degrees of freedom).
        rows: The sequence: (pose, cycle, direction) per row, direction ``""`` in the pose series.
        directions: The approach directions of each pose of the multi-directional series.
        approach: Distance [m] of the approach points from their pose.
        compensation: The commands of the 5 poses then the approach points (:func:`approach_points` order).
        region_note, orientation_note, commands_note: In words, where the cube was sought, the orientation and what
            the commands were computed on.
    """

    robot: Robot
    frame: str
    cube: Cube
    names: list[str]
    positions: Array
    orientation: Array | None
    rows: list[tuple[str, int, str]]
    directions: dict[str, tuple[str, ...]]
    approach: float
    compensation: Compensation
    region_note: str
    orientation_note: str
    commands_note: str

    @property
    def n_rows(self) -> int:
        """Rows of the sequence."""
        return len(self.rows)

    @property
    def largest_residual(self) -> float:
        """Largest distance [m] from a planned point to the frame, as the model places it at the commands."""
        return float(np.max(self.compensation.residuals[:, 0]))


def approach_points(positions: Array, approach: float) -> list[tuple[str, str, Array]]:
    """(pose, direction, point [m]) of each approach of the multi-directional series: the point ``approach`` [m]
    from the pose along the direction (``+x``: towards larger x)."""
    out = []
    for name, directions in MULTI_DIRECTIONAL.items():
        for d in directions:
            step = np.zeros(3)
            step[AXES[d[1]]] = approach if d[0] == "+" else -approach
            out.append((name, d, positions[int(name[1]) - 1] + step))
    return out


def _sequence(cycles: int) -> list[tuple[str, int, str]]:
    rows = [(name, cycle, "") for cycle in range(1, cycles + 1) for name in CYCLE_ORDER]
    rows += [(name, cycle, d) for name, directions in MULTI_DIRECTIONAL.items() for d in directions
             for cycle in range(1, cycles + 1)]
    return rows


def _goals(points: Array, orientation: Array | None) -> Goals:
    return Goals(points, None if orientation is None else np.tile(orientation, (len(points), 1, 1)))


def _inside(points: Array, region: Array | None) -> npt.NDArray[np.bool_]:
    if region is None:
        return np.ones(points.shape[:-1], dtype=bool)
    return np.asarray(np.all((points >= region[:3]) & (points <= region[3:]), axis=-1))


def checked_points(cube: Cube) -> Array:
    """(41, 3) the points [m] a cube is judged on: its 3 × 3 × 3 grid, P1–P5 and the approach points."""
    positions = cube.poses()
    return np.vstack([cube.grid(), positions, [p for _, _, p in approach_points(positions, APPROACH * cube.side)]])


def _reached(solver: CommandSolver, cubes: list[Cube], starts: Array, orientation: Array | None,
             region: Array | None) -> npt.NDArray[np.bool_]:
    """Which cubes have every checked point (:func:`checked_points`) reached from their start (na,), away from
    singular postures (:data:`CLEAR_RATIO`) and inside ``region``."""
    points = np.array([checked_points(cube) for cube in cubes])
    n = points.shape[1]
    solved = actuated_newton(solver.frame, _goals(points.reshape(-1, 3), orientation),
                             np.repeat(starts, n, axis=0), solver.lower, solver.upper, REACH_TOLERANCE)
    clear = solved.converged.copy()
    rows = np.flatnonzero(clear)
    if rows.size:
        clear[rows] = solver.ratios(solver.frame.state(solved.q[rows]), orientation is not None) >= CLEAR_RATIO
    return np.asarray(clear.reshape(len(cubes), n).all(axis=1) & _inside(points, region).all(axis=1))


def largest_cube(robot: Robot, frame: str, orientation: Array | None, region: Array | None, candidates: int,
                 seed: int) -> Cube | None:
    """The largest cube found inside the reachable workspace of ``frame`` (and ``region``) with the frame held at
    ``orientation`` (this module's docstring); None when no candidate centre is reached."""
    _, q = random_actuated(robot, candidates, np.random.default_rng(seed))
    cloud = np.array([robot.placement(config, frame).translation for config in q])
    inside = cloud[_inside(cloud, region)]
    if not len(inside):
        return None
    order = np.argsort(np.linalg.norm(inside - linalg.median(inside, axis=0), axis=1), kind="stable")
    centres = inside[order[np.linspace(0, len(order) - 1, min(CENTRES, len(order))).astype(int)]]
    solver = CommandSolver(Model(robot), frame, REACH_TOLERANCE, seed)
    commands = solver.solve(_goals(centres, orientation))
    ok = np.array([s == "ok" for s in commands.statuses])
    centres, starts = centres[ok], commands.raw[ok]
    if not len(centres):
        return None
    largest = float(np.max(np.ptp(inside, axis=0)))
    if region is not None:
        largest = min(largest, float(np.min(region[3:] - region[:3])))
    sides = largest * SHRINK ** np.arange(SIDES)
    cubes = [Cube(c, float(s)) for c in centres for s in sides]
    reached = _reached(solver, cubes, np.repeat(starts, SIDES, axis=0), orientation, region).reshape(-1, SIDES)
    best_side, best = 0.0, -1
    for k in range(len(centres)):
        if reached[k].any():
            side = float(sides[int(np.argmax(reached[k]))])
            if side > best_side:
                best_side, best = side, k
    if best < 0:
        return None
    low, high = best_side, best_side / SHRINK
    for _ in range(BISECTIONS):
        middle = (low + high) / 2
        if _reached(solver, [Cube(centres[best], middle)], starts[best:best + 1], orientation, region)[0]:
            low = middle
        else:
            high = middle
    return Cube(np.asarray(centres[best], dtype=float), low)


def _targets(frame: str, points: Array, orientation: Array | None) -> Targets:
    ids = [f"t{k}" for k in range(len(points))]
    if orientation is None:
        return Targets(f"position:{frame}", ids, points)
    xyzw = pin.Quaternion(orientation).coeffs()
    return Targets(f"pose:{frame}", ids, np.hstack([points, np.tile(xyzw, (len(points), 1))]))


def plan_test(robot: Robot, region: tuple[float, ...] | None = None, orientation: tuple[float, ...] | None = None,
              frame: str | None = None, model: str | None = None, cycles: int = 30, seed: int = 0,
              candidates: int = 400, min_side: float = 0.02) -> Plan:
    """Plan the ISO 9283 test of ``robot`` (this module's docstring).

    Args:
        robot: The nominal robot.
        region: (xmin, ymin, zmin, xmax, ymax, zmax) [m] in the base frame the cube must lie in; None: anywhere.
        orientation: The frame's orientation at every pose, a unit quaternion (qw, qx, qy, qz) in the base frame;
            None: its orientation at the reference configuration. Refused for a robot of fewer than 6 degrees of
            freedom (its orientation is not commanded).
        frame: The frame tested; None: the robot's measured frame.
        model: A calibrated URDF of the robot: the commands are computed on it (``pincal compensate``).
        cycles: Cycles of each series (the standard: 30).
        seed: Seed of the sampled postures.
        candidates: Sampled postures.
        min_side: Smallest side [m] of a test cube worth testing.

    Raises:
        DataError: a robot of fewer than 3 degrees of freedom, or an orientation for one of fewer than 6; no cube
            of ``min_side`` fits inside the reachable workspace (in ``region``); a planned point the model does not
            reach; a model of other actuated joints.
        NotFoundError: an unknown frame.
    """
    validation.whole("cycles", cycles, 2)
    validation.whole("candidates", candidates, 1)
    name = frame or robot.measured_frame_choice.frame
    if name is None:
        raise DataError(f"'{robot.name}' has no frame its actuated joints move: give frame=NAME", option="frame")
    with Culprit(option="frame"):
        robot.frame_id(name)
    if robot.mobility() < 3:
        raise DataError(f"'{robot.name}' has {robot.mobility()} degrees of freedom: its frame cannot reach the points "
                        "of a cube, which the ISO 9283 test needs (three)")
    six = robot.mobility() >= 6
    if orientation is not None and not six:
        given = ",".join(f"{v:g}" for v in orientation)
        raise DataError(f"orientation={given}: '{robot.name}' has {robot.mobility()} degrees of freedom, so the "
                        "orientation of its frame is not commanded; plan without it",
                        option="orientation")
    rotation = None
    if six:
        if orientation is None:
            rotation = robot.placement(robot.q_reference, name).rotation.copy()
            orientation_note = "the frame's orientation at the reference configuration (give --orientation)"
        else:
            w, x, y, z = orientation
            rotation = pin.Quaternion(w, x, y, z).normalized().matrix()
            orientation_note = f"(qw, qx, qy, qz) = ({', '.join(f'{v:.6g}' for v in orientation)}) as given"
    else:
        orientation_note = f"not commanded ({robot.mobility()} degrees of freedom: positions only)"
    bounds = None if region is None else np.array(region, dtype=float)
    where = ("the reachable workspace" if bounds is None else
             f"the reachable workspace in the region [{', '.join(f'{v:g}' for v in region or ())}] m")
    cube = largest_cube(robot, name, rotation, bounds, candidates, seed)
    if cube is None or cube.side < min_side:
        found = "none is reached" if cube is None else f"the largest found has a side of {cube.side * 1e3:.3g} mm"
        raise DataError(f"no test cube of side ≥ {min_side * 1e3:g} mm fits inside {where} of frame '{name}' with the "
                        f"orientation asked: {found}; give another region=XMIN,YMIN,ZMIN,XMAX,YMAX,ZMAX or orientation",
                        option="region")
    positions = cube.poses()
    approach = APPROACH * cube.side
    points = np.vstack([positions, [p for _, _, p in approach_points(positions, approach)]])
    controlled = load_model(model, robot) if model else Model(robot)
    if controlled.robot.actuated_joints != robot.actuated_joints:
        raise DataError(f"model={model} actuates {', '.join(controlled.robot.actuated_joints)}, not the joints of "
                        f"'{robot.name}': it is not a calibration of this robot", option="model")
    result = compensate(controlled, _targets(name, points, rotation), targets_in="base" if model else "measurement",
                        seed=seed)
    missed = [k for k, status in enumerate(result.statuses) if status != "ok"]
    if missed:
        labels = ["P1", "P2", "P3", "P4", "P5"] + [f"the approach of {p} from {d}"
                                                   for p, d, _ in approach_points(positions, approach)]
        raise DataError(f"{labels[missed[0]]} of the test cube is not reached"
                        + (f" on model={model}" if model else "") + f": {result.statuses[missed[0]]}",
                        option="model" if model else None)
    commands_note = (f"through compensate on the calibrated model {model}" if model
                     else f"on the nominal robot '{robot.name}' (give --model CAL.urdf for a calibrated one)")
    return Plan(robot, result.frame, cube, ["P1", "P2", "P3", "P4", "P5"], positions, rotation, _sequence(cycles),
                dict(MULTI_DIRECTIONAL), approach, result, f"sought in {where}", orientation_note, commands_note)


def plan_text(plan: Plan, given: str) -> str:
    """The plan as a CSV: ``#`` lines (robot, pincal version, units, frame, cube, P1–P5), then one row per step: pose,
    cycle, direction, the commanded position (and orientation) as ``iso9283 evaluate`` reads it, the actuated joint
    commands, and for the multi-directional rows the approach point and its joint commands."""
    joints = list(plan.robot.actuated_joints)
    commands = plan.compensation.commands
    approaches = {(p, d): (point, commands[5 + k])
                  for k, (p, d, point) in enumerate(approach_points(plan.positions, plan.approach))}
    quaternion = [] if plan.orientation is None else list(pin.Quaternion(plan.orientation).coeffs())
    wxyz = quaternion[3:] + quaternion[:3]
    header = ["step", "pose", "cycle", "direction", "cmd_x", "cmd_y", "cmd_z",
              *(["cmd_qw", "cmd_qx", "cmd_qy", "cmd_qz"] if wxyz else []), *joints,
              "approach_x", "approach_y", "approach_z", *(f"approach:{j}" for j in joints)]
    lines = [f"# robot: {given}", f"# pincal: {version()}", "# units: SI (m, rad)",
             f"# iso9283: ISO 9283:1998 test plan of frame {plan.frame}; add the attained x, y, z [m] (and qw, qx, qy, "
             "qz) to each row and run 'pincal iso9283 evaluate'",
             f"# cube: centre {' '.join(repr(float(v)) for v in plan.cube.centre)} m, side {plan.cube.side!r} m",
             *(f"# {n}: {' '.join(repr(float(v)) for v in p)}" for n, p in zip(plan.names, plan.positions,
                                                                                 strict=True)),
             ",".join(header)]
    for step, (pose, cycle, direction) in enumerate(plan.rows, start=1):
        k = int(pose[1]) - 1
        cells = [str(step), pose, str(cycle), direction, *(repr(float(v)) for v in plan.positions[k]),
                 *(repr(float(v)) for v in wxyz), *(repr(float(v)) for v in commands[k])]
        if direction:
            point, values = approaches[(pose, direction)]
            cells += [*(repr(float(v)) for v in point), *(repr(float(v)) for v in values)]
        else:
            cells += [""] * (3 + len(joints))
        lines.append(",".join(cells))
    return "\n".join(lines) + "\n"
