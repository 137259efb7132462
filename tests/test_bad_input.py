"""Bad input never gets a wrong answer: each class of bad input the command line
and the Python API meet, with the one error (or the honest "no grasp") it gets.

Every case here was a wrong or unclear answer before: an "internal error", a
grasp under the table, a silently accepted value, or a message that blamed the
wrong thing. The randomised counterparts are in ``test_fuzz.py``.
"""

from __future__ import annotations

import json
import math
import os
import re
from pathlib import Path

import numpy as np
import pytest
import yaml
from bad_scenes import noisy_box, table_slab
from PIL import Image
from test_record_fakes import box_scene, fake_gripper, fake_spec

from wsgrasp.api import Pipeline
from wsgrasp.cli import main
from wsgrasp.errors import GripperError, InputError, RecordingError, SpecError
from wsgrasp.perception.io import load_cloud
from wsgrasp.perception.types import Scene, View
from wsgrasp.spec import load_spec

ROOT = Path(__file__).resolve().parents[1]
SPEC = ROOT / "examples" / "specs" / "franka.yaml"


def run_cli(capsys: pytest.CaptureFixture[str], *args: str) -> tuple[int, str]:
    code = main([str(a) for a in args])
    out = capsys.readouterr()
    return code, out.out + out.err


# ------------------------------------------------------------------------------
# 1. usage errors are usage errors
# ------------------------------------------------------------------------------
USAGE = [
    [],
    ["plan"],
    ["plan", "x.npz", "--bogus"],
    ["nosuch"],
    ["eval", "--objects", "a", "b"],
    ["plan", "x.npz", "--spec", str(SPEC), "--at", "noon"],
    ["plan", "x.npz", "--spec", str(SPEC), "--at", "nan"],
    ["bench", "--repeat", "0"],
    ["eval", "--friction", "nan"],
    ["eval", "--mass", "-1"],
    ["scene", "synth", "--out", "x.npz", "--width", "0"],
    ["scene", "synth", "--out", "x.npz", "--elevation", "100"],
    ["scene", "synth", "--out", "x.npz", "--noise", "inf"],
    ["scene", "synth", "--out", "x.npz", "--flying", "1.5"],
]


@pytest.mark.parametrize("args", USAGE, ids=[" ".join(a) or "(none)" for a in USAGE])
def test_usage_errors_exit_2_with_clicks_message(capsys, args):
    code, text = run_cli(capsys, *args)
    assert code == 2, text
    assert "internal error" not in text
    assert "Usage:" in text


def test_os_errors_name_the_path_and_the_fix(capsys, tmp_path):
    blocker = tmp_path / "afile"
    blocker.write_text("x")
    cloud = tmp_path / "scene.npy"
    np.save(cloud, box_scene(views=1).points)
    spec = tmp_path / "spec.yaml"
    data = yaml.safe_load(SPEC.read_text())
    data["record"] = {"dir": str(blocker)}
    spec.write_text(yaml.safe_dump(data))
    for args in (
        ["plan", cloud, "--spec", SPEC, "--record", blocker / "run.mcap"],
        ["plan", cloud, "--spec", spec],
    ):
        code, text = run_cli(capsys, *args)
        assert code == 2, text
        assert "internal error" not in text
        assert str(blocker) in text and "fix:" in text


def test_os_error_message_names_path_and_fix():
    import errno

    from wsgrasp.errors import os_error_message

    text = os_error_message(PermissionError(errno.EACCES, "Permission denied", "/x/y"))
    assert text.startswith("/x/y: Permission denied (fix: ")


# ------------------------------------------------------------------------------
# 2. a grasp is never under the table
# ------------------------------------------------------------------------------
def _posed_scene(world: np.ndarray, camera_z: float) -> Scene:
    """One view of world points from a camera at height ``camera_z`` (a pose is
    given, so the camera's side of the table is known)."""
    T = np.eye(4)
    T[:3, 3] = [0.05, -0.02, camera_z]
    cam = world - T[:3, 3]
    return load_scene_from_view(View(points=cam, T_world_camera=T, name="cam"))


def load_scene_from_view(view: View) -> Scene:
    from wsgrasp.perception.io import scene_from_arrays

    return scene_from_arrays([(view.points, view.T_world_camera)])


def _table(rng: np.random.Generator, n: int = 8000) -> np.ndarray:
    return np.column_stack(
        [rng.uniform(-0.4, 0.4, n), rng.uniform(-0.4, 0.4, n), np.zeros(n)]
    )


def _box(rng, center, size, n=1500) -> np.ndarray:
    p = rng.uniform(-0.5, 0.5, size=(n, 3))
    axis = rng.integers(0, 3, size=n)
    p[np.arange(n), axis] = np.sign(p[np.arange(n), axis]) * 0.5
    return p * size + center


def test_object_under_the_table_is_not_grasped_when_the_camera_is_above():
    # the only thing standing on the plane hangs under it (a drawer, a shelf
    # below): seen from above, nothing stands on the table
    rng = np.random.default_rng(0)
    world = np.concatenate([_table(rng), _box(rng, [0, 0, -0.06], [0.04, 0.06, 0.12])])
    pipeline = Pipeline(fake_spec(), gripper=fake_gripper())
    with pytest.raises(InputError, match="below the table"):
        pipeline.plan(_posed_scene(world, camera_z=0.5))


def test_object_above_is_chosen_over_one_below_when_the_camera_is_above():
    rng = np.random.default_rng(1)
    above = _box(rng, [0.08, 0, 0.06], [0.04, 0.06, 0.12], 800)
    below = _box(rng, [-0.08, 0, -0.06], [0.05, 0.06, 0.12], 2500)
    pipeline = Pipeline(fake_spec(), gripper=fake_gripper())
    result = pipeline.plan(
        _posed_scene(np.concatenate([_table(rng), above, below]), camera_z=0.5)
    )
    assert result.found
    n = np.asarray(result.info["table_normal"])
    assert n[2] > 0.99  # up is where the camera is
    assert result.T_world_object[0, 3] > 0.0  # the box above, not the larger one


def test_objects_on_both_sides_without_poses_warn_which_side_was_taken():
    # a glossy table's reflection of the box under it: without a camera pose
    # either side may be up, and the plan says so; with one, the box is taken
    from wsgrasp.api import as_scene

    rng = np.random.default_rng(13)
    box = _box(rng, [0.02, 0.0, 0.05], [0.05, 0.05, 0.1], 1500)
    world = np.concatenate([_table(rng, 20000), box, box * [1.0, 1.0, -1.0]])
    pipeline = Pipeline(fake_spec(), gripper=fake_gripper())
    bare = pipeline.plan(as_scene(world))
    assert bare.found
    (warning,) = [w for w in bare.warnings if "both sides of the table" in w]
    assert "T_world_camera" in warning
    posed = pipeline.plan(_posed_scene(world, camera_z=0.6))
    assert posed.found and posed.T_world_object[2, 3] > 0.0
    assert not [w for w in posed.warnings if "both sides" in w]
    # one side alone: no warning
    alone = pipeline.plan(as_scene(np.concatenate([_table(rng, 20000), box])))
    assert alone.found and not [w for w in alone.warnings if "both sides" in w]


def test_cameras_below_the_table_are_refused():
    rng = np.random.default_rng(2)
    world = np.concatenate([_table(rng), _box(rng, [0, 0, 0.06], [0.04, 0.06, 0.12])])
    pipeline = Pipeline(fake_spec(), gripper=fake_gripper())
    with pytest.raises(InputError, match="(?i)below"):
        pipeline.plan(_posed_scene(world, camera_z=-0.5))


