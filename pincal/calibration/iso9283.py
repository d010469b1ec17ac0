"""ISO 9283:1998 performance figures of measured runs: pose accuracy and repeatability, distance accuracy and
repeatability, multi-directional pose accuracy variation (docs/iso9283.md gives each formula with its clause).

Every figure is in SI units: positions [m], orientations [rad]. The orientation deviations a, b, c are the components,
about the base frame's x, y, z axes, of the rotation vector log(R_attained · R_commandedᵀ), which equal the
standard's differences of the angles about x, y, z to first order.
"""

from __future__ import annotations

import itertools
import re
from dataclasses import asdict
from typing import Any

import numpy as np
import numpy.typing as npt

from pincal.errors import DataError, listing
from pincal.io.iso_runs import Runs
from pincal.records import record

Array = npt.NDArray[np.float64]

#: Largest spread [m] of one pose's commanded positions: the standard commands each pose the same in every cycle.
COMMAND_TOLERANCE = 1e-6


#: The largest angle [rad] an attained orientation plausibly deviates from its command: beyond, a quaternion in
#: another order (x, y, z, w) or frame, and the orientation figures are warned of.
ORIENTATION_PLAUSIBLE = 0.1


@record(frozen=True)
class PoseFigures:
    """Pose accuracy and repeatability of one pose (ISO 9283:1998, 7.2.1 and 7.2.2).

    Attributes:
        pose: Its name.
        cycles: n, the cycles measured.
        commanded: (x_c, y_c, z_c) [m].
        mean: (x̄, ȳ, z̄) [m], the barycentre of the attained positions.
        ap: AP_P = √((x̄−x_c)² + (ȳ−y_c)² + (z̄−z_c)²) [m].
        ap_xyz: (AP_x, AP_y, AP_z) = (x̄−x_c, ȳ−y_c, z̄−z_c) [m].
        rp: RP_l = l̄ + 3 S_l [m], l_j = distance of attained position j from the barycentre.
        l_mean: l̄ [m].
        s_l: S_l = √(Σ(l_j − l̄)² / (n − 1)) [m].
        ap_abc: (AP_a, AP_b, AP_c) = (ā − a_c, b̄ − b_c, c̄ − c_c) [rad], or None without orientations.
        rp_abc: (RP_a, RP_b, RP_c) = ±3 S_a, ±3 S_b, ±3 S_c [rad] (the half-width), or None.
    """

    pose: str
    cycles: int
    commanded: list[float]
    mean: list[float]
    ap: float
    ap_xyz: list[float]
    rp: float
    l_mean: float
    s_l: float
    ap_abc: list[float] | None
    rp_abc: list[float] | None


@record(frozen=True)
class DistanceFigures:
    """Distance accuracy and repeatability between two poses (ISO 9283:1998, 7.4.1 and 7.4.2).

    Attributes:
        poses: The two poses' names.
        cycles: n, the cycles in which both were measured.
        commanded: D_c = |P_c1 − P_c2| [m].
        mean: D̄ = Σ D_j / n, D_j = |P_1j − P_2j| [m].
        ad: AD_P = D̄ − D_c [m].
        ad_xyz: (AD_x, AD_y, AD_z) = D̄_x − D_cx … with D_x = |x_1 − x_2| [m].
        rd: RD = 3 √(Σ(D_j − D̄)² / (n − 1)) [m] (the half-width of ±).
    """

    poses: list[str]
    cycles: int
    commanded: float
    mean: float
    ad: float
    ad_xyz: list[float]
    rd: float


@record(frozen=True)
class VariationFigures:
    """Multi-directional pose accuracy variation of one pose (ISO 9283:1998, 7.3).

    Attributes:
        pose: Its name.
        directions: The approach directions, each with its cycles.
        vap: vAP_P = max over pairs h, k of directions of |barycentre_h − barycentre_k| [m].
        vap_abc: (vAP_a, vAP_b, vAP_c) = max |ā_h − ā_k| … [rad], or None without orientations.
    """

    pose: str
    directions: dict[str, int]
    vap: float
    vap_abc: list[float] | None


@record(frozen=True)
class Iso9283Figures:
    """The ISO 9283 figures of a runs file.

    Attributes:
        poses: Per pose of the pose series (rows without a direction), in the order of their names (P2 before P10).
        distances: Per pair of poses measured in common cycles of the pose series.
        variations: Per pose measured from two or more directions.
        instrument_uncertainty: The measuring instrument's stated uncertainty [m], or None.
        warnings: Figures the instrument cannot resolve, in words.
    """

    poses: list[PoseFigures]
    distances: list[DistanceFigures]
    variations: list[VariationFigures]
    instrument_uncertainty: float | None
    warnings: list[str]

    def as_dict(self) -> dict[str, Any]:
        """The figures as JSON values (SI: m, rad)."""
        return {"units": "SI: m, rad", **asdict(self)}


