"""Segmenters and target selection on synthetic scenes, in a z-up frame and in
arbitrary rigid frames (nothing may assume z up)."""

from __future__ import annotations

import re
import sys
from pathlib import Path

import numpy as np
import pytest
from conftest_perception import (
    VOXEL,
    level_grid,
    move_plane,
    moved,
    random_rigid,
    small_scene,
)
from numpy.testing import assert_allclose
from wsgrasp_segmenters.given_table import GivenTable, GivenTableOptions
from wsgrasp_segmenters.ransac_dbscan import RansacDbscan, RansacDbscanOptions

from wsgrasp.errors import InputError
from wsgrasp.geometry import plane_basis, transform_from
from wsgrasp.perception.process import downsample, select_target
from wsgrasp.perception.synth import default_cameras, make_object, render_scene
from wsgrasp.perception.types import Segmentation
from wsgrasp.plugins import get_registry
from wsgrasp.spec import TargetRule

ROOT = Path(__file__).resolve().parents[1]


def segment(points: np.ndarray, **options: float) -> Segmentation:
    return RansacDbscan().segment(points, RansacDbscanOptions(**options), seed=0)


def mesh_points(kind: str, pose: str, seed: int) -> np.ndarray:
    synth = small_scene(kind, pose, seed)
    return (
        synth.mesh.vertices @ synth.T_world_mesh[:3, :3].T + synth.T_world_mesh[:3, 3]
    )


def test_segmenters_are_registered() -> None:
    reg = get_registry()
    assert reg.get("segmenters", "ransac_dbscan").obj is RansacDbscan
    assert reg.get("segmenters", "given_table").obj is GivenTable


# --------------------------------------------------------------------------------
# ransac_dbscan
# --------------------------------------------------------------------------------
SCENES = [
    ("box", "upright"),
    ("cylinder", "lying"),
    ("cone", "random"),
    ("ring", "upright"),
]


@pytest.mark.parametrize("kind,pose", SCENES, ids=[f"{k}-{p}" for k, p in SCENES])
@pytest.mark.parametrize("frame", range(3), ids=["z-up", "rigid-1", "rigid-2"])
def test_table_and_object_in_any_frame(kind: str, pose: str, frame: int) -> None:
    synth = small_scene(kind, pose, 0)
    T = np.eye(4) if frame == 0 else random_rigid(np.random.default_rng(frame))
    points = downsample(moved(T, synth.points), VOXEL)
    seg = segment(points)
    truth = move_plane(T, synth.table)
    # the normal points to the object, whatever the frame
    assert_allclose(seg.table.normal, truth.normal, atol=0.01)
    assert seg.table.offset == pytest.approx(truth.offset, abs=0.003)
    assert len(seg.clusters) == 1
    obj = seg.clusters[0]
    assert (seg.table.signed_distance(obj) > 0).all()
    # the cluster is the object: its box matches the mesh's within 1.5 cm
    mesh = moved(T, mesh_points(kind, pose, 0))
    assert_allclose(obj.min(axis=0), mesh.min(axis=0), atol=0.015)
    assert_allclose(obj.max(axis=0), mesh.max(axis=0), atol=0.015)


def test_camera_frame_scene_table_is_tilted_and_found() -> None:
    synth = small_scene("box", "upright", 3, camera_frame=True)
    # in the camera frame z is the viewing direction: the table is far from z-up
    assert abs(synth.table.normal[2]) < 0.95
    seg = segment(downsample(synth.points, VOXEL))
    assert_allclose(seg.table.normal, synth.table.normal, atol=0.01)
    assert len(seg.clusters) == 1


def test_segmentation_is_deterministic_for_a_seed() -> None:
    points = downsample(small_scene("box", "upright", 0).points, VOXEL)
    a, b = segment(points), segment(points)
    assert a.table.offset == b.table.offset
    assert_allclose(a.clusters[0], b.clusters[0])


