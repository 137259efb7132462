"""Which neighbour blocks a candidate: the obstacle whose points lie inside the
gripper's body superellipsoids, or in a finger's closing path: the finger's
sweep (``wsgrasp.planning.sweeps``: its links' points from the pre-grasp
posture to the closed one) reaches the neighbour no later than it reaches the
target, so the neighbour stops the finger or is squeezed along with the
target. A model without finger configurations has no sweeps: its fingers'
workspace spheres stand for the paths.

Each test takes candidate poses ``(C, 4, 4)`` and obstacle clouds (one per
neighbour) and answers, per candidate, the index of the neighbour with the most
points inside, or -1. Only obstacle points within reach of a candidate are
tested: those within the bounding sphere of the region (body, workspace spheres
or sweeps) around its pose, found by measuring every (candidate, point) pair
where there are few enough of them, else by a KD-tree over the obstacles; a
finger's sweep looks up only the points in the box around its reach grid.
"""

from __future__ import annotations

from collections.abc import Callable

import numpy as np
from numpy.typing import NDArray
from scipy.spatial import cKDTree

from wsgrasp.geometry import coordinates_in_superellipsoids
from wsgrasp.gripper.model import GripperModel
from wsgrasp.planning import _compiled

__all__ = ["blocked_by_body", "blocked_in_closing"]

Array = NDArray[np.float64]

