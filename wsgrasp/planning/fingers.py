"""Stage 3, the fingers: how many object points each finger's workspace spheres
hold, per candidate (Algorithm 1, lines 18-22: a candidate needs at least one per
finger).

Per orientation with the samples as translations (``wsgrasp.planning.poses``), a
finger whose box of spheres is apart from the object's box holds none. The rest
get the exact test (a point strictly inside a sphere), by one of two kernels
(``wsgrasp.planning.kernels`` picks), both reading each point's verdict from the
depth grid (``_grids.FingerSpheres``) and testing the points it leaves unsure
against the few spheres listed at their node: the compiled loop (``_compiled``),
or numpy's (``FingerDepth.holding_coordinates``, every point of a candidate whose
object box meets a finger's: looking up only the points in the slab of the
fingers' sphere box gained nothing on the bundled plans and cost the Allegro
hand's dense search a fifth more, ``kernels``). Any number of fingers: arrays
are per finger with the count as a dimension.

The holdings themselves (which points each finger holds) come from the same
kernel: computed with the counts and kept where they are few (up to
``_KEEP_ENTRIES`` bools), else computed for the candidates something asks about
(``wsgrasp.planning.holdings``).
"""

from __future__ import annotations

from collections.abc import Callable, Iterator
from dataclasses import dataclass
from typing import Any

import numpy as np
from numpy.typing import NDArray

from wsgrasp.gripper.model import GripperModel
from wsgrasp.planning import _compiled
from wsgrasp.planning._grids import FingerDepth
from wsgrasp.planning.kernels import Kernels
from wsgrasp.planning.poses import StructuredPoses, clear_of_boxes, grouped

__all__ = ["FingerVerdicts", "finger_verdicts", "count_held"]

Array = NDArray[np.float64]

#: at most this many candidates' points (per chunk) in numpy's temporaries
_CHUNK_POINTS = 2_000_000
#: at most this many (candidate, point) pairs through the sphere grid at once
_CHUNK_PAIRS = 100_000
#: up to this many (candidate, point, finger) entries, the finger test keeps the
#: holdings it computes; beyond, it counts, and computes holdings when asked
_KEEP_ENTRIES = 24_000_000


def count_held(hold: NDArray[np.bool_]) -> NDArray[np.int64]:
    """Points held per candidate and finger, ``(n, no, nf)`` -> ``(n, nf)``."""
    # a float32 product of ones: exact (counts below 2**24), several times faster
    # than numpy's count_nonzero over the middle axis
    ones = np.ones(hold.shape[1], dtype=np.float32)
    return np.matmul(ones, hold.astype(np.float32)).astype(np.int64)  # (n, nf)


@dataclass
class FingerVerdicts:
    """What the finger test found for candidates ``index`` (k,).

    Attributes
    ----------
    counts : (k, nf) int
        Object points held per candidate and finger.
    held : (k, no, nf) bool or None
        The holdings, where they were few enough to keep.
    rows : callable
        ``rows(i)``: the holdings of the candidates at positions ``i`` (m,) of
        ``index``, (m, no, nf) bool, from the same kernel.
    num_points : int
    """

    counts: NDArray[np.int64]
    held: NDArray[np.bool_] | None
    rows: Callable[[NDArray[np.int64]], NDArray[np.bool_]]
    num_points: int


def finger_verdicts(
    poses: StructuredPoses,
    index: NDArray[np.int64],
    gripper: GripperModel,
    spheres: FingerDepth,
    object_points: Array,
    kernels: Kernels,
) -> FingerVerdicts:
    """The finger test of the candidates ``index`` (k,) of ``poses`` (those
    clear of the table and of every body), through ``gripper``'s sphere index
    ``spheres`` (``_grids.FingerSpheres``)."""
    nf = int(gripper.num_fingers)
    P = np.asarray(object_points, dtype=np.float64).reshape(-1, 3)
    fingers = _Fingers(poses, P, spheres, kernels)
    s, o = np.divmod(np.asarray(index, dtype=np.int64), len(poses.R))
    keep = len(s) * len(P) * nf <= _KEEP_ENTRIES
    held, counts = fingers.holding_and_counts(s, o, keep)

    def rows(i: NDArray[np.int64]) -> NDArray[np.bool_]:
        return fingers.holding_and_counts(s[i], o[i])[0]

    return FingerVerdicts(counts, held if keep else None, rows, len(P))