def test_object_standing_under_a_wall_is_not_taken_for_the_wall() -> None:
    """A wall beside the table is a large plane; the table is still chosen."""
    synth = small_scene("box", "upright", 0)
    rng = np.random.default_rng(0)
    # a 0.4 x 0.4 m wall at x = -0.2, rising from the table (more points than table)
    wall = np.column_stack(
        [
            np.full(40000, -0.2) + rng.normal(0, 0.001, 40000),
            rng.uniform(-0.2, 0.2, 40000),
            rng.uniform(0.0, 0.4, 40000),
        ]
    )
    points = downsample(np.vstack([synth.points, wall]), VOXEL)
    seg = segment(points)
    assert_allclose(seg.table.normal, [0, 0, 1], atol=0.01)
    assert len(seg.clusters) == 1
    assert np.ptp(seg.clusters[0], axis=0).max() < 0.2


def one_view(
    kind: str, size: tuple[float, ...], lift: float, elevation_deg: float, seed: int
) -> np.ndarray:
    """``kind`` standing on a 0.6 m table (or ``lift`` above it), seen by one
    camera at ``elevation_deg`` above the table; the cloud in the camera's frame
    (the table tilted), downsampled."""
    rng = np.random.default_rng(seed)
    mesh = make_object(kind, size)
    base = -float(mesh.vertices[:, 2].min())
    cams = default_cameras(
        1, (0, 0, 0.05), elevation=np.radians(elevation_deg), rng=rng
    )
    (view,) = render_scene(
        [(mesh, transform_from(None, [0.0, 0.0, base + lift]))], 0.6, cams, 0.001, rng
    )
    return downsample(view.points, VOXEL)


@pytest.mark.parametrize("seed", range(2))
@pytest.mark.parametrize(
    "kind,size",
    [
        ("box", (0.06, 0.08, 0.16)),
        ("cylinder", (0.04, 0.1)),
        ("cylinder", (0.02, 0.1)),
        ("sphere", (0.04,)),
    ],
    ids=["box", "can", "thin-can", "ball"],
)
def test_an_object_seen_from_straight_above_stands_on_the_table(
    kind: str, size: tuple[float, ...], seed: int
) -> None:
    # its top alone is seen, 4 to 16 cm above the table: the gap under it is
    # hidden, not seen, so it stands, and its sides are filled in under its
    # outline down to the table
    points = one_view(kind, size, 0.0, 85.0, seed)
    o = RansacDbscanOptions()
    # what the camera sees of it (a contact distance that takes it as it is)
    plain = segment(points, contact_distance=1.0)
    seen = plain.clusters[0]
    assert plain.table.signed_distance(seen).min() > o.contact_distance
    seg = segment(points)
    assert len(seg.clusters) == 1
    obj = seg.clusters[0]
    heights = seg.table.signed_distance(obj)
    assert heights.min() == pytest.approx(o.min_height, abs=0.002)
    top = 2.0 * size[0] if kind == "sphere" else size[-1]  # (r,), (r, h), (x, y, z)
    assert heights.max() == pytest.approx(top, abs=0.01)
    # the filled-in sides stand under the object's outline: as wide as it is
    basis = plane_basis(seg.table.normal)
    width = np.ptp(seen @ basis, axis=0)
    assert_allclose(np.ptp(obj @ basis, axis=0), width, atol=1e-9)
    low = obj[heights < 0.5 * heights.max()]
    assert len(low) > 0.2 * len(obj)


