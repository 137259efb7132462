"""Flying pixels: rendered along depth edges (``scene synth``'s camera model and
the simulator's ``flying_pixels``) and dropped before planning
(``preprocess.flying_pixels``, :mod:`wsgrasp.perception.flying`)."""

from __future__ import annotations

import json
from dataclasses import replace

import numpy as np
import pytest

from wsgrasp.api import Pipeline
from wsgrasp.cli import main
from wsgrasp.default_specs import default_spec
from wsgrasp.errors import InputError
from wsgrasp.geometry import transform_from, transform_points
from wsgrasp.perception.flying import flying_mask, flying_points, pixel_grid
from wsgrasp.perception.io import scene_from_arrays
from wsgrasp.perception.sides import behind_the_side
from wsgrasp.perception.synth import default_cameras, make_object, render_scene
from wsgrasp.record import open_run
from wsgrasp.sim.params import SimParams, parse_overrides
from wsgrasp.spec import load_spec

BOX = (0.06, 0.08, 0.12)


def box_views(
    elevation_deg: float,
    share: float,
    seed: int = 0,
    views: int = 1,
    fy_over_fx: float = 1.0,
) -> tuple[list, np.ndarray]:
    """A box standing on a 0.6 m table seen by ``views`` cameras at
    ``elevation_deg`` (their pixels ``fy_over_fx`` as high as wide),
    ``share`` of its depth-edge pixels flying; the views and the box's
    pose."""
    rng = np.random.default_rng(seed)
    T = transform_from(None, [0.0, 0.0, BOX[2] / 2])
    cams = default_cameras(
        views, (0, 0, 0.05), elevation=np.radians(elevation_deg), rng=rng
    )
    cams = [replace(c, fy=c.fx * fy_over_fx) for c in cams]
    mesh = make_object("box", BOX)
    return render_scene([(mesh, T)], 0.6, cams, 0.001, rng, share), T


def off_the_surfaces(world: np.ndarray) -> np.ndarray:
    """Each point's distance (m) to the nearest of the table top and the box."""
    half = np.array(BOX) / 2
    c = np.abs(world - [0.0, 0.0, half[2]]) - half  # per axis, past the faces
    outside = np.linalg.norm(np.maximum(c, 0.0), axis=1)
    inside = -np.minimum(c.max(axis=1), 0.0)
    return np.minimum(np.abs(world[:, 2]), np.maximum(outside, inside))


def world(view) -> np.ndarray:
    return transform_points(view.T_world_camera, view.points)


@pytest.mark.parametrize("elevation", [30.0, 45.0, 60.0])
def test_the_veil_along_an_outline_is_dropped_and_the_surfaces_stay(elevation):
    (view,), _ = box_views(elevation, 1.0)
    off = off_the_surfaces(world(view))
    floating = off > 0.005  # the veil, where it stands clear of the surfaces
    assert floating.sum() > 100  # the box's outline leaves a veil
    flagged = flying_mask(view.points)
    assert flagged[floating].mean() > 0.85
    # of the points on the table and the faces, those along the outline beside
    # a flying pixel alone
    on = off < 0.002
    assert flagged[on].mean() < 0.01


@pytest.mark.parametrize("fy_over_fx", [0.98, 1.007, 1.05])
def test_a_camera_whose_pixels_are_not_square_is_still_an_image(fy_over_fx):
    """fx and fy apart (TUM RGB-D's fr3 camera: 535.4 and 539.2 pixels) put
    the directions on a grid of two pitches; its pixels are found again and
    its veil dropped as a square camera's."""
    (view,), _ = box_views(45.0, 1.0, fy_over_fx=fy_over_fx)
    grid = pixel_grid(view.points)
    assert grid is not None
    cam = default_cameras(1, (0, 0, 0.05), elevation=np.radians(45.0))[0]
    p = view.points  # each on its pixel's ray: the pixel again, from fx and fy
    u = np.rint(cam.fx * p[:, 0] / p[:, 2] + cam.cx)
    v = np.rint(cam.fx * fy_over_fx * p[:, 1] / p[:, 2] + cam.cy)
    np.testing.assert_array_equal(grid.u, u - u.min())
    np.testing.assert_array_equal(grid.v, v - v.min())
    floating = off_the_surfaces(world(view)) > 0.005
    assert flying_mask(view.points)[floating].mean() > 0.85


@pytest.mark.parametrize("elevation", [30.0, 45.0])
def test_a_clean_view_loses_nothing(elevation):
    (view,), _ = box_views(elevation, 0.0, seed=2)
    assert not flying_mask(view.points).any()


def test_a_cloud_that_is_no_image_is_left_alone():
    (view,), _ = box_views(45.0, 1.0)
    assert pixel_grid(view.points) is not None
    rng = np.random.default_rng(0)
    # registered into another frame: its directions from the origin lie on no grid
    moved = transform_points(transform_from(None, [0.3, -0.2, 0.1]), view.points)
    # or thinned to a voxel grid's centroids
    voxels = np.unique(np.floor(view.points / 0.004), axis=0) * 0.004 + 0.002
    jittered = view.points + rng.normal(0.0, 0.0005, view.points.shape)
    for cloud in (moved, voxels, jittered):
        assert pixel_grid(cloud) is None
        assert not flying_mask(cloud).any()