def test_a_table_alone_is_no_object(tmp_path):
    rng = np.random.default_rng(3)
    world = _table(rng, 20000) + rng.normal(0, 0.001, (20000, 3))
    pipeline = Pipeline(fake_spec(), gripper=fake_gripper())
    with pytest.raises(InputError, match="(?i)nothing stands|no object"):
        pipeline.plan(_posed_scene(world, camera_z=0.5))


def test_every_plan_ends_with_the_table_check(monkeypatch):
    import wsgrasp.api as api

    # a search that (wrongly) puts its chosen pose 20 cm under the table
    real_search = Pipeline.search

    def sunken(self, prepared):
        out = real_search(self, prepared)
        out.candidates.T_world_ee[out.best, 2, 3] -= 0.2
        return out

    monkeypatch.setattr(Pipeline, "search", sunken)
    monkeypatch.setattr(
        api, "_with_clear_pregrasp", lambda out, *a, **k: (out.best, None)
    )
    pipeline = Pipeline(fake_spec(), gripper=fake_gripper())
    with pytest.raises(AssertionError, match="enters the table"):
        pipeline.plan(box_scene())


def test_grasps_and_pregrasps_clear_the_table():
    from wsgrasp.api import _hits_table

    pipeline = Pipeline(fake_spec(), gripper=fake_gripper())
    result = pipeline.plan(box_scene())
    assert result.found
    prep = pipeline.prepare(box_scene())
    table = prep.search_input.table
    assert not _hits_table(pipeline.gripper, table, result.T_world_ee)
    assert not _hits_table(pipeline.gripper, table, result.T_world_pregrasp)


@pytest.mark.parametrize(
    ("seed", "fold"), [(1, 0.0), (2, 0.1)], ids=["edges", "cloth_fold"]
)
def test_a_table_alone_with_its_edges_in_view_is_nothing_to_grasp(
    capsys, tmp_path, seed, fold
):
    # no pose: the slab's side faces (or a cloth over its edge) hang below the
    # table along its border; they were the "object", the table turned upside
    # down, and allegro_right was sent 8-12 cm under the table top
    cloud = tmp_path / "table.npy"
    np.save(cloud, table_slab(np.random.default_rng(seed), fold=fold))
    for gripper in ("allegro_right", "franka_hand"):
        code, text = run_cli(
            capsys, "plan", cloud, "--gripper", gripper, "--no-record", "--json"
        )
        assert code == 2, text
        assert "nothing to grasp" in text and "border" in text
        assert "T_world_ee" not in text


def test_an_object_on_a_table_with_its_edges_in_view_is_found_above_it():
    rng = np.random.default_rng(3)
    world = np.concatenate(
        [table_slab(rng), _box(rng, [0.1, 0.05, 0.06], [0.04, 0.06, 0.12])]
    )
    result = Pipeline(fake_spec(), gripper=fake_gripper()).plan(world)
    assert result.found, result.hint
    assert result.info["table_normal"][2] > 0.99
    assert result.T_world_ee[2, 3] > 0.0 and result.T_world_pregrasp[2, 3] > 0.0


def test_a_grasp_under_the_table_plane_is_never_returned(monkeypatch):
    # a search that (wrongly) finds every grasp half a metre under the table,
    # deeper than the table's superellipsoid reaches
    real_search = Pipeline.search

    def sunken(self, prepared):
        out = real_search(self, prepared)
        out.candidates.T_world_ee[:, 2, 3] -= 0.5
        out.candidates.T_world_gwc[:, 2, 3] -= 0.5
        return out

    monkeypatch.setattr(Pipeline, "search", sunken)
    pipeline = Pipeline(fake_spec(), gripper=fake_gripper())
    result = pipeline.plan(box_scene())
    assert not result.found
    assert result.T_world_ee is None and result.T_world_pregrasp is None
    assert "under the table" in result.hint


# ------------------------------------------------------------------------------
# 3. specs refuse what cannot work, at load and in `spec check` alike
# ------------------------------------------------------------------------------
def _spec_with(tmp_path: Path, name: str, change) -> Path:
    data = yaml.safe_load(SPEC.read_text())
    change(data)
    path = tmp_path / name
    path.write_text(yaml.safe_dump(data))
    return path


def _set(path: str, value):
    def change(data):
        *head, last = path.split(".")
        node = data
        for key in head:
            node = node.setdefault(key, {}) if not key.isdigit() else node[int(key)]
        node[int(last) if last.isdigit() else last] = value

    return change


BAD_SPECS = {
    "semi_axes_nan": (_set("table.semi_axes", [math.nan, 0.3, 0.05]), "finite"),
    "semi_axes_negative": (_set("table.semi_axes", [-0.3, 0.3, 0.05]), "greater"),
    "weight_inf": (_set("scorers.0.weight", math.inf), "finite"),
    "weights_zero": (
        lambda d: [s.update(weight=0.0) for s in d["scorers"]],
        "weight 0",
    ),
    "voxel_nan": (_set("preprocess.voxel_size", math.nan), "finite"),
    "scale_zero": (_set("sampling.scale", [0.0, 0.9, 0.7]), "greater"),
    "over_memory": (
        _set("sampling", {"points": 100000, "orientations": 360}),
        "GiB",
    ),
    "plugin_option_nan": (
        _set("segmenter.options", {"plane_distance": math.nan}),
        "finite",
    ),
    "clearance_inf": (_set("table.clearance", math.inf), "finite"),
}


@pytest.mark.parametrize("case", sorted(BAD_SPECS))
def test_bad_specs_are_refused_by_spec_check_and_plan_alike(capsys, tmp_path, case):
    change, fragment = BAD_SPECS[case]
    path = _spec_with(tmp_path, f"{case}.yaml", change)
    with pytest.raises(SpecError, match=fragment):
        load_spec(path)
    cloud = tmp_path / "scene.npy"
    np.save(cloud, box_scene(views=1).points)
    code_check, text_check = run_cli(capsys, "spec", "check", path)
    code_plan, text_plan = run_cli(capsys, "plan", cloud, "--spec", path, "--no-record")
    assert code_check == code_plan == 2
    first = text_check.strip().splitlines()[0]
    assert fragment in text_check and fragment in text_plan
    assert first.split(":")[0] in text_plan


def _gripper_files(tmp_path: Path, missing: str) -> Path:
    """A spec in ``tmp_path/specs`` naming a gripper YAML beside it in
    ``grippers/`` (robotiq_2f85_like's, whose URDF names a collision mesh), with
    ``missing`` (``yaml``, ``urdf`` or ``mesh``) left out."""
    src = ROOT / "examples/plugins/robotiq_2f85_like/wsgrasp_robotiq_2f85_like"
    grippers = tmp_path / "specs" / "grippers"
    (grippers / "meshes").mkdir(parents=True)
    if missing != "yaml":
        (grippers / "robotiq_2f85_like.yaml").write_text(
            (src / "robotiq_2f85_like.yaml").read_text()
        )
    if missing != "urdf":
        (grippers / "robotiq_2f85_like.urdf").write_text(
            (src / "robotiq_2f85_like.urdf").read_text()
        )
    if missing != "mesh":
        mesh = "meshes/base_housing.stl"
        (grippers / mesh).write_bytes((src / mesh).read_bytes())
    data = yaml.safe_load(SPEC.read_text())
    data["gripper"] = "grippers/robotiq_2f85_like.yaml"
    spec = tmp_path / "specs" / "spec.yaml"
    spec.write_text(yaml.safe_dump(data, sort_keys=False))
    return spec


