"""What docs/architecture.md says of the package, checked: its parts, which imports load the numerical libraries
(each in an interpreter of its own, ``sys.modules`` read after it), what ``cli/app.py`` loads at its top, what
``pincal`` re-exports, where the lazy ``__init__`` files point, and which modules may import argparse and rosbags.

tests/test_architecture.py holds the layers of every ``import`` statement and the page's package table."""

from __future__ import annotations

import ast
import importlib
import json
import subprocess
import sys
from pathlib import Path

import pytest

PACKAGE = Path(__file__).resolve().parents[1] / "pincal"
ARCHITECTURE = (PACKAGE.parent / "docs" / "architecture.md").read_text(encoding="utf-8")
HEAVY = ("numpy", "scipy", "pinocchio")

PROBE = """
import json, sys
import {module}
print(json.dumps(sorted(m for m in sys.modules if m in {watched!r} or m == "pincal" or m.startswith("pincal."))))
"""


def _loaded_by(module: str, watched: tuple[str, ...] = HEAVY) -> set[str]:
    """The modules of ``watched`` and of pincal that ``import module`` leaves in ``sys.modules`` of a fresh
    interpreter (``-P``: the working folder is not searched first)."""
    done = subprocess.run([sys.executable, "-P", "-c", PROBE.format(module=module, watched=watched)],
                          capture_output=True, text=True, timeout=120, check=False)
    assert done.returncode == 0, done.stderr
    return set(json.loads(done.stdout.splitlines()[-1]))


def _python_parts() -> tuple[set[str], set[str]]:
    """pincal's sub-packages and its top-level modules (``__init__`` and ``__main__`` aside)."""
    packages = {p.name for p in PACKAGE.iterdir() if (p / "__init__.py").is_file()}
    modules = {p.stem for p in PACKAGE.glob("*.py") if not p.name.startswith("__")}
    return packages, modules


def test_seven_sub_packages_the_fleet_module_and_seven_shared_modules() -> None:
    packages, modules = _python_parts()
    assert "pincal is seven sub-packages, the `fleet` module and seven shared modules" in ARCHITECTURE
    assert packages == {"model", "identification", "study", "io", "calibration", "viz", "cli"}
    assert "fleet" in modules
    assert modules - {"fleet"} == {"errors", "lazy", "records", "validation", "linalg", "progress", "plugins"}


@pytest.mark.parametrize("module", ["pincal", "pincal.calibration", "pincal.identification", "pincal.io",
                                    "pincal.study", "pincal.cli", "pincal.cli.app", "pincal.calibration.options",
                                    "pincal.identification.choices", "pincal.study.criteria", "pincal.errors",
                                    "pincal.lazy", "pincal.records", "pincal.validation", "pincal.progress",
                                    "pincal.plugins"])
def test_a_light_import_loads_no_numerical_library(module: str) -> None:
    """The lazy packages, the command line's parser and the light modules it reads load none of NumPy, SciPy and
    Pinocchio."""
    assert _loaded_by(module) & set(HEAVY) == set()


@pytest.mark.parametrize("module", ["pincal.model", "pincal.model.dh", "pincal.viz", "pincal.fleet",
                                    "pincal.identification.measurements", "pincal.identification.parameters"])
def test_an_eager_package_loads_numpy_and_pinocchio(module: str) -> None:
    """``import pincal.model`` (or any module under it) loads Pinocchio, as the other eager ``__init__`` files do:
    the page says so rather than calling every package lazy (SciPy's LAPACK bindings load on first use)."""
    assert _loaded_by(module) >= {"numpy", "pinocchio"}


def test_of_the_shared_modules_only_linalg_loads_numpy() -> None:
    assert _loaded_by("pincal.linalg") & set(HEAVY) == {"numpy"}


def test_chi2_needs_neither_scipy_statistics_nor_special_functions() -> None:
    """The page's row of ``identification``: ``chi2`` without SciPy's statistics or special functions."""
    loaded = _loaded_by("pincal.identification.chi2", ("scipy.stats", "scipy.special", "pinocchio"))
    assert not loaded & {"scipy.stats", "scipy.special", "pinocchio"}


def test_the_command_line_loads_at_its_top_only_the_modules_the_page_names() -> None:
    """``cli/app.py`` imports the command modules and the light modules their parsers read; the work's modules load
    when a command runs."""
    named = {"calibration.options", "identification.choices", "identification.fit_options", "study.criteria", "plugins",
             "validation", "errors", "lazy", "records"}
    for name in named:
        assert f"`{name}`" in ARCHITECTURE
    loaded = {m.removeprefix("pincal.") for m in _loaded_by("pincal.cli.app") if m.startswith("pincal.")}
    packages = {"calibration", "identification", "study", "cli"}  # the packages of those modules, lazy ones
    assert {m for m in loaded if not m.startswith("cli.")} == named | packages


