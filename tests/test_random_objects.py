"""Object sets and mesh objects: the pybullet_data ``random`` set (names, ranges,
scale, the 3 cm rule) and coacd convex decomposition with its cache."""

from __future__ import annotations

import importlib.util
import json
from pathlib import Path

import numpy as np
import pytest

pytest.importorskip("mujoco")
pytest.importorskip("coacd")

import trimesh  # noqa: E402

import wsgrasp.sim._meshes as meshes  # noqa: E402
import wsgrasp.sim.random_objects as random_objects  # noqa: E402
from wsgrasp.errors import InputError, SimulationError  # noqa: E402
from wsgrasp.sim import SimParams, build_scene, settle_object  # noqa: E402
from wsgrasp.sim._meshes import convex_decomposition, decompose_meshes  # noqa: E402
from wsgrasp.sim.objects import (  # noqa: E402
    object_from_mesh,
    resolve_objects,
    trial_mass,
)
from wsgrasp.sim.random_objects import MIN_EXTENT, parse_selection  # noqa: E402

HAS_PYBULLET_DATA = importlib.util.find_spec("pybullet_data") is not None
needs_pybullet_data = pytest.mark.skipif(
    not HAS_PYBULLET_DATA, reason="pybullet (its data files) not installed"
)

URDF = """<robot name="blob{n:03d}">
  <link name="random_obj_{n:03d}">
    <inertial><origin rpy="0 0 0" xyz="0 0 0"/><mass value="{mass}"/>
      <inertia ixx="1" ixy="0" ixz="0" iyy="1" iyz="0" izz="0"/></inertial>
    <collision><origin rpy="0 0 0" xyz="0 0 0"/>
      <geometry><mesh filename="{n:03d}.obj" scale="0.015 0.015 0.015"/></geometry>
    </collision>
  </link>
</robot>
"""


@pytest.fixture
def cache(tmp_path: Path, monkeypatch: pytest.MonkeyPatch) -> Path:
    """A fresh decomposition cache (the gripper cache stays where it is)."""
    where = tmp_path / "mesh-cache"
    monkeypatch.setattr(
        meshes, "mesh_cache_dir", lambda cache_dir=None: Path(cache_dir or where)
    )
    return where


@pytest.fixture
def fake_random(tmp_path: Path, monkeypatch: pytest.MonkeyPatch):
    """``make(sides)``: a random_urdfs folder of cubes, side in URDF units (the
    URDF scales by 0.015, the set by 2/3: 1 unit = 1 cm), mass 0.25 kg."""

    def make(sides: dict[int, float]) -> Path:
        root = tmp_path / "random_urdfs"
        for n, side in sides.items():
            d = root / f"{n:03d}"
            d.mkdir(parents=True)
            trimesh.creation.box(extents=(side, side, side)).export(d / f"{n:03d}.obj")
            (d / f"{n:03d}.urdf").write_text(URDF.format(n=n, mass=0.25))
        monkeypatch.setattr(random_objects, "random_urdfs_dir", lambda: root)
        return root

    return make


def u_shape() -> trimesh.Trimesh:
    """A 6 cm wide U: a 2 cm bar with two 5 cm posts (concave, 80 % of its hull)."""
    bar = trimesh.creation.box(extents=(0.06, 0.02, 0.02))
    post = trimesh.creation.box(extents=(0.02, 0.02, 0.05))
    return trimesh.boolean.union(
        [
            bar.apply_translation((0, 0, 0.01)),
            post.copy().apply_translation((-0.02, 0, 0.025)),
            post.copy().apply_translation((0.02, 0, 0.025)),
        ],
        engine="manifold",
    )


def hulls_volume(hulls: list[np.ndarray]) -> float:
    parts = [trimesh.Trimesh(vertices=h).convex_hull for h in hulls]
    return float(trimesh.boolean.union(parts, engine="manifold").volume)


# --------------------------------------------------------------------------------
# names and ranges
# --------------------------------------------------------------------------------
@pytest.mark.parametrize(
    ("selection", "count", "first", "last"),
    [
        ("", 1000, 0, 999),
        ("7", 1, 7, 7),
        ("000-299", 300, 0, 299),
        ("300-999", 700, 300, 999),
        ("0-9, 20,5", 11, 0, 20),
    ],
    ids=["all", "one", "dev", "held-out", "list"],
)
def test_selections_parse(selection: str, count: int, first: int, last: int):
    ids = parse_selection(selection)
    assert len(ids) == count and ids[0] == first and ids[-1] == last
    assert ids == sorted(set(ids))


