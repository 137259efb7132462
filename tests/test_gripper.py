"""Gripper models of the built-in grippers: Table I counts, workspace spheres, body
superellipsoids, frames, the on-disk cache and the ``wsgrasp grippers`` commands."""

from __future__ import annotations

import json
import shutil
from pathlib import Path

import numpy as np
import pytest
from numpy.testing import assert_allclose

from wsgrasp.cli import main
from wsgrasp.errors import PluginError
from wsgrasp.geometry import points_in_superellipsoids
from wsgrasp.gripper import GripperModel, load_gripper, sample_workspace
from wsgrasp.spec import load_gripper_description

PLUGIN_DIR = Path(__file__).resolve().parents[1] / "plugins/grippers/wsgrasp_grippers"
YAML = {n: PLUGIN_DIR / n / f"{n}.yaml" for n in ("franka_hand", "allegro_right")}
#: the paper's Table I: fingers, spheres per finger, ellipsoids, cloud points
TABLE_I = {"franka_hand": (2, 10, 5, 499), "allegro_right": (4, 77, 5, 870)}


@pytest.fixture(scope="session")
def gripper_cache(tmp_path_factory) -> Path:
    return tmp_path_factory.mktemp("gripper-cache")


@pytest.fixture(scope="session")
def models(gripper_cache) -> dict[str, GripperModel]:
    """Both built-in grippers, built once (cold) into a fresh cache."""
    return {n: load_gripper(n, cache_dir=gripper_cache) for n in TABLE_I}


@pytest.fixture(scope="session")
def workspaces() -> dict[str, list]:
    out = {}
    for name, path in YAML.items():
        desc, base = load_gripper_description(path)
        out[name] = [sample_workspace(desc, base, f.name) for f in desc.fingers]
    return out


@pytest.mark.parametrize("name", list(TABLE_I))
def test_table_i_counts(models, name):
    m = models[name]
    nf, nsp, ne, ng = TABLE_I[name]
    assert m.num_fingers == nf
    assert m.spheres_per_finger == [nsp] * nf
    assert m.se_centers.shape == m.se_semi_axes.shape == (ne, 3)
    assert m.cloud.shape == (ng, 3)
    assert m.sphere_centers.shape == (nf * nsp, 3)
    assert np.all(np.isfinite(m.cloud)) and np.all(m.sphere_radii > 0)
    assert m.stats["cache"] == "miss" and m.stats["build_s"] > 0


@pytest.mark.parametrize("name", list(TABLE_I))
def test_every_sphere_lies_inside_its_fingers_workspace(models, workspaces, name):
    m = models[name]
    rng = np.random.default_rng(0)
    dirs = rng.normal(size=(200, 3))
    dirs /= np.linalg.norm(dirs, axis=1, keepdims=True)
    for f, ws in enumerate(workspaces[name]):
        sel = m.sphere_finger == f
        centers, radii = m.sphere_centers[sel], m.sphere_radii[sel]
        # every voxel centre within a sphere is an occupied voxel
        occ = ws.centers(np.argwhere(ws.occupied))  # (V, 3)
        for c, r in zip(centers, radii, strict=True):
            lattice = (
                ws.centers(np.argwhere(np.ones((41, 41, 41), bool)) - 20)
                - ws.origin
                + c
            )  # (41**3, 3) lattice around c
            near = lattice[np.linalg.norm(lattice - c, axis=1) <= r]
            assert ws.contains(near).all(), f"{name} finger {f}: sphere leaves ws"
        # points on the sphere surfaces fall in occupied voxels
        shell = centers[:, None] + radii[:, None, None] * dirs[None] * 0.999
        assert ws.contains(shell.reshape(-1, 3)).all()
        # and the spheres sit where that finger's pad points were sampled
        d = np.linalg.norm(occ[None] - centers[:, None], axis=-1).min(axis=1)
        assert_allclose(d, 0.0, atol=1e-9)


