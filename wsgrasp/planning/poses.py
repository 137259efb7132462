"""The candidate structure every stage of the search takes: samples × orientations.

A candidate set built by ``candidate_poses`` is not an arbitrary list of poses: every
candidate is a sample position ``s`` (object frame) and an orientation ``o`` (a
rotation and a depth offset), and its gripper pose factors as

``R_world_gripper[s, o] = R_world_object R_object_gwc[o] R_gwc_gripper``: one per
orientation, and
``t_world_gripper[s, o] = A[s] + B[o]``, with ``A[s] = R_world_object s +
t_world_object`` and ``B[o] = R_world_object (R_object_gwc[o] t_gwc_gripper +
depth[o] z_gwc[o])``.

So anything linear in the pose splits into a per-orientation part and a
per-sample part, and a per-candidate quantity is one broadcast sum of the two. In
the gripper frame a candidate's object points are ``Q[o] - u[c]``: ``Q[o] = p_world
R[o]`` once per orientation, ``u[c] = (A[s] + B[o]) R[o]`` per candidate.

A list of arbitrary poses is the structure with one sample at the origin and a
rotation and translation per pose (:meth:`StructuredPoses.of_transforms`).
"""

from __future__ import annotations

from dataclasses import dataclass
from functools import cached_property

import numpy as np
from numpy.typing import NDArray
from scipy.spatial import ConvexHull, QhullError

from wsgrasp.geometry import invert_transforms

__all__ = [
    "CandidateStructure",
    "PoseArray",
    "PoseRows",
    "StructuredPoses",
    "TableSE",
    "hull_vertices",
]

Array = NDArray[np.float64]

#: a bound decides a verdict only this far (in eq. (1)'s value, or metres) from it
MARGIN = 1e-9
#: a chunk of the compiled body test holds at most this many candidates, and its
#: orientations' points at most this many coordinates
_SPAN_CANDIDATES = 65_536
_SPAN_POINTS = 3_000_000


