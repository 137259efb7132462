"""Randomised bad input, class by class: clouds, cloud files, specs, gripper
descriptions, URDFs and recordings. Whatever comes in, wsgrasp answers with a
result or with its own error (``WsgraspError``): never another exception, never a
grasp under the table, never a silently accepted non-finite number.

The example counts are the ``CASES`` table below (the README's "What bad input
gets" table gives them); the whole module runs in about a minute.
"""

from __future__ import annotations

import copy
import math
from pathlib import Path
from typing import Any

import numpy as np
import pytest
import yaml
from hypothesis import HealthCheck, given, settings
from hypothesis import strategies as st
from hypothesis.extra import numpy as hnp
from test_record_fakes import box_scene, fake_gripper, fake_spec

from wsgrasp.api import Pipeline, _hits_table
from wsgrasp.errors import GripperError, InputError, RecordingError, WsgraspError
from wsgrasp.perception.io import load_cloud, scene_from_arrays
from wsgrasp.spec import load_gripper_description, load_spec

ROOT = Path(__file__).resolve().parents[1]

#: examples tried per class
CASES = {
    "cloud_arrays": 200,
    "cloud_files": 600,
    "cloud_file_damage": 300,
    "specs": 500,
    "gripper_descriptions": 400,
    "urdfs": 300,
    "recording_bit_flips": 200,
}


def fuzz(name: str) -> Any:
    return settings(
        max_examples=CASES[name],
        deadline=None,
        derandomize=True,
        suppress_health_check=[HealthCheck.too_slow, HealthCheck.data_too_large],
    )


@pytest.fixture(scope="module")
def pipeline() -> Pipeline:
    return Pipeline(fake_spec(), gripper=fake_gripper())


# ------------------------------------------------------------------------------
# values a careless or hostile user writes
# ------------------------------------------------------------------------------
nasty_floats = st.one_of(
    st.sampled_from([math.nan, math.inf, -math.inf, 0.0, -0.0, -1.0, 1e-12, 1e12]),
    st.floats(allow_nan=True, allow_infinity=True, width=64),
)
nasty_values = st.one_of(
    nasty_floats,
    st.integers(min_value=-(10**12), max_value=10**12),
    st.text(max_size=12),
    st.none(),
    st.booleans(),
    st.lists(nasty_floats, max_size=5),
    st.dictionaries(st.text(max_size=5), st.integers(), max_size=2),
)


def _leaves(data: Any, path: tuple[Any, ...] = ()) -> list[tuple[Any, ...]]:
    if isinstance(data, dict):
        return [p for k, v in data.items() for p in _leaves(v, (*path, k))] or [path]
    if isinstance(data, list):
        return [p for i, v in enumerate(data) for p in _leaves(v, (*path, i))] or [path]
    return [path]


def _get(data: Any, path: tuple[Any, ...]) -> Any:
    for key in path:
        data = data[key]
    return data


def _put(data: Any, path: tuple[Any, ...], value: Any) -> Any:
    out = copy.deepcopy(data)
    node = out
    for key in path[:-1]:
        node = node[key]
    if path:
        node[path[-1]] = value
    return out


def mutations(base: dict[str, Any]) -> st.SearchStrategy[dict[str, Any]]:
    """``base`` with one to three leaves replaced by nasty values, or a key
    added."""
    leaves = _leaves(base)

    numeric = [p for p in leaves if isinstance(_get(base, p), (int, float))]

    @st.composite
    def mutate(draw: Any) -> dict[str, Any]:
        data = copy.deepcopy(base)
        for _ in range(draw(st.integers(1, 3))):
            kind = draw(st.sampled_from(["number", "number", "any", "new key"]))
            if kind == "number" and numeric:
                # a number turned NaN, inf, negative, zero or huge
                data = _put(data, draw(st.sampled_from(numeric)), draw(nasty_floats))
            elif kind == "any" or not leaves:
                data = _put(data, draw(st.sampled_from(leaves)), draw(nasty_values))
            else:
                data[draw(st.text(min_size=1, max_size=8))] = draw(nasty_values)
        return data

    return mutate()


def _no_nonfinite(model: Any) -> None:
    """No NaN or inf anywhere in an accepted document."""
    dumped = model.model_dump(mode="python")
    for path in _leaves(dumped):
        value = dumped
        for key in path:
            value = value[key]
        if isinstance(value, float):
            assert math.isfinite(value), path