MISSING = {
    "yaml": ("grippers/robotiq_2f85_like.yaml", "relative to the spec file's folder"),
    "urdf": (
        "grippers/robotiq_2f85_like.urdf",
        "relative to the gripper YAML's folder",
    ),
    "mesh": ("grippers/meshes/base_housing.stl", "relative to the URDF's folder"),
}


@pytest.mark.parametrize("missing", list(MISSING))
def test_a_spec_naming_a_missing_file_is_refused_by_spec_check_and_plan_alike(
    capsys, tmp_path, monkeypatch, missing
):
    spec = _gripper_files(tmp_path, missing)
    tried, relative = MISSING[missing]
    where = tmp_path / "elsewhere"
    where.mkdir()
    monkeypatch.chdir(where)  # the paths are the spec's, not the current folder's
    cloud = tmp_path / "scene.npy"
    np.save(cloud, box_scene(views=1).points)
    code_check, text_check = run_cli(capsys, "spec", "check", spec)
    code_plan, text_plan = run_cli(capsys, "plan", cloud, "--spec", spec, "--no-record")
    assert code_check == code_plan == 2, (text_check, text_plan)
    message = text_check.strip().splitlines()[0].removeprefix("error: ")
    assert str(tmp_path / "specs" / tried) in message and relative in message
    assert message.startswith(f"{spec}:2: gripper: ")
    assert message in " ".join(text_plan.split()) or message in text_plan
    assert "current directory" not in text_check + text_plan
    with pytest.raises(SpecError, match="not found"):
        load_spec(spec)


def test_duplicate_keys_are_refused(tmp_path):
    path = tmp_path / "dup.yaml"
    path.write_text(SPEC.read_text() + "\ngripper: allegro_right\n")
    with pytest.raises(SpecError, match="given twice.*first at line"):
        load_spec(path)
    nested = tmp_path / "nested.yaml"
    nested.write_text(
        "version: 1\ngripper: franka_hand\ntable:\n  exponent: 10\n  exponent: 4\n"
    )
    with pytest.raises(SpecError, match="nested.yaml:5: key 'exponent'"):
        load_spec(nested)
    js = tmp_path / "dup.json"
    js.write_text('{"version": 1, "gripper": "a", "gripper": "b"}')
    with pytest.raises(SpecError, match="given twice"):
        load_spec(js)


def test_binary_spec_is_refused(tmp_path):
    path = tmp_path / "spec.yaml"
    path.write_bytes(bytes(range(128, 256)) * 3)
    with pytest.raises(SpecError, match="not a text file"):
        load_spec(path)


# ------------------------------------------------------------------------------
# 4. inputs read by the libraries' readers
# ------------------------------------------------------------------------------
def _ply_ascii(points: np.ndarray, names=("x", "y", "z"), declared=None) -> str:
    order = ["xyz".index(n) for n in names]
    head = (
        "ply\nformat ascii 1.0\n"
        f"element vertex {declared if declared is not None else len(points)}\n"
        + "".join(f"property float {n}\n" for n in names)
        + "end_header\n"
    )
    return head + "".join(" ".join(f"{p[i]:.6f}" for i in order) + "\n" for p in points)


def _pcd_ascii(points: np.ndarray, names=("x", "y", "z"), declared=None) -> str:
    order = ["xyz".index(n) for n in names]
    n = declared if declared is not None else len(points)
    head = (
        "VERSION .7\nFIELDS " + " ".join(names) + "\nSIZE 4 4 4\nTYPE F F F\n"
        f"COUNT 1 1 1\nWIDTH {n}\nHEIGHT 1\nVIEWPOINT 0 0 0 1 0 0 0\nPOINTS {n}\n"
        "DATA ascii\n"
    )
    return head + "".join(" ".join(f"{p[i]:.6f}" for i in order) + "\n" for p in points)


POINTS = np.random.default_rng(0).uniform(0, 1, (200, 3)) * [0.1, 0.2, 0.3]


@pytest.mark.parametrize("suffix", [".ply", ".pcd"])
def test_properties_are_read_by_name(tmp_path, suffix):
    path = tmp_path / f"zyx{suffix}"
    writer = _ply_ascii if suffix == ".ply" else _pcd_ascii
    path.write_text(writer(POINTS, names=("z", "y", "x")))
    np.testing.assert_allclose(load_cloud(path), POINTS, atol=1e-6)


@pytest.mark.parametrize("suffix", [".ply", ".pcd"])
def test_truncated_text_clouds_are_refused(tmp_path, suffix):
    path = tmp_path / f"cut{suffix}"
    writer = _ply_ascii if suffix == ".ply" else _pcd_ascii
    path.write_text(writer(POINTS[:120], declared=len(POINTS)))
    with pytest.raises(InputError, match="truncated.*200.*120"):
        load_cloud(path)


def test_truncated_binary_clouds_are_refused(tmp_path):
    import open3d as o3d

    for suffix in (".ply", ".pcd"):
        path = tmp_path / f"whole{suffix}"
        pcd = o3d.geometry.PointCloud(o3d.utility.Vector3dVector(POINTS))
        o3d.io.write_point_cloud(str(path), pcd, write_ascii=False)
        data = path.read_bytes()
        cut = tmp_path / f"cut{suffix}"
        cut.write_bytes(data[: len(data) - 500])
        with pytest.raises(InputError, match="(?i)truncated|not a readable"):
            load_cloud(cut)


def test_clouds_without_xyz_are_refused(tmp_path):
    path = tmp_path / "abc.ply"
    text = _ply_ascii(POINTS).replace("property float x", "property float a")
    path.write_text(text)
    with pytest.raises(InputError, match="(?i)vertex propert"):
        load_cloud(path)


@pytest.mark.parametrize("suffix", [".ply", ".pcd", ".npy", ".npz"])
def test_garbage_bytes_are_not_called_empty(tmp_path, suffix):
    path = tmp_path / f"noise{suffix}"
    path.write_bytes(np.random.default_rng(0).bytes(3000))
    with pytest.raises(InputError) as info:
        load_cloud(path)
    assert "empty (0 points)" not in str(info.value)
    assert "allow_pickle" not in str(info.value)


def _structured(points: np.ndarray) -> np.ndarray:
    """Points as a PointCloud2 reads into numpy: fields x, y, z, rgb."""
    out = np.zeros(
        points.shape[:-1], dtype=[(k, "<f4") for k in ("x", "y", "z", "rgb")]
    )
    for k, name in enumerate("xyz"):
        out[name] = points[..., k]
    return out