@dataclass(frozen=True)
class TableSE:
    """The table's superellipsoid, in the table frame (z = table normal).

    Attributes
    ----------
    T_world_table : (4, 4) float
    center, semi_axes : (3,) float
    exponent : float
    """

    T_world_table: Array
    center: Array
    semi_axes: Array
    exponent: float


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

    def indices(self) -> tuple[NDArray[np.int64], NDArray[np.int64]]:
        """Each candidate's sample and orientation, ``(C,)`` each: samples
        outer, orientations inner."""
        ns, n_or = len(self.samples_object), len(self.R_object_gwc)
        sample = np.repeat(np.arange(ns, dtype=np.int64), n_or)
        orientation = np.tile(np.arange(n_or, dtype=np.int64), ns)
        return sample, orientation


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
        cls, structure: CandidateStructure, T_gripper_gwc: Array | None = None
    ) -> StructuredPoses:
        """The gripper poses of the candidates ``structure`` describes, or
        without ``T_gripper_gwc`` the poses of their GWC frames."""
        T_wo = np.asarray(structure.T_world_object, dtype=np.float64)
        R_og = np.asarray(structure.R_object_gwc, dtype=np.float64).reshape(-1, 3, 3)
        s = np.asarray(structure.samples_object, dtype=np.float64).reshape(-1, 3)
        R_wo, t_wo = T_wo[:3, :3], T_wo[:3, 3]
        R = R_wgwc = R_wo @ R_og  # (O, 3, 3)
        B = np.zeros((len(R_og), 3))  # (O, 3) the GWC's offsets along the approach
        if structure.depth is not None:
            depth = np.asarray(structure.depth, dtype=np.float64)  # (O,)
            B = depth[:, None] * R_wgwc[:, :, 2]
        if T_gripper_gwc is not None:
            T_gwc_gripper = invert_transforms(T_gripper_gwc)
            R = R_wgwc @ T_gwc_gripper[:3, :3]  # (O, 3, 3)
            B = R_wgwc @ T_gwc_gripper[:3, 3] + B
        A = s @ R_wo.T + t_wo  # (ns, 3)
        return cls(R, A, B)

    @classmethod
    def of_transforms(cls, T_world_gripper: Array) -> StructuredPoses:
        """Arbitrary poses ``(C, 4, 4)`` as one sample at the origin and ``C``
        orientations."""
        T = np.asarray(T_world_gripper, dtype=np.float64).reshape(-1, 4, 4)
        return cls(T[:, :3, :3].copy(), np.zeros((1, 3)), T[:, :3, 3].copy())

    @classmethod
    def checked(
        cls,
        structure: CandidateStructure,
        T_gripper_gwc: Array,
        T_world_gripper: Array | PoseArray,
    ) -> StructuredPoses:
        """:meth:`build`, refused where ``T_world_gripper`` (C, 4, 4) is not the
        candidate set ``structure`` describes."""
        C = len(T_world_gripper)
        if structure.num_candidates != C:
            raise ValueError(
                f"structure describes {structure.num_candidates} candidates, "
                f"T_world_gripper holds {C}; pass the structure it was built from"
            )
        poses = cls.build(structure, T_gripper_gwc)
        if C:
            ends = np.array([0, C - 1])
            a = poses.transforms(ends)
            b = (
                T_world_gripper.at(ends)
                if isinstance(T_world_gripper, PoseArray)
                else T_world_gripper[ends]
            )
            # np.allclose(a, b, atol=1e-9) without its wrapper (a tenth of the time)
            if not np.all(np.abs(a - b) <= 1e-9 + 1e-5 * np.abs(b)):
                raise ValueError(
                    "structure does not match T_world_gripper: pass the samples, "
                    "orientations and depths candidate_poses was given"
                )
        return poses

    @property
    def num_candidates(self) -> int:
        return len(self.A) * len(self.R)

    @cached_property
    def columns(self) -> tuple[Array, Array]:
        """``A.T`` (3, ns) and ``B.T`` (3, O), contiguous (built once, then
        kept): one coordinate's gather is a 1-D ``take``."""
        return np.ascontiguousarray(self.A.T), np.ascontiguousarray(self.B.T)

    def every(self) -> Array:
        """``T_world_gripper`` of every candidate, samples outer: (ns O, 4, 4).
        Per orientation its pose at ``A = 0``, copied once per sample, then
        shifted (``B[o] + A[s] == A[s] + B[o]``): no (C, 4, 4) products."""
        T_o = np.zeros((len(self.R), 4, 4))  # (O, 4, 4)
        T_o[:, :3, :3] = self.R
        T_o[:, :3, 3] = self.B
        T_o[:, 3, 3] = 1.0
        T = np.empty((len(self.A), len(self.R), 4, 4))  # (ns, O, 4, 4)
        T[...] = T_o[None]
        T[:, :, :3, 3] += self.A[:, None, :]
        return T.reshape(-1, 4, 4)

    def transforms(self, index: NDArray[np.int64]) -> Array:
        """``T_world_gripper`` of the candidates ``index`` (k,): (k, 4, 4)."""
        n_or = len(self.R)
        s, o = np.divmod(np.asarray(index, dtype=np.int64), n_or)
        T = np.zeros((len(s), 4, 4))
        T[:, :3, :3] = self.R[o]
        T[:, :3, 3] = self.A[s] + self.B[o]
        T[:, 3, 3] = 1.0
        return T

    def chunk(
        self, P: Array, s: NDArray[np.int64], o: NDArray[np.int64]
    ) -> tuple[Array, Array, NDArray[np.int64], Array]:
        """For candidates ``(s, o)`` (m,): the rotations of their orientations
        ``R`` (q, 3, 3), the points ``P`` (n, 3) in those axes ``Q`` (q, 3, n),
        each candidate's row ``ol`` (m,) and translation ``u`` (m, 3) (its points
        are ``Q[ol] - u``)."""
        o = np.asarray(o, dtype=np.int64)
        # a row per run of one orientation: one per orientation where they come
        # grouped (the callers' order, :func:`grouped`)
        change = o[1:] != o[:-1]
        used = np.concatenate((o[:1], o[1:][change]))
        ol = np.zeros(len(o), dtype=np.int64)
        np.cumsum(change, out=ol[1:])
        R = self.R[used]  # (q, 3, 3)
        Q = in_axes(P, R)  # (q, 3, n) gripper axes, untranslated
        # u = w R[ol] with w = A[s] + B[o] the gripper origins (world frame), one
        # coordinate at a time from 1-D gathers (row gathers of (m, 3) arrays and
        # a batched (1, 3) @ (3, 3) product per candidate are several times slower)
        A, B = self.columns
        w = [np.take(A[i], s) + np.take(B[i], o) for i in range(3)]  # 3 × (m,)
        u = np.empty((len(o), 3))
        Rt = np.ascontiguousarray(R.transpose(1, 2, 0))  # (3, 3, q): Rt[i, k] per row
        for k in range(3):
            u[:, k] = w[0] * np.take(Rt[0, k], ol)
            u[:, k] += w[1] * np.take(Rt[1, k], ol)
            u[:, k] += w[2] * np.take(Rt[2, k], ol)
        return R, Q, ol.reshape(-1), u


