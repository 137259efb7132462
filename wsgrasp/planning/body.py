"""Stage 2, the body: which candidates put an object point, or a point of another
object, inside a body superellipsoid of the gripper (Algorithm 1, lines 10-17).

Per orientation with the samples as translations (``wsgrasp.planning.poses``): a
candidate's object points are ``Q[o] - u[c]`` in the gripper frame. Where the
object's box in the gripper axes (``Q[o]``'s extremes less ``u``) is apart from a
body superellipsoid's box, no point is inside it; apart from all of them, the body
is clear. The rest get the exact test (eq. (1) with the arithmetic of
``coordinates_in_superellipsoids``), by one of two kernels
(``wsgrasp.planning.kernels`` picks): the compiled loop, which stops at the first
point inside, or numpy's: a subset of ``_COARSE`` points first (a hit by a subset
is a hit), then per superellipsoid only the points in its slab along its thinnest
axis. The other objects' points, left to the candidates clear of the object,
get numpy's test with either kernel.
"""

from __future__ import annotations

from collections.abc import Callable

import numpy as np
from numpy.typing import NDArray

from wsgrasp.geometry import coordinates_in_superellipsoids
from wsgrasp.geometry._superellipsoid import _power
from wsgrasp.gripper.model import GripperModel
from wsgrasp.planning import _compiled
from wsgrasp.planning._grids import NearestPoint
from wsgrasp.planning.kernels import SLAB_FROM, Kernels
from wsgrasp.planning.poses import (
    StructuredPoses,
    clear_of_boxes,
    grouped,
    in_axes,
    orientation_spans,
)

__all__ = ["body_verdicts"]

Array = NDArray[np.float64]

#: object points in numpy's first, coarse pass
_COARSE = 24
#: at most this many transformed points per numpy chunk (bounds memory)
_CHUNK_POINTS = 2_000_000


def body_verdicts(
    poses: StructuredPoses,
    index: NDArray[np.int64],
    gripper: GripperModel,
    object_points: Array,
    obstacle_points: Array,
    kernels: Kernels,
) -> NDArray[np.int64]:
    """The object and obstacle tests of the candidates ``index`` (k,) of
    ``poses`` (those clear of the table).

    Returns
    -------
    (k,) int
        2 where an object point is inside a body superellipsoid, else 3 where a
        point of ``obstacle_points`` is, else 0.
    """
    g = gripper
    P = np.asarray(object_points, dtype=np.float64).reshape(-1, 3)
    X = np.asarray(obstacle_points, dtype=np.float64).reshape(-1, 3)
    no = len(P)
    se = (g.se_centers, g.se_semi_axes, g.se_exponent)
    se_lo, se_hi = g.se_centers - g.se_semi_axes, g.se_centers + g.se_semi_axes
    index = np.asarray(index, dtype=np.int64)
    s_all, o_all = np.divmod(index, len(poses.R))
    hints = NearestPoint(P) if kernels.compiled and kernels.dense else None
    order = grouped(o_all)  # candidates grouped by orientation
    k_all = len(index)
    reason = np.zeros(k_all, dtype=np.int64)
    if kernels.compiled:  # few calls: larger chunks, bounded by their points
        spans = orientation_spans(o_all[order], max(no, len(X), 1))
    else:
        step = max(1, _CHUNK_POINTS // max(no, len(X), 1))
        spans = [(a, min(a + step, k_all)) for a in range(0, k_all, step)]
    for a, b in spans:
        at = order[a:b]  # positions in index, orientation-sorted
        R, Q, ol, u = poses.chunk(P, s_all[at], o_all[at])
        if kernels.compiled:  # the loop skips the bodies apart itself
            hit = _compiled.body_hits(Q, ol, u, *se, R=R, hints=hints)
        else:
            hit = _numpy_hits(Q, ol, u, se, se_lo, se_hi)
        reason[at[hit]] = 2
        alive = np.flatnonzero(~hit)
        if len(X) and alive.size:  # the obstacles by numpy's object test
            QX = in_axes(X, R)  # (q, 3, nx)
            obs = _numpy_hits(QX, ol[alive], u[alive], se, se_lo, se_hi)
            reason[at[alive[obs]]] = 3
    return reason


def _numpy_hits(
    Q: Array,
    ol: NDArray[np.int64],
    u: Array,
    se: tuple[Array, Array, float],
    se_lo: Array,
    se_hi: Array,
) -> NDArray[np.bool_]:
    """numpy's object test of a chunk (``Q``, ``ol``, ``u`` as
    ``StructuredPoses.chunk`` gives them): (m,) bool."""
    no = Q.shape[2]
    Q_lo, Q_hi = Q.min(axis=2)[ol], Q.max(axis=2)[ol]  # (m, 3)
    clear = clear_of_boxes(Q_lo, Q_hi, u, se_lo, se_hi)  # (m,)
    hit = np.zeros(len(ol), dtype=bool)
    todo = np.flatnonzero(~clear)
    if todo.size:
        # a subset first: a hit by some points is a hit by the cloud
        Qs = Q[:, :, :: max(1, no // _COARSE)]
        x, y, z = (Qs[ol[todo], i] - u[todo, i, None] for i in range(3))
        hit[todo] = coordinates_in_superellipsoids(x, y, z, *se).any(axis=1)
        todo = todo[~hit[todo]]
    if todo.size > SLAB_FROM * len(Q):
        hit[todo] = _slab_hits(Slabs(Q), ol, u, todo, *se)
    elif todo.size:  # few per orientation: every point beats sorting them
        x, y, z = (Q[ol[todo], i] - u[todo, i, None] for i in range(3))
        hit[todo] = coordinates_in_superellipsoids(x, y, z, *se).any(axis=1)
    return hit


def _slab_hits(
    slabs: Slabs,
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


class Slabs:
    """Per orientation, the points sorted along each gripper axis, so that the
    points of a candidate inside a slab ``lo <= (Q - u)_k <= hi`` are one range.

    ``Q`` (q, 3, n) are the points per orientation in the gripper axes. An axis is
    sorted when a search along it first needs it (numpy's body test searches
    along each body's thinnest axis).
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
        empty = np.zeros(0, dtype=np.int64)
        if len(row) == 0 or self.n == 0:
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
            return empty, empty, empty
        pair = np.repeat(np.arange(len(row)), counts)  # (total,)
        start = np.repeat(i0 - (np.cumsum(counts) - counts), counts)
        pos = start + np.arange(total)
        r = pos // self.n
        j = rank[pos]  # the point at sorted position pos - r n of row r
        return pair, j, r
