"""Names of a package that load on first use (PEP 562), so that importing a light module of the package — or the
``pincal`` command's parser — does not import Pinocchio, SciPy or matplotlib until a name that needs them is read."""

from __future__ import annotations

import sys

TYPE_CHECKING = False  # typing.TYPE_CHECKING without importing typing: the ``pincal`` command's start imports this
if TYPE_CHECKING:
    from collections.abc import Callable
    from typing import Any


def lazy_names(package: str, names: dict[str, str]) -> tuple[Callable[[str], Any], Callable[[], list[str]]]:
    """A ``__getattr__`` and a ``__dir__`` for ``package``: ``names`` maps each public name to the module that
    defines it (a full name, or one relative to the package, ``.setup``); a module of the package read as an
    attribute (``pincal.identification.parameters``) is imported then."""

    def __getattr__(name: str) -> Any:
        import importlib  # here, not above: the ``pincal`` command's start imports this module before its Ctrl-C
        import importlib.util  # handler, and imports nothing the interpreter has not loaded

        module = names.get(name)
        if module is not None:
            value = getattr(importlib.import_module(module, package), name)
            setattr(sys.modules[package], name, value)
            return value
        if not name.startswith("_") and importlib.util.find_spec(f"{package}.{name}") is not None:
            return importlib.import_module(f"{package}.{name}")
        raise AttributeError(f"module '{package}' has no attribute '{name}'")

    def __dir__() -> list[str]:
        return sorted(set(vars(sys.modules[package])) | set(names))

    return __getattr__, __dir__