def test_a_box_on_a_desk_stands_on_the_desk_not_on_the_floor_it_hides() -> None:
    """A wide camera over a desk sees more floor than desk. The box on the
    desk hides the floor under it, as an object seen from straight above hides
    the table under it, but the desk round its foot holds it up: the desk is
    the table, and the box is as tall as it is (its sides were filled in down
    to the floor, 85 cm)."""
    rng = np.random.default_rng(0)

    def grid(x: tuple[float, float], y: tuple[float, float], step: float) -> np.ndarray:
        u, v = np.arange(*x, step), np.arange(*y, step)
        return np.stack(np.meshgrid(u, v), -1).reshape(-1, 2)

    floor = grid((-1.2, 1.2), (-1.2, 1.2), 0.01)
    floor = floor[(np.abs(floor[:, 0]) > 0.5) | (np.abs(floor[:, 1]) > 0.35)]
    desk = grid((-0.5, 0.5), (-0.35, 0.35), VOXEL)
    # hidden by the box: under it, and its shadow away from the camera (-y)
    desk = desk[(np.abs(desk[:, 0]) > 0.03) | (desk[:, 1] < -0.03) | (desk[:, 1] > 0.1)]
    top = grid((-0.03, 0.03), (-0.03, 0.03), VOXEL)
    face = grid((-0.03, 0.03), (0.76, 0.85), VOXEL)  # the side facing the camera
    points = np.vstack(
        [
            np.column_stack([floor, np.zeros(len(floor))]),
            np.column_stack([desk, np.full(len(desk), 0.75)]),
            np.column_stack([top, np.full(len(top), 0.85)]),
            np.column_stack([face[:, 0], np.full(len(face), -0.03), face[:, 1]]),
        ]
    )
    points += rng.normal(0.0, 0.0005, points.shape)
    assert len(floor) > len(desk)
    seg = RansacDbscan().segment(
        points, RansacDbscanOptions(), seed=0, viewpoints=np.array([[0.0, -0.8, 1.6]])
    )
    assert abs(seg.table.signed_distance(np.array([[0.0, 0.0, 0.75]]))[0]) < 0.003
    (obj,) = seg.clusters
    assert np.ptp(obj[:, 2]) < 0.11  # 10 cm tall, not filled down to the floor


@pytest.mark.parametrize(
    "kind,size,distance,elevation,azimuth",
    [
        ("box", (0.05, 0.07, 0.14), 1.5, 40, 20),
        ("cylinder", (0.035, 0.11), 2.0, 35, -30),
        ("cylinder", (0.035, 0.11), 3.0, 25, 0),
    ],
)
def test_a_desks_legs_under_its_top_are_no_objects_on_the_floor(
    kind: str,
    size: tuple[float, ...],
    distance: float,
    elevation: float,
    azimuth: float,
) -> None:
    """A camera 1.5-3 m from a desk sees its legs standing on the floor, the
    largest plane, under the desk's top; the object on the desk is what stands
    in the open. The legs (and a shred of the desk's edge, its floor hidden
    by the desk) were the objects, and a plan grasped a leg 40 cm under the
    desk in 8 of 12 such views."""
    el, az = np.radians(elevation), np.radians(azimuth)
    eye = distance * np.array(
        [np.cos(el) * np.cos(az), np.cos(el) * np.sin(az), np.sin(el)]
    )
    sys.path.insert(0, str(ROOT / "benchmarks"))
    try:
        from room_views import CAMERAS, room
    finally:
        sys.path.remove(str(ROOT / "benchmarks"))
    points, T_world_camera, centre = room(
        kind, size, eye, CAMERAS["640"], 0.002, 0.0, 0
    )
    seg = segment(downsample(points, VOXEL))
    R, t = T_world_camera[:3, :3], T_world_camera[:3, 3]
    up = R @ seg.table.normal
    assert up[2] > 0.99
    desk_top = seg.table.signed_distance(((np.zeros(3) - t) @ R)[None])[0]
    assert abs(desk_top) < 0.01  # the desk's top, not the floor 76 cm under it
    obj = seg.clusters[0] @ R.T + t
    assert np.linalg.norm(obj.mean(axis=0)[:2] - centre[:2]) < 0.03


