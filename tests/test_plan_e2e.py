"""Planning end to end with the built-in grippers on bundled and new synthetic
scenes: a grasp is found, it is collision-free against the true object and table,
and every finger holds part of the object."""

from __future__ import annotations

from pathlib import Path

import numpy as np
import pytest

from wsgrasp import Pipeline
from wsgrasp.errors import InputError
from wsgrasp.geometry import invert_transforms, transform_points
from wsgrasp.perception.io import load_scene, scene_from_arrays
from wsgrasp.perception.synth import synth_scene
from wsgrasp.spec import load_spec

ROOT = Path(__file__).resolve().parents[1]
GRIPPERS = {"franka_hand": "franka.yaml", "allegro_right": "allegro.yaml"}


@pytest.fixture(scope="session")
def pipelines():
    return {
        g: Pipeline(load_spec(ROOT / "examples" / "specs" / f))
        for g, f in GRIPPERS.items()
    }


def _check_grasp(result, pipeline, mesh, T_world_mesh, table_normal, table_offset):
    """The chosen grasp against ground truth: gripper cloud outside the mesh and
    above the table, each finger holding object points near the true surface."""
    assert result.found, result.hint
    g = pipeline.gripper
    cloud_world = transform_points(result.T_world_ee, g.cloud)
    # above the table (2 mm for sensor noise in the fitted plane)
    heights = cloud_world @ table_normal + table_offset
    assert heights.min() > -0.002, heights.min()
    # not inside the object: the gripper's body is allowed to touch the surface
    # within the sensor noise, never to go deep
    cloud_mesh = transform_points(invert_transforms(T_world_mesh), cloud_world)
    depth = -mesh.nearest.signed_distance(cloud_mesh)  # trimesh: + inside
    assert np.max(-depth) < 0.006, f"gripper {np.max(-depth):.4f} m inside the object"
    assert len(result.contacts) == g.num_fingers
    for c in result.contacts:
        assert len(c.points) > 0, f"finger {c.finger} holds nothing"
        held = transform_points(invert_transforms(T_world_mesh), c.points)
        dist = np.abs(mesh.nearest.signed_distance(held))
        assert np.median(dist) < 0.004


@pytest.mark.parametrize("gripper", list(GRIPPERS))
@pytest.mark.parametrize(
    ("kind", "size", "pose"),
    [
        ("box", (0.05, 0.06, 0.14), "upright"),
        ("cylinder", (0.03, 0.12), "upright"),
        ("cylinder", (0.03, 0.18), "lying"),
        ("cone", (0.04, 0.12), "upright"),
        ("ring", (0.025, 0.045, 0.05), "upright"),
        ("sphere", (0.035,), "upright"),
        ("box", (0.04, 0.05, 0.13), "random"),
    ],
    ids=lambda v: "x".join(map(str, v)) if isinstance(v, tuple) else str(v),
)
@pytest.mark.parametrize("frame", ["world", "camera"])
def test_new_synthetic_scenes(pipelines, gripper, kind, size, pose, frame):
    syn = synth_scene(
        kind,
        size=size,
        pose=pose,
        seed=11,
        width=160,
        height=120,
        table_size=0.4,
        camera_frame=frame == "camera",
    )
    pipe = pipelines[gripper]
    result = pipe.plan(scene_from_arrays(syn.points))
    _check_grasp(
        result, pipe, syn.mesh, syn.T_world_mesh, syn.table.normal, syn.table.offset
    )


@pytest.mark.parametrize("gripper", list(GRIPPERS))
@pytest.mark.parametrize(
    "scene", ["box_upright.npz", "mug.npz", "bottle_lying.npz", "box_camera_frame.npz"]
)
def test_bundled_scenes(pipelines, gripper, scene):
    result = pipelines[gripper].plan(load_scene([ROOT / "examples" / "scenes" / scene]))
    assert result.found, result.hint
    assert all(len(c.points) for c in result.contacts)
    assert result.timing_ms["total"] > 0
    hist = result.candidates.histogram()
    sampling = pipelines[gripper].spec.sampling
    assert sum(hist.values()) == len(result.candidates)
    assert len(result.candidates) == sampling.points * result.info["orientations"]
    # every candidate approaches from above the table or level with it
    up = result.candidates.T_world_gwc[:, :3, 2] @ result.info["table_normal"]
    assert up.max() <= np.sin(np.deg2rad(sampling.upward_tolerance_deg)) + 1e-9


