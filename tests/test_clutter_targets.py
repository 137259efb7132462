"""Targets in a pile: the rules that pick one instance, the others as obstacles
that the gripper's body and the fingers' closing paths must keep clear of, and
the neighbour named where it blocked candidates."""

from __future__ import annotations

import numpy as np
import pytest
from clutter_scenes import pile
from pydantic import ValidationError

import wsgrasp
from wsgrasp.errors import InputError
from wsgrasp.neighbours import blocked_by_body, blocked_in_closing
from wsgrasp.perception.process import select_target
from wsgrasp.perception.types import Plane, Segmentation
from wsgrasp.spec import TargetRule, load_spec

TABLE = Plane(normal=np.array([0.0, 0.0, 1.0]), offset=0.0)


def _blob(center, n=50, seed=0):
    rng = np.random.default_rng(seed)
    return np.asarray(center) + rng.uniform(-0.01, 0.01, (n, 3))


def _segmentation(unsegmented=None):
    clusters = [
        _blob([0.0, 0.0, 0.05], 300),  # largest
        _blob([0.02, 0.0, 0.15], 100),  # on top of it
        _blob([0.30, 0.0, 0.03], 80),  # far from the others
    ]
    info = {} if unsegmented is None else {"unsegmented": unsegmented}
    return Segmentation(TABLE, np.zeros((0, 3)), clusters, info)


@pytest.mark.parametrize(
    ("rule", "expected"),
    [
        ({"rule": "largest"}, 0),
        ({"rule": "highest"}, 1),
        ({"rule": "most_isolated"}, 2),
        ({"rule": "id", "id": 1}, 1),
        ({"rule": "nearest", "point": [0.3, 0.0, 0.0]}, 2),
    ],
    ids=["largest", "highest", "most_isolated", "id", "nearest"],
)
def test_a_pile_rule_picks_its_instance_and_the_rest_are_obstacles(rule, expected):
    seg = _segmentation()
    target, obstacles = select_target(seg, TargetRule(**rule))
    assert target is seg.clusters[expected]
    assert len(obstacles) == 2
    assert all(o is not target for o in obstacles)


def test_unsegmented_points_are_obstacles_and_count_against_isolation():
    # stray points beside the far instance make the top one the most isolated
    stray = _blob([0.30, 0.03, 0.03], 10, seed=1)
    seg = _segmentation(unsegmented=stray)
    target, obstacles = select_target(seg, TargetRule(rule="most_isolated"))
    assert target is not seg.clusters[2]
    assert any(o is stray for o in obstacles)


def test_an_id_no_instance_has_is_refused_with_the_ids_there_are():
    with pytest.raises(InputError, match=r"target id 7 names no instance.*0 to 2"):
        select_target(_segmentation(), TargetRule(rule="id", id=7))


def test_rule_id_needs_an_id():
    with pytest.raises(ValidationError, match="needs target.id"):
        TargetRule(rule="id")


@pytest.fixture(scope="module")
def franka():
    from wsgrasp.gripper import load_gripper

    return load_gripper("franka_hand")


def test_a_neighbour_in_the_closing_path_is_found_and_one_beside_it_is_not(franka):
    g = franka
    T = np.eye(4)
    # a point inside finger 0's first workspace sphere, and one far away
    inside = g.sphere_centers[0]
    far = g.sphere_centers[0] + np.array([0.0, 0.0, 0.5])
    assert blocked_in_closing(g, T[None], [far[None], inside[None]]).tolist() == [1]
    assert blocked_in_closing(g, T[None], [far[None]]).tolist() == [-1]
    # moved with the pose: the same point, the gripper shifted 0.2 m away
    T_away = np.eye(4)
    T_away[0, 3] = 0.2
    assert blocked_in_closing(g, T_away[None], [inside[None]]).tolist() == [-1]
    # inside a body superellipsoid, at its centre
    body = g.se_centers[0]
    assert blocked_by_body(g, np.stack([T, T_away]), [body[None]]).tolist() == [0, -1]


def _franka(rule, **target):
    spec = load_spec("examples/specs/franka_followup.yaml")
    spec = spec.model_copy(
        update={
            "segmenter": spec.segmenter.model_copy(
                update={"name": "clutter", "options": {}}
            ),
            "target": TargetRule(rule=rule, **target),
        }
    )
    return wsgrasp.Pipeline(spec)


