"""One spelling of every calibration option: each field of CalibrationOptions reaches the API keywords, the parsers of
calibrate, view, report and fleet, the job-file reader and the --result check, with the same default and choices."""

from __future__ import annotations

import argparse
import json
from dataclasses import fields
from pathlib import Path

import pytest
from conftest import run_pincal
from test_job import write_job

import pincal
from pincal.calibration.job import JOB_KEYS, read_job
from pincal.calibration.options import DEFAULTS, OPTIONS, CalibrationOptions, GivenOptions, options_given
from pincal.cli.app import build_parser
from pincal.errors import DataError, NotFoundError

#: A value other than the default for each option, as the command line writes it and as the keyword holds it.
OTHER = {"parameter_spec": (["model24"], ("model24",)), "solver": (["tsvd"], "tsvd"), "loss": (["cauchy"], "cauchy"),
         "sigma": (["2e-5"], 2e-5), "formulation": (["ikm"], "ikm"), "max_iter": (["7"], 7),
         "select": (["none"], "none"), "cv": (["5x2"], "5x2"), "cv_seed": (["3"], 3),
         "markers": (["cluster"], "cluster"), "payload": (["1.5@tool0:0,0,0.1"], None),
         "plausible": (["2.5"], 2.5), "prior": (["off"], "off"), "force": ([], True)}


def _subparsers(parser: argparse.ArgumentParser) -> dict[str, argparse.ArgumentParser]:
    action = next(a for a in parser._actions if isinstance(a, argparse._SubParsersAction))
    return dict(action.choices)


def test_every_option_is_a_field_with_a_default_and_one_flag() -> None:
    assert list(OPTIONS) == [f.name for f in fields(CalibrationOptions)]
    assert set(DEFAULTS) == set(OPTIONS)
    flags = [o.flag for o in OPTIONS.values()]
    assert len(set(flags)) == len(flags)
    assert CalibrationOptions() == CalibrationOptions(**DEFAULTS)


@pytest.mark.parametrize("command", ["calibrate", "view", "report", "fleet"])
def test_every_option_reaches_each_command_line_with_its_choices(command: str) -> None:
    parser = _subparsers(build_parser())[command]
    by_dest = {a.dest: a for a in parser._actions}
    for name, option in OPTIONS.items():
        if option.api_only:
            assert name not in by_dest, name
            continue
        action = by_dest[name]
        assert option.flag in action.option_strings, name
        assert action.default is None, name  # not given: the job file's value or the dataclass's default stands
        assert (list(option.choices) if option.choices else None) == action.choices, name
        assert action.help == option.help, name


@pytest.mark.parametrize("command", ["calibrate", "view", "report", "fleet"])
def test_a_value_given_on_the_command_line_becomes_the_keyword(command: str) -> None:
    from pincal.cli.arguments import given_options

    positional = {"calibrate": ["delta", "d.csv"], "view": ["delta", "d.csv", "--out", "x.html"],
                  "report": ["delta", "d.csv", "--out", "x.html"], "fleet": ["delta", "dir", "--out", "o"]}[command]
    argv = [command, *positional]
    for name, (words, _) in OTHER.items():
        argv += [OPTIONS[name].flag, *words]
    given = given_options(build_parser().parse_args(argv))
    assert set(given) == set(OTHER)
    made = options_given(given, "command line")  # together: a seed goes with its plan
    for name, (_, value) in OTHER.items():
        if value is not None:
            assert getattr(made, name) == value, name
    assert given["payload"].as_dict() == {"mass": 1.5, "frame": "tool0", "offset": [0.0, 0.0, 0.1]}


