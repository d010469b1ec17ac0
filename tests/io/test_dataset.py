"""The measurement CSV format: exact round-trips, metadata, subsets, and every validation error."""

from __future__ import annotations

import math
import re
from pathlib import Path

import numpy as np
import pytest
from hypothesis import given, settings
from hypothesis import strategies as st
from hypothesis.extra.numpy import arrays

from pincal.errors import DataError
from pincal.io.dataset import Dataset, parse_measurement_key, write_dataset
from pincal.io.dataset_reader import read_dataset

JOINTS = ["arm_1_joint", "arm_2_joint", "arm_3_joint"]
HEADER = "sample,set,arm_1_joint,arm_2_joint,arm_3_joint,position:end_effector:x,position:end_effector:y," \
         "position:end_effector:z"


def _dataset(n: int = 6, seed: int = 0) -> Dataset:
    rng = np.random.default_rng(seed)
    quaternions = rng.normal(size=(n, 4))
    quaternions /= np.linalg.norm(quaternions, axis=1, keepdims=True)
    increments = rng.uniform(-0.05, 0.05, size=(n, 1))
    increments[0] = np.nan
    return Dataset(
        joint_names=[*JOINTS, "scale_joint"],
        joints=np.column_stack([rng.uniform(-1, 1.5, size=(n, 3)), rng.uniform(0.6, 0.9, size=n)]),
        measurements={
            "position:end_effector": rng.uniform(-0.3, 0.3, size=(n, 3)),
            "pose:platform": np.column_stack([rng.uniform(-0.3, 0.3, size=(n, 3)), quaternions]),
            "distance:O1-O2": rng.uniform(0.5, 1.0, size=(n, 1)),
            "distance_increment:O1-O2": increments,
        },
        sample_ids=[f"p{i}" for i in range(n)],
        sets=["train" if i % 3 else "test" for i in range(n)],
        metadata={"robot": "delta", "units": "SI (m, rad)", "sigma position": "1e-05"},
    )


def _assert_identical(a: Dataset, b: Dataset) -> None:
    assert a.joint_names == b.joint_names
    assert a.joints.tobytes() == b.joints.tobytes()
    assert list(a.measurements) == list(b.measurements)
    for key in a.measurements:
        assert np.array_equal(a.measurements[key], b.measurements[key], equal_nan=True), key
        assert np.array_equal(np.signbit(a.measurements[key]), np.signbit(b.measurements[key]))
    assert a.sample_ids == b.sample_ids
    assert a.sets == b.sets
    assert a.metadata == b.metadata


#: Two markers on one frame: the frame's own point and marker m2.
MARKERS_HEADER = f"{HEADER},position:end_effector@m2:x,position:end_effector@m2:y,position:end_effector@m2:z"


def _write(tmp_path: Path, text: str) -> Path:
    path = tmp_path / "data.csv"
    path.write_text(text)
    return path


# --- round-trips ----------------------------------------------------------------------------------
def test_write_read_round_trip_is_exact(tmp_path: Path) -> None:
    data = _dataset()
    data.joints[0, 0] = -0.0
    data.joints[1, 0] = 1 / 3
    write_dataset(data, tmp_path / "a.csv")
    back = read_dataset(tmp_path / "a.csv", joint_names_required=JOINTS)
    _assert_identical(data, back)
    write_dataset(back, tmp_path / "b.csv")
    assert (tmp_path / "a.csv").read_text() == (tmp_path / "b.csv").read_text()


@settings(max_examples=40, deadline=None)
@given(values=arrays(np.float64, (5, 4), elements=st.floats(-10.0, 10.0, allow_subnormal=True)),
       positions=arrays(np.float64, (5, 3), elements=st.floats(-19.0, 19.0)))
def test_round_trip_of_any_finite_floats(tmp_path_factory: pytest.TempPathFactory, values: np.ndarray,
                                         positions: np.ndarray) -> None:
    values[:, 3] = np.arange(5) + 0.5  # distinct rows: duplicated samples are refused
    data = Dataset(["a", "b", "c", "d"], values, {"position:tool": positions}, [str(i) for i in range(5)],
                   ["train"] * 5, {})
    path = tmp_path_factory.mktemp("rt") / "d.csv"
    write_dataset(data, path)
    _assert_identical(data, read_dataset(path))