def test_walls_on_both_sides_block_by_name_and_the_grasp_closes_between_them():
    # a box between two walls 1.5 cm away along x: the fingers must not close
    # along x
    items = [
        ("box", (0.03, 0.05, 0.12), (0.0, 0.0, 0.0), 0.0),
        ("box", (0.01, 0.12, 0.12), (0.035, 0.0, 0.0), 0.0),
        ("box", (0.01, 0.12, 0.12), (-0.035, 0.0, 0.0), 0.0),
    ]
    pipeline = _franka("nearest", point=(0.0, 0.0, 0.12))
    scene = pile(items).scene
    result = pipeline.plan(scene)
    assert result.found
    segments = result.info["segments"]
    target = next(s for s in segments if s["target"])
    assert abs(target["centroid"][0]) < 0.005
    walls = {f"object {s['id']}" for s in segments if not s["target"]}
    assert set(result.info["blocked_by"]) == walls
    # the fingers do not close towards the walls (along x); seen edge-on from
    # one camera, a wall's outer face is dropped with the flying pixels, and the
    # choice may then tilt its approach: it still clears every wall point
    closing = result.T_world_ee[:3, :3] @ pipeline.gripper.closing_axis
    assert abs(closing[0]) < 0.25
    points = scene.points
    wall_points = [
        points[(np.abs(points[:, 0] - x) < 0.0051) & (points[:, 2] > 0.003)]
        for x in (0.035, -0.035)
    ]
    T = result.T_world_ee[None]
    assert blocked_in_closing(pipeline.gripper, T, wall_points).tolist() == [-1]
    assert blocked_by_body(pipeline.gripper, T, wall_points).tolist() == [-1]


def test_no_grasp_between_walls_names_them_in_the_hint():
    items = [
        ("box", (0.03, 0.05, 0.12), (0.0, 0.0, 0.0), 0.0),
        ("box", (0.01, 0.12, 0.12), (0.035, 0.0, 0.0), 0.0),
        ("box", (0.01, 0.12, 0.12), (-0.035, 0.0, 0.0), 0.0),
    ]
    spec = load_spec("examples/specs/franka.yaml")  # side grasps only
    spec = spec.model_copy(
        update={
            "segmenter": spec.segmenter.model_copy(update={"name": "clutter"}),
            "target": TargetRule(rule="nearest", point=(0.0, 0.0, 0.12)),
        }
    )
    result = wsgrasp.Pipeline(spec).plan(pile(items).scene)
    assert not result.found
    assert "candidates blocked by neighbours: object" in result.hint
    assert "by the gripper's body" in result.hint


def test_an_unconfident_split_keeps_the_refusal_and_its_hint():
    items = [
        ("cylinder", (0.03, 0.10), (0.0, 0.0, 0.0), 0.0),
        ("cylinder", (0.03, 0.10), (0.06, 0.0, 0.0), 0.0),
    ]
    spec = load_spec("examples/specs/franka.yaml")
    spec = spec.model_copy(
        update={
            "segmenter": spec.segmenter.model_copy(
                update={
                    "name": "clutter",
                    "options": {"min_instance_points": 5000, "max_waist_splits": 0},
                }
            )
        }
    )
    with pytest.raises(InputError, match="two objects that touch") as info:
        wsgrasp.Pipeline(spec).plan(pile(items).scene)
    assert "target: {rule: nearest, point: [" in str(info.value)


def test_a_plan_lists_the_instances_and_an_id_from_it_names_the_same_object():
    items = [
        ("box", (0.10, 0.10, 0.05), (0.0, 0.0, 0.0), 0.0),
        ("box", (0.05, 0.05, 0.06), (0.0, 0.0, 0.05), 20.0),
        ("cylinder", (0.03, 0.10), (0.2, 0.0, 0.0), 0.0),
    ]
    scene = pile(items).scene
    first = _franka("highest").plan(scene)
    top = next(s for s in first.info["segments"] if s["target"])
    assert top["top"] == pytest.approx(0.11, abs=0.01)  # the stacked box
    other = next(s for s in first.info["segments"] if not s["target"])
    again = _franka("id", id=other["id"]).plan(scene)
    chosen = next(s for s in again.info["segments"] if s["target"])
    assert chosen["centroid"] == other["centroid"]


def test_walls_in_the_fingers_closing_paths_reject_candidates_by_name():
    # walls 8 mm from a box: outside the fingers' bodies when they straddle the
    # box, inside the space they sweep as they close
    items = [
        ("box", (0.03, 0.05, 0.12), (0.0, 0.0, 0.0), 0.0),
        ("box", (0.01, 0.12, 0.12), (0.028, 0.0, 0.0), 0.0),
        ("box", (0.01, 0.12, 0.12), (-0.028, 0.0, 0.0), 0.0),
    ]
    pipeline = _franka("nearest", point=(0.0, 0.0, 0.12))
    scene = pile(items).scene
    result = pipeline.plan(scene)
    closing = {n: v["closing"] for n, v in result.info["blocked_by"].items()}
    assert sum(closing.values()) > 0
    assert all(n.startswith("object ") for n, v in closing.items() if v)
    assert result.found
    # the choice has nothing of its neighbours where its fingers close
    obstacles = pipeline.prepare(scene).obstacles
    T = result.T_world_ee[None]
    assert blocked_in_closing(pipeline.gripper, T, obstacles).tolist() == [-1]
    axis = result.T_world_ee[:3, :3] @ pipeline.gripper.closing_axis
    assert abs(axis[1]) > 0.9  # it closes along the walls, not through them