@pytest.mark.parametrize(
    ("name", "what"),
    [
        ("random:300-200", "runs backwards"),
        ("random:0-1000", "beyond the last object"),
        ("random:abc", "not a number or a range"),
        ("random:1-", "not a number or a range"),
        ("random:1,,2", "not a number or a range"),
    ],
    ids=["backwards", "too-far", "letters", "open-range", "empty-item"],
)
def test_bad_selections_name_the_set_and_the_fix(name: str, what: str):
    with pytest.raises(InputError, match=what) as info:
        resolve_objects([name])
    assert repr(name) in str(info.value)
    assert "fix: write random, random:N or random:A-B" in str(info.value)


def test_paper13_takes_no_selection_and_unknown_names_list_the_sets():
    with pytest.raises(InputError, match="paper13 takes no selection"):
        resolve_objects(["paper13:mug"])
    with pytest.raises(InputError, match=r"random:000-299") as info:
        resolve_objects(["randum:0-9"])
    assert "does not exist" in str(info.value)


def test_missing_pybullet_says_how_to_install(monkeypatch: pytest.MonkeyPatch):
    real = importlib.util.find_spec
    monkeypatch.setattr(
        importlib.util,
        "find_spec",
        lambda name, *a: None if name == "pybullet_data" else real(name, *a),
    )
    with pytest.raises(SimulationError, match=r"pip install 'wsgrasp\[sim\]'"):
        resolve_objects(["random:000-002"])


# --------------------------------------------------------------------------------
# scale, mass and the 3 cm rule
# --------------------------------------------------------------------------------
def test_scale_mass_and_the_3cm_rule(fake_random, cache: Path):
    fake_random({0: 2.9, 1: 3.1, 2: 6.0})  # cm after scaling
    got = resolve_objects(["random:0-2"])
    assert [o.name for o in got.objects] == ["random_001", "random_002"]
    assert [(k.name, k.reason) for k in got.skipped] == [("random_000", "under 3 cm")]
    for obj, side in zip(got.objects, (0.031, 0.06), strict=True):
        np.testing.assert_allclose(obj.size(), side, rtol=1e-9)
        assert obj.mass == 0.25  # the URDF's
        assert len(obj.parts) == 1  # a cube is convex: no coacd
        assert np.asarray(obj.mesh().bounds)[0, 2] == pytest.approx(0.0, abs=1e-12)
    assert MIN_EXTENT == 0.03


@needs_pybullet_data
def test_pybullet_data_objects_are_read_and_scaled():
    sources, skipped = random_objects.random_objects("0-2,168,295")
    assert [s.name for s in sources] == ["random_000", "random_001", "random_002"]
    assert {k.name: k.reason for k in skipped} == {
        "random_168": "unreadable mesh",  # its vertices are NaN
        "random_295": "under 3 cm",
    }
    for s in sources:
        np.testing.assert_allclose(s.scale, 0.015 * 2 / 3)  # URDF scale × 2/3
        assert s.mass == pytest.approx(0.1)
        assert 0.03 <= float(np.max(s.scaled().extents)) <= 0.15


# --------------------------------------------------------------------------------
# convex decomposition and its cache
# --------------------------------------------------------------------------------
def test_concave_mesh_splits_into_convex_parts_and_is_cached(cache: Path):
    u = u_shape()
    first = convex_decomposition(u)
    assert first.status == "miss" and len(first.hulls) >= 3
    assert hulls_volume(first.hulls) == pytest.approx(u.volume, rel=0.02)
    assert all(trimesh.Trimesh(vertices=h).convex_hull.is_convex for h in first.hulls)
    again = convex_decomposition(u)
    assert again.status == "hit" and again.seconds == 0.0
    for a, b in zip(first.hulls, again.hulls, strict=True):
        np.testing.assert_array_equal(a, b)
    assert convex_decomposition(u, 0.5).status == "miss"  # the scale is in the key


def test_ring_splits_box_stays_one_part(cache: Path):
    ring = trimesh.creation.torus(
        major_radius=0.03, minor_radius=0.008, major_sections=16, minor_sections=8
    )
    parts = convex_decomposition(ring).hulls
    assert len(parts) >= 6
    # the hole stays open: no part covers the ring's centre
    centre = np.zeros((1, 3))
    assert not any(
        trimesh.Trimesh(vertices=h).convex_hull.contains(centre)[0] for h in parts
    )
    box = convex_decomposition(trimesh.creation.box(extents=(0.05, 0.05, 0.1)))
    assert box.status == "convex" and len(box.hulls) == 1
    assert (
        convex_decomposition(trimesh.creation.box(extents=(0.05, 0.05, 0.1))).status
        == "hit"
    )


