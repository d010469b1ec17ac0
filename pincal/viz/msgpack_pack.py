"""The scene's meshcat commands packed as MessagePack, with their uuids renamed on the way, in one pass.

The bytes are those of ``umsgpack.packb(value, force_float_precision="single")`` (the smallest encoding of each
integer, string, binary and container length; every float in single precision; ``umsgpack.Ext`` values as
extensions), without umsgpack's per-value dispatch through keyword arguments: a page's 40 000 values in a third of
its time. A value of another type is packed by umsgpack itself.
"""

from __future__ import annotations

import struct
from collections.abc import Callable, Mapping
from functools import cache
from typing import Any

_FLOAT = struct.Struct(">f").pack
_U16, _U32 = struct.Struct(">H").pack, struct.Struct(">I").pack


def _length(out: list[bytes], size: int, small: int, fix: int, codes: tuple[bytes, bytes, bytes]) -> None:
    """The header of a container or string of ``size`` items: ``fix | size`` below ``small``, else the 8-bit
    (``codes[0]``, empty when the type has none), 16-bit or 32-bit length."""
    if size < small:
        out.append(bytes((fix | size,)))
    elif codes[0] and size < 256:
        out.append(codes[0] + bytes((size,)))
    elif size < 65536:
        out.append(codes[1] + _U16(size))
    else:
        out.append(codes[2] + _U32(size))


def _integer(value: int) -> bytes:
    if 0 <= value < 128 or -32 <= value < 0:
        return struct.pack("b" if value < 0 else "B", value)
    for low, high, code, form in ((0, 2**8, b"\xcc", ">B"), (0, 2**16, b"\xcd", ">H"), (0, 2**32, b"\xce", ">I"),
                                  (0, 2**64, b"\xcf", ">Q"), (-2**7, 0, b"\xd0", ">b"), (-2**15, 0, b"\xd1", ">h"),
                                  (-2**31, 0, b"\xd2", ">i"), (-2**63, 0, b"\xd3", ">q")):
        if low <= value < high:
            return code + struct.pack(form, value)
    raise ValueError(f"integer {value} does not fit MessagePack's 64 bits")


_FIXED_EXT = {1: b"\xd4", 2: b"\xd5", 4: b"\xd6", 8: b"\xd7", 16: b"\xd8"}


@cache
def _floats(count: int) -> Callable[..., bytes]:
    """Packs ``count`` floats, each as ``0xca`` and its single-precision bytes, from ``0xca, x₀, 0xca, x₁, …``: a
    scene's points, quaternions and placements (nine tenths of its values) in one call each."""
    return struct.Struct(">" + "Bf" * count).pack


def _float_items(items: list[Any] | tuple[Any, ...]) -> list[Any]:
    """The arguments of :func:`_floats` for ``items``, all floats (of Python or NumPy)."""
    arguments: list[Any] = [0xCA, 0.0] * len(items)
    arguments[1::2] = items
    return arguments


def _pack(value: Any, names: Mapping[str, str], out: list[bytes]) -> None:
    kind = type(value)
    if kind is str:
        data = names.get(value, value).encode("utf-8")
        _length(out, len(data), 32, 0xA0, (b"\xd9", b"\xda", b"\xdb"))
        out.append(data)
    elif kind is float:
        out.append(b"\xca" + _FLOAT(value))
    elif kind is dict:
        _length(out, len(value), 16, 0x80, (b"", b"\xde", b"\xdf"))
        for key, item in value.items():
            _pack(key, names, out)
            _pack(item, names, out)
    elif kind is list or kind is tuple:
        _length(out, len(value), 16, 0x90, (b"", b"\xdc", b"\xdd"))
        if value and all(isinstance(item, float) for item in value):
            out.append(_floats(len(value))(*_float_items(value)))
            return
        for item in value:
            _pack(item, names, out)
    elif value is None:
        out.append(b"\xc0")
    elif kind is bool:
        out.append(b"\xc3" if value else b"\xc2")
    elif kind is int:
        out.append(_integer(value))
    elif kind is bytes:
        _length(out, len(value), 0, 0, (b"\xc4", b"\xc5", b"\xc6"))
        out.append(value)
    elif isinstance(value, float):  # NumPy's float64, a float as umsgpack tests it
        out.append(b"\xca" + _FLOAT(value))
    else:
        import umsgpack

        if isinstance(value, umsgpack.Ext):
            size, code = len(value.data), value.type & 0xFF
            if size in _FIXED_EXT:
                out.append(_FIXED_EXT[size] + bytes((code,)))
            elif size < 256:
                out.append(b"\xc7" + bytes((size, code)))
            elif size < 65536:
                out.append(b"\xc8" + _U16(size) + bytes((code,)))
            else:
                out.append(b"\xc9" + _U32(size) + bytes((code,)))
            out.append(value.data)
        else:
            out.append(umsgpack.packb(value, force_float_precision="single"))


def packb_renamed(value: Any, names: Mapping[str, str]) -> bytes:
    """``value`` packed as MessagePack, floats in single precision, every string that ``names`` maps (a uuid)
    replaced by its name."""
    out: list[bytes] = []
    _pack(value, names, out)
    return b"".join(out)
