"""Points projected on a plane, looked at on a grid of square cells: the points
in a cluster's grid (:class:`Window`), the cells points fall in
(:func:`cells_seen`) and a cluster's footprint (:func:`footprint`). The
``ransac_dbscan`` segmenter's checks of what stands on a plane use them."""

from __future__ import annotations

import math

import numpy as np
from numpy.typing import NDArray

from wsgrasp.perception.types import Array

__all__ = ["ROW_NEIGHBOURS", "Window", "cells_seen", "footprint"]


class Window:
    """Points ``p`` ``(n, 3)`` projected on a plane (``basis`` ``(3, 2)``;
    ``uv``, once asked for), from which those in a cluster's grid are taken:
    by one pass over them all for the first ``WINDOW_PASSES`` clusters (all of
    them, where ``queries``, the clusters to come, are ``WINDOW_FEW`` or
    fewer), then from the points sorted by the square of side
    ``WINDOW_BUCKET`` they fall in (a noisy room's floor, 100,000 inliers
    under 400 noise clusters, took 3 s to look at cluster by cluster; sorting
    a tabletop's points for its one object costs more than the pass)."""

    def __init__(
        self, p: Array, basis: Array | None = None, queries: int | None = None
    ) -> None:
        self.p, self.basis = p, basis
        self.calls = 0
        # a pass each for a few clusters told beforehand: sorting cost as
        # much as 25 passes (a noisy room's 753,000 points: 18 ms, a pass 0.7)
        few = queries is not None and queries <= WINDOW_FEW
        self.passes = WINDOW_PASSES if queries is None or not few else queries
        self._uv: Array | None = None
        # once sorted: the points' order by square, their squares' keys in that
        # order, the squares' corner and how many rows of squares there are
        self.order: NDArray[np.int64] | None = None
        self.keys = np.zeros(0, dtype=np.int64)
        self.sorted_uv = np.zeros((0, 2))
        self.origin = np.zeros(2)
        self.rows_per = 0

    @property
    def uv(self) -> Array:
        """The points on the plane ``(n, 2)`` (``p`` itself without a basis)."""
        if self._uv is None:
            # einsum's own loop, not BLAS: on a shared 2-core machine the
            # BLAS threads of a (500,000, 3) @ (3, 2) product waited up to
            # 190 ms for each other (median 10 ms; einsum 8.5, at most 11)
            self._uv = (
                self.p
                if self.basis is None
                else np.einsum("ij,jk->ik", self.p, self.basis, optimize=False)
            )
        return self._uv

    def within(
        self, lo: Array, shape: tuple[int, ...], side: float, ordered: bool = True
    ) -> NDArray[np.int64]:
        """Indices (ascending where ``ordered``, else in any order) of the
        points in the grid of ``shape`` cells of side ``side`` from corner
        ``lo``, and a cell round it (the cells a point falls in are then told
        as over the whole)."""
        a = lo - side
        b = lo + (np.asarray(shape) + 1) * side
        uv = self.uv
        self.calls += 1
        if self.calls <= self.passes:
            u, v = uv[:, 0], uv[:, 1]
            inside = (u >= a[0]) & (u <= b[0]) & (v >= a[1]) & (v <= b[1])
            return np.flatnonzero(inside)
        if self.order is None:
            # a column at a time (a noisy room's 745,000 points: 17 -> 0.6 ms)
            self.origin = np.array([uv[:, 0].min(), uv[:, 1].min()])
            ij = np.floor((uv - self.origin) / WINDOW_BUCKET).astype(np.int64)
            self.rows_per = int(ij[:, 1].max()) + 1
            key = ij[:, 0] * self.rows_per + ij[:, 1]
            # the order within a square is never read (what is taken is
            # sorted): keys under 2**16 sort by radix as 16-bit integers (the
            # 745,000 points: 55 -> 6 ms), others by quicksort (10 ms)
            if int(key.max()) < 2**16:
                self.order = np.argsort(key.astype(np.uint16), kind="stable")
            else:
                self.order = np.argsort(key)
            self.keys = key[self.order]
            # the points in that order: a run of squares is a slice of them
            self.sorted_uv = uv.take(self.order, axis=0)
        # the buckets the box overlaps, a run of keys per column of them
        i0, j0 = np.floor((a - self.origin) / WINDOW_BUCKET).astype(np.int64)
        i1, j1 = np.floor((b - self.origin) / WINDOW_BUCKET).astype(np.int64)
        j0, j1 = max(int(j0), 0), min(int(j1), self.rows_per - 1)
        if j1 < j0:
            return np.zeros(0, dtype=np.int64)
        cols = np.arange(max(int(i0), 0), int(i1) + 1) * self.rows_per
        starts = np.searchsorted(self.keys, cols + j0, "left")
        ends = np.searchsorted(self.keys, cols + j1, "right")
        if not len(cols) or not (ends > starts).any():
            return np.zeros(0, dtype=np.int64)
        runs = [slice(s, e) for s, e in zip(starts, ends, strict=True) if e > s]
        # slices of the sorted points, not a gather of their rows (a noisy
        # room's 1,858 clusters: 0.46 -> 0.2 ms a window)
        suv = np.concatenate([self.sorted_uv[r] for r in runs])
        u, v = suv[:, 0], suv[:, 1]
        inside = (u >= a[0]) & (u <= b[0]) & (v >= a[1]) & (v <= b[1])
        rows = np.concatenate([self.order[r] for r in runs])[inside]
        return np.sort(rows) if ordered else rows