def test_structured_arrays_are_read_by_field_name(tmp_path):
    # a ROS PointCloud2 read into numpy (sensor_msgs_py's read_points,
    # ros2_numpy) and saved: fields x, y, z and rgb, flat or organised
    from wsgrasp.perception.io import scene_from_arrays

    xyz = POINTS.astype(np.float32).astype(np.float64)
    for shape in ((-1, 3), (2, -1, 3)):
        if len(xyz) % 2 and shape[0] == 2:
            continue
        path = tmp_path / "cloud.npy"
        np.save(path, _structured(xyz.reshape(shape)))
        np.testing.assert_array_equal(load_cloud(path).reshape(-1, 3), xyz)
    np.savez(tmp_path / "cloud.npz", points=_structured(xyz))
    np.testing.assert_array_equal(load_cloud(tmp_path / "cloud.npz"), xyz)
    scene = scene_from_arrays(_structured(xyz))
    np.testing.assert_array_equal(scene.points, xyz)
    # the Python API's own entry too, flat and organised
    from wsgrasp.api import as_scene

    np.testing.assert_array_equal(as_scene(_structured(xyz)).points, xyz)
    if len(xyz) % 2 == 0:
        organised = _structured(xyz.reshape(2, -1, 3))
        np.testing.assert_array_equal(as_scene(organised).points, xyz)
    pose = np.eye(4)
    assert len(as_scene([(xyz, pose), (xyz, pose)]).views) == 2
    with pytest.raises(InputError, match=r"views\[1\] is not a \(points, T_world"):
        as_scene([(xyz, pose), (xyz,)])
    flat = np.zeros(len(xyz), dtype=[("a", "<f4"), ("b", "<f4"), ("c", "<f4")])
    np.save(tmp_path / "abc.npy", flat)
    with pytest.raises(InputError, match="fields \\['a', 'b', 'c'\\].*x, y and z"):
        load_cloud(tmp_path / "abc.npy")


def test_float32_far_from_its_origin_is_refused(tmp_path):
    """A cloud in a map or UTM frame saved as float32: 5.6 million metres from
    the origin float32 steps by half a metre, and the scene planned on is
    another (it was refused as "nothing stands on the table, lower
    min_points"). Refused naming float32; the same in float64, or float32 a
    kilometre out (steps of 0.06 mm), is read."""
    offset = np.array([350_000.0, 5_600_000.0, 100.0])
    far = (POINTS + offset).astype(np.float32)
    np.save(tmp_path / "utm.npy", far)
    with pytest.raises(InputError, match="float32 coordinates as large as") as info:
        load_cloud(tmp_path / "utm.npy")
    assert "float64" in (info.value.hint or "")
    np.save(tmp_path / "utm64.npy", POINTS + offset)
    np.testing.assert_array_equal(load_cloud(tmp_path / "utm64.npy"), POINTS + offset)
    near = (POINTS + 1000.0).astype(np.float32)
    np.save(tmp_path / "km.npy", near)
    assert len(load_cloud(tmp_path / "km.npy")) == len(POINTS)


def test_a_file_named_for_another_format_is_named_by_its_bytes(tmp_path):
    """A PLY file named .npy or .pcd (numpy called it "Python objects", pypcd4
    printed its validation errors), a PNG named .npy: named for what their
    first bytes say, with the name to give them; an empty .xyz holds no point."""
    from wsgrasp.perception.io import save_cloud

    save_cloud(tmp_path / "c.ply", POINTS)
    for suffix in (".npy", ".pcd", ".xyz"):
        wrong = tmp_path / f"cloud{suffix}"
        wrong.write_bytes((tmp_path / "c.ply").read_bytes())
        with pytest.raises(InputError, match=f"named {suffix} but .* a PLY file") as e:
            load_cloud(wrong)
        assert e.value.hint == "rename it to cloud.ply"
    png = tmp_path / "depth.npy"
    png.write_bytes(b"\x89PNG\r\n\x1a\n" + bytes(64))
    with pytest.raises(InputError, match="a PNG image file"):
        load_cloud(png)
    (tmp_path / "empty.xyz").write_text("# x y z\n")
    with pytest.raises(InputError, match="holds no point"):
        load_cloud(tmp_path / "empty.xyz")


def test_one_point_repeated_is_no_tabletop():
    """5,000 copies of one point: one voxel, which the segmenter called a
    plane of 0 of 1 points (with advice on metres and plane_distance)."""
    from wsgrasp.api import Pipeline
    from wsgrasp.default_specs import default_spec
    from wsgrasp.spec import load_spec

    pipe = Pipeline(load_spec(default_spec("franka_hand")[0]))
    with pytest.raises(InputError, match="5000 points lie within 0 m of each other"):
        pipe.plan(np.tile([[0.1, 0.2, 0.5]], (5000, 1)))


def test_bad_numpy_files(tmp_path):
    empty = tmp_path / "empty.npy"
    empty.write_bytes(b"")
    with pytest.raises(InputError, match="empty or cut short"):
        load_cloud(empty)
    np.savez(tmp_path / "none.npz")
    with pytest.raises(InputError, match="holds no array"):
        load_cloud(tmp_path / "none.npz")
    whole = tmp_path / "whole.npz"
    np.savez(whole, points=POINTS)
    cut = tmp_path / "cut.npz"
    cut.write_bytes(whole.read_bytes()[:300])
    with pytest.raises(InputError, match="not a complete zip"):
        load_cloud(cut)
    np.save(tmp_path / "complex.npy", POINTS + 1j)
    with pytest.raises(InputError, match="complex128, expected real numbers"):
        load_cloud(tmp_path / "complex.npy")
    np.save(tmp_path / "objects.npy", np.array([object()] * 3, dtype=object))
    with pytest.raises(InputError, match="Python objects") as info:
        load_cloud(tmp_path / "objects.npy")
    assert "allow_pickle" not in str(info.value)


@pytest.mark.parametrize(("scale", "unit"), [(100.0, "centimetres"), (1000.0, "mm")])
def test_the_unit_check_names_the_likely_unit(scale, unit):
    from wsgrasp.perception.io import scene_from_arrays

    with pytest.raises(InputError, match=unit):
        scene_from_arrays(box_scene(views=1).points * scale)


def test_a_cloud_in_inches_gets_a_units_hint_where_nothing_is_found(capsys, tmp_path):
    # a 0.5 m scene in inches spans about 20 units, which the unit check lets
    # through; every object then looks 39 times too large
    points = box_scene(views=1).points
    cloud = tmp_path / "inches.npy"
    np.save(cloud, points / 0.0254)
    code, text = run_cli(capsys, "plan", cloud, "--spec", SPEC, "--no-record")
    assert code == 2, text
    assert "inches" in text and "0.0254" in text and "Traceback" not in text
    # the same scene in metres needs no such hint, and the same scene in a
    # scene YAML with `units: in` plans as the metres one does
    np.save(cloud, points / 0.0254)
    (tmp_path / "scene.yaml").write_text(
        yaml.safe_dump(
            {"version": 1, "units": "in", "views": [{"cloud": "inches.npy"}]}
        )
    )
    from wsgrasp.perception.io import load_scene, units_hint

    assert units_hint(points) is None
    scene = load_scene(tmp_path / "scene.yaml")
    np.testing.assert_allclose(scene.points, points, atol=1e-12)
    assert "depth_scale" not in text  # a cloud that is no camera's image


def test_a_depth_image_in_another_unit_is_told_its_depth_scale(capsys, tmp_path):
    """A depth image whose units are not millimetres, read as millimetres,
    puts the scene several times too far: in tenths of a millimetre, nothing
    stands on its table and the error names the depth scale; in TUM RGB-D's
    0.2 mm, a grasp is found on what is left, and the result warns that the
    object lies far from the camera, naming the depth scale. At its depth
    scale the same image plans without the warning."""
    from wsgrasp.perception.io import write_scene_yaml
    from wsgrasp.perception.synth import synth_scene

    synth = synth_scene("box", views=1, seed=2, width=320, height=240)
    path = write_scene_yaml(tmp_path / "s", synth.views, cameras=synth.cameras)
    png = tmp_path / "s" / "view_0.png"
    mm = np.asarray(Image.open(png)).astype(np.int64)
    for per_mm in (10, 5):
        Image.fromarray(np.clip(mm * per_mm, 0, 65535).astype(np.uint16)).save(png)
        code, text = run_cli(capsys, "plan", path, "--spec", SPEC, "--no-record")
        text = " ".join(text.split())
        assert "Traceback" not in text
        if per_mm == 10:
            assert code == 2 and "0.0002 for TUM RGB-D" in text, text
        else:
            assert code == 0 and "depth scale is probably wrong" in text, text
    doc = yaml.safe_load(path.read_text())
    doc["views"][0]["depth_scale"] = 0.0002
    path.write_text(yaml.safe_dump(doc))
    code, text = run_cli(capsys, "plan", path, "--spec", SPEC, "--no-record")
    assert code == 0 and "depth scale" not in text, text


