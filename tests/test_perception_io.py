"""Cloud and scene loading: every format, NaN handling, views with poses, ICP, and
every bad input."""

from __future__ import annotations

from pathlib import Path

import numpy as np
import pytest
import yaml
from conftest_perception import random_rigid, small_scene
from numpy.testing import assert_allclose

from wsgrasp.errors import InputError
from wsgrasp.geometry import invert_transforms, transform_from, transform_points
from wsgrasp.perception.io import (
    load_cloud,
    load_scene,
    save_cloud,
    scene_from_arrays,
    write_scene_yaml,
)
from wsgrasp.perception.types import View

RNG_POINTS = np.random.default_rng(0).uniform(-0.2, 0.2, (50, 3))


@pytest.mark.parametrize(
    "suffix", [".ply", ".pcd", ".xyz", ".txt", ".csv", ".npy", ".npz"]
)
def test_round_trip_every_format(tmp_path: Path, suffix: str) -> None:
    path = save_cloud(tmp_path / f"cloud{suffix}", RNG_POINTS)
    got = load_cloud(path)
    assert got.dtype == np.float64 and got.shape == (50, 3)
    # npz/npy are float32, text has 6 decimals
    assert_allclose(got, RNG_POINTS, atol=1e-6)


def test_npz_single_array_under_any_key(tmp_path: Path) -> None:
    np.savez(tmp_path / "a.npz", cloud=RNG_POINTS)
    assert_allclose(load_cloud(tmp_path / "a.npz"), RNG_POINTS)


def test_npz_with_several_arrays_needs_points_key(tmp_path: Path) -> None:
    np.savez(tmp_path / "a.npz", a=RNG_POINTS, b=RNG_POINTS)
    with pytest.raises(InputError, match="none is named 'points'"):
        load_cloud(tmp_path / "a.npz")


def test_text_with_header_and_extra_columns(tmp_path: Path) -> None:
    rows = np.hstack([RNG_POINTS, np.ones((50, 3))])  # x y z r g b
    text = "x y z r g b\n" + "\n".join(" ".join(f"{v:.6f}" for v in r) for r in rows)
    (tmp_path / "c.txt").write_text(text)
    assert_allclose(load_cloud(tmp_path / "c.txt"), RNG_POINTS, atol=1e-6)


def test_nan_and_inf_are_dropped_and_counted(tmp_path: Path) -> None:
    pts = RNG_POINTS.copy()
    pts[3] = np.nan
    pts[7, 1] = np.inf
    pts[9, 2] = -np.inf
    for suffix in (".npz", ".ply", ".xyz"):
        path = tmp_path / f"nan{suffix}"
        if suffix == ".npz":
            np.savez(path, points=pts)
        else:
            save_cloud(path, pts)
        scene = load_scene(path)
        assert scene.dropped_nonfinite == 3, suffix
        assert scene.points.shape == (47, 3)
        assert np.isfinite(scene.points).all()
    # a sensor's FLT_MAX for a pixel without a return, in float32 and float64:
    # dropped as NaN is (the voxel grid's arithmetic overflowed on it)
    flt_max = float(np.finfo(np.float32).max)
    for dtype in (np.float32, np.float64):
        marked = pts.astype(dtype)
        marked[11] = flt_max
        marked[12, 0] = -flt_max
        scene = scene_from_arrays(marked)
        assert scene.dropped_nonfinite == 5
        assert np.abs(scene.points).max() < 10.0


def test_points_without_depth_are_dropped_and_counted(tmp_path: Path) -> None:
    """A pixel without a depth comes back as (0, 0, 0) in its camera's frame:
    dropped from a plain cloud and from a posed view (before it is moved into
    the world, where it would land on the camera's centre), and counted apart
    from NaN/inf."""
    pts = RNG_POINTS.copy()
    pts[[2, 5, 11]] = 0.0
    pts[4] = np.nan
    pts[6, 0] = 0.0  # one coordinate at zero is a point
    np.savez(tmp_path / "zeros.npz", points=pts)
    scene = load_scene(tmp_path / "zeros.npz")
    assert (scene.dropped_no_depth, scene.dropped_nonfinite) == (3, 1)
    assert scene.points.shape == (46, 3)
    assert scene.points.any(axis=1).all()
    T = random_rigid(np.random.default_rng(1))
    posed = scene_from_arrays([(pts, T)])
    assert posed.dropped_no_depth == 3
    assert not np.isclose(posed.points, T[:3, 3], atol=1e-12).all(axis=1).any()