@pytest.mark.parametrize("gap", [0.008, 0.0095])
def test_the_sides_of_a_sparsely_seen_top_stand_under_its_outline(gap: float) -> None:
    """A 15 cm box whose top alone is seen, and sparsely (from far or at a
    slant: rows of points ``gap`` apart, 5 mm along them, within DBSCAN's reach
    of each other), its gap to the table
    hidden: its sides are filled in under the top's outline, not under the
    rows in its middle (they stood up to 5 cm inside the box)."""
    rng = np.random.default_rng(0)
    ax = np.arange(-0.3, 0.3, VOXEL)
    table = np.stack(np.meshgrid(ax, ax), -1).reshape(-1, 2)
    table = table[(np.abs(table) > 0.085).any(axis=1)]  # hidden under the box
    u = np.arange(-0.075, 0.0751, VOXEL)
    v = np.arange(-0.075, 0.0751, gap)
    top = np.stack(np.meshgrid(u, v), -1).reshape(-1, 2)
    points = np.vstack(
        [
            np.column_stack([table, np.zeros(len(table))]),
            np.column_stack([top, np.full(len(top), 0.15)]),
        ]
    ) + rng.normal(0, 0.0005, (len(table) + len(top), 3))
    seg = segment(points)
    assert seg.info["planes_tried"][-1].get("sides filled in", 0) > 0
    (obj,) = seg.clusters
    low = obj[obj[:, 2] < 0.1]  # the filled-in sides
    # how far in from the outline of the top as seen (its rows' ends)
    edge = np.abs(top).max(axis=0)  # (2,)
    inside = (edge - np.abs(low[:, :2])).min(axis=1)
    assert len(low) > 100 and inside.max() < 0.015  # 3 cells; 7 cm unclosed


@pytest.mark.parametrize("elevation", [45.0, 60.0])
@pytest.mark.parametrize("lift", [0.05, 0.15])
def test_an_object_hanging_over_the_table_does_not_stand_on_it(
    elevation: float, lift: float
) -> None:
    # a camera that looks in under it sees the table below its middle
    points = one_view("box", (0.06, 0.08, 0.05), lift, elevation, 0)
    with pytest.raises(InputError, match="nothing stands on the table.*not touching"):
        segment(points)


def test_a_cluster_apart_from_the_table_is_named_with_the_contact_distance() -> None:
    # the hint names the contact_distance that takes the hanging box, for an
    # object whose foot the cameras do not see; with it, the box stands
    points = one_view("box", (0.06, 0.08, 0.05), 0.05, 45.0, 0)
    with pytest.raises(InputError) as err:
        segment(points)
    hint = err.value.hint
    found = re.search(
        r"its lowest (\d+\.\d) cm above it.*contact_distance to ([\d.]+)", hint
    )
    assert found, hint
    assert float(found.group(1)) == pytest.approx(5.0, abs=0.6)
    reach = float(found.group(2))
    assert (
        float(found.group(1)) / 100.0 < reach <= float(found.group(1)) / 100.0 + 0.015
    )
    assert len(segment(points, contact_distance=reach).clusters) == 1


@pytest.mark.parametrize("gap", [0.03, 0.05, 0.1])
@pytest.mark.parametrize("views", [1, 3])
def test_something_held_over_an_object_does_not_stand_on_the_table(
    gap: float, views: int
) -> None:
    # a robot's finger (2 x 2 x 6 cm) held over a box: the box hides the table
    # under it, but the cameras see the box's top under it, so it hangs: the
    # box is the one object, its sides not filled in under the finger
    rng = np.random.default_rng(3)
    box = make_object("box", (0.05, 0.05, 0.1))
    finger = make_object("box", (0.02, 0.02, 0.06))
    parts = [
        (box, transform_from(None, [0.0, 0.0, 0.05])),
        (finger, transform_from(None, [0.005, -0.004, 0.1 + gap + 0.03])),
    ]
    cams = default_cameras(views, (0, 0, 0.05), rng=rng, width=200, height=150)
    points = np.vstack(
        [
            v.points @ v.T_world_camera[:3, :3].T + v.T_world_camera[:3, 3]
            for v in render_scene(parts, 0.5, cams, 0.001, rng)
        ]
    )
    seg = segment(downsample(points, 0.005))
    assert len(seg.clusters) == 1
    heights = seg.table.signed_distance(seg.clusters[0])
    assert heights.max() == pytest.approx(0.1, abs=0.01)
    assert seg.info["planes_tried"][0]["not touching"] == 1


