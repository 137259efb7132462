"""Synthetic rendering, the `wsgrasp scene` commands and the bundled scenes."""

from __future__ import annotations

import json
from pathlib import Path

import numpy as np
import pytest
from conftest_perception import small_scene
from numpy.testing import assert_allclose

from wsgrasp.cli import main
from wsgrasp.errors import InputError
from wsgrasp.geometry import check_transforms, transform_points
from wsgrasp.perception.io import load_cloud, load_scene
from wsgrasp.perception.synth import (
    Camera,
    default_cameras,
    look_at,
    make_object,
    render_scene,
    synth_scene,
)

SCENES = Path(__file__).resolve().parents[1] / "examples" / "scenes"


def test_look_at_points_the_optical_axis_at_the_target() -> None:
    T = look_at([0.3, 0.2, 0.4], [0, 0, 0.05])
    check_transforms(T)
    z = T[:3, 2]
    assert_allclose(z, -np.array([0.3, 0.2, 0.35]) / np.linalg.norm([0.3, 0.2, 0.35]))
    assert T[2, 1] < 0  # image y (down) points away from world up


def test_cameras_surround_the_target() -> None:
    cams = default_cameras(4, (0, 0, 0.05), 0.5, np.radians(40))
    eyes = np.array([c.T_world_camera[:3, 3] for c in cams])
    assert_allclose(np.linalg.norm(eyes - [0, 0, 0.05], axis=1), 0.5)
    assert_allclose(eyes[:, 2] - 0.05, 0.5 * np.sin(np.radians(40)))
    az = np.sort(np.degrees(np.arctan2(eyes[:, 1], eyes[:, 0])) % 360)
    assert_allclose(np.diff(az), 90.0)


def test_render_counts_and_depths_without_noise() -> None:
    """A camera 0.5 m above a table looking straight down sees only the table at
    depth 0.5 in every pixel."""
    T = look_at([0, 0, 0.5], [0, 0, 0], up=(0, 1, 0))
    cam = Camera.from_fov(T, 40, 30, fov_deg=40)
    (view,) = render_scene([], 2.0, [cam], 0.0, np.random.default_rng(0))
    assert view.points.shape == (40 * 30, 3)
    assert_allclose(view.points[:, 2], 0.5, atol=1e-6)
    world = transform_points(view.T_world_camera, view.points)
    assert_allclose(world[:, 2], 0.0, atol=1e-6)


def test_depth_noise_has_the_requested_spread() -> None:
    T = look_at([0, 0, 0.5], [0, 0, 0], up=(0, 1, 0))
    cam = Camera.from_fov(T, 80, 60, fov_deg=40)
    (view,) = render_scene([], 2.0, [cam], 0.002, np.random.default_rng(0))
    assert view.points[:, 2].std() == pytest.approx(0.002, rel=0.1)
    assert view.points[:, 2].mean() == pytest.approx(0.5, abs=3e-4)


def test_object_is_seen_and_sits_on_the_table() -> None:
    synth = small_scene("box", "upright", 0)
    assert len(synth.views) == 3
    assert all(v.points.shape[0] > 1000 for v in synth.views)
    above = synth.points[synth.points[:, 2] > 0.01]
    assert above.shape[0] > 500
    assert above[:, 2].max() == pytest.approx(0.16, abs=0.005)
    assert synth.points[:, 2].min() > -0.025  # nothing below the 2 cm table


def test_camera_frame_scene_is_the_same_scene_moved() -> None:
    world = small_scene("cone", "random", 2)
    cam = small_scene("cone", "random", 2, camera_frame=True)
    T_cam_world = np.linalg.inv(world.views[0].T_world_camera)
    assert_allclose(cam.points, transform_points(T_cam_world, world.points), atol=1e-9)
    assert_allclose(cam.views[0].T_world_camera, np.eye(4), atol=1e-9)
    on_table = transform_points(T_cam_world, np.array([[0.1, 0.0, 0.0]]))
    assert cam.table.signed_distance(on_table)[0] == pytest.approx(0.0, abs=1e-9)


