"""``record``: a dataclass whose methods are shared functions or made when first needed, not compiled per class at
import.

``dataclasses.dataclass`` writes each method it generates as Python source and compiles it with ``exec`` when the
class is defined: six compilations for a frozen class (``__init__``, ``__repr__``, ``__eq__``, ``__setattr__``,
``__delattr__``, ``__hash__``), most of the time pincal's own modules take to import (a calibration command defines
some 120 of them, and creates instances of fewer than half). :func:`record` lets ``dataclasses`` read the fields
(``dataclasses.fields``, ``replace``, ``asdict`` and ``is_dataclass`` read a record as a dataclass) and compiles
nothing then: a frozen class's ``__setattr__`` and ``__delattr__`` and every class's ``__repr__``, ``__eq__`` and
``__hash__`` are built from its fields' names without compiling, and ``__init__``, written as ``dataclasses`` writes it
and compiled once, is made when the class is first instantiated or its ``__init__`` first read (``inspect.signature``
and ``help`` see it, and a class without a docstring gets the one ``dataclasses`` would give it).
They answer as the generated ones do (the same text, the same comparisons of the same field tuples, the
same hashes, the same errors on assignment to a frozen record), and a class that defines one of them keeps its own, as
under ``dataclasses``. ``__eq__`` compares the field tuples, as ``dataclasses`` does up to Python 3.12 (from 3.13 it
compares field by field, so that one NaN or one array held by both no longer counts as equal to itself; a record keeps
the tuple's identity shortcut on every version). A frozen record is frozen by :func:`record`, not by ``dataclasses``;
its ``__dataclass_params__`` say what ``dataclasses`` would have made, and frozen and unfrozen classes mix in one
hierarchy, records or dataclasses, as little as under ``dataclasses``.
"""

from __future__ import annotations

import dataclasses
import reprlib
import sys
import threading
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


def _frozen_methods(cls: type) -> None:
    """Give ``cls`` the ``__setattr__`` and ``__delattr__`` of ``dataclasses.dataclass(frozen=True)``: assigning or
    deleting any attribute of an instance of ``cls`` itself, or a field of a subclass's, raises
    ``FrozenInstanceError``; as there, a class that defines either of them itself is refused."""
    names = frozenset(f.name for f in dataclasses.fields(cls))
    owner: Any = cls  # the class whose base's method a subclass's non-field attribute goes to

    def __setattr__(self: Any, name: str, value: Any) -> None:
        if type(self) is cls or name in names:
            raise dataclasses.FrozenInstanceError(f"cannot assign to field {name!r}")
        super(owner, self).__setattr__(name, value)

    def __delattr__(self: Any, name: str) -> None:
        if type(self) is cls or name in names:
            raise dataclasses.FrozenInstanceError(f"cannot delete field {name!r}")
        super(owner, self).__delattr__(name)

    for method in (__setattr__, __delattr__):
        if method.__name__ in cls.__dict__:
            raise TypeError(f"Cannot overwrite attribute {method.__name__} in class {cls.__name__}")
        _install(cls, method)


#: What ``dataclasses`` names in the ``__init__`` it writes: the default of a field with a default factory (shown
#: ``<factory>`` in the signature), and the kind of an ``InitVar`` pseudo-field; None where a version lacks them.
_FACTORY = getattr(dataclasses, "_HAS_DEFAULT_FACTORY", None)
_INITVAR = getattr(dataclasses, "_FIELD_INITVAR", None)


