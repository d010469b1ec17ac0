"""The layers of docs/architecture.md: every import inside pincal points down, never up or sideways."""

from __future__ import annotations

import ast
import itertools
import re
import warnings
from pathlib import Path

import pytest

PACKAGE = Path(__file__).resolve().parents[1] / "pincal"

#: Layer of each top-level part of pincal, from the bottom; a module imports only parts of a lower layer or
#: modules of its own part (``pincal.__version__`` is a constant of the package root).
LAYERS = {"errors": 0, "__version__": 0, "lazy": 0, "records": 0, "validation": 1, "linalg": 1, "progress": 1,
          "plugins": 1, "model": 2, "identification": 3, "study": 4, "io": 4, "calibration": 5, "fleet": 6, "viz": 6,
          "cli": 7, "__main__": 8}


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


ARCHITECTURE = (PACKAGE.parent / "docs" / "architecture.md").read_text(encoding="utf-8")
#: The package table of docs/architecture.md: package -> its row.
ROWS = {m.group(1): m.group(0) for m in re.finditer(r"^\| `(\w+)` \|.*$", ARCHITECTURE, re.MULTILINE)}
PACKAGES = sorted(p.name for p in PACKAGE.iterdir() if p.is_dir() and (p / "__init__.py").is_file())


@pytest.mark.parametrize("package", PACKAGES)
def test_the_architecture_page_names_every_module_of_each_package(package: str) -> None:
    """Each sub-package has a row in the page's table that names each of its modules, and a layer in LAYERS."""
    assert package in ROWS, f"docs/architecture.md has no row for pincal/{package}/"
    assert package in LAYERS
    modules = sorted(p.stem for p in (PACKAGE / package).glob("*.py") if p.name != "__init__.py")
    modules += sorted(p.name for p in (PACKAGE / package).iterdir() if (p / "__init__.py").is_file())
    missing = [m for m in modules if f"`{m}`" not in ROWS[package]]
    assert not missing, f"docs/architecture.md's row of {package} does not name {missing}"


def test_the_architecture_page_names_no_module_that_is_gone() -> None:
    """A package named on the page exists, and the page's layer order is the one LAYERS holds."""
    assert set(ROWS) <= set(PACKAGES)
    order = re.search(r"\(`errors` < `linalg`.*?\)", ARCHITECTURE, re.DOTALL)
    assert order is not None
    named = re.findall(r"`(\w+)`", order.group(0))
    assert all(LAYERS[a] <= LAYERS[b] for a, b in itertools.pairwise(named))


def test_every_package_is_installed() -> None:
    """pyproject.toml lists each package of pincal (a package left out is missing from a non-editable install)."""
    import tomllib

    listed = set(tomllib.loads((PACKAGE.parent / "pyproject.toml").read_text(encoding="utf-8"))["tool"]["setuptools"]
                 ["packages"])
    packages = {".".join(p.relative_to(PACKAGE.parent).parts[:-1]) for p in PACKAGE.rglob("__init__.py")}
    assert packages <= listed, sorted(packages - listed)


@pytest.mark.parametrize("package", ["pincal", "pincal.calibration", "pincal.identification", "pincal.io",
                                     "pincal.study"])
def test_no_exported_name_is_shadowed_by_a_module(package: str) -> None:
    """A name a package exports is never also one of its modules: importing ``pincal.calibration.simulate`` once
    turned ``from pincal.calibration import simulate`` into the module."""
    import importlib
    import pkgutil

    module = importlib.import_module(package)
    modules = {info.name for info in pkgutil.iter_modules(module.__path__)}
    assert not modules & set(module.__all__), sorted(modules & set(module.__all__))


#: The length past which a module of pincal is named for review [lines]: does it hold two concepts?
MAX_MODULE_LINES = 500


def _module_lengths() -> dict[str, int]:
    """Each module under pincal/ (path relative to it) -> its number of lines."""
    return {str(p.relative_to(PACKAGE)): len(p.read_text(encoding="utf-8").splitlines())
            for p in PACKAGE.rglob("*.py")}