def test_empty_cloud_files_through_the_cli_exit_2(capsys, tmp_path):
    for name, write in (
        ("empty.npy", lambda p: p.write_bytes(b"")),
        ("empty.npz", lambda p: np.savez(p)),
    ):
        path = tmp_path / name
        write(path)
        code, text = run_cli(capsys, "plan", path, "--spec", SPEC, "--no-record")
        assert code == 2, text
        assert "aborted" not in text


# ------------------------------------------------------------------------------
# 5. objects that cannot be grasped are said to be so
# ------------------------------------------------------------------------------
def test_an_object_wider_than_the_opening_everywhere_is_too_large():
    rng = np.random.default_rng(4)
    world = np.concatenate([_table(rng), _box(rng, [0, 0, 0.1], [0.2, 0.2, 0.2], 4000)])
    pipeline = Pipeline(fake_spec(), gripper=fake_gripper())
    result = pipeline.plan(_posed_scene(world, camera_z=0.6))
    assert not result.found
    assert "too large" in result.hint and "narrowest" in result.hint
    assert "samples" not in result.hint and "clearance" not in result.hint


def test_a_cube_larger_than_a_hand_encloses_is_too_large(capsys, tmp_path):
    # a 1 m cube on a 3 m table, its points 3 mm noisy: the noise made it look
    # hollow, and allegro_right "grasped" a top corner
    cloud = tmp_path / "cube.npy"
    world = noisy_box(np.random.default_rng(9), (1.0, 1.0, 1.0), table=3.0, step=0.01)
    np.save(cloud, world)
    data = {
        "version": 1,
        "gripper": "allegro_right",
        "segmenter": {
            "name": "ransac_dbscan",
            "options": {
                "max_object_extent": 3.0,
                "max_height": 2.0,
                "cluster_eps": 0.03,
            },
        },
        "sampling": {"mode": "approach_sphere", "grid": [5, 5, 3], "directions": 4},
    }
    spec = tmp_path / "big.yaml"
    spec.write_text(yaml.safe_dump(data))
    for gripper in ("allegro_right", "franka_hand"):
        code, text = run_cli(
            capsys, "plan", cloud, "--spec", spec, "--gripper", gripper, "--no-record"
        )
        assert code == 0, text
        text = " ".join(text.replace("│", " ").split())
        assert f"too large for {gripper}" in text, text
        assert "narrowest" in text and "workspaces span" in text


def _default_pipeline(gripper: str) -> Pipeline:
    from wsgrasp.default_specs import default_spec
    from wsgrasp.spec import PipelineSpec

    return Pipeline(PipelineSpec.model_validate(default_spec(gripper)[0]))


def test_a_target_too_large_names_another_object_that_fits():
    # the largest cluster, a 20 cm box, is the default rule's target; the 5 cm
    # box beside it fits the jaw, and the hint's rule plans for it
    rng = np.random.default_rng(11)
    world = np.concatenate(
        [
            _table(rng, 20000),
            _box(rng, [0.12, 0.0, 0.1], [0.2, 0.2, 0.2], 6000),
            _box(rng, [-0.12, 0.05, 0.04], [0.05, 0.05, 0.08], 1500),
        ]
    )
    scene = _posed_scene(world, camera_z=0.6)
    result = _default_pipeline("franka_hand").plan(scene)
    assert not result.found
    assert "too large for franka_hand" in result.hint
    match = re.search(r"`target: \{rule: nearest, point: \[([^\]]+)\]\}`", result.hint)
    assert match, result.hint
    point = np.array([float(x) for x in match.group(1).split(",")])
    assert np.linalg.norm(point[:2] - [-0.12, 0.05]) < 0.02, result.hint
    pipeline = _default_pipeline("franka_hand")
    pipeline.spec.target.rule = "nearest"
    pipeline.spec.target.point = tuple(point)
    again = pipeline.plan(scene)
    assert again.found, again.hint
    assert np.linalg.norm(again.T_world_tcp[:2, 3] - [-0.12, 0.05]) < 0.03


def test_a_target_too_large_whose_top_fits_names_the_clutter_segmenter():
    from types import SimpleNamespace

    from wsgrasp.api import _what_fits
    from wsgrasp.gripper import load_gripper
    from wsgrasp.perception.types import Plane

    g = load_gripper("franka_hand")
    rng = np.random.default_rng(12)
    table = Plane(normal=np.array([0.0, 0.0, 1.0]), offset=0.0)

    def prep(points, obstacles=()):
        return SimpleNamespace(
            search_input=SimpleNamespace(object_points=points),
            table_plane=table,
            obstacles=list(obstacles),
            obstacle_names=[f"object {k + 1}" for k in range(len(obstacles))],
        )

    # a 5 x 5 x 10 cm box on a 20 x 15 x 2 cm tray: one cluster to ransac_dbscan
    tray = _box(rng, [0.0, 0.0, 0.01], [0.2, 0.15, 0.02], 3000)
    box = _box(rng, [0.03, 0.02, 0.07], [0.05, 0.05, 0.1], 1500)
    hint = _what_fits(prep(np.concatenate([tray, box])), g)
    assert "segmenter: {name: clutter}" in hint and "rule: highest" in hint, hint
    top = re.search(r"its top (\d+) cm \((\d+\.\d) cm across, at \[([^\]]+)\]", hint)
    assert top, hint
    assert 8 <= int(top.group(1)) <= 10 and float(top.group(2)) <= 8.0
    at = np.array([float(x) for x in top.group(3).split(",")])
    assert np.linalg.norm(at[:2] - [0.03, 0.02]) < 0.01
    # a box too large all the way up, alone or beside another too large: nothing
    big = _box(rng, [0.0, 0.0, 0.1], [0.2, 0.2, 0.2], 4000)
    assert _what_fits(prep(big), g) == ""
    assert _what_fits(prep(big, [big + [0.4, 0, 0]]), g) == ""
    # a target that fits but holds no grasp, beside nothing else that fits: no
    # suggestion; beside another object that fits (the rule picked a robot's arm
    # hanging low over the table): that object
    assert _what_fits(prep(box, [big]), g) == ""
    other = box + [0.3, 0.0, 0.0]
    hint = _what_fits(prep(box, [big, other]), g)
    assert "another object on the table fits" in hint
    assert "rule: nearest, point: [0.330, 0.020" in hint, hint