def test_a_cloud_without_any_depth(tmp_path: Path) -> None:
    np.savez(tmp_path / "zero.npz", points=np.zeros((10, 3)))
    with pytest.raises(InputError, match="no point with a depth") as info:
        load_scene(tmp_path / "zero.npz")
    assert "range and exposure" in (info.value.hint or "")


# --------------------------------------------------------------------------------
# scenes with several views
# --------------------------------------------------------------------------------
def test_scene_yaml_merges_views_into_world(tmp_path: Path) -> None:
    synth = small_scene("box", "upright", 0)
    yaml_path = write_scene_yaml(tmp_path, synth.views)
    scene = load_scene([yaml_path])
    assert len(scene.views) == 3
    # float32 storage of camera-frame points: well under a millimetre
    assert_allclose(scene.points, synth.points, atol=1e-5)


@pytest.mark.parametrize("mistake", ["inverted", "camera_link", "millimetres"])
def test_a_view_with_a_wrong_pose_is_named(tmp_path: Path, mistake: str) -> None:
    """A view whose T_world_camera is inverted, is the pose of ROS's camera_link
    (x forward) instead of the optical frame's, or has its translation in
    millimetres in a scene in metres lands apart from the others: the scene is
    refused naming it, before a phantom of the scene is planned on."""
    views = [
        View(v.points, v.T_world_camera.copy(), v.name)
        for v in small_scene("box", "upright", 0).views
    ]
    load_scene(write_scene_yaml(tmp_path / "ok", views))  # agrees
    T = views[1].T_world_camera
    if mistake == "inverted":
        wrong = np.linalg.inv(T)
    elif mistake == "camera_link":  # the optical frame's axes in camera_link's
        wrong = T @ np.linalg.inv(transform_from([[0, 0, 1], [-1, 0, 0], [0, -1, 0]]))
    else:
        wrong = T.copy()
        wrong[:3, 3] *= 1000.0
    views[1].T_world_camera = wrong
    with pytest.raises(InputError, match="view 'view_1.npz' shares almost") as info:
        load_scene(write_scene_yaml(tmp_path / "bad", views))
    assert "optical frame" in (info.value.hint or "")
    # two views alone: which of them is wrong cannot be told
    with pytest.raises(InputError, match="views 'view_0.npz', 'view_1.npz' share"):
        load_scene(write_scene_yaml(tmp_path / "two", views[:2]))
    # a rig whose cameras see apart says so, and is merged as given (a view
    # metres away still spans too much for a tabletop)
    path = write_scene_yaml(tmp_path / "apart", views)
    path.write_text(path.read_text() + "views_overlap: false\n")
    pairs = [(v.points, v.T_world_camera) for v in views]
    if mistake == "millimetres":
        with pytest.raises(InputError, match="spans"):
            load_scene(path)
    else:
        assert len(load_scene(path).views) == 3
        assert len(scene_from_arrays(pairs, views_overlap=False).views) == 3


def test_two_cameras_over_a_wide_table_agree() -> None:
    """Two cameras 2 m from a 3 m table, posed right, seeing it at 1.3 and
    1.1 cm spacing: a thousand points of one view lie 9 cm apart there, so
    matched against the other's thousand they met few of them and the scene
    was refused as misposed; against all of the other's points they agree. The
    same view half a metre off is still refused."""
    rng = np.random.default_rng(0)

    def view(camera: np.ndarray, step: float) -> tuple[np.ndarray, np.ndarray]:
        axis = np.arange(-1.5, 1.5, step)
        grid = np.stack(np.meshgrid(axis, axis), -1).reshape(-1, 2)
        table = np.column_stack([grid, np.zeros(len(grid))])  # world, z up
        z = -camera / np.linalg.norm(camera)  # looking at the origin
        x = np.cross(z, [0.0, 0.0, 1.0])
        x /= np.linalg.norm(x)
        T = np.eye(4)
        T[:3, :3] = np.column_stack([x, np.cross(z, x), z])
        T[:3, 3] = camera
        seen = table + rng.normal(0, 0.001, table.shape)
        return transform_points(invert_transforms(T), seen), T

    a = view(np.array([2.0, 0.0, 1.2]), 0.013)
    b = view(np.array([0.0, 2.0, 1.2]), 0.011)
    assert len(scene_from_arrays([a, b]).views) == 2
    moved = b[1].copy()
    moved[:3, 3] += [0.0, 0.0, 0.5]
    with pytest.raises(InputError, match="share almost nothing"):
        scene_from_arrays([a, (b[0], moved)])


