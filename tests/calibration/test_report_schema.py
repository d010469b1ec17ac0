"""The report JSON's schema: a report written by an earlier pincal (``data/report_v1/report.json``, written by
``pincal calibrate panda measurements.csv --cv 3 --report report.json`` at main 2282474) read back into the typed
report, its sections typed, written again byte for byte; older reports lacking keys read with their defaults; newer
ones and malformed sections refused with the culprit named."""

from __future__ import annotations

import copy
import json
from pathlib import Path
from typing import Any

import pytest
from conftest import run_pincal

from pincal.calibration.growth import ErrorGrowth
from pincal.calibration.report import SCHEMA_VERSION, CalibrationReport
from pincal.calibration.report_sections import (
    BadJointReading,
    CameraRecord,
    CrossValidation,
    DownWeighted,
    DroppedSample,
    EstimatedSigma,
    FileDigest,
    HeldOutPredictions,
    ImplausibleCorrection,
    ImplausibleScale,
    ModelSelection,
    OutsideRange,
    ParameterEstimate,
    PixelErrors,
    PixelPredictions,
    PredictedImage,
    PredictedSample,
    ProvenanceRecord,
    RangeGuard,
    SampleError,
    WorkspacePrediction,
)
from pincal.errors import DataError
from pincal.identification.corrections import Payload

FIXTURE = Path(__file__).parent / "data" / "report_v1"
TEXT = (FIXTURE / "report.json").read_text(encoding="utf-8")
RAW: dict[str, Any] = json.loads(TEXT)


def test_fixture_is_of_this_schema() -> None:
    """The fixture was written by a pincal of this schema version (a new version commits a fixture of its own)."""
    assert RAW["schema_version"] == SCHEMA_VERSION == 1


def test_older_report_round_trips_byte_for_byte() -> None:
    """Read into the typed report and written again, the earlier pincal's report is the same text."""
    report = CalibrationReport.read(FIXTURE / "report.json")
    assert report.to_json() == TEXT


def test_the_fields_a_calibrated_urdf_carries_are_the_whole_json_s() -> None:
    """``as_dict(keys)`` (what ``<pincal_calibration>`` holds) is the whole JSON's content under those keys, in field
    order; a key the report leaves out (an optional field at None) stays out."""
    from pincal.calibration.carried import CARRIED

    report = CalibrationReport.read(FIXTURE / "report.json")
    whole = report.as_dict()
    carried = report.as_dict(CARRIED)
    assert carried == {key: value for key, value in whole.items() if key in CARRIED}
    assert set(carried) < set(CARRIED) and "parameters" in carried and "n_samples" not in carried
    assert report.as_dict(["no_such_field"]) == {}


def test_sections_are_typed() -> None:
    """Each nested part read is its record, holding the file's values under its fields."""
    report = CalibrationReport.read(FIXTURE / "report.json")
    assert list(report.parameters) == list(RAW["parameters"])
    for name, entry in RAW["parameters"].items():
        estimate = report.parameters[name]
        assert isinstance(estimate, ParameterEstimate)
        assert (estimate.value, estimate.std, estimate.identified) == (entry["value"], entry["std"],
                                                                       entry["identified"])
    cv = report.cv
    assert isinstance(cv, CrossValidation)
    assert (cv.plan, cv.n_samples, cv.n_predictions, cv.rms, cv.failed_folds, cv.unconverged_folds, cv.rms_angle) \
        == tuple(RAW["cv"][key] for key in ("plan", "n_samples", "n_predictions", "rms", "failed_folds",
                                            "unconverged_folds", "rms_angle"))
    assert cv.rms_by_reading is None and "rms_by_reading" not in RAW["cv"]
    selection, raw = report.selection, RAW["selection"]
    assert isinstance(selection, ModelSelection) and isinstance(selection.guard, RangeGuard)
    assert (selection.policy, selection.removed, selection.removed_groups, selection.n_candidates,
            selection.prior_factors, selection.prior) \
        == tuple(raw[key] for key in ("policy", "removed", "removed_groups", "n_candidates", "prior_factors", "prior"))
    assert (selection.guard.firmer, selection.guard.nominal_beyond, selection.guard.scores) \
        == (raw["guard"]["firmer"], raw["guard"]["nominal_beyond"], raw["guard"]["scores"])