class PoseArray:
    """The ``(C, 4, 4)`` poses of a candidate set, built whole only when read whole.

    Made from :class:`StructuredPoses`, it gives the poses of some candidates
    (:meth:`at`) from the structure, bit for bit those of
    :meth:`StructuredPoses.every` (``A[s] + B[o]`` and ``B[o] + A[s]`` are the
    same sum). A search keeps its candidates' poses this way, and reads a few
    thousand of them. Built whole instead, the dense bench cases' two arrays
    (93 MB each for the Allegro hand's 729,000 candidates) take the Franka
    hand's search from 151 to 185 ms and the Allegro hand's from 720 to 761 ms,
    and their peak memory from 55 to 180 MB and from 111 to 288 MB (medians of
    11, the two alternated on the 2-core machine).

    Made from an array, it is that array. Poses set with :meth:`set` (a
    backed-off choice) override the structure's.
    """

    __slots__ = ("_poses", "_array", "_edits")

    def __init__(self, source: StructuredPoses | Array) -> None:
        self._edits: dict[int, Array] = {}
        if isinstance(source, StructuredPoses):
            self._poses: StructuredPoses | None = source
            self._array: Array | None = None
        else:
            self._poses = None
            self._array = np.asarray(source, dtype=np.float64).reshape(-1, 4, 4)

    def __len__(self) -> int:
        if self._array is not None:
            return int(self._array.shape[0])
        assert self._poses is not None
        return self._poses.num_candidates

    @property
    def built(self) -> bool:
        """Whether the whole array exists (read whole, or made from one)."""
        return self._array is not None

    def whole(self) -> Array:
        """Every pose, ``(C, 4, 4)``: built on the first call, then kept (writes
        to it stay)."""
        if self._array is None:
            assert self._poses is not None
            a = self._poses.every()
            for i, T in self._edits.items():
                a[i] = T
            self._array, self._poses, self._edits = a, None, {}
        return self._array

    def at(self, index: int | NDArray[np.integer] | NDArray[np.bool_]) -> Array:
        """The poses of candidates ``index``: ``(4, 4)`` for an integer, ``(k, 4,
        4)`` for integers or a boolean mask over the candidates; numpy's
        indexing of :meth:`whole`, without building it."""
        if self._array is not None:
            return np.asarray(self._array[index])
        assert self._poses is not None
        C = self._poses.num_candidates
        idx = np.asarray(index)
        if idx.dtype == np.bool_:
            if idx.shape != (C,):
                raise IndexError(f"boolean index of shape {idx.shape}, expected ({C},)")
            idx = np.flatnonzero(idx)
        idx = idx.astype(np.int64, copy=False)
        if idx.size and (idx.min() < -C or idx.max() >= C):
            raise IndexError(f"candidate index out of range for {C} candidates")
        idx = np.where(idx < 0, idx + C, idx)
        T = self._poses.transforms(idx.reshape(-1))  # (k, 4, 4)
        for i, edit in self._edits.items():
            T[idx.reshape(-1) == i] = edit
        return T[0] if idx.ndim == 0 else T.reshape(*idx.shape, 4, 4)

    def split(
        self, index: NDArray[np.int64], groups: NDArray[np.int64] | None = None
    ) -> tuple[Array, NDArray[np.int64], Array]:
        """The poses of candidates ``index`` (k,) as rotations and translations,
        bit for bit those of :meth:`at`: the distinct rotations ``R`` (U, 3, 3)
        (:func:`distinct_rotations`, with ``groups`` where the poses are an
        array), each pose's row of ``R`` (k,) and its translation (k, 3). From
        the structure no ``(k, 4, 4)`` array is built: the Allegro hand's dense
        search takes 16 ms less than through :meth:`at`."""
        if self._poses is None or self._edits:
            R, t = self.parts(index)
            return (*distinct_rotations(R, groups), t)
        sp = self._poses
        s, o = np.divmod(np.asarray(index, dtype=np.int64), len(sp.R))
        used = np.zeros(len(sp.R), dtype=bool)
        used[o] = True
        R, of = distinct_rotations(sp.R[used])  # (U, 3, 3), (used,)
        return R, of[np.cumsum(used)[o] - 1], sp.A[s] + sp.B[o]

    def parts(self, index: NDArray[np.int64]) -> tuple[Array, Array]:
        """The rotations (k, 3, 3) and translations (k, 3) of candidates
        ``index`` (k,), bit for bit those of :meth:`at`, without building
        ``(k, 4, 4)`` arrays from the structure."""
        if self._poses is None or self._edits:
            T = self.at(index)
            return T[:, :3, :3], T[:, :3, 3]
        sp = self._poses
        s, o = np.divmod(np.asarray(index, dtype=np.int64), len(sp.R))
        return sp.R[o], sp.A[s] + sp.B[o]

    def set(self, index: int, T: Array) -> None:
        """Set candidate ``index``'s pose to ``T`` (4, 4)."""
        if self._array is not None:
            self._array[index] = T
            return
        C = len(self)
        i = int(index) + (C if int(index) < 0 else 0)
        if not 0 <= i < C:
            raise IndexError(f"candidate index {index} out of range for {C} candidates")
        self._edits[i] = np.array(T, dtype=np.float64).reshape(4, 4)

    def copy(self) -> PoseArray:
        """An independent copy (the structure is shared: it is never written)."""
        if self._array is not None:
            return PoseArray(self._array.copy())
        assert self._poses is not None
        out = PoseArray(self._poses)
        out._edits = {i: T.copy() for i, T in self._edits.items()}
        return out


