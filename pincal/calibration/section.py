"""A nested part of a JSON document as a frozen record: :class:`Section`, its fields the JSON object's keys.

:meth:`Section.as_dict` gives the JSON object, :meth:`Section.from_json` reads one back: keys this version does not
know are left out, keys an older file lacks take their default, values are kept as the file holds them; a field marked
:data:`OPTIONAL` is left out of the JSON while it holds None. The report's records
(:mod:`pincal.calibration.report_sections`) are sections.
"""

from __future__ import annotations

import dataclasses
import math
from collections.abc import Callable, Mapping
from dataclasses import fields
from typing import Any, TypeVar

from pincal.errors import DataError
from pincal.records import record

S = TypeVar("S", bound="Section")

#: The metadata of a field left out of the JSON while it holds None.
OPTIONAL = {"optional": True}


#: What a value that no calibration writes is told to be instead.
EXPECTED = "expected a report written by 'pincal calibrate --report'"


def _expect_mapping(value: Any, where: str) -> Mapping[str, Any]:
    if not isinstance(value, dict):
        raise DataError(f"{where} is not a JSON object: {EXPECTED}")
    return value


def _finite(value: Any) -> bool:
    """Whether ``value`` is a finite JSON number (not a boolean)."""
    return isinstance(value, int | float) and not isinstance(value, bool) and math.isfinite(value)


def at_least(minimum: float) -> Callable[[Any, str], float]:
    """The reader of a finite number ≥ ``minimum`` (a variance factor: ≥ 0)."""

    def read(value: Any, where: str) -> float:
        if not _finite(value) or value < minimum:
            raise DataError(f"{where} is {value!r}, not a finite number ≥ {minimum:g}: {EXPECTED}")
        return float(value)

    return read


def numbers_by_name(value: Any, where: str) -> dict[str, float]:
    """The reader of a JSON object of finite numbers by name (a setup's values [m, rad])."""
    content = _expect_mapping(value, where)
    bad = [name for name, item in content.items() if not _finite(item)]
    if bad:
        raise DataError(f"{where}['{bad[0]}'] is {content[bad[0]]!r}, not a finite number: {EXPECTED}")
    return {name: float(item) for name, item in content.items()}


def ranges_by_name(value: Any, where: str) -> dict[str, list[float]]:
    """The reader of a JSON object of ranges ``[min, max]`` by name (finite numbers, min ≤ max: joint ranges)."""
    content = _expect_mapping(value, where)
    for name, item in content.items():
        if not (isinstance(item, list) and len(item) == 2 and all(_finite(v) for v in item) and item[0] <= item[1]):
            raise DataError(f"{where}['{name}'] is {item!r}, not a range [min, max] of finite numbers: {EXPECTED}")
    return {name: [float(item[0]), float(item[1])] for name, item in content.items()}


def square(names: Any, matrix: Any, where: str) -> None:
    """Refuse what is not ``n`` names and an ``n × n`` matrix of finite numbers or null (a covariance's).

    Raises:
        DataError: naming ``where``.
    """
    n = len(names) if isinstance(names, list) and all(isinstance(name, str) for name in names) else -1
    if n < 0 or not isinstance(matrix, list) or len(matrix) != n or not all(
            isinstance(row, list) and len(row) == n and all(v is None or _finite(v) for v in row) for row in matrix):
        raise DataError(f"{where} is not an object of 'parameters' (n names) and 'matrix' (n × n numbers or null): "
                        f"{EXPECTED}")


def positive_lists_by_name(value: Any, where: str) -> dict[str, list[float]]:
    """The reader of a JSON object of lists of finite numbers > 0 by name (each measurement's row σ)."""
    content = _expect_mapping(value, where)
    for name, item in content.items():
        if not (isinstance(item, list) and item and all(_finite(v) and v > 0 for v in item)):
            raise DataError(f"{where}['{name}'] is {item!r}, not a list of finite numbers > 0: {EXPECTED}")
    return {name: [float(v) for v in item] for name, item in content.items()}


def nested(reader: Callable[[Any, str], Any], **metadata: Any) -> dict[str, Any]:
    """The metadata of a field whose JSON value ``reader(value, where)`` reads (a section, or sections by name)."""
    return {"read": reader, **metadata}


@record(frozen=True)
class Section:
    """A nested part of the report JSON as a record: its fields are the JSON object's keys, in order."""

    def as_dict(self) -> dict[str, Any]:
        """The JSON object: every field in order, the optional ones that hold None left out; nested sections as
        their own objects."""
        return {f.name: _plain(getattr(self, f.name)) for f in fields(self) if not f.metadata.get("internal")
                and not (f.metadata.get("optional") and getattr(self, f.name) is None)}

    @classmethod
    def from_json(cls: type[S], value: Any, where: str) -> S:
        """The section of a parsed JSON object ``value`` (``where`` names it in errors, e.g. ``the result JSON's
        'cv'``): its known keys, each read by its field's reader; keys it lacks take their default.

        Raises:
            DataError: ``value`` is not an object, lacks a key without default, or a nested part is not one.
        """
        content = _expect_mapping(value, where)
        given: dict[str, Any] = {}
        for f in fields(cls):
            if f.metadata.get("internal"):
                continue
            if f.name not in content:
                if f.default is dataclasses.MISSING and f.default_factory is dataclasses.MISSING:
                    raise DataError(f"{where} has no '{f.name}': expected a report written by 'pincal calibrate "
                                    "--report'")
                continue
            reader = f.metadata.get("read")
            item = content[f.name]
            given[f.name] = reader(item, f"{where}['{f.name}']") if reader is not None and item is not None else item
        return cls(**given)


def _plain(value: Any) -> Any:
    """``value`` with every section made its JSON object, through lists, tuples and dicts."""
    if isinstance(value, Section):
        return value.as_dict()
    if isinstance(value, dict):
        return {k: _plain(v) for k, v in value.items()}
    if isinstance(value, (list, tuple)):
        return [_plain(v) for v in value]
    return value


def by_name(section: type[S]) -> Callable[[Any, str], dict[str, S]]:
    """The reader of a JSON object of ``section``s by name."""

    def read(value: Any, where: str) -> dict[str, S]:
        return {name: section.from_json(item, f"{where}['{name}']")
                for name, item in _expect_mapping(value, where).items()}

    return read


def listed(section: type[S]) -> Callable[[Any, str], list[S]]:
    """The reader of a JSON list of ``section``s."""

    def read(value: Any, where: str) -> list[S]:
        if not isinstance(value, list):
            raise DataError(f"{where} is not a JSON list: expected a report written by 'pincal calibrate --report'")
        return [section.from_json(item, f"{where}[{k}]") for k, item in enumerate(value)]

    return read