def test_metadata_and_comments_are_read(tmp_path: Path) -> None:
    path = _write(tmp_path, "# robot: delta\n# units: SI (m, rad)\n# sigma position: 1e-5\n# a free comment\n"
                            f"{HEADER}\n# a comment between rows: not metadata\n"
                            "0,train,0.1,0.2,0.3,0.01,0.02,-0.2\n\n1,test,0.2,0.1,0.0,0.02,0.01,-0.25\n")
    data = read_dataset(path, joint_names_required=JOINTS, min_samples=2)
    assert data.metadata == {"robot": "delta", "units": "SI (m, rad)", "sigma position": "1e-5"}
    assert data.n_samples == 2
    assert data.sets == ["train", "test"]
    assert data.measurements["position:end_effector"].tolist() == [[0.01, 0.02, -0.2], [0.02, 0.01, -0.25]]
    assert data.joint_column("arm_2_joint").tolist() == [0.2, 0.1]


def test_sample_and_set_columns_are_optional(tmp_path: Path) -> None:
    path = _write(tmp_path, "arm_1_joint,position:ee:z,position:ee:y,position:ee:x\n0.1,3,2,1\n0.2,6,5,4\n")
    data = read_dataset(path)
    assert data.sample_ids == ["0", "1"]
    assert data.sets == ["train", "train"]
    assert data.measurements["position:ee"].tolist() == [[1, 2, 3], [4, 5, 6]]  # reordered x, y, z


def test_subset_and_sets(tmp_path: Path) -> None:
    data = _dataset(n=6)
    test = data.of_set("test")
    assert test.sample_ids == ["p0", "p3"]
    picked = data.subset([4, 1, 2])
    assert picked.sample_ids == ["p4", "p1", "p2"]
    assert np.array_equal(picked.joints, data.joints[[4, 1, 2]])
    # Increments stay "change since the previous sample" in the subset's order.
    inc = data.measurements["distance_increment:O1-O2"][:, 0]
    distance = np.concatenate([[0.0], np.cumsum(inc[1:])])
    new = picked.measurements["distance_increment:O1-O2"][:, 0]
    assert math.isnan(new[0])
    assert new[1:] == pytest.approx([distance[1] - distance[4], distance[2] - distance[1]], abs=1e-15)
    mask = np.array([True, False, True, True, False, False])
    assert data.subset(mask).measurements["distance_increment:O1-O2"][2, 0] == inc[3]
    with pytest.raises(DataError, match=r"mask has shape \(2,\), expected \(6,\)"):
        data.subset(np.array([True, False]))
    with pytest.raises(DataError, match=r"out of range 0\.\.5"):
        data.subset([7])


def test_parse_measurement_key() -> None:
    assert parse_measurement_key("distance:O1-O2") == ("distance", ("O1", "O2"))
    assert parse_measurement_key("pose:tool0") == ("pose", ("tool0",))
    with pytest.raises(DataError, match="two frames"):
        parse_measurement_key("distance:a-b-c")


def test_dataset_constructor_checks_shapes() -> None:
    with pytest.raises(DataError, match=r"'position:ee' has shape \(2, 2\), expected \(2, 3\)"):
        Dataset(["a"], np.zeros((2, 1)), {"position:ee": np.zeros((2, 2))}, ["0", "1"], ["train"] * 2)
    with pytest.raises(DataError, match=r"'valid'.*sets are: train, test"):
        Dataset(["a"], np.zeros((1, 1)), {}, ["0"], ["valid"])


def test_write_refuses_what_would_not_read_back(tmp_path: Path) -> None:
    data = _dataset()
    data.measurements["position:end_effector"][2, 1] = np.nan
    with pytest.raises(DataError, match="'position:end_effector' holds NaN"):
        write_dataset(data, tmp_path / "x.csv")
    data = _dataset()
    data.metadata["a:b"] = "c"
    with pytest.raises(DataError, match="metadata 'a:b'"):
        write_dataset(data, tmp_path / "x.csv")