def test_the_job_file_reads_every_option_it_has_a_key_for(tmp_path: Path) -> None:
    keyed = {name: o.key for name, o in OPTIONS.items() if o.key is not None}
    assert set(keyed.values()) <= set(JOB_KEYS)
    values = {"parameters": '["model24"]', "solver": '"tsvd"', "loss": '"cauchy"', "sigma": "2e-5",
              "formulation": '"ikm"', "max_iter": "7", "select": '"none"', "cv": '"5x2"', "cv_seed": "3",
              "payload": '{ mass = 1.5, frame = "tool0", offset = [0, 0, 0.1] }', "plausible": "2.5",
              "prior": '"off"'}
    assert set(values) == set(keyed.values())
    job = write_job(tmp_path, top="\n".join(f"{k} = {v}" for k, v in values.items()))
    options = read_job(job).options
    assert {given.name for given in options.given} == set(keyed)
    assert {options.source(name) for name in keyed} == {job}
    made = options.calibration
    for name in keyed:
        expected = OTHER[name][1]
        if expected is not None:
            assert getattr(made, name) == expected, name


def test_a_bad_keyword_is_refused_by_name() -> None:
    with pytest.raises(NotFoundError, match="option 'solvr'"):
        CalibrationOptions().replace(solvr="lm")
    with pytest.raises(DataError, match="unknown solver 'gn'; solvers are: lm, tsvd"):
        CalibrationOptions(solver="gn")  # type: ignore[arg-type]
    with pytest.raises(DataError, match="max_iter is 0"):
        CalibrationOptions(max_iter=0)
    with pytest.raises(DataError, match="sigma=-1e-05"):
        CalibrationOptions(sigma=-1e-5)
    with pytest.raises(DataError, match="force='yes': give True or False"):
        CalibrationOptions(force="yes")  # type: ignore[arg-type]


@pytest.mark.parametrize(("keywords", "option"), [({"solver": "gn"}, "solver"), ({"max_iter": 0}, "max_iter"),
                                                 ({"sigma": -1e-5}, "sigma"), ({"prior": -2.0}, "prior"),
                                                 ({"plausible": 0}, "plausible"), ({"cv_seed": -1}, "cv_seed"),
                                                 ({"force": "yes"}, "force"), ({"cv": "fivefold"}, "cv")])
def test_a_bad_value_names_its_option_as_a_field(keywords: dict[str, object], option: str) -> None:
    with pytest.raises(DataError) as raised:
        CalibrationOptions(**keywords)  # type: ignore[arg-type]
    assert (raised.value.option, raised.value.file, raised.value.column) == (option, None, None)


def test_a_seed_that_seeds_nothing_names_the_seed_and_the_job_file() -> None:
    from pincal.calibration.options import check_cv_seed, check_select_cv

    with pytest.raises(DataError) as raised:
        check_cv_seed(None, 5, Path("job.toml"), Path("job.toml"))
    assert (raised.value.option, raised.value.file) == ("cv_seed", "job.toml")
    with pytest.raises(DataError) as raised:
        check_cv_seed("loo", 5, "command line", "command line")
    assert (raised.value.option, raised.value.file) == ("cv_seed", None)
    with pytest.raises(DataError) as raised:
        check_select_cv("cv", "loo", Path("job.toml"), Path("job.toml"))
    assert (raised.value.option, raised.value.file) == ("cv", "job.toml")


def test_view_and_report_fit_with_every_option_the_command_line_gives(tmp_path: Path) -> None:
    """report without --result calibrates with the options given (the formulation and the iteration limit included,
    which view and report once dropped): the same fit as calibrate's, figure for figure."""
    sim = tmp_path / "sim"
    assert run_pincal("simulate", "delta", "--samples", "30", "--test-samples", "10", "--seed", "2", "--quiet",
                      "--out", str(sim)).returncode == 0
    data = str(sim / "measurements.csv")
    options = ["--parameters", "model24", "--max-iter", "2", "--formulation", "ikm", "--select", "none"]
    result = tmp_path / "r.json"
    done = run_pincal("calibrate", "delta", data, *options, "--report", str(result))
    assert done.returncode == 1, done.stderr  # two iterations do not converge: exit 1, as the summary says
    page = tmp_path / "p.html"
    done = run_pincal("report", "delta", data, *options, "--out", str(page), "--quiet")
    assert done.returncode == 1, done.stderr
    recorded = json.loads(result.read_text(encoding="utf-8"))
    assert recorded["formulation"] == "ikm" and not recorded["converged"]
    assert f"{recorded['test_rms_after'] * 1e3:.4f} mm" in page.read_text(encoding="utf-8")
    assert pincal.CalibrationOptions is CalibrationOptions