#: :class:`Window`'s squares (m): a few times a cluster's cells
WINDOW_BUCKET = 0.05
#: clusters looked at by a pass over every point before they are sorted
WINDOW_PASSES = 3
#: ... or all of them, where no more are told beforehand
WINDOW_FEW = 24


def cells_seen(
    uv: Array, lo: Array, side: float, shape: tuple[int, ...]
) -> NDArray[np.bool_]:
    """The cells of side ``side`` of a grid of ``shape`` from corner ``lo``
    ``(2,)`` that points projected on the plane, ``uv`` ``(m, 2)``, fall in."""
    t = np.floor((uv - lo) / side).astype(np.int64)  # (m, 2)
    i, j = t[:, 0], t[:, 1]
    # a column at a time: numpy's all(axis=1) over (m, 2) took 4 times as long
    ok = (i >= 0) & (j >= 0) & (i < shape[0]) & (j < shape[1])
    seen = np.zeros(shape, dtype=bool)
    seen[i[ok], j[ok]] = True
    return seen


def footprint(
    uv: Array, cell: float
) -> tuple[NDArray[np.bool_], Array, NDArray[np.int64]]:
    """The footprint of points projected on a plane, ``uv`` ``(k, 2)``: the
    cells of side ``cell`` they fall into, the gaps between the points' rows
    closed and holes filled, on a grid with a border as wide as the closing
    and a cell; the grid's corner ``lo`` ``(2,)`` and each point's cell
    ``(k, 2)``.

    A top seen at a slant, or from far, falls into rows with empty cells
    between them (a 15 cm cube's top seen from 1.5 m: 399 points in 900
    cells) that open its footprint to the outside: without the closing, its
    outline ran through its middle, and the sides filled in under it (the
    ``ransac_dbscan`` segmenter's ``_hidden_sides``) stood up to 5 cm inside
    the object. The closing spans the points' spacing across their rows:
    the median distance to a point's sixth nearest (its row's neighbours are
    the first four), at least one cell."""
    from scipy.ndimage import binary_dilation, binary_erosion, binary_fill_holes
    from scipy.spatial import cKDTree

    reach = 1
    if len(uv) > ROW_NEIGHBOURS and not _dense(uv, cell):
        d, _ = cKDTree(uv).query(uv, k=ROW_NEIGHBOURS + 1)
        spacing = float(np.median(d[:, -1]))
        reach = max(1, min(MAX_CLOSING, math.ceil(spacing / cell - 1e-9) - 1))
    lo = uv.min(axis=0) - (reach + 1) * cell
    shape = tuple(int(n) for n in np.floor((uv.max(axis=0) - lo) / cell) + reach + 2)
    ij = np.floor((uv - lo) / cell).astype(np.int64)  # (k, 2)
    foot = np.zeros(shape, dtype=bool)
    foot[ij[:, 0], ij[:, 1]] = True
    grown = binary_dilation(foot, iterations=reach)
    foot |= binary_erosion(grown, iterations=reach, border_value=0)
    return binary_fill_holes(foot), lo, ij


#: ``footprint``: the neighbour whose distance tells the points' spacing
#: across their rows, and the widest closing (cells)
ROW_NEIGHBOURS = 6
MAX_CLOSING = 4


#: :func:`footprint` looks for dense squares first in this many points or more
#: (a noisy room's wall, 79,231 points seen edge on: its spacing took 55 ms)
DENSE_FROM = 500


def _dense(uv: Array, cell: float) -> bool:
    """Whether more than half the points ``uv`` ``(k, 2)`` fall in squares of
    side ``cell`` with ``ROW_NEIGHBOURS`` others or more: each of them has
    those others within a square's diagonal, so the median distance to the
    sixth nearest, which :func:`footprint` measures for its closing, is at
    most 1.42 cells: a closing of one cell, as for any spacing up to two."""
    if len(uv) < DENSE_FROM:
        return False
    ij = np.floor((uv - uv.min(axis=0)) / cell).astype(np.int64)
    rows = int(ij[:, 1].max()) + 1
    if (int(ij[:, 0].max()) + 1) * rows > 64 * len(uv):
        return False  # squares far sparser than the points
    key = ij[:, 0] * rows + ij[:, 1]
    counts = np.bincount(key)
    return bool(np.count_nonzero(counts[key] > ROW_NEIGHBOURS) > len(uv) // 2)