@pytest.mark.parametrize("noise", [0.0, 0.003, 0.01])
def test_too_large_is_decided_from_the_spheres_for_jaws_and_hands(noise):
    from wsgrasp.api import _too_large
    from wsgrasp.gripper import load_gripper

    rng = np.random.default_rng(10)
    for name in ("franka_hand", "allegro_right"):
        g = load_gripper(name)
        side = 1.5 * g.enclosure
        # its points start one grid step above the table: it is that much lower
        cube = noisy_box(rng, (side,) * 3, table=0.0, step=0.01, noise=noise)
        why = _too_large(cube, g, noise=noise)
        assert f"too large for {name}" in why
        across = float(re.search(r"it is (\d+\.\d+) m across", why).group(1))
        # the widest noise widens it (some 3 deviations a side)
        assert abs(across - (side - 0.01)) < 0.002 + 8 * noise, why
        assert f"span at most {g.enclosure:.3f} m" in why
        # what the noise makes a convex cloud look is no concavity, but a real
        # one is: an L as wide, whose arms fit the gripper, is left to the search
        arm, t = 2.5 * g.enclosure, 0.6 * g.enclosure
        a = noisy_box(rng, (arm, t, arm), table=0.0, step=0.01, noise=0.0)
        a += [arm / 2, t / 2, 0]
        b = noisy_box(rng, (t, arm - t, arm), table=0.0, step=0.01, noise=0.0)
        b += [t / 2, arm / 2, 0]
        a = a[~((np.abs(a[:, 1] - t) < 1e-9) & (a[:, 0] < t + 1e-9))]  # shared face
        b = b[np.abs(b[:, 1] - t) > 1e-9]
        ell = np.concatenate([a, b])
        ell += rng.normal(0.0, noise, ell.shape)
        assert _too_large(ell, g, noise=noise) == ""


@pytest.mark.parametrize("noise", [0.0, 0.002])
def test_a_flat_object_concave_seen_from_above_is_left_to_the_search(noise):
    """A hammer lying flat (a 30 cm handle, a 14 cm head across its end, 3 cm
    thick) is wider than the Franka hand opens along every horizontal
    direction, yet its handle fits: seen from above it is concave, though no
    point lies deeper than half its thickness inside its hull in space. A flat
    plate as wide is convex from above too, and too large."""
    from wsgrasp.api import _too_large
    from wsgrasp.gripper import load_gripper

    rng = np.random.default_rng(11)
    g = load_gripper("franka_hand")
    handle = noisy_box(rng, (0.30, 0.03, 0.025), table=0.0, step=0.005, noise=noise)
    head = noisy_box(rng, (0.03, 0.14, 0.03), table=0.0, step=0.005, noise=noise)
    hammer = np.concatenate([handle, head + [0.15, 0.0, 0.0]])
    a = np.linspace(0.0, np.pi, 8, endpoint=False)
    closing = np.column_stack([np.cos(a), np.sin(a), np.zeros(8)])  # horizontal
    up = np.array([0.0, 0.0, 1.0])
    assert "too large" in _too_large(hammer, g, closing, noise=noise)  # in space
    assert _too_large(hammer, g, closing, noise=noise, up=up) == ""
    plate = noisy_box(rng, (0.16, 0.16, 0.025), table=0.0, step=0.005, noise=noise)
    assert "too large" in _too_large(plate, g, closing, noise=noise, up=up)


def test_a_hollow_object_wider_than_the_opening_is_left_to_the_search():
    from wsgrasp.api import _too_large

    # a bowl 20 cm across, open at the top: its wall fits between the fingers
    rng = np.random.default_rng(5)
    theta = rng.uniform(0, 2 * np.pi, 3000)
    z = rng.uniform(0.0, 0.08, 3000)
    r = np.where(rng.uniform(size=3000) < 0.5, 0.1, 0.095)
    bowl = np.column_stack([r * np.cos(theta), r * np.sin(theta), z])
    assert _too_large(bowl, fake_gripper()) == ""
    solid = _box(rng, [0, 0, 0.1], [0.2, 0.2, 0.2], 3000)
    assert "too large" in _too_large(solid, fake_gripper())


# ------------------------------------------------------------------------------
# grippers and simulation settings
# ------------------------------------------------------------------------------
def _write_gripper(tmp_path: Path, urdf: str, **changes) -> Path:
    (tmp_path / "jaw.urdf").write_text(urdf)
    desc = {
        "version": 1,
        "name": "bad_jaw",
        "urdf": "jaw.urdf",
        "base_link": "palm",
        "tool_frame": {"link": "palm", "xyz": [0, 0, 0.1]},
        "approach_axis": [0, 0, 1],
        "closing_axis": [0, 1, 0],
        "fingers": [
            {
                "name": "left",
                "joints": ["left_joint"],
                "pad": {
                    "link": "left_finger",
                    "center": [0, 0, 0.045],
                    "size": [0.02, 0, 0.01],
                },
            },
            {
                "name": "right",
                "joints": ["right_joint"],
                "pad": {
                    "link": "right_finger",
                    "center": [0, 0, 0.045],
                    "size": [0.02, 0, 0.01],
                },
            },
        ],
        "pregrasp": {"left_joint": 0.04},
        "closed": {"left_joint": 0.0},
        **changes,
    }
    path = tmp_path / "bad_jaw.yaml"
    path.write_text(yaml.safe_dump(desc))
    return path


def _build(path: Path, tmp_path: Path):
    from wsgrasp.gripper import load_gripper

    return load_gripper(str(path), cache_dir=tmp_path / "cache")


def test_a_nan_joint_limit_is_named(tmp_path):
    from urdf_factory import jaw_urdf

    urdf = jaw_urdf(mimic=False).replace('upper="0.04"', 'upper="nan"', 1)
    with pytest.raises(GripperError, match="left_joint.*finite"):
        _build(_write_gripper(tmp_path, urdf), tmp_path)


def test_a_millimetre_urdf_is_named_quickly(tmp_path):
    import time

    from urdf_factory import jaw_urdf

    path = _write_gripper(tmp_path, jaw_urdf(mimic=False, scale=1000.0))
    t = time.perf_counter()
    with pytest.raises(GripperError, match="millimetres"):
        _build(path, tmp_path)
    # the refusal comes before the voxel grid is built (not a timing claim: a
    # grid of this size takes minutes)
    assert time.perf_counter() - t < 60


def test_a_voxel_grid_past_budget_is_refused_with_the_fix(tmp_path):
    from urdf_factory import jaw_urdf

    path = _write_gripper(tmp_path, jaw_urdf(mimic=False), workspace_voxel=1e-6)
    with pytest.raises(GripperError, match="voxels.*raise workspace_voxel"):
        _build(path, tmp_path)


def test_sim_settings_are_checked_by_the_api():
    from wsgrasp.sim.objects import resolve_objects

    for kwargs in ({"mass": -1.0}, {"friction": math.nan}, {"mass": math.inf}):
        with pytest.raises(InputError, match="positive finite"):
            resolve_objects(["paper13"], **kwargs)


# ------------------------------------------------------------------------------
# recordings
# ------------------------------------------------------------------------------
def test_force_never_replaces_what_is_not_a_recording(capsys, tmp_path):
    cloud = tmp_path / "scene.npy"
    np.save(cloud, box_scene(views=1).points)
    before = cloud.read_bytes()
    code, text = run_cli(
        capsys, "plan", cloud, "--spec", SPEC, "--record", cloud, "--force"
    )
    assert code == 2 and "input of this run" in text
    assert cloud.read_bytes() == before
    other = tmp_path / "notes.txt"
    other.write_text("keep")
    link = tmp_path / "run.mcap"
    os.symlink(other, link)
    code, text = run_cli(
        capsys, "plan", cloud, "--spec", SPEC, "--record", link, "--force"
    )
    assert code == 2 and "symbolic link" in text
    assert other.read_text() == "keep"


