"""The culprit an error carries as fields (option, column, sample, file, line), beside its message."""

from __future__ import annotations

import pickle

import pytest

from pincal.errors import ArgumentError, Culprit, DataError, NotFoundError, PincalError, PluginError, not_found

FIELDS = ("option", "column", "sample", "file", "line")


@pytest.mark.parametrize("kind", [PincalError, DataError, ArgumentError, PluginError])
def test_an_error_names_no_culprit_unless_told(kind: type[PincalError]) -> None:
    error = kind("the message")
    assert str(error) == "the message"
    assert [getattr(error, name) for name in FIELDS] == [None] * 5


def test_the_fields_are_keywords_and_leave_the_message_alone() -> None:
    error = DataError("data.csv: line 4: column 'q2': 'x' is not a number", file="data.csv", line=4, column="q2",
                      sample=2)
    assert str(error) == "data.csv: line 4: column 'q2': 'x' is not a number"
    assert (error.file, error.line, error.column, error.sample, error.option) == ("data.csv", 4, "q2", 2, None)
    with pytest.raises(TypeError):
        DataError("message", "data.csv")  # type: ignore[call-arg]


def test_a_lookup_keeps_its_choices_and_takes_the_fields() -> None:
    error = NotFoundError("frame 'tool' does not exist", "frame", "tool", ["tool0"], file="job.toml", option="frame")
    assert (error.kind, error.name, error.choices) == ("frame", "tool", ["tool0"])
    assert (error.file, error.option, error.line) == ("job.toml", "frame", None)
    assert not_found("joint", "j9", ["j1"]).file is None


def test_the_fields_survive_a_process_pool() -> None:
    """Errors cross process boundaries (the Monte Carlo pool, fleet's workers): pickling keeps the fields."""
    error = pickle.loads(pickle.dumps(DataError("bad", file="a.csv", line=3, column=2, sample="s1", option="sigma")))
    assert (str(error), error.file, error.line, error.column, error.sample, error.option) == \
        ("bad", "a.csv", 3, 2, "s1", "sigma")
    found = pickle.loads(pickle.dumps(NotFoundError("gone", "robot", "ur11", ["ur10"], file="job.toml")))
    assert (found.kind, found.name, found.choices, found.file) == ("robot", "ur11", ["ur10"], "job.toml")


def test_a_culprit_block_fills_the_fields_an_error_leaves_empty() -> None:
    with pytest.raises(DataError) as caught, Culprit(file="run.csv", line=7):
        raise DataError("line 3: no number", line=3)
    assert (str(caught.value), caught.value.file, caught.value.line) == ("line 3: no number", "run.csv", 3)


def test_a_culprit_block_leaves_other_errors_alone() -> None:
    with pytest.raises(ValueError, match=r"^plain$") as caught, Culprit(file="run.csv"):
        raise ValueError("plain")
    assert not hasattr(caught.value, "file")
    with Culprit(file="run.csv"):
        pass  # nothing raised, nothing to fill
