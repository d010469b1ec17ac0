"""``pincal detect``'s errors name their culprit as fields beside the message: the ``measure`` option, the joints
file's missing ``time`` column; the command still says it in one line."""

from __future__ import annotations

from pathlib import Path

import numpy as np
import pytest
from conftest import run_pincal

from pincal.errors import DataError
from pincal.io.dataset import Dataset
from pincal.io.detections import by_time, pixel_kind
from pincal.io.vision import Detections

BOARD = "charuco:8x6:0.03:0.022:DICT_4X4_50"


@pytest.mark.parametrize("measure", ["pose:tool0", "pixel:", "cross_pixel:tool0", "cross_pixel:tool0-tool0"])
def test_a_measure_of_another_form_names_the_option(measure: str) -> None:
    with pytest.raises(DataError, match=f"^measure='{measure}'") as caught:
        pixel_kind(measure)
    assert (caught.value.option, caught.value.file) == ("measure", None)


def test_pairing_by_time_without_a_time_column_names_the_column() -> None:
    joints = Dataset(["j1", "j2"], np.zeros((2, 2)), {}, ["a", "b"], ["train", "train"])
    with pytest.raises(DataError, match="needs a 'time' column") as caught:
        by_time(Detections(), joints, 0.05)
    assert caught.value.column == "time"


def test_the_command_names_a_camera_and_board_on_one_frame(tmp_path: Path) -> None:
    done = run_pincal("detect", "0000.png", "--joints", "joints.csv", "--board", BOARD, "--measure",
                      "cross_pixel:tool0-tool0", "--out", "d.csv", cwd=tmp_path)
    assert done.returncode == 2 and done.stdout == "", done.stdout + done.stderr
    assert done.stderr.splitlines() == ["pincal: error: --measure cross_pixel:tool0-tool0: the camera and the board "
                                        "are on the same frame (nothing moves between them): give two frames on "
                                        "different chains"]
    assert not (tmp_path / "d.csv").exists()