def test_an_unwritable_replay_record_is_an_error_not_a_difference(tmp_path):
    from test_record_fakes import plan_recorded

    from wsgrasp.record import replay_run

    run = tmp_path / "run.mcap"
    plan_recorded(run)
    blocker = tmp_path / "afile"
    blocker.write_text("x")
    with pytest.raises((RecordingError, OSError)):
        replay_run(run, record=blocker / "replay.mcap")


def test_json_result_of_a_too_large_object(capsys, tmp_path):
    rng = np.random.default_rng(6)
    world = np.concatenate([_table(rng), _box(rng, [0, 0, 0.1], [0.2, 0.2, 0.2], 4000)])
    cloud = tmp_path / "cube.npy"
    np.save(cloud, world)
    code, text = run_cli(capsys, "plan", cloud, "--spec", SPEC, "--no-record", "--json")
    assert code == 0
    data = json.loads(text[text.index("{") :])
    assert data["found"] is False and "too large" in data["hint"]


def _cylinder(rng, center, radius, height, n=3000) -> np.ndarray:
    theta = rng.uniform(0, 2 * np.pi, n)
    on_top = rng.uniform(size=n) < 0.3
    r = np.where(on_top, radius * np.sqrt(rng.uniform(size=n)), radius)
    z = np.where(on_top, height, rng.uniform(0, height, n))
    return np.column_stack(
        [center[0] + r * np.cos(theta), center[1] + r * np.sin(theta), z]
    )


def _two_cans(seed: int = 7) -> np.ndarray:
    rng = np.random.default_rng(seed)
    return np.concatenate(
        [
            _table(rng),
            _cylinder(rng, [-0.03, 0.0], 0.03, 0.12),
            _cylinder(rng, [0.03, 0.0], 0.03, 0.12),
        ]
    )


def test_two_touching_objects_are_reported_with_the_rules_to_pick_one():
    pipeline = Pipeline(fake_spec(), gripper=fake_gripper())
    with pytest.raises(InputError, match="two objects that touch") as info:
        pipeline.plan(_posed_scene(_two_cans(), camera_z=0.6))
    assert "target: {rule: nearest, point: [" in str(info.value)


def test_a_nearest_rule_picks_one_of_two_touching_objects():
    spec = fake_spec(target={"rule": "nearest", "point": [0.05, 0.0, 0.1]})
    result = Pipeline(spec, gripper=fake_gripper()).plan(
        _posed_scene(_two_cans(), camera_z=0.6)
    )
    assert result.info["obstacles"] == 1
    assert result.T_world_object[0, 3] > 0.01  # the can on the +x side
    assert result.object_extents.max() < 0.14  # one can, not both (12 cm)


def test_one_object_is_never_split():
    from wsgrasp.perception.process import downsample
    from wsgrasp.perception.synth import synth_scene
    from wsgrasp.perception.touching import find_touching
    from wsgrasp.perception.types import Plane

    rng = np.random.default_rng(8)
    plane = Plane(normal=np.array([0.0, 0.0, 1.0]), offset=0.0)
    shapes = [
        _cylinder(rng, [0, 0], 0.04, 0.12),
        _box(rng, [0, 0, 0.05], [0.18, 0.06, 0.1]),  # long box: a plateau, no waist
        _box(rng, [0, 0, 0.05], [0.09, 0.06, 0.1]),
    ]
    for kind in ("box", "cylinder", "cone", "ring", "sphere"):
        syn = synth_scene(kind, seed=1, width=160, height=120)
        shapes.append(syn.points[syn.points[:, 2] > 0.01])
    for points in shapes:
        assert find_touching(downsample(points, 0.005), plane) is None


def test_a_hammer_lying_flat_is_one_object_with_a_handle():
    """A head and a thick grip end, each wider than the handle between them and
    as tall: a waist as two touching objects make, but a long one (the
    handle, 26 cm), so one object; with a handle rule that never fires it is
    split, as two cans that touch still are."""
    from wsgrasp.perception import touching
    from wsgrasp.perception.process import downsample
    from wsgrasp.perception.types import Plane

    rng = np.random.default_rng(12)
    plane = Plane(normal=np.array([0.0, 0.0, 1.0]), offset=0.0)
    hammer = np.concatenate(
        [
            _box(rng, [0.15, 0.0, 0.0175], [0.04, 0.13, 0.035], 3000),  # head
            _box(rng, [0.0, 0.0, 0.015], [0.26, 0.024, 0.03], 3000),  # handle
            _box(rng, [-0.15, 0.0, 0.0175], [0.06, 0.045, 0.035], 2000),  # grip
        ]
    )
    points = downsample(hammer, 0.005)
    assert touching.find_touching(points, plane) is None
    cans = _two_cans()
    cans = downsample(cans[cans[:, 2] > 0.01], 0.005)
    assert touching.find_touching(cans, plane) is not None
    never = pytest.MonkeyPatch()
    never.setattr(touching, "HANDLE_LENGTH", np.inf)
    try:
        split = touching.find_touching(points, plane)
    finally:
        never.undo()
    assert split is not None and split.neck < 0.03


@pytest.mark.parametrize(
    "setting",
    [
        {"width": 0},
        {"noise": math.nan},
        {"distance": -1.0},
        {"table_size": math.inf},
        {"elevation_deg": math.nan},
    ],
    ids=lambda s: next(iter(s)),
)
def test_synthetic_scene_settings_are_checked_by_the_api(setting):
    from wsgrasp.perception.synth import synth_scene

    with pytest.raises(InputError, match=next(iter(setting))):
        synth_scene("box", **setting)


def test_a_table_bound_search_says_what_rejected_the_other_poses():
    from wsgrasp.planning.search import no_grasp_hint

    hist = {
        "feasible": 0,
        "table_collision": 3840,
        "object_collision": 900,
        "obstacle_collision": 0,
        "finger_without_contact": 60,
        "finger_sweeps_table": 0,
    }
    hint = no_grasp_hint(hist, np.array([0.13, 0.07, 0.055]), fake_gripper(), 0.057)
    assert hint.startswith("the gripper hits the table at 3840 of 4800 poses")
    assert "(the object stands 0.057 m tall)" in hint
    assert "of the other 960, 900 with the body in the object, 60 with a finger" in hint
    assert "sampling.directions" in hint
    only = dict(hist, object_collision=0, finger_without_contact=0)
    assert "of the other" not in no_grasp_hint(only, np.ones(3), fake_gripper(), 0.1)
    g = fake_gripper()
    for width, named in ((g.max_opening + 0.01, True), (g.max_opening - 0.01, False)):
        hint = no_grasp_hint(hist, np.ones(3), g, 0.04, width)
        assert hint.startswith("the object is ") is named
        assert ("more than the gripper opens" in hint) is named


