"""``record``: a dataclass whose ``__repr__``, ``__eq__`` and ``__hash__`` are shared functions, not compiled per class.

``dataclasses.dataclass`` writes each method it generates as Python source and compiles it with ``exec`` when the
class is defined: six compilations for a frozen class (``__init__``, ``__repr__``, ``__eq__``, ``__setattr__``,
``__delattr__``, ``__hash__``), about half of the time pincal's own modules take to import (a calibration command
defines some 120 of them). :func:`record` lets ``dataclasses`` make ``__init__`` and a frozen class's
``__setattr__`` and ``__delattr__``, and gives the class ``__repr__``, ``__eq__`` and ``__hash__`` built from its
fields' names without compiling anything; they return what the generated ones return (the same text, the same
comparisons of the same field tuples, the same hashes), and a class that defines one of them keeps its own, as
under ``dataclasses``. ``dataclasses.fields``, ``replace``, ``asdict`` and ``is_dataclass`` read a record as a
dataclass. ``__eq__`` compares the field tuples, as ``dataclasses`` does up to Python 3.12 (from 3.13 it compares field
by field, so that one NaN or one array held by both no longer counts as equal to itself; a record keeps the tuple's
identity shortcut on every version).
"""

from __future__ import annotations

import dataclasses
import reprlib
from collections.abc import Callable
from operator import attrgetter
from typing import Any, TypeVar, dataclass_transform, overload

T = TypeVar("T", bound=type)


def _getter(names: tuple[str, ...]) -> Callable[[Any], tuple[Any, ...]]:
    """The named attributes of an object, always as a tuple (``attrgetter`` of one name returns the value)."""
    if len(names) == 1:
        one = attrgetter(names[0])
        return lambda obj: (one(obj),)
    if not names:
        return lambda obj: ()
    return attrgetter(*names)  # a tuple for two names or more


def _methods(cls: type, frozen: bool) -> None:
    """Give ``cls`` (already a dataclass made with ``repr=False, eq=False``) the ``__repr__``, ``__eq__`` and
    ``__hash__`` that ``dataclasses.dataclass(repr=True, eq=True, frozen=frozen)`` would have generated."""
    fields = dataclasses.fields(cls)
    shown = tuple(f.name for f in fields if f.repr)
    compared = _getter(tuple(f.name for f in fields if f.compare))
    hashed = _getter(tuple(f.name for f in fields if (f.compare if f.hash is None else f.hash)))
    own_eq = "__eq__" in cls.__dict__  # read before any method is installed: the table below asks of the class's own
    own_hash = cls.__dict__.get("__hash__", dataclasses.MISSING)
    if "__repr__" not in cls.__dict__:
        @reprlib.recursive_repr(fillvalue="...")
        def __repr__(self: Any) -> str:
            text: str = self.__class__.__qualname__
            return text + "(" + ", ".join(f"{name}={getattr(self, name)!r}" for name in shown) + ")"

        _install(cls, __repr__)
    if not own_eq:
        def __eq__(self: Any, other: object) -> bool:
            if other.__class__ is self.__class__:
                return compared(self) == compared(other)
            return NotImplemented

        _install(cls, __eq__)
    # dataclasses' table for eq=True without unsafe_hash: a hash of the compared fields when frozen, none otherwise,
    # unless the class defines its own (a ``__hash__ = None`` beside its own ``__eq__`` is no definition).
    if own_hash is dataclasses.MISSING or (own_hash is None and own_eq):
        if frozen:
            def __hash__(self: Any) -> int:
                return hash(hashed(self))

            _install(cls, __hash__)
        else:
            cls.__hash__ = None  # type: ignore[assignment]


def _install(cls: type, method: Callable[..., Any]) -> None:
    method.__qualname__ = f"{cls.__qualname__}.{method.__name__}"
    setattr(cls, method.__name__, method)


@overload
def record(cls: T, /) -> T: ...
@overload
def record(*, frozen: bool = False, kw_only: bool = False) -> Callable[[T], T]: ...


@dataclass_transform(field_specifiers=(dataclasses.field, dataclasses.Field))
def record(cls: T | None = None, /, *, frozen: bool = False, kw_only: bool = False) -> T | Callable[[T], T]:
    """``dataclasses.dataclass(cls, frozen=frozen, kw_only=kw_only)`` with its ``__repr__``, ``__eq__`` and
    ``__hash__`` made without compiling (the module's docstring); used as ``@record`` or ``@record(frozen=True)``."""

    def wrap(c: T) -> T:
        made: T = dataclasses.dataclass(c, repr=False, eq=False, frozen=frozen, kw_only=kw_only)  # type: ignore[assignment]
        _methods(made, frozen)
        return made

    return wrap if cls is None else wrap(cls)
