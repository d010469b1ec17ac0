"""Plugins: the user's own modules, loaded before a command runs, that declare new kinds (a measurement class with
its ``kinds`` registers itself, :mod:`pincal.identification.measurements`; a parameter kind likewise,
:mod:`pincal.identification.parameters.kinds`).

The environment variable ``PINCAL_PLUGINS`` names them, separated by ``os.pathsep`` (``:`` on Linux and macOS,
``;`` on Windows): each a ``.py`` file (``~/sensors/height.py``) or a dotted module name importable from the Python
path (``mylab.sensors``). docs/extending.md has the recipe of a new sensor.
"""

from __future__ import annotations

import importlib
import importlib.util
import os
import re
import sys
from pathlib import Path
from types import ModuleType

from pincal.errors import PluginError

#: The environment variable that names the plugins.
ENVIRONMENT = "PINCAL_PLUGINS"
#: A dotted module name: identifiers separated by dots.
MODULE_NAME = re.compile(r"[A-Za-z_][A-Za-z0-9_]*(\.[A-Za-z_][A-Za-z0-9_]*)*")
#: What an entry may be, for the messages.
FORMS = "an existing .py file or a dotted module name on the Python path"


def plugin_entries(value: str | None = None) -> list[str]:
    """The entries of ``value`` (default: the environment's ``PINCAL_PLUGINS``), ``os.pathsep``-separated, blanks
    ignored."""
    text = os.environ.get(ENVIRONMENT, "") if value is None else value
    return [entry.strip() for entry in text.split(os.pathsep) if entry.strip()]


def load_plugins(value: str | None = None) -> list[ModuleType]:
    """Import every plugin ``PINCAL_PLUGINS`` names (or ``value`` names), in order; a module already imported is not
    imported again.

    Raises:
        PluginError: naming the entry that is neither an existing ``.py`` file nor an importable module, or whose
            import failed (with the error it raised).
    """
    return [load_plugin(entry) for entry in plugin_entries(value)]


def load_plugin(entry: str) -> ModuleType:
    """Import one plugin: a ``.py`` file (a path) or a dotted module name (PluginError otherwise)."""
    if entry.endswith(".py") or "/" in entry or os.sep in entry:
        return _load_file(entry)
    if not MODULE_NAME.fullmatch(entry):
        raise PluginError(f"{ENVIRONMENT}: plugin '{entry}' is not {FORMS}", entry)
    try:
        return importlib.import_module(entry)
    except Exception as exc:  # the plugin's own error, whatever it is, is reported as the plugin's
        raise PluginError(f"{ENVIRONMENT}: cannot import plugin '{entry}': {type(exc).__name__}: {exc} (a plugin is "
                          f"{FORMS})", entry) from exc


def _load_file(entry: str) -> ModuleType:
    """Import the ``.py`` file ``entry`` as a module named after its resolved path (imported once)."""
    path = Path(entry).expanduser()
    if path.suffix != ".py" or not path.is_file():
        raise PluginError(f"{ENVIRONMENT}: plugin '{entry}' is not {FORMS}", entry)
    resolved = path.resolve()
    import hashlib  # here, where a plugin file is named: not in every command's start

    name = f"pincal_plugin_{resolved.stem}_{hashlib.sha1(str(resolved).encode()).hexdigest()[:8]}"
    if name in sys.modules:
        return sys.modules[name]
    spec = importlib.util.spec_from_file_location(name, resolved)
    if spec is None or spec.loader is None:
        raise PluginError(f"{ENVIRONMENT}: plugin '{entry}' cannot be loaded as a module ({FORMS})", entry)
    module = importlib.util.module_from_spec(spec)
    sys.modules[name] = module  # dataclasses look their module up while the file runs
    try:
        spec.loader.exec_module(module)
    except Exception as exc:
        del sys.modules[name]
        raise PluginError(f"{ENVIRONMENT}: plugin '{entry}' failed to load: {type(exc).__name__}: {exc}",
                          entry) from exc
    return module
