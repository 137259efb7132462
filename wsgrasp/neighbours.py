"""Which neighbour blocks a candidate: the obstacle whose points lie inside the
gripper's body superellipsoids, or in a finger's closing path: the finger's
sweep (``wsgrasp.planning.closing``: its links' points from the pre-grasp
posture to the closed one) reaches the neighbour no later than it reaches the
target, so the neighbour stops the finger or is squeezed along with the
target. A model without finger configurations has no sweeps: its fingers'
workspace spheres stand for the paths.

Each test takes candidate poses ``(C, 4, 4)`` and obstacle clouds (one per
neighbour) and answers, per candidate, the index of the neighbour with the most
points inside, or -1. Only obstacle points within reach of a candidate are
tested: a KD-tree over the obstacles gives, per candidate, the points within the
bounding sphere of the region (body or workspace spheres) around its pose.
"""

from __future__ import annotations

from collections.abc import Callable

import numpy as np
from numpy.typing import NDArray
from scipy.spatial import cKDTree

from wsgrasp.geometry import coordinates_in_superellipsoids
from wsgrasp.gripper.model import GripperModel

__all__ = ["blocked_by_body", "blocked_in_closing"]

Array = NDArray[np.float64]

#: the first pass tests every this-many-th obstacle point
_COARSE = 4
#: point-sphere pairs tested at once (memory bound: pairs x spheres floats)
_CHUNK = 200_000