def test_scene_yaml_in_millimetres(tmp_path: Path) -> None:
    T = random_rigid(np.random.default_rng(1), reach=0.5)
    np.savez(tmp_path / "v.npz", points=RNG_POINTS * 1000.0)
    T_mm = T.copy()
    T_mm[:3, 3] *= 1000.0
    doc = {
        "units": "mm",
        "views": [{"cloud": "v.npz", "T_world_camera": T_mm.tolist()}],
    }
    (tmp_path / "s.yaml").write_text(yaml.safe_dump(doc))
    scene = load_scene(tmp_path / "s.yaml")
    assert_allclose(scene.points, transform_points(T, RNG_POINTS), atol=1e-9)


def test_scene_from_arrays_with_poses() -> None:
    rng = np.random.default_rng(2)
    T0, T1 = random_rigid(rng, 0.5), random_rigid(rng, 0.5)
    world = RNG_POINTS
    views = [
        (transform_points(invert_transforms(T0), world), T0),
        (transform_points(invert_transforms(T1), world[:20]), T1),
    ]
    scene = scene_from_arrays(views)
    assert_allclose(scene.points, np.vstack([world, world[:20]]), atol=1e-12)
    single = scene_from_arrays(world)
    assert_allclose(single.points, world)


def test_icp_refines_a_perturbed_view() -> None:
    from scipy.spatial.transform import Rotation

    from wsgrasp.geometry import transform_from
    from wsgrasp.perception.synth import synth_scene

    synth = synth_scene("box", seed=0, table_size=0.4)
    # a 2 degree, 1 cm error on the second camera's pose
    rot = Rotation.from_rotvec([0.0, 0.01, 0.03]).as_matrix()
    err = transform_from(rot, [0.01, -0.005, 0.003])
    views = [(v.points, v.T_world_camera) for v in synth.views]
    views[1] = (views[1][0], err @ views[1][1])
    refined = scene_from_arrays(views, icp=True)
    p = synth.views[1].points
    truth = transform_points(synth.views[1].T_world_camera, p)

    def error(T: np.ndarray) -> float:
        return float(np.linalg.norm(transform_points(T, p) - truth, axis=1).mean())

    assert error(views[1][1]) > 0.01
    assert error(refined.views[1].T_world_camera) < 0.002


def test_several_clouds_without_poses_need_registered(tmp_path: Path) -> None:
    a = save_cloud(tmp_path / "a.npz", RNG_POINTS)
    b = save_cloud(tmp_path / "b.npz", RNG_POINTS + 0.01)
    with pytest.raises(InputError, match="without camera poses") as info:
        load_scene([a, b])
    assert "scene YAML" in str(info.value) and "--registered" in str(info.value)
    scene = load_scene([a, b], registered=True)
    assert scene.points.shape == (100, 3)


# --------------------------------------------------------------------------------
# bad input
# --------------------------------------------------------------------------------
def test_missing_file(tmp_path: Path) -> None:
    with pytest.raises(InputError, match="does not exist"):
        load_scene(tmp_path / "nope.ply")


def test_unknown_format(tmp_path: Path) -> None:
    (tmp_path / "cloud.las").write_text("x")
    with pytest.raises(InputError, match="unknown format '.las'") as info:
        load_cloud(tmp_path / "cloud.las")
    assert info.value.hint


@pytest.mark.parametrize("suffix", [".npz", ".xyz", ".ply"])
def test_empty_cloud(tmp_path: Path, suffix: str) -> None:
    path = tmp_path / f"empty{suffix}"
    if suffix == ".npz":
        np.savez(path, points=np.zeros((0, 3)))
    elif suffix == ".xyz":
        path.write_text("")
    else:
        path.write_text(
            "ply\nformat ascii 1.0\nelement vertex 0\nproperty float x\n"
            "property float y\nproperty float z\nend_header\n"
        )
    with pytest.raises(InputError, match="empty|0 points|shape"):
        load_scene(path)


def test_all_nan_cloud(tmp_path: Path) -> None:
    np.savez(tmp_path / "nan.npz", points=np.full((10, 3), np.nan))
    with pytest.raises(InputError, match="no finite point"):
        load_scene(tmp_path / "nan.npz")


