"""A command's own options in library errors: the library names each by its keyword (``poses=8``, with the error's
``option`` field), the command line shows the flag the user typed (``--poses 8``)."""

from __future__ import annotations

from pathlib import Path

import pytest
from conftest import ROOT, run_pincal

import pincal
from pincal.calibration.design import design_poses
from pincal.calibration.drift import check_level
from pincal.calibration.iso9283_plan import plan_test
from pincal.cli.app import build_parser
from pincal.cli.arguments import command_flags, in_flags
from pincal.cli.planning import cmd_design
from pincal.errors import DataError, NotFoundError


def test_a_command_s_flags_are_read_from_its_parser() -> None:
    from pincal.cli.iso_commands import cmd_plan

    design = command_flags(build_parser(), cmd_design)
    assert (design["candidates"], design["poses"], design["out"]) == ("--candidates", "--poses", "--out")
    assert command_flags(build_parser(), cmd_plan)["min_side"] == "--min-side"  # a subcommand's subcommand
    assert command_flags(build_parser(), print) == {}


def test_a_keyword_becomes_the_flag_only_for_options_the_command_has() -> None:
    flags = {"poses": "--poses", "targets_in": "--targets-in"}
    assert in_flags("poses=8: too few; targets_in='board': no board; frame=NAME", flags) == \
        "--poses 8: too few; --targets-in board: no board; frame=NAME"
    assert in_flags("select='bic', poses=8") == "--select bic, poses=8"  # calibration options are always known


def test_design_names_candidates_and_poses_by_keyword() -> None:
    robot = pincal.load_robot("five_bar")
    with pytest.raises(DataError, match=r"^candidates=100000000: pincal draws at most ") as caught:
        design_poses(robot, ["position"], None, None, 100_000_000, 3)
    assert caught.value.option == "candidates"
    with pytest.raises(DataError, match=r"^cannot choose poses=5 of candidates=3 candidate postures: need "
                                        r"1 <= poses <= candidates$") as caught:
        design_poses(robot, ["position"], None, None, 3, 5)
    assert caught.value.option == "poses"


def test_drift_level_and_iso9283_orientation_and_frame_by_keyword() -> None:
    with pytest.raises(DataError, match=r"^level=0\.7: the chance of a false alarm") as caught:
        check_level(0.7)
    assert caught.value.option == "level"
    delta = pincal.load_robot("delta")
    with pytest.raises(DataError, match=r"^orientation=1,0,0,0: 'delta' has 3 degrees of freedom") as caught:
        plan_test(delta, orientation=(1.0, 0.0, 0.0, 0.0))
    assert caught.value.option == "orientation"
    with pytest.raises(NotFoundError, match=r"^frame 'nowhere' does not exist in robot 'delta'") as caught:
        plan_test(delta, frame="nowhere")
    assert caught.value.option == "frame"


def test_the_command_line_shows_the_flags(tmp_path: Path) -> None:
    done = run_pincal("iso9283", "plan", "delta", "--orientation", "1,0,0,0", "--out", str(tmp_path / "p.csv"))
    assert done.returncode == 2 and done.stderr.splitlines() == [
        "pincal: error: --orientation 1,0,0,0: 'delta' has 3 degrees of freedom, so the orientation of its frame is "
        "not commanded; plan without it"], done.stderr
    assert not (tmp_path / "p.csv").exists()


def test_filter_names_its_frames_by_keyword_and_the_command_line_by_flag(tmp_path: Path) -> None:
    from pincal.calibration.program_filter import default_frames

    ur10 = pincal.load_robot("ur10")
    with pytest.raises(NotFoundError, match=r"^base=nowhere: frame 'nowhere' does not exist in robot 'ur10'") as caught:
        default_frames(ur10, "urscript", base="nowhere")
    assert caught.value.option == "base"
    with pytest.raises(NotFoundError, match=r"^flange=nowhere: frame 'nowhere' does not exist") as caught:
        default_frames(ur10, "urscript", flange="nowhere")
    assert caught.value.option == "flange"
    program = ROOT / "examples" / "data" / "programs" / "pick_place.script"
    out = tmp_path / "out.script"
    for flag in ("--base-frame", "--flange"):
        done = run_pincal("filter", str(program), "--model", "ur10", flag, "nowhere", "--out", str(out))
        assert done.returncode == 2 and done.stderr.startswith(
            f"pincal: error: {flag} nowhere: frame 'nowhere' does not exist in robot 'ur10'; frames are: ") and \
            done.stderr.count("\n") == 1, done.stderr
    assert not out.exists()


def test_plausible_off_is_a_keyword_to_the_library() -> None:
    from pincal.calibration.samples import _scale_message

    message = _scale_message("position:tool0", 1.0, 0.1, {}, 3.0)
    assert message.endswith("(a wrong unit, or a robot of another size; plausible=F widens the 3× band, "
                            "plausible='off' keeps only 30×)")
    assert in_flags(message).endswith("; --plausible F widens the 3× band, --plausible off keeps only 30×)")


