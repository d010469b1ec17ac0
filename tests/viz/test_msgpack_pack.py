"""The scene's MessagePack packer gives umsgpack's bytes, uuids renamed, for every kind of value a command holds."""

from __future__ import annotations

import numpy as np
import pytest
import umsgpack

from pincal.viz.msgpack_pack import packb_renamed


def _umsgpack(value: object) -> bytes:
    return umsgpack.packb(value, force_float_precision="single")  # type: ignore[no-any-return]


def test_every_size_class_packs_as_umsgpack_does() -> None:
    integers = [0, 1, 127, 128, 255, 256, 65535, 65536, 2**32 - 1, 2**32, 2**64 - 1, -1, -32, -33, -128, -129,
                -32768, -32769, -2**31, -2**31 - 1, -2**63]
    strings = ["", "é", "a" * 31, "a" * 32, "a" * 255, "a" * 256, "a" * 65535, "a" * 65536]
    binaries = [b"", b"x" * 255, b"x" * 256, b"x" * 65536]
    extensions = [umsgpack.Ext(t, b"y" * n) for t, n in ((1, 1), (2, 2), (-3, 4), (4, 8), (5, 16), (6, 3),
                                                           (7, 255), (8, 256), (9, 70000))]
    floats = [0.0, -1.5, 1e-30, 3.4e38, float("inf"), np.float64(0.1)]
    containers = [list(range(15)), list(range(16)), list(range(70000)), tuple(range(3)),
                  {str(k): k for k in range(15)}, {str(k): k for k in range(16)}, {str(k): k for k in range(70000)}]
    for value in [*integers, *strings, *binaries, *extensions, *floats, *containers, None, True, False]:
        assert packb_renamed(value, {}) == _umsgpack(value), repr(value)[:40]


def test_uuids_are_renamed_wherever_they_appear() -> None:
    command = {"type": "set_object", "object": {"geometries": [{"uuid": "u-1", "data": [1.25, 2, None]}],
                                                "object": {"geometry": "u-1", "u-1": ("u-1", "other")}}}
    names = {"u-1": "pincal-1"}
    renamed = {"type": "set_object", "object": {"geometries": [{"uuid": "pincal-1", "data": [1.25, 2, None]}],
                                                "object": {"geometry": "pincal-1",
                                                           "pincal-1": ("pincal-1", "other")}}}
    assert packb_renamed(command, names) == _umsgpack(renamed)


def test_lists_of_floats_pack_as_umsgpack_does() -> None:
    """A list of numbers only (a point, a quaternion, a placement: most of a scene) is packed in one call, to
    umsgpack's bytes, whatever its length and whichever floats it mixes; a list with a number of another type packs
    as before, and a float beyond single precision's range is refused as umsgpack refuses it."""
    rng = np.random.default_rng(3)
    mixed = [np.float64(x) if k % 2 else float(x) for k, x in enumerate(rng.normal(scale=1e3, size=70000))]
    special = [1.0, np.float64(-2.25), 1e-45, 3.4e38, float("-inf"), float("nan")]
    for value in ([0.5], special, list(rng.normal(size=16)), tuple(rng.normal(size=4)), mixed[:15], mixed[:16], mixed,
                  [1.5, 2, 3.5], [1.5, True], [[0.5, 1.5]]):
        assert packb_renamed(value, {}) == _umsgpack(value), repr(value)[:40]
    for packer in (_umsgpack, lambda value: packb_renamed(value, {})):
        with pytest.raises(OverflowError, match="float too large to pack with f format"):
            packer([1.0, 1e300])
