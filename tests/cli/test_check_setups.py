"""``pincal check`` on measurement setups beyond a tracker and one marker: contact with a plane fixed on a robot frame
(``plane:<frame>@<support>``) and markers declared on a frame (``position:<frame>@<marker>``, fitted each or as a
cluster).

Each is calibrated on its ``set=train`` rows and checked on its ``set=test`` rows as a user runs it: the calibrated
URDF as it stands reproduces the calibration's held-out "after" figures, the report JSON is the same model as the
URDF, ``--register`` re-estimates the setup (the plane, the markers, the measurement frame) and lowers them, and the
samples left out are listed, not lost.
"""

from __future__ import annotations

import hashlib
import json
from pathlib import Path

import numpy as np
import pytest
from conftest import run_pincal

import pincal
from pincal.identification.measurements import position
from pincal.identification.parameters import choose_parameters
from pincal.io.dataset import Dataset, write_dataset
from pincal.study.simulation import perturbation, random_actuated, simulate_observations

NOISE = 1e-5  # [m, rad] per reading row, as simulated
EXAMPLES = Path(__file__).resolve().parents[2] / "examples" / "data"
#: Three markers on the UR10's tool0 at declared nominal offsets [m], a rigid cluster a few cm across.
MARKERS = {"m1": (0.06, 0.0, 0.03), "m2": (-0.04, 0.05, 0.01), "m3": (0.0, -0.05, 0.07)}
#: The held-out row that sees no marker at all.
BLIND = "31"


def _ok(done: object) -> None:
    assert done.returncode == 0, done.stdout + done.stderr  # type: ignore[attr-defined]


def _check(*args: str, code: int = 0) -> dict:
    """``pincal check ARGS --report`` (beside MODEL): its exit status checked, its report read, its stdout kept."""
    report = Path(args[0]).parent / f"check-{hashlib.sha1(' '.join(args).encode()).hexdigest()[:8]}.json"
    done = run_pincal("check", *args, "--report", str(report))
    assert done.returncode == code, done.stdout + done.stderr
    content = json.loads(report.read_text(encoding="utf-8"))
    content["stdout"] = done.stdout
    return content


def _calibrated(data: Path, robot: str, *options: str) -> dict:
    """``pincal calibrate ROBOT DATA --out cal.urdf --report r.json`` beside DATA; the report read."""
    _ok(run_pincal("calibrate", robot, str(data), *options, "--out", str(data.parent / "cal.urdf"), "--report",
                   str(data.parent / "r.json")))
    return json.loads((data.parent / "r.json").read_text(encoding="utf-8"))


def _same_model(a: dict, b: dict) -> None:
    """Two checks of the same data give the same figures [m, rad]."""
    keys = [k for k in ("rms", "max", "nominal_rms", "nominal_max", "rms_angle", "max_angle") if k in a or k in b]
    for key in keys:
        assert a[key] == pytest.approx(b[key], rel=1e-9, abs=1e-15), key
    assert [s.get("error") for s in a["samples"]] == pytest.approx([s.get("error") for s in b["samples"]], rel=1e-9)


def _held_out_after(out: dict, calibration: dict) -> None:
    """MODEL as it stands on the calibration's held-out rows: the calibration's own held-out 'after' figures."""
    assert out["n_samples"] == calibration["n_test_samples"]
    assert out["rms"] == pytest.approx(calibration["test_rms_after"], rel=1e-9)
    assert out["max"] == pytest.approx(calibration["test_max_after"], rel=1e-9)
    if calibration.get("test_rms_angle_after") is not None:
        assert out["rms_angle"] == pytest.approx(calibration["test_rms_angle_after"], rel=1e-9)
        assert out["max_angle"] == pytest.approx(calibration["test_max_angle_after"], rel=1e-9)


@pytest.mark.parametrize(("key", "support"), [("plane:tool0@forearm_link", "forearm_link"),
                                              ("plane_point:tool0@base_link", "base_link")])