def _generated_init(cls: type, frozen: bool) -> Callable[..., None]:
    """The ``__init__`` ``dataclasses.dataclass(frozen=frozen)`` generates for ``cls`` (a record), written as it
    writes it (the same parameters, annotations, defaults and factories, keyword-only fields after ``*``, the fields
    assigned in order, through ``object.__setattr__`` when frozen, then ``__post_init__``) and compiled once; a class
    with ``InitVar`` pseudo-fields gets its ``__init__`` from ``dataclasses`` itself (:func:`_twin_init`)."""
    if _FACTORY is None or _INITVAR is None \
            or any(f._field_type is _INITVAR for f in cls.__dataclass_fields__.values()):  # type: ignore[attr-defined]
        return _twin_init(cls, frozen)
    fields = dataclasses.fields(cls)
    me = "__dataclass_self__" if any(f.name == "self" for f in fields) else "self"
    names: dict[str, Any] = {"__dataclass_builtins_object__": object, "__dataclass_HAS_DEFAULT_FACTORY__": _FACTORY,
                             "__dataclass_return_type__": None}
    positional: list[str] = []
    keywords: list[str] = []
    body: list[str] = []
    for f in fields:
        names[f"__dataclass_type_{f.name}__"] = f.type
        default, value = "", f.name
        if f.default_factory is not dataclasses.MISSING:
            names[f"__dataclass_dflt_{f.name}__"] = f.default_factory
            default = "=__dataclass_HAS_DEFAULT_FACTORY__"
            value = (f"__dataclass_dflt_{f.name}__() if {f.name} is __dataclass_HAS_DEFAULT_FACTORY__ else {f.name}"
                     if f.init else f"__dataclass_dflt_{f.name}__()")
        elif f.default is not dataclasses.MISSING:
            names[f"__dataclass_dflt_{f.name}__"] = f.default
            default = f"=__dataclass_dflt_{f.name}__"
        if f.init:
            (keywords if f.kw_only else positional).append(f"{f.name}:__dataclass_type_{f.name}__{default}")
        elif f.default_factory is dataclasses.MISSING:
            continue  # the class attribute holds its default (or __post_init__ sets it)
        body.append(f"__dataclass_builtins_object__.__setattr__({me},{f.name!r},{value})" if frozen
                    else f"{me}.{f.name}={value}")
    if hasattr(cls, "__post_init__"):
        body.append(f"{me}.__post_init__()")
    parameters = ",".join([me, *positional, *(["*", *keywords] if keywords else [])])
    lines = "\n".join(f"  {line}" for line in body or ["pass"])
    source = (f"def __create_fn__({', '.join(names)}):\n def __init__({parameters})->__dataclass_return_type__:\n"
              f"{lines}\n return __init__")
    module = sys.modules.get(cls.__module__)
    scope: dict[str, Any] = {}
    code = compile(source, "<string>", "exec", dont_inherit=True)  # not this module's postponed annotations
    exec(code, module.__dict__ if module is not None else {}, scope)  # dataclasses' own way
    init: Callable[..., None] = scope["__create_fn__"](**names)
    init.__qualname__ = f"{cls.__qualname__}.__init__"
    return init


def _twin_init(cls: type, frozen: bool) -> Callable[..., None]:
    """The ``__init__`` ``dataclasses`` generates for ``cls``, made by ``dataclasses`` on a class of the same fields
    (names, types, defaults and factories, ``init`` and ``kw_only`` flags) and ``__post_init__``, then named as
    ``cls``'s."""
    namespace: dict[str, Any] = {"__module__": cls.__module__, "__qualname__": cls.__qualname__,
                                 "__annotations__": {}, "__doc__": "a twin"}  # no docstring made from a signature
    for f in cls.__dataclass_fields__.values():  # type: ignore[attr-defined]
        if f._field_type is dataclasses._FIELD_CLASSVAR:  # type: ignore[attr-defined]
            continue
        namespace["__annotations__"][f.name] = f.type
        namespace[f.name] = dataclasses.field(default=f.default, default_factory=f.default_factory, init=f.init,
                                              kw_only=f.kw_only)
    if hasattr(cls, "__post_init__"):
        namespace["__post_init__"] = cls.__post_init__
    twin: type = dataclasses.dataclass(type(cls.__name__, (), namespace), repr=False, eq=False, frozen=frozen,
                                       match_args=False)
    init: Callable[..., None] = twin.__dict__["__init__"]
    init.__qualname__ = f"{cls.__qualname__}.__init__"
    return init


