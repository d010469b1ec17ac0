"""The workflow's cross-validation from Python: a shuffle seed that would seed nothing is refused in the words of
:func:`pincal.calibration.calibrate`'s keywords, and :func:`pincal.calibration.cross_validate` takes its seed from the
plan. (The command line's and the job file's words: tests/cli/test_inputs.py, tests/cli/test_job_file.py.)"""

from __future__ import annotations

from pathlib import Path

import pytest

import pincal
from pincal.calibration.crossval import cross_validate, parse_cv
from pincal.calibration.options import check_cv_seed
from pincal.calibration.pipeline import calibrate
from pincal.calibration.samples import read_robot_dataset
from pincal.errors import ArgumentError, DataError
from pincal.io.dataset import Dataset


@pytest.fixture(scope="module")
def five_bar(five_bar_csv: Path) -> tuple[pincal.Robot, Dataset]:
    robot = pincal.load_robot("five_bar")
    return robot, read_robot_dataset(five_bar_csv, robot)


@pytest.mark.parametrize(("options", "message"), [
    ({"cv_seed": 5}, "cv_seed=5 seeds the shuffles of a K-fold cross-validation, and no cv is given; give cv too "
                     "(e.g. cv='5x4')"),
    ({"cv": "loo", "cv_seed": 5}, "cv_seed=5 seeds the shuffles of K-fold plans; cv='loo' has none (it leaves each "
                                  "sample out in turn): drop cv_seed, or cross-validate by K folds (e.g. cv='5x4')"),
    ({"cv": "5", "cv_seed": -1}, "cv_seed=-1: give a whole number ≥ 0"),
])
def test_a_seed_that_seeds_nothing_is_refused_in_the_keywords_words(five_bar: tuple[pincal.Robot, Dataset],
                                                                    options: dict[str, object], message: str) -> None:
    with pytest.raises(DataError) as refused:
        calibrate(*five_bar, **options)  # type: ignore[arg-type]
    assert str(refused.value) == message


def test_select_cv_by_leave_one_out_is_refused_as_an_argument_error(five_bar: tuple[pincal.Robot, Dataset]) -> None:
    """calibrate(select="cv", cv="loo") would repeat the selection's own cross-validation in each of its folds, one
    per sample: an ArgumentError in the keywords' words, before any fit (issue 36)."""
    with pytest.raises(ArgumentError) as refused:
        calibrate(*five_bar, select="cv", cv="loo")
    assert str(refused.value) == ("select='cv' with cv='loo' would repeat the cv selection (its own 5-fold "
                                  "cross-validation of every combination of parameter groups) in each of its folds "
                                  "(one per sample): minutes to hours of fitting; cross-validate by fewer folds "
                                  "(cv='5' or cv='5x4'), or leave select at its default")


def test_the_default_seed_and_a_k_fold_seed_are_accepted() -> None:
    """0 is the default seed, said or not: accepted with every plan; another seed with a K-fold plan."""
    for cv in (None, "loo", "LOO", "5", "5x4"):
        check_cv_seed(cv, 0)
    check_cv_seed("5x4", 3, "command line", "command line")
    check_cv_seed("3", 7, Path("job.toml"), Path("job.toml"))


def test_cross_validate_takes_the_seed_from_its_plan(five_bar: tuple[pincal.Robot, Dataset]) -> None:
    """The plan's seed moves the folds (and its label says so); cross_validate takes no ``seed`` of its own, as a
    keyword or in the place of ``progress``."""
    robot, dataset = five_bar
    problem = calibrate(robot, dataset, select="none").problem
    common = (robot, problem.parameters, problem.measurements, problem.observations)
    n = problem.observations.n_samples
    figures = {}
    for seed in (0, 2):
        cv = cross_validate(*common, parse_cv("3", n, seed), select="none")
        assert cv.plan == ("3-fold" if seed == 0 else "3-fold, shuffle seed 2") and not cv.failed_folds
        figures[seed] = cv.rms
    assert figures[0] != figures[2]
    with pytest.raises(TypeError, match="seed"):
        cross_validate(*common, parse_cv("3", n), select="none", seed=2)
    with pytest.raises(TypeError, match="positional argument"):
        cross_validate(*common, parse_cv("3", n), "none", 2)  # type: ignore[call-arg, arg-type]
