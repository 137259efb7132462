"""Stage 1, the table: which candidates put the gripper cloud inside the table
superellipsoid (Algorithm 1, line 9).

Per orientation, the gripper cloud's heights above the table differ between
samples by one shift (``wsgrasp.planning.poses``), so the cloud's support
function along the table normal decides most candidates at once: the lowest
cloud point of an orientation is the same vertex of the cloud's convex hull for
every sample, and its height is ``h[o] + n · A[s]``. A candidate whose lowest
point is above the table superellipsoid's top cannot touch it (every point has
``(z - z0)^2 / c^2 > 1``); one whose lowest point, or the vertex nearest the
slab's middle height, is inside it is in collision. Only the few others need the
exact test over the whole cloud. Both bounds keep a margin of ``MARGIN`` so that
a verdict decided here is the one every evaluation of eq. (1) in floating point
gives.
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np
from numpy.typing import NDArray

from wsgrasp.geometry import invert_transforms
from wsgrasp.geometry._superellipsoid import _power
from wsgrasp.gripper.model import GripperModel
from wsgrasp.planning.poses import (
    MARGIN,
    StructuredPoses,
    TableSE,
    grouped,
    one_thread_block,
)
from wsgrasp.planning.poses import hull_vertices as _hull_vertices

__all__ = ["TableVerdicts", "table_verdicts"]

Array = NDArray[np.float64]

#: at most this many candidates' intermediate arrays at once (bounds memory)
_CHUNK_CANDIDATES = 262_144


@dataclass
class TableVerdicts:
    """What the table test found for every candidate ``C``.

    Attributes
    ----------
    hit : (C,) bool
        The gripper cloud enters the table superellipsoid.
    """

    hit: NDArray[np.bool_]
    poses: StructuredPoses
    vertices: Array
    table: TableSE

    def lowest_heights(self, index: NDArray[np.int64]) -> Array:
        """Height above the table surface of the lowest gripper-cloud point, for
        the candidates ``index`` (k,): per orientation the lowest hull vertex's
        height without the sample's part, plus the sample's shift: (k,)."""
        poses, vertices = self.poses, self.vertices
        T_table_world = invert_transforms(self.table.T_world_table)
        R_tw, t_tw = T_table_world[:3, :3], T_table_world[:3, 3]
        n_or = len(poses.R)
        s, o = np.divmod(np.asarray(index, dtype=np.int64), n_or)
        if len(vertices) == 0:
            return np.full(len(s), np.inf)
        z_axes = poses.R.transpose(0, 2, 1) @ R_tw[2]  # (O, 3) normal, gripper axes
        step = one_thread_block(len(vertices))  # orientations per product
        low = np.concatenate(
            [
                (vertices @ z_axes[a : a + step].T).min(axis=0)
                for a in range(0, len(z_axes), step)
            ]
            or [np.zeros(0)]
        )  # (O,)
        low = low + poses.B @ R_tw[2] + t_tw[2]
        return low[o] + poses.A[s] @ R_tw[2]  # type: ignore[no-any-return]


def table_verdicts(
    poses: StructuredPoses, gripper: GripperModel, table: TableSE
) -> TableVerdicts:
    """The table test of every candidate of ``poses``: the support-function
    bounds decide most, the exact test over the whole cloud the rest."""
    hull = _cloud_hull(gripper)
    hit, unsure = _bounds(poses, hull, table)
    idx = np.flatnonzero(unsure)
    if idx.size:
        cloud = np.ascontiguousarray(gripper.cloud, dtype=np.float64)
        hit[idx] = _exact(poses, cloud, table, idx)
    return TableVerdicts(hit, poses, hull, table)


def _cloud_hull(gripper: GripperModel) -> Array:
    """The gripper cloud's convex-hull vertices, computed once and kept on the
    model (as its other derived lookups are)."""
    hull = gripper.__dict__.get("_cloud_hull")
    if hull is None:
        hull = _hull_vertices(np.ascontiguousarray(gripper.cloud, dtype=np.float64))
        gripper.__dict__["_cloud_hull"] = hull
    return hull  # type: ignore[no-any-return]


def _bounds(
    poses: StructuredPoses, vertices: Array, table: TableSE
) -> tuple[NDArray[np.bool_], NDArray[np.bool_]]:
    """The table test decided from two points of each candidate's gripper cloud.

    Per orientation the lowest point (the support vertex along the normal) and
    the point nearest the middle of the table superellipsoid's slab are found
    once (a sorted row and one ``searchsorted`` per candidate).

    Parameters
    ----------
    poses : StructuredPoses
    vertices : (h, 3) float
        Gripper-frame points that include the cloud's convex hull vertices.
    table : TableSE

    Returns
    -------
    hit : (C,) bool
        Certainly in collision: one of the two points is inside (eq. (1) below
        ``1 - MARGIN``).
    unsure : (C,) bool
        Neither proven: the exact test decides these. The others (neither flag)
        certainly clear the table: their lowest point is above the
        superellipsoid's top by more than ``MARGIN``.
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
    # each orientation's lowest vertex, a row per axis: (3, O)
    lowest = np.ascontiguousarray(P[np.arange(n_or), order[:, 0]].T)
    top = float(table.center[2] + table.semi_axes[2])
    ns = len(M)
    # (samples, orientations), as the candidates are numbered (s * O + o)
    hit = np.zeros((ns, n_or), dtype=bool)
    unsure = np.zeros((ns, n_or), dtype=bool)
    # blocks of samples, every orientation: a candidate's lowest height is a
    # broadcast sum of its orientation's part and its sample's, and the low
    # ones come with their sample and orientation (no division of indices)
    rows = max(1, _CHUNK_CANDIDATES // n_or)
    for a in range(0, ns, rows):
        Mb = M[a : a + rows]  # (b, 3)
        # a candidate whose lowest point is above the top by MARGIN has both
        # points above it (the rounding of the shifted heights keeps their
        # order): eq. (1)'s z term alone exceeds 1, so neither is inside and
        # nothing is left to compute (43 % of the Allegro's dense candidates)
        low = lowest[2] + Mb[:, 2, None] <= top + MARGIN  # (b, O)
        # the lowest vertex, then for the others the vertex nearest the slab's
        # middle height
        s, o = np.nonzero(low)  # (l,) each
        s += a
        x, y, z = (lowest[k][o] + M[s, k] for k in range(3))
        first = _inside(x, y, z, table)
        inside = np.zeros_like(low)
        inside[s[first] - a, o[first]] = True
        s, o = s[~first], o[~first]
        shift = M[s, 2]
        target = table.center[2] - shift + span * o
        j = np.clip(np.searchsorted(flat, target) - o * nv, 0, nv - 1)
        p = P[o, order[o, j]] + M[s]  # (r, 3)
        second = _inside(p[:, 0], p[:, 1], p[:, 2], table)
        inside[s[second] - a, o[second]] = True
        # the rest against every vertex (of the Allegro's dense candidates, 8,968
        # are left here, 8,944 of them with a vertex inside: the hand's lowest
        # vertex below the slab and the one nearest its middle beyond its edge)
        s, o = s[~second], o[~second]
        step = max(1, 500_000 // max(nv, 1))  # (k, h) temporaries: 4 MB each
        for b in range(0, len(s), step):
            sb, ob = s[b : b + step], o[b : b + step]
            p = P[ob]  # (k, h, 3)
            x, y, z = (p[:, :, k] + M[sb, k, None] for k in range(3))
            any_in = _inside(x, y, z, table).any(axis=1)
            inside[sb[any_in] - a, ob[any_in]] = True
        hit[a : a + rows] = inside
        unsure[a : a + rows] = low & ~inside
    return hit.reshape(-1), unsure.reshape(-1)


def _inside(x: Array, y: Array, z: Array, table: TableSE) -> NDArray[np.bool_]:
    """Points with table-frame coordinates ``x``, ``y``, ``z`` (any one shape)
    inside the table superellipsoid by more than ``MARGIN`` in eq. (1)'s value,
    ``(|x - x0| / a)^l + (|y - y0| / b)^l + (|z - z0| / c)^2``: (...) bool."""
    c, e, l_ = table.center, table.semi_axes, table.exponent
    dz = np.abs(z - c[2]) / e[2]
    value = _power(np.abs(x - c[0]) / e[0], l_)
    value += _power(np.abs(y - c[1]) / e[1], l_)
    value += dz * dz
    return value < 1.0 - MARGIN  # type: ignore[no-any-return]


def _exact(
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
    by_o = grouped(o_all)  # a chunk spans few orientations
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