def test_a_neighbour_the_finger_sweeps_before_the_target_blocks_it(franka):
    from wsgrasp.planning.closing import closing_paths

    g = franka
    paths = closing_paths(g)  # (nf, K, 3) pad centres, pre-grasp to closed
    K = paths.shape[1]
    # the target between the pads where they close; a neighbour on finger 0's
    # way there, and one behind where finger 0 starts
    target = paths[:, -1].mean(axis=0)[None]
    on_the_way = paths[0, K // 4][None]
    behind = (paths[0, 0] + 3.0 * (paths[0, 0] - target[0]))[None]
    T = np.eye(4)[None]
    assert blocked_in_closing(g, T, [behind, on_the_way], target).tolist() == [1]
    assert blocked_in_closing(g, T, [behind], target).tolist() == [-1]


def _grouped(groups):
    seg = _segmentation(unsegmented=_blob([0.5, 0.0, 0.02], 10, seed=3))
    seg.info["groups"] = groups
    return seg


def test_rule_cluster_plans_the_instances_split_from_one_cluster_as_one_object():
    seg = _grouped([0, 0, 1])  # instances 0 and 1 were split from one cluster
    target, obstacles = select_target(seg, TargetRule(rule="cluster", id=1))
    assert np.array_equal(target, np.concatenate(seg.clusters[:2]))
    assert [len(o) for o in obstacles] == [80, 10]  # instance 2, unsegmented
    target, obstacles = select_target(seg, TargetRule(rule="cluster", id=2))
    assert target is seg.clusters[2]
    assert len(obstacles) == 3


def test_rule_cluster_without_groups_is_the_instance_alone():
    seg = _segmentation()  # a segmenter that splits nothing
    target, obstacles = select_target(seg, TargetRule(rule="cluster", id=0))
    assert np.array_equal(target, seg.clusters[0])
    assert len(obstacles) == 2
    with pytest.raises(ValidationError, match="'cluster' needs target.id"):
        TargetRule(rule="cluster")


def test_a_stack_planned_as_one_cluster_lists_both_instances_as_the_target():
    items = [
        ("box", (0.06, 0.06, 0.05), (0.0, 0.0, 0.0), 0.0),
        ("box", (0.04, 0.04, 0.04), (0.0, 0.0, 0.05), 20.0),
        ("cylinder", (0.03, 0.06), (0.2, 0.0, 0.0), 0.0),
    ]
    scene = pile(items).scene
    first = _franka("highest").plan(scene)  # the box on top
    segs = first.info["segments"]
    top = next(s for s in segs if s["target"])
    stack = [s["id"] for s in segs if s["cluster"] == top["cluster"]]
    assert len(stack) == 2 and len(segs) == 3
    whole = _franka("cluster", id=top["id"]).plan(scene)  # not refused as two
    assert [s["id"] for s in whole.info["segments"] if s["target"]] == stack
    assert whole.info["object_points"] > first.info["object_points"]


def test_a_no_grasp_hint_names_the_rule_where_its_own_cluster_blocked_it():
    from types import SimpleNamespace

    from wsgrasp.api import _siblings

    segs = [
        {"id": 0, "cluster": 0, "target": False},
        {"id": 1, "cluster": 0, "target": True},
        {"id": 2, "cluster": 1, "target": False},
    ]
    blocked = {"object 0": {"body": 5, "closing": 0}}
    hint = _siblings(SimpleNamespace(segments=segs, blocked_by=blocked))
    assert "object 0 and the target were split from one cluster" in hint
    assert "`target: {rule: cluster, id: 1}`" in hint
    other = {"object 2": {"body": 5, "closing": 0}}
    assert _siblings(SimpleNamespace(segments=segs, blocked_by=other)) == ""


def test_a_clutter_step_tries_the_other_instances_then_each_split_cluster():
    from wsgrasp.sim.clutter import _other_targets

    segs = [
        {"id": 0, "cluster": 0, "top": 0.05, "target": True},
        {"id": 1, "cluster": 0, "top": 0.09, "target": False},
        {"id": 2, "cluster": 1, "top": 0.12, "target": False},
    ]
    order = [(t.rule, t.id) for t in _other_targets(segs)]
    assert order == [("id", 2), ("id", 1), ("cluster", 1)]


def _walls(height=0.10, half=(0.15, 0.11), n=2000, seed=0):
    """A bin's four walls (no floor: it lies within min_height of the table)."""
    rng = np.random.default_rng(seed)
    t = rng.uniform(-1.0, 1.0, n)
    side = rng.integers(0, 4, n)
    x = np.where(side < 2, t * half[0], np.where(side == 2, half[0], -half[0]))
    y = np.where(side >= 2, t * half[1], np.where(side == 0, half[1], -half[1]))
    return np.column_stack([x, y, rng.uniform(0.01, height, n)])


def _box(center, size, n=400, seed=1):
    rng = np.random.default_rng(seed)
    return np.asarray(center) + rng.uniform(-0.5, 0.5, (n, 3)) * size


@pytest.mark.parametrize("rule", ["largest", "highest", "most_isolated"])
def test_a_bins_walls_are_no_target_while_something_lies_in_it(rule):
    """A bin's walls (the largest cluster) surround the box in it, whose bottom
    lies below their top: the automatic rules pick the box, and the walls are an
    obstacle; an object stacked on a wider one, or standing beside it, leaves
    the rules as they were."""
    from wsgrasp.perception.pile import containers

    walls = _walls()
    box = _box([0.05, 0.0, 0.06], [0.05, 0.05, 0.09])
    seg = Segmentation(TABLE, np.zeros((0, 3)), [walls, box], {})
    assert containers(seg).tolist() == [True, False]
    target, obstacles = select_target(seg, TargetRule(rule=rule))
    assert target is box and obstacles[0] is walls
    # stacked: the small box's bottom at the big one's top
    big = _box([0.0, 0.0, 0.05], [0.2, 0.2, 0.1], n=2000)
    on_top = _box([0.0, 0.0, 0.13], [0.05, 0.05, 0.06])
    seg = Segmentation(TABLE, np.zeros((0, 3)), [big, on_top], {})
    assert not containers(seg).any()
    beside = _box([0.2, 0.0, 0.05], [0.05, 0.05, 0.1])
    seg = Segmentation(TABLE, np.zeros((0, 3)), [big, beside], {})
    assert not containers(seg).any()
    assert select_target(seg, TargetRule(rule="largest"))[0] is big


def test_a_box_in_a_bin_is_grasped_not_the_bin(tmp_path):
    """Rendered: a 5 x 5 x 10 cm box in a 30 x 22 x 10 cm bin. The target was
    the bin's walls ("0.227 m across ... more than the gripper opens"); the
    Allegro hand's default spec now grasps the box, and the Franka hand's with
    approaches from above."""
    import trimesh

    from wsgrasp.default_specs import default_spec
    from wsgrasp.perception.synth import synth_scene

    def slab(extents, centre):
        m = trimesh.creation.box(extents)
        m.apply_translation(centre)
        return m

    t, length, width, height = 0.005, 0.30, 0.22, 0.10
    parts = [
        slab((length, width, t), (0, 0, t / 2)),
        slab((length, t, height), (0, width / 2, height / 2)),
        slab((length, t, height), (0, -width / 2, height / 2)),
        slab((t, width, height), (length / 2, 0, height / 2)),
        slab((t, width, height), (-length / 2, 0, height / 2)),
        slab((0.05, 0.05, 0.10), (0.05, 0.0, t + 0.05)),
    ]
    trimesh.util.concatenate(parts).export(tmp_path / "bin.obj")
    syn = synth_scene(str(tmp_path / "bin.obj"), seed=1)
    box = syn.T_world_mesh[:3, :3] @ [0.05, 0.0, t + 0.05] + syn.T_world_mesh[:3, 3]
    up = syn.table.normal

    def across(a, b):  # their distance seen from above
        d = np.asarray(a) - b
        return float(np.linalg.norm(d - (d @ up) * up))

    pipe = wsgrasp.Pipeline(load_spec(default_spec("allegro_right")[0]))
    prep = pipe.prepare(wsgrasp.api.as_scene(syn.points))
    assert across(prep.search_input.object_points.mean(axis=0), box) < 0.01
    result = pipe.plan(syn.points)
    assert result.found, result.hint
    assert across(result.T_world_tcp[:3, 3], box) < 0.02
    # the Franka hand's default comes from the side only, which the walls block:
    # the hint says so, and approaching from above grasps the box
    data = default_spec("franka_hand")[0]
    side = wsgrasp.Pipeline(load_spec(data)).plan(syn.points)
    assert not side.found
    assert "blocked by neighbours: object" in side.hint
    assert "sampling.mode approach_sphere also approaches from above" in side.hint
    data["sampling"] = {"mode": "approach_sphere", "directions": 8, "orientations": 4}
    above = wsgrasp.Pipeline(load_spec(data)).plan(syn.points)
    assert above.found, above.hint
    assert across(above.T_world_tcp[:3, 3], box) < 0.02