def test_predictions_are_typed() -> None:
    """The per-sample errors, the held-out and workspace predictions and the bound's growth are their records."""
    report = CalibrationReport.read(FIXTURE / "report.json")
    assert all(isinstance(e, SampleError) and not e.imaged for e in report.sample_errors)
    assert [(e.sample, e.set, e.before, e.after) for e in report.sample_errors] \
        == [(e["sample"], e["set"], e["before"], e["after"]) for e in RAW["sample_errors"]]
    held, raw = report.predicted_held_out, RAW["predicted_held_out"]
    assert isinstance(held, HeldOutPredictions) and held.in_range is not None and held.beyond_range is not None
    assert (held.inside, held.samples, held.beyond, held.in_range.samples, held.beyond_range.inside) \
        == (raw["inside"], raw["samples"], raw["beyond"], raw["in_range"]["samples"], raw["beyond_range"]["inside"])
    assert [PredictedSample(**p) for p in raw["samples_predicted"]] == held.samples_predicted
    space = report.predicted_workspace
    assert isinstance(space, WorkspacePrediction)
    assert (space.postures, space.positions, space.max_bound) == tuple(RAW["predicted_workspace"][key] for key in (
        "postures", "positions", "max_bound"))
    assert report.error_growth == ErrorGrowth(**RAW["error_growth"])


def test_pixel_errors_written_when_imaged() -> None:
    """A sample's pixel errors are written, None or not, when the calibration read pixels, and not otherwise."""
    seen = {"sample": "3", "set": "test", "before": None, "after": None, "pixel_before": 1.5, "pixel_after": None}
    report = CalibrationReport.from_json({**RAW, "sample_errors": [seen, {**RAW["sample_errors"][0]}]})
    assert report.sample_errors[0].imaged and not report.sample_errors[1].imaged
    assert json.loads(report.to_json())["sample_errors"] == [seen, RAW["sample_errors"][0]]


def test_sample_accounts_are_typed() -> None:
    """The samples dropped, down-weighted, left out as bad joint readings and held out beyond the fitted range (the
    account of a file with such samples, as 'pincal calibrate' writes it) are read into their records and written
    back as they were."""
    accounts = {
        "dropped_samples": [{"sample": "3", "reason": "joint 'panda_joint1' reads 5 rad, outside its URDF limits"}],
        "down_weighted": [{"sample": "7", "weight": 0.0, "error_after": 0.1527},
                          {"sample": "12", "weight": 1.52e-05, "error_after": None}],
        "bad_readings": [{"sample": "7", "joint": "panda_joint3", "off": 0.3, "unit": "rad", "explained": 0.9999}],
        "dropped_test_samples": [{"sample": "31", "reason": "outside its URDF limits"}],
        "held_out_outside_range": [{"sample": "15", "joint": "panda_joint5", "value": -2.54, "range": [-1.7, 2.6]}]}
    report = CalibrationReport.from_json({**RAW, **accounts})
    assert report.dropped_samples == [DroppedSample(**accounts["dropped_samples"][0])]
    assert report.down_weighted[1] == DownWeighted("12", 1.52e-05, None)
    assert report.bad_readings == [BadJointReading("7", "panda_joint3", 0.3, "rad", 0.9999)]
    assert report.dropped_test_samples == [DroppedSample("31", "outside its URDF limits")]
    assert report.held_out_outside_range == [OutsideRange("15", "panda_joint5", -2.54, [-1.7, 2.6])]
    written = json.loads(report.to_json())
    assert {key: written[key] for key in accounts} == accounts


def test_payload_is_the_payload() -> None:
    """The payload a calibration with compliances records is read as the :class:`Payload` it was given as, and
    written back as it was."""
    recorded = {"mass": 2.0, "frame": "panda_link7", "offset": [0.0, 0.0, 0.05]}
    report = CalibrationReport.from_json({**RAW, "payload": recorded})
    assert report.payload == Payload(2.0, "panda_link7", (0.0, 0.0, 0.05))
    assert json.loads(report.to_json())["payload"] == recorded


def test_estimated_sigma_is_typed() -> None:
    """The σ estimated from data without '# sigma' lines (none in the fixture) is read per measurement into its record;
    the kinds not estimated stay out of the JSON written back."""
    estimated = {"position:panda_hand": {"rows": {"x": 3.4e-4, "y": 5.0e-4, "z": 5.2e-4},
                                         "units": {"x": "m", "y": "m", "z": "m"}, "length": 4.6e-4}}
    report = CalibrationReport.from_json({**RAW, "estimated_sigma": estimated})
    assert report.estimated_sigma == {"position:panda_hand": EstimatedSigma(
        {"x": 3.4e-4, "y": 5.0e-4, "z": 5.2e-4}, {"x": "m", "y": "m", "z": "m"}, 4.6e-4, None)}
    assert json.loads(report.to_json())["estimated_sigma"] == estimated


