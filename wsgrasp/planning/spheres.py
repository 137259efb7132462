"""Exact "which finger's spheres hold this point" queries, fast for many points.

Two levels, both exact:

1. A voxel grid over the fingers' spheres, classified once per gripper: per cell and
   finger, *full* (the whole cell lies strictly inside one of the finger's spheres),
   *empty* (no sphere of the finger reaches into the cell) or *partial*. Most
   points are answered by one lookup.
2. Points in partial cells are answered exactly: a point lies inside some sphere
   ``(c, r)`` of a finger exactly when its nearest neighbour among the lifted
   centres ``(c, sqrt(R² - r²))`` (``R`` the finger's largest radius) lies closer
   than ``R`` to ``(p, 0)`` — one KD-tree query, whatever the number of spheres.
"""

from __future__ import annotations

import numpy as np
from numpy.typing import NDArray
from scipy.spatial import cKDTree

from wsgrasp.gripper.model import GripperModel

__all__ = ["FingerSpheres"]

Array = NDArray[np.float64]

_EMPTY, _FULL, _PARTIAL = 0, 1, 2
#: classification margin (m): cells this close to a sphere's surface are partial
_MARGIN = 1e-9


class FingerSpheres:
    """Exact point-in-sphere queries per finger.

    Parameters
    ----------
    gripper : GripperModel
    cell : float, optional
        Grid cell size (m); by default half the smallest sphere radius, at least
        2 mm.
    """

    def __init__(self, gripper: GripperModel, cell: float | None = None) -> None:
        self.num_fingers = nf = gripper.num_fingers
        centers_all = gripper.sphere_centers
        radii_all = gripper.sphere_radii
        h = cell if cell is not None else max(0.5 * float(radii_all.min()), 0.002)
        # two cells of margin that no sphere reaches (cell centres 1.5 h away)
        lo = (centers_all - radii_all[:, None]).min(axis=0) - 2 * h
        hi = (centers_all + radii_all[:, None]).max(axis=0) + 2 * h
        shape = np.maximum(np.ceil((hi - lo) / h).astype(np.int64), 1)
        self.cell, self.origin, self.shape = h, lo, shape
        # cell centres: (nx * ny * nz, 3)
        axes = [lo[i] + h * (np.arange(shape[i]) + 0.5) for i in range(3)]
        cells = np.stack(np.meshgrid(*axes, indexing="ij"), axis=-1).reshape(-1, 3)
        half_diag = 0.5 * h * np.sqrt(3.0)
        cell_tree = cKDTree(cells)
        self.status = np.empty((len(cells), nf), dtype=np.uint8)
        self._exact = []
        for f in range(nf):
            sel = gripper.sphere_finger == f
            centers, radii = centers_all[sel], radii_all[sel]
            R = float(radii.max())
            # every (cell, sphere) pair close enough to touch: d - δ < r ≤ R
            pairs = cell_tree.sparse_distance_matrix(
                cKDTree(centers), R + half_diag + 1e-6, output_type="ndarray"
            )
            i, j, d = pairs["i"], pairs["j"], pairs["v"]
            touch = d - half_diag < radii[j] + _MARGIN
            full = d + half_diag < radii[j] - _MARGIN
            status = np.full(len(cells), _EMPTY, dtype=np.uint8)
            status[i[touch]] = _PARTIAL
            status[i[full]] = _FULL
            self.status[:, f] = status
            lifted = np.hstack([centers, np.sqrt(R * R - radii * radii)[:, None]])
            self._exact.append((cKDTree(lifted), centers, radii, R))
        self._strides = np.array([shape[1] * shape[2], shape[2], 1], dtype=np.int64)
        self._last = shape - 1

    def holding(self, points: Array) -> NDArray[np.bool_]:
        """Which finger's spheres hold each point.

        Parameters
        ----------
        points : (n, 3) float
            In the gripper frame.

        Returns
        -------
        (n, nf) bool
        """
        p = np.asarray(points, dtype=np.float64)
        return self.holding_coordinates(p[:, 0], p[:, 1], p[:, 2])

    def holding_coordinates(self, x: Array, y: Array, z: Array) -> NDArray[np.bool_]:
        """:meth:`holding` for points given as three coordinate arrays.

        Parameters
        ----------
        x, y, z : (...) float
            In the gripper frame, all of one shape.

        Returns
        -------
        (..., nf) bool
        """
        shape = np.shape(x)
        # flat cell index of each point, computed in floats (exact below 2**53);
        # points outside the grid are clipped into its margin, two cells of which
        # no sphere reaches, so they read as empty
        flat = np.zeros(shape)
        for axis, (c, stride) in enumerate(zip((x, y, z), self._strides, strict=True)):
            q = np.floor((c - self.origin[axis]) * (1.0 / self.cell))
            np.clip(q, 0.0, float(self._last[axis]), out=q)
            q *= float(stride)
            flat += q
        status = self.status[flat.astype(np.int64).ravel()]  # (n, nf)
        out = status == _FULL
        partial = status == _PARTIAL
        if partial.any():
            px, py, pz = (np.ravel(c) for c in (x, y, z))
            for f, (tree, centers, radii, R) in enumerate(self._exact):
                idx = np.flatnonzero(partial[:, f])
                if idx.size == 0:
                    continue
                pts = np.stack([px[idx], py[idx], pz[idx]], axis=-1)  # (k, 3)
                out[idx, f] = _exact_inside(pts, tree, centers, radii, R)
        return out.reshape(*shape, self.num_fingers)


def _exact_inside(
    pts: Array, tree: cKDTree, centers: Array, radii: Array, R: float
) -> NDArray[np.bool_]:
    """Whether each point ``(k, 3)`` lies strictly inside any of the spheres."""
    out = np.zeros(len(pts), dtype=bool)
    query = np.hstack([pts, np.zeros((len(pts), 1))])  # (k, 4)
    _, nearest = tree.query(query, k=1, distance_upper_bound=R * (1.0 + 1e-9))
    found = np.flatnonzero(nearest < len(centers))
    nearest = nearest[found]
    # exact test against the sphere nearest in power distance
    d2 = np.sum((pts[found] - centers[nearest]) ** 2, axis=-1)
    inside = d2 < radii[nearest] * radii[nearest]
    out[found[inside]] = True
    # points on a surface to within rounding: every sphere, as a brute force test
    # would (a handful of points at most)
    edge = found[~inside]
    if edge.size:
        diff = pts[edge, None, :] - centers  # (e, nsp, 3)
        out[edge] = np.any(np.sum(diff**2, axis=-1) < radii * radii, axis=1)
    return out