def distinct_rotations(
    R: Array, groups: NDArray[np.int64] | None = None
) -> tuple[Array, NDArray[np.int64]]:
    """The distinct rotations of ``R`` (C, 3, 3), in ``np.unique``'s order (rows
    compared as numbers, lexicographically), and each one's index: (U, 3, 3),
    (C,). Rows are grouped by ``groups`` (C,) (nonnegative labels, a rotation
    per label: a row of each label stands for it, checked), then only the
    groups' first rows are sorted: sorting every row took 99 ms of the Allegro's
    dense sweeps (87,417 rows, 4,670 distinct), the labels (the candidates'
    orientations) 4 ms. Without labels (a search's callers give them; a pose
    checked alone has one row), every row is sorted."""
    rows = np.ascontiguousarray(R, dtype=np.float64).reshape(-1, 9)  # (C, 9)
    first = of = np.arange(len(rows))
    if groups is not None and len(rows):
        label = np.asarray(groups, dtype=np.int64).reshape(-1)
        # a row of each label (whichever the assignment keeps), labels renumbered
        some = np.full(int(label.max()) + 1, -1, dtype=np.int64)
        some[label] = np.arange(len(label))
        used = np.flatnonzero(some >= 0)
        renumber = np.zeros(len(some), dtype=np.int64)
        renumber[used] = np.arange(len(used))
        if np.array_equal(rows[some[used]][renumber[label]], rows):  # one per label
            first, of = some[used], renumber[label]
    # a stable sort (``return_index``): of rows equal as numbers (0.0 and -0.0),
    # the first stands for them
    s, _, rank = np.unique(rows[first], axis=0, return_index=True, return_inverse=True)
    return s.reshape(-1, 3, 3), rank.reshape(-1)[of]


