"""Kernels for structured candidate sets: box samples × orientations.

A candidate set built by ``candidate_poses`` is not an arbitrary list of poses: every
candidate is a sample position ``s`` (object frame) and an orientation ``o`` (a
rotation and a depth offset), and its gripper pose factors as

``R_world_gripper[s, o] = R_world_object R_object_gwc[o] R_gwc_gripper``: one per
orientation, and
``t_world_gripper[s, o] = A[s] + B[o]``, with ``A[s] = R_world_object s +
t_world_object`` and ``B[o] = R_world_object (R_object_gwc[o] t_gwc_gripper +
depth[o] z_gwc[o])``.

So anything linear in the pose splits into a per-orientation part and a per-sample
part, and a per-candidate quantity is one broadcast sum of the two.

The table test uses this with the gripper cloud's support function along the table
normal: the lowest cloud point of an orientation is the same vertex of the cloud's
convex hull for every sample, and its height is ``h[o] + n · A[s]``. A candidate
whose lowest point is above the table superellipsoid's top cannot touch it (every
point has ``(z - z0)^2 / c^2 > 1``); one whose lowest point is inside it is in
collision. Only the few others need the exact test over the whole cloud. Both
bounds keep a margin of ``MARGIN`` so that a verdict decided here is the one every
evaluation of eq. (1) in floating point gives.
"""

from __future__ import annotations

from collections.abc import Callable, Iterable, Iterator
from dataclasses import dataclass
from typing import TYPE_CHECKING, Any

import numpy as np
from numpy.typing import NDArray
from scipy.spatial import ConvexHull, QhullError

from wsgrasp.geometry import coordinates_in_superellipsoids, invert_transforms
from wsgrasp.geometry._superellipsoid import _power
from wsgrasp.gripper.model import GripperModel
from wsgrasp.planning import _dense_numba
from wsgrasp.planning._dense_grid import (
    FingerDepth,
    NearestPoint,
    ObjectDistance,
    finger_depth,
    inscribed_balls,
)
from wsgrasp.planning._holdings import Holdings, count_held
from wsgrasp.planning.spheres import FingerSpheres

if TYPE_CHECKING:
    from wsgrasp.planning.evaluate import TableSE

__all__ = ["CandidateStructure", "StructuredPoses", "table_bounds", "hull_vertices"]

Array = NDArray[np.float64]

#: a bound decides a verdict only this far (in eq. (1)'s value, or metres) from it
MARGIN = 1e-9
#: at most this many candidates' intermediate arrays at once (bounds memory)
_CHUNK_CANDIDATES = 262_144
#: at most this many (candidate, point) pairs through the sphere grid at once
_CHUNK_PAIRS = 100_000
#: at most this many unsure (candidate, point) pairs through the sphere lists at once
_CHUNK_LISTED = 1_000_000
#: from this many candidates on, the object's distance grid proves body hits
_BALLS_FROM = 20_000
#: from this many (candidate, point) pairs on, the compiled loops run (with numba
#: installed), loaded at once if need be, and the body loop reads nearest-point
#: hints; below, once they are loaded, or from a process's
#: ``_SMALL_BEFORE_LOADING + 1``-th search of ``_SMALL_FROM`` pairs or more on
#: (see :func:`_use_compiled`)
_COMPILED_FROM = 1_000_000
_SMALL_BEFORE_LOADING = 3
_SMALL_FROM = 20_000
#: a chunk of the compiled body test holds at most this many candidates, and its
#: orientations' points at most this many coordinates
_SPAN_CANDIDATES = 65_536
_SPAN_POINTS = 3_000_000
#: from this many candidates of a chunk on, the finger test reads the depth grid
_DEPTH_FROM = 1024
#: up to this many (candidate, point, finger) entries, the finger test keeps the
#: holdings it computes; beyond, it counts, and builds holdings when asked
_KEEP_ENTRIES = 24_000_000


@dataclass(frozen=True)
class CandidateStructure:
    """How a candidate set was built: samples outer, orientations inner.

    Attributes
    ----------
    T_world_object : (4, 4) float
    samples_object : (ns, 3) float
    R_object_gwc : (O, 3, 3) float
    depth : (O,) float or None
        Offset of each orientation's GWC along its approach axis (m).
    """

    T_world_object: Array
    samples_object: Array
    R_object_gwc: Array
    depth: Array | None = None

    @property
    def num_candidates(self) -> int:
        return len(self.samples_object) * len(self.R_object_gwc)


@dataclass(frozen=True)
class StructuredPoses:
    """``T_world_gripper[s * O + o] = [R[o], A[s] + B[o]]``.

    Attributes
    ----------
    R : (O, 3, 3) float
        ``R_world_gripper`` per orientation.
    A : (ns, 3) float
        Per sample (world frame).
    B : (O, 3) float
        Per orientation (world frame).
    """

    R: Array
    A: Array
    B: Array

    @classmethod
    def build(
        cls, structure: CandidateStructure, T_gripper_gwc: Array
    ) -> StructuredPoses:
        T_wo = np.asarray(structure.T_world_object, dtype=np.float64)
        R_og = np.asarray(structure.R_object_gwc, dtype=np.float64)  # (O, 3, 3)
        s = np.asarray(structure.samples_object, dtype=np.float64).reshape(-1, 3)
        T_gwc_gripper = invert_transforms(T_gripper_gwc)
        R_wo, t_wo = T_wo[:3, :3], T_wo[:3, 3]
        R_wgwc = R_wo @ R_og  # (O, 3, 3)
        R = R_wgwc @ T_gwc_gripper[:3, :3]  # (O, 3, 3)
        B = R_wgwc @ T_gwc_gripper[:3, 3]  # (O, 3)
        if structure.depth is not None:
            B = (
                B
                + np.asarray(structure.depth, dtype=np.float64)[:, None]
                * (R_wgwc[:, :, 2])
            )
        A = s @ R_wo.T + t_wo  # (ns, 3)
        return cls(R, A, B)

    def columns(self) -> tuple[Array, Array]:
        """``A.T`` (3, ns) and ``B.T`` (3, O), contiguous (built once, then
        kept): one coordinate's gather is a 1-D ``take``."""
        got = self.__dict__.get("_columns")
        if got is None:
            got = (np.ascontiguousarray(self.A.T), np.ascontiguousarray(self.B.T))
            object.__setattr__(self, "_columns", got)
        return got  # type: ignore[no-any-return]

    def transforms(self, index: NDArray[np.int64]) -> Array:
        """``T_world_gripper`` of the candidates ``index`` (k,): (k, 4, 4)."""
        n_or = len(self.R)
        s, o = np.divmod(np.asarray(index, dtype=np.int64), n_or)
        T = np.zeros((len(s), 4, 4))
        T[:, :3, :3] = self.R[o]
        T[:, :3, 3] = self.A[s] + self.B[o]
        T[:, 3, 3] = 1.0
        return T


