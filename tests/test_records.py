"""``records.record`` answers as ``dataclasses.dataclass`` does; its repr, eq and hash are not compiled."""

from __future__ import annotations

import builtins
import dataclasses
import pickle
from dataclasses import dataclass, field
from typing import Any

import numpy as np
import pytest

from pincal.records import record


def _pair(frozen: bool, kw_only: bool = False) -> tuple[type, type]:
    """The same class made by ``dataclasses`` and by ``record``: fields shown or not, compared or not, hashed or not,
    with defaults and a default factory."""

    def body() -> dict[str, Any]:
        return {"__annotations__": {"name": "str", "value": "float", "hidden": "int", "uncompared": "int",
                                    "unhashed": "int", "items": "list[int]"},
                "value": 1.5, "hidden": field(default=3, repr=False), "uncompared": field(default=4, compare=False),
                "unhashed": field(default=5, hash=False), "items": field(default_factory=list, hash=False)}

    plain = dataclass(frozen=frozen, kw_only=kw_only)(type("Thing", (), body()))
    made = record(frozen=frozen, kw_only=kw_only)(type("Thing", (), body()))
    return plain, made


@pytest.mark.parametrize("frozen", [True, False])
def test_repr_eq_and_hash_answer_as_the_generated_ones(frozen: bool) -> None:
    plain, made = _pair(frozen)
    values = [("a", 2.0, 7, 8, 9), ("a", 2.0, 7, 9, 9), ("a", 2.0, 7, 8, 10), ("b", 2.0, 7, 8, 9), ("a", -0.0, 1, 2, 3)]
    for first in values:
        assert repr(made(*first)) == repr(plain(*first))
        for second in values:
            assert (made(*first) == made(*second)) == (plain(*first) == plain(*second))
            assert (made(*first) != made(*second)) == (plain(*first) != plain(*second))
        if frozen:
            assert hash(made(*first)) == hash(plain(*first))
    assert made("a") != plain("a") and made("a").__eq__(1) is NotImplemented
    assert (made.__hash__ is None) == (plain.__hash__ is None) == (not frozen)
    assert made.__repr__.__qualname__ == "Thing.__repr__"


def test_a_frozen_record_refuses_assignment_and_keeps_its_dataclass_contract() -> None:
    _, made = _pair(frozen=True, kw_only=True)
    thing = made(name="a", items=[1])
    with pytest.raises(dataclasses.FrozenInstanceError):
        thing.name = "b"  # type: ignore[misc]
    with pytest.raises(TypeError):
        made("a")  # keyword-only
    assert dataclasses.is_dataclass(made) and [f.name for f in dataclasses.fields(made)][:2] == ["name", "value"]
    assert dataclasses.replace(thing, value=2.0) == made(name="a", value=2.0, items=[1])
    assert dataclasses.asdict(thing)["items"] == [1]


@pytest.mark.parametrize("frozen", [True, False])
def test_a_class_keeps_the_methods_it_defines(frozen: bool) -> None:
    def loose(make: Any) -> Any:
        @make(frozen=frozen)
        class Loose:
            """Equal to anything of its kind, as its own ``__eq__`` says."""

            size: float

            def __eq__(self, other: object) -> bool:
                return isinstance(other, Loose)

            def __repr__(self) -> str:
                return "loose"

        return Loose

    plain, made = loose(dataclass), loose(record)
    assert made(1.0) == made(2.0) and repr(made(1.0)) == "loose"
    assert (made.__hash__ is None) == (plain.__hash__ is None)  # dataclasses' table: hashed when frozen
    if frozen:
        assert hash(made(1.0)) == hash(plain(1.0))


@record(frozen=True)
class Holder:
    """A name beside an array."""

    name: str
    data: np.ndarray = field(compare=False)


def test_a_record_with_arrays_pickles_and_compares_as_a_dataclass() -> None:
    held = Holder("x", np.arange(3.0))
    back = pickle.loads(pickle.dumps(held))
    assert back == held and np.array_equal(back.data, held.data)
    assert repr(back) == "Holder(name='x', data=array([0., 1., 2.]))"


def test_a_record_that_holds_itself_shows_dots() -> None:
    @record
    class Node:
        """A node of a list that may loop."""

        next: Any = None

    node = Node()
    node.next = node
    assert repr(node) == f"{Node.__qualname__}(next=...)"


def test_record_compiles_only_what_dataclasses_needs(monkeypatch: pytest.MonkeyPatch) -> None:
    """``__init__`` (and a frozen class's ``__setattr__``, ``__delattr__``): three compilations, not six."""
    compiled: list[str] = []
    real = builtins.exec

    def counting(source: Any, *args: Any) -> None:
        compiled.append(str(source))
        real(source, *args)

    monkeypatch.setattr(builtins, "exec", counting)
    _pair(frozen=True)
    assert len(compiled) == 3 + 6  # the record's three, the dataclass's six


def test_an_explicit_hash_none_beside_an_inherited_eq_stays_unhashable() -> None:
    """A frozen class that says ``__hash__ = None`` without its own ``__eq__`` is unhashable, as under dataclasses."""
    @dataclasses.dataclass(frozen=True)
    class Plain:
        a: int
        __hash__ = None  # type: ignore[assignment]

    @record(frozen=True)
    class Record:
        a: int
        __hash__ = None  # type: ignore[assignment]

    for cls in (Plain, Record):
        with pytest.raises(TypeError, match="unhashable"):
            hash(cls(1))
