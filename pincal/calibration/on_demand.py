"""Dataclass fields computed when first read: a calibration's extras that a caller may never read.

A field named in :func:`on_demand` may be given a :class:`Pending` (a computation not yet run) instead of its value;
its first read runs it and keeps the value, and every later read, ``==``, ``repr``, ``dataclasses.replace``, a
pickle or a copy sees that value, as if it had been given. A :class:`Pending` computes once, so two fields may share
one (the bound's growth, and the workspace prediction that reads it). What is computed must not depend on when: the
computation reads nothing a later call changes (:func:`~pincal.calibration.pipeline.calibrate` runs the work of a
closed-loop robot's problem, whose evaluations follow its warm starts, at once).
"""

from __future__ import annotations

from collections.abc import Callable
from typing import Any, Generic, TypeVar

T = TypeVar("T")
C = TypeVar("C", bound=type)


class Pending(Generic[T]):
    """A value computed by ``compute()`` when first asked for (:meth:`value`), then kept."""

    __slots__ = ("_compute", "_value")

    def __init__(self, compute: Callable[[], T]) -> None:
        self._compute: Callable[[], T] | None = compute
        self._value: T | None = None

    @property
    def computed(self) -> bool:
        """Whether :meth:`value` has run."""
        return self._compute is None

    def value(self) -> T:
        """The value, computed at the first call."""
        if self._compute is not None:
            self._value, self._compute = self._compute(), None
        return self._value  # type: ignore[return-value]  # computed above: T itself, None included


class _Field:
    """The data descriptor of one field of :func:`on_demand`: stores in the instance's ``__dict__`` (a frozen
    dataclass's ``__init__`` sets the field through it), resolves a :class:`Pending` when read."""

    def __init__(self, name: str, default: Any) -> None:
        self.name, self.default = name, default

    def __get__(self, instance: Any, owner: type | None = None) -> Any:
        if instance is None:
            return self.default  # the class attribute a dataclass field has: its default
        value = instance.__dict__[self.name]
        if isinstance(value, Pending):
            value = value.value()
            instance.__dict__[self.name] = value
        return value

    def __set__(self, instance: Any, value: Any) -> None:
        instance.__dict__[self.name] = value


def _resolved_state(self: Any) -> dict[str, Any]:
    """The instance's ``__dict__`` with every pending field computed (what pickle and copy take)."""
    for name in type(self).__on_demand__:
        getattr(self, name)
    return dict(self.__dict__)


def on_demand(*names: str) -> Callable[[C], C]:
    """A class decorator, above ``@dataclass``: the fields ``names`` may be given a :class:`Pending`, computed when
    first read."""

    def decorate(cls: C) -> C:
        for name in names:
            setattr(cls, name, _Field(name, cls.__dict__.get(name)))
        cls.__on_demand__ = names  # type: ignore[attr-defined]
        setattr(cls, "__getstate__", _resolved_state)  # noqa: B010  # pickle and copy take the values
        return cls

    return decorate


def defer(instance: Any, name: str, compute: Callable[[], Any] | Pending[Any]) -> None:
    """Give the on-demand field ``name`` of ``instance`` the value ``compute()`` (or a :class:`Pending`'s) when
    first read.

    Raises:
        TypeError: ``name`` is not one of its class's on-demand fields.
    """
    if name not in getattr(type(instance), "__on_demand__", ()):
        raise TypeError(f"{type(instance).__name__}.{name} is not a field computed on demand")
    instance.__dict__[name] = compute if isinstance(compute, Pending) else Pending(compute)


def pending_fields(instance: Any) -> list[str]:
    """The on-demand fields of ``instance`` whose value is not computed yet."""
    return [name for name in getattr(type(instance), "__on_demand__", ())
            if isinstance(instance.__dict__.get(name), Pending) and not instance.__dict__[name].computed]