def test_pixel_figures_are_typed() -> None:
    """A camera calibration's reprojection RMS, fitted and held out (none in the fixture), is read into its record."""
    report = CalibrationReport.from_json({**RAW, "pixels": {"rms_before": 2.075, "rms_after": 0.431},
                                          "test_pixels": {"rms_before": None, "rms_after": 0.434}})
    assert report.pixels == PixelErrors(2.075, 0.431) and report.test_pixels == PixelErrors(None, 0.434)
    written = json.loads(report.to_json())
    assert (written["pixels"], written["test_pixels"]) == ({"rms_before": 2.075, "rms_after": 0.431},
                                                           {"rms_before": None, "rms_after": 0.434})


def test_cameras_and_predicted_images_are_typed() -> None:
    """A camera calibration's intrinsics per camera and its held-out images' predicted bounds are records, written back
    as the JSON held them, key for key and in order."""
    cameras = {"intrinsics.tool0": {"frame": "tool0", "board": "charuco:8x6:0.03:0.022:DICT_4X4_50", "held": False,
                                    "intrinsics": {"fx": 998.97, "fy": 1001.4, "cx": 649.99, "cy": 476.4, "k1": -0.12,
                                                   "k2": 0.19, "p1": -2e-05, "p2": 0.0008, "k3": 0.0031},
                                    "std": {"fx": 1.02, "fy": 1.01, "cx": 0.8, "cy": 0.7, "k1": 0.002, "k2": 0.01,
                                            "p1": None, "p2": None, "k3": 0.02}}}
    pixels = {"level": 0.95, "unit": "px", "inside": 1, "images": 2, "median_bound": 0.81, "median_model_bound": 0.68,
              "median_bound_at_board": 0.00063,
              "images_predicted": [{"sample": "0012", "pixel_error": 0.54, "pixel_bound": 0.89,
                                    "pixel_model_bound": 0.78, "pixel_bound_at_board": 0.00047},
                                   {"sample": "0013", "pixel_error": None, "pixel_bound": None,
                                    "pixel_model_bound": None, "pixel_bound_at_board": None}]}
    held = {**RAW["predicted_held_out"], "pixels": pixels} if RAW.get("predicted_held_out") else {"pixels": pixels}
    report = CalibrationReport.from_json({**RAW, "cameras": cameras, "predicted_held_out": held})
    assert report.cameras is not None and report.predicted_held_out is not None
    camera = report.cameras["intrinsics.tool0"]
    assert isinstance(camera, CameraRecord) and camera.frame == "tool0" and camera.intrinsics["fx"] == 998.97
    assert camera.std["p1"] is None and not camera.held
    predicted = report.predicted_held_out.pixels
    assert isinstance(predicted, PixelPredictions) and (predicted.inside, predicted.images) == (1, 2)
    assert predicted.images_predicted[0] == PredictedImage("0012", 0.54, 0.89, 0.78, 0.00047)
    written = report.to_json()
    assert json.dumps(json.loads(written)["cameras"]) == json.dumps(cameras)
    assert json.dumps(json.loads(written)["predicted_held_out"]["pixels"]) == json.dumps(pixels)
    assert CalibrationReport.from_json(json.loads(written)).to_json() == written


def test_provenance_is_typed() -> None:
    """The provenance: the pincal version, the robot and data files with their SHA-256, the options."""
    report = CalibrationReport.read(FIXTURE / "report.json")
    provenance, raw = report.provenance, RAW["provenance"]
    assert isinstance(provenance, ProvenanceRecord) and provenance.robot is not None
    assert (provenance.pincal_version, provenance.robot.file, provenance.robot.sha256) \
        == (raw["pincal_version"], raw["robot"]["file"], raw["robot"]["sha256"])
    assert provenance.data == [FileDigest(d["file"], d["sha256"]) for d in raw["data"]]
    assert provenance.options == raw["options"] and provenance.as_dict() == raw


def test_missing_keys_take_defaults() -> None:
    """A report older still, without the keys later versions added (here a section's optional and defaulted keys and
    whole top-level parts), is read with their defaults and written without the optional ones."""
    older = copy.deepcopy(RAW)
    for key in ("provenance", "predicted_held_out", "error_growth", "selection", "sample_errors"):
        del older[key]
    del older["cv"]["rms_angle"], older["cv"]["unconverged_folds"]
    for entry in older["parameters"].values():
        del entry["identified"]
    report = CalibrationReport.from_json(older)
    assert report.provenance is None and report.sample_errors == []
    assert report.cv is not None and report.cv.rms_angle is None and report.cv.unconverged_folds == 0
    assert not any(estimate.identified for estimate in report.parameters.values())
    written = json.loads(report.to_json())
    assert "provenance" not in written and "rms_angle" not in written["cv"]
    assert "provenance" not in report.present and "cv" in report.present