def two_objects() -> np.ndarray:
    """A box at (0.1, 0, 0) and a smaller cylinder at (-0.1, 0.05, 0), z up."""
    rng = np.random.default_rng(5)
    box, cyl = make_object("box"), make_object("cylinder", (0.03, 0.08))
    parts = [
        (box, transform_from(None, [0.1, 0.0, 0.08])),
        (cyl, transform_from(None, [-0.1, 0.05, 0.04])),
    ]
    cams = default_cameras(3, (0, 0, 0.05), rng=rng, width=200, height=150)
    views = render_scene(parts, 0.5, cams, 0.001, rng)
    return np.vstack(
        [v.points @ v.T_world_camera[:3, :3].T + v.T_world_camera[:3, 3] for v in views]
    )


def test_several_objects_and_every_target_rule() -> None:
    T = random_rigid(np.random.default_rng(9))
    seg = segment(downsample(moved(T, two_objects()), VOXEL))
    assert len(seg.clusters) == 2
    box_c, cyl_c = moved(T, np.array([[0.1, 0.0, 0.08], [-0.1, 0.05, 0.04]]))

    def centroid(rule: TargetRule) -> np.ndarray:
        obj, obstacles = select_target(seg, rule)
        assert len(obstacles) == (1 if rule.obstacles else 0)
        return obj.mean(axis=0)

    assert_allclose(centroid(TargetRule(rule="largest")), box_c, atol=0.02)
    near = TargetRule(rule="nearest", point=tuple(cyl_c))
    assert_allclose(centroid(near), cyl_c, atol=0.02)
    lo, hi = (
        np.minimum(cyl_c - 0.05, cyl_c + 0.05),
        np.maximum(cyl_c - 0.05, cyl_c + 0.05),
    )
    box = TargetRule(rule="inside_box", box_min=tuple(lo), box_max=tuple(hi))
    assert_allclose(centroid(box), cyl_c, atol=0.02)
    alone = TargetRule(rule="largest", obstacles=False)
    assert_allclose(centroid(alone), box_c, atol=0.02)
    with pytest.raises(
        InputError, match="'only' expects one object on the table, found 2"
    ):
        select_target(seg, TargetRule(rule="only"))
    far = TargetRule(rule="inside_box", box_min=(5, 5, 5), box_max=(6, 6, 6))
    with pytest.raises(InputError, match="inside the target box"):
        select_target(seg, far)


def test_rule_only_with_one_object() -> None:
    seg = segment(downsample(small_scene("box", "upright", 0).points, VOXEL))
    obj, obstacles = select_target(seg, TargetRule(rule="only"))
    assert obj.shape[0] > 100 and obstacles == []


# --------------------------------------------------------------------------------
# bad input
# --------------------------------------------------------------------------------
def test_no_plane_in_a_blob() -> None:
    blob = np.random.default_rng(0).normal(0, 0.2, (3000, 3))
    with pytest.raises(InputError, match="no table plane") as info:
        segment(blob)
    assert "given_table" in str(info.value)


def test_nothing_on_the_table() -> None:
    rng = np.random.default_rng(0)
    table = np.column_stack(
        [
            rng.uniform(-0.3, 0.3, 5000),
            rng.uniform(-0.3, 0.3, 5000),
            rng.normal(0, 5e-4, 5000),
        ]
    )
    with pytest.raises(InputError, match="nothing stands on the table"):
        segment(table)


def test_object_too_small_for_min_points() -> None:
    points = downsample(small_scene("sphere", "upright", 0).points, VOXEL)
    with pytest.raises(InputError, match="nothing stands on the table.*too small"):
        segment(points, min_points=100000)