def test_meshes_copy_is_a_keyword_to_the_library(tmp_path: Path) -> None:
    from pincal.io.mesh_files import plan_meshes

    text = ("<robot name='arm'><link name='base'><visual><geometry><mesh filename='package://nowhere/base.stl'/>"
            "</geometry></visual></link></robot>")
    with pytest.raises(NotFoundError, match=r"^meshes='copy': mesh 'package://nowhere/base.stl' is not found on this "
                                            r"machine; give ROS_PACKAGE_PATH, or use meshes='keep'$") as caught:
        plan_meshes(text, tmp_path, tmp_path / "out" / "cal.urdf", "copy")
    assert caught.value.option == "meshes"


def test_check_names_its_arguments_by_keyword() -> None:
    import numpy as np

    from pincal.calibration.check import rows_of_set
    from pincal.cli.check_data import cmd_check
    from pincal.io.dataset import Dataset

    trained = Dataset(["j1"], np.zeros((2, 1)), {}, ["a", "b"], ["train", "train"])
    with pytest.raises(DataError, match=r"^DATA 'd.csv' has no set=test row \(train 2\): .* or leave rows out to "
                                        r"check every row$") as caught:
        rows_of_set(trained, "test", "d.csv")
    assert caught.value.option == "rows"
    flags = command_flags(build_parser(), cmd_check)
    assert (flags["nominal_path"], flags["rows"], flags["register"]) == ("--nominal", "--set", "--register")
    assert in_flags("check with register=True; nominal_path=ROBOT; no set=test row", flags) == \
        "check with --register; --nominal ROBOT; no set=test row"


def test_markers_cluster_on_a_job_file_is_a_keyword_to_the_library_and_a_flag_to_the_user(tmp_path: Path) -> None:
    from pincal.calibration.from_files import read_inputs
    from pincal.calibration.options import GivenOptions
    from pincal.errors import PincalError

    job = tmp_path / "job.toml"
    job.write_text("robot = 'five_bar'\n", encoding="utf-8")
    with pytest.raises(PincalError, match=r"^calibrate: markers='cluster' applies to a dataset named on the command "
                                          r"line, not yet to a job file$") as caught:
        read_inputs("calibrate", str(job), None, GivenOptions.of({"markers": "cluster"}))
    assert caught.value.option == "markers"
    done = run_pincal("calibrate", str(job), "--markers", "cluster")
    assert done.returncode == 2 and done.stderr == "pincal: error: calibrate: --markers cluster applies to a dataset " \
                                                   "named on the command line, not yet to a job file\n", done.stderr


def test_outputs_are_named_by_their_library_keyword_and_shown_as_flags(tmp_path: Path) -> None:
    from pincal.calibration.from_files import calibrate_files
    from pincal.errors import OutputError
    from pincal.fleet import jobs_from_directory

    data = str(ROOT / "examples" / "data" / "tiago_mocap_marker1.csv")
    with pytest.raises(OutputError, match=r"^out_urdf '.*' is the input file ") as caught:
        calibrate_files("tiago_no_hand", data, data, None)
    assert caught.value.option == "out_urdf"
    with pytest.raises(OutputError, match=r"^report_path '.*' is the input file ") as caught:
        calibrate_files("tiago_no_hand", data, None, data)
    assert caught.value.option == "report_path"
    with pytest.raises(OutputError, match=r"^out: '.*' is a file, not a directory$") as caught:
        jobs_from_directory("ur10", tmp_path, data)
    assert caught.value.option == "out"
    # the same outputs through the command line: the flags the user typed, the paths quoted as before
    done = run_pincal("calibrate", "tiago_no_hand", data, "--report", data, cwd=tmp_path)
    assert done.returncode == 2 and done.stderr.splitlines() == [
        f"pincal: error: --report '{data}' is the input file '{data}': pincal never writes over its input; choose "
        "another output name"], done.stderr
    done = run_pincal("fleet", "ur10", str(tmp_path), "--out", data, cwd=tmp_path)
    assert done.returncode == 2 and done.stderr.splitlines() == [
        f"pincal: error: --out: '{data}' is a file, not a directory"], done.stderr


def test_an_option_a_flag_gives_over_a_job_file_is_named_as_the_flag(tmp_path: Path) -> None:
    job = str(ROOT / "examples" / "data" / "talos_table_contact" / "left_job.toml")
    done = run_pincal("report", job, "--cv-seed", "3", "--out", str(tmp_path / "r.html"), cwd=tmp_path)
    assert done.returncode == 2 and done.stderr.splitlines() == [
        "pincal: error: --cv-seed 3 seeds the shuffles of --cv; give --cv too (e.g. --cv 5x4)"], done.stderr
    assert not (tmp_path / "r.html").exists()