def hull_vertices(cloud: Array) -> Array:
    """The points of ``cloud`` (n, 3) on its convex hull (all of them when the
    cloud is flat or too small for a hull): (h, 3)."""
    p = np.asarray(cloud, dtype=np.float64).reshape(-1, 3)
    if len(p) < 5:
        return p
    try:
        return p[ConvexHull(p).vertices]
    except QhullError:
        return p


def table_bounds(
    poses: StructuredPoses, vertices: Array, table: TableSE
) -> tuple[NDArray[np.bool_], NDArray[np.bool_]]:
    """The table test decided from two points of each candidate's gripper cloud.

    Per orientation, the cloud's heights above the table differ between samples by
    one shift, so the lowest point (the support vertex along the normal) and the
    point nearest the middle of the table superellipsoid's slab are found once per
    orientation (a sorted row and one ``searchsorted`` per candidate).

    Parameters
    ----------
    poses : StructuredPoses
    vertices : (h, 3) float
        Gripper-frame points that include the cloud's convex hull vertices (the
        hull's, or the whole cloud).
    table : TableSE

    Returns
    -------
    hit : (C,) bool
        Certainly in collision with the table: one of the two points is inside
        (eq. (1) below ``1 - MARGIN``).
    unsure : (C,) bool
        Neither proven: the exact test over the whole cloud decides these. The
        others (neither flag) certainly clear the table: their lowest point is
        above the superellipsoid's top by more than ``MARGIN``.
    """
    if len(poses.R) == 0 or len(poses.A) == 0 or len(vertices) == 0:
        none = np.zeros(len(poses.R) * len(poses.A), dtype=bool)
        return none, none.copy() if len(vertices) else ~none
    T_table_world = invert_transforms(table.T_world_table)
    R_tw, t_tw = T_table_world[:3, :3], T_table_world[:3, 3]
    RT = R_tw @ poses.R  # (O, 3, 3) gripper axes in the table frame
    base = poses.B @ R_tw.T + t_tw  # (O, 3)
    M = poses.A @ R_tw.T  # (ns, 3)
    # the vertices in the table frame per orientation, without the sample's shift
    # (one batched product: an einsum takes 7 times as long)
    P = np.matmul(vertices, RT.transpose(0, 2, 1)) + base[:, None, :]  # (O, h, 3)
    heights = P[:, :, 2]  # (O, h)
    order = np.argsort(heights, axis=1)  # (O, h)
    sorted_h = np.take_along_axis(heights, order, axis=1)
    n_or, nv = heights.shape
    # rows laid end to end, each shifted clear of the previous one, so that one
    # searchsorted answers every (orientation, target) pair
    span = float(np.ptp(heights) + np.ptp(M[:, 2]) + abs(table.center[2]) + 1.0)
    flat = (sorted_h + span * np.arange(n_or)[:, None]).ravel()  # (O * h,)
    lowest = P[np.arange(n_or), order[:, 0]]  # (O, 3) each orientation's lowest
    top = float(table.center[2] + table.semi_axes[2])
    ns = len(M)
    hit = np.zeros(ns * n_or, dtype=bool)
    unsure = np.zeros(ns * n_or, dtype=bool)
    for a in range(0, ns * n_or, _CHUNK_CANDIDATES):
        c = np.arange(a, min(a + _CHUNK_CANDIDATES, ns * n_or))
        s, o = np.divmod(c, n_or)
        shift = M[s, 2]  # (k,)
        # a candidate whose lowest point is above the top by MARGIN has both
        # points above it (the rounding of the shifted heights keeps their
        # order): eq. (1)'s z term alone exceeds 1, so neither is inside and
        # nothing is left to compute (43 % of the Allegro's dense candidates)
        low = np.flatnonzero(sorted_h[o, 0] + shift <= top + MARGIN)  # (l,)
        s, o, shift = s[low], o[low], shift[low]
        # the lowest vertex, then for the others the vertex nearest the slab's
        # middle height
        inside = _vertices_inside(lowest[o] + M[s], table)
        rest = np.flatnonzero(~inside)
        target = table.center[2] - shift[rest] + span * o[rest]
        j = np.clip(np.searchsorted(flat, target) - o[rest] * nv, 0, nv - 1)
        inside[rest] = _vertices_inside(
            P[o[rest], order[o[rest], j]] + M[s[rest]], table
        )
        # the rest against every vertex (of the Allegro's dense candidates, 8,968
        # are left here, 8,944 of them with a vertex inside: the hand's lowest
        # vertex below the slab and the one nearest its middle beyond its edge)
        rest = np.flatnonzero(~inside)
        step = max(1, 500_000 // max(nv, 1))  # (k, h, 3) temporaries: 12 MB
        for b in range(0, len(rest), step):
            r = rest[b : b + step]
            p = P[o[r]] + M[s[r]][:, None, :]  # (k, h, 3) table frame
            inside[r] = _vertices_inside(p, table).any(axis=1)
        hit[c[low]] = inside
        unsure[c[low]] = ~inside
    return hit, unsure


def _vertices_inside(p: Array, table: TableSE) -> NDArray[np.bool_]:
    """Points ``p`` (..., 3), table frame, inside the table superellipsoid by
    more than ``MARGIN`` in eq. (1)'s value: (...) bool."""
    d = np.abs(p - table.center) / table.semi_axes
    l_ = table.exponent
    value = _power(d[..., 0], l_) + _power(d[..., 1], l_) + d[..., 2] * d[..., 2]
    return value < 1.0 - MARGIN  # type: ignore[no-any-return]


def lowest_heights(
    poses: StructuredPoses,
    vertices: Array,
    table: TableSE,
    index: NDArray[np.int64],
) -> Array:
    """Height above the table surface of the lowest of ``vertices`` (h, 3),
    gripper frame, for the candidates ``index`` (k,): per orientation the lowest
    vertex's height without the sample's part, plus the sample's shift: (k,)."""
    T_table_world = invert_transforms(table.T_world_table)
    R_tw, t_tw = T_table_world[:3, :3], T_table_world[:3, 3]
    n_or = len(poses.R)
    s, o = np.divmod(np.asarray(index, dtype=np.int64), n_or)
    if len(vertices) == 0:
        return np.full(len(s), np.inf)
    z_axes = poses.R.transpose(0, 2, 1) @ R_tw[2]  # (O, 3) table normal, gripper axes
    low = (vertices @ z_axes.T).min(axis=0)  # (O,)
    low = low + poses.B @ R_tw[2] + t_tw[2]
    return low[o] + poses.A[s] @ R_tw[2]  # type: ignore[no-any-return]


def table_exact(
    poses: StructuredPoses, cloud: Array, table: TableSE, index: NDArray[np.int64]
) -> NDArray[np.bool_]:
    """Eq. (1) of the table at every cloud point of the candidates ``index`` (k,):
    whether any lies inside, (k,) bool.

    The cloud is put into the table frame once per orientation concerned; each
    candidate adds its sample's shift.
    """
    T_table_world = invert_transforms(table.T_world_table)
    R_tw, t_tw = T_table_world[:3, :3], T_table_world[:3, 3]
    n_or = len(poses.R)
    s_all, o_all = np.divmod(np.asarray(index, dtype=np.int64), n_or)
    by_o = _grouped(o_all)  # a chunk spans few orientations
    M = poses.A @ R_tw.T  # (ns, 3)
    out = np.zeros(len(s_all), dtype=bool)
    step = max(1, 2_000_000 // max(len(cloud), 1))
    for a in range(0, len(s_all), step):
        at = by_o[a : a + step]
        used, ol = np.unique(o_all[at], return_inverse=True)
        RT = R_tw @ poses.R[used]  # (u, 3, 3)
        base = poses.B[used] @ R_tw.T + t_tw  # (u, 3)
        P = np.einsum("oij,nj->ion", RT, cloud) + base.T[:, :, None]  # (3, u, ng)
        ss = s_all[at]
        z = P[2][ol] + M[ss, 2:3]  # (k, ng)
        dz = np.abs(z - table.center[2]) / table.semi_axes[2]
        maybe = dz < 1.0  # only points within the slab can be inside
        k, n = np.nonzero(maybe)
        if k.size == 0:
            continue
        dx = np.abs(P[0][ol[k], n] + M[ss[k], 0] - table.center[0])
        dy = np.abs(P[1][ol[k], n] + M[ss[k], 1] - table.center[1])
        value = (
            (dx / table.semi_axes[0]) ** table.exponent
            + (dy / table.semi_axes[1]) ** table.exponent
            + dz[k, n] ** 2
        )
        out[at[k[value < 1.0]]] = True
    return out


# --------------------------------------------------------------------------------
# object, obstacles and fingers
# --------------------------------------------------------------------------------
@dataclass
class BodyFingerVerdicts:
    """What the object, obstacle and finger tests found for candidates ``index``.

    Attributes
    ----------
    reason : (k,) int
        2, 3, 4 or 0 (feasible), per candidate of ``index``.
    contacts : (k, nf) int
    holding : Holdings
        For the feasible ones, in the order of ``index``: their counts, and
        their ``(F, no, nf)`` holdings computed when asked for.
    """

    reason: NDArray[np.int64]
    contacts: NDArray[np.int64]
    holding: Holdings


def _separated(lo_a: Array, hi_a: Array, lo_b: Array, hi_b: Array) -> NDArray[np.bool_]:
    """Boxes ``[lo_a, hi_a]`` and ``[lo_b, hi_b]`` (..., 3) apart by more than
    ``MARGIN`` along some axis: (...) bool."""
    return np.any((lo_a > hi_b + MARGIN) | (hi_a < lo_b - MARGIN), axis=-1)


def _object_box_clear(
    Q_lo: Array,
    Q_hi: Array,
    u: Array,
    box_lo: Array,
    box_hi: Array,
) -> NDArray[np.bool_]:
    """Candidates whose object box (gripper axes: ``[Q_lo - u, Q_hi - u]``,
    (m, 3)) is apart from every box ``[box_lo, box_hi]`` (e, 3): (m,) bool."""
    lo = (Q_lo - u)[:, None, :]  # (m, 1, 3)
    hi = (Q_hi - u)[:, None, :]
    return np.all(_separated(lo, hi, box_lo[None], box_hi[None]), axis=1)


def _boxes_clear(
    poses: StructuredPoses,
    s: NDArray[np.int64],
    o: NDArray[np.int64],
    ext_lo: Array,
    ext_hi: Array,
    box_lo: Array,
    box_hi: Array,
) -> NDArray[np.bool_]:
    """:func:`_object_box_clear` for candidates ``(s, o)`` (k,), with the object's
    box in the gripper axes per orientation ``[ext_lo, ext_hi]`` (O, 3).

    A candidate's translation in the gripper axes is ``u = A[s] R[o] + B[o]
    R[o]``, whose two parts come from one product per orientation; each box
    and axis is then two comparisons per candidate."""
    out = np.empty(len(s), dtype=bool)
    AR = np.matmul(poses.A[None], poses.R)  # (O, ns, 3) A[s] R[o]
    BR = np.matmul(poses.B[:, None, :], poses.R)[:, 0]  # (O, 3)
    ns = len(poses.A)
    for a in range(0, len(s), _CHUNK_CANDIDATES):
        sa, oa = s[a : a + _CHUNK_CANDIDATES], o[a : a + _CHUNK_CANDIDATES]
        flat = oa * ns + sa
        apart_all = np.ones(len(sa), dtype=bool)
        u = [AR[:, :, k].ravel()[flat] + BR[oa, k] for k in range(3)]  # 3 × (c,)
        lo = [ext_lo[oa, k] - u[k] for k in range(3)]  # the object box, gripper axes
        hi = [ext_hi[oa, k] - u[k] for k in range(3)]
        for e in range(len(box_lo)):
            apart = np.zeros(len(sa), dtype=bool)
            for k in range(3):
                apart |= lo[k] > box_hi[e, k] + MARGIN
                apart |= hi[k] < box_lo[e, k] - MARGIN
            apart_all &= apart
        out[a : a + len(sa)] = apart_all
    return out


def body_and_fingers(
    poses: StructuredPoses,
    index: NDArray[np.int64],
    gripper: GripperModel,
    spheres: FingerSpheres,
    object_points: Array,
    obstacle_points: Array,
    coarse: int = 24,
    chunk_points: int = 2_000_000,
    compiled: bool = True,
) -> BodyFingerVerdicts:
    """Algorithm 1's object, obstacle and finger tests for candidates ``index``
    (those clear of the table), per orientation with the samples as translations.

    In the gripper frame a candidate's object points are ``Q[o] - u[c]``:
    ``Q[o] = p_world R[o]`` once per orientation, ``u[c] = (A[s] + B[o]) R[o]``
    per candidate. Conservative bounds settle most candidates without a point:

    - the object's box in the gripper axes (``Q[o]``'s extremes less ``u``) apart
      from a body superellipsoid's box means no object point is inside it; apart
      from all of them, the body is clear;
    - a ball inscribed in a body superellipsoid that the object's distance grid
      proves to hold a point proves the hit (``_dense_grid.ObjectDistance``);
    - a finger whose sphere box is apart from the object's box holds none; for
      the others, a point whose nearest node of the finger's depth grid is deep
      inside its union of spheres is held, one far outside it is not
      (``_dense_grid.FingerDepth``).

    The rest get the exact tests: a subset of ``coarse`` points first (a hit by a
    subset is a hit), then every point in a superellipsoid's slab; the points the
    depth grid leaves undecided against the spheres listed at their node (or
    through the sphere grid of ``spheres``). With numba installed (and
    ``compiled``), the finger test is one compiled loop over every point instead
    (``_dense_numba``), with the same answers.

    The finger test counts the points each finger holds; the feasible
    candidates' holdings come back as ``Holdings``, computed and kept when they
    are few (up to ``_KEEP_ENTRIES`` bools), else built when something reads
    them, with the same kernels.
    """
    g, sp = gripper, spheres
    nf = int(g.num_fingers)
    n_or = len(poses.R)
    P = np.asarray(object_points, dtype=np.float64).reshape(-1, 3)
    X = np.asarray(obstacle_points, dtype=np.float64).reshape(-1, 3)
    no = len(P)
    se = (g.se_centers, g.se_semi_axes, g.se_exponent)
    se_lo, se_hi = g.se_centers - g.se_semi_axes, g.se_centers + g.se_semi_axes
    depth = finger_depth(sp, g.sphere_centers, g.sphere_radii, g.sphere_finger, nf)
    index = np.asarray(index, dtype=np.int64)
    s_all, o_all = np.divmod(index, n_or)
    proven = np.zeros(len(index), dtype=bool)
    clear_all: NDArray[np.bool_] | None = None
    bodies_compiled = compiled and _use_compiled(len(index) * no)
    # the ball proofs serve the numpy path; the compiled body loop tries a few
    # points first (near each body's centre, or spread over the cloud), which
    # settles those candidates faster
    if len(index) >= _BALLS_FROM and not bodies_compiled:
        # the object's box in the gripper axes per orientation: (O, 3) each
        ext_lo, ext_hi = _extremes(P, poses.R)
        clear_all = _boxes_clear(poses, s_all, o_all, ext_lo, ext_hi, se_lo, se_hi)
        near = ~clear_all
        ball_c, ball_r, body = inscribed_balls(*se)  # (b, 3), (b,), (b,)
        # per body the central ball first, bodies in turn
        rank = np.abs(ball_c - g.se_centers[body]).sum(axis=1)
        rank = np.argsort(np.argsort(rank, kind="stable"), kind="stable")
        within = np.empty(len(body), dtype=np.int64)
        for e in np.unique(body):
            mine = np.flatnonzero(body == e)
            within[mine[np.argsort(rank[mine], kind="stable")]] = np.arange(len(mine))
        first = np.lexsort((body, within))
        ball_c, ball_r, body = ball_c[first], ball_r[first], body[first]
        Bb = poses.B[:, None, :] + np.matmul(poses.R, ball_c.T).transpose(0, 2, 1)
        at_near = np.flatnonzero(near)
        proven[at_near] = ObjectDistance(P, ball_r).hits(
            poses.A, Bb, s_all[at_near], o_all[at_near], body
        )
    # the hint grid costs milliseconds to build (3.4 ms for 800 points here):
    # worth it for the many candidates of a dense search
    many = len(index) * no >= _COMPILED_FROM
    hints = NearestPoint(P) if bodies_compiled and many else None
    order = _grouped(o_all)  # candidates grouped by orientation
    k_all = len(index)
    reason = np.zeros(k_all, dtype=np.int64)
    contacts = np.zeros((k_all, nf), dtype=np.int64)
    step = max(1, chunk_points // max(no, len(X), 1))
    # 1. bodies: object, then obstacles
    if bodies_compiled:  # few calls: larger chunks, bounded by their points
        spans = _orientation_spans(o_all[order], max(no, len(X), 1))
    else:
        spans = [(a, min(a + step, k_all)) for a in range(0, k_all, step)]
    for a, b in spans:
        at = order[a:b]  # positions in index, orientation-sorted
        R, Q, ol, u = _chunk(poses, P, s_all[at], o_all[at])
        if clear_all is not None:
            clear = clear_all[at]
        elif bodies_compiled:  # the compiled loop skips the bodies apart itself
            clear = np.zeros(len(at), dtype=bool)
        else:
            Q_lo, Q_hi = Q.min(axis=2)[ol], Q.max(axis=2)[ol]  # (m, 3)
            clear = _object_box_clear(Q_lo, Q_hi, u, se_lo, se_hi)  # (m,)
        hit = proven[at] & ~clear
        todo = np.flatnonzero(~clear & ~hit)
        if todo.size and bodies_compiled:
            hit[todo] = _dense_numba.body_hits(
                Q, ol[todo], u[todo], *se, R=R, hints=hints
            )
            todo = todo[:0]
        if todo.size:
            # a subset first: a hit by some points is a hit by the cloud
            Qs = Q[:, :, :: max(1, no // max(coarse, 1))]
            x, y, z = (Qs[ol[todo], i] - u[todo, i, None] for i in range(3))
            hit[todo] = coordinates_in_superellipsoids(x, y, z, *se).any(axis=1)
            todo = todo[~hit[todo]]
        if todo.size > 2 * len(Q):
            hit[todo] = _body_hits(_Slabs(Q), ol, u, todo, *se)
        elif todo.size:  # few per orientation: every point beats sorting them
            x, y, z = (Q[ol[todo], i] - u[todo, i, None] for i in range(3))
            hit[todo] = coordinates_in_superellipsoids(x, y, z, *se).any(axis=1)
        reason[at[hit]] = 2
        alive = np.flatnonzero(~hit)
        if len(X) and alive.size:
            QX = _in_axes(X, R)  # (q, 3, nx)
            xclear = _object_box_clear(
                QX.min(axis=2)[ol[alive]],
                QX.max(axis=2)[ol[alive]],
                u[alive],
                se_lo,
                se_hi,
            )
            t = alive[~xclear]
            if t.size:
                x, y, z = (QX[ol[t], i] - u[t, i, None] for i in range(3))
                obs = coordinates_in_superellipsoids(x, y, z, *se).any(axis=1)
                reason[at[t[obs]]] = 3
    # 2. fingers, for the candidates clear of every body: how many points each
    # finger holds (the holdings themselves are built for the feasible ones only
    # when something asks for them, see ``Holdings``)
    live = np.flatnonzero(reason == 0)  # positions in index, ascending
    if live.size == 0:
        return BodyFingerVerdicts(
            reason, contacts, Holdings.of(np.zeros((0, no, nf), dtype=bool))
        )
    # (the live candidates are some of those tested: the same path)
    fingers = _Fingers(poses, P, sp, depth, step, bodies_compiled, many)
    given = None
    if bodies_compiled and not many and len(spans) == 1:
        # one chunk held every candidate, and the finger loop reads the points
        # in their own order: its rows serve the finger test too
        inv = np.empty(k_all, dtype=np.int64)
        inv[order] = np.arange(k_all)
        given = (Q, ol[inv[live]], u[inv[live]])
    if len(live) * no * nf <= _KEEP_ENTRIES:
        # few: the holdings themselves, counted, and the feasible ones kept
        held, counts = fingers.holding_and_counts(s_all[live], o_all[live], given)
    else:
        counts = fingers.counts(s_all[live], o_all[live])
    contacts[live] = counts
    ok = np.all(counts > 0, axis=1)
    reason[live[~ok]] = 4
    keep = live[ok]
    if len(live) * no * nf <= _KEEP_ENTRIES:
        holdings = Holdings(counts[ok], no, dense=held[ok])
    else:
        rows = fingers.rows_of(s_all[keep], o_all[keep])
        holdings = Holdings(counts[ok], no, rows=rows)
    return BodyFingerVerdicts(reason, contacts, holdings)


_small_searches = 0


def _use_compiled(pairs: int) -> bool:
    """Whether a test of ``pairs`` (candidate, point) pairs runs the compiled
    loops: with numba installed, from ``_COMPILED_FROM`` pairs on (loading the
    loops if need be); below, once they are loaded, or from the
    ``_SMALL_BEFORE_LOADING + 1``-th test of ``_SMALL_FROM`` pairs or more in
    the process on. Loading costs 0.3-0.4 s once per process
    (``_dense_numba``); on a small set the loops take under half the time of
    numpy's tests (the Franka hand's Table I: body and finger tests 2.8 -> 1.2
    ms), so a process that plans a scene or two never loads them and one that
    plans many pays once. The answers are the same either way."""
    global _small_searches
    if not _dense_numba.available():
        return False
    if pairs >= _COMPILED_FROM or _dense_numba.loaded():
        return True
    if pairs < _SMALL_FROM:  # too few to be worth loading for
        return False
    _small_searches += 1
    return _small_searches > _SMALL_BEFORE_LOADING


class _Fingers:
    """The finger test of structured candidates ``(s, o)``: per finger the number
    of points held (for the verdicts and contacts), and the holdings themselves
    (for the candidates something asks about), with the same answers.

    The compiled loop, when ``compiled``, is the one installed when this was
    built, so that holdings asked for later come from the same kernel.
    """

    def __init__(
        self,
        poses: StructuredPoses,
        P: Array,
        spheres: FingerSpheres,
        depth: FingerDepth,
        step: int,
        compiled: bool,
        ordered: bool = True,
    ) -> None:
        self.poses, self.P, self.sp, self.depth = poses, P, spheres, depth
        # each finger's box of spheres, gripper frame: (nf, 3) each
        self.f_lo, self.f_hi, self.step = depth.box_lo, depth.box_hi, step
        # (the compiled loop sums 16-bit lanes: fewer than 2**16 points)
        few = len(P) < 2**16
        # one kernel counts, and writes the holdings when asked
        self.loop = _dense_numba.load()[0] if compiled and few else None
        # the compiled loop reads the points in space order where ``ordered``
        # (many candidates): the depth grid's nodes it reads then follow one
        # another in memory (the Allegro's dense counts 20 % faster than in the
        # cloud's own, farthest-first order); it writes each holding to the
        # point's own column (``perm``). Sorting costs more than it saves on a
        # few hundred candidates (0.13 ms of the Franka hand's Table I search).
        ordering = compiled and few and ordered
        self.perm = _space_order(P) if ordering else np.arange(len(P))
        self.P_counts = P[self.perm] if ordering else P
        self.nf = len(self.f_lo)
        lo, hi = self.f_lo.min(axis=0), self.f_hi.max(axis=0)  # the fingers' box
        self.k = int(np.argmin(hi - lo))  # its thinnest gripper axis
        self.width = float(hi[self.k] - lo[self.k])

    def _groups(
        self, s: NDArray[np.int64], o: NDArray[np.int64], P: Array | None = None
    ) -> Iterator[tuple[NDArray[np.int64], Array, NDArray[np.int64], Array, Any]]:
        """Chunks of candidates grouped by orientation, as ``(rows, Q, ol, u,
        need)``: positions ``rows`` (m,) into ``s``, the chunk's arrays as
        :func:`_chunk` gives them (for the points ``P``, by default the
        object's), and ``need``: the chunk's candidates with some finger's
        sphere box meeting the object's box."""
        order = _grouped(o)  # rows grouped by orientation
        for a in range(0, len(s), self.step):
            rows = order[a : a + self.step]
            _, Q, ol, u = _chunk(
                self.poses, self.P if P is None else P, s[rows], o[rows]
            )
            lo = (Q.min(axis=2)[ol] - u)[:, None, :]  # (m, 1, 3)
            hi = (Q.max(axis=2)[ol] - u)[:, None, :]
            apart = _separated(lo, hi, self.f_lo[None], self.f_hi[None])  # (m, nf)
            need = np.flatnonzero(~apart.all(axis=1))
            if need.size:
                yield rows, Q, ol, u, need

    def counts(self, s: NDArray[np.int64], o: NDArray[np.int64]) -> NDArray[np.int64]:
        """Points held per candidate and finger: (k, nf) int."""
        out = np.zeros((len(s), self.nf), dtype=np.int64)
        if self.loop is not None:
            for rows, Q, ol, u, need in self._groups(s, o, self.P_counts):
                out[rows[need]] = _dense_numba.count_by_fingers(
                    self.depth, Q, ol[need], u[need], loop=self.loop
                )
            return out
        for rows, Q, ol, u, need in self._groups(s, o):
            ext = float(np.ptp(Q[:, self.k, :], axis=1).max()) if Q.size else 0.0
            slab = self.width < 0.5 * ext  # the slab leaves most points out
            if len(need) >= _DEPTH_FROM and not (slab and len(need) >= 8 * len(Q)):
                out[rows[need]] = _count_depth(self.depth, self.sp, Q, ol, u, need)
            elif slab and len(need) >= 2 * len(Q):
                out[rows[need]] = _count_in_slab(
                    _Slabs(Q), ol, u, need, self.sp, self.k, self.f_lo, self.f_hi
                )
            else:
                out[rows[need]] = _count_every_point(self.sp, Q, ol, u, need)
        return out

    def rows_of(
        self, s: NDArray[np.int64], o: NDArray[np.int64]
    ) -> Callable[[NDArray[np.int64]], NDArray[np.bool_]]:
        """``rows(i)``: the holdings of candidates ``(s[i], o[i])``, (k, no, nf)."""

        def rows(i: NDArray[np.int64]) -> NDArray[np.bool_]:
            return self.holding(s[i], o[i])

        return rows

    def holding(self, s: NDArray[np.int64], o: NDArray[np.int64]) -> NDArray[np.bool_]:
        """Which object points each finger holds: (k, no, nf) bool."""
        return self.holding_and_counts(s, o)[0]

    def holding_and_counts(
        self,
        s: NDArray[np.int64],
        o: NDArray[np.int64],
        given: tuple[Array, NDArray[np.int64], Array] | None = None,
    ) -> tuple[NDArray[np.bool_], NDArray[np.int64]]:
        """Which object points each finger holds, (k, no, nf) bool, and how
        many, (k, nf) int. ``given``: the candidates' ``Q, ol, u`` as
        :func:`_chunk` gives them for the points in their own order, to the
        compiled loop without chunking again (it counts every candidate)."""
        out = np.zeros((len(s), len(self.P), self.nf), dtype=bool)
        if self.loop is not None:
            counts = np.zeros((len(s), self.nf), dtype=np.int64)
            if given is not None and self.P_counts is self.P:
                every = np.arange(len(s))
                groups: Iterable[tuple[Any, ...]] = [(every, *given, every)]
            else:
                groups = self._groups(s, o, self.P_counts)
            for rows, Q, ol, u, need in groups:
                dest = rows[need]
                counts[dest] = _dense_numba.count_by_fingers(
                    self.depth, Q, ol[need], u[need], self.loop, self.perm, out, dest
                )
            return out, counts
        for rows, Q, ol, u, need in self._groups(s, o):
            dest = rows[need]
            if len(need) >= _DEPTH_FROM and len(need) < 8 * len(Q):
                # few candidates per orientation: sorting the points per
                # orientation for the slab costs more than the depth grid saves
                out[dest] = _held_numpy(self.depth, self.sp, Q, ol, u, need)
            else:
                out[dest] = _held_in_slab(
                    _Slabs(Q), ol, u, need, self.sp, self.f_lo, self.f_hi, self.depth
                )
        return out, count_held(out)


def _space_order(P: Array, cell: float = 0.01) -> NDArray[np.int64]:
    """An order of the points ``P`` (n, 3) that keeps near points near: by
    ``cell`` voxel, rows of voxels along z (the lexicographic order of the
    voxel indices): (n,) int."""
    if len(P) == 0:
        return np.zeros(0, dtype=np.int64)
    g = np.floor((P - P.min(axis=0)) / cell).astype(np.int64)  # (n, 3) voxels
    return np.lexsort((g[:, 2], g[:, 1], g[:, 0]))


def _count_depth(
    depth: FingerDepth,
    sp: FingerSpheres,
    Q: Array,
    ol: NDArray[np.int64],
    u: Array,
    c: NDArray[np.int64],
) -> NDArray[np.int64]:
    """Points held per finger for candidates ``c`` (n,): the depth grid counts
    the points it proves held; a point it leaves unsure for a finger is tested
    against the few spheres listed at its node (``FingerDepth.sphere_lists``),
    with the sphere grid's arithmetic: (n, nf) int."""
    counts, code, flat = depth.counts(Q, ol[c], u[c])  # (n, nf), (n, no) × 2
    no = code.shape[1]
    # np.take on flat indices: several times faster than fancy indexing here
    unsure = np.flatnonzero(np.take(depth.unsure_codes, code))  # (pairs,) flat
    open_f = depth.unsure_fingers
    node_id, lists, centers, radii = depth.sphere_lists()
    pad = len(radii) - 1  # the padding's sphere, of radius 0
    n = len(c)
    Qf = Q.reshape(-1)  # (q * 3 * no,)
    for b in range(0, len(unsure), _CHUNK_LISTED):  # bounds the temporaries
        at = unsure[b : b + _CHUNK_LISTED]
        rb, jb = np.divmod(at, no)
        cb = np.take(c, rb)
        base = np.take(ol, cb) * (3 * no) + jb  # Q[ol[cb], 0, jb], flat
        x = np.take(Qf, base) - np.take(u[:, 0], cb)  # (pairs,) gripper frame
        y = np.take(Qf, base + no) - np.take(u[:, 1], cb)
        z = np.take(Qf, base + 2 * no) - np.take(u[:, 2], cb)
        nid = np.take(node_id, np.take(flat, at))  # all >= 0: the nodes are unsure
        todo = open_f[np.take(code, at)]  # (pairs, nf) the fingers left open
        for f in range(todo.shape[1]):
            p = np.flatnonzero(todo[:, f])  # pairs open for finger f
            mine = lists[np.take(nid, p), f]  # (p, K) candidate spheres, padded
            held = np.zeros(len(p), dtype=bool)
            act = np.arange(len(p))
            for t in range(mine.shape[1]):
                sid = mine[act, t]
                real = sid != pad  # a list ends at its first padding
                act, sid = act[real], sid[real]
                if act.size == 0:
                    break
                pa = np.take(p, act)
                dx = np.take(x, pa) - np.take(centers[:, 0], sid)
                dy = np.take(y, pa) - np.take(centers[:, 1], sid)
                dz = np.take(z, pa) - np.take(centers[:, 2], sid)
                r = np.take(radii, sid)
                inside = dx * dx + dy * dy + dz * dz < r * r
                held[act[inside]] = True
                act = act[~inside]
            counts[:, f] += np.bincount(rb[p[held]], minlength=n)
    return counts


def _count_in_slab(
    slabs: _Slabs,
    ol: NDArray[np.int64],
    u: Array,
    cand: NDArray[np.int64],
    spheres: FingerSpheres,
    k: int,
    f_lo: Array,
    f_hi: Array,
) -> NDArray[np.int64]:
    """Points held per finger for candidates ``cand`` (n,), testing only the
    points in the slab of the fingers' sphere box along gripper axis ``k`` (the
    others are outside every sphere): (n, nf) int."""
    lo, hi = float(f_lo[:, k].min()), float(f_hi[:, k].max())
    pair, j, r = slabs.pairs(ol[cand], u[cand, k], k, lo, hi)
    counts = np.zeros((len(cand), len(f_lo)), dtype=np.int64)
    for b, _, held in _slab_pairs_held(slabs.Q, u, cand, pair, j, r, spheres):
        for f in range(held.shape[1]):
            counts[:, f] += np.bincount(pair[b][held[:, f]], minlength=len(cand))
    return counts


def _slab_pairs_held(
    Q: Array,
    u: Array,
    cand: NDArray[np.int64],
    pair: NDArray[np.int64],
    j: NDArray[np.int64],
    r: NDArray[np.int64],
    spheres: FingerSpheres,
) -> Iterator[tuple[slice, NDArray[np.int64], NDArray[np.bool_]]]:
    """The slab's (candidate, point) pairs through the sphere grid, in chunks
    that bound the sphere lists' memory: per chunk, its slice of the pairs, their
    points ``j`` and which fingers hold each (pairs, nf)."""
    c = cand[pair]
    n = Q.shape[2]
    Qf = np.ascontiguousarray(Q).reshape(-1)  # (q * 3 * n,)
    uT = np.ascontiguousarray(u.T)  # (3, m) a row per axis
    for a in range(0, len(pair), _CHUNK_PAIRS):
        b = slice(a, a + _CHUNK_PAIRS)
        jb, cb = j[b], c[b]
        base = r[b] * (3 * n) + jb  # Q[r, 0, j], flat
        held = spheres.holding_coordinates(
            Qf[base] - uT[0, cb], Qf[base + n] - uT[1, cb], Qf[base + 2 * n] - uT[2, cb]
        )  # (pairs, nf)
        yield b, jb, held


def _every_point_held(
    sp: FingerSpheres,
    Q: Array,
    ol: NDArray[np.int64],
    u: Array,
    cand: NDArray[np.int64],
) -> Iterator[tuple[slice, NDArray[np.bool_]]]:
    """Every point of candidates ``cand`` through the sphere grid, as contiguous
    rows in chunks: per chunk, its slice of ``cand`` and the holdings
    (b, no, nf)."""
    step = max(1, _CHUNK_PAIRS // max(Q.shape[2], 1))
    for a in range(0, len(cand), step):
        cb = cand[a : a + step]
        rb = ol[cb]
        held = sp.holding_coordinates(*(Q[rb, i] - u[cb, i, None] for i in range(3)))
        yield slice(a, a + step), held


def _count_every_point(
    sp: FingerSpheres,
    Q: Array,
    ol: NDArray[np.int64],
    u: Array,
    cand: NDArray[np.int64],
) -> NDArray[np.int64]:
    """Points held per finger for candidates ``cand`` (n,), every point through
    the sphere grid: (n, nf) int."""
    counts = np.empty((len(cand), sp.num_fingers), dtype=np.int64)
    for b, held in _every_point_held(sp, Q, ol, u, cand):
        counts[b] = count_held(held)
    return counts


def _grouped(o: NDArray[np.int64]) -> NDArray[np.int64]:
    """The stable order of ``o`` (k,) (orientation indices): numpy's radix sort
    where they fit 16 bits (5 times faster than its merge sort on the Franka's
    378,000 dense candidates), else its stable sort."""
    o = np.asarray(o, dtype=np.int64)
    if len(o) and 0 <= o.min() and o.max() < 2**16:
        return np.argsort(o.astype(np.uint16), kind="stable")
    return np.argsort(o, kind="stable")


def _orientation_spans(
    o_sorted: NDArray[np.int64], n_points: int
) -> list[tuple[int, int]]:
    """Chunks ``[a, b)`` of candidates sorted by orientation ``o_sorted`` (k,)
    that hold at most ``_SPAN_CANDIDATES`` candidates and whose orientations'
    points (``n_points`` each, 3 coordinates) number at most ``_SPAN_POINTS``."""
    k = len(o_sorted)
    if k == 0:
        return []
    # (np.r_ costs 30 us a call here: a tenth of the Franka's Table I chunking)
    starts = np.flatnonzero(o_sorted[1:] != o_sorted[:-1]) + 1
    starts = np.concatenate((np.zeros(1, dtype=starts.dtype), starts))
    per_group = max(1, _SPAN_POINTS // max(3 * n_points, 1))
    spans = []
    a = 0
    g = 0  # the group where the chunk starts
    n_groups = len(starts)
    while a < k:
        # at most per_group orientations, and at most _SPAN_CANDIDATES candidates
        g_end = min(g + per_group, n_groups)
        b = int(starts[g_end]) if g_end < n_groups else k
        b = min(b, a + _SPAN_CANDIDATES)
        spans.append((a, b))
        a = b
        g = int(np.searchsorted(starts, a, side="right")) - 1
    return spans


def _chunk(
    poses: StructuredPoses, P: Array, s: NDArray[np.int64], o: NDArray[np.int64]
) -> tuple[Array, Array, NDArray[np.int64], Array]:
    """For candidates ``(s, o)`` (m,): the rotations of their orientations ``R``
    (q, 3, 3), the object points in those axes ``Q`` (q, 3, no), each candidate's
    row ``ol`` (m,) and translation ``u`` (m, 3) (its points are ``Q[ol] - u``)."""
    o = np.asarray(o, dtype=np.int64)
    change = o[1:] != o[:-1]
    if len(o) and np.all(o[1:] >= o[:-1]):  # grouped (the callers' order)
        used = np.concatenate((o[:1], o[1:][change]))
        ol = np.zeros(len(o), dtype=np.int64)
        np.cumsum(change, out=ol[1:])
    else:
        used, ol = np.unique(o, return_inverse=True)
    R = poses.R[used]  # (q, 3, 3)
    Q = _in_axes(P, R)  # (q, 3, no) gripper axes, untranslated
    # u = w R[ol] with w = A[s] + B[o] the gripper origins (world frame), one
    # coordinate at a time from 1-D gathers (row gathers of (m, 3) arrays and a
    # batched (1, 3) @ (3, 3) product per candidate are several times slower)
    A, B = poses.columns()
    w = [np.take(A[i], s) + np.take(B[i], o) for i in range(3)]  # 3 × (m,)
    u = np.empty((len(o), 3))
    Rt = np.ascontiguousarray(R.transpose(1, 2, 0))  # (3, 3, q): Rt[i, k] per row
    for k in range(3):
        u[:, k] = w[0] * np.take(Rt[0, k], ol)
        u[:, k] += w[1] * np.take(Rt[1, k], ol)
        u[:, k] += w[2] * np.take(Rt[2, k], ol)
    return R, Q, ol.reshape(-1), u


def _held_numpy(
    depth: FingerDepth,
    sp: FingerSpheres,
    Q: Array,
    ol: NDArray[np.int64],
    u: Array,
    c: NDArray[np.int64],
) -> NDArray[np.bool_]:
    """Which object points each finger holds for candidates ``c``: the depth grid
    decides most, the sphere grid the points it leaves unsure: (n, no, nf)."""
    hold, unsure = depth.held_points(Q, ol[c], u[c])  # (n, no, nf), (n, no)
    row, j = np.nonzero(unsure)
    for b in range(0, len(row), _CHUNK_PAIRS):  # bounds the sphere lists
        rb, jb = row[b : b + _CHUNK_PAIRS], j[b : b + _CHUNK_PAIRS]
        cb = c[rb]
        qb = ol[cb]
        hold[rb, jb] = sp.holding_coordinates(
            Q[qb, 0, jb] - u[cb, 0],
            Q[qb, 1, jb] - u[cb, 1],
            Q[qb, 2, jb] - u[cb, 2],
        )  # (pairs, nf)
    return hold


def _in_axes(P: Array, R: Array) -> Array:
    """Points ``P`` (n, 3) in the axes of each rotation ``R`` (q, 3, 3), ``P @
    R[o]`` per row: (q, 3, n) (one batched product; an einsum is 20× slower)."""
    return np.matmul(R.transpose(0, 2, 1), P.T)


def _extremes(P: Array, R: Array) -> tuple[Array, Array]:
    """Smallest and largest coordinates of the points ``P`` (n, 3) in the axes
    of each rotation ``R`` (O, 3, 3): (O, 3) each, ``P @ R[o]``'s extremes."""
    lo = np.empty((len(R), 3))
    hi = np.empty((len(R), 3))
    step = max(1, 2_000_000 // max(3 * len(P), 1))
    for a in range(0, len(R), step):
        Q = _in_axes(P, R[a : a + step])  # (q, 3, n)
        lo[a : a + step], hi[a : a + step] = Q.min(axis=2), Q.max(axis=2)
    return lo, hi


class _Slabs:
    """Per orientation, the points sorted along each gripper axis, so that the
    points of a candidate inside a slab ``lo <= (Q - u)_k <= hi`` are one range.

    ``Q`` (q, 3, n) are the points per orientation in the gripper axes. An axis is
    sorted when a search along it first needs it (the body and finger tests
    search along one or two).
    """

    def __init__(self, Q: Array) -> None:
        self.Q = Q
        q, _, self.n = Q.shape
        self.span = float(np.ptp(Q) + 1.0) if Q.size else 1.0
        self.q_min = float(Q.min()) if Q.size else 0.0
        self.q_max = float(Q.max()) if Q.size else 0.0
        self.rows = np.arange(q)
        # per axis: the sorting order (q * n,) of each row, flat, and the sorted
        # coordinates (q * n,), rows end to end, each shifted clear of the last
        self._rank: dict[int, NDArray[np.int64]] = {}
        self._flat: dict[int, Array] = {}

    def _axis(self, k: int) -> tuple[NDArray[np.int64], Array]:
        if k not in self._flat:
            Qk = self.Q[:, k]  # (q, n)
            rank = Qk.argsort(axis=1)  # (q, n)
            shift = 4.0 * self.span * self.rows[:, None]  # (q, 1)
            self._flat[k] = (Qk[self.rows[:, None], rank] + shift).ravel()
            self._rank[k] = rank.reshape(-1)
        return self._rank[k], self._flat[k]

    def pairs(
        self, row: NDArray[np.int64], uk: Array, k: int, lo: float, hi: float
    ) -> tuple[NDArray[np.int64], NDArray[np.int64], NDArray[np.int64]]:
        """For candidates in rows ``row`` (m,) translated by ``uk`` (m,) along axis
        ``k``: every (candidate, point) with the point in the slab, as the
        candidate's position in ``row``, the point's index and its row.

        The slab is widened by 1e-7 m, so rounding in the shifted search can only
        add points (tested exactly later), never drop one.
        """
        if len(row) == 0 or self.n == 0:
            empty = np.zeros(0, dtype=np.int64)
            return empty, empty, empty
        rank, flat = self._axis(k)
        # a slab beyond every point holds none: the translation is clipped to
        # where the slab still reaches a metre past the points, which keeps the
        # search inside the candidate's row (np.clip, without its wrapper)
        uk = np.minimum(np.maximum(uk, self.q_min - hi - 1.0), self.q_max - lo + 1.0)
        off = 4.0 * self.span * row
        i0 = flat.searchsorted(lo + uk - 1e-7 + off, side="left")
        i1 = flat.searchsorted(hi + uk + 1e-7 + off, side="right")
        # the search can only land in the candidate's own row
        i0 = np.maximum(i0, row * self.n)
        i1 = np.minimum(i1, (row + 1) * self.n)
        counts = np.maximum(i1 - i0, 0)
        total = int(counts.sum())
        if total == 0:
            empty = np.zeros(0, dtype=np.int64)
            return empty, empty, empty
        pair = np.repeat(np.arange(len(row)), counts)  # (total,)
        start = np.repeat(i0 - (np.cumsum(counts) - counts), counts)
        pos = start + np.arange(total)
        r = pos // self.n
        j = rank[pos]  # the point at sorted position pos - r n of row r
        return pair, j, r


def _held_in_slab(
    slabs: _Slabs,
    ol: NDArray[np.int64],
    u: Array,
    cand: NDArray[np.int64],
    spheres: FingerSpheres,
    f_lo: Array,
    f_hi: Array,
    depth: FingerDepth | None = None,
) -> NDArray[np.bool_]:
    """Which object points each finger's spheres hold, for candidates ``cand``,
    testing only the points in the slab of the fingers' sphere box along its
    thinnest gripper axis (the others are outside every sphere); where the slab
    holds most points, every point (through ``depth`` first, when given).

    Returns
    -------
    (n, no, nf) bool
    """
    Q = slabs.Q
    nf = len(f_lo)
    lo, hi = f_lo.min(axis=0), f_hi.max(axis=0)  # the fingers' box, gripper frame
    k = int(np.argmin(hi - lo))
    pair, j, r = slabs.pairs(ol[cand], u[cand, k], k, float(lo[k]), float(hi[k]))
    many = len(cand) >= _DEPTH_FROM  # below, the depth grid saves less than it costs
    if depth is not None and many and len(pair) > 0.25 * len(cand) * slabs.n:
        return _held_numpy(depth, spheres, Q, ol, u, cand)
    if len(pair) > 0.5 * len(cand) * slabs.n:
        # the slab holds most points: every point, as contiguous rows, is cheaper
        held = np.empty((len(cand), slabs.n, nf), dtype=bool)
        for b, rows in _every_point_held(spheres, Q, ol, u, cand):
            held[b] = rows
        return held
    held = np.zeros((len(cand), slabs.n, nf), dtype=bool)
    for b, jb, pairs_held in _slab_pairs_held(Q, u, cand, pair, j, r, spheres):
        held[pair[b], jb] = pairs_held
    return held


def _body_hits(
    slabs: _Slabs,
    ol: NDArray[np.int64],
    u: Array,
    cand: NDArray[np.int64],
    centers: Array,
    semi_axes: Array,
    exponent: float,
) -> NDArray[np.bool_]:
    """Whether some point lies inside some superellipsoid, for candidates
    ``cand``: per superellipsoid, only the candidates not yet hit and only the
    points in its slab along its thinnest axis, narrowed by the box along the
    other two before eq. (1) (:func:`_inside_narrowing`): (n,) bool."""
    n = slabs.n
    Qf = np.ascontiguousarray(slabs.Q).reshape(-1)  # (q * 3 * n,)
    uT = np.ascontiguousarray(u.T)  # (3, m) a row per axis
    hit = np.zeros(len(cand), dtype=bool)
    lo_all, hi_all = centers - semi_axes, centers + semi_axes
    for e in np.argsort(-np.prod(semi_axes, axis=1)):  # largest first
        k = int(np.argmin(semi_axes[e]))
        todo = np.flatnonzero(~hit)
        if todo.size == 0:
            break
        c0 = cand[todo]
        pair, j, r = slabs.pairs(
            ol[c0], u[c0, k], k, float(lo_all[e, k]), float(hi_all[e, k])
        )
        if len(pair) == 0:
            continue
        c = c0[pair]
        base = r * (3 * n) + j  # (p,) Q[r, 0, j], flat
        others = [i for i in np.argsort(semi_axes[e], kind="stable") if i != k]
        inside = _inside_narrowing(
            lambda i, at: Qf[base[at] + i * n] - uT[i, c[at]],
            len(base),
            centers[e],
            semi_axes[e],
            exponent,
            (int(others[0]), int(others[1]), k),  # the slab's axis holds them all
        )
        hit[todo[pair[inside]]] = True
    return hit


def _inside_narrowing(
    coordinate: Callable[[int, NDArray[np.int64]], Array],
    count: int,
    center: Array,
    semi_axes: Array,
    exponent: float,
    axes: tuple[int, int, int],
) -> NDArray[np.int64]:
    """Which of ``count`` points lie strictly inside the superellipsoid
    ``center``, ``semi_axes`` (3,): their indices. ``coordinate(i, at)`` gives the
    points ``at``'s coordinates along axis ``i``. The box test one axis at a time
    in the order ``axes``, keeping only the points inside so far, then eq. (1)
    for the points in the box: per point the arithmetic of
    ``coordinates_in_superellipsoids``."""
    at = np.arange(count)
    d: dict[int, Array] = {}  # per axis done: |coordinate - centre| of the points at
    for i in axes:
        di = np.abs(coordinate(i, at) - center[i])  # (a,)
        keep = np.flatnonzero(di < semi_axes[i])
        at = at[keep]
        d = {a: x[keep] for a, x in d.items()}
        d[i] = di[keep]
    value = (
        _power(d[0] / semi_axes[0], exponent)
        + _power(d[1] / semi_axes[1], exponent)
        + (d[2] / semi_axes[2]) ** 2
    )
    return at[value < 1.0]