def test_select_target_without_clusters() -> None:
    seg = Segmentation(
        table=segment_plane_only(), table_points=np.zeros((0, 3)), clusters=[]
    )
    with pytest.raises(InputError, match="nothing stands on the table"):
        select_target(seg, TargetRule())


def segment_plane_only():  # noqa: ANN201 - tiny helper
    from wsgrasp.perception.types import Plane

    return Plane(np.array([0.0, 0.0, 1.0]), 0.0)


def test_options_are_validated() -> None:
    with pytest.raises(ValueError, match="min_height"):
        RansacDbscanOptions(min_height=0.5, max_height=0.1)
    with pytest.raises(ValueError, match="extra"):
        RansacDbscanOptions(plane_dist=0.01)  # type: ignore[call-arg]
    with pytest.raises(ValueError, match="exactly one of offset or point"):
        GivenTableOptions(normal=(0, 0, 1))


# --------------------------------------------------------------------------------
# given_table
# --------------------------------------------------------------------------------
@pytest.mark.parametrize("flip", [False, True], ids=["normal-up", "normal-down"])
def test_given_table_removes_table_points(flip: bool) -> None:
    T = random_rigid(np.random.default_rng(4))
    synth = small_scene("box", "upright", 0)
    points = moved(T, downsample(synth.points, VOXEL))
    table = move_plane(T, synth.table)
    n = -table.normal if flip else table.normal
    point_on_table = T[:3, 3]  # the world origin is on the table
    opts = GivenTableOptions(normal=tuple(n), point=tuple(point_on_table))
    seg = GivenTable().segment(points, opts, seed=0)
    assert_allclose(seg.table.normal, table.normal, atol=1e-9)
    (obj,) = seg.clusters
    heights = seg.table.signed_distance(obj)
    assert heights.min() > 0.005
    # every box point above the threshold is kept
    assert obj.shape[0] == int((table.signed_distance(points) > 0.005).sum())
    by_offset = GivenTableOptions(normal=tuple(n), offset=float(-n @ point_on_table))
    assert (
        GivenTable().segment(points, by_offset, seed=0).clusters[0].shape == obj.shape
    )


def test_given_table_with_nothing_above() -> None:
    flat = np.random.default_rng(0).uniform(-0.1, 0.1, (100, 3)) * [1, 1, 0]
    opts = GivenTableOptions(normal=(0, 0, 1), offset=0.0)
    with pytest.raises(InputError, match="none of the 100 points"):
        GivenTable().segment(flat, opts, seed=0)


# --------------------------------------------------------------------------------
# a noisy camera
# --------------------------------------------------------------------------------
def test_height_noise_measures_noise_wider_than_its_band() -> None:
    from wsgrasp_segmenters.ransac_dbscan import height_noise

    rng = np.random.default_rng(0)
    for sigma in (0.0005, 0.003, 0.012, 0.02):
        h = rng.normal(0.0, sigma, 20000)
        h[:500] = rng.uniform(0.0, 0.1, 500)  # an object's points above the table
        assert height_noise(h, 0.015) == pytest.approx(sigma, rel=0.1)
    assert height_noise(np.zeros(10), 0.015) == 0.0


@pytest.mark.parametrize("noise", [0.008, 0.012, 0.016])
def test_a_noisy_tables_points_are_not_the_object(noise: float) -> None:
    """With 8-16 mm of depth noise (a depth camera far from the table: 22-51 %
    of the table's points more than 1 cm off its plane), the object found is
    the one on the table, not a cluster of the table's own noise 30 cm from it
    (which the fixed min_height gave from 12 mm on), and the noise is measured;
    noise_floor 0 gives the fixed thresholds back."""
    from wsgrasp.perception.synth import synth_scene

    syn = synth_scene("box", size=(0.05, 0.05, 0.1), seed=1, noise=noise)
    points = downsample(syn.points, VOXEL)
    seg = segment(points)
    centre = syn.T_world_mesh[:3, 3]
    obj = select_target(seg, TargetRule(rule="largest"))[0]
    assert np.linalg.norm(obj.mean(axis=0) - centre) < 0.04
    assert seg.info["depth_noise"] == pytest.approx(noise, rel=0.25)
    if noise >= 0.012:
        fixed = segment(points, noise_floor=0.0)
        obj = select_target(fixed, TargetRule(rule="largest"))[0]
        assert np.linalg.norm(obj.mean(axis=0) - centre) > 0.1