def blocked_in_closing(
    g: GripperModel,
    T_world_gripper: Array,
    obstacles: list[Array],
    object_points: Array | None = None,
) -> NDArray[np.int64]:
    """Per candidate ``(C,)``: the index into ``obstacles`` of the neighbour with
    the most points in a finger's closing path at pose ``T_world_gripper``
    ``(C, 4, 4)``, or -1 where none has any.

    With the target's ``object_points`` ``(n, 3)`` (world) and a model whose
    fingers have configurations, a point is in finger ``f``'s path when the
    finger's sweep reaches it (the reach grid of
    ``wsgrasp.planning.closing``) at a posture no later than the first at which
    it reaches a target point (a finger whose sweep never meets the target is
    not judged); otherwise, when it lies strictly inside one of the fingers'
    workspace spheres."""
    if (
        object_points is not None
        and g.num_fingers
        and (g.has_sweeps or g.has_configurations)
    ):
        return _blocked_in_sweeps(g, T_world_gripper, obstacles, object_points)
    centers = np.asarray(g.sphere_centers, dtype=np.float64)  # (S, 3)
    radii = np.asarray(g.sphere_radii, dtype=np.float64)  # (S,)
    if not len(centers):
        return np.full(len(T_world_gripper), -1, dtype=np.int64)
    mid = centers.mean(axis=0)
    reach = float((np.linalg.norm(centers - mid, axis=1) + radii).max())

    lo = (centers - radii[:, None]).min(axis=0)  # (3,) the spheres' box
    hi = (centers + radii[:, None]).max(axis=0)
    r2 = radii * radii
    step = max(1, _CHUNK // len(centers))

    def inside(p: Array, cand: NDArray[np.int64]) -> NDArray[np.bool_]:
        out = np.zeros(len(p), dtype=bool)
        box = np.flatnonzero(((p > lo) & (p < hi)).all(axis=1))  # most are not
        for s in range(0, len(box), step):
            rows = box[s : s + step]
            # (m, S) squared distances of these points to every sphere's centre
            d2 = ((p[rows, None, :] - centers[None, :, :]) ** 2).sum(axis=2)
            out[rows] = (d2 < r2).any(axis=1)
        return out

    # most candidates are clear: one pass with every point
    return _blocked_all(T_world_gripper, obstacles, mid, reach, inside)


def blocked_by_body(
    g: GripperModel, T_world_gripper: Array, obstacles: list[Array]
) -> NDArray[np.int64]:
    """Per candidate ``(C,)``: the index into ``obstacles`` of the neighbour with
    the most points strictly inside the gripper's body superellipsoids at pose
    ``T_world_gripper`` ``(C, 4, 4)``, or -1 where none has any."""
    c = np.asarray(g.se_centers, dtype=np.float64)  # (ne, 3)
    ax = np.asarray(g.se_semi_axes, dtype=np.float64)  # (ne, 3)
    if not len(c):
        return np.full(len(T_world_gripper), -1, dtype=np.int64)
    mid = c.mean(axis=0)
    reach = float((np.linalg.norm(c - mid, axis=1) + np.linalg.norm(ax, axis=1)).max())

    def inside(p: Array, cand: NDArray[np.int64]) -> NDArray[np.bool_]:
        return coordinates_in_superellipsoids(  # type: ignore[no-any-return]
            p[:, 0], p[:, 1], p[:, 2], c, ax, g.se_exponent
        )

    return _blocked(T_world_gripper, obstacles, mid, reach, inside)


def _blocked(
    T_world_gripper: Array,
    obstacles: list[Array],
    mid_gripper: Array,
    reach: float,
    inside: Callable[[Array, NDArray[np.int64]], NDArray[np.bool_]],
) -> NDArray[np.int64]:
    """:func:`_blocked_all`, first with every :data:`_COARSE`-th obstacle point
    (most blocked candidates have many points inside), then with all of them
    for the candidates that pass left unnamed."""
    coarse = [np.asarray(o).reshape(-1, 3)[::_COARSE] for o in obstacles]
    who = _blocked_all(T_world_gripper, coarse, mid_gripper, reach, inside)
    rest = np.flatnonzero(who < 0)
    if len(rest):
        T = np.asarray(T_world_gripper, dtype=np.float64).reshape(-1, 4, 4)
        who[rest] = _blocked_all(T[rest], obstacles, mid_gripper, reach, inside)
    return who


def _blocked_all(
    T_world_gripper: Array,
    obstacles: list[Array],
    mid_gripper: Array,
    reach: float,
    inside: Callable[[Array, NDArray[np.int64]], NDArray[np.bool_]],
) -> NDArray[np.int64]:
    """The neighbour with the most points for which ``inside`` (gripper-frame
    points ``(m, 3)`` and the candidate of each ``(m,)`` -> ``(m,)`` bool)
    holds, per pose; only the points within ``reach`` of ``mid_gripper``
    (gripper frame) are tested."""
    T = np.asarray(T_world_gripper, dtype=np.float64).reshape(-1, 4, 4)
    C = len(T)
    none = np.full(C, -1, dtype=np.int64)
    clouds = [np.asarray(o, dtype=np.float64).reshape(-1, 3) for o in obstacles]
    if not C or not clouds or not sum(len(o) for o in clouds):
        return none
    points = np.concatenate(clouds)  # (K, 3)
    owner = np.concatenate([np.full(len(o), i) for i, o in enumerate(clouds)])
    centres = T[:, :3, :3] @ mid_gripper + T[:, :3, 3]  # (C, 3) world
    near = cKDTree(points).query_ball_point(centres, reach, return_sorted=False)
    counts = np.fromiter((len(n) for n in near), dtype=np.int64, count=C)
    if not counts.sum():
        return none
    cand = np.repeat(np.arange(C), counts)  # (P,) candidate of each pair
    idx = np.concatenate([np.asarray(n, dtype=np.int64) for n in near if len(n)])
    # (P, 3) each pair's point in its candidate's gripper frame: R^T (p - t),
    # one candidate's run of pairs at a time
    p_g = np.empty((len(idx), 3))
    end = np.cumsum(counts)
    for c in np.flatnonzero(counts):
        s, e = end[c] - counts[c], end[c]
        np.matmul(points[idx[s:e]] - T[c, :3, 3], T[c, :3, :3], out=p_g[s:e])
    hit = inside(p_g, cand)
    if not hit.any():
        return none
    tally = np.zeros((C, len(clouds)), dtype=np.int64)
    np.add.at(tally, (cand[hit], owner[idx[hit]]), 1)
    return np.where(tally.max(axis=1) > 0, tally.argmax(axis=1), -1)  # type: ignore[no-any-return]


def _blocked_in_sweeps(
    g: GripperModel,
    T_world_gripper: Array,
    obstacles: list[Array],
    object_points: Array,
) -> NDArray[np.int64]:
    """:func:`blocked_in_closing` by the fingers' sweeps (see there)."""
    from wsgrasp.planning.closing import REACH_VOXEL, finger_sweep, reach_steps

    sweep = finger_sweep(g)  # (nf, K, P, 3) gripper frame
    K = sweep.shape[1]
    sweep = sweep.reshape(-1, 3)
    T = np.asarray(T_world_gripper, dtype=np.float64).reshape(-1, 4, 4)
    mid = sweep.mean(axis=0)
    reach = float(np.linalg.norm(sweep - mid, axis=1).max()) + 4 * REACH_VOXEL
    pts = np.asarray(object_points, dtype=np.float64).reshape(-1, 3)
    # (C, nf) the first posture at which each finger reaches the target
    first = np.full((len(T), g.num_fingers), K, dtype=np.int64)
    step = max(1, _CHUNK // max(len(pts), 1))
    for a in range(0, len(T), step):
        Tc = T[a : a + step]
        # (c, n, 3) the target's points in each candidate's gripper frame
        p_g = np.matmul(pts[None] - Tc[:, None, :3, 3], Tc[:, :3, :3])
        steps = reach_steps(g, p_g.reshape(-1, 3))
        first[a : a + step] = steps.reshape(len(Tc), len(pts), -1).min(axis=1)

    def inside(p: Array, cand: NDArray[np.int64]) -> NDArray[np.bool_]:
        hit = np.zeros(len(p), dtype=bool)
        for f in range(g.num_fingers):
            limit = first[cand, f]  # (m,)
            # a finger whose sweep never meets the target (it closes to its own
            # contact, off this straight path) is not judged, nor a point
            # another finger reaches first
            todo = np.flatnonzero((limit < K) & ~hit)
            if len(todo):
                hit[todo] = reach_steps(g, p[todo], finger=f)[:, 0] <= limit[todo]
        return hit

    return _blocked_all(T, obstacles, mid, reach, inside)
