"""Objects that touch: one cluster that is clearly two objects.

Clustering joins objects that touch. Seen from above, two touching objects make a
footprint with a waist: two wide parts joined by a narrow neck, at the objects'
full height (a bar of a dumbbell or the handle of a pan is lower than what it
joins, so it is no such neck), and where they meet the objects touch: the neck
is short. A narrow stretch as tall as the parts and long, farther from both
parts than either is wide, is a handle joining two ends of one object (a hammer
lying flat: its head, the thick end of its grip). Two boxes flush side by side
make no waist and are not "clearly two": they stay one object.

The footprint is the object's points projected on the table, on a grid; the
distance transform gives each cell its distance to the footprint's edge. The two
widest parts are the two highest maxima whose disks do not overlap; the neck is
the bottleneck of the best path between them (the highest level at which both
stay connected); the handle's length is how far the cells that connect them at
that level reach from both parts' cores.
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np
from numpy.typing import NDArray
from scipy import ndimage

from wsgrasp.geometry import plane_basis
from wsgrasp.perception.types import Array, Plane

__all__ = ["Touching", "find_touching", "split_touching"]

#: footprint grid cell (m)
CELL = 0.0025
#: each part is at least this wide (m, twice its inscribed radius)
MIN_PART_WIDTH = 0.03
#: a neck narrower than this fraction of the narrower part's width is a waist
NECK_FRACTION = 0.65
#: the neck stands at least this fraction of the lower part's height
NECK_HEIGHT = 0.8
#: a stretch narrower than this fraction of the narrower part's width ...
HANDLE_WIDTH = 0.8
#: ... longer than this many times the wider part's width, on the widest path
#: between the parts, is a handle of one object, not where two objects touch
HANDLE_LENGTH = 2.0


@dataclass
class Touching:
    """Two objects in one cluster.

    Attributes
    ----------
    centers : (2, 3) float
        Each part's widest point on its top, world frame.
    widths : (2,) float
        Each part's width (m): twice its inscribed radius in the footprint.
    neck : float
        The width (m) where they meet.
    labels : (n,) int
        0 or 1 per point of the cluster: the part it belongs to.
    """

    centers: Array
    widths: Array
    neck: float
    labels: NDArray[np.int64]


def find_touching(points: Array, table: Plane) -> Touching | None:
    """Whether ``points`` ``(n, 3)`` (one cluster on ``table``, at about the
    grid's spacing: downsampled, not thinned) are two objects that touch, and
    which point belongs to which."""
    p = np.asarray(points, dtype=np.float64)
    if len(p) < 20:
        return None
    uv = p @ plane_basis(table.normal)  # (n, 2) in the table plane
    lo = uv.min(axis=0) - 2 * CELL
    ij = np.floor((uv - lo) / CELL).astype(np.int64)  # (n, 2)
    shape = tuple(int(x) for x in ij.max(axis=0) + 3)
    if shape[0] * shape[1] > 4_000_000:  # larger than any tabletop object
        return None
    grid = np.zeros(shape, dtype=bool)
    grid[ij[:, 0], ij[:, 1]] = True
    # close the gaps between the samples, fill what the top surface hides
    grid = ndimage.binary_closing(grid, structure=np.ones((3, 3)))
    grid = ndimage.binary_fill_holes(grid)
    dist = ndimage.distance_transform_edt(grid) * CELL  # (h, w) inscribed radius

    # the widest part, then the widest whose centre lies outside the first's
    # inscribed disk (the neck test below decides whether they are two)
    flat = int(np.argmax(dist))
    a = np.array(np.unravel_index(flat, shape))
    ra = float(dist[tuple(a)])
    cells = np.argwhere(grid)  # (k, 2)
    d_cells = dist[grid]  # (k,)
    apart = np.linalg.norm((cells - a) * CELL, axis=1) > np.maximum(ra, d_cells)
    if not apart.any():
        return None
    k = int(np.argmax(np.where(apart, d_cells, -1.0)))
    b, rb = cells[k], float(d_cells[k])
    if 2 * min(ra, rb) < MIN_PART_WIDTH:
        return None
    # bottleneck: the highest level of the distance at which a and b connect;
    # just above it, each lies in a core of its own
    neck, cores = 0.0, None
    for level in np.linspace(min(ra, rb), 0.0, 25, endpoint=False):
        labels, _ = ndimage.label(dist >= level)
        if labels[tuple(a)] and labels[tuple(a)] == labels[tuple(b)]:
            neck = float(level)
            break
        cores = labels
    if cores is None or neck >= NECK_FRACTION * min(ra, rb):
        return None
    if _handle_length(dist, neck, a, b) > HANDLE_LENGTH * 2 * max(ra, rb):
        return None  # a handle joins two ends of one object
    # every footprint cell belongs to the nearer core
    seeds = np.zeros(shape, dtype=np.int64)
    seeds[cores == cores[tuple(a)]] = 1
    seeds[cores == cores[tuple(b)]] = 2
    _, nearest = ndimage.distance_transform_edt(seeds == 0, return_indices=True)
    parts = np.where(grid, seeds[nearest[0], nearest[1]], 0)
    # the neck must stand as tall as the objects: where the two parts meet
    boundary = (
        ndimage.binary_dilation(parts == 1) & ndimage.binary_dilation(parts == 2)
    ) & grid
    if not boundary.any():
        return None
    # each cell's highest point, for the heights at the neck and of the parts:
    # only for a footprint with a waist (most clusters have none)
    top = np.full(shape, -np.inf)
    np.maximum.at(top, (ij[:, 0], ij[:, 1]), table.signed_distance(p))
    top = ndimage.grey_dilation(top, size=(3, 3))
    neck_height = float(top[boundary].max())
    heights = [float(top[parts == i].max()) for i in (1, 2)]
    if neck_height < NECK_HEIGHT * min(heights):
        return None
    labels_pts = (parts[ij[:, 0], ij[:, 1]] == 2).astype(np.int64)
    centers = []
    for i in (0, 1):
        mine = p[labels_pts == i]
        centers.append(mine[np.argmax(table.signed_distance(mine))])
    return Touching(
        centers=np.array(centers),
        widths=np.array([2 * ra, 2 * rb]),
        neck=2 * neck,
        labels=labels_pts,
    )


def _handle_length(
    dist: Array, neck: float, a: NDArray[np.int64], b: NDArray[np.int64]
) -> float:
    """How long (m) the path between cells ``a`` and ``b`` runs narrower than
    ``HANDLE_WIDTH`` of the narrower one's inscribed radius: the shortest path
    (8-connected, in cells) through the footprint cells at least ``neck`` from
    its edge (``dist`` ``(h, w)``, m), the widest way between them."""
    from scipy.sparse import coo_matrix
    from scipy.sparse.csgraph import dijkstra

    inside = dist >= neck
    index = np.full(dist.shape, -1, dtype=np.int64)
    cells = np.argwhere(inside)  # (k, 2)
    index[inside] = np.arange(len(cells))
    rows, cols, weights = [], [], []
    for di, dj in ((0, 1), (1, 0), (1, 1), (1, -1)):
        j = cells + (di, dj)
        ok = (j[:, 0] < dist.shape[0]) & (j[:, 1] >= 0) & (j[:, 1] < dist.shape[1])
        k = np.flatnonzero(ok)
        other = index[j[k, 0], j[k, 1]]
        keep = other >= 0
        rows.append(k[keep])
        cols.append(other[keep])
        weights.append(np.full(int(keep.sum()), np.hypot(di, dj)))
    r, c, w = np.concatenate(rows), np.concatenate(cols), np.concatenate(weights)
    graph = coo_matrix((w, (r, c)), shape=(len(cells), len(cells))).tocsr()
    start, goal = int(index[tuple(a)]), int(index[tuple(b)])
    _, pred = dijkstra(graph, directed=False, indices=start, return_predecessors=True)
    if pred[goal] < 0:
        return 0.0
    narrow = HANDLE_WIDTH * min(float(dist[tuple(a)]), float(dist[tuple(b)]))
    length, node = 0.0, goal
    while node != start:
        prev = int(pred[node])
        if dist[tuple(cells[node])] < narrow:
            length += float(np.hypot(*(cells[node] - cells[prev])))
        node = prev
    return length * CELL


def split_touching(points: Array, touching: Touching) -> list[Array]:
    """The two objects' points, in the order of ``touching.centers``."""
    return [points[touching.labels == i] for i in (0, 1)]