@pytest.mark.parametrize("name", list(TABLE_I))
def test_stats_report_coverage_and_cloud_inside_ses(models, name):
    m = models[name]
    for f in m.stats["fingers"]:
        assert 0.3 < f["covered_fraction"] <= 1.0
        assert f["workspace_volume_m3"] > 0
        assert f["workspace_inside_se"] < 0.2
    inside = points_in_superellipsoids(m.cloud, m.se_centers, m.se_semi_axes)
    assert_allclose(m.stats["cloud_inside_se"], inside.mean(), atol=1e-4)
    assert m.stats["cloud_inside_se"] >= 0.99


def test_franka_matches_the_authors_numbers(models):
    m = models["franka_hand"]
    # ten 5 mm spheres per finger at the fingertips, 0-40 mm off centre
    assert_allclose(m.sphere_radii.max(), 0.005, atol=1e-9)
    y = m.sphere_centers[:, 1]
    left = m.sphere_finger == m.finger_names.index("left")
    assert np.all((y[left] > 0) & (y[left] < 0.04))
    assert np.all((y[~left] < 0) & (y[~left] > -0.04))
    assert_allclose(m.sphere_centers[:, 2], 0.1034, atol=0.003)
    assert_allclose(m.max_opening, 0.08, atol=1e-9)
    assert_allclose(m.T_gripper_tcp[:3, 3], [0, 0, 0.1034], atol=1e-12)
    # fitted body SEs near the authors' hand-made ones (palm, fingers, flange)
    ref_centers = np.array(
        [[0, 0, 0.0225], [0, 0.05, 0.09], [0, -0.05, 0.09], [-0.01, 0, -0.02]]
    )
    for c in ref_centers:
        assert np.linalg.norm(m.se_centers - c, axis=1).min() < 0.015


@pytest.mark.parametrize("name", list(TABLE_I))
def test_gwc_frame(models, name):
    m = models[name]
    T = m.T_gripper_gwc
    assert_allclose(T[:3, :3] @ T[:3, :3].T, np.eye(3), atol=1e-12)
    assert_allclose(np.linalg.det(T[:3, :3]), 1.0, atol=1e-12)
    assert_allclose(T[:3, 2], m.approach_axis, atol=1e-12)
    assert_allclose(T[:3, 1], m.closing_axis, atol=1e-12)
    assert_allclose(T[:3, 3], m.sphere_centers.mean(axis=0), atol=1e-12)
    # the workspaces lie ahead of the palm along the approach axis
    assert (m.sphere_centers @ m.approach_axis).mean() > 0.04


def test_model_bytes_round_trip(models):
    m = models["allegro_right"]
    back = GripperModel.from_bytes(m.to_bytes())
    for key in ("cloud", "sphere_centers", "sphere_radii", "se_centers"):
        np.testing.assert_array_equal(getattr(back, key), getattr(m, key))
    np.testing.assert_array_equal(back.sphere_finger, m.sphere_finger)
    assert back.finger_names == m.finger_names
    assert back.description == m.description
    assert back.source_hash == m.source_hash and len(m.source_hash) == 64


def test_cache_hit_loads_without_building(models, gripper_cache):
    again = load_gripper("franka_hand", cache_dir=gripper_cache)
    first = models["franka_hand"]
    assert again.stats["cache"] == "hit"
    assert again.stats["load_s"] < first.stats["build_s"]
    assert again.source_hash == first.source_hash
    np.testing.assert_array_equal(again.sphere_centers, first.sphere_centers)
    np.testing.assert_array_equal(again.cloud, first.cloud)


def _copy_franka(tmp_path: Path) -> Path:
    """A quick-to-build copy of the Franka hand to edit."""
    folder = tmp_path / "franka"
    shutil.copytree(PLUGIN_DIR / "franka_hand", folder)
    yaml = folder / "franka_hand.yaml"
    text = yaml.read_text().replace("cloud_points: 499", "cloud_points: 120")
    yaml.write_text(text.replace("joint_samples: 41", "joint_samples: 21"))
    return yaml


