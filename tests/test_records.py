"""``records.record`` answers as ``dataclasses.dataclass`` does; nothing is compiled when a record is defined."""

from __future__ import annotations

import builtins
import dataclasses
import inspect
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
    assert made.__doc__ == plain.__doc__  # an undocumented class's, from the generated __init__'s signature


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


def test_record_compiles_nothing_until_an_instance_is_made(monkeypatch: pytest.MonkeyPatch) -> None:
    """A documented class: no source compiled when it is defined; one, its ``__init__``, when the first instance is
    made, and none for the next."""
    compiled: list[str] = []
    real_exec, real_compile = builtins.exec, builtins.compile

    def executing(source: Any, *args: Any) -> None:
        if isinstance(source, str):
            compiled.append(source)
        real_exec(source, *args)

    def compiling(source: Any, *args: Any, **kwargs: Any) -> Any:
        compiled.append(str(source))
        return real_compile(source, *args, **kwargs)

    monkeypatch.setattr(builtins, "exec", executing)
    monkeypatch.setattr(builtins, "compile", compiling)

    @record(frozen=True)
    class Point:
        """A point with a name."""

        x: float
        name: str = "p"

    assert compiled == []
    first = Point(1.0)
    assert len(compiled) == 1 and "def __init__" in compiled[0]
    assert Point(2.0, "q") != first and len(compiled) == 1
    with pytest.raises(dataclasses.FrozenInstanceError, match="cannot assign to field 'x'"):
        first.x = 3.0  # type: ignore[misc]


@pytest.mark.parametrize("frozen", [True, False])
@pytest.mark.parametrize("kw_only", [True, False])
def test_the_init_made_on_first_use_is_the_generated_one(frozen: bool, kw_only: bool) -> None:
    """Its signature before any instance (what ``inspect`` and ``help`` read), its defaults and factories, an
    ``init=False`` field, ``__post_init__`` and a subclass's fields in order, as under ``dataclasses``."""
    def pair() -> tuple[type, type]:
        def body() -> dict[str, Any]:
            def __post_init__(self: Any) -> None:
                object.__setattr__(self, "total", self.a + len(self.items))

            return {"__annotations__": {"a": "int", "items": "list[int]", "total": "int"}, "a": 1,
                    "items": field(default_factory=lambda: [1, 2]), "total": field(default=0, init=False),
                    "__post_init__": __post_init__, "__doc__": "A documented class."}

        plain = dataclass(frozen=frozen, kw_only=kw_only)(type("Base", (), body()))
        made = record(frozen=frozen, kw_only=kw_only)(type("Base", (), body()))
        return plain, made

    plain, made = pair()
    assert str(inspect.signature(made)) == str(inspect.signature(plain))
    assert made.__init__.__qualname__ == "Base.__init__"
    plain_child = dataclass(frozen=frozen)(type("Child", (plain,), {"__annotations__": {"b": "str"}, "b": "x"}))
    made_child = record(frozen=frozen)(type("Child", (made,), {"__annotations__": {"b": "str"}, "b": "x"}))
    assert str(inspect.signature(made_child)) == str(inspect.signature(plain_child))
    for cls in (made, made_child):
        one, two = cls(a=3), cls(a=3)
        assert one.items == [1, 2] and one.items is not two.items and one.total == 5
    assert repr(made_child(a=2, b="y")) == repr(plain_child(a=2, b="y"))


def test_frozen_and_unfrozen_records_do_not_mix_as_under_dataclasses() -> None:
    @record(frozen=True)
    class Frozen:
        """Frozen."""

        a: int = 0

    @record
    class Loose:
        """Not frozen."""

        a: int = 0

    with pytest.raises(TypeError, match="cannot inherit non-frozen dataclass from a frozen one"):
        record(type("Child", (Frozen,), {"__doc__": "A child."}))
    with pytest.raises(TypeError, match="cannot inherit frozen dataclass from a non-frozen one"):
        record(frozen=True)(type("Child", (Loose,), {"__doc__": "A child."}))
    with pytest.raises(TypeError, match="non-default argument 'b' follows default argument"):
        record(type("Late", (), {"__doc__": "Late.", "__annotations__": {"a": "int", "b": "int"}, "a": 0}))
    with pytest.raises(TypeError, match="Cannot overwrite attribute __setattr__"):
        record(frozen=True)(type("Own", (), {"__doc__": "Its own.", "__setattr__": object.__setattr__}))
    thing = Frozen()
    with pytest.raises(dataclasses.FrozenInstanceError, match="cannot delete field 'a'"):
        del thing.a
    # a dataclass derived from a record (a measurement kind of a plugin) is judged as if the record were a dataclass
    plain = dataclass(frozen=True)(type("Plain", (Frozen,), {"__annotations__": {"b": "int"}, "b": 1}))
    assert plain(2, 3).a == 2 and dataclasses.fields(plain)[1].name == "b"
    assert plain.__dataclass_params__.frozen and not Loose.__dataclass_params__.frozen
    with pytest.raises(TypeError, match="cannot inherit non-frozen dataclass from a frozen one"):
        dataclass(type("Unfrozen", (Frozen,), {}))
    with pytest.raises(TypeError, match="cannot inherit frozen dataclass from a non-frozen one"):
        dataclass(frozen=True)(type("Refrozen", (Loose,), {}))


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


def test_every_record_a_calibration_loads_gets_the_init_dataclasses_writes() -> None:
    """Each record of the modules a calibration loads: its ``__init__`` (signature: names, kinds, annotations,
    defaults) is the one ``dataclasses`` makes for the same fields, and a frozen record's assigns without its
    ``__setattr__``."""
    import importlib
    import sys

    from pincal.records import _Params, _twin_init

    for name in ("pincal.calibration.from_files", "pincal.calibration.pipeline", "pincal.calibration.summary",
                 "pincal.calibration.crossval", "pincal.cli.app"):
        importlib.import_module(name)
    records = {value for module in list(sys.modules.values()) if module and module.__name__.startswith("pincal")
               for value in vars(module).values()
               if isinstance(value, type) and isinstance(value.__dict__.get("__dataclass_params__"), _Params)}
    assert len(records) > 100
    for cls in records:
        frozen = cls.__dataclass_params__.frozen
        ours, theirs = inspect.signature(cls.__init__), inspect.signature(_twin_init(cls, frozen))
        assert ours.return_annotation == theirs.return_annotation, cls
        assert [(p.name, p.kind, p.annotation) for p in ours.parameters.values()] == \
            [(p.name, p.kind, p.annotation) for p in theirs.parameters.values()], cls
        assert all(a.default is b.default for a, b in zip(ours.parameters.values(), theirs.parameters.values(),
                                                          strict=True)), cls  # the same objects (a NaN included)
        assert cls.__init__.__qualname__ == f"{cls.__qualname__}.__init__"