def _shared_names() -> dict[str, list[str]]:
    """Each name two or more modules (or sub-packages) under pincal/ have in different packages -> their paths."""
    names: dict[str, list[str]] = {}
    for path in PACKAGE.rglob("*.py"):
        if path.parent == PACKAGE and path.name in ("__init__.py", "__main__.py"):
            continue
        name = path.parent.name if path.name == "__init__.py" else path.stem
        names.setdefault(name, []).append(str(path.relative_to(PACKAGE)))
    return {name: paths for name, paths in names.items() if len(paths) > 1}


def test_modules_longer_than_the_review_size_are_reported() -> None:
    """A module longer than :data:`MAX_MODULE_LINES` lines is a review signal, not a failure: the run's warnings
    name it, so a reviewer asks whether it holds two concepts. Splitting a module only to meet the number made
    import circles (:func:`test_no_import_circle`)."""
    lengths = _module_lengths()
    assert "errors.py" in lengths and "calibration/pipeline.py" in lengths
    long = {path: n for path, n in sorted(lengths.items()) if n > MAX_MODULE_LINES}
    if long:
        warnings.warn(f"review: modules longer than {MAX_MODULE_LINES} lines: {long}", stacklevel=1)


def _module_name(path: Path) -> str:
    """The dotted name of a module under pincal/ (a package's ``__init__.py`` is the package)."""
    parts = list(path.relative_to(PACKAGE.parent).with_suffix("").parts)
    return ".".join(parts[:-1] if parts[-1] == "__init__" else parts)


def _import_graph() -> dict[str, set[str]]:
    """Each module of pincal -> the modules of pincal it imports.

    Every import statement counts: at module level, inside functions and under ``TYPE_CHECKING``.
    ``from pincal.a import b`` names the module ``pincal.a.b`` where there is one, else ``pincal.a`` (a package: its
    ``__init__``, whose own imports then count; a lazy ``__init__`` imports by name on first use, and has none).
    """
    modules = {_module_name(path): path for path in PACKAGE.rglob("*.py")}
    graph: dict[str, set[str]] = {}
    for name, path in modules.items():
        found: set[str] = set()
        for node in ast.walk(ast.parse(path.read_text(encoding="utf-8"))):
            if isinstance(node, ast.ImportFrom) and node.level == 0 and node.module and (
                    node.module == "pincal" or node.module.startswith("pincal.")):
                found |= {f"{node.module}.{a.name}" if f"{node.module}.{a.name}" in modules else node.module
                          for a in node.names}
            elif isinstance(node, ast.Import):
                found |= {a.name for a in node.names if a.name in modules}
        graph[name] = {module for module in found if module in modules and module != name}
    return graph


def _circles(graph: dict[str, set[str]]) -> list[list[str]]:
    """The import circles of ``graph``: each set of two or more modules that import each other in a loop (a strongly
    connected component, Tarjan's algorithm), sorted."""
    index: dict[str, int] = {}
    low: dict[str, int] = {}
    stack: list[str] = []
    circles: list[list[str]] = []

    def visit(module: str) -> None:
        index[module] = low[module] = len(index)
        stack.append(module)
        for other in sorted(graph[module]):
            if other not in index:
                visit(other)
                low[module] = min(low[module], low[other])
            elif other in stack:
                low[module] = min(low[module], index[other])
        if low[module] == index[module]:
            component = stack[stack.index(module):]
            del stack[stack.index(module):]
            if len(component) > 1:
                circles.append(sorted(component))

    for module in sorted(graph):
        if module not in index:
            visit(module)
    return sorted(circles)


def test_the_circle_finder_finds_each_circle_once() -> None:
    """A loop of three modules is one circle; a module that only imports into it, and one importing itself, none."""
    graph = {"a": {"b"}, "b": {"c"}, "c": {"a"}, "d": {"a", "d"}, "e": {"f"}, "f": {"e"}}
    assert _circles(graph) == [["a", "b", "c"], ["e", "f"]]


