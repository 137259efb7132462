"""Randomised bad input, class by class: clouds, cloud files, specs, gripper
descriptions, URDFs and recordings. Whatever comes in, wsgrasp answers with a
result or with its own error (``WsgraspError``): never another exception, never a
grasp under the table, never a silently accepted non-finite number.

The example counts are the ``CASES`` table below (the "What bad input gets" table
of docs/reference/errors.md gives them); the whole module runs in about a minute.
"""

from __future__ import annotations

import copy
import math
from pathlib import Path
from typing import Any

import numpy as np
import pytest
import yaml
from bad_scenes import noisy_box, table_slab
from hypothesis import HealthCheck, given, settings
from hypothesis import strategies as st
from hypothesis.extra import numpy as hnp
from test_record_fakes import box_scene, fake_gripper, fake_spec

from wsgrasp.api import Pipeline, _hits_table, _under_table
from wsgrasp.errors import (
    GripperError,
    InputError,
    RecordingError,
    SpecError,
    WsgraspError,
)
from wsgrasp.perception.io import load_cloud, scene_from_arrays
from wsgrasp.spec import load_gripper_description, load_spec

ROOT = Path(__file__).resolve().parents[1]

#: examples tried per class
CASES = {
    "cloud_arrays": 200,
    "tables_alone": 40,
    "oversized_objects": 15,  # per gripper
    "missing_files": 60,
    "cloud_files": 600,
    "cloud_file_damage": 300,
    "depth_images": 150,
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
        for T in (result.T_world_ee, result.T_world_pregrasp):
            assert not _hits_table(pipeline.gripper, table, T)
            assert not _under_table(pipeline.gripper, prep.table_footprint, T)


def _turned(points: np.ndarray, tilt: float, yaw: float, shift: float) -> np.ndarray:
    """``points`` tilted about x, turned about z and shifted: the same scene in
    a frame that is not the table's."""
    from scipy.spatial.transform import Rotation

    R = Rotation.from_euler("xz", [tilt, yaw]).as_matrix()
    return points @ R.T + shift  # type: ignore[no-any-return]


@fuzz("tables_alone")
@given(
    size=st.tuples(st.floats(0.4, 1.0), st.floats(0.4, 1.0)),
    thickness=st.floats(0.012, 0.05),
    step=st.sampled_from([0.004, 0.005, 0.006]),
    noise=st.floats(0.0, 0.002),
    sides=st.tuples(*[st.booleans()] * 4),
    fold=st.one_of(st.just(0.0), st.floats(0.03, 0.2)),
    frame=st.tuples(st.floats(0.0, 3.1), st.floats(-3.1, 3.1), st.floats(-2.0, 2.0)),
    seed=st.integers(0, 2**16),
)
def test_a_table_alone_with_its_edges_is_nothing_to_grasp(
    pipeline, size, thickness, step, noise, sides, fold, frame, seed
):
    # no pose: a table top with its side faces and a cloth over an edge, in
    # any frame; nothing stands on it, so there is nothing to grasp
    rng = np.random.default_rng(seed)
    world = table_slab(
        rng,
        size=size,
        thickness=thickness,
        step=step,
        noise=noise,
        sides=sides,
        fold=fold,
    )
    with pytest.raises(InputError, match="nothing to grasp|no object above"):
        pipeline.plan(_turned(world, *frame))


#: every built-in gripper and the example plugins' grippers
OVERSIZED_GRIPPERS = ["franka_hand", "allegro_right"] + sorted(
    str(p) for p in ROOT.glob("examples/plugins/*/wsgrasp_*/*.yaml")
)


@pytest.fixture(scope="module")
def big_pipelines() -> dict[str, Pipeline]:
    """Per gripper, its default spec with a segmenter that keeps objects up to
    3 m (the default takes larger ones for walls), joins their sparser points,
    and leaves the table's noise (up to 5 mm) on the table, and a coarser
    voxel."""
    from wsgrasp.default_specs import default_spec

    out = {}
    for gripper in OVERSIZED_GRIPPERS:
        data, _ = default_spec(gripper)
        data = {
            **data,
            "segmenter": {
                "name": "ransac_dbscan",
                "options": {
                    "max_object_extent": 3.0,
                    "max_height": 2.0,
                    "cluster_eps": 0.03,
                    "min_height": 0.025,
                },
            },
            "preprocess": {"voxel_size": 0.01, "max_object_points": 800},
        }
        out[gripper] = Pipeline(load_spec(data))
    return out


@pytest.mark.parametrize(
    "gripper", OVERSIZED_GRIPPERS, ids=[Path(g).stem for g in OVERSIZED_GRIPPERS]
)
@fuzz("oversized_objects")
@given(
    scale=st.tuples(*[st.floats(1.3, 3.0)] * 3),
    noise=st.sampled_from([0.0, 0.001, 0.003, 0.005]),
    yaw=st.floats(-3.1, 3.1),
    seed=st.integers(0, 2**16),
)
def test_an_object_larger_than_a_gripper_encloses_is_too_large(
    big_pipelines, gripper, scale, noise, yaw, seed
):
    # a box wider than the gripper's fingers' workspaces spread in every
    # direction, its points noisy: never grasped, and the result says why
    pipe = big_pipelines[gripper]
    size = tuple(s * pipe.gripper.enclosure for s in scale)
    table = 2.0 * float(np.hypot(size[0], size[1])) + 0.2
    world = noisy_box(
        np.random.default_rng(seed), size, table=table, step=0.01, noise=noise, yaw=yaw
    )
    result = pipe.plan(world)
    assert not result.found
    assert f"too large for {pipe.gripper.name}" in result.hint, result.hint


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


@fuzz("depth_images")
@given(
    data=st.one_of(
        st.binary(max_size=2000),
        hnp.arrays(
            st.sampled_from([np.uint16, np.float32, np.uint8, np.int32]),
            hnp.array_shapes(min_dims=1, max_dims=3, min_side=1, max_side=40),
        ),
    ),
    suffix=st.sampled_from([".png", ".tif", ".npy"]),
    k=st.tuples(*[st.one_of(st.floats(-1e3, 1e3), st.just(math.nan))] * 4),
    scale=st.one_of(st.none(), st.floats(-1.0, 10.0), st.just(math.inf)),
)
def test_any_depth_image_gets_points_or_our_error(
    tmp_path_factory, data, suffix, k, scale
):
    """Random bytes, arrays of any type and shape saved as an image or an NPY,
    with any intrinsics and scale: points in front of the camera, or one
    ``InputError``."""
    from PIL import Image

    from wsgrasp.perception.depth import Intrinsics
    from wsgrasp.perception.io import load_scene

    path = tmp_path_factory.mktemp("d") / f"depth{suffix}"
    if isinstance(data, bytes):
        path.write_bytes(data)
    elif suffix == ".npy":
        np.save(path, data)
    else:
        try:
            Image.fromarray(data).save(path)
        except (TypeError, ValueError, OSError, KeyError):
            return  # PIL cannot write it: no such file to read
    try:
        intrinsics = Intrinsics.parse(",".join(map(str, k)))
        scene = load_scene(path, intrinsics=intrinsics, depth_scale=scale)
    except InputError:
        return
    assert scene.points.ndim == 2 and np.isfinite(scene.points).all()
    assert (scene.points[:, 2] > 0).all()


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


ROBOTIQ = ROOT / "examples/plugins/robotiq_2f85_like/wsgrasp_robotiq_2f85_like"
#: relative to what each file a spec leads to is read
RELATIVE_TO = {
    "yaml": "the spec file's folder",
    "urdf": "the gripper YAML's folder",
    "mesh": "the URDF's folder",
}
folder_names = st.text("abcxyz_-. 0123456789", min_size=1, max_size=6).filter(
    lambda t: t.strip(". ") == t and t not in (".", "..")
)


@fuzz("missing_files")
@given(
    missing=st.sampled_from(sorted(RELATIVE_TO)),
    spec_dirs=st.lists(folder_names, max_size=2),
    gripper_dirs=st.lists(folder_names, min_size=1, max_size=2),
    urdf_dirs=st.lists(folder_names, max_size=2),
    absolute=st.booleans(),
)
def test_a_spec_naming_a_missing_file_says_which_and_where(
    tmp_path_factory, missing, spec_dirs, gripper_dirs, urdf_dirs, absolute
):
    # the spec names a gripper YAML (by a relative or an absolute path), which
    # names a URDF (relative), which names a collision mesh (relative); one of
    # the three files is missing
    from wsgrasp.cli._spec_check import spec_problems

    root = tmp_path_factory.mktemp("m")
    spec_dir = root.joinpath(*spec_dirs)
    gripper_dir = spec_dir.joinpath(*gripper_dirs)
    urdf_dir = gripper_dir.joinpath(*urdf_dirs)
    (urdf_dir / "meshes").mkdir(parents=True, exist_ok=True)
    urdf_rel = Path(*urdf_dirs, "jaw.urdf")
    desc = yaml.safe_load((ROBOTIQ / "robotiq_2f85_like.yaml").read_text())
    desc["urdf"] = str(urdf_rel)
    paths = {
        "yaml": gripper_dir / "jaw.yaml",
        "urdf": urdf_dir / "jaw.urdf",
        "mesh": urdf_dir / "meshes" / "base_housing.stl",
    }
    if missing != "yaml":
        paths["yaml"].write_text(yaml.safe_dump(desc))
    if missing != "urdf":
        paths["urdf"].write_text((ROBOTIQ / "robotiq_2f85_like.urdf").read_text())
    if missing != "mesh":
        paths["mesh"].write_bytes((ROBOTIQ / "meshes/base_housing.stl").read_bytes())
    ref = paths["yaml"] if absolute else Path(*gripper_dirs, "jaw.yaml")
    spec = spec_dir / "spec.yaml"
    spec.write_text(yaml.safe_dump({**BASE_SPEC, "gripper": str(ref)}, sort_keys=False))
    problems = spec_problems(spec)
    assert len(problems) == 1, problems
    message = problems[0]
    assert message.startswith(f"{spec}:") and "not found: tried " in message
    assert str(paths[missing]) in message
    if missing != "yaml" or not absolute:
        assert f"relative to {RELATIVE_TO[missing]}" in message
    with pytest.raises(SpecError) as info:
        load_spec(spec)
    assert info.value.message == message


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
