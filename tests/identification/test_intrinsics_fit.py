"""The intrinsics a calibration fits from pixels are unbiased: the fit does not stop short along the distortion
(a UR10 eye-in-hand campaign of 30 images, whose k1 a stop at the noise level once left 2.9σ from the truth)."""

from __future__ import annotations

import pincal
from pincal.calibration.pixel_campaign import DEFAULT_INTRINSICS, simulate_pixels
from pincal.identification.parameters.parameter import DISTORTION_SCALE

NAMES = ("fx", "fy", "cx", "cy", "k1", "k2", "p1", "p2")


def test_a_30_image_campaign_gives_the_true_intrinsics_within_their_sigma() -> None:
    robot = pincal.load_robot("ur10")
    sim = simulate_pixels(robot, "tool0", 30, 0, seed=5, noise=0.3)
    cal = pincal.calibrate(robot, sim.dataset)
    value = dict(zip(cal.result.names, cal.result.x.tolist(), strict=True))
    std = dict(zip(cal.result.names, cal.result.std.tolist(), strict=True))
    off = {c: (value[f"intrinsics.tool0.{c}"] - DEFAULT_INTRINSICS[k]) / std[f"intrinsics.tool0.{c}"]
           for k, c in enumerate(NAMES)}
    assert all(abs(v) < 3.0 for v in off.values()), off
    assert abs(off["k1"]) < 1.5, off
    # the images fix k1 to a few hundredths: a few typical sizes of a distortion coefficient, not thousands
    assert std["intrinsics.tool0.k1"] < 0.5 * DISTORTION_SCALE
