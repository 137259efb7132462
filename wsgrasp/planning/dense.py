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

from dataclasses import dataclass
from typing import TYPE_CHECKING

import numpy as np
from numpy.typing import NDArray
from scipy.spatial import ConvexHull, QhullError

from wsgrasp.geometry import invert_transforms

if TYPE_CHECKING:
    from wsgrasp.planning.evaluate import TableSE

__all__ = ["CandidateStructure", "StructuredPoses", "table_bounds", "hull_vertices"]

Array = NDArray[np.float64]

#: a bound decides a verdict only this far (in eq. (1)'s value, or metres) from it
MARGIN = 1e-9
#: at most this many candidates' intermediate arrays at once (bounds memory)
_CHUNK_CANDIDATES = 262_144


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
    T_table_world = invert_transforms(table.T_world_table)
    R_tw, t_tw = T_table_world[:3, :3], T_table_world[:3, 3]
    RT = R_tw @ poses.R  # (O, 3, 3) gripper axes in the table frame
    base = poses.B @ R_tw.T + t_tw  # (O, 3)
    M = poses.A @ R_tw.T  # (ns, 3)
    # heights of the vertices per orientation, without the sample's shift
    # the vertices in the table frame per orientation, without the sample's shift
    P = np.einsum("oij,vj->ovi", RT, vertices) + base[:, None, :]  # (O, h, 3)
    heights = P[:, :, 2]  # (O, h)
    order = np.argsort(heights, axis=1)  # (O, h)
    sorted_h = np.take_along_axis(heights, order, axis=1)
    n_or, nv = heights.shape
    # rows laid end to end, each shifted clear of the previous one, so that one
    # searchsorted answers every (orientation, target) pair
    span = float(np.ptp(heights) + np.ptp(M[:, 2]) + abs(table.center[2]) + 1.0)
    flat = (sorted_h + span * np.arange(n_or)[:, None]).ravel()  # (O * h,)
    top = float(table.center[2] + table.semi_axes[2])
    ns = len(M)
    hit = np.zeros(ns * n_or, dtype=bool)
    unsure = np.zeros(ns * n_or, dtype=bool)
    for a in range(0, ns * n_or, _CHUNK_CANDIDATES):
        c = np.arange(a, min(a + _CHUNK_CANDIDATES, ns * n_or))
        s, o = np.divmod(c, n_or)
        shift = M[s, 2]  # (k,)
        above = sorted_h[o, 0] + shift > top + MARGIN
        # the vertex nearest the slab's middle height
        target = table.center[2] - shift + span * o
        j = np.clip(np.searchsorted(flat, target) - o * nv, 0, nv - 1)
        inside = np.zeros(len(c), dtype=bool)
        for rank in (np.zeros_like(j), j):
            p = P[o, order[o, rank]] + M[s]  # (k, 3) table frame
            d = np.abs(p - table.center) / table.semi_axes
            value = d[:, 0] ** table.exponent + d[:, 1] ** table.exponent + d[:, 2] ** 2
            inside |= value < 1.0 - MARGIN
        hit[c] = inside
        unsure[c] = ~above & ~inside
    return hit, unsure


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
    s, o = np.divmod(np.asarray(index, dtype=np.int64), n_or)
    used, o_local = np.unique(o, return_inverse=True)
    RT = R_tw @ poses.R[used]  # (u, 3, 3)
    base = poses.B[used] @ R_tw.T + t_tw  # (u, 3)
    P = np.einsum("oij,nj->ion", RT, cloud) + base.T[:, :, None]  # (3, u, ng)
    M = poses.A @ R_tw.T  # (ns, 3)
    out = np.zeros(len(s), dtype=bool)
    step = max(1, 2_000_000 // max(len(cloud), 1))
    for a in range(0, len(s), step):
        sl = slice(a, min(a + step, len(s)))
        ol, ss = o_local[sl], s[sl]
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
        out[a + k[value < 1.0]] = True
    return out