def test_a_plane_fixed_on_a_robot_frame(key: str, support: str, tmp_path: Path) -> None:
    """A plane carried by a link of the robot (``<support>_plane`` in the calibrated URDF): the calibrated URDF and
    the report JSON reproduce calibrate's held-out figures as they stand; ``--register`` re-estimates that plane only;
    a MODEL without the link is refused in one line naming it."""
    _ok(run_pincal("simulate", "ur10", "--measure", key, "--samples", "30", "--test-samples", "12", "--seed", "3",
                   "--out", str(tmp_path), "--quiet"))
    data = tmp_path / "measurements.csv"
    calibration = _calibrated(data, "ur10")
    urdf = _check(str(tmp_path / "cal.urdf"), str(data), "--set", "test")
    _held_out_after(urdf, calibration)
    assert urdf["setup"]["parameters"] == [f"plane.{support}.{c}" for c in ("tz", "rx", "ry")]
    assert urdf["nominal_rms"] > 30 * urdf["rms"]
    _same_model(_check(str(tmp_path / "r.json"), str(data), "--set", "test"), urdf)
    registered = _check(str(tmp_path / "cal.urdf"), str(data), "--set", "test", "--register")
    assert registered["setup"]["model_converged"] is True and registered["setup"]["nominal_converged"] is True
    assert registered["rms"] < 3 * NOISE and registered["nominal_rms"] > 30 * registered["rms"]
    _same_model(_check(str(tmp_path / "r.json"), str(data), "--set", "test", "--register"), registered)
    text = (tmp_path / "cal.urdf").read_text(encoding="utf-8")
    assert f'"{support}_plane"' in text
    (tmp_path / "bare.urdf").write_text(text.replace(f'"{support}_plane"', '"other_plane"'), encoding="utf-8")
    done = run_pincal("check", str(tmp_path / "bare.urdf"), str(data), "--nominal", "ur10")
    lines = done.stderr.strip().splitlines()
    assert done.returncode == 2 and len(lines) == 1 and lines[0].startswith("pincal: error: "), done.stderr
    assert f"'{support}_plane'" in lines[0] and "--register" in lines[0]


@pytest.fixture(scope="module")
def markers(tmp_path_factory: pytest.TempPathFactory) -> Path:
    """A UR10 with the three :data:`MARKERS` on tool0, moved together from their declared offsets (the true robot
    off by 1 mm / 1 mrad, the cluster's placement included), 30 + 10 postures, 10 µm noise; a fifth of the readings
    not seen and held-out row :data:`BLIND` seeing none. Returns the CSV (set=train, set=test rows)."""
    robot = pincal.load_robot("ur10")
    models = [position("tool0", marker=m, nominal=n) for m, n in MARKERS.items()]
    rng = np.random.default_rng(21)
    parameters = choose_parameters(robot, models, None, "cluster")
    truth = perturbation(parameters, 1e-3, rng)
    actuated, _ = random_actuated(robot, 40, rng)
    observed = simulate_observations(robot, parameters, truth, models, actuated, rng, noise=NOISE)
    unseen = rng.random((40, 3)) < 0.2
    unseen[unseen.all(axis=1), 0] = False
    unseen[int(BLIND)] = True
    for j, m in enumerate(models):
        observed.values[m.key][unseen[:, j]] = np.nan
    metadata = {"robot": "ur10", "units": "SI (m, rad)",
                **{f"marker {m} on tool0": " ".join(repr(v) for v in n) for m, n in MARKERS.items()}}
    dataset = Dataset(list(robot.actuated_joints), observed.actuated, observed.values, [str(k) for k in range(40)],
                      ["train"] * 30 + ["test"] * 10, metadata)
    path = tmp_path_factory.mktemp("markers") / "markers.csv"
    write_dataset(dataset, path)
    return path