def test_the_choices_are_the_registries() -> None:
    from pincal.calibration.options import OPTIONS, SELECT_CHOICES
    from pincal.identification.choices import LOSSES, MARKER_FITS, SOLVERS
    from pincal.identification.selection import SELECTIONS

    assert SELECT_CHOICES == ("auto", *SELECTIONS)
    assert OPTIONS["solver"].choices == SOLVERS and OPTIONS["loss"].choices == LOSSES
    assert OPTIONS["markers"].choices == MARKER_FITS == ("each", "cluster")


def test_a_seed_without_its_plan_is_refused_as_the_options_are_made_in_the_words_of_its_source() -> None:
    """The cross-validation checks run once, when the options are made: the library's words for keywords, the flags'
    for the command line, the file and its key for a job file."""
    with pytest.raises(DataError) as raised:
        CalibrationOptions(cv_seed=3)
    assert raised.value.option == "cv_seed" and str(raised.value).startswith("cv_seed=3 seeds")
    assert "--" not in str(raised.value)
    with pytest.raises(DataError, match=r"^--cv-seed 3 seeds the shuffles of --cv; give --cv too"):
        options_given({"cv_seed": 3}, "command line")
    with pytest.raises(DataError) as raised:
        options_given({"cv": "loo", "cv_seed": 2}, Path("job.toml"))
    assert str(raised.value).startswith("job.toml: cv_seed: 2 seeds the shuffles of K-fold plans; cv = \"loo\" has")
    assert (raised.value.option, raised.value.file) == ("cv_seed", "job.toml")
    with pytest.raises(DataError, match=r"^--select cv with --cv loo would repeat"):
        options_given({"select": "cv", "cv": "loo"}, "command line")
    assert options_given({"cv": "5x2", "cv_seed": 3}, "command line") == CalibrationOptions(cv="5x2", cv_seed=3)


def test_options_given_at_two_sources_are_checked_together_each_worded_where_given() -> None:
    """A job file's seed goes with the plan the command line gives; a seed that seeds nothing is blamed on the job
    file and a plan that has no shuffle on the flag, each as the user wrote it."""
    job = Path("job.toml")
    from_job = GivenOptions.of({"cv_seed": 3, "select": "bic"}, job)
    assert from_job.over(GivenOptions.of({"cv": "5x2"}, "command line")).calibration == CalibrationOptions(
        select="bic", cv="5x2", cv_seed=3)
    with pytest.raises(DataError) as raised:
        _ = from_job.calibration
    assert str(raised.value).startswith("job.toml: cv_seed: 3 seeds the shuffles of a K-fold cross-validation")
    with pytest.raises(DataError) as raised:
        _ = from_job.over(GivenOptions.of({"cv": "loo"}, "command line")).calibration
    assert str(raised.value).startswith("job.toml: cv_seed: 3 seeds the shuffles of K-fold plans; --cv loo has none")
    assert (raised.value.option, raised.value.file) == ("cv_seed", "job.toml")


def test_no_module_but_the_options_runs_the_cross_validation_checks() -> None:
    """The seed's and the selection's checks are called from one place, the options' own check."""
    root = Path(__file__).resolve().parents[2] / "pincal"
    checks = ("check_cv_seed(", "check_select_cv(")
    callers = sorted(str(p.relative_to(root)) for p in root.rglob("*.py")
                     if any(check in p.read_text(encoding="utf-8") for check in checks))
    assert callers == ["calibration/options.py"]
