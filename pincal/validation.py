"""Checks of a library call's arguments, as the command line checks its flags: type, finiteness, sign, range.

A wrong type raises ``TypeError``, a wrong value :class:`~pincal.errors.ArgumentError`; both name the argument and
the value given, so a caller meets the fault in the words of their own call, not from deep inside. The module
imports nothing beyond the standard library (the ``pincal`` command's start imports neither NumPy nor Pinocchio).
"""

from __future__ import annotations

import math
import numbers
import os
from collections.abc import Sequence
from pathlib import Path
from typing import TYPE_CHECKING, Any, TypeVar

from pincal.errors import ArgumentError

if TYPE_CHECKING:
    import numpy as np
    import numpy.typing as npt

T = TypeVar("T")


def shown(value: object, limit: int = 60) -> str:
    """``value``'s ``repr``, shortened past ``limit`` characters."""
    text = repr(value)
    return text if len(text) <= limit else text[:limit] + "..."


def _type_error(name: str, value: object, expected: str) -> TypeError:
    return TypeError(f"{name}={shown(value)}: expected {expected}, not {type(value).__name__}")


def real(name: str, value: Any, unit: str = "", *, minimum: float = 0.0, strict: bool = False) -> float:
    """``value`` as a float: a finite real number ≥ ``minimum`` (> it when ``strict``) [``unit``].

    Raises:
        TypeError: not a real number (a bool, a string, None).
        ArgumentError: NaN, infinite, or below the minimum.
    """
    if isinstance(value, bool) or not isinstance(value, numbers.Real):
        raise _type_error(name, value, "a number")
    number = float(value)
    if not math.isfinite(number) or number < minimum or (strict and number == minimum):
        bound = f"{'>' if strict else '≥'} {minimum:g}"
        raise ArgumentError(f"{name}={shown(value)}: must be a finite number {bound}{f' [{unit}]' if unit else ''}",
                            option=name)
    return number


def optional_real(name: str, value: Any, unit: str = "", *, minimum: float = 0.0, strict: bool = False) -> float | None:
    """None, or ``value`` checked by :func:`real`."""
    return None if value is None else real(name, value, unit, minimum=minimum, strict=strict)


def whole(name: str, value: Any, minimum: int = 0) -> int:
    """``value``, a whole number (an ``int``, not a bool) ≥ ``minimum``.

    Raises:
        TypeError: not an integer (a float such as 5.0 included: a count is exact).
        ArgumentError: below the minimum.
    """
    if isinstance(value, bool) or not isinstance(value, numbers.Integral):
        raise _type_error(name, value, "a whole number (int)")
    if value < minimum:
        raise ArgumentError(f"{name}={value}: must be a whole number ≥ {minimum}", option=name)
    return int(value)


def finite_vector(name: str, value: Any, size: int, unit: str = "") -> npt.NDArray[np.float64]:
    """``value`` (a list, tuple or array) as ``size`` finite floats [``unit``]; NumPy is imported only here.

    Raises:
        TypeError: not numbers (a string, None, a mapping).
        ArgumentError: another shape, or NaN or infinity among them.
    """
    import numpy as np

    if isinstance(value, (str, bytes)) or value is None:
        raise _type_error(name, value, f"{size} numbers")
    try:
        array = np.asarray(value, dtype=float)
    except (TypeError, ValueError):
        raise _type_error(name, value, f"{size} numbers") from None
    units = f" [{unit}]" if unit else ""
    if array.shape != (size,):
        raise ArgumentError(f"{name}={shown(value)}: must be {size} numbers{units}, not an array of shape "
                            f"{array.shape}", option=name)
    if not np.all(np.isfinite(array)):
        raise ArgumentError(f"{name}={shown(value)}: must be {size} finite numbers{units} (NaN or infinity given)",
                            option=name)
    return array


def instance(name: str, value: Any, kind: type[T], expected: str) -> T:
    """``value``, which must be a ``kind`` (``expected`` says what, for the message, e.g. ``a Robot (load_robot)``).

    Raises:
        TypeError: another type.
    """
    if not isinstance(value, kind):
        raise _type_error(name, value, expected)
    return value


def path(name: str, value: Any) -> str | Path:
    """``value``, a file path: a ``str`` or an ``os.PathLike`` of one.

    Raises:
        TypeError: another type (bytes, None, a number).
    """
    if isinstance(value, str):
        return value
    if isinstance(value, os.PathLike) and isinstance(os.fspath(value), str):
        return Path(value)
    raise _type_error(name, value, "a path (str or pathlib.Path)")


def texts(name: str, value: Any) -> tuple[str, ...]:
    """``value``, a list or tuple of strings (a single string is refused: it would be read letter by letter).

    Raises:
        TypeError: a string, or not a sequence of strings.
    """
    if isinstance(value, str):
        raise _type_error(name, value, f"a list of strings (e.g. [{value!r}])")
    if not isinstance(value, Sequence) or not all(isinstance(item, str) for item in value):
        raise _type_error(name, value, "a list of strings")
    return tuple(value)


def optional_texts(name: str, value: Any) -> tuple[str, ...] | None:
    """None, or ``value`` checked by :func:`texts`."""
    return None if value is None else texts(name, value)
