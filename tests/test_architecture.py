"""The layers of docs/architecture.md: every import inside pincal points down, never up or sideways."""

from __future__ import annotations

import ast
from pathlib import Path

import pytest

PACKAGE = Path(__file__).resolve().parents[1] / "pincal"

#: Layer of each top-level part of pincal, from the bottom; a module imports only parts of a lower layer or
#: modules of its own part (``pincal.__version__`` is a constant of the package root).
LAYERS = {"errors": 0, "__version__": 0, "linalg": 1, "progress": 1, "plugins": 1, "model": 2, "identification": 3,
          "study": 4, "io": 4, "workflow": 5, "fleet": 6, "viz": 6, "cli": 7, "__main__": 8}


def _part(module: str) -> str:
    return module.split(".")[1] if module.count(".") else "__init__"


def _imports(path: Path) -> list[str]:
    found = []
    for node in ast.walk(ast.parse(path.read_text(encoding="utf-8"))):
        if isinstance(node, ast.ImportFrom) and node.module and node.module.startswith("pincal"):
            found += [node.module] if node.module != "pincal" else [f"pincal.{a.name}" for a in node.names]
        elif isinstance(node, ast.Import):
            found += [a.name for a in node.names if a.name.startswith("pincal")]
    return found


SOURCES = sorted(p for p in PACKAGE.rglob("*.py") if p.name != "__init__.py" or p.parent != PACKAGE)


@pytest.mark.parametrize("path", SOURCES, ids=[str(p.relative_to(PACKAGE)) for p in SOURCES])
def test_imports_point_down(path: Path) -> None:
    own = path.relative_to(PACKAGE).parts[0].removesuffix(".py")
    assert own in LAYERS, f"{own} has no layer in docs/architecture.md"
    for module in _imports(path):
        part = _part(module)
        if part == own:
            continue
        assert part in LAYERS and LAYERS[part] < LAYERS[own], f"{path.relative_to(PACKAGE)} imports {module}"