def rotation_deviations(commanded: Array, attained: Array) -> Array:
    """(N, 3) a, b, c [rad]: the rotation vector of R_attained · R_commandedᵀ, about the base frame's axes.

    Args:
        commanded: (N, 4) the commanded orientations, unit quaternions (w, x, y, z).
        attained: (N, 4) the attained orientations, unit quaternions (w, x, y, z).
    """
    qa = attained / np.linalg.norm(attained, axis=1)[:, None]
    qc = commanded / np.linalg.norm(commanded, axis=1)[:, None]
    wa, va, wc, vc = qa[:, 0], qa[:, 1:], qc[:, 0], -qc[:, 1:]  # q_attained ⊗ conj(q_commanded)
    w = wa * wc - np.sum(va * vc, axis=1)
    v = wa[:, None] * vc + wc[:, None] * va + np.cross(va, vc)
    v = np.where((w < 0)[:, None], -v, v)  # q and -q are one rotation: the one of angle ≤ π
    norm = np.linalg.norm(v, axis=1)
    angle = 2.0 * np.arctan2(norm, np.abs(w))  # exact up to a half turn, where the matrix formula loses its axis
    scale = np.where(norm > 1e-15, angle / np.where(norm > 1e-15, norm, 1.0), 2.0)
    return np.asarray(v * scale[:, None], dtype=float)


def pose_figures(name: str, commanded: Array, attained: Array, deviations: Array | None = None) -> PoseFigures:
    """AP and RP of one pose from its cycles (ISO 9283:1998, 7.2.1, 7.2.2).

    Args:
        name: The pose's name.
        commanded: (3,) x_c, y_c, z_c [m].
        attained: (n, 3) the attained positions [m], n ≥ 2.
        deviations: (n, 3) orientation deviations a, b, c [rad] (:func:`rotation_deviations`), or None.
    """
    mean = attained.mean(axis=0)
    ap_xyz = mean - commanded
    distances = np.linalg.norm(attained - mean, axis=1)
    l_mean = float(distances.mean())
    s_l = float(np.sqrt(np.sum((distances - l_mean) ** 2) / (len(distances) - 1)))
    ap_abc = rp_abc = None
    if deviations is not None:
        ap_abc = deviations.mean(axis=0).tolist()
        rp_abc = (3.0 * deviations.std(axis=0, ddof=1)).tolist()
    return PoseFigures(name, len(attained), commanded.tolist(), mean.tolist(), float(np.linalg.norm(ap_xyz)),
                       ap_xyz.tolist(), l_mean + 3.0 * s_l, l_mean, s_l, ap_abc, rp_abc)


def distance_figures(names: tuple[str, str], commanded: tuple[Array, Array], first: Array,
                     second: Array) -> DistanceFigures:
    """AD and RD between two poses from the cycles in which both were measured (ISO 9283:1998, 7.4).

    Args:
        names: The two poses.
        commanded: Their commanded positions (3,) [m].
        first: (n, 3) the first pose's attained positions in the n common cycles [m], n ≥ 2.
        second: (n, 3) the second's, in the same cycles [m].
    """
    d_c = float(np.linalg.norm(commanded[0] - commanded[1]))
    d = np.linalg.norm(first - second, axis=1)
    d_xyz = np.abs(first - second).mean(axis=0) - np.abs(commanded[0] - commanded[1])
    return DistanceFigures(list(names), len(d), d_c, float(d.mean()), float(d.mean()) - d_c, d_xyz.tolist(),
                           float(3.0 * d.std(ddof=1)))


def variation_figures(name: str, attained: dict[str, Array], deviations: dict[str, Array] | None) -> VariationFigures:
    """vAP of one pose from its attained positions [m] (and orientation deviations [rad]) per approach direction
    (ISO 9283:1998, 7.3)."""
    centres = {d: a.mean(axis=0) for d, a in attained.items()}
    pairs = list(itertools.combinations(centres, 2))
    vap = max(float(np.linalg.norm(centres[h] - centres[k])) for h, k in pairs)
    vap_abc = None
    if deviations is not None:
        means = {d: a.mean(axis=0) for d, a in deviations.items()}
        vap_abc = np.max([np.abs(means[h] - means[k]) for h, k in pairs], axis=0).tolist()
    return VariationFigures(name, {d: len(a) for d, a in attained.items()}, vap, vap_abc)


def _natural(name: str) -> list[Any]:
    """A sort key putting P2 before P10."""
    return [int(part) if part.isdigit() else part for part in re.split(r"(\d+)", name)]