class PoseRows:
    """Candidates ``index`` (k,) of a :class:`PoseArray`, their ``(k, 4, 4)``
    poses built only when read whole (:meth:`whole`); :attr:`parts` gives their
    rotations and translations without them (:meth:`PoseArray.parts`)."""

    def __init__(self, poses: PoseArray, index: NDArray[np.int64]) -> None:
        self.poses, self.index = poses, np.asarray(index, dtype=np.int64)

    def __len__(self) -> int:
        return len(self.index)

    @cached_property
    def _whole(self) -> Array:
        return self.poses.at(self.index)

    def whole(self) -> Array:
        """The ``(k, 4, 4)`` poses: built on the first call, then kept."""
        return self._whole

    @cached_property
    def parts(self) -> tuple[Array, Array]:
        return self.poses.parts(self.index)


#: OpenBLAS computes a matrix product of up to this many multiply-adds on one
#: thread (``SMP_THRESHOLD_MIN`` times ``GEMM_MULTITHREAD_THRESHOLD``)
_ONE_THREAD = 262_144


def one_thread_block(other: int) -> int:
    """How many rows a thin product ``(b, 3) @ (3, other)`` (or columns of
    ``(other, 3) @ (3, b)``) may have for OpenBLAS to compute it on one thread:
    on threads, the Allegro hand's dense search took three times as long on
    the 2-core machine while it ran other work."""
    return max(1, _ONE_THREAD // (3 * max(other, 1)))


def in_axes(P: Array, R: Array) -> Array:
    """Points ``P`` (n, 3) in the axes of each rotation ``R`` (q, 3, 3), ``P @
    R[o]`` per row: (q, 3, n).

    Matrix products of blocks of rotations stacked, ``(3b, 3) @ (3, n)``: the
    same bits as a batched product per rotation (checked with OpenBLAS's
    SkylakeX, Haswell and Sandybridge kernels) in under half its time (130
    rotations, 800 points: 89 against 200 us; an einsum is slower still), each
    block computed on one thread (:func:`one_thread_block`)."""
    q, n = len(R), len(P)
    Rt = np.ascontiguousarray(R.transpose(0, 2, 1)).reshape(-1, 3)  # (3q, 3)
    out = np.empty((3 * q, n))
    rows = 3 * max(1, one_thread_block(n) // 3)  # whole rotations
    for a in range(0, 3 * q, rows):
        np.matmul(Rt[a : a + rows], P.T, out=out[a : a + rows])
    return out.reshape(q, 3, n)


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


def clear_of_boxes(
    Q_lo: Array, Q_hi: Array, u: Array, box_lo: Array, box_hi: Array
) -> NDArray[np.bool_]:
    """Candidates whose points' box (gripper axes: ``[Q_lo - u, Q_hi - u]``,
    (m, 3)) is apart from every box ``[box_lo, box_hi]`` (e, 3) by more than
    ``MARGIN`` along some axis: (m,) bool."""
    lo = (Q_lo - u)[:, None, :]  # (m, 1, 3)
    hi = (Q_hi - u)[:, None, :]
    apart = (lo > box_hi[None] + MARGIN) | (hi < box_lo[None] - MARGIN)  # (m, e, 3)
    return np.all(np.any(apart, axis=-1), axis=1)


def grouped(o: NDArray[np.int64]) -> NDArray[np.int64]:
    """The stable order of ``o`` (k,) (orientation indices): numpy's radix sort
    where they fit 16 bits (5 times faster than its merge sort on the Franka's
    378,000 dense candidates), else its stable sort."""
    o = np.asarray(o, dtype=np.int64)
    if len(o) and 0 <= o.min() and o.max() < 2**16:
        return np.argsort(o.astype(np.uint16), kind="stable")
    return np.argsort(o, kind="stable")


def orientation_spans(
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