def test_cache_invalidation_on_description_and_urdf(tmp_path):
    yaml = _copy_franka(tmp_path)
    cache = tmp_path / "cache"
    first = load_gripper(str(yaml), cache_dir=cache)
    assert first.stats["cache"] == "miss" and len(first.cloud) == 120
    assert load_gripper(str(yaml), cache_dir=cache).stats["cache"] == "hit"
    # the description changes: a new hash, a rebuild
    yaml.write_text(yaml.read_text().replace("cloud_points: 120", "cloud_points: 100"))
    second = load_gripper(str(yaml), cache_dir=cache)
    assert second.stats["cache"] == "miss" and len(second.cloud) == 100
    assert second.source_hash != first.source_hash
    # the URDF changes (even a comment): rebuild
    urdf = yaml.parent / "franka_hand.urdf"
    urdf.write_text(urdf.read_text() + "<!-- edited -->\n")
    third = load_gripper(str(yaml), cache_dir=cache)
    assert third.stats["cache"] == "miss"
    assert third.source_hash != second.source_hash
    # rebuild=True ignores the entry; a corrupt entry is rebuilt
    assert load_gripper(str(yaml), cache_dir=cache, rebuild=True).stats["cache"] == (
        "miss"
    )
    for entry in cache.glob("*.npz"):
        entry.write_bytes(b"garbage")
    assert load_gripper(str(yaml), cache_dir=cache).stats["cache"] == "miss"


def test_cache_dir_from_environment(tmp_path, monkeypatch):
    yaml = _copy_franka(tmp_path)
    monkeypatch.setenv("WSGRASP_CACHE_DIR", str(tmp_path / "env-cache"))
    load_gripper(str(yaml))
    assert list((tmp_path / "env-cache").glob("franka_hand-*.npz"))


def test_unknown_gripper_name_suggests_close_names():
    with pytest.raises(PluginError, match="franka_hand"):
        load_gripper("franka_hnd")


def test_cli_grippers_list_json(models, gripper_cache, monkeypatch, capsys):
    monkeypatch.setenv("WSGRASP_CACHE_DIR", str(gripper_cache))
    assert main(["grippers", "list", "--json"]) == 0
    rows = {r["name"]: r for r in json.loads(capsys.readouterr().out)}
    for name, (nf, nsp, ne, ng) in TABLE_I.items():
        r = rows[name]
        assert r["fingers"] == nf and r["spheres_per_finger"] == [nsp] * nf
        assert r["ellipsoids"] == ne and r["cloud_points"] == ng
        assert r["distribution"] == "wsgrasp"
        assert r["cache"] == "hit"


def test_cli_grippers_show_writes_a_png(models, gripper_cache, tmp_path, monkeypatch):
    monkeypatch.setenv("WSGRASP_CACHE_DIR", str(gripper_cache))
    out = tmp_path / "franka.png"
    assert main(["grippers", "show", "franka_hand", "-o", str(out)]) == 0
    assert out.read_bytes()[:8] == b"\x89PNG\r\n\x1a\n"
    assert main(["grippers", "show", "no_such_gripper", "-o", str(out)]) == 2


def test_given_superellipsoids_are_used_as_is(tmp_path):
    yaml = _copy_franka(tmp_path)
    given = (
        "ellipsoids:\n  count: 2\n  exponent: 10.0\n  given:\n"
        "    - {center: [0, 0, 0.0225], semi_axes: [0.025, 0.11, 0.045]}\n"
        "    - {center: [-0.01, 0, -0.02], semi_axes: [0.05, 0.04, 0.02]}\n"
    )
    _edit_text(yaml, "ellipsoids: {count: 5, exponent: 10.0}\n", given)
    m = load_gripper(str(yaml), cache_dir=tmp_path / "cache")
    assert_allclose(m.se_centers, [[0, 0, 0.0225], [-0.01, 0, -0.02]], atol=0)
    assert_allclose(m.se_semi_axes, [[0.025, 0.11, 0.045], [0.05, 0.04, 0.02]])
    assert m.stats["ellipsoids_fitted"] is False
    # the fingers and camera are outside these two: part of the cloud is not held
    assert 0.2 < m.stats["cloud_inside_se"] < 0.95


