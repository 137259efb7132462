"""Exact "which finger's spheres hold this point" queries, fast for many points.

Two levels, both exact:

1. A voxel grid over the fingers' spheres, classified once per gripper: per cell and
   finger, *full* (the whole cell lies strictly inside one of the finger's spheres),
   *empty* (no sphere of the finger reaches into the cell) or *partial*. Most
   points are answered by one lookup.
2. A point in a partial cell is tested against the few spheres that reach into
   that cell (a compressed list per cell), with the same arithmetic as a brute-force
   test, so the answer is the brute-force answer even on a sphere's surface.

Neither level's cost grows with the number of spheres per finger.
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


class _PartialCells:
    """For one finger: the spheres reaching into each partial cell (CSR lists)."""

    def __init__(
        self, n_cells: int, cell: NDArray[np.int64], sphere: NDArray[np.int64]
    ) -> None:
        order = np.lexsort((sphere, cell))
        cell, sphere = cell[order], sphere[order]
        cells, counts = np.unique(cell, return_counts=True)
        # compact id of each partial cell, -1 elsewhere
        self.index = np.full(n_cells, -1, dtype=np.int64)
        self.index[cells] = np.arange(len(cells))
        self.start = np.concatenate([[0], np.cumsum(counts)[:-1]]).astype(np.int64)
        self.count = counts.astype(np.int64)
        self.sphere = sphere.astype(np.int64)


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
        self._fingers: list[tuple[Array, Array, _PartialCells]] = []
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
            keep = touch & (status[i] == _PARTIAL)
            partial = _PartialCells(len(cells), i[keep], j[keep])
            self._fingers.append((centers, radii, partial))
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
        flat_f = np.zeros(shape)
        for axis, (c, stride) in enumerate(zip((x, y, z), self._strides, strict=True)):
            q = np.floor((c - self.origin[axis]) * (1.0 / self.cell))
            np.clip(q, 0.0, float(self._last[axis]), out=q)
            q *= float(stride)
            flat_f += q
        flat = flat_f.astype(np.int64).ravel()
        status = self.status[flat]  # (n, nf)
        out = status == _FULL
        partial = status == _PARTIAL
        if partial.any():
            px, py, pz = (np.ravel(c) for c in (x, y, z))
            for f, (centers, radii, cells) in enumerate(self._fingers):
                idx = np.flatnonzero(partial[:, f])
                if idx.size:
                    out[idx, f] = _inside_listed(
                        px[idx], py[idx], pz[idx], flat[idx], centers, radii, cells
                    )
        return out.reshape(*shape, self.num_fingers)


def _inside_listed(
    x: Array,
    y: Array,
    z: Array,
    flat: NDArray[np.int64],
    centers: Array,
    radii: Array,
    cells: _PartialCells,
) -> NDArray[np.bool_]:
    """Whether each point (coordinates ``(k,)``, cells ``flat``) lies strictly inside
    one of the spheres listed for its cell."""
    k = cells.index[flat]  # (k,) compact cell ids, all >= 0 for partial cells
    count = cells.count[k]
    point = np.repeat(np.arange(len(flat)), count)  # (m,) one row per pair
    # position of each pair in the CSR list: its cell's start + its rank there
    first = np.repeat(np.cumsum(count) - count, count)
    sphere = cells.sphere[
        np.repeat(cells.start[k], count) + np.arange(len(point)) - first
    ]
    c = centers[sphere]  # (m, 3)
    # the same arithmetic as a brute-force test: sum of squares over x, y, z
    diff = np.stack([x[point], y[point], z[point]], axis=-1) - c
    inside = np.sum(diff**2, axis=-1) < radii[sphere] * radii[sphere]
    out = np.zeros(len(flat), dtype=bool)
    out[point[inside]] = True
    return out