#: the first pass tests every this-many-th obstacle point
_COARSE = 4
#: point-sphere pairs tested at once (memory bound: pairs x spheres floats)
_CHUNK = 200_000
#: candidate-point pairs up to which every pair is measured (:func:`_near_dense`)
#: without a sample first: on clutter plans' calls up to 5,000 pairs it beat the
#: KD-tree even with 6 % of the pairs within reach
_DENSE = 10_000
#: the share of pairs within reach from which every pair is measured rather
#: than a KD-tree asked for those within reach (:func:`_near_tree`): on clutter
#: plans' calls it was slower at 12 % and 16 %, faster from 27 % up
_DENSE_SHARE = 0.25
#: candidates and points in the sample that estimates that share
_SAMPLE = (16, 512)


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
    ``wsgrasp.planning.sweeps``) at a posture no later than the first at which
    it reaches a target point; otherwise, when it lies strictly inside one of
    the fingers' workspace spheres.

    A finger whose sweep never meets the target is not judged. With ``close_to:
    contacts`` it closes to a contact posture off this straight path; with
    ``close_to: closed`` it sweeps on to its ``closed`` posture, and may meet a
    neighbour there, around the target the other fingers hold. Rejecting those
    candidates too was tried on the Allegro hand's development piles and packed
    rows (``random:000-299``, strict): the gripper touched neighbours in fewer
    attempts, no more grasps held, and fewer objects were removed."""
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
    if _mostly_near(T, points, mid_gripper, reach):
        cand, idx, p_g = _near_dense(T, points, mid_gripper, reach)
    else:
        cand, idx, p_g = _near_tree(T, points, mid_gripper, reach)
    if not len(cand):
        return none
    hit = inside(p_g, cand)
    if not hit.any():
        return none
    tally = np.zeros((C, len(clouds)), dtype=np.int64)
    np.add.at(tally, (cand[hit], owner[idx[hit]]), 1)
    return np.where(tally.max(axis=1) > 0, tally.argmax(axis=1), -1)  # type: ignore[no-any-return]


def _mostly_near(T: Array, points: Array, mid_gripper: Array, reach: float) -> bool:
    """Whether :func:`_near_dense` is the way to the pairs within ``reach``: for
    few pairs, or where a sample of candidates and points has at least
    :data:`_DENSE_SHARE` of its pairs within reach."""
    C, K = len(T), len(points)
    if C * K <= _DENSE:
        return True
    Ts = T[:: -(-C // _SAMPLE[0])]
    ps = points[:: -(-K // _SAMPLE[1])]
    centres = Ts[:, :3, :3] @ mid_gripper + Ts[:, :3, 3]  # (c, 3) world
    d = centres[:, None, :] - ps[None, :, :]  # (c, k, 3)
    share = float((np.einsum("ckx,ckx->ck", d, d) <= reach * reach).mean())
    return share >= _DENSE_SHARE


def _near_dense(
    T: Array, points: Array, mid_gripper: Array, reach: float
) -> tuple[NDArray[np.int64], NDArray[np.int64], Array]:
    """The (candidate, point) pairs of poses ``T`` ``(C, 4, 4)`` and world
    ``points`` ``(K, 3)`` with the point within ``reach`` of ``mid_gripper``,
    by candidate: each pair's candidate ``(P,)``, point ``(P,)`` and the point
    in the candidate's gripper frame ``(P, 3)``. Every pair is transformed and
    measured, a block of candidates at a time."""
    K = len(points)
    r2 = reach * reach
    step = max(1, _CHUNK // K)
    cand, idx, p_g = [], [], []
    for a in range(0, len(T), step):
        Tc = T[a : a + step]
        # (c, K, 3) the points in each candidate's gripper frame: R^T (p - t)
        p = np.matmul(points[None] - Tc[:, None, :3, 3], Tc[:, :3, :3])
        d = p - mid_gripper
        within = np.einsum("ckx,ckx->ck", d, d) <= r2
        c, i = np.nonzero(within)
        cand.append(c + a)
        idx.append(i)
        p_g.append(p.reshape(-1, 3) if within.all() else p[c, i])
    return np.concatenate(cand), np.concatenate(idx), np.concatenate(p_g)


def _near_tree(
    T: Array, points: Array, mid_gripper: Array, reach: float
) -> tuple[NDArray[np.int64], NDArray[np.int64], Array]:
    """:func:`_near_dense` by a KD-tree's ball queries: only the pairs within
    reach are transformed."""
    C = len(T)
    centres = T[:, :3, :3] @ mid_gripper + T[:, :3, 3]  # (C, 3) world
    near = cKDTree(points).query_ball_point(centres, reach, return_sorted=False)
    counts = np.fromiter((len(n) for n in near), dtype=np.int64, count=C)
    if not counts.sum():
        empty = np.zeros(0, dtype=np.int64)
        return empty, empty, np.zeros((0, 3))
    cand = np.repeat(np.arange(C), counts)  # (P,) candidate of each pair
    idx = np.concatenate([np.asarray(n, dtype=np.int64) for n in near if len(n)])
    # (P, 3) each pair's point in its candidate's gripper frame: R^T (p - t),
    # one candidate's run of pairs at a time
    p_g = np.empty((len(idx), 3))
    end = np.cumsum(counts)
    for c in np.flatnonzero(counts):
        s, e = end[c] - counts[c], end[c]
        rows = points[idx[s:e]] - T[c, :3, 3]  # (n, 3)
        if e - s == 1:
            # numpy takes one row times a matrix by another kernel than several
            # rows (OpenBLAS's vector product), whose last bits differ on some
            # processors: two copies of the row give :func:`_near_dense`'s bits
            p_g[s:e] = (np.repeat(rows, 2, axis=0) @ T[c, :3, :3])[:1]
        else:
            np.matmul(rows, T[c, :3, :3], out=p_g[s:e])
    return cand, idx, p_g


def _blocked_in_sweeps(
    g: GripperModel,
    T_world_gripper: Array,
    obstacles: list[Array],
    object_points: Array,
) -> NDArray[np.int64]:
    """:func:`blocked_in_closing` by the fingers' sweeps (see there)."""
    from wsgrasp.planning.closing import finger_sweep
    from wsgrasp.planning.sweeps import REACH_VOXEL, reach_boxes, reach_steps

    sweep = finger_sweep(g)  # (nf, K, P, 3) gripper frame
    K = sweep.shape[1]
    sweep = sweep.reshape(-1, 3)
    T = np.asarray(T_world_gripper, dtype=np.float64).reshape(-1, 4, 4)
    mid = sweep.mean(axis=0)
    reach = float(np.linalg.norm(sweep - mid, axis=1).max()) + 4 * REACH_VOXEL
    lo, hi = reach_boxes(g)

    # only the points in a finger's box are looked up in its reach grid
    pts = np.asarray(object_points, dtype=np.float64).reshape(-1, 3)
    # (C, nf) the first posture at which each finger reaches the target
    first = np.full((len(T), g.num_fingers), K, dtype=np.int64)
    step = max(1, _CHUNK // max(len(pts), 1))
    grids = _Grids.of(g, K) if _compiled.loaded() else None  # a search loaded them
    for a in range(0, len(T), step):
        Tc = T[a : a + step]
        # (c n, 3) the target's points in each candidate's gripper frame
        p_g = np.matmul(pts[None] - Tc[:, None, :3, 3], Tc[:, :3, :3]).reshape(-1, 3)
        if grids is not None:
            grids.first(p_g, len(pts), first[a : a + step])
            continue
        for f in range(g.num_fingers):
            steps = np.full(len(p_g), K, dtype=np.int64)
            box = np.flatnonzero(_in_box(p_g.T, lo[f], hi[f]))
            steps[box] = reach_steps(g, p_g[box], finger=f)[:, 0]
            first[a : a + step, f] = steps.reshape(len(Tc), len(pts)).min(axis=1)

    def inside(p: Array, cand: NDArray[np.int64]) -> NDArray[np.bool_]:
        if grids is not None:
            return grids.hits(p, cand, first)
        hit = np.zeros(len(p), dtype=bool)
        xyz = np.ascontiguousarray(p.T)  # (3, m) for the box tests
        for f in range(g.num_fingers):
            todo = np.flatnonzero(_in_box(xyz, lo[f], hi[f]) & ~hit)
            # a finger whose sweep never meets the target is not judged (see
            # blocked_in_closing), nor a point
            # another finger reaches first
            limit = first[cand[todo], f]  # (m,)
            judged = limit < K
            todo, limit = todo[judged], limit[judged]
            if len(todo):
                hit[todo] = reach_steps(g, p[todo], finger=f)[:, 0] <= limit
        return hit

    return _blocked_all(T, obstacles, mid, reach, inside)


class _Grids:
    """The fingers' reach grids and boxes as the compiled passes read them (one
    flat array, each finger's start and shape), and the two passes of
    :func:`_blocked_in_sweeps` over them: the first posture at which each
    finger reaches the target (:meth:`first`), and whether it reaches a
    neighbour's point no later (:meth:`hits`). Both answer point for point as
    the per-finger numpy passes they stand in for (``reach_steps``' lookups);
    on five simulated piles of ``random:000-299`` objects with the Allegro
    hand, the closing-path test took 18.9 ms with them against 27.4 ms with
    numpy's passes (medians; ``benchmarks/neighbours.py``)."""

    def __init__(self, g: GripperModel, K: int, loop: Callable[..., None]):
        from wsgrasp.planning.sweeps import REACH_VOXEL, reach_boxes, reach_grids

        origins, grids = reach_grids(g)
        lo, hi = reach_boxes(g)
        shapes = np.array([r.shape for r in grids], dtype=np.int64)  # (nf, 3)
        start = np.concatenate([[0], np.cumsum(shapes.prod(axis=1))[:-1]])
        # what both passes read after their own arguments (see _sweep_loop)
        self.grids = (
            np.asarray(origins, dtype=np.float64),
            float(REACH_VOXEL),
            shapes,
            start.astype(np.int64),
            np.concatenate([r.reshape(-1) for r in grids]),  # uint8
            np.asarray(lo, dtype=np.float64),
            np.asarray(hi, dtype=np.float64),
            int(K),
        )
        self.loop = loop

    @classmethod
    def of(
        cls, g: GripperModel, K: int, loop: Callable[..., None] | None = None
    ) -> _Grids:
        """The grids of ``g``, whose closing paths have ``K`` steps, with the
        compiled loop (or ``loop``, the tests' plain :func:`_sweep_loop`)."""
        return cls(g, K, loop or _compiled_sweep_loop())

    def first(self, p: Array, n: int, out: NDArray[np.int64]) -> None:
        """Lower ``out`` ``(c, nf)`` (C-contiguous, ``K`` where nothing is
        reached yet) to the first posture at which each finger reaches one of
        its candidate's points (``n`` rows of ``p`` per candidate)."""
        none = np.zeros(0, dtype=np.int64)
        self.loop(
            np.ascontiguousarray(p), int(n), none, out, *self.grids, np.zeros(0, bool)
        )

    def hits(
        self, p: Array, cand: NDArray[np.int64], first: NDArray[np.int64]
    ) -> NDArray[np.bool_]:
        """Per point (of candidate ``cand``): whether a finger whose sweep
        meets the target reaches it no later than the target."""
        hit = np.zeros(len(p), dtype=bool)
        self.loop(
            np.ascontiguousarray(p),
            0,
            np.ascontiguousarray(cand, dtype=np.int64),
            np.ascontiguousarray(first, dtype=np.int64),
            *self.grids,
            hit,
        )
        return hit


def _sweep_loop(
    p: Array,
    n: int,
    cand: NDArray[np.int64],
    first: NDArray[np.int64],
    origins: Array,
    voxel: float,
    shapes: NDArray[np.int64],
    start: NDArray[np.int64],
    flat: NDArray[np.uint8],
    lo: Array,
    hi: Array,
    K: int,
    hit: NDArray[np.bool_],
) -> None:
    """Both passes of :class:`_Grids` over points ``p`` ``(m, 3)``, each
    finger's step looked up as ``reach_steps`` looks it up (its box, then the
    nearest voxel of its grid). With ``n`` > 0 (:meth:`_Grids.first`), rows
    ``c n`` to ``(c + 1) n`` are candidate ``c``'s, and ``first`` ``(c, nf)``
    takes the least step per candidate and finger. With ``n`` = 0
    (:meth:`_Grids.hits`), row ``m`` is candidate ``cand[m]``'s, and ``hit``
    marks the points that a finger whose sweep meets the target (``first``
    below ``K``) reaches at a step no later than that."""
    for m in range(p.shape[0]):
        c = m // n if n else cand[m]
        x, y, z = p[m, 0], p[m, 1], p[m, 2]
        for f in range(lo.shape[0]):
            limit = first[c, f]
            if (not n and limit >= K) or not (
                lo[f, 0] <= x <= hi[f, 0]
                and lo[f, 1] <= y <= hi[f, 1]
                and lo[f, 2] <= z <= hi[f, 2]
            ):
                continue
            i = np.int64(np.rint((x - origins[f, 0]) / voxel))
            j = np.int64(np.rint((y - origins[f, 1]) / voxel))
            k = np.int64(np.rint((z - origins[f, 2]) / voxel))
            nx, ny, nz = shapes[f, 0], shapes[f, 1], shapes[f, 2]
            if i < 0 or i >= nx or j < 0 or j >= ny or k < 0 or k >= nz:
                continue
            step = np.int64(flat[start[f] + (i * ny + j) * nz + k])
            if n:
                if step < limit:
                    first[c, f] = step
            elif step <= limit:
                hit[m] = True
                break


_compiled_loop: Callable[..., None] | None = None


def _compiled_sweep_loop() -> Callable[..., None]:
    """:func:`_sweep_loop` compiled by numba (loaded from its cache beside
    this file), once per process; it runs only where a search has loaded its
    own compiled loops, so numba is imported already."""
    global _compiled_loop
    if _compiled_loop is None:
        import numba

        _compiled_loop = numba.njit(cache=True, nogil=True)(_sweep_loop)
    return _compiled_loop


def _in_box(xyz: Array, lo: Array, hi: Array) -> NDArray[np.bool_]:
    """Per point (the coordinates ``(3, m)``): whether it lies in the box
    ``lo``..``hi``."""
    x, y, z = xyz
    return (  # type: ignore[no-any-return]
        (x >= lo[0])
        & (x <= hi[0])
        & (y >= lo[1])
        & (y <= hi[1])
        & (z >= lo[2])
        & (z <= hi[2])
    )