def _commanded(runs: Runs, rows: npt.NDArray[np.intp], pose: str) -> Array:
    values = runs.commanded[rows]
    spread = float(np.abs(values - values[0]).max())
    if spread > COMMAND_TOLERANCE:
        far = rows[int(np.argmax(np.abs(values - values[0]).max(axis=1)))]
        raise DataError(f"pose {pose}: its commanded position on line {runs.lines[far]} differs from line "
                        f"{runs.lines[rows[0]]}'s by {spread:.3g} m; the standard commands a pose the same in every "
                        "cycle", line=int(runs.lines[far]))
    return np.asarray(values[0], dtype=float)


def evaluate_runs(runs: Runs, instrument_uncertainty: float | None = None) -> Iso9283Figures:
    """The ISO 9283 figures of ``runs``.

    Args:
        runs: The measured runs (:func:`~pincal.io.iso_runs.read_runs`).
        instrument_uncertainty: The instrument's stated uncertainty [m]; an RP below it is warned of.

    Raises:
        DataError: no row of the pose series, a pose (or a pose's direction) of fewer than 2 cycles, a pose
            commanded differently in two cycles.
    """
    deviations = (rotation_deviations(runs.commanded_quaternions, runs.attained_quaternions)
                  if runs.commanded_quaternions is not None and runs.attained_quaternions is not None else None)
    series = np.array([d == "" for d in runs.directions])
    if not series.any():
        raise DataError("no row of the pose series (rows with an empty direction): AP and RP need it")
    names = sorted(dict.fromkeys(p for p, s in zip(runs.poses, series, strict=True) if s), key=_natural)
    poses, commanded, by_cycle = [], {}, {}
    for name in names:
        rows = np.flatnonzero(series & np.array([p == name for p in runs.poses]))
        if len(rows) < 2:
            raise DataError(f"pose {name} has {len(rows)} cycle; RP needs at least 2 (the standard: 30)")
        commanded[name] = _commanded(runs, rows, name)
        poses.append(pose_figures(name, commanded[name], runs.attained[rows],
                                  None if deviations is None else deviations[rows]))
        by_cycle[name] = {int(runs.cycles[r]): runs.attained[r] for r in rows}
    distances, apart = [], []
    for first, second in itertools.combinations(names, 2):
        common = sorted(set(by_cycle[first]) & set(by_cycle[second]))
        if len(common) < 2:
            apart.append(f"{first}-{second}")
        else:
            distances.append(distance_figures((first, second), (commanded[first], commanded[second]),
                                              np.array([by_cycle[first][c] for c in common]),
                                              np.array([by_cycle[second][c] for c in common])))
    variations = []
    for name in dict.fromkeys(p for p, s in zip(runs.poses, series, strict=True) if not s):
        rows = np.flatnonzero(~series & np.array([p == name for p in runs.poses]))
        groups = {d: rows[[runs.directions[r] == d for r in rows]] for d in dict.fromkeys(runs.directions[r]
                                                                                            for r in rows)}
        if len(groups) < 2:
            raise DataError(f"pose {name} is measured from one direction only ({listing(groups)}); the multi-"
                            "directional variation compares two or more")
        few = next((d for d, g in groups.items() if len(g) < 2), None)
        if few is not None:
            raise DataError(f"pose {name} from direction '{few}' has {len(groups[few])} cycle; its barycentre needs "
                            "at least 2 (the standard: 30): a mistyped direction?")
        _commanded(runs, rows, name)
        variations.append(variation_figures(name, {d: runs.attained[g] for d, g in groups.items()},
                                            None if deviations is None else {d: deviations[g]
                                                                             for d, g in groups.items()}))
    warnings = [] if not apart else [f"no distance between {listing(apart)}: measured in fewer than 2 common "
                                     "cycles of the pose series"]
    if np.array_equal(runs.attained, runs.commanded):
        warnings.append("every attained position x, y, z equals its command cmd_x, cmd_y, cmd_z: are they the "
                        "instrument's readings? The figures are all zero")
    if deviations is not None and len(deviations):
        worst = int(np.argmax(np.linalg.norm(deviations, axis=1)))
        angle = float(np.linalg.norm(deviations[worst]))
        if angle > ORIENTATION_PLAUSIBLE:
            warnings.append(f"an attained orientation {angle:.3g} rad from its command (line {runs.lines[worst]}): "
                            "no robot errs so much; are the quaternions in w, x, y, z order, commanded and attained "
                            "in the same frame? The orientation figures cannot be trusted")
    if instrument_uncertainty is not None:
        below = [p.pose for p in poses if p.rp < instrument_uncertainty]
        if below:
            warnings.append(f"RP of {listing(below)} is below the instrument's stated uncertainty "
                            f"{instrument_uncertainty * 1e3:.4g} mm: the instrument cannot resolve it")
    return Iso9283Figures(poses, distances, variations, instrument_uncertainty, warnings)
