"""``pincal check`` on pixels: each image's reprojection error under MODEL and under the nominal robot.

A pixel reading is a board corner seen in one image (a sample); its error is ``|(Δu, Δv)|`` [px], predicted −
measured. An image's reprojection error is the RMS of its corners' errors; the check's verdict on pixels compares
the RMS over every corner seen. MODEL predicts with its calibrated camera (placement and intrinsics, as its file
holds them); the nominal robot with its camera registered on the data (placement and intrinsics), calibrate's
"before" (:mod:`pincal.calibration.check_setup`).
"""

from __future__ import annotations

from collections.abc import Sequence
from typing import Any

import numpy as np
import numpy.typing as npt

from pincal import linalg
from pincal.calibration.propagation import LEVEL, norm_quantiles, row_sigmas
from pincal.calibration.report_sections import PixelAccount, PixelPredictions, PredictedImage
from pincal.identification.measurements import KIND_CLASSES, Measurement
from pincal.identification.measurements.pixels import Pixel
from pincal.identification.metrics import pixel_error_norms, rms
from pincal.identification.problem import CalibrationProblem
from pincal.records import record

Array = npt.NDArray[np.float64]


def is_pixel_key(key: str) -> bool:
    """Whether measurement ``key`` is a pixel reading (its kind's readings are in px)."""
    kind = KIND_CLASSES.get(key.partition(":")[0])
    return kind is not None and issubclass(kind, Pixel)


def image_errors(errors: dict[str, Array], n: int) -> Array | None:
    """Each of ``n`` samples' (images') reprojection error [px]: the RMS of ``|(Δu, Δv)|`` over the corners it saw
    (NaN for an image that saw none); None when no pixel is measured."""
    keys = [key for key in errors if is_pixel_key(key)]
    if not keys:
        return None
    squares, seen = np.zeros(n), np.zeros(n)
    for key in keys:
        rows = errors[key][:, :2]
        taken = ~np.isnan(rows).any(axis=1)
        squares[taken] += np.sum(rows[taken] ** 2, axis=1)
        seen += taken
    with np.errstate(invalid="ignore", divide="ignore"):
        return np.where(seen > 0, np.sqrt(squares / np.maximum(seen, 1)), np.nan)


def number(value: float) -> float | None:
    """A figure for JSON: None when not finite (no reading)."""
    return float(value) if np.isfinite(value) else None


def largest(values: Array) -> float | None:
    """The largest of ``values``; None when there is none."""
    return float(values.max()) if values.size else None


def pixel_figures(model: dict[str, Array], nominal: dict[str, Array]) -> dict[str, Any] | None:
    """RMS and max reprojection error [px] of MODEL and of the nominal robot (their errors per measurement key, rows
    predicted − measured) over every corner seen, and the corners' count; None when no pixel is measured."""
    if not any(is_pixel_key(key) for key in model):
        return None
    a, b = pixel_error_norms(model), pixel_error_norms(nominal)
    return {"unit": "px", "n_corners": int(a.size), "rms": number(rms(a)),
            "max": largest(a), "nominal_rms": number(rms(b)),
            "nominal_max": largest(b)}


def pixel_quantities(models: Sequence[Measurement], model: dict[str, Array],
                     nominal: dict[str, Array]) -> list[dict[str, Any]]:
    """One row per camera (``pixel:<frame>``, ``board_pixel:<frame>``) of ``check``'s quantities: its corners seen,
    the RMS and max reprojection error [px] of MODEL and of the nominal robot."""
    groups: dict[str, list[str]] = {}
    for m in models:
        if isinstance(m, Pixel):
            groups.setdefault(m.key.rpartition("@")[0], []).append(m.key)
    out = []
    for name, keys in groups.items():
        a = pixel_error_norms({k: model[k] for k in keys})
        b = pixel_error_norms({k: nominal[k] for k in keys})
        out.append({"measurement": name, "quantity": "reprojection", "unit": "px", "n": int(a.size),
                    "rms": number(rms(a)), "max": largest(a),
                    "nominal_rms": number(rms(b)), "nominal_max": largest(b)})
    return out