def test_an_object_lying_flat_wider_than_the_gripper_opens_is_named():
    """A box lying flat, 11 x 9 x 4 cm, has no grasp for the Franka hand (it
    opens 8 cm): the hint names its narrowest width seen from above against the
    opening first, not the table alone; its narrowest width is 9 cm whichever
    way it turns."""
    from wsgrasp.default_specs import default_spec
    from wsgrasp.perception.footprint import narrowest_width
    from wsgrasp.perception.synth import synth_scene

    rng = np.random.default_rng(3)
    lo, hi = np.array([-0.055, -0.045, 0.0]), np.array([0.055, 0.045, 0.04])
    corners = np.stack(np.meshgrid(*zip(lo, hi, strict=True)), -1).reshape(-1, 3)
    box = np.vstack([rng.uniform(lo, hi, (3000, 3)), corners])
    for turn in (0.0, 0.4, 1.2):
        c, s = np.cos(turn), np.sin(turn)
        turned = box @ np.array([[c, -s, 0.0], [s, c, 0.0], [0.0, 0.0, 1.0]]).T
        assert abs(narrowest_width(turned, [0.0, 0.0, 1.0]) - 0.09) < 1e-3
    # seen askew, its side adds to it: 9 cos 0.3 + 4 sin 0.3 cm
    tilted = narrowest_width(box, [0.0, np.sin(0.3), np.cos(0.3)])
    assert abs(tilted - (0.09 * np.cos(0.3) + 0.04 * np.sin(0.3))) < 1e-3
    assert narrowest_width(box[:2], [0.0, 0.0, 1.0]) == 0.0
    scene = synth_scene("box", size=(0.11, 0.09, 0.04), seed=1)
    result = Pipeline(load_spec(default_spec("franka_hand")[0])).plan(scene.points)
    assert not result.found
    assert result.hint.startswith("the object is 0.0")
    assert "more than the gripper opens (0.080 m)" in result.hint


#: the fix each kind of wrongly shaped cloud gets
_SHAPE_FIXES = {
    "transpose": "pass its transpose",
    "columns": "pass those alone: points[:, :3]",
    "pixels": "pass those alone: points[..., :3]",
    "image": "depth image: pass --intrinsics",
}


@pytest.mark.parametrize(
    ("shape", "kind"),
    [((3, 2000), "transpose"), ((2000, 4), "columns"), ((2000, 6), "columns")]
    + [((240, 320), "image"), ((48, 64, 4), "pixels")],
)
def test_a_cloud_of_the_wrong_shape_names_the_likely_fix(tmp_path, shape, kind):
    """Points stored a point per column, with intensity or colour beside x, y, z
    (XYZI, XYZRGB), an organised cloud with colour per pixel (a ZED's XYZRGBA,
    (h, w, 4)), or a depth image: each gets the fix that fits it, and no
    other."""
    path = tmp_path / "c.npy"
    np.save(path, np.zeros(shape))
    with pytest.raises(InputError, match=re.escape(f"has shape {shape}")) as info:
        load_cloud(path)
    hint = info.value.hint or ""
    assert [k for k, fix in _SHAPE_FIXES.items() if fix in hint] == [kind]


def test_far_points_in_a_cloud_in_metres_are_not_taken_for_millimetres():
    """A scene in metres with 5 % of its points strewn over 100 m (an outdoor
    background, a sensor's stray returns) spans 79 units, which read as
    centimetres before; its points lie millimetres apart, so it is metres: the
    box on the table is grasped. The same scene in millimetres or centimetres
    is still named so."""
    from wsgrasp.perception.synth import synth_scene

    syn = synth_scene("box", size=(0.05, 0.05, 0.1), seed=1)
    rng = np.random.default_rng(0)
    far = rng.uniform(-50.0, 50.0, (len(syn.points) // 20, 3))
    result = Pipeline(load_spec(SPEC)).plan(np.concatenate([syn.points, far]))
    assert result.found, result.hint
    tcp = result.T_world_tcp[:3, 3]
    assert np.linalg.norm(tcp - syn.T_world_mesh[:3, 3]) < 0.02
    for scale, unit in ((1000.0, "millimetres"), (100.0, "centimetres")):
        with pytest.raises(InputError, match=f"probably in {unit}"):
            Pipeline(load_spec(SPEC)).plan(syn.points * scale)


def test_a_far_target_in_a_wide_view_is_told_to_crop_not_a_depth_scale() -> None:
    """An object 3.5 m from the camera in a scene seen mostly within 1.2 m (a
    wide view of a room whose far floor gave the target) is told to crop the
    scene, naming a radius that keeps the near scene; a scene all as far (a
    depth scale read wrong puts everything far) is told its depth scale."""
    from wsgrasp.api import _range_warnings

    rng = np.random.default_rng(0)
    camera = np.zeros((1, 3))
    obj = rng.normal([0.0, 0.0, 3.5], 0.02, (200, 3))
    near = rng.uniform([-0.5, -0.5, 0.8], [0.5, 0.5, 1.2], (5000, 3))
    (wide,) = _range_warnings(camera, obj, np.vstack([near, obj]))
    assert "crop the scene" in wide and "depth scale" not in wide
    radius = float(re.search(r"within about ([0-9.]+) m of the cameras", wide)[1])
    assert 1.2 < radius < 3.5
    (scaled,) = _range_warnings(camera, obj, 3.0 * near)
    assert "depth scale is probably wrong" in scaled
    assert _range_warnings(camera, obj / 2.0, near) == []


def test_a_far_target_in_a_wide_view_gives_way_to_the_near_scenes() -> None:
    """One camera sees a small table 1 m away with a box on it, and beyond it
    a floor 3.5 m away, larger in points, with a crate standing on it: the
    floor, the largest plane, was the table and the crate the target. The
    target lies far while much of the scene lies near the camera, so the near
    scene is segmented again: its table and its box are planned on, and the
    result says so. Given a crop radius, the plan keeps the spec's."""
    from conftest_perception import level_grid

    from wsgrasp.api import Pipeline
    from wsgrasp.perception.io import scene_from_arrays

    rng = np.random.default_rng(0)

    def box(centre: tuple[float, float, float], size: tuple[float, float, float]):
        """Points on a box's sides and top."""
        pts = rng.uniform(-0.5, 0.5, (40000, 3))  # dense: one cluster
        face = rng.integers(0, 3, len(pts))
        side = np.where(face == 2, 0.5, np.sign(rng.normal(size=len(pts))) * 0.5)
        pts[np.arange(len(pts)), face] = side
        return pts * np.array(size) + np.array(centre)

    # a z-up world, the camera 1 m over the near table looking down
    table = level_grid((-0.3, 0.3), (-0.3, 0.3), 0.0, 0.004)
    near_box = box((0.0, 0.0, 0.05), (0.05, 0.07, 0.1))
    floor = level_grid((-2.5, 2.5), (1.0, 4.0), -2.5, 0.01)
    crate = box((0.0, 2.5, -2.4), (0.25, 0.25, 0.2))
    points = np.vstack([table, near_box, floor, crate])
    points += rng.normal(0.0, 0.001, points.shape)
    pose = np.eye(4)
    pose[2, 3] = 1.0  # its axes the world's: the points seen are shifted alone
    camera_points = points - pose[:3, 3]
    spec = {
        "version": 1,
        "gripper": "franka_hand",
        "segmenter": {"name": "ransac_dbscan"},
    }
    from wsgrasp.spec import PipelineSpec

    result = Pipeline(PipelineSpec.model_validate(spec)).plan(
        scene_from_arrays([(camera_points, pose)])
    )
    assert result.found
    assert np.linalg.norm(result.T_world_tcp[:3, 3] - [0.0, 0.0, 0.05]) < 0.08
    assert any("first found lay" in w for w in result.warnings), result.warnings
    spec["preprocess"] = {"crop_radius": 6.0}
    kept = Pipeline(PipelineSpec.model_validate(spec)).plan(
        scene_from_arrays([(camera_points, pose)])
    )
    assert not any("first found lay" in w for w in kept.warnings)
