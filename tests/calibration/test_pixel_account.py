"""``pincal check``'s account of the images' predicted reprojection bounds is a typed record, written to the report
JSON as the object it was before and read back from it."""

from __future__ import annotations

import json

import numpy as np

from pincal.calibration.check_pixels import PixelBounds, pixel_account
from pincal.calibration.report_sections import PixelAccount, PixelPredictions
from pincal.io.files import json_text


def test_the_account_counts_the_images_within_their_bound() -> None:
    bounds = PixelBounds(bound=np.array([1.0, 2.0, np.nan]), model_bound=np.array([0.5, 1.0, np.nan]),
                         scale=np.array([1e-3, 2e-3, np.nan]))
    account = pixel_account(bounds, np.array([0.5, 3.0, 1.0]))  # within, beyond, no bound
    assert account == PixelAccount(level=0.95, unit="px", inside=1, images=2, median_bound=1.5,
                                   median_model_bound=0.75, median_bound_at_board=0.0025)
    assert pixel_account(None, np.array([0.5])) is None


def test_the_record_is_written_as_its_json_object_and_read_back() -> None:
    account = PixelAccount(inside=3, images=4, median_bound=0.5, median_model_bound=0.25, median_bound_at_board=None)
    text = json_text({"pixel_predicted": account, "after": 1})
    assert text == json_text({"pixel_predicted": {"level": 0.95, "unit": "px", "inside": 3, "images": 4,
                                                  "median_bound": 0.5, "median_model_bound": 0.25,
                                                  "median_bound_at_board": None}, "after": 1})
    assert PixelAccount.from_json(json.loads(text)["pixel_predicted"], "the check's 'pixel_predicted'") == account
    assert isinstance(PixelPredictions(**account.as_dict()), PixelAccount)  # the held-out images' account is one