@pytest.mark.parametrize("fit", ["each", "cluster"])
def test_markers_on_a_frame(fit: str, markers: Path, tmp_path: Path) -> None:
    """Declared markers calibrated with ``--markers each|cluster``: on the held-out rows, MODEL as it stands gives
    calibrate's held-out figures, each marker counted by the readings taken and the row that saw no marker listed on
    both sides; the report JSON is the URDF's model, also on data that declare no nominal offsets (the report records
    those of its calibration); ``--register`` re-estimates the frame and the markers."""
    data = tmp_path / "markers.csv"
    data.write_bytes(markers.read_bytes())
    calibration = _calibrated(data, "ur10", "--markers", fit)
    assert calibration["declared_markers"] == {f"tool0@{m}": list(n) for m, n in MARKERS.items()}
    urdf = _check(str(tmp_path / "cal.urdf"), str(data), "--set", "test")
    _held_out_after(urdf, calibration)
    assert {q["measurement"]: q["n"] for q in urdf["quantities"]} == calibration["test_readings"]
    assert [d["sample"] for d in urdf["dropped_samples"]] == [BLIND, BLIND]
    assert all("not seen" in d["reason"] for d in urdf["dropped_samples"])
    assert urdf["nominal_rms"] > 30 * urdf["rms"]
    _same_model(_check(str(tmp_path / "r.json"), str(data), "--set", "test"), urdf)
    undeclared = tmp_path / "undeclared.csv"  # the same rows, their '# marker' lines left out
    undeclared.write_text("".join(line for line in data.read_text(encoding="utf-8").splitlines(keepends=True)
                                  if not line.startswith("# marker")), encoding="utf-8")
    as_urdf = _check(str(tmp_path / "cal.urdf"), str(undeclared), "--set", "test")
    assert as_urdf["rms"] == pytest.approx(urdf["rms"], rel=1e-9)  # MODEL's markers are its links
    _same_model(_check(str(tmp_path / "r.json"), str(undeclared), "--set", "test"), as_urdf)
    registered = _check(str(tmp_path / "r.json"), str(data), "--set", "test", "--register")
    assert registered["setup"]["model_converged"] is True
    assert {f"marker.tool0@{m}.x" for m in MARKERS} <= set(registered["setup"]["parameters"])
    assert registered["rms"] <= urdf["rms"] and registered["nominal_rms"] > 30 * registered["rms"]


def test_tiago_three_markers_checked_on_its_held_out_rows(tmp_path: Path) -> None:
    """Real data: the TIAGo's three mocap markers, calibrated on the set=train postures, checked on the six set=test
    ones: as it stands, calibrate's held-out figures; with the mocap frame and the markers re-estimated on those six
    the errors can only be lower, and the nominal robot registered the same way stays worse."""
    data = tmp_path / "markers.csv"
    data.write_bytes((EXAMPLES / "tiago_mocap_markers.csv").read_bytes())
    calibration = _calibrated(data, "tiago_no_hand")
    as_is = _check(str(tmp_path / "cal.urdf"), str(data), "--set", "test")
    _held_out_after(as_is, calibration)
    assert {q["measurement"]: q["n"] for q in as_is["quantities"]} == calibration["test_readings"]
    registered = _check(str(tmp_path / "r.json"), str(data), "--set", "test", "--register")
    assert registered["setup"]["model_converged"] is True
    assert registered["rms"] <= as_is["rms"] and registered["rms"] < registered["nominal_rms"]


def test_the_help_names_the_setup_the_parameter_kinds_declare() -> None:
    """``pincal check --help`` names the setup a calibrated URDF holds in the words the parameter kinds declare
    (``setup_words`` of the setup kinds a URDF holds): a kind added there shows in the help, or this fails."""
    from pincal.cli.check_data import SETUP_HELD
    from pincal.identification.parameters.kinds import kinds_where, setup_phrase

    assert setup_phrase(kinds_where(setup=True, in_urdf=True)) == SETUP_HELD
    done = run_pincal("check", "--help")
    assert done.returncode == 0, done.stderr
    shown = " ".join(done.stdout.split())
    assert f"its {SETUP_HELD} as the file holds them" in shown
    assert f"re-estimate the measurement setup ({SETUP_HELD}) of both robots" in shown