def _edit_text(path: Path, old: str, new: str) -> None:
    text = path.read_text()
    assert old in text, old
    path.write_text(text.replace(old, new))


MESH_URDF = """<?xml version="1.0"?>
<robot name="mesh_jaw">
  <link name="base">
    <collision><geometry>
      <mesh filename="package://mesh_jaw/meshes/palm.stl" scale="2 1 1"/>
    </geometry></collision>
  </link>
  <link name="finger">
    <collision><origin xyz="0 0 0.05"/><geometry>
      <mesh filename="meshes/palm.stl" scale="0.5 0.5 1"/>
    </geometry></collision>
  </link>
  <joint name="slide" type="prismatic">
    <parent link="base"/><child link="finger"/>
    <origin xyz="0 0 0.02"/><axis xyz="0 1 0"/>
    <limit lower="0" upper="0.03" effort="1" velocity="1"/>
  </joint>
  <link name="finger2">
    <collision><origin xyz="0 0 0.05"/><geometry>
      <mesh filename="meshes/palm.stl" scale="0.5 0.5 1"/>
    </geometry></collision>
  </link>
  <joint name="slide2" type="prismatic">
    <parent link="base"/><child link="finger2"/>
    <origin xyz="0 0 0.02"/><axis xyz="0 1 0"/>
    <limit lower="-0.03" upper="0" effort="1" velocity="1"/>
    <mimic joint="slide" multiplier="-1"/>
  </joint>
</robot>
"""

MESH_YAML = """version: 1
name: mesh_jaw
urdf: mesh_jaw.urdf
base_link: base
tool_frame: {link: base, xyz: [0, 0, 0.08]}
approach_axis: [0, 0, 1]
closing_axis: [0, 1, 0]
fingers:
  - name: only
    joints: [slide]
    pad: {link: finger, center: [0, 0, 0.06], size: [0.008, 0.0, 0.008], samples: 5}
  - name: other
    joints: [slide]
    pad: {link: finger2, center: [0, 0, 0.06], size: [0.008, 0.0, 0.008], samples: 5}
joint_samples: 16
spheres_per_finger: 4
workspace_voxel: 0.002
ellipsoids: {count: 2}
cloud_points: 100
pregrasp: {slide: 0.03}
closed: {slide: 0.0}
"""


def test_mesh_geometry_is_loaded_scaled_and_hashed(tmp_path):
    import trimesh

    folder = tmp_path / "mesh_jaw"
    (folder / "meshes").mkdir(parents=True)
    trimesh.creation.box(extents=(0.04, 0.02, 0.02)).export(folder / "meshes/palm.stl")
    (folder / "mesh_jaw.urdf").write_text(MESH_URDF)
    (folder / "mesh_jaw.yaml").write_text(MESH_YAML)
    cache = tmp_path / "cache"
    m = load_gripper(str(folder / "mesh_jaw.yaml"), cache_dir=cache)
    assert m.cloud.shape == (100, 3) and m.spheres_per_finger == [4, 4]
    # base mesh scaled x2 along x: the cloud spans 80 mm in x
    assert_allclose(np.ptp(m.cloud[:, 0]), 0.08, atol=1e-6)
    # the finger (scaled 0.5 in y) at the open posture, 30 mm along y
    assert_allclose(m.cloud[:, 1].max(), 0.03 + 0.005, atol=1e-6)
    assert m.stats["cloud_inside_se"] >= 0.99
    # new mesh bytes: a new hash and a rebuild
    trimesh.creation.box(extents=(0.05, 0.02, 0.02)).export(folder / "meshes/palm.stl")
    again = load_gripper(str(folder / "mesh_jaw.yaml"), cache_dir=cache)
    assert again.stats["cache"] == "miss"
    assert again.source_hash != m.source_hash
    assert_allclose(np.ptp(again.cloud[:, 0]), 0.10, atol=1e-6)