# --- validation errors, each from a real malformed file ---------------------------------------------
GOOD_ROW = "0,train,0.1,0.2,0.3,0.01,0.02,-0.2"
MALFORMED = {
    "missing joint": (
        "sample,arm_1_joint,arm_3_joint,position:ee:x,position:ee:y,position:ee:z\n0,0.1,0.2,1e-3,2e-3,3e-3\n",
        r"missing joint columns arm_2_joint; joint columns present: arm_1_joint, arm_3_joint"),
    "unknown kind": (
        "arm_1_joint,arm_2_joint,arm_3_joint,positon:ee:x\n0.1,0.2,0.3,0.4\n",
        r"column 'positon:ee:x' has unknown kind 'positon'.*kinds: position, pose, camera, camera_point, distance, "
        r"distance_increment"),
    "bad component": (
        "arm_1_joint,arm_2_joint,arm_3_joint,position:ee:w\n0.1,0.2,0.3,0.4\n",
        r"column 'position:ee:w' has component 'w'; a position has components: x, y, z"),
    "no frame": (
        "arm_1_joint,arm_2_joint,arm_3_joint,position:x\n0.1,0.2,0.3,0.4\n",
        r"column 'position:x' is not a joint name nor '<kind>:<frame>:<component>'"),
    "incomplete position": (
        f"{HEADER.removesuffix(',position:end_effector:z')}\n0,train,0.1,0.2,0.3,0.01,0.02\n",
        r"measurement 'position:end_effector' has columns x, y but not z; a position needs x, y, z"),
    "incomplete pose": (
        "arm_1_joint,arm_2_joint,arm_3_joint,pose:tool:x,pose:tool:y,pose:tool:z,pose:tool:qx,pose:tool:qw\n"
        "0.1,0.2,0.3,0,0,0,0,1\n",
        r"measurement 'pose:tool' has columns x, y, z, qx, qw but not qy, qz"),
    "non-numeric": (
        f"# robot: delta\n{HEADER}\n{GOOD_ROW}\n1,train,0.1,abc,0.3,0.01,0.02,-0.2\n",
        r"column 'arm_2_joint', line 4: 'abc' is not a number"),
    "empty cell": (
        f"{HEADER}\n{GOOD_ROW}\n1,train,0.1,0.2,0.3,0.01,,-0.2\n",
        r"column 'position:end_effector:y', line 3: the cell is empty"),
    "nan cell": (
        f"{HEADER}\n1,train,0.1,0.2,0.3,0.01,0.02,NaN\n",
        r"column 'position:end_effector:z', line 2: the cell is 'NaN'"),
    "infinite cell": (
        f"{HEADER}\n1,train,inf,0.2,0.3,0.01,0.02,0.1\n",
        r"column 'arm_1_joint', line 2: 'inf' is not finite"),
    "first increment given": (
        "arm_1_joint,arm_2_joint,arm_3_joint,distance_increment:O1-O2:d\n0.1,0.2,0.3,0.01\n0.2,0.2,0.3,0.02\n",
        r"column 'distance_increment:O1-O2:d', line 2: 0.01 on the first row.*must be empty or NaN"),
    "later increment empty": (
        "arm_1_joint,arm_2_joint,arm_3_joint,distance_increment:O1-O2:d\n0.1,0.2,0.3,\n0.2,0.2,0.3,\n",
        r"column 'distance_increment:O1-O2:d', line 3: the cell is empty"),
    "duplicated column": (
        "arm_1_joint,arm_2_joint,arm_3_joint,arm_2_joint\n0.1,0.2,0.3,0.4\n",
        r"column 'arm_2_joint' appears twice \(columns 2 and 4\)"),
    "duplicated rows": (
        f"{HEADER}\n{GOOD_ROW}\n1,train,0.2,0.2,0.3,0.01,0.02,-0.2\n# comment\n2,test,0.1,0.2,0.3,0.01,0.02,-0.2\n",
        r"duplicated samples \(identical joint readings and measurements\): line 5 repeats line 2"),
    "duplicated sample id": (
        f"{HEADER}\n{GOOD_ROW}\n0,train,0.2,0.2,0.3,0.01,0.02,-0.2\n",
        r"sample id '0' is used twice \(lines 2 and 3\)"),
    "ragged row": (
        f"{HEADER}\n{GOOD_ROW}\n1,train,0.2,0.2,0.3,0.01,0.02\n",
        r"line 3 has 7 cells; the header \(line 1\) has 8"),
    "bad set": (
        f"{HEADER}\n0,validation,0.1,0.2,0.3,0.01,0.02,-0.2\n",
        r"column 'set', line 2: 'validation' is not a set; sets are: train, test"),
    "non-unit quaternion": (
        "arm_1_joint,arm_2_joint,arm_3_joint,pose:tool:x,pose:tool:y,pose:tool:z,pose:tool:qx,pose:tool:qy,"
        "pose:tool:qz,pose:tool:qw\n0.1,0.2,0.3,0,0,0,0,0,0,1\n0.2,0.2,0.3,0,0,0,0,0,0.1,1\n",
        r"measurement 'pose:tool', line 3: quaternion \(qx, qy, qz, qw\) = \(0.0, 0.0, 0.1, 1.0\) has norm 1.00499"),
    "millimetre positions": (
        f"{HEADER}\n0,train,0.1,0.2,0.3,10.0,20.0,-224.9\n",
        r"column 'position:end_effector:z', line 2: -224.9 looks like millimetres; pincal expects metres"),
    "millimetre distance": (
        "arm_1_joint,arm_2_joint,arm_3_joint,distance:O1-O2:d\n0.1,0.2,0.3,850.0\n",
        r"column 'distance:O1-O2:d', line 2: 850.0 looks like millimetres; pincal expects metres"),
    "duplicated metadata": (
        f"# robot: delta\n# robot: hexapod\n{HEADER}\n{GOOD_ROW}\n",
        r"metadata 'robot' is given twice \(lines 1 and 2\)"),
    "no header": ("# robot: delta\n\n", r"no header line"),
    "marker partly empty": (
        f"{MARKERS_HEADER}\n0,train,0.1,0.2,0.3,0.01,0.02,-0.2,0.03,,-0.2\n",
        r"column 'position:end_effector@m2:y', line 2: the cell is empty but position:end_effector@m2:x, "
        r"position:end_effector@m2:z hold numbers; a marker that was not seen leaves all the cells"),
    "marker partly NaN": (
        f"{MARKERS_HEADER}\n0,train,0.1,0.2,0.3,0.01,0.02,-0.2,0.03,0.02,nan\n",
        r"column 'position:end_effector@m2:z', line 2: the cell is 'nan' but position:end_effector@m2:x, "
        r"position:end_effector@m2:y hold numbers"),
    "bad marker name": (
        "arm_1_joint,arm_2_joint,arm_3_joint,position:ee@m-1:x,position:ee@m-1:y,position:ee@m-1:z\n0.1,0.2,0.3,0,0,0\n",
        r"column 'position:ee@m-1:x': measurement 'position:ee@m-1' must name a frame and a marker as "
        r"'position:<frame>@<marker>', the marker in letters, digits and '_'"),
    "no marker name": (
        "arm_1_joint,arm_2_joint,arm_3_joint,position:ee@:x,position:ee@:y,position:ee@:z\n0.1,0.2,0.3,0,0,0\n",
        r"measurement 'position:ee@' must name a frame and a marker"),
}


