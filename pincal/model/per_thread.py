"""Values made on first use, one per thread: the scratch a robot's methods write as they work.

Pinocchio's ``Data``, a loop's constraint data, the batched evaluation's arrays and the last Newton pass are
overwritten by every call that uses them. Kept one per thread (:class:`per_thread`), they let one
:class:`~pincal.model.robot.Robot` serve several threads at once (a thread pool calibrating on it, a Monte Carlo study
on threads sharing its cached robot): each thread works in its own, and within a thread a call finds what the previous
one left, as before. Each thread that has used a robot holds its own copy while both live (Pinocchio's ``Data`` grows
as nv³).
"""

from __future__ import annotations

import threading
from collections.abc import Callable
from typing import Any, Generic, TypeVar, overload

T = TypeVar("T")

#: The instance attribute that holds an object's per-thread values.
VALUES = "_per_thread"


class _Values(threading.local):
    """One object's per-thread values: each thread sees its own attributes. A copy or a pickle starts empty (the
    values are scratch, made again on first use), so an object holding them copies and pickles as before."""

    def __reduce__(self) -> tuple[type[_Values], tuple[()]]:
        return (_Values, ())


class per_thread(Generic[T]):  # a decorator, named as functools.cached_property is
    """A property made on first use in each thread and kept for that thread (``functools.cached_property``, one value
    per thread). A thread's values go when the thread ends.

    Args:
        make: Makes the value from the instance (the decorated method).
    """

    def __init__(self, make: Callable[[Any], T]) -> None:
        self.make = make
        self.name = make.__name__
        self.__doc__ = make.__doc__

    def __set_name__(self, owner: type, name: str) -> None:
        self.name = name

    @overload
    def __get__(self, instance: None, owner: type | None = None) -> per_thread[T]: ...

    @overload
    def __get__(self, instance: object, owner: type | None = None) -> T: ...

    def __get__(self, instance: object | None, owner: type | None = None) -> per_thread[T] | T:
        if instance is None:
            return self
        values = instance.__dict__.get(VALUES)
        if values is None:
            values = instance.__dict__.setdefault(VALUES, _Values())  # one for all threads, whichever sets it
        try:
            value: T = getattr(values, self.name)
        except AttributeError:
            value = self.make(instance)
            setattr(values, self.name, value)
        return value


def made(instance: object, name: str) -> bool:
    """Whether the calling thread has made ``instance``'s :class:`per_thread` value ``name``."""
    values = instance.__dict__.get(VALUES)
    return values is not None and name in vars(values)