# ------------------------------------------------------------------------------
# clouds
# ------------------------------------------------------------------------------
cloud_arrays = st.one_of(
    hnp.arrays(
        dtype=st.sampled_from([np.float64, np.float32]),
        shape=st.tuples(st.integers(0, 400), st.sampled_from([2, 3, 4])),
        elements=st.one_of(
            st.floats(-1e6, 1e6, width=32), st.sampled_from([math.nan, math.inf])
        ),
    ),
    # plausible scenes, scaled, shifted, spoilt with NaN
    st.tuples(
        st.sampled_from([1e-3, 0.01, 1.0, 100.0, 1000.0]),
        st.floats(-10, 10),
        st.floats(0, 0.9),
    ).map(
        lambda t: np.where(
            np.random.default_rng(0).uniform(size=(4500, 1)) < t[2],
            np.nan,
            box_scene(views=1).points * t[0] + t[1],
        )
    ),
)


@fuzz("cloud_arrays")
@given(points=cloud_arrays)
def test_any_array_gets_a_result_or_our_error(pipeline, points):
    try:
        result = pipeline.plan(points)
    except WsgraspError:
        return
    if result.found:
        prep = pipeline.prepare(scene_from_arrays(points))
        table = prep.search_input.table
        assert not _hits_table(pipeline.gripper, table, result.T_world_ee)
        assert not _hits_table(pipeline.gripper, table, result.T_world_pregrasp)


SUFFIXES = [".ply", ".pcd", ".npy", ".npz", ".xyz", ".csv", ".txt"]


@fuzz("cloud_files")
@given(suffix=st.sampled_from(SUFFIXES), data=st.binary(max_size=4000))
def test_any_bytes_as_a_cloud_file_get_our_error(tmp_path_factory, suffix, data):
    path = tmp_path_factory.mktemp("c") / f"cloud{suffix}"
    path.write_bytes(data)
    try:
        points = load_cloud(path)
    except InputError:
        return
    assert points.ndim == 2 and points.shape[1] == 3
    assert points.dtype == np.float64


def _valid_cloud_files(folder: Path) -> dict[str, bytes]:
    import open3d as o3d

    pts = box_scene(views=1).points[:300]
    pcd = o3d.geometry.PointCloud(o3d.utility.Vector3dVector(pts))
    out = {}
    for suffix, ascii_ in ((".ply", False), (".ply", True), (".pcd", False)):
        path = folder / f"c{int(ascii_)}{suffix}"
        o3d.io.write_point_cloud(str(path), pcd, write_ascii=ascii_)
        out[path.name] = path.read_bytes()
    np.save(folder / "c.npy", pts)
    out["c.npy"] = (folder / "c.npy").read_bytes()
    np.savez(folder / "c.npz", points=pts)
    out["c.npz"] = (folder / "c.npz").read_bytes()
    return out


@pytest.fixture(scope="module")
def valid_files(tmp_path_factory) -> dict[str, bytes]:
    return _valid_cloud_files(tmp_path_factory.mktemp("valid"))


@fuzz("cloud_file_damage")
@given(data=st.data())
def test_damaged_cloud_files_never_read_as_wrong_points(
    valid_files, tmp_path_factory, data
):
    name = data.draw(st.sampled_from(sorted(valid_files)))
    raw = bytearray(valid_files[name])
    if data.draw(st.booleans()):
        raw = raw[: data.draw(st.integers(0, len(raw) - 1))]
    else:
        for _ in range(data.draw(st.integers(1, 4))):
            i = data.draw(st.integers(0, len(raw) - 1))
            raw[i] ^= 1 << data.draw(st.integers(0, 7))
    path = tmp_path_factory.mktemp("d") / name
    path.write_bytes(bytes(raw))
    try:
        points = load_cloud(path)
    except InputError:
        return
    # a cut file is refused; one that still reads has every point it declared
    assert len(points) == 300


# ------------------------------------------------------------------------------
# specs, gripper descriptions, URDFs
# ------------------------------------------------------------------------------
BASE_SPEC = yaml.safe_load((ROOT / "examples" / "specs" / "franka.yaml").read_text())


@fuzz("specs")
@given(data=mutations(BASE_SPEC))
def test_any_spec_is_valid_or_refused_with_one_error(data):
    try:
        spec = load_spec(data)
    except WsgraspError:
        return
    _no_nonfinite(spec)
    assert sum(s.weight for s in spec.scorers) > 0
    # what loads, plans: the pipeline accepts every option the check accepted
    Pipeline(spec, gripper=fake_gripper())


