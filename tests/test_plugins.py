"""Plugins: a measurement kind defined only outside pincal (here, in a file the test writes) works through the
library and through ``pincal simulate``, ``calibrate`` and ``report`` run as a user runs them; a bad entry in
``PINCAL_PLUGINS`` is refused, naming it."""

from __future__ import annotations

import json
import os
import subprocess
import sys
from pathlib import Path

import numpy as np
import pytest
from conftest import PINCAL

import pincal
from pincal.errors import PluginError
from pincal.identification.measurements import KIND_CLASSES, KINDS, parse_key
from pincal.identification.parameters import choose_parameters
from pincal.identification.problem import CalibrationProblem, Observations
from pincal.io.dataset import MEASUREMENT_COMPONENTS, OCCLUDABLE_KINDS
from pincal.plugins import ENVIRONMENT, load_plugin, load_plugins, plugin_entries

#: A sensor pincal does not have: the height [m] of a frame's origin above the floor (the robot's world xy plane).
HEIGHT_KIND = '''
"""A height sensor: the height [m] of a frame's origin above the floor (the robot's world xy plane)."""

from __future__ import annotations

from dataclasses import dataclass
from typing import ClassVar

from pincal.identification.measurements import Measurement, SampleContext


@dataclass(frozen=True)
class Height(Measurement):
    kinds: ClassVar[tuple[str, ...]] = ("{kind}",)
    components: ClassVar[tuple[str, ...]] = ("h",)
    length_rows: ClassVar[int] = 1

    frame: str = ""

    @classmethod
    def from_key(cls, kind: str, rest: str, sigma: float | None) -> Measurement:
        return cls(f"{{kind}}:{{rest}}", 1, sigma or 1e-5, rest)

    @property
    def frames(self) -> tuple[str, ...]:
        return (self.frame,)

    def predict(self, ctx: SampleContext, out, jac) -> None:
        placement = ctx.placement(self.frame)
        out[0] = placement.translation[2]
        if jac is not None:  # the origin's world velocity is R v, v the local twist's linear part
            jac[0] = placement.rotation[2] @ ctx.twists[self.frame][:3]
'''


def write_kind(folder: Path, kind: str) -> Path:
    """The height sensor's module, for key kind ``kind``, written to ``folder``."""
    path = folder / f"{kind}_sensor.py"
    path.write_text(HEIGHT_KIND.format(kind=kind), encoding="utf-8")
    return path


def test_a_kind_from_a_file_registers_and_its_jacobian_matches_finite_differences(tmp_path: Path) -> None:
    load_plugins(str(write_kind(tmp_path, "height_lib")))
    try:
        assert "height_lib" in KINDS and "height_lib" in MEASUREMENT_COMPONENTS
        assert "height_lib" not in OCCLUDABLE_KINDS  # the registry's views see a kind declared after import
        model = parse_key("height_lib:tool0", 1e-5)
        assert (model.width, model.column_units, model.columns) == (1, ("m",), ("height_lib:tool0:h",))
        robot = pincal.load_robot("ur10")
        rng = np.random.default_rng(0)
        actuated = rng.uniform(-1.0, 1.0, (5, robot.n_actuated))
        problem = CalibrationProblem(robot, choose_parameters(robot, [model]), [model],
                                     Observations(actuated, {model.key: model.neutral(5)}))
        x = rng.normal(scale=1e-3, size=len(problem.parameters))
        pred = problem.evaluate(x)
        assert pred.jacobian is not None
        step = 1e-7
        numeric = np.column_stack([(problem.evaluate(x + step * e, jacobian=False).residual
                                    - problem.evaluate(x - step * e, jacobian=False).residual) / (2 * step)
                                   for e in np.eye(len(x))])
        np.testing.assert_allclose(pred.jacobian, numeric, rtol=1e-5, atol=1e-3)
    finally:
        KINDS.pop("height_lib", None)
        KIND_CLASSES.pop("height_lib", None)


