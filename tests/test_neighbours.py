"""The neighbour tests' shortcuts give the verdicts of the plain tests: pairs
within reach measured one by one or found by a KD-tree, and a finger's reach
looked up only in the box around its grid."""

from __future__ import annotations

import numpy as np
import pytest

import wsgrasp.neighbours as nb
from wsgrasp.gripper import load_gripper
from wsgrasp.planning.closing import finger_sweep
from wsgrasp.planning.sweeps import reach_boxes, reach_steps


@pytest.fixture(scope="module", params=["franka_hand", "allegro_right"])
def gripper(request):
    return load_gripper(request.param)


def _poses(rng, n):
    """``n`` poses ``(n, 4, 4)`` turned and shifted a little about the origin."""
    from scipy.spatial.transform import Rotation

    T = np.tile(np.eye(4), (n, 1, 1))
    T[:, :3, :3] = Rotation.from_rotvec(rng.normal(scale=0.4, size=(n, 3))).as_matrix()
    T[:, :3, 3] = rng.normal(scale=0.03, size=(n, 3))
    return T


def _scene(g, rng):
    """Obstacle clouds spread over the fingers' sweep and around it, and a
    target between the fingers, gripper frame."""
    sweep = finger_sweep(g).reshape(-1, 3)
    lo, hi = sweep.min(axis=0) - 0.05, sweep.max(axis=0) + 0.05
    obstacles = [rng.uniform(lo, hi, size=(n, 3)) for n in (150, 90, 200)]
    target = sweep.mean(axis=0) + rng.normal(scale=0.01, size=(60, 3))
    return obstacles, target


@pytest.mark.parametrize("dense", [True, False])
def test_either_way_to_the_pairs_within_reach_gives_the_same_verdicts(
    gripper, dense, monkeypatch
):
    rng = np.random.default_rng(3)
    T = _poses(rng, 40)
    obstacles, target = _scene(gripper, rng)
    want = (
        nb.blocked_in_closing(gripper, T, obstacles, target),
        nb.blocked_in_closing(gripper, T, obstacles),
        nb.blocked_by_body(gripper, T, obstacles),
    )
    monkeypatch.setattr(nb, "_mostly_near", lambda *a: dense)
    got = (
        nb.blocked_in_closing(gripper, T, obstacles, target),
        nb.blocked_in_closing(gripper, T, obstacles),
        nb.blocked_by_body(gripper, T, obstacles),
    )
    for w, v in zip(want, got, strict=True):
        assert v.tolist() == w.tolist()
    # some candidates blocked and some clear, by more than one neighbour
    assert 0 < (want[0] >= 0).sum() < len(T)
    assert len(set(want[0][want[0] >= 0].tolist())) > 1


def test_the_pairs_within_reach_are_the_same_either_way(gripper):
    rng = np.random.default_rng(4)
    T = _poses(rng, 30)
    obstacles, _ = _scene(gripper, rng)
    points = np.concatenate(obstacles)
    mid = finger_sweep(gripper).reshape(-1, 3).mean(axis=0)
    for reach in (0.03, 0.08, 0.3):
        c0, i0, p0 = nb._near_dense(T, points, mid, reach)
        c1, i1, p1 = nb._near_tree(T, points, mid, reach)
        order = np.lexsort((i1, c1))  # the tree's points come unsorted
        assert c0.tolist() == c1[order].tolist()
        assert i0.tolist() == i1[order].tolist()
        np.testing.assert_array_equal(p0, p1[order])


def test_a_point_outside_a_fingers_box_is_never_reached_by_it(gripper):
    rng = np.random.default_rng(5)
    sweep = finger_sweep(gripper).reshape(-1, 3)
    K = finger_sweep(gripper).shape[1]
    lo, hi = reach_boxes(gripper)
    p = rng.uniform(sweep.min(axis=0) - 0.05, sweep.max(axis=0) + 0.05, (200_000, 3))
    for f in range(gripper.num_fingers):
        steps = reach_steps(gripper, p, finger=f)[:, 0]
        inside = nb._in_box(p.T, lo[f], hi[f])
        assert (steps < K).any() and (~inside).any()
        assert (steps[~inside] == K).all()


@pytest.mark.parametrize("compiled", [False, True], ids=["plain loop", "compiled"])
def test_the_one_pass_closing_test_answers_as_the_per_finger_passes(
    gripper, compiled, monkeypatch
):
    from types import SimpleNamespace

    rng = np.random.default_rng(7)
    obstacles, target = _scene(gripper, rng)
    T = _poses(rng, 40)
    monkeypatch.setattr(nb, "_compiled", SimpleNamespace(loaded=lambda: False))
    want = nb.blocked_in_closing(gripper, T, obstacles, target)
    assert (want >= 0).any() and (want < 0).any()  # some blocked, some clear
    monkeypatch.setattr(nb, "_compiled", SimpleNamespace(loaded=lambda: True))
    if not compiled:  # the loop as written, run by Python
        monkeypatch.setattr(nb, "_compiled_sweep_loop", lambda: nb._sweep_loop)
    got = nb.blocked_in_closing(gripper, T, obstacles, target)
    assert got.tolist() == want.tolist()