BASE_GRIPPER = yaml.safe_load(
    (
        ROOT
        / "plugins"
        / "grippers"
        / "wsgrasp_grippers"
        / "franka_hand"
        / "franka_hand.yaml"
    ).read_text()
)


@fuzz("gripper_descriptions")
@given(data=mutations(BASE_GRIPPER))
def test_any_gripper_description_is_valid_or_refused(tmp_path_factory, data):
    path = tmp_path_factory.mktemp("g") / "gripper.yaml"
    path.write_text(yaml.safe_dump(data))
    try:
        desc, _ = load_gripper_description(path)
    except WsgraspError:
        return
    _no_nonfinite(desc)


def _urdf_numbers() -> st.SearchStrategy[str]:
    return st.one_of(
        st.sampled_from(["nan", "inf", "-inf", "", "abc", "1e400", "-1", "0"]),
        nasty_floats.map(repr),
    )


@fuzz("urdfs")
@given(data=st.data())
def test_any_urdf_number_is_finite_or_refused(tmp_path_factory, data):
    import re

    from urdf_factory import jaw_urdf

    from wsgrasp.gripper._urdf import load_kinematics

    text = jaw_urdf(mimic=data.draw(st.booleans()))
    numbers = list(re.finditer(r'(?<==")[-0-9. e]+(?=")', text))
    for _ in range(data.draw(st.integers(1, 3))):
        m = data.draw(st.sampled_from(numbers))
        words = m.group(0).split()
        k = data.draw(st.integers(0, len(words) - 1))
        words[k] = data.draw(_urdf_numbers())
        text = text[: m.start()] + " ".join(words) + text[m.end() :]
        numbers = list(re.finditer(r'(?<==")[-0-9. e+a-z]*(?=")', text))
    path = tmp_path_factory.mktemp("u") / "jaw.urdf"
    path.write_text(text)
    try:
        kin = load_kinematics(path, "jaw")
    except GripperError:
        return
    for joint in kin.joints.values():
        assert np.isfinite([joint.lower, joint.upper, *joint.axis]).all()
        assert np.isfinite(joint.origin).all()
        assert joint.lower <= joint.upper


# ------------------------------------------------------------------------------
# recordings: cut at every chunk boundary, and bits flipped
# ------------------------------------------------------------------------------
@pytest.fixture(scope="module")
def recording(tmp_path_factory) -> bytes:
    from wsgrasp.record import RunRecorder

    path = tmp_path_factory.mktemp("rec") / "run.mcap"
    recorder = RunRecorder(path)
    Pipeline(fake_spec(), gripper=fake_gripper()).plan(
        box_scene(), observers=[recorder]
    )
    recorder.close()
    return path.read_bytes()


def _chunk_boundaries(raw: bytes) -> list[int]:
    import io

    from mcap.reader import make_reader

    summary = make_reader(io.BytesIO(raw)).get_summary()
    assert summary is not None
    cuts = {8, len(raw) - 1}
    for c in summary.chunk_indexes:
        start, end = c.chunk_start_offset, c.chunk_start_offset + c.chunk_length
        cuts |= {start, start + 1, end - 1, end, end + 1}
    return sorted(x for x in cuts if 0 < x < len(raw))


def test_a_recording_cut_at_every_chunk_boundary_reads_or_says_why(recording, tmp_path):
    from wsgrasp.record import open_run

    cuts = _chunk_boundaries(recording)
    assert len(cuts) > 10
    readable = 0
    for cut in cuts:
        path = tmp_path / f"cut{cut}.mcap"
        path.write_bytes(recording[:cut])
        try:
            run = open_run(path)
        except RecordingError:
            continue
        readable += 1
        # the cut is seen: the run is truncated, or only the closing magic after
        # a complete footer is gone
        assert run.truncated or run.truncated_at is not None
        assert run.status in ("truncated", "ok", "error")
    # everything after the inputs' chunk reads back to its last complete stage
    assert readable >= len(cuts) // 2


@fuzz("recording_bit_flips")
@given(data=st.data())
def test_a_recording_with_flipped_bits_reads_or_says_why(
    recording, tmp_path_factory, data
):
    from wsgrasp.record import open_run

    raw = bytearray(recording)
    for _ in range(data.draw(st.integers(1, 3))):
        i = data.draw(st.integers(0, len(raw) - 1))
        raw[i] ^= 1 << data.draw(st.integers(0, 7))
    path = tmp_path_factory.mktemp("f") / "run.mcap"
    path.write_bytes(bytes(raw))
    try:
        run = open_run(path)
    except RecordingError:
        return
    assert run.status in ("ok", "truncated", "error")