def pixels_worse(model: dict[str, Array], nominal: dict[str, Array], same: float) -> bool | None:
    """Whether MODEL's RMS reprojection error exceeds the nominal robot's by more than the fraction ``same``; None
    when no pixel is measured."""
    figures = pixel_figures(model, nominal)
    if figures is None or figures["rms"] is None or figures["nominal_rms"] is None:
        return None
    return bool(figures["rms"] > (1.0 + same) * figures["nominal_rms"])


@record(frozen=True)
class PixelBounds:
    """Each image's predicted 95 % bound of its reprojection error under MODEL, from the calibration's covariance.

    An image's corners' errors ``e`` (2 per corner, u and v [px]) are predicted to have the covariance
    ``S = J C Jᵀ + σ̂² diag(σ_row²)`` [px²] (``C`` the fit's covariance of its estimates, robot, camera, board and
    intrinsics, and the corners' stated σ scaled by the fit's variance factor): the bound of the image's RMS
    reprojection error is the 95 % quantile of ``‖e‖`` under ``S`` over ``√n`` (n the corners seen,
    :func:`~pincal.calibration.propagation.norm_quantiles`). No growth beyond the fitted range is known for pixels.

    Attributes:
        bound: (N,) the bound [px] (NaN for an image that saw no corner).
        model_bound: (N,) the same with no noise (``J C Jᵀ`` alone) [px]: how far MODEL's prediction of a corner may be
            off.
        scale: (N,) metres at the board per pixel there [m/px]: the median over pairs of corners seen of their distance
            on the board over their distance in MODEL's image (NaN with fewer than two corners): ``bound · scale`` is
            the bound in m at the board.
    """

    bound: Array
    model_bound: Array
    scale: Array

    def entry(self, k: int) -> dict[str, Any]:
        """Sample ``k``'s figures for the check's report: the bounds [px] and [m] at the board."""
        return {"pixel_bound": number(self.bound[k]), "pixel_model_bound": number(self.model_bound[k]),
                "pixel_bound_at_board": number(self.bound[k] * self.scale[k])}

    def account(self, errors: Array | None) -> PixelAccount:
        """How many images' reprojection errors ``errors`` (N,) [px] lie within their bound, and the median bound [px]
        and at the board [m]."""
        known = np.isfinite(self.bound) & (np.isfinite(errors) if errors is not None else False)
        within = known & (np.nan_to_num(errors, nan=np.inf) <= self.bound) if errors is not None else known & False
        inside = int(np.count_nonzero(within))
        at_board = self.bound * self.scale
        return PixelAccount(level=LEVEL, unit="px", inside=inside, images=int(np.count_nonzero(known)),
                            median_bound=_median(self.bound), median_model_bound=_median(self.model_bound),
                            median_bound_at_board=_median(at_board))


def pixel_account(bounds: PixelBounds | None, errors: Array | None) -> PixelAccount | None:
    """:meth:`PixelBounds.account` of the images' reprojection errors ``errors`` (N,) [px]; None without bounds."""
    return bounds.account(errors) if bounds is not None else None


def _median(values: Array) -> float | None:
    finite = values[np.isfinite(values)]
    return float(linalg.median(finite)) if finite.size else None