def test_implausible_entries_typed() -> None:
    """An implausible correction and scale (none in the fixture) are read into their records and written back."""
    entry = {"parameter": "panda_joint5.tx", "kind": "joint", "value": -0.0335, "fitted": -0.0443, "limit": 0.02,
             "unit": "m"}
    scale = {"measurement": "position:panda_hand", "scale": 3.28, "limit": 1.2}
    report = CalibrationReport.from_json({**RAW, "implausible": [entry], "implausible_scale": [scale]})
    assert report.implausible == [ImplausibleCorrection(**entry)] and report.is_implausible
    assert report.implausible_scale == [ImplausibleScale(**scale)]
    written = json.loads(report.to_json())
    assert (written["implausible"], written["implausible_scale"]) == ([entry], [scale])


def test_newer_schema_refused() -> None:
    newer = {**RAW, "schema_version": SCHEMA_VERSION + 1}
    with pytest.raises(DataError, match=f"schema_version {SCHEMA_VERSION + 1}, newer than this pincal reads"):
        CalibrationReport.from_json(newer)


@pytest.mark.parametrize(("part", "value", "culprit"), [
    ("cv", [1, 2], r"the result JSON's 'cv' is not a JSON object"),
    ("cv", {"rms": 0.1}, r"the result JSON's 'cv' has no 'plan'"),
    ("selection", {**RAW["selection"], "guard": 3}, r"the result JSON's 'selection'\['guard'\] is not a JSON object"),
    ("parameters", {"base.x": {"value": 0.0}, "base.y": 2}, r"'parameters'"),
    ("implausible", [{"parameter": "base.x", "kind": "base"}], r"the result JSON's 'implausible'\[0\] has no 'value'"),
    ("implausible_scale", {"position": 3.3}, r"the result JSON's 'implausible_scale' is not a JSON list"),
    ("payload", {"mass": 2.0}, r"the result JSON's 'payload': payload \{'mass': 2.0\} is not"),
    ("error_growth", {"rho0": 1.0}, r"the result JSON's 'error_growth' is not an object of numbers"),
    ("predicted_held_out", {**RAW["predicted_held_out"], "samples_predicted": [{"bound": 0.1}]},
     r"'predicted_held_out'\['samples_predicted'\]\[0\] has no 'sample'"),
])
def test_malformed_section_named(part: str, value: Any, culprit: str) -> None:
    """A nested part that is not of its record's form: a DataError naming the part and what is wrong."""
    with pytest.raises(DataError, match=culprit):
        CalibrationReport.from_json({**RAW, part: value})


def test_older_report_drawn_by_the_command(tmp_path: Path) -> None:
    """``pincal report --result`` reads the earlier pincal's report as a user runs it: its page shows the
    cross-validation the report holds and every parameter."""
    page = tmp_path / "page.html"
    done = run_pincal("report", "panda", str(FIXTURE / "measurements.csv"), "--result", str(FIXTURE / "report.json"),
                      "--out", str(page), "--quiet")
    assert done.returncode == 0, done.stderr
    text = page.read_text(encoding="utf-8")
    assert f"cross-validated, {RAW['cv']['plan']}, {RAW['cv']['n_samples']} samples" in text
    assert all(f"<td>{name}</td>" in text for name in RAW["parameters"])


def test_malformed_report_refused_by_the_command(tmp_path: Path) -> None:
    """A report JSON whose part is malformed: 'pincal report --result' stops with one line naming the file and the
    part, exit 2, no traceback."""
    bad = tmp_path / "bad.json"
    bad.write_text(json.dumps({**RAW, "cv": {"rms": 0.1}}), encoding="utf-8")
    done = run_pincal("report", "panda", str(FIXTURE / "measurements.csv"), "--result", str(bad),
                      "--out", str(tmp_path / "page.html"), "--quiet")
    assert done.returncode == 2 and "Traceback" not in done.stderr
    assert done.stderr.strip().splitlines() == [
        f"pincal: error: the result JSON '{bad}''s 'cv' has no 'plan': expected a report written by 'pincal "
        "calibrate --report'"]
    assert not (tmp_path / "page.html").exists()