def test_rendered_flying_pixels_are_reproducible_for_a_seed():
    a, _ = box_views(45.0, 0.5, seed=4)
    b, _ = box_views(45.0, 0.5, seed=4)
    np.testing.assert_array_equal(a[0].points, b[0].points)
    clean, _ = box_views(45.0, 0.0, seed=4)
    assert len(clean[0].points) == len(a[0].points)  # the same pixels, moved
    assert not np.array_equal(clean[0].points, a[0].points)


def test_the_plan_sees_the_box_not_its_veil():
    """Three views with every edge pixel flying: with the filter (the default)
    the object cluster spans the box; without it, it reaches out along the
    veil."""
    views, _ = box_views(45.0, 1.0, seed=1, views=3)
    scene = scene_from_arrays([(v.points, v.T_world_camera) for v in views])
    mask = flying_points(scene)
    assert mask is not None and mask.sum() > 300
    spec = load_spec(default_spec("franka_hand")[0])
    spans = {}
    for on in (True, False):
        spec.preprocess.flying_pixels = on
        obj = Pipeline(spec).prepare(scene).search_input.object_points
        spans[on] = float(np.ptp(obj[:, :2], axis=0).max())
    diagonal = float(np.hypot(*BOX[:2]))
    assert spans[True] <= diagonal + 0.01
    assert spans[False] > spans[True] + 0.01


def test_points_that_are_not_the_views_merge_are_left_alone():
    views, _ = box_views(45.0, 1.0, views=2)
    scene = scene_from_arrays([(v.points, v.T_world_camera) for v in views])
    scene.points = scene.points[:-1]
    assert flying_points(scene) is None


def test_the_share_of_flying_pixels_is_a_simulation_parameter():
    assert SimParams().flying_pixels == 0.0
    assert parse_overrides(["flying_pixels=0.5"]) == {"flying_pixels": 0.5}
    with pytest.raises(InputError, match="must be at most 1") as info:
        parse_overrides(["flying_pixels=1.5"])
    assert "the default is 0.0" in info.value.hint


def test_a_scene_with_flying_pixels_from_synth_to_replay(tmp_path, capsys):
    """``scene synth --flying`` writes the views; ``scene info`` counts the
    flying pixels it drops, a recorded plan names them in ``inspect``, and
    ``replay`` re-plans the recording to the same choice."""
    views = tmp_path / "views"
    args = ["scene", "synth", "-o", tmp_path / "m.npz", "--views-out", views]
    assert main([str(a) for a in [*args, "--flying", "1", "--seed", "3"]]) == 0
    capsys.readouterr()
    assert main(["scene", "info", str(views / "scene.yaml"), "--json"]) == 0
    info = json.loads(capsys.readouterr().out)
    assert info["flying_pixels"] > 300
    run = tmp_path / "run.mcap"
    plan = [
        "plan",
        str(views / "scene.yaml"),
        "-g",
        "franka_hand",
        "--record",
        str(run),
    ]
    assert main(plan) == 0
    capsys.readouterr()
    assert main(["inspect", str(run), "--json"]) == 0
    summary = json.loads(capsys.readouterr().out)
    assert summary["inputs"]["flying_pixels"] == info["flying_pixels"]
    # the dropped points are in the recording, drawn on a topic of their own
    recorded = open_run(run)
    dropped = recorded.stages["preprocess"]["flying_points"]
    assert len(dropped) == info["flying_pixels"]
    assert "/scene/flying_pixels" in {m.topic for m in recorded.messages}
    assert main(["replay", str(run)]) == 0
    assert "moved 0.0 mm and turned 0.0°" in capsys.readouterr().out