def pixel_bounds(problem: CalibrationProblem, covariance: Array, columns: list[int], sigma2: float,
                 x: Array) -> PixelBounds | None:
    """:class:`PixelBounds` of ``problem``'s images for the model at ``x`` [m, rad], with the fit's ``covariance`` of
    the parameters ``columns`` (in ``problem``'s order) [their units squared] and variance factor ``sigma2``; None when
    the problem measures no pixel or the covariance is not known."""
    pixels = [m for m in problem.measurements if isinstance(m, Pixel)]
    if not pixels or not np.all(np.isfinite(covariance)) or not np.isfinite(sigma2):
        return None
    prediction = problem.evaluate(x, jacobian=True)
    assert prediction.jacobian is not None
    n = problem.observations.n_samples
    rows = _pixel_rows(problem, n)
    width = 2 * max((len(r) for r in rows), default=0)
    sigma = row_sigmas(problem)
    jac = prediction.jacobian[:, columns] * sigma[:, None]  # unweighted [px per parameter unit]
    bound, model_bound, scale = np.full(n, np.nan), np.full(n, np.nan), np.full(n, np.nan)
    full, model = np.zeros((n, width, width)), np.zeros((n, width, width))
    for k, starts in enumerate(rows):
        if not starts:
            continue
        index = np.concatenate([[r, r + 1] for r in starts])
        block = jac[index]
        w = index.size
        model[k, :w, :w] = block @ covariance @ block.T
        full[k, :w, :w] = model[k, :w, :w] + sigma2 * np.diag(sigma[index] ** 2)
    seen = np.array([len(r) for r in rows], dtype=float)
    some = seen > 0
    bound[some] = norm_quantiles(full[some]) / np.sqrt(seen[some])
    model_bound[some] = norm_quantiles(model[some]) / np.sqrt(seen[some])
    for k in range(n):
        scale[k] = metres_per_pixel(pixels, prediction.predicted, k)
    return PixelBounds(bound, model_bound, scale)


def _pixel_rows(problem: CalibrationProblem, n: int) -> list[list[int]]:
    """Per sample, the first residual row (u; v follows) of each pixel reading it holds, in :meth:`evaluate`'s order."""
    out: list[list[int]] = [[] for _ in range(n)]
    start = 0
    for m in problem.measurements:
        taken = np.flatnonzero(problem.seen(m.key))
        if isinstance(m, Pixel):
            for j, k in enumerate(taken.tolist()):
                out[k].append(start + m.size * j)
        start += m.size * taken.size
    return out


def metres_per_pixel(pixels: list[Pixel], predicted: dict[str, Array], k: int) -> float:
    """Image ``k``'s metres at the board per pixel [m/px]: the median over pairs of its corners of their distance on
    the board over their distance in the predicted image; NaN with fewer than two corners."""
    points, uv = [], []
    for m in pixels:
        row = predicted[m.key][k, :2]
        if np.all(np.isfinite(row)) and m.board is not None:
            points.append(m.point())
            uv.append(row)
    if len(points) < 2:
        return float("nan")
    b, p = np.array(points), np.array(uv)
    i, j = np.triu_indices(len(b), 1)
    apart = np.linalg.norm(p[i] - p[j], axis=1)
    keep = apart > 0.0
    return float(linalg.median(np.linalg.norm(b[i] - b[j], axis=1)[keep] / apart[keep])) if keep.any() else float("nan")


def held_out_pixels(problem: CalibrationProblem, covariance: Array, columns: list[int], sigma2: float, x: Array,
                    errors: dict[str, Array], ids: list[str]) -> PixelPredictions | None:
    """The report's predictions of the held-out images (``problem``'s samples ``ids``, their errors after the fit
    ``errors`` per measurement key [px]): :meth:`PixelBounds.account` and, per image, :meth:`PixelBounds.entry`
    (bounds [px] and at the board [m]) beside its reprojection error [px]; None without pixels or covariance."""
    bounds = pixel_bounds(problem, covariance, columns, sigma2, x)
    found = image_errors(errors, len(ids))
    if bounds is None or found is None:
        return None
    return PixelPredictions(**bounds.account(found).as_dict(),
                            images_predicted=[PredictedImage(sample=s, pixel_error=number(found[k]), **bounds.entry(k))
                                              for k, s in enumerate(ids)])
