"""Cross-validation refuses incremental readings by the measurement's own hook (``incremental``), not by its key."""

from __future__ import annotations

import pytest

from pincal.calibration.crossval import check_cross_validation
from pincal.errors import DataError
from pincal.identification.measurements import parse_key


def test_incremental_readings_are_refused_and_absolute_ones_kept() -> None:
    chained = parse_key("distance_increment:a-b")
    assert chained.incremental
    with pytest.raises(DataError, match=r"^cv='5' cannot split distance_increment:a-b: each reading is the change"):
        check_cross_validation([parse_key("position:tool0"), chained], "fkm", "5")
    check_cross_validation([chained.absolute()], "fkm", "5")  # the same distance, absolute: a fold keeps its meaning