def _l_round_a_workspace(rng):
    """Surface samples of an L (a block 10 cm long and a plate standing on its
    end), finger-workspace samples in its corner, and their voxel volume."""
    block = rng.uniform([0.0, -0.02, 0.0], [0.1, 0.02, 0.02], (500, 3))
    plate = rng.uniform([0.0, -0.02, 0.02], [0.01, 0.02, 0.12], (700, 3))
    lo, hi = [0.02, -0.015, 0.03], [0.08, 0.015, 0.08]
    workspace = rng.uniform(lo, hi, (400, 3))
    cell = float(np.prod(np.subtract(hi, lo))) / len(workspace)
    return block, plate, workspace, cell


def test_a_body_split_frees_the_workspace_its_box_swallows():
    """One link shaped as an L (a block and a jaw plate standing on it, as a
    rigid jaw on its gripper's body) with a finger's workspace in the corner:
    split in two, neither half's box holds the workspace (the cut runs along
    the block's top), where halving at the median along the longest side
    leaves most of it inside; a link whose box holds no workspace is still
    halved at the median along its longest side."""
    from wsgrasp.gripper._body import BodySamples, _box, _inside_box, group_links

    rng = np.random.default_rng(0)
    block, plate, workspace, cell = _l_round_a_workspace(rng)
    points = np.concatenate([block, plate])
    body = BodySamples(points, np.zeros(len(points), dtype=np.int64), ["jaw"])
    groups = group_links(body, 2, workspace, cell)
    assert sum(len(g) for g in groups) == len(points)
    assert all(_inside_box(workspace, *_box(g)) == 0 for g in groups)
    # the median cut along z (the longest side) would keep most of it inside
    below = points[points[:, 2] <= np.median(points[:, 2])]
    assert _inside_box(workspace, *_box(below)) > 0
    # with the workspace elsewhere, the longest side is halved at the median
    halves = group_links(body, 2, workspace + [0.0, 0.0, 0.3], cell)
    cut = np.median(points[:, 2])
    assert sorted(float(g[:, 2].max()) <= cut for g in halves) == [False, True]


def test_an_l_shaped_link_round_a_workspace_is_fitted_as_two():
    """A link shaped as an L round a finger's workspace (a jaw plate and the
    carriage it stands on, in one link), among as many links as superellipsoids:
    it is fitted as two groups, so no box holds the workspace in its corner; a
    straight link beside the same workspace stays whole."""
    from wsgrasp.gripper._body import BodySamples, _box, _inside_box, group_links

    rng = np.random.default_rng(1)
    block, plate, workspace, cell = _l_round_a_workspace(rng)
    small = rng.uniform([0.3, -0.01, 0.0], [0.32, 0.01, 0.02], (100, 3))
    other = rng.uniform([0.33, -0.01, 0.0], [0.35, 0.01, 0.02], (100, 3))
    points = np.concatenate([block, plate, small, other])
    link = np.repeat([0, 1, 2], [1200, 100, 100])
    body = BodySamples(points, link, ["jaw", "a", "b"])
    groups = group_links(body, 3, workspace, cell)
    assert sum(len(g) for g in groups) == len(points)
    assert all(_inside_box(workspace, *_box(g)) == 0 for g in groups)
    # the plate alone, beside the workspace: one group, as it was
    straight = BodySamples(
        np.concatenate([plate, small, other]),
        np.repeat([0, 1, 2], 100 * np.array([7, 1, 1])),
        ["jaw", "a", "b"],
    )
    kept = group_links(straight, 3, workspace, cell)
    assert sorted(len(g) for g in kept) == [100, 100, 700]