def test_missing_coacd_says_how_to_install(
    cache: Path, monkeypatch: pytest.MonkeyPatch
):
    import sys

    monkeypatch.setitem(sys.modules, "coacd", None)
    with pytest.raises(SimulationError, match=r"pip install 'wsgrasp\[sim\]'"):
        convex_decomposition(u_shape())
    box = trimesh.creation.box(extents=(0.05, 0.05, 0.1))
    assert len(convex_decomposition(box).hulls) == 1  # convex: coacd not needed


def test_mesh_file_collides_as_its_decomposition(tmp_path: Path, cache: Path):
    u = u_shape()
    u.export(tmp_path / "u.stl")
    obj = object_from_mesh(tmp_path / "u.stl", mass=0.3)
    assert len(obj.parts) >= 3
    com, inertia = obj.inertial()
    assert np.all(np.linalg.eigvalsh(inertia) > 0)
    assert com[2] < 0.025  # the U's bar is heavier than its posts
    scene = build_scene(obj, None, SimParams())
    assert scene.model.ngeom == 1 + len(obj.parts)  # table + parts
    assert scene.model.body_mass[scene.object_body] == pytest.approx(0.3)


@pytest.mark.slow
def test_many_meshes_decompose_in_worker_processes(cache: Path):
    u = u_shape()
    srcs = [meshes.MeshSource(f"u{i}", u, np.full(3, s)) for i, s in enumerate((1, 2))]
    parallel = decompose_meshes(srcs, workers=2)
    assert [d.status for d in parallel] == ["miss", "miss"]
    serial = [convex_decomposition(u, s) for s in (1, 2)]
    assert [d.status for d in serial] == ["hit", "hit"]


# --------------------------------------------------------------------------------
# in MuJoCo
# --------------------------------------------------------------------------------
@needs_pybullet_data
def test_random_object_builds_into_a_scene_and_rests_on_the_table(cache: Path):
    (obj,) = resolve_objects(["random:000"]).objects
    assert obj.name == "random_000" and len(obj.parts) >= 3
    p = SimParams()
    scene = build_scene(obj, None, p)
    assert scene.model.ngeom == 1 + len(obj.parts)
    # the random set gives no masses of its own: density x volume of its parts
    assert not obj.mass_given
    mass = scene.model.body_mass[scene.object_body]
    assert mass == pytest.approx(p.density * obj.volume(), rel=1e-6)
    assert mass == pytest.approx(trial_mass(obj, p), rel=1e-6)
    settled = settle_object(scene, obj, np.random.default_rng(0), p)
    verts = np.asarray(obj.mesh().vertices)
    lowest = (verts @ settled.T_world_object[:3, :3].T)[:, 2].min()
    assert lowest + settled.T_world_object[2, 3] == pytest.approx(0.0, abs=3e-3)


def test_eval_reports_the_skipped_objects(
    fake_random, cache: Path, capsys: pytest.CaptureFixture
):
    from wsgrasp.cli import main

    fake_random({0: 2.0, 1: 5.0})
    rc = main(
        ["eval", "-g", "franka_hand", "--objects", "random:0-1", "-n", "1", "-j", "1"]
        + ["--no-paper", "--json"]
    )
    assert rc == 0
    report = json.loads(capsys.readouterr().out)
    assert report["objects_skipped"] == {"random_000": "under 3 cm"}
    assert "skipped 1 objects: 1 under 3 cm" in report["objects"]
    assert {r["object"] for r in report["trial_records"]} == {"random_001"}


def test_damaged_cache_entry_is_decomposed_again(cache: Path):
    u = u_shape()
    first = convex_decomposition(u)
    (entry,) = [p for p in cache.rglob("*") if p.is_file()]
    raw = bytearray(entry.read_bytes())
    if b"'shape': (" in raw:  # stored: garble an array header
        i = raw.index(b"'shape': (") + len(b"'shape': ")
        raw[i] ^= 0x01
    else:  # compressed: cut it short
        raw = raw[: len(raw) // 2]
    entry.write_bytes(bytes(raw))
    again = convex_decomposition(u)
    assert again.status == "miss"
    assert len(again.hulls) == len(first.hulls)
