"""The fingers' closing sweeps against the table, for every candidate at once.

A hand whose fingers curl (the Allegro hand's sweep 9.6 cm along the approach
axis as they close) or swing down (the D'Claw's fingertips sweep 18 cm) drives
them into the table when it grasps a low object from above at the depth the
search chose: stopped on the table, they never reach round the object. The
sweeps (:func:`wsgrasp.planning.closing.finger_sweep`) are points on the links
each finger's joints move, at postures along its closing line.

:func:`sweep_back_offs` follows those points for every candidate at once: a
finger's sweep counts up to the posture at which it reaches the object (a point
of the object cloud within the points' spacing), and must stay above the table
until then (a finger whose tip slides may graze it: :func:`slides`). A
candidate whose sweep dips into the table first is backed off along its
approach axis by the least step (5 mm, at most 3 cm) that clears it, or else
rejected (``finger_sweeps_table``, see ``wsgrasp.api``). A model built before
the sweeps were kept (format 2) sweeps its pad centres.
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np
from numpy.typing import NDArray
from scipy.spatial import cKDTree

from wsgrasp.gripper.model import GripperModel
from wsgrasp.planning import _compiled
from wsgrasp.planning.closing import (
    BACK_OFF_STEPS,
    _pre_closed,
    finger_sweep,
    pad_positions,
)
from wsgrasp.planning.poses import MARGIN, distinct_rotations, hull_vertices

__all__ = [
    "GRAZE_SLACK",
    "REACH_VOXEL",
    "SWEEP_SLACK",
    "TIP_FRICTION",
    "declared_on_table",
    "prepare_sweeps",
    "reach_boxes",
    "reach_steps",
    "slides",
    "sweep_back_offs",
    "sweep_steps",
]

Array = NDArray[np.float64]

#: a sweep point this far (m) below the table plane is in the table (the
#: plane's own noise) ...
SWEEP_SLACK = 0.002
#: ... or this far, for a finger driven by several joints: where the table
#: pushes on its tip, its position-controlled joints give way and the tip
#: slides along the table, while a finger that one joint drives (a jaw, a
#: linkage, mimic-coupled links) stops there. Deeper, a low object's fingertips
#: jam against the table and push it out of the hand; shallower, they close
#: above its edges (the Allegro hand, random:000-299, strict: 194 of 297 held
#: at 8 mm, 170 at 15 mm, 183 at 2 mm; docs/results/graze-depth/). Not every
#: finger of several joints slides (a D'Claw's nearly straight two-joint
#: fingers press their tips into the table: docs/results/on-table/), so which
#: it is is the description's ``on_table`` or guessed per finger (:func:`slides`)
GRAZE_SLACK = 0.008
#: voxel (m) of each finger's reach grid (:func:`_reach_grid`, :func:`reach_steps`)
REACH_VOXEL = 0.004
#: a finger reaches an object point within this share of its sweep points'
#: spacing (the median distance to the nearest other point) ...
_REACH_SHARE = 0.6
#: ... or within this (m), whichever is larger (pad centres alone: 5 mm)
_REACH_MIN = 0.003
_REACH_PAD = 0.005
#: candidates whose object points are put into the gripper frame at once
_CHUNK = 256


def prepare_sweeps(g: GripperModel) -> None:
    """Build what :func:`sweep_back_offs` looks up for ``g`` (kept on the
    model), so that the first plan does not pay for it."""
    if g.num_fingers and (g.has_sweeps or g.has_configurations):
        _sweep_index(g)
        slides(g)


@dataclass(frozen=True)
class _SweepIndex:
    """What :func:`sweep_back_offs` looks up, built once per model.

    Attributes
    ----------
    hull : (nf, K, H, 3) float
        Per finger and posture, the corners of the sweep points' convex hull
        (a finger's lowest point is one of them), padded by repeating one.
    outline : list of (m, 3) float
        Per finger, the corners of the convex hull of all postures' corners.
    origin : (nf, 3) float
        Centre of voxel ``(0, 0, 0)`` of each finger's reach grid.
    reach : list of (X, Y, Z) uint8
        Per finger, the first posture (step) at which the finger reaches each
        voxel; ``K`` where it never does.
    """

    hull: Array
    outline: list[Array]
    origin: Array
    reach: list[NDArray[np.uint8]]


#: at most this many (corner, direction) heights at once in :func:`_lowest`
#: (its temporaries stay in cache: 2,000,000 took twice as long)
_LOWEST_ENTRIES = 262_144


def _sweep_index(g: GripperModel) -> _SweepIndex:
    cached = g.__dict__.get("_sweep_index")
    if cached is not None:
        return cached  # type: ignore[no-any-return]
    sweep = finger_sweep(g)  # (nf, K, P, 3)
    nf, K = sweep.shape[:2]
    hulls = [[hull_vertices(sweep[f, k]) for k in range(K)] for f in range(nf)]
    H = max((len(h) for row in hulls for h in row), default=1)
    # each posture's corners padded with its own: (nf, K, H, 3)
    hull = np.reshape(
        [np.resize(h, (H, 3)) for row in hulls for h in row], (nf, K, H, 3)
    )
    outline = [hull_vertices(np.concatenate(row)) for row in hulls]
    grids = [_reach_grid(sweep[f]) for f in range(nf)]  # (origin, grid) each
    origin = np.reshape([o for o, _ in grids], (nf, 3))
    index = _SweepIndex(hull, outline, origin, [grid for _, grid in grids])
    g.__dict__["_sweep_index"] = index
    return index


def _reach_grid(points: Array) -> tuple[Array, NDArray[np.uint8]]:
    """One finger's reach grid from its sweep ``points`` ``(K, P, 3)``: each
    voxel holds the first step at which a sweep point lies within the reach
    radius of its centre (``K`` where none does). Returns the grid's origin
    (the centre of voxel ``(0, 0, 0)``) and the grid."""
    K, P = points.shape[:2]
    if P > 1:
        d, _ = cKDTree(points[0]).query(points[0], k=2)  # (P, 2)
        spacing = float(np.median(d[:, 1]))
        radius = max(_REACH_MIN, _REACH_SHARE * spacing)
    else:
        radius = _REACH_PAD
    v = REACH_VOXEL
    r = int(np.ceil(radius / v))
    flat = points.reshape(-1, 3)  # (K P, 3)
    origin = flat.min(axis=0) - (r + 1) * v
    idx = np.rint((flat - origin) / v).astype(np.int64)  # (K P, 3)
    shape = idx.max(axis=0) + r + 2  # (3,)
    g = np.arange(-r, r + 1)
    off = np.stack(np.meshgrid(g, g, g, indexing="ij"), axis=-1).reshape(-1, 3)
    off = off[np.linalg.norm(off * v, axis=1) <= radius + 0.5 * v]  # (m, 3) a ball
    step = np.repeat(np.arange(K, dtype=np.uint8), P)  # (K P,)
    grid = np.full(tuple(int(x) for x in shape), K, dtype=np.uint8)
    cells = (idx[:, None, :] + off[None, :, :]).reshape(-1, 3)  # (K P m, 3)
    np.minimum.at(grid, tuple(cells.T), np.repeat(step, len(off)))
    return origin, grid


def reach_boxes(g: GripperModel) -> tuple[list[Array], list[Array]]:
    """Per finger, the corners ``lo``, ``hi`` (gripper frame) of a box holding
    its reach grid with half a voxel to spare: :func:`reach_steps` reads ``K``
    (never reached) for every point outside it."""
    index = _sweep_index(g)
    lo = [o - REACH_VOXEL for o in index.origin]
    hi = [
        o + np.array(r.shape) * REACH_VOXEL
        for o, r in zip(index.origin, index.reach, strict=True)
    ]
    return lo, hi


def reach_grids(g: GripperModel) -> tuple[list[Array], list[NDArray[np.uint8]]]:
    """Per finger, the origin (gripper frame) and the reach grid that
    :func:`reach_steps` looks points up in: voxel ``(i, j, k)`` at ``origin +
    REACH_VOXEL (i, j, k)`` holds the first posture reaching it."""
    index = _sweep_index(g)
    return list(index.origin), list(index.reach)


def sweep_steps(g: GripperModel) -> int:
    """The postures a finger's sweep is followed through, ``K``: what
    :func:`reach_steps` answers for a point no finger reaches."""
    return int(_sweep_index(g).hull.shape[1])


def reach_steps(
    g: GripperModel, points: Array, finger: int | None = None
) -> NDArray[np.int64]:
    """Per point ``(m, 3)`` (gripper frame) and finger: the first posture (step
    along the closing path, as :func:`finger_sweep` counts them) at which the
    finger's sweep reaches the point, ``K`` (the path's steps) where it never
    does: ``(m, nf)``, or ``(m, 1)`` for ``finger`` alone. Looked up in the
    fingers' reach grids, built once per model."""
    index = _sweep_index(g)
    K = index.hull.shape[1]
    p = np.asarray(points, dtype=np.float64).reshape(-1, 3)
    fingers = range(len(index.reach)) if finger is None else [finger]
    out = np.empty((len(p), len(fingers)), dtype=np.int64)
    for col, f in enumerate(fingers):
        grid = index.reach[f]
        ijk = np.rint((p - index.origin[f]) / REACH_VOXEL).astype(np.int64)  # (m, 3)
        nx, ny, nz = grid.shape
        i, j, k = ijk[:, 0], ijk[:, 1], ijk[:, 2]
        ok = (i >= 0) & (i < nx) & (j >= 0) & (j < ny) & (k >= 0) & (k < nz)
        # one flat lookup, voxels outside the grid read as K: a boolean mask
        # and a tuple of index arrays took twice as long (the neighbour test
        # looks up some 100,000 points per finger in a clutter plan)
        flat = np.where(ok, (i * ny + j) * nz + k, 0)
        out[:, col] = np.where(ok, grid.reshape(-1)[flat], K)
    return out