def test_a_file_is_loaded_once_and_a_module_by_its_dotted_name(tmp_path: Path,
                                                                monkeypatch: pytest.MonkeyPatch) -> None:
    path = write_kind(tmp_path, "height_once")
    (tmp_path / "lab_sensors").mkdir()
    (tmp_path / "lab_sensors" / "__init__.py").write_text("LOADED = True\n", encoding="utf-8")
    monkeypatch.syspath_prepend(str(tmp_path))
    try:
        first = load_plugin(str(path))
        assert load_plugin(str(path)) is first
        monkeypatch.setenv(ENVIRONMENT, f"{path}{os.pathsep} {os.pathsep}lab_sensors")
        assert plugin_entries() == [str(path), "lab_sensors"]
        modules = load_plugins()
        assert modules[0] is first and modules[1].LOADED
    finally:
        KINDS.pop("height_once", None)
        KIND_CLASSES.pop("height_once", None)
        sys.modules.pop("lab_sensors", None)


@pytest.mark.parametrize(("entry", "culprit"), [
    ("missing_sensor.py", "plugin '{path}' is not an existing .py file or a dotted module name"),
    ("not a module", "plugin 'not a module' is not an existing .py file or a dotted module name"),
    ("pincal_no_such_plugin", "cannot import plugin 'pincal_no_such_plugin': ModuleNotFoundError"),
    ("broken.py", "plugin '{path}' failed to load: ZeroDivisionError: division by zero"),
])
def test_a_bad_entry_is_refused_naming_it(tmp_path: Path, entry: str, culprit: str) -> None:
    (tmp_path / "broken.py").write_text("1 / 0\n", encoding="utf-8")
    value = str(tmp_path / entry) if entry.endswith(".py") else entry
    with pytest.raises(PluginError) as caught:
        load_plugins(value)
    assert culprit.format(path=value) in str(caught.value) and caught.value.entry == value
    assert str(caught.value).startswith(f"{ENVIRONMENT}: ")


def run(args: list[str], plugins: str, cwd: Path) -> subprocess.CompletedProcess[str]:
    """``pincal ARGS`` in a subprocess with ``PINCAL_PLUGINS`` set to ``plugins``."""
    env = {**os.environ, ENVIRONMENT: plugins, "OPENBLAS_NUM_THREADS": "1"}
    return subprocess.run([str(PINCAL), *args], capture_output=True, text=True, timeout=300, env=env, cwd=cwd,
                          check=False)


def test_a_kind_defined_only_in_a_plugin_file_goes_through_simulate_calibrate_and_report(tmp_path: Path) -> None:
    plugin = str(write_kind(tmp_path, "height"))
    sim = run(["simulate", "ur10", "--measure", "height", "--samples", "60", "--test-samples", "20", "--seed", "2",
               "--out", "sim"], plugin, tmp_path)
    assert sim.returncode == 0, sim.stderr
    header = next(line for line in (tmp_path / "sim" / "measurements.csv").read_text().splitlines()
                  if not line.startswith("#"))
    assert header.endswith(",height:tool0:h")
    cal = run(["calibrate", "ur10", "sim/measurements.csv", "--report", "result.json"], plugin, tmp_path)
    assert cal.returncode == 0, cal.stderr
    result = json.loads((tmp_path / "result.json").read_text())
    assert result["test_rms_after"] < 0.02 * result["test_rms_before"], cal.stdout  # held out: 2.6 mm -> 0.015 mm
    report = run(["report", "ur10", "sim/measurements.csv", "--out", "report.html", "--truth", "sim/truth.json"],
                 plugin, tmp_path)
    assert report.returncode == 0, report.stderr
    assert (tmp_path / "report.html").stat().st_size > 10_000 and "held out" in report.stdout
    without = run(["calibrate", "ur10", "sim/measurements.csv"], "", tmp_path)  # no plugin: the kind is unknown
    assert without.returncode == 2 and "unknown kind 'height'" in without.stderr