def test_cone_views_scene_yaml(pipelines):
    scene = load_scene([ROOT / "examples" / "scenes" / "cone_views" / "scene.yaml"])
    assert len(scene.views) == 3
    assert pipelines["franka_hand"].plan(scene).found


def test_object_too_wide_is_a_no_grasp_result(pipelines):
    syn = synth_scene("box", size=(0.2, 0.22, 0.25), seed=3, width=160, height=120)
    result = pipelines["franka_hand"].plan(syn.points)
    assert not result.found
    assert result.T_world_ee is None
    assert "too large" in result.hint and "narrowest" in result.hint
    assert sum(result.rejections.values()) == len(result.candidates)


@pytest.mark.parametrize(
    ("points", "fragment"),
    [
        (np.zeros((0, 3)), "empty"),
        (np.full((100, 3), np.nan), "no finite point"),
        (np.random.default_rng(0).normal(size=(500, 3)) * 5000.0, "millimetres"),
    ],
    ids=["empty", "all-nan", "millimetres"],
)
def test_bad_clouds_get_one_clear_error(pipelines, points, fragment):
    with pytest.raises(InputError, match=fragment):
        pipelines["franka_hand"].plan(points)


def test_nothing_on_the_table(pipelines):
    rng = np.random.default_rng(0)
    table = np.column_stack([rng.uniform(-0.3, 0.3, (20000, 2)), np.zeros(20000)])
    with pytest.raises(InputError, match="(?i)nothing|no object|cluster"):
        pipelines["franka_hand"].plan(table + rng.normal(0, 0.0005, table.shape))


def test_json_fields(pipelines):
    syn = synth_scene("box", size=(0.05, 0.06, 0.14), seed=1, width=160, height=120)
    data = pipelines["franka_hand"].plan(syn.points).to_json()
    for key in (
        "found",
        "T_world_ee",
        "T_world_gwc",
        "score",
        "candidates",
        "rejections",
        "timing_ms",
    ):
        assert key in data
    assert np.asarray(data["T_world_ee"]).shape == (4, 4)
    # each pose again as a robot's message takes it, the quaternion scalar last
    from scipy.spatial.transform import Rotation

    for name in ("ee", "tcp", "pregrasp"):
        T = np.asarray(data[f"T_world_{name}"])
        pose = data["poses"][name]
        np.testing.assert_allclose(pose["translation"], T[:3, 3])
        R = Rotation.from_quat(pose["quaternion_xyzw"]).as_matrix()
        np.testing.assert_allclose(R, T[:3, :3], atol=1e-12)
    assert "total" in data["timing_ms"]
    assert data["feasible"] + sum(data["rejections"].values()) == data["candidates"]


def test_crop_radius_drops_what_lies_farther_in_plan(pipelines):
    """``preprocess.crop_radius`` applies in ``plan``: a second object beyond it
    is not seen (with ``target.rule: only`` it would be an error)."""
    scene = load_scene([ROOT / "examples" / "scenes" / "box_upright.npz"])
    spec = pipelines["franka_hand"].spec
    first = pipelines["franka_hand"].plan(scene)
    assert first.found, first.hint
    n = np.asarray(first.info["table_normal"], dtype=np.float64)
    c = first.T_world_object[:3, 3]
    # a copy of the object 1.5 m further away from the origin, along the table
    away = c - (c @ n) * n
    away = away / np.linalg.norm(away) if np.linalg.norm(away) > 1e-6 else None
    if away is None:
        away = np.cross(n, [1.0, 0.0, 0.0] if abs(n[0]) < 0.9 else [0.0, 1.0, 0.0])
        away /= np.linalg.norm(away)
    obj = scene.points[np.linalg.norm(scene.points - c, axis=1) < 0.12]
    both = scene_from_arrays(np.vstack([scene.points, obj + 1.5 * away]))
    radius = float(np.linalg.norm(scene.points, axis=1).max()) + 0.01
    data = spec.model_dump(mode="json")
    data["target"] = {"rule": "only"}
    with pytest.raises(InputError):
        Pipeline(load_spec(data), gripper=pipelines["franka_hand"].gripper).plan(both)
    data["preprocess"]["crop_radius"] = radius
    cropped = Pipeline(load_spec(data), gripper=pipelines["franka_hand"].gripper)
    prepared = cropped.prepare(both)
    assert np.linalg.norm(prepared.downsampled, axis=1).max() <= radius
    assert cropped.plan(both).found