def test_a_noisy_plan_grasps_the_object_and_warns() -> None:
    """The Franka hand's default spec on a 5 cm box seen with 12 mm of depth
    noise: the cloud measures 8.5 cm across, which the noise widens, so the box
    is not too large; the grasp is on the box, and the result warns that the
    depth is noisy. With 1 mm, no warning."""
    from wsgrasp.api import Pipeline
    from wsgrasp.default_specs import default_spec
    from wsgrasp.perception.synth import synth_scene
    from wsgrasp.spec import load_spec

    pipe = Pipeline(load_spec(default_spec("franka_hand")[0]))
    for noise in (0.001, 0.012):
        syn = synth_scene("box", size=(0.05, 0.05, 0.1), seed=1, noise=noise)
        result = pipe.plan(syn.points)
        assert result.found, result.hint
        tcp = result.T_world_tcp[:3, 3]
        assert np.linalg.norm(tcp - syn.T_world_mesh[:3, 3]) < 0.05
        noisy = [w for w in result.warnings if "the depth is noisy" in w]
        assert len(noisy) == (noise > 0.005)


def test_an_object_too_small_for_min_points_is_named_with_the_fix() -> None:
    """A 1.2 cm cube (14 points above min_height at 5 mm voxels, three cameras)
    is no object for min_points 30: the error names its cluster's size, and with
    min_points at that size the cube is found."""
    import re

    from wsgrasp.perception.synth import synth_scene

    syn = synth_scene("box", size=(0.012, 0.012, 0.012), seed=1)
    points = downsample(syn.points, VOXEL)
    with pytest.raises(InputError, match="nothing stands on the table") as info:
        segment(points)
    hint = info.value.hint or ""
    found = re.search(r"has (\d+) points and is ([\d.]+) cm across", hint)
    assert found, hint
    count = int(found.group(1))
    assert 8 <= count < 30 and float(found.group(2)) < 2.5
    seg = segment(points, min_points=count)
    obj = select_target(seg, TargetRule(rule="largest"))[0]
    assert np.linalg.norm(obj.mean(axis=0) - syn.T_world_mesh[:3, 3]) < 0.01


def test_an_empty_desks_legs_are_planned_on_with_a_warning() -> None:
    """An empty desk on legs, the floor in view: nothing stands in the open, so
    the floor's legs, which stand under the desk's top, are the objects (the
    desk holds none), and the plan warns that every object stands under a
    surface: the target may be a leg."""
    from wsgrasp.api import Pipeline
    from wsgrasp.default_specs import default_spec
    from wsgrasp.perception.io import scene_from_arrays
    from wsgrasp.spec import PipelineSpec

    sys.path.insert(0, str(ROOT / "benchmarks"))
    try:
        from room_views import CAMERAS, room
    finally:
        sys.path.remove(str(ROOT / "benchmarks"))
    el, az = np.radians(40.0), np.radians(20.0)
    eye = 1.5 * np.array([np.cos(el) * np.cos(az), np.cos(el) * np.sin(az), np.sin(el)])
    points, _, _ = room(None, (), eye, CAMERAS["640"], 0.002, 0.0, 0)
    seg = RansacDbscan().segment(
        downsample(points, VOXEL),
        RansacDbscanOptions(),
        seed=0,
        viewpoints=np.zeros((1, 3)),
    )
    assert seg.info.get("under_surface") is True
    pipe = Pipeline(PipelineSpec.model_validate(default_spec("franka_hand")[0]))
    result = pipe.plan(scene_from_arrays(points))
    assert any("stands under a flat surface" in w for w in result.warnings)