def test_the_import_graph_reads_imports_inside_functions() -> None:
    """``pincal calibrate`` imports the work's modules when it runs: those imports are arrows of the graph."""
    graph = _import_graph()
    assert "pincal.calibration.from_files" in graph["pincal.cli.app"]
    assert "pincal.errors" in graph["pincal.calibration.pipeline"]


#: The import circles still to be split by concept; a new one fails the test, this list only shrinks.
def test_no_import_circle() -> None:
    """No modules of pincal import each other in a loop (:func:`_import_graph` says which imports count): a package
    is split by concept, so that one module builds on the others."""
    circles = _circles(_import_graph())
    assert not circles, f"modules that import each other in a loop: {circles}"


def test_no_two_modules_share_a_name() -> None:
    """A module's name says what it holds once: no two modules (or sub-packages) under pincal/ have the same name
    in different packages."""
    assert _shared_names() == {}


def test_the_layer_drawing_names_every_part_of_pincal() -> None:
    """The drawing at the top of docs/architecture.md shows each package and each shared module of pincal."""
    drawing = ARCHITECTURE.split("```", 2)[1]
    parts = sorted(p.stem if p.suffix else p.name for p in PACKAGE.iterdir()
                   if (p.suffix == ".py" and not p.name.startswith("__")) or (p / "__init__.py").is_file())
    missing = [part for part in parts if f"pincal.{part}" not in drawing]
    assert not missing, f"the drawing in docs/architecture.md lacks {missing}"


def test_every_command_module_registers_itself_in_the_app() -> None:
    """The recipe for a new command: a module in cli/ with ``register`` and a ``cmd_…`` function, in the list
    ``cli/app.py`` registers (app and the shared arguments aside)."""
    app = (PACKAGE / "cli" / "app.py").read_text(encoding="utf-8")
    listed = re.search(r"for module in \(([^)]*)\)", app)
    assert listed is not None
    registered = set(re.findall(r"\w+", listed.group(1)))
    for path in sorted((PACKAGE / "cli").glob("*.py")):
        if path.stem in ("__init__", "app", "arguments"):
            continue
        text = path.read_text(encoding="utf-8")
        assert "\ndef register(" in text and "\ndef cmd_" in text, f"cli/{path.name} has no register or cmd_ function"
        assert path.stem in registered, f"cli/app.py does not register cli/{path.name}"


def _recipe(title: str) -> str:
    """The bullet of docs/architecture.md's "Where a change goes" that starts with ``title`` in bold."""
    found = re.search(rf"^- \*\*{re.escape(title)}\*\*.*?(?=^- \*\*|\Z)", ARCHITECTURE, re.MULTILINE | re.DOTALL)
    assert found is not None, title
    return found.group(0)


def test_the_sensor_recipe_names_what_a_measurement_kind_declares() -> None:
    """Each class attribute a measurement kind may declare, and each method it may override to say what it reads,
    is named in the recipe for a new sensor."""
    from pincal.identification.measurements import Measurement

    recipe = _recipe("A new sensor")
    declared = [n for n, hint in Measurement.__annotations__.items() if "ClassVar" in str(hint)]
    declared += ["from_key", "predict", "predict_batch", "error", "neutral", "simulate", "markers", "attachments",
                 "read_joints", "locates_point"]
    assert all(hasattr(Measurement, n) or n == "from_key" for n in declared)
    missing = [n for n in declared if f"`{n}`" not in recipe]
    assert not missing, f"the sensor recipe does not name {missing}"


def test_the_parameter_kind_recipe_names_what_a_kind_declares() -> None:
    """Each class attribute of :class:`ParameterKind` and each class method a kind overrides is named in the recipe
    for a new parameter kind."""
    from pincal.identification.parameters import ParameterKind

    recipe = _recipe("A new parameter kind")
    declared = [n for n, hint in ParameterKind.__annotations__.items() if "ClassVar" in str(hint)]
    declared += [n for n, v in vars(ParameterKind).items() if isinstance(v, classmethod) and not n.startswith("_")
                 and n not in ("kinematic", "plausible_limit")]  # these two read acts_in and plausible
    missing = [n for n in declared if f"`{n}`" not in recipe]
    assert not missing, f"the parameter-kind recipe does not name {missing}"