@pytest.mark.parametrize("shape", [(10,), (10, 2), (10, 4, 2)], ids=str)
def test_wrong_shape(tmp_path: Path, shape: tuple[int, ...]) -> None:
    np.save(tmp_path / "bad.npy", np.zeros(shape))
    with pytest.raises(InputError, match=r"expected \(n, 3\)"):
        load_cloud(tmp_path / "bad.npy")
    with pytest.raises(InputError, match=r"expected \(n, 3\)"):
        scene_from_arrays(np.zeros(shape))


def test_millimetre_cloud_is_reported() -> None:
    synth = small_scene("box", "upright", 0)
    with pytest.raises(InputError, match="millimetres") as info:
        scene_from_arrays(synth.points * 1000.0)
    assert "divide the points by 1000" in str(info.value)


def test_non_numeric_text(tmp_path: Path) -> None:
    (tmp_path / "c.xyz").write_text("a b c\nd e f\n")
    with pytest.raises(InputError, match="not a table of numbers"):
        load_cloud(tmp_path / "c.xyz")


def test_scene_yaml_errors(tmp_path: Path) -> None:
    np.savez(tmp_path / "v.npz", points=RNG_POINTS)
    bad_pose = [[1, 0, 0, 0], [0, 2, 0, 0], [0, 0, 1, 0], [0, 0, 0, 1]]
    (tmp_path / "s.yaml").write_text(
        yaml.safe_dump({"views": [{"cloud": "v.npz", "T_world_camera": bad_pose}]})
    )
    with pytest.raises(InputError, match="not orthonormal"):
        load_scene(tmp_path / "s.yaml")
    (tmp_path / "t.yaml").write_text(yaml.safe_dump({"views": [{"clouds": "v.npz"}]}))
    with pytest.raises(InputError, match="t.yaml"):
        load_scene(tmp_path / "t.yaml")
    (tmp_path / "u.yaml").write_text(yaml.safe_dump({"views": [{"cloud": "w.npz"}]}))
    with pytest.raises(InputError, match="w.npz.*does not exist"):
        load_scene(tmp_path / "u.yaml")
    with pytest.raises(InputError, match="alone"):
        load_scene([tmp_path / "u.yaml", tmp_path / "v.npz"])


def test_a_pose_written_with_few_decimals_or_transposed(tmp_path: Path) -> None:
    """A rotation printed to 3 or 4 decimals (tf2_echo, calibration exports) is
    taken as the nearest rotation; a matrix given column after column is named
    as transposed; a rotation off by more than rounding is still refused."""
    np.savez(tmp_path / "v.npz", points=RNG_POINTS)
    T = random_rigid(np.random.default_rng(3), reach=0.5)

    def scene(pose: np.ndarray, name: str):
        path = tmp_path / f"{name}.yaml"
        doc = {"views": [{"cloud": "v.npz", "T_world_camera": pose.tolist()}]}
        path.write_text(yaml.safe_dump(doc))
        return load_scene(path)

    exact = scene(T, "exact").points
    for decimals in (3, 4):
        rounded = np.round(T, decimals)
        assert np.abs(rounded[:3, :3] @ rounded[:3, :3].T - np.eye(3)).max() > 1e-6
        assert_allclose(scene(rounded, f"r{decimals}").points, exact, atol=3e-3)
    with pytest.raises(InputError, match="transposed") as info:
        scene(T.T, "transposed")
    assert "row after row" in (info.value.hint or "")
    skewed = T.copy()
    skewed[:3, :3] *= 1.02
    with pytest.raises(InputError, match="not orthonormal .* up to 0.04"):
        scene(skewed, "skewed")


@pytest.mark.parametrize("suffix", [".npy", ".npz"])
def test_damaged_array_header_is_one_input_error(tmp_path: Path, suffix: str) -> None:
    """A flipped bit that turns the header's ``(`` into ``)`` reaches numpy's
    Python-2 header filter, whose tokenizer raises; the loader says what is wrong."""
    path = tmp_path / f"c{suffix}"
    if suffix == ".npy":
        np.save(path, RNG_POINTS)
        raw = bytearray(path.read_bytes())
    else:  # stored, not compressed, so the header's bytes are in the file
        np.savez(path, points=RNG_POINTS)
        raw = bytearray(path.read_bytes())
    i = raw.index(b"'shape': (") + len(b"'shape': ")
    raw[i] ^= 0x01  # '(' (0x28) -> ')' (0x29)
    path.write_bytes(bytes(raw))
    with pytest.raises(InputError, match="array header is damaged|not a readable"):
        load_cloud(path)