@pytest.mark.parametrize("case", list(MALFORMED))
def test_malformed_file_is_refused(tmp_path: Path, case: str) -> None:
    text, message = MALFORMED[case]
    with pytest.raises(DataError, match=message) as info:
        read_dataset(_write(tmp_path, text), joint_names_required=JOINTS)
    assert str(info.value).startswith("data.csv: ")  # names the file


def test_too_few_samples(tmp_path: Path) -> None:
    path = _write(tmp_path, f"{HEADER}\n{GOOD_ROW}\n1,test,0.2,0.1,0.0,0.02,0.01,-0.25\n")
    with pytest.raises(DataError, match="2 samples; at least 8 are needed"):
        read_dataset(path, joint_names_required=JOINTS, min_samples=8)
    assert read_dataset(path, min_samples=2).n_samples == 2


def test_unknown_joint_column_with_known_joints(tmp_path: Path) -> None:
    path = _write(tmp_path, "arm_1_joint,arm2_joint,arm_3_joint\n0.1,0.2,0.3\n")
    with pytest.raises(DataError, match=r"columns arm2_joint are neither joints.*joints are: arm_1_joint, "
                                         r"arm_2_joint, arm_3_joint, scale_joint"):
        read_dataset(path, known_joints=[*JOINTS, "scale_joint"])


