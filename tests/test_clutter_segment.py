"""The ``clutter`` segmenter: touching, leaning and stacked objects split into
their instances, geometry only."""

from __future__ import annotations

import numpy as np
import pytest
from clutter_scenes import match, pile, true_labels
from wsgrasp_segmenters.clutter import Clutter, ClutterOptions

from wsgrasp.perception.process import downsample
from wsgrasp.perception.synth import synth_scene

BOX_A = ("box", (0.05, 0.05, 0.08))
BOX_TALL = ("box", (0.05, 0.06, 0.12))
CAN = ("cylinder", (0.03, 0.10))
THIN_CAN = ("cylinder", (0.025, 0.12))

#: piles of 2 to 5 boxes and cylinders that touch (base centre x, y, z; yaw deg)
PILES = {
    "boxes flush, different heights": [
        (*BOX_A, (0.0, 0.0, 0.0), 0.0),
        (*BOX_TALL, (0.05, 0.0, 0.0), 0.0),
    ],
    "boxes flush, same height, offset": [
        (*BOX_A, (0.0, 0.0, 0.0), 0.0),
        (*BOX_A, (0.05, 0.025, 0.0), 0.0),
    ],
    "two cans touching": [(*CAN, (0.0, 0.0, 0.0), 0.0), (*CAN, (0.06, 0.0, 0.0), 0.0)],
    "box against a can": [
        ("box", (0.05, 0.07, 0.09), (0.0, 0.0, 0.0), 0.0),
        (*THIN_CAN, (0.05, 0.0, 0.0), 0.0),
    ],
    "box stacked on a box": [
        ("box", (0.10, 0.10, 0.05), (0.0, 0.0, 0.0), 0.0),
        ("box", (0.05, 0.05, 0.06), (0.0, 0.0, 0.05), 20.0),
    ],
    "three in a row": [
        (*BOX_A, (0.0, 0.0, 0.0), 0.0),
        (*BOX_TALL, (0.05, 0.0, 0.0), 0.0),
        (*CAN, (0.105, 0.0, 0.0), 0.0),
    ],
    "four, flush and touching": [
        (*BOX_A, (0.0, 0.0, 0.0), 0.0),
        (*BOX_TALL, (0.05, 0.0, 0.0), 0.0),
        (*CAN, (0.0, 0.055, 0.0), 0.0),
        ("cylinder", (0.025, 0.07), (0.055, 0.06, 0.0), 0.0),
    ],
    "five in a pile": [
        (*BOX_A, (0.0, 0.0, 0.0), 0.0),
        (*BOX_TALL, (0.05, 0.0, 0.0), 0.0),
        (*CAN, (0.0, 0.055, 0.0), 0.0),
        ("cylinder", (0.025, 0.07), (0.055, 0.06, 0.0), 0.0),
        ("box", (0.06, 0.04, 0.05), (-0.055, 0.0, 0.0), 90.0),
    ],
}


def _segment(items, **options):
    scene = pile(items)
    points = downsample(scene.scene.points, 0.005)
    seg = Clutter().segment(
        points,
        ClutterOptions(**options),
        seed=0,
        viewpoints=scene.scene.viewpoints(),
    )
    return points, true_labels(points, scene.meshes), seg


@pytest.mark.parametrize("items", PILES.values(), ids=PILES.keys())
def test_touching_objects_are_split_into_their_instances(items):
    points, truth, seg = _segment(items)
    found, correct, worst = match(truth, points, seg.clusters)
    assert found == len(items)
    # share of object points in the right instance, and the worst object's IoU
    assert correct >= 0.85
    assert worst >= 0.6


def test_two_boxes_flush_along_a_whole_face_are_one_box_to_a_camera():
    items = [(*BOX_A, (0.0, 0.0, 0.0), 0.0), (*BOX_A, (0.05, 0.0, 0.0), 0.0)]
    _, _, seg = _segment(items)
    assert len(seg.clusters) == 1


@pytest.mark.parametrize("kind", ["box", "cylinder", "cone", "sphere"])
@pytest.mark.parametrize("pose", ["upright", "lying"])
def test_one_object_stays_one_instance(kind, pose):
    syn = synth_scene(kind, pose=pose, seed=1, views=4)
    points = downsample(syn.points, 0.005)
    seg = Clutter().segment(
        points,
        ClutterOptions(),
        seed=0,
        viewpoints=np.array([v.T_world_camera[:3, 3] for v in syn.views]),
    )
    assert len(seg.clusters) == 1


def test_objects_apart_are_instances_and_stray_points_are_unsegmented():
    items = [(*CAN, (0.0, 0.0, 0.0), 0.0), (*BOX_A, (0.15, 0.0, 0.0), 0.0)]
    scene = pile(items)
    stray = np.array([[0.08, 0.10, 0.05], [0.081, 0.10, 0.05]])
    points = downsample(np.concatenate([scene.scene.points, stray]), 0.005)
    seg = Clutter().segment(
        points, ClutterOptions(), seed=0, viewpoints=scene.scene.viewpoints()
    )
    assert len(seg.clusters) == 2
    unseg = seg.info["unsegmented"]
    assert np.linalg.norm(unseg - [0.08, 0.10, 0.05], axis=1).min() < 0.005


def test_without_viewpoints_a_stack_is_still_split():
    items = PILES["box stacked on a box"]
    scene = pile(items)
    points = downsample(scene.scene.points, 0.005)
    seg = Clutter().segment(points, ClutterOptions(), seed=0)
    found, correct, _ = match(true_labels(points, scene.meshes), points, seg.clusters)
    assert found == 2 and correct >= 0.85


def test_a_split_it_is_not_confident_of_is_not_made():
    # parts must be object-sized: with instances of at least 5000 points, none is
    _, _, seg = _segment(PILES["two cans touching"], min_instance_points=5000)
    assert len(seg.clusters) == 1
    assert seg.info["splits"][0]["instances"] == 1


def test_a_point_no_smooth_pair_reaches_joins_the_instance_of_its_nearest():
    from wsgrasp_segmenters.clutter import _seam_labels

    items = PILES["box stacked on a box"]
    scene = pile(items)
    points = downsample(scene.scene.points, 0.005)
    seg = Clutter().segment(points, ClutterOptions(), seed=0)
    cluster = max(seg.clusters, key=len)
    o = ClutterOptions()
    # 2 cm above the top box's highest point: farther than edge_radius from all
    top = cluster[np.argmax(seg.table.signed_distance(cluster))]
    lone = top + 0.02 * seg.table.normal
    p = np.concatenate([np.concatenate(seg.clusters), lone[None]])
    labels = _seam_labels(p, seg.table, o, scene.scene.viewpoints())
    assert labels.max() == 1  # the two boxes
    nearest = int(np.argmin(np.linalg.norm(p[:-1] - lone, axis=1)))
    assert labels[-1] == labels[nearest]