def test_lazy_packages_and_eager_ones_are_those_the_page_names() -> None:
    """``pincal`` and four packages define ``__getattr__`` from :func:`pincal.lazy.lazy_names`; the other four
    ``__init__`` files import their modules; ``cli``'s re-exports nothing."""
    lazy, eager = [], []
    for init in sorted(PACKAGE.rglob("__init__.py")):
        tree = ast.parse(init.read_text(encoding="utf-8"))
        name = ".".join(("pincal", *init.parent.relative_to(PACKAGE).parts))
        calls = {n.func.id for n in ast.walk(tree) if isinstance(n, ast.Call) and isinstance(n.func, ast.Name)}
        if "lazy_names" in calls:
            lazy.append(name)
        elif any(isinstance(n, ast.ImportFrom) for n in tree.body):
            eager.append(name)
        else:
            assert not [n for n in tree.body if not isinstance(n, ast.Expr)], f"{name} re-exports names"
            assert name == "pincal.cli"
    assert lazy == ["pincal", "pincal.calibration", "pincal.identification", "pincal.io", "pincal.study"]
    assert eager == ["pincal.identification.measurements", "pincal.identification.parameters", "pincal.model",
                     "pincal.viz"]


@pytest.mark.parametrize("package", ["pincal.calibration", "pincal.identification", "pincal.io", "pincal.study"])
def test_a_lazy_package_loads_its_names_from_its_own_modules(package: str) -> None:
    """The names a lazy ``__init__`` holds as strings point inside the package (which test_architecture's reading
    of ``import`` statements cannot see), and each loads."""
    module = importlib.import_module(package)
    table: dict[str, str] = vars(module)["_LAZY"]
    for name, where in table.items():
        full = where if where.startswith("pincal.") else f"{package}.{where.lstrip('.')}"  # else relative to it
        assert full.startswith(f"{package}."), f"{package}.{name} loads from {full}"
        assert getattr(module, name) is getattr(importlib.import_module(full), name)


def test_pincal_re_exports_the_working_names_the_page_lists() -> None:
    import pincal

    listed = ["load_robot", "Robot", "read_dataset", "Dataset", "Position", "Pose", "Distance", "JointReading",
              "ParameterSet", "calibrate", "simulate", "CalibrationOptions", "CalibrationReport", "identify",
              "CalibrationResult", "analyse", "PincalError", "DataError", "ArgumentError"]
    for name in listed:
        assert name in pincal.__all__ and getattr(pincal, name) is not None, name


def _importers(library: str) -> set[str]:
    """The modules under pincal/ (relative paths) with an ``import`` of ``library`` or one of its modules."""
    found = set()
    for path in PACKAGE.rglob("*.py"):
        for node in ast.walk(ast.parse(path.read_text(encoding="utf-8"))):
            names = [a.name for a in node.names] if isinstance(node, ast.Import) else \
                [node.module or ""] if isinstance(node, ast.ImportFrom) and not node.level else []
            if any(n == library or n.startswith(f"{library}.") for n in names):
                found.add(str(path.relative_to(PACKAGE)))
    return found


def test_argparse_only_in_the_command_line() -> None:
    """"argparse and printing: one module per command group": no module outside ``cli/`` imports argparse."""
    importers = _importers("argparse")
    assert importers and all(p.startswith("cli/") for p in importers), importers


def test_rosbags_only_where_bags_are_read() -> None:
    """The ``io`` row: ``bags`` reads ROS bags through ``rosbags``, imported only there."""
    assert _importers("rosbags") == {"io/bags.py"}


def test_the_report_is_a_typed_schema_versioned_record() -> None:
    """The ``calibration`` row: ``CalibrationReport`` is a dataclass with typed fields, a ``schema_version``, and
    ``to_json``/``from_json``."""
    import dataclasses

    from pincal.calibration.report import CalibrationReport

    assert dataclasses.is_dataclass(CalibrationReport)
    names = {f.name for f in dataclasses.fields(CalibrationReport)}
    assert "schema_version" in names and callable(CalibrationReport.to_json) and callable(CalibrationReport.from_json)


PARAMETER_KIND = """
from pincal.identification.parameters import ParameterKind, parameter_kind
class Probe(ParameterKind):
    name = "probe_kind_of_the_architecture_test"
print(parameter_kind("probe_kind_of_the_architecture_test") is Probe)
"""


def test_a_parameter_kind_registers_itself() -> None:
    """The recipe for a new parameter kind: a ``ParameterKind`` subclass with its ``name`` registers itself (in an
    interpreter of its own, so that the registry of the other tests keeps its kinds)."""
    done = subprocess.run([sys.executable, "-P", "-c", PARAMETER_KIND], capture_output=True, text=True, timeout=120,
                          check=False)
    assert (done.returncode, done.stdout.strip()) == (0, "True"), done.stderr