class _Fingers:
    """The finger test of structured candidates ``(s, o)`` by one kernel: the
    compiled loop, when ``kernels.compiled`` (loaded when this is built, so that
    holdings asked for later come from the same kernel), else numpy's."""

    def __init__(
        self,
        poses: StructuredPoses,
        P: Array,
        depth: FingerDepth,
        kernels: Kernels,
    ) -> None:
        self.poses, self.P, self.depth = poses, P, depth
        # each finger's box of spheres, gripper frame: (nf, 3) each
        self.f_lo, self.f_hi = depth.box_lo, depth.box_hi
        self.step = max(1, _CHUNK_POINTS // max(len(P), 1))
        # (the compiled loop sums 16-bit lanes: fewer than 2**16 points)
        few = len(P) < 2**16
        self.loop = _compiled.load()[0] if kernels.compiled and few else None
        # the compiled loop reads the points in space order in a dense search
        # (``wsgrasp.planning.kernels``); it writes each holding to the point's
        # own column (``perm``)
        ordering = self.loop is not None and kernels.dense
        self.perm = _space_order(P) if ordering else np.arange(len(P))
        self.P_loop = P[self.perm] if ordering else P
        self.nf = len(self.f_lo)

    def _groups(
        self, s: NDArray[np.int64], o: NDArray[np.int64], P: Array, box: bool = True
    ) -> Iterator[tuple[NDArray[np.int64], Array, NDArray[np.int64], Array, Any]]:
        """Chunks of candidates grouped by orientation, as ``(rows, Q, ol, u,
        need)``: positions ``rows`` (m,) into ``s``, the chunk's arrays as
        ``StructuredPoses.chunk`` gives them for the points ``P``, and ``need``:
        the chunk's candidates with some finger's sphere box meeting the
        object's box (with ``box``; else every one, a slice: the compiled loop
        tests the boxes itself)."""
        order = grouped(o)  # rows grouped by orientation
        for a in range(0, len(s), self.step):
            rows = order[a : a + self.step]
            _, Q, ol, u = self.poses.chunk(P, s[rows], o[rows])
            if not box:
                yield rows, Q, ol, u, slice(None)
                continue
            lo, hi = Q.min(axis=2)[ol], Q.max(axis=2)[ol]  # (m, 3) each
            need = np.flatnonzero(~clear_of_boxes(lo, hi, u, self.f_lo, self.f_hi))
            if need.size:
                yield rows, Q, ol, u, need

    def holding_and_counts(
        self, s: NDArray[np.int64], o: NDArray[np.int64], keep: bool = True
    ) -> tuple[NDArray[np.bool_], NDArray[np.int64]]:
        """Which object points each finger holds, (k, no, nf) bool (with
        ``keep``; else no rows), and how many, (k, nf) int."""
        out = np.zeros((len(s) if keep else 0, len(self.P), self.nf), dtype=bool)
        counts = np.zeros((len(s), self.nf), dtype=np.int64)
        if self.loop is not None:
            for rows, Q, ol, u, _ in self._groups(s, o, self.P_loop, False):
                counts[rows] = _compiled.count_by_fingers(
                    self.depth, Q, ol, u, self.loop, self.perm, out, rows
                )
            return out, counts
        for rows, Q, ol, u, need in self._groups(s, o, self.P):
            held = self._numpy_held(Q, ol, u, need)
            counts[rows[need]] = count_held(held)
            if keep:
                out[rows[need]] = held
        return out, counts

    def _numpy_held(
        self, Q: Array, ol: NDArray[np.int64], u: Array, cand: NDArray[np.int64]
    ) -> NDArray[np.bool_]:
        """numpy's holdings of candidates ``cand`` of a chunk, every point
        through the depth grid: (n, no, nf) bool."""
        n = Q.shape[2]
        held = np.empty((len(cand), n, self.nf), dtype=bool)
        step = max(1, _CHUNK_PAIRS // max(n, 1))
        for a in range(0, len(cand), step):
            cb = cand[a : a + step]
            rb = ol[cb]
            held[a : a + step] = self.depth.holding_coordinates(
                *(Q[rb, i] - u[cb, i, None] for i in range(3))
            )
        return held


def _space_order(P: Array, cell: float = 0.01) -> NDArray[np.int64]:
    """An order of the points ``P`` (n, 3) that keeps near points near: by
    ``cell`` voxel, rows of voxels along z (the lexicographic order of the
    voxel indices): (n,) int."""
    if len(P) == 0:
        return np.zeros(0, dtype=np.int64)
    g = np.floor((P - P.min(axis=0)) / cell).astype(np.int64)  # (n, 3) voxels
    return np.lexsort((g[:, 2], g[:, 1], g[:, 0]))
