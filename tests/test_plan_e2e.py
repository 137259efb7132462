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


def test_a_view_posed_degrees_off_is_named(pipelines):
    """One of three views posed 3 degrees off (a hand-eye calibration gone
    wrong) sees its own table apart from the others': the plan warns, naming
    it and the fix; the views as calibrated give no such warning."""
    from scipy.spatial.transform import Rotation

    scene = load_scene([ROOT / "examples" / "scenes" / "cone_views" / "scene.yaml"])
    assert not any("apart" in w for w in pipelines["franka_hand"].plan(scene).warnings)
    views = [(v.points, np.array(v.T_world_camera)) for v in scene.views]
    turn = np.eye(4)  # 3 degrees about the camera's own x axis
    turn[:3, :3] = Rotation.from_rotvec([np.radians(3.0), 0.0, 0.0]).as_matrix()
    views[2] = (views[2][0], views[2][1] @ turn)
    off = pipelines["franka_hand"].plan(scene_from_arrays(views))
    (warning,) = [w for w in off.warnings if "see the table apart" in w]
    assert "'view_2' (3.0°" in warning and "icp" in warning
    assert "'view_0'" not in warning and "'view_1'" not in warning


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


def test_mirror_hidden_adds_the_unseen_sides_of_an_object_seen_from_one_side():
    # one camera sees two side faces and the top of an upright box: turned half
    # a turn about the vertical through its middle, they give the two it did not
    from wsgrasp.perception.sides import mirror_hidden

    s = synth_scene("box", size=(0.06, 0.08, 0.16), views=1, seed=3)
    up = np.array([0.0, 0.0, 1.0])
    seen = s.points[s.points[:, 2] > 0.01]
    eye = s.views[0].T_world_camera[:3, 3][None]
    both = mirror_hidden(seen, up, eye)
    assert len(both) == 2 * len(seen)
    # in the box's frame, below its top: the camera saw two adjacent side faces
    # (and the top's edges along the others); the completed cloud has as many
    # points on each face as on the one opposite
    half = np.array([0.03, 0.04])

    def on_faces(points: np.ndarray) -> np.ndarray:  # (2, 2): axis, side
        local = (points - s.T_world_mesh[:3, 3]) @ s.T_world_mesh[:3, :3]
        side = local[:, 2] < 0.06
        return np.array(
            [
                [
                    np.sum(side & (np.abs(local[:, k] - sign * half[k]) < 0.005))
                    for sign in (-1, 1)
                ]
                for k in range(2)
            ]
        )

    seen_faces, both_faces = on_faces(seen), on_faces(both)
    k = int(np.argmax(seen_faces.max(axis=1)))  # the axis the camera faces most
    assert seen_faces[k].min() < 0.2 * seen_faces[k].max(), seen_faces
    assert (both_faces.min(axis=1) > 0.9 * both_faces.max(axis=1)).all(), both_faces
    # the new points lie on the box, within the noise and the middle's error
    local = (both[len(seen) :] - s.T_world_mesh[:3, 3]) @ s.T_world_mesh[:3, :3]
    assert (np.abs(local[:, :2]) < half + 0.005).all()
    # cameras all round, or none: nothing added
    around = np.array([[1.0, 0.0, 0.5], [-0.5, 0.87, 0.5], [-0.5, -0.87, 0.5]])
    assert mirror_hidden(seen, up, around) is seen
    assert mirror_hidden(seen, up, np.zeros((0, 3))) is seen


@pytest.mark.parametrize("seed", range(4))
def test_a_jaw_grasps_an_upright_box_seen_by_one_camera(seed):
    # the jaw closes across two faces, one of which no camera saw: with the
    # hidden sides mirrored in, it holds points on both
    from wsgrasp.default_specs import default_spec
    from wsgrasp.spec import PipelineSpec

    s = synth_scene("box", size=(0.06, 0.08, 0.16), views=1, seed=seed)
    data, _ = default_spec("franka_hand")
    feasible = {}
    for mirror in (False, True):
        spec = PipelineSpec.model_validate(data)
        spec.object_frame.mirror_hidden = mirror
        r = Pipeline(spec).plan(
            scene_from_arrays([(v.points, v.T_world_camera) for v in s.views])
        )
        feasible[mirror] = int(r.candidates.feasible.sum())
        if mirror:
            assert r.found, r.hint
    assert feasible[True] > feasible[False]