def test_scene_info_mirrors_in_the_hidden_sides_as_the_spec_says(tmp_path, capsys):
    """``scene info --spec`` with ``object_frame.mirror_hidden`` counts the
    points mirrored in for one camera, as a plan with that spec adds them;
    with three cameras, or without the setting, none."""
    import json

    from wsgrasp.cli import main
    from wsgrasp.default_specs import default_spec

    spec = default_spec("franka_hand")[1]  # the Franka hand's: mirror_hidden on
    views = small_scene("box", "upright", 0).views
    counts = {}
    for label, vs, args in (
        ("one", views[:1], ["--spec", spec]),
        ("all", views, ["--spec", spec]),
        ("off", views[:1], []),
    ):
        path = write_scene_yaml(tmp_path / label, vs)
        assert main(["scene", "info", str(path), "--json", *args]) == 0
        counts[label] = json.loads(capsys.readouterr().out)["mirrored_points"]
    assert counts["one"] > 100 and counts["all"] == 0 and counts["off"] == 0


def test_scene_info_gives_the_tables_tilt_where_views_have_poses(tmp_path, capsys):
    """With the views' poses, ``scene info`` says how far the table's normal is
    from the world's z axis (a wrong pose shows there); without, it does not."""
    from wsgrasp.cli import main

    views = small_scene("box", "upright", 0).views
    assert main(["scene", "info", str(write_scene_yaml(tmp_path, views))]) == 0
    assert "0.0° from the world's z axis" in " ".join(capsys.readouterr().out.split())
    np.savez(tmp_path / "one.npz", points=views[0].points)
    assert main(["scene", "info", str(tmp_path / "one.npz")]) == 0
    assert "world's z" not in capsys.readouterr().out


def test_a_tilted_table_under_camera_poses_is_a_warning():
    """A plan whose views have poses, its table tilted far from the world's z
    axis (one view given camera_link's pose), says so in ``warnings``; the
    same view with its pose, or without one (its camera's frame), does not."""
    from wsgrasp.api import Pipeline
    from wsgrasp.default_specs import default_spec
    from wsgrasp.spec import load_spec

    view = small_scene("box", "upright", 0).views[0]
    link = transform_from([[0, 0, 1], [-1, 0, 0], [0, -1, 0]])
    pipe = Pipeline(load_spec(default_spec("franka_hand")[0]))
    wrong = pipe.plan(
        scene_from_arrays([(view.points, view.T_world_camera @ np.linalg.inv(link))])
    )
    assert len(wrong.warnings) == 1 and "camera_link" in wrong.warnings[0]
    assert wrong.to_json()["warnings"] == wrong.warnings
    assert (
        pipe.plan(scene_from_arrays([(view.points, view.T_world_camera)])).warnings
        == []
    )
    assert pipe.plan(scene_from_arrays(view.points)).warnings == []


def test_one_camera_posed_in_millimetres_is_a_warning():
    """One view whose pose's translation is in millimetres in a scene in metres:
    no other view to disagree with, and the table level, so the plan went on a
    thousand times too far out without a word. The cameras' distance from the
    world's origin says so; the same view with its pose does not."""
    from wsgrasp.api import Pipeline
    from wsgrasp.default_specs import default_spec
    from wsgrasp.spec import load_spec

    view = small_scene("box", "upright", 0).views[0]
    pipe = Pipeline(load_spec(default_spec("franka_hand")[0]))
    mm = view.T_world_camera.copy()
    mm[:3, 3] *= 1000.0
    wrong = pipe.plan(scene_from_arrays([(view.points, mm)]))
    assert len(wrong.warnings) == 1 and "millimetres" in wrong.warnings[0]
    assert "m from the world's origin" in wrong.warnings[0]
    right = pipe.plan(scene_from_arrays([(view.points, view.T_world_camera)]))
    assert right.warnings == []