def test_the_window_round_a_cluster_takes_the_points_a_pass_over_all_takes() -> None:
    """The points in a cluster's grid (and a cell round it), as the segmenter
    takes them from its sorted squares after the first clusters, are those a
    pass over every point takes, for boxes of any size and place (past the
    points' edges too)."""
    from wsgrasp_segmenters.ransac_dbscan import _Window

    rng = np.random.default_rng(3)
    p = rng.uniform(-2.0, 2.0, (50_000, 3))
    basis = plane_basis(rng.normal(size=3))
    window = _Window(p, basis)
    uv = window.uv  # the projection it sorts
    for _ in range(60):
        lo = rng.uniform(-2.5, 2.5, 2)
        shape = tuple(int(n) for n in rng.integers(1, 60, 2))
        side = float(rng.uniform(0.002, 0.03))
        a, b = lo - side, lo + (np.asarray(shape) + 1) * side
        inside = ((uv >= a) & (uv <= b)).all(axis=1)
        np.testing.assert_array_equal(
            window.within(lo, shape, side), np.flatnonzero(inside)
        )
    assert window.order is not None  # the sorted squares were used


def test_a_floor_found_as_slabs_leaves_the_desk_over_it_a_plane_to_try() -> None:
    """A noisy floor is found as parallel slabs, each a plane larger than the
    desk: they used up the three planes tried, and the legs standing on them
    under the desk's top were the objects. Where all that stands on the planes
    tried stands under a surface, as many planes again are tried: the desk is
    the table and the box on it the object."""
    rng = np.random.default_rng(0)

    def box(lo: tuple[float, float, float], hi: tuple[float, float, float]):
        """Points on a box's four sides and top, 5 mm apart."""
        (x0, y0, z0), (x1, y1, z1) = lo, hi
        zs = np.arange(z0, z1, 0.005)
        sides = []
        for x in np.arange(x0, x1, 0.005):
            sides += [[x, y0, z] for z in zs] + [[x, y1, z] for z in zs]
        for y in np.arange(y0, y1, 0.005):
            sides += [[x0, y, z] for z in zs] + [[x1, y, z] for z in zs]
        return np.vstack([np.array(sides), level_grid((x0, x1), (y0, y1), z1, 0.005)])

    slabs = [
        level_grid((-1.5, 1.5), (-1.5, 1.5), z, 0.01) for z in (-0.76, -0.75, -0.77)
    ]
    floor = np.vstack(slabs)
    floor = floor[(np.abs(floor[:, 0]) > 0.42) | (np.abs(floor[:, 1]) > 0.62)]
    # the legs' upper half hidden under the desk's top, as a camera over it sees
    legs = [
        box(
            (sx * 0.35 - 0.025, sy * 0.55 - 0.025, -0.745),
            (sx * 0.35 + 0.025, sy * 0.55 + 0.025, -0.35),
        )
        for sx in (-1, 1)
        for sy in (-1, 1)
    ]
    desk = level_grid((-0.4, 0.4), (-0.6, 0.6), 0.0, 0.005)
    desk = desk[(np.abs(desk[:, 0] - 0.05) > 0.03) | (np.abs(desk[:, 1]) > 0.04)]
    thing = box((0.02, -0.04, 0.003), (0.08, 0.04, 0.12))
    points = np.vstack([floor, *legs, desk, thing])
    points += rng.normal(0.0, 0.0005, points.shape)
    assert min(len(s) for s in slabs) > len(desk)
    seg = RansacDbscan().segment(
        downsample(points, VOXEL),
        RansacDbscanOptions(),
        seed=0,
        viewpoints=np.array([[1.2, 0.0, 1.0]]),
    )
    assert abs(seg.table.signed_distance(np.zeros((1, 3)))[0]) < 0.005
    assert "under_surface" not in seg.info
    assert np.linalg.norm(seg.clusters[0].mean(axis=0)[:2] - [0.05, 0.0]) < 0.02