def test_a_cloud_in_its_camera_frame_has_its_camera_at_the_origin():
    """A cloud given without a pose that is still its camera's image was seen
    from the origin: its scene has that viewpoint, as the same view with its
    pose has the camera's centre, and the plan moves the centroid of a ball seen
    from one side behind the points alike in both frames."""
    rng = np.random.default_rng(0)
    mesh = make_object("sphere", (0.04,))
    cams = default_cameras(1, (0, 0, 0.05), elevation=np.radians(45), rng=rng)
    T_mesh = transform_from(None, [0.0, 0.0, 0.04])
    (view,) = render_scene([(mesh, T_mesh)], 0.6, cams, 0.001, rng)
    posed = scene_from_arrays([(view.points, view.T_world_camera)])
    plain = scene_from_arrays(view.points)
    np.testing.assert_allclose(posed.viewpoints(), [view.T_world_camera[:3, 3]])
    np.testing.assert_array_equal(plain.viewpoints(), [[0.0, 0.0, 0.0]])
    # the same points merged in the world frame: no camera at the origin
    assert len(scene_from_arrays(posed.points).viewpoints()) == 0
    pipe = Pipeline(load_spec(default_spec("franka_hand")[0]))
    # the points as seen: mirrored in, the hidden side would hold the middle
    pipe.spec.object_frame.mirror_hidden = False
    centres = []
    for scene, T in ((posed, np.eye(4)), (plain, view.T_world_camera)):
        inp = pipe.prepare(scene).search_input
        n = inp.table.T_world_table[:3, 2]
        c = inp.T_world_object[:3, 3]
        shift = behind_the_side(inp.object_points, c, n, inp.viewpoints)
        assert np.linalg.norm(shift) > 0.005  # the ball's middle lies behind
        centres.append(transform_points(T, (c + shift)[None])[0])
    # the two frames' voxel grids differ: the same centre within a few mm
    np.testing.assert_allclose(centres[0], centres[1], atol=0.004)
    # along the table, where the ball's middle is (its height is the points')
    np.testing.assert_allclose(centres[0][:2], T_mesh[:2, 3], atol=0.006)
    # mirrored in (the default), the points' own middle lies there
    pipe.spec.object_frame.mirror_hidden = True
    middle = pipe.prepare(posed).search_input.T_world_object[:3, 3]
    np.testing.assert_allclose(middle[:2], T_mesh[:2, 3], atol=0.006)


def test_pixels_without_depth_leave_the_image_an_image(tmp_path, capsys):
    """A camera's cloud saved with its pixels that have no depth at (0, 0, 0)
    (RealSense's ``get_vertices``, Azure Kinect's point cloud image) plans as
    the cloud without them: its camera at the origin, its flying pixels found,
    and ``scene info`` counts what it dropped."""
    rng = np.random.default_rng(0)
    (view,), _ = box_views(45.0, 1.0)
    holes = np.insert(view.points, rng.integers(0, len(view.points), 5000), 0.0, 0)
    clean = scene_from_arrays(view.points)
    holed = scene_from_arrays(holes)
    assert holed.dropped_no_depth == 5000
    np.testing.assert_array_equal(holed.viewpoints(), [[0.0, 0.0, 0.0]])
    dropped = int(flying_points(clean).sum())
    assert dropped > 100
    np.testing.assert_array_equal(flying_points(holed), flying_points(clean))
    np.savez(tmp_path / "holes.npz", points=holes)
    assert main(["scene", "info", str(tmp_path / "holes.npz"), "--json"]) == 0
    info = json.loads(capsys.readouterr().out)
    assert info["dropped_no_depth"] == 5000
    assert info["flying_pixels"] == dropped


def test_a_cloud_in_ros_camera_link_axes_is_still_an_image():
    """A camera's cloud turned into ROS's camera_link axes (x forward, y left, z
    up) has the same pixels: the same flying pixels, its camera at the origin."""
    (view,), _ = box_views(45.0, 1.0)
    link = view.points @ np.array([[0, 0, 1], [-1, 0, 0], [0, -1, 0]], float).T
    grid = pixel_grid(link)
    assert grid is not None
    np.testing.assert_allclose(grid.depth, view.points[:, 2], atol=1e-12)
    mask = flying_mask(view.points)
    assert mask.sum() > 100
    np.testing.assert_array_equal(flying_mask(link), mask)
    np.testing.assert_array_equal(
        scene_from_arrays(link).viewpoints(), [[0.0, 0.0, 0.0]]
    )


@pytest.mark.parametrize("k1", [-0.1, 0.05, 0.1])
def test_a_lens_that_bends_the_grid_still_gives_the_pixels(k1):
    """A camera's points deprojected through radial distortion lie on a bent
    grid: the pixels are still found and the same veil dropped (a pixel or two
    apart where the bent grid puts two points in one cell)."""
    (view,), _ = box_views(45.0, 1.0, seed=1)
    p = view.points
    a, b = p[:, 0] / p[:, 2], p[:, 1] / p[:, 2]
    f = 1.0 + k1 * (a * a + b * b)
    bent = np.column_stack([a * f * p[:, 2], b * f * p[:, 2], p[:, 2]])
    assert pixel_grid(bent) is not None
    straight, seen_bent = flying_mask(p), flying_mask(bent)
    assert (straight != seen_bent).sum() <= 0.01 * straight.sum()


def test_a_views_grid_is_built_once_and_not_for_other_points():
    """The plan asks for a view's grid twice (its camera, its flying pixels):
    the same points get the same grid back, read-only; points that differ in
    one value get their own."""
    (view,), _ = box_views(45.0, 0.0)
    grid = pixel_grid(view.points)
    assert grid is not None and pixel_grid(view.points.copy()) is grid
    with pytest.raises(ValueError, match="read-only"):
        grid.u[0] = 1
    moved = view.points.copy()
    moved[0, 2] += 1e-6
    assert pixel_grid(moved) is not grid