@pytest.mark.parametrize("mistake", ["inverted", "camera_link", "scalar_first"])
@pytest.mark.parametrize("seed", [0, 1, 2, 3])
def test_the_tilt_warning_names_the_mistake_that_levels_the_table(
    mistake: str, seed: int
) -> None:
    """One view's pose with a common mistake, the table tilted by it: the warning
    names that mistake (the one whose undoing levels the table), whatever the
    camera's pose."""
    from scipy.spatial.transform import Rotation

    from wsgrasp.api import TABLE_TILT_WARNING_DEG, Pipeline
    from wsgrasp.default_specs import default_spec
    from wsgrasp.spec import load_spec

    view = small_scene("box", "upright", seed).views[0]
    T = view.T_world_camera
    if mistake == "inverted":
        wrong = np.linalg.inv(T)
        said = "T_camera_world"
    elif mistake == "camera_link":
        wrong = T @ np.linalg.inv(transform_from([[0, 0, 1], [-1, 0, 0], [0, -1, 0]]))
        said = "camera_link"
    else:  # x, y, z, w read from w, x, y, z
        q = np.roll(Rotation.from_matrix(T[:3, :3]).as_quat(), 1)
        wrong = T.copy()
        wrong[:3, :3] = Rotation.from_quat(q).as_matrix()
        said = "scalar first (w, x, y, z)"
    pipe = Pipeline(load_spec(default_spec("franka_hand")[0]))
    result = pipe.plan(scene_from_arrays([(view.points, wrong)]))
    tilted = [w for w in result.warnings if "world's z axis" in w]
    # the table's normal under the wrong pose (the world's z under the right one)
    up = wrong[:3, :3] @ T[:3, :3].T @ np.array([0.0, 0.0, 1.0])
    tilt = np.degrees(np.arccos(min(1.0, abs(up[2]))))
    if tilt < TABLE_TILT_WARNING_DEG - 1.0:  # a mistake that keeps it level
        assert not tilted  # (a turn about z alone) cannot be told from one view
        return
    assert tilt > TABLE_TILT_WARNING_DEG + 1.0  # no case on the edge
    assert len(tilted) == 1, result.warnings
    assert said in tilted[0] and "levels the table" in tilted[0], tilted[0]


def test_a_scene_yaml_takes_a_pose_as_tf2_gives_it(tmp_path: Path) -> None:
    """``T_world_camera: {translation, quaternion_xyzw}`` (tf2_echo's pose, the
    scalar last) is the same view as its 4x4 matrix, in the scene's units; a
    quaternion that is not of unit length is refused naming the view."""
    from scipy.spatial.transform import Rotation

    views = small_scene("box", "upright", 0).views
    path = write_scene_yaml(tmp_path / "m", views)
    doc = yaml.safe_load(path.read_text())
    for entry, view in zip(doc["views"], views, strict=True):
        T = view.T_world_camera
        entry["T_world_camera"] = {
            "translation": [float(v) * 100 for v in T[:3, 3]],
            "quaternion_xyzw": Rotation.from_matrix(T[:3, :3]).as_quat().tolist(),
        }
    doc["units"] = "cm"  # clouds and translations
    for entry in doc["views"]:  # the clouds in centimetres too
        cloud = tmp_path / "m" / entry["cloud"]
        points = load_cloud(cloud)
        np.save(cloud.with_suffix(".npy"), points * 100)
        entry["cloud"] = cloud.with_suffix(".npy").name
    tf = tmp_path / "m" / "tf.yaml"
    tf.write_text(yaml.safe_dump(doc))
    got, want = load_scene(tf), load_scene(path)
    for a, b in zip(got.views, want.views, strict=True):
        assert_allclose(a.T_world_camera, b.T_world_camera, atol=1e-9)
    assert_allclose(got.points, want.points, atol=1e-9)
    doc["views"][1]["T_world_camera"]["quaternion_xyzw"] = [0.5, 0.5, 0.5, 0.9]
    tf.write_text(yaml.safe_dump(doc))
    with pytest.raises(InputError, match=r"views\[1\]\.T_world_camera\.quaternion"):
        load_scene(tf)


def test_scene_from_arrays_takes_a_pose_as_tf2_gives_it() -> None:
    """The Python API takes each view's pose as a matrix, a CameraPose or its
    data, the same view each way; a mapping that is no pose is named."""
    from scipy.spatial.transform import Rotation

    from wsgrasp.perception.io import CameraPose

    views = small_scene("box", "upright", 0).views
    matrices = [(v.points, v.T_world_camera) for v in views]
    poses = []
    for k, v in enumerate(views):
        T = v.T_world_camera
        data = {
            "translation": T[:3, 3].tolist(),
            "quaternion_xyzw": Rotation.from_matrix(T[:3, :3]).as_quat().tolist(),
        }
        poses.append((v.points, CameraPose(**data) if k else data))
    want, got = scene_from_arrays(matrices), scene_from_arrays(poses)
    assert_allclose(got.points, want.points, atol=1e-9)
    with pytest.raises(InputError, match=r"views\[0\]\.T_world_camera .* is no pose"):
        scene_from_arrays([(views[0].points, {"translation": [0, 0, 0]})])