class _LazyInit:
    """A record's ``__init__`` until it is first needed: then :func:`_generated_init` made and put in its place."""

    __slots__ = ("cls", "frozen")

    def __init__(self, cls: type, frozen: bool) -> None:
        self.cls, self.frozen = cls, frozen

    def __get__(self, instance: Any, owner: type | None = None) -> Any:
        init = _generated_init(self.cls, self.frozen)
        type.__setattr__(self.cls, "__init__", init)
        return init if instance is None else init.__get__(instance, owner)


#: Set while :func:`record` has ``dataclasses`` read a class: its record bases then answer "not frozen" (it judges the
#: hierarchy itself, :func:`_hierarchy_frozen`, and makes a frozen record frozen without ``dataclasses``).
_DEFINING = threading.local()


class _Params:
    """A record's ``__dataclass_params__``: what ``dataclasses.dataclass(repr=True, eq=True, frozen=frozen)`` would
    have recorded (``init``, ``repr`` and ``eq`` True, ``frozen`` as the record is, the rest from ``dataclasses``), so
    that a frozen dataclass may derive from a frozen record and an unfrozen one may not, as under ``dataclasses``."""

    __slots__ = ("_frozen", "_params")
    init = repr = eq = True

    def __init__(self, params: Any, frozen: bool) -> None:
        self._params, self._frozen = params, frozen

    @property
    def frozen(self) -> bool:
        """Whether the record is frozen (False while :func:`record` defines a class derived from it)."""
        return self._frozen and not getattr(_DEFINING, "active", False)

    def __getattr__(self, name: str) -> Any:
        return getattr(self._params, name)


def _hierarchy_frozen(cls: type) -> bool | None:
    """Whether the dataclasses ``cls`` derives from are frozen, as ``dataclasses`` judges it (any of them frozen), or
    None without any."""
    frozen = None
    for base in cls.__mro__[-1:0:-1]:
        params = base.__dict__.get("__dataclass_params__")
        if params is not None:
            frozen = bool(frozen) or bool(params.frozen)
    return frozen


def _check_defaults(cls: type) -> None:
    """Refuse, as ``dataclasses`` does when it writes ``__init__``, a field without a default after one with a default
    among the positional fields of ``__init__``."""
    seen = False
    for f in dataclasses.fields(cls):
        if not f.init or f.kw_only:
            continue
        if f.default is not dataclasses.MISSING or f.default_factory is not dataclasses.MISSING:
            seen = True
        elif seen:
            raise TypeError(f"non-default argument {f.name!r} follows default argument")


@overload
def record(cls: T, /) -> T: ...
@overload
def record(*, frozen: bool = False, kw_only: bool = False) -> Callable[[T], T]: ...


@dataclass_transform(field_specifiers=(dataclasses.field, dataclasses.Field))
def record(cls: T | None = None, /, *, frozen: bool = False, kw_only: bool = False) -> T | Callable[[T], T]:
    """``dataclasses.dataclass(cls, frozen=frozen, kw_only=kw_only)`` with its methods made without compiling, its
    ``__init__`` when first needed (the module's docstring); used as ``@record`` or ``@record(frozen=True)``."""

    def wrap(c: T) -> T:
        based = _hierarchy_frozen(c)
        if based is not None and based != frozen:
            raise TypeError("cannot inherit non-frozen dataclass from a frozen one" if based
                            else "cannot inherit frozen dataclass from a non-frozen one")
        if "__init__" not in c.__dict__:  # before dataclasses reads the class: a class without a docstring gets one
            c.__init__ = _LazyInit(c, frozen)  # type: ignore[misc]  # from the generated __init__'s signature
        outer, _DEFINING.active = getattr(_DEFINING, "active", False), True
        try:
            made: T = dataclasses.dataclass(c, init=False, repr=False, eq=False, kw_only=kw_only)  # type: ignore[assignment]
        finally:
            _DEFINING.active = outer
        made.__dataclass_params__ = _Params(made.__dataclass_params__, frozen)  # type: ignore[attr-defined]
        _check_defaults(made)
        if frozen:
            _frozen_methods(made)
        _methods(made, frozen)
        return made

    return wrap if cls is None else wrap(cls)