def sweep_back_offs(
    g: GripperModel,
    T_world_gripper: Array | tuple[Array, NDArray[np.int64], Array],
    T_world_table: Array,
    object_points: Array,
    groups: NDArray[np.int64] | None = None,
) -> Array:
    """The least back-off along each candidate's approach axis that keeps its
    fingers' sweeps out of the table until they reach the object.

    A finger's sweep (:func:`finger_sweep`) is followed posture by posture from
    the pre-grasp one: it fails at the first posture with a point more than
    :data:`SWEEP_SLACK` (:data:`GRAZE_SLACK` for a finger whose tip slides
    along the table, :func:`slides`) below the table plane, unless an earlier posture
    already reached an object point (a finger stopped by the object goes no
    further). A candidate is clear when no finger fails; backing it off
    ``d`` along its approach lifts the sweeps and moves the object deeper into
    them, so each step of ``BACK_OFF_STEPS`` is tried in turn.

    Parameters
    ----------
    g : GripperModel
    T_world_gripper : (C, 4, 4) float, or (R, of, t)
        The candidates' poses, or their rotations ``R`` (U, 3, 3), each one's
        row of ``R`` ``of`` (C,) and translations ``t`` (C, 3)
        (:meth:`~wsgrasp.planning.poses.PoseArray.split`).
    T_world_table : (4, 4) float
        Table frame: origin on the surface, z its normal towards the object.
    object_points : (n, 3) float
        World frame.
    groups : (C,) int, optional
        A label per candidate (its orientation in a search's candidate set)
        such that candidates with one label share their rotation: the
        rotations are then told apart by label (checked; see
        :func:`~wsgrasp.planning.poses.distinct_rotations`). The answers are
        the same without it.

    Returns
    -------
    (C,) float
        The back-off (m; 0 where the sweeps are clear as they are), NaN where
        no step up to ``BACK_OFF_STEPS[-1]`` clears them. All zeros for a model
        without finger configurations.
    """
    if isinstance(T_world_gripper, tuple):
        R, of, t = T_world_gripper
    else:
        T = np.asarray(T_world_gripper, dtype=np.float64).reshape(-1, 4, 4)
        # candidates share their rotations (samples x orientations): each once
        R, of = distinct_rotations(T[:, :3, :3], groups)  # (U, 3, 3), (C,) into R
        t = T[:, :3, 3]
    C = len(of)
    if g.num_fingers == 0 or not (g.has_sweeps or g.has_configurations):
        return np.zeros(C)
    out = np.full(C, np.nan)
    index = _sweep_index(g)
    nf, K = index.hull.shape[:2]
    n = np.asarray(T_world_table, dtype=np.float64)[:3, 2]
    o = np.asarray(T_world_table, dtype=np.float64)[:3, 3]
    u = np.einsum("uij,i->uj", R, n)  # (U, 3) table normal, gripper frame
    # a finger's sweep dips below the table at some posture only if its lowest
    # corner of all does (less MARGIN: a corner on a face of their hull may
    # round lower than the face's own corners, never by that much): postures
    # are followed only for the rotations of candidates that cross (the
    # Allegro's dense sweeps: 627 of 87,417 candidates, 192 of 4,670 rotations;
    # all postures of all rotations took 170 of their 370 ms): (nf, U)
    lowest = np.stack([_lowest(c[None, None], u)[0, 0] for c in index.outline])
    lowest -= MARGIN
    lift = (t - o) @ n  # (C,) each candidate's origin above the table
    a_n = u[of] @ g.approach_axis  # (C,) how the approach moves along the normal
    pts = np.asarray(object_points, dtype=np.float64).reshape(-1, 3)
    t_g = np.einsum("cji,cj->ci", R[of], t)  # (C, 3) R^T t
    slack = np.where(slides(g), GRAZE_SLACK, SWEEP_SLACK)[:, None]  # (nf, 1)
    todo = np.arange(C)  # candidates not yet settled
    for d in BACK_OFF_STEPS:
        c = todo
        clear = ~((lowest[:, of[c]] + lift[c] - d * a_n[c]) < -slack).any(axis=0)
        crossing = np.flatnonzero(~clear)
        if d == BACK_OFF_STEPS[0]:  # the rotations of those that cross at all
            rs = np.unique(of[todo[crossing]])  # (r,)
            at = np.zeros(len(R), dtype=np.int64)
            at[rs] = np.arange(len(rs))
            low = _lowest(index.hull, u[rs])  # (nf, K, r) without the heights
            # object points in these rotations' gripper axes, reach-grid voxels
            p_rot = np.empty((len(rs), len(pts), 3), dtype=np.float32)  # (r, n, 3)
            step = max(1, _LOWEST_ENTRIES // max(3 * len(pts), 1))
            for a in range(0, len(rs), step):
                p_rot[a : a + step] = (
                    np.matmul(pts[None], R[rs[a : a + step]]) / REACH_VOXEL
                )
        for lo in range(0, len(crossing), _CHUNK):
            x = crossing[lo : lo + _CHUNK]
            c = todo[x]
            # each finger's lowest height per posture: (nf, K, x)
            below = (low[:, :, at[of[c]]] + lift[c] - d * a_n[c]) < -slack[..., None]
            limit = np.where(below.any(axis=1), below.argmax(axis=1), K)  # (nf, x)
            # the gripper origins, backed off, in the candidates' own axes
            shift = (t_g[c] - d * g.approach_axis) / REACH_VOXEL  # (x, 3)
            clear[x] = _reached_first(index, p_rot, at[of[c]], shift, limit)
        out[todo[clear]] = d
        todo = todo[~clear]
        if not len(todo):
            break
    return out


def slides(g: GripperModel) -> list[bool]:
    """Per finger, whether its tip slides along the table where its sweep meets
    it: the description's ``on_table`` where it says; otherwise a finger that
    one joint drives sticks, and one that several joints drive slides unless
    its joints press its pad into the table as it comes down onto it
    (:func:`_presses_into_table`). Kept on the model (built once)."""
    cached = g.__dict__.get("_slides")
    if cached is not None:
        return cached  # type: ignore[no-any-return]
    out = []
    for f, said in enumerate(declared_on_table(g)):
        if said is not None:
            out.append(said == "slides")
        else:
            out.append(len(g.finger_joints[f]) > 1 and not _presses_into_table(g, f))
    g.__dict__["_slides"] = out
    return out


def declared_on_table(g: GripperModel) -> list[str | None]:
    """Per finger, the description's ``on_table`` (``None`` where it leaves it
    out, and for a model kept without its description)."""
    fingers = g.description.get("fingers", []) if g.description else []
    return [
        fingers[f].get("on_table") if f < len(fingers) else None
        for f in range(g.num_fingers)
    ]


#: friction between a fingertip and the table, for :func:`_presses_into_table`
#: (rubber or plastic on a table top: 0.5 to 1; the simulator's pads: 0.8)
TIP_FRICTION = 0.8
#: postures whose sweep is within this (m) of its lowest, along the approach,
#: are where a table under a low object meets a finger grasping it from above
_NEAR_TABLE = 0.02
#: a finger sticks where at least this share of those postures press it in
_STICK_SHARE = 1.0 / 3.0


def _presses_into_table(g: GripperModel, f: int) -> bool:
    """Whether finger ``f``'s joints, closing, press its pad into a table below
    it inside the friction cone, where it comes down onto the table.

    The gripper approaches from above (the table's normal against the approach
    axis), the finger closes from its pre-grasp posture towards its closed one,
    and each joint is driven, as the simulator's position actuators with one
    gain drive it, with a torque along its remaining travel: the pad force
    ``F = pinv(J^T) (q_closed - q_pregrasp)``, ``J`` the pad centre's Jacobian.
    At the postures where the finger's sweep comes down to within
    ``_NEAR_TABLE`` of its lowest, a force into the table with less sideways
    push than ``TIP_FRICTION`` times its push into it holds the tip where it
    touches (friction cone): the joints stop, as a D'Claw's do. A force along
    the table or away from it lets the tip slide (the Allegro's, the Shadow
    hand's). The finger sticks where at least ``_STICK_SHARE`` of those
    postures press it in."""
    if not g.has_configurations:
        return False
    index = _sweep_index(g)
    K = index.hull.shape[1]
    down = -np.asarray(g.approach_axis, dtype=np.float64)  # table normal, up
    low = _lowest(index.hull[f : f + 1], down[None])[0, :, 0]  # (K,)
    k_min = int(np.argmin(low))
    ks = np.arange(1, k_min + 1)
    ks = ks[(low[ks] < low[ks - 1]) & (low[ks] - low[k_min] < _NEAR_TABLE)]
    if not len(ks):
        return False
    lim = np.asarray(g.finger_limits[f], dtype=np.float64)  # (d, 2)
    pre, closed = _pre_closed(g, f)
    q = pre + (ks / (K - 1))[:, None] * (closed - pre)  # (k, d)
    d, eps = len(lim), 0.02
    J = np.empty((len(ks), 3, d))
    for i in range(d):
        step = np.zeros(d)
        step[i] = eps
        hi = np.clip(q + step, lim[:, 0], lim[:, 1])
        lo = np.clip(q - step, lim[:, 0], lim[:, 1])
        J[:, :, i] = (pad_positions(g, f, hi) - pad_positions(g, f, lo)) / (
            hi[:, i] - lo[:, i]
        ).clip(min=1e-12)[:, None]
    F = np.einsum("kij,j->ki", np.linalg.pinv(J.transpose(0, 2, 1)), closed - pre)
    into = -(F @ down)  # (k,) the push into the table
    sideways = np.sqrt(np.maximum((F * F).sum(axis=1) - into**2, 0.0))
    pressed = (into > 0.0) & (sideways < TIP_FRICTION * into)
    return bool(pressed.mean() >= _STICK_SHARE)


def _lowest(hull: Array, u: Array) -> Array:
    """Per finger and posture, the least height of the hull corners ``hull``
    ``(nf, K, H, 3)`` along each direction ``u`` ``(U, 3)``: ``(nf, K, U)``.

    Elementwise products and sums over a bounded block of directions at a time:
    the whole ``(nf K H, U)`` matrix product took 300 MB for the Allegro's dense
    candidates (4,673 rotations), and its rounding depended on how the product
    was blocked; this takes 15 % longer."""
    nf, K, H, _ = hull.shape
    hT = np.ascontiguousarray(hull.reshape(-1, 3).T)  # (3, nf K H)
    out = np.empty((nf, K, len(u)))
    step = max(1, _LOWEST_ENTRIES // max(hT.shape[1], 1))
    z = np.empty((min(step, len(u)), hT.shape[1]))  # (c, nf K H) heights
    t = np.empty_like(z)
    for a in range(0, len(u), step):
        v = u[a : a + step]  # (c, 3)
        c = len(v)
        np.multiply(v[:, 0, None], hT[0], out=z[:c])
        np.multiply(v[:, 1, None], hT[1], out=t[:c])
        z[:c] += t[:c]
        np.multiply(v[:, 2, None], hT[2], out=t[:c])
        z[:c] += t[:c]
        # (c, nf, K, H) -> least over the corners -> (nf, K, c)
        out[:, :, a : a + c] = z[:c].reshape(c, nf, K, H).min(axis=3).transpose(1, 2, 0)
    return out


def _reached_first(
    index: _SweepIndex,
    p_rot: NDArray[np.float32],
    rotation: NDArray[np.int64],
    shift: Array,
    limit: NDArray[np.int64],
) -> NDArray[np.bool_]:
    """Whether every finger reaches an object point before the step ``limit``
    ``(nf, x)`` at which it enters the table (``K``: it never does), for
    candidates whose object points in the gripper frame are
    ``p_rot[rotation] - shift`` (reach-grid voxels; ``p_rot`` ``(U, n, 3)``,
    ``rotation`` ``(x,)``, ``shift`` ``(x, 3)``): ``(x,)``. Fingers are
    looked up one after another, each only for the candidates no finger has
    failed yet: by the compiled loop where the search's are loaded
    (``_loops._reach_loop``, stopping at the first point reached), else all
    points at once."""
    nf, K = index.hull.shape[:2]
    alive = ~(limit == 0).any(axis=0)  # (x,) entering the table at once fails
    if p_rot.shape[1] == 0:
        return alive & (limit == K).all(axis=0)
    loop = _compiled.reach_loop()  # where the search's loops are loaded
    for f in range(nf):  # fingers, each with its own grid
        rows = np.flatnonzero(alive & (limit[f] < K))
        if not len(rows):
            continue
        grid = index.reach[f]
        top = np.array(grid.shape, dtype=np.int32) - 1
        offset = (shift[rows] + index.origin[f] / REACH_VOXEL).astype(np.float32)
        if loop is not None:
            hit = np.empty(len(rows), dtype=bool)
            loop(p_rot, rotation[rows], offset, grid, limit[f, rows], hit)
            alive[rows] = hit
            continue
        q = p_rot[rotation[rows]] - offset[:, None, :]  # (r, n, 3) voxels
        idx = np.rint(q, out=q).astype(np.int32)
        # the grid's border voxels never hold a step: clipped points fall there
        np.minimum(idx, top, out=idx)
        np.maximum(idx, 0, out=idx)
        flat = (idx[..., 0] * grid.shape[1] + idx[..., 1]) * grid.shape[2]
        flat += idx[..., 2]
        reached = grid.reshape(-1)[flat].min(axis=1)  # (r,) first step
        alive[rows] = reached < limit[f, rows]
    return alive