def test_degrees_and_millimetre_joint_readings(tmp_path: Path) -> None:
    kinds = {"arm_1_joint": "revolute", "scale_joint": "prismatic", "spin": "continuous"}
    rows = [f"{d},{0.8 + i * 1e-3},{20.0 * i}" for i, d in enumerate([3.0, -35.5, 60.0, 20.0])]
    path = _write(tmp_path, "arm_1_joint,scale_joint,spin\n" + "\n".join(rows) + "\n")
    with pytest.raises(DataError, match=re.escape("column 'arm_1_joint' (revolute joint), line 3: -35.5 looks like "
                                                  "degrees; pincal expects radians")):
        read_dataset(path, joint_kinds=kinds)
    # Radians with a few multi-turn readings are fine; so is a continuous joint far past 4 pi.
    rows = [f"{d},{0.8 + i * 1e-3},{20.0 * i}" for i, d in enumerate([1.0, -35.5, 0.5, 3.0])]
    path = _write(tmp_path, "arm_1_joint,scale_joint,spin\n" + "\n".join(rows) + "\n")
    assert read_dataset(path, joint_kinds=kinds).n_samples == 4
    rows = [f"0.{i},{850.0 + i},{i}" for i in range(3)]
    path = _write(tmp_path, "arm_1_joint,scale_joint,spin\n" + "\n".join(rows) + "\n")
    with pytest.raises(DataError, match=r"column 'scale_joint' \(prismatic joint\): median \|reading\| 851 looks "
                                        "like millimetres; pincal expects metres"):
        read_dataset(path, joint_kinds=kinds)
    assert read_dataset(path).n_samples == 3  # without joint kinds, readings are not judged


def test_a_marker_not_seen_leaves_its_cells_empty_and_round_trips(tmp_path: Path) -> None:
    """All three cells of a marker empty (or NaN): that reading was not taken, the sample keeps its others; written
    back as empty cells, read back the same."""
    text = (f"# robot: delta\n{MARKERS_HEADER}\n0,train,0.1,0.2,0.3,0.01,0.02,-0.2,,,\n"
            "1,test,0.2,0.2,0.3,,,,0.03,0.02,-0.21\n2,train,0.3,0.2,0.3,NaN,nan,NAN,0.03,0.02,-0.22\n"
            "3,train,0.4,0.2,0.3,0.01,0.02,-0.2,0.03,0.02,-0.23\n")
    data = read_dataset(_write(tmp_path, text), joint_names_required=JOINTS)
    assert list(data.measurements) == ["position:end_effector", "position:end_effector@m2"]
    assert np.isnan(data.measurements["position:end_effector@m2"][0]).all()
    assert np.isnan(data.measurements["position:end_effector"][[1, 2]]).all()
    assert np.isfinite(data.measurements["position:end_effector@m2"][1:]).all()
    write_dataset(data, tmp_path / "again.csv")
    assert ",,," in (tmp_path / "again.csv").read_text()
    _assert_identical(read_dataset(tmp_path / "again.csv"), data)
    _assert_identical(data.subset([2, 0]).subset([1]), data.subset([0]))


def test_a_dataset_refuses_a_marker_reading_partly_nan() -> None:
    values = np.zeros((2, 3))
    values[1, 2] = np.nan
    with pytest.raises(DataError, match=r"'position:ee@m1', row 1: some values are NaN and some not"):
        Dataset(["a"], np.zeros((2, 1)), {"position:ee@m1": values}, ["0", "1"], ["train"] * 2)
    values = np.zeros((2, 1))
    values[1] = np.nan
    data = Dataset(["a"], np.zeros((2, 1)), {"distance:a-b": values}, ["0", "1"], ["train"] * 2)
    with pytest.raises(DataError, match="'distance:a-b' holds NaN"):  # a distance is never occluded
        write_dataset(data, Path("unused.csv"))