@pytest.mark.parametrize("kind", ["box", "cylinder", "cone", "ring", "sphere"])
def test_every_primitive_renders(kind: str) -> None:
    synth = synth_scene(kind, pose="lying", views=2, width=80, height=60, seed=1)
    assert synth.points.shape[0] > 1000
    assert np.isfinite(synth.points).all()


def test_mesh_file_object(tmp_path: Path) -> None:
    mesh = make_object("box", (0.05, 0.05, 0.1))
    mesh.export(tmp_path / "thing.stl")
    synth = synth_scene(str(tmp_path / "thing.stl"), views=1, width=80, height=60)
    assert (synth.points[:, 2] > 0.05).any()


def test_bad_synth_inputs(tmp_path: Path) -> None:
    with pytest.raises(InputError, match="neither a primitive"):
        make_object("teapot")
    with pytest.raises(InputError, match="needs 2 positive numbers"):
        make_object("cylinder", (0.1,))
    with pytest.raises(InputError, match="inner radius"):
        make_object("ring", (0.05, 0.03, 0.01))
    with pytest.raises(InputError, match="at least 1"):
        default_cameras(0)
    mesh = make_object("box", (50, 50, 100))
    mesh.export(tmp_path / "mm.stl")
    with pytest.raises(InputError, match="millimetres"):
        make_object(str(tmp_path / "mm.stl"))


# --------------------------------------------------------------------------------
# CLI
# --------------------------------------------------------------------------------
def test_cli_synth_writes_cloud_and_views(tmp_path: Path, capsys) -> None:  # noqa: ANN001
    out = tmp_path / "s.npz"
    args = ["scene", "synth", "--object", "cylinder", "--size", "0.03,0.12"]
    args += ["--views", "2", "--width", "96", "--height", "72", "--seed", "3"]
    args += ["-o", str(out), "--views-out", str(tmp_path / "v"), "--json"]
    assert main(args) == 0
    summary = json.loads(capsys.readouterr().out)
    merged = load_cloud(out)
    assert merged.shape == (summary["points"], 3)
    assert len(summary["views"]) == 2
    scene = load_scene(tmp_path / "v" / "scene.yaml")
    assert_allclose(scene.points, merged, atol=1e-5)
    assert main(["scene", "info", str(tmp_path / "v" / "scene.yaml"), "--json"]) == 0
    info = json.loads(capsys.readouterr().out)
    assert info["clusters"] and info["table_normal"][2] > 0.99


def test_cli_synth_camera_frame(tmp_path: Path, capsys) -> None:  # noqa: ANN001
    out = tmp_path / "c.ply"
    args = ["scene", "synth", "--views", "2", "--width", "96", "--height", "72"]
    assert main([*args, "--camera-frame", "-o", str(out), "--json"]) == 0
    summary = json.loads(capsys.readouterr().out)
    assert summary["frame"] == "camera 0"
    assert abs(summary["table_normal"][2]) < 0.95
    assert load_cloud(out).shape[0] == summary["points"]


def test_cli_errors_are_one_line(tmp_path: Path, capsys) -> None:  # noqa: ANN001
    assert main(["scene", "synth", "--object", "teapot", "-o", "x.npz"]) == 2
    err = capsys.readouterr().err
    assert "teapot" in err and "Traceback" not in err
    assert main(["scene", "info", str(tmp_path / "missing.ply")]) == 2
    assert "does not exist" in capsys.readouterr().err


# --------------------------------------------------------------------------------
# bundled scenes
# --------------------------------------------------------------------------------
BUNDLED = sorted(SCENES.glob("*.npz")) + sorted(SCENES.glob("*/*.npz"))


@pytest.mark.parametrize("path", BUNDLED, ids=lambda p: p.name)
def test_bundled_scene_files_are_small_float32(path: Path) -> None:
    assert path.stat().st_size < 1.5e6
    with np.load(path) as data:
        assert data["points"].dtype == np.float32
        assert data["points"].shape[1] == 3


def test_benchmark_scene_has_about_100k_points_in_3_views() -> None:
    points = load_cloud(SCENES / "box_upright.npz")
    assert 90_000 <= points.shape[0] <= 110_000
    scene = load_scene(SCENES / "cone_views" / "scene.yaml")
    assert len(scene.views) == 3
