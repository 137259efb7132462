"""Scene processing: cropping, voxel downsampling, clustering, plane fitting, target
selection. The building blocks the segmenter plugins share."""

from __future__ import annotations

from typing import Any

import numpy as np
from numpy.typing import ArrayLike, NDArray

from wsgrasp.errors import InputError
from wsgrasp.perception.pile import (
    PILE_RULES,
    cluster_members,
    containers,
    pile_target,
)
from wsgrasp.perception.types import Array, Segmentation

__all__ = [
    "cluster_labels",
    "crop",
    "downsample",
    "fit_plane_ransac",
    "preprocess",
    "select_target",
    "thin",
    "warm_up",
]


def _pcd(points: Array) -> Any:
    from wsgrasp._open3d import load_open3d

    o3d = load_open3d()

    return o3d.geometry.PointCloud(o3d.utility.Vector3dVector(points))


def warm_up() -> None:
    """Import open3d and run its first calls now (about 0.5-1 s once per process),
    so that the first plan's timing does not include them."""
    p = np.random.default_rng(0).uniform(-0.1, 0.1, (64, 3))
    downsample(p, 0.01)
    cluster_labels(p, 0.05, 2)


def downsample(points: ArrayLike, voxel: float) -> Array:
    """Voxel-grid downsampling: one point, the mean, per occupied voxel, in the
    order of the voxels (by x, then y, then z index).

    The voxels and means are open3d's ``voxel_down_sample``'s, bit for bit (the
    grid starts half a voxel below the least coordinates; a mean is the sum of
    the voxel's points in their order over their count); its order is its hash
    map's. Here in numpy, without converting the cloud: 2.3 to 2.9 times faster
    than open3d with the conversions on the bundled scenes (box_upright's 101,213
    points: 2.7 against 6.7 ms on the 2-core machine at load 4.6;
    ``benchmarks/preprocess.py``).

    Parameters
    ----------
    points : (n, 3) float
    voxel
        Edge length (m); ``0`` returns the points unchanged.

    Returns
    -------
    (m, 3) float
    """
    p = np.asarray(points, dtype=np.float64)
    if voxel <= 0.0 or p.shape[0] == 0:
        return p
    n = p.shape[0]
    # a column at a time: numpy reduces (n, 3) along axis 0 far more slowly
    cols = p.T  # (3, n) view
    lo = [float(c.min()) - voxel * 0.5 for c in cols]
    # voxel index of each column's greatest value: floor is monotonic
    dims = [
        int(np.floor((float(c.max()) - lo[k]) / voxel)) + 1 for k, c in enumerate(cols)
    ]
    cells = dims[0] * dims[1] * dims[2]  # Python ints: no overflow
    # few and small temporaries: on a 100,000-point cloud, faulting in fresh
    # pages took as long as the arithmetic
    tmp = np.empty(n)

    def index_of(k: int) -> Array:
        """The points' voxel index along axis ``k``, as floats in ``tmp``."""
        np.subtract(cols[k], lo[k], out=tmp)
        np.divide(tmp, voxel, out=tmp)
        return np.floor(tmp, out=tmp)

    if cells <= _DENSE_CELLS_PER_POINT * n:
        # a dense grid: the occupied cells in order, in O(n + cells)
        inverse = np.empty(n, dtype=np.intp)  # each point's cell, then voxel
        for k in range(3):
            if k:
                inverse *= dims[k]
                # in float64, exactly: every key is below 16 n, far below 2**53
                np.add(inverse, index_of(k), out=inverse, casting="unsafe")
            else:
                inverse[:] = index_of(k)
        occupied = np.zeros(cells, dtype=bool)
        occupied[inverse] = True
        cell = np.flatnonzero(occupied)  # (m,) ascending
        del occupied
        # each occupied cell's voxel number, in the smallest unsigned type that
        # holds them: box_upright's 14,793 voxels in uint16 halve this (cells,)
        # array against int32, and with it the fresh pages a plan touches (a
        # process planning box_upright over and over: 787 page faults per plan,
        # all in here, fell to none; preprocess 3.7 -> 2.3 ms)
        slot = np.empty(cells, dtype=np.min_scalar_type(cell.size))
        slot[cell] = np.arange(cell.size, dtype=slot.dtype)
        inverse[:] = slot[inverse]
        del slot
        counts = np.bincount(inverse, minlength=cell.size)
    else:
        index = np.empty((3, n), dtype=np.int64)
        for k in range(3):
            index[k] = index_of(k)
        if cells < 2**62:
            key = (index[0] * dims[1] + index[1]) * dims[2] + index[2]  # (n,)
            _, inverse, counts = np.unique(key, return_inverse=True, return_counts=True)
        else:  # a key would overflow: sort the rows
            _, inverse, counts = np.unique(
                index.T, axis=0, return_inverse=True, return_counts=True
            )
        inverse = inverse.reshape(-1)
    m = counts.size
    out = np.empty((m, 3))
    for k in range(3):  # bincount adds each voxel's points in their order
        tmp[:] = cols[k]  # contiguous, as bincount would copy it
        out[:, k] = np.bincount(inverse, weights=tmp, minlength=m) / counts
    return out


#: ``downsample`` counts voxels in a dense grid of up to this many cells per
#: point, and sorts their keys beyond
_DENSE_CELLS_PER_POINT = 16


def crop(
    points: ArrayLike, radius: float | None, center: ArrayLike = (0, 0, 0)
) -> Array:
    """Points ``(m, 3)`` within ``radius`` of ``center``; all points if ``radius`` is
    None."""
    p = np.asarray(points, dtype=np.float64)
    if radius is None:
        return p
    c = np.asarray(center, dtype=np.float64)
    keep = ((p - c) ** 2).sum(axis=1) <= radius * radius
    if not keep.any():
        raise InputError(
            f"no point lies within crop_radius {radius:g} m of the origin "
            f"(nearest at {np.sqrt(((p - c) ** 2).sum(axis=1).min()):.3g} m)",
            hint="raise preprocess.crop_radius or remove it",
        )
    return p.take(np.flatnonzero(keep), axis=0)  # faster than a mask over rows


def preprocess(scene: Any, options: Any) -> tuple[Array, Array]:
    """A scene's points ``(m, 3)`` as a plan takes them, by a spec's
    ``preprocess`` ``options``: its views' flying pixels dropped (where
    ``flying_pixels``; :func:`wsgrasp.perception.flying.without_flying`),
    cropped to ``crop_radius``, downsampled to ``voxel_size``; and the flying
    pixels dropped ``(k, 3)``."""
    from wsgrasp.perception.flying import without_flying

    kept, flying = without_flying(scene, options.flying_pixels)
    return downsample(crop(kept, options.crop_radius), options.voxel_size), flying


def thin(points: ArrayLike, max_points: int, seed: int = 0) -> Array:
    """At most ``max_points`` of ``points`` ``(n, 3)``, chosen by open3d's
    farthest-point sampling (from the first point: deterministic, ``seed`` is not
    needed) so the object keeps its shape."""
    p = np.asarray(points, dtype=np.float64)
    if p.shape[0] <= max_points:
        return p
    out = _pcd(p).farthest_point_down_sample(int(max_points))
    return np.asarray(out.points, dtype=np.float64)


def cluster_labels(
    points: ArrayLike, eps: float, core_points: int
) -> NDArray[np.int64]:
    """DBSCAN labels ``(n,)`` (open3d); ``-1`` is noise."""
    p = np.asarray(points, dtype=np.float64)
    if p.shape[0] == 0:
        return np.zeros(0, dtype=np.int64)
    labels = _pcd(p).cluster_dbscan(float(eps), int(core_points), print_progress=False)
    return np.asarray(labels, dtype=np.int64)


_RANSAC_BATCH = 64
_RANSAC_CONFIDENCE = 0.9999


def fit_plane_ransac(
    points: Array,
    distance: float,
    iterations: int,
    seed: int,
    *,
    score_points: int = 1024,
) -> tuple[Array, float, NDArray[np.int64]]:
    """RANSAC plane, seeded and deterministic, then refined by least squares.

    Hypotheses (planes through 3 random points) are scored in batches on a random
    subset of ``score_points`` points, until ``iterations`` or until enough were
    drawn to have hit the best plane's inliers with probability 0.9999; the best
    one's inliers among all points are then refitted twice by least squares.

    Not open3d's ``segment_plane``: on open3d 0.20, seeded with
    ``o3d.utility.random.seed(7)`` before every call, it gave another plane in 4 of
    396 calls on two clouds (e.g. 91,277 instead of 91,278 inliers of the
    ``box_upright`` scene; one in 40 calls under ``OMP_NUM_THREADS=8``): its
    iterations draw from one generator in parallel threads, so the draws depend on
    scheduling, and a run would not replay bit for bit. ``benchmarks/open3d_ransac.py``
    measures it again.

    Returns
    -------
    normal : (3,) float
        Unit normal (sign arbitrary).
    offset : float
    inliers : (k,) int
        Indices of points within ``distance`` of the plane.
    """
    p = np.asarray(points, dtype=np.float64)
    n = p.shape[0]
    none = (np.array([0.0, 0.0, 1.0]), 0.0, np.zeros(0, dtype=np.int64))
    if n < 3:
        return none
    rng = np.random.default_rng(seed)
    sub = p if n <= score_points else p[rng.choice(n, score_points, replace=False)]
    best_count, normal, offset = -1, none[0], 0.0
    done = 0
    needed = float(iterations)
    while done < min(needed, iterations):
        batch = min(_RANSAC_BATCH, iterations - done)
        tri = p[rng.integers(0, n, (batch, 3))]  # (b, 3 points, 3)
        u, v = tri[:, 1] - tri[:, 0], tri[:, 2] - tri[:, 0]  # (b, 3) each
        normals = np.column_stack(  # u x v, (b, 3)
            [
                u[:, 1] * v[:, 2] - u[:, 2] * v[:, 1],
                u[:, 2] * v[:, 0] - u[:, 0] * v[:, 2],
                u[:, 0] * v[:, 1] - u[:, 1] * v[:, 0],
            ]
        )
        length = np.linalg.norm(normals, axis=1)
        ok = length > 1e-12
        done += batch
        if not ok.any():
            continue
        normals = normals[ok] / length[ok, None]
        offsets = -(normals * tri[ok, 0]).sum(axis=1)  # (b,)
        # (m, b) distances of the subset to every hypothesis -> inlier counts (b,)
        counts = (np.abs(sub @ normals.T + offsets) <= distance).sum(axis=0)
        k = int(np.argmax(counts))
        if counts[k] > best_count:
            best_count, normal, offset = int(counts[k]), normals[k], float(offsets[k])
            # hypotheses needed to draw 3 inliers with probability _RANSAC_CONFIDENCE
            w3 = (best_count / sub.shape[0]) ** 3
            if w3 >= 1.0:
                needed = 0.0
            elif w3 > 0.0:
                needed = np.log(1 - _RANSAC_CONFIDENCE) / np.log1p(-w3)
    if best_count <= 0:
        return none
    inliers = np.flatnonzero(np.abs(p @ normal + offset) <= distance)
    for _ in range(2):
        if inliers.size < 3:
            break
        q = p.take(inliers, axis=0)  # (k, 3); a quarter of p[inliers]'s time
        c = q.mean(axis=0)
        _, _, vt = np.linalg.svd(q - c, full_matrices=False)
        normal = vt[2]
        offset = -float(normal @ c)
        inliers = np.flatnonzero(np.abs(p @ normal + offset) <= distance)
    return normal, offset, inliers


def _describe(clusters: list[Array]) -> str:
    sizes = ", ".join(str(c.shape[0]) for c in clusters[:6])
    more = ", ..." if len(clusters) > 6 else ""
    return f"{len(clusters)} clusters of {sizes}{more} points"


def select_target(segmentation: Segmentation, rule: Any) -> tuple[Array, list[Array]]:
    """The object to grasp and the obstacles, by the spec's ``TargetRule``.

    Parameters
    ----------
    segmentation
        A segmenter's result; ``clusters`` must not be empty.
    rule
        ``TargetRule``: ``largest``, ``nearest`` (to ``point``), ``inside_box``
        (cluster centroid within ``box_min``..``box_max``; the largest such),
        ``only`` (several clusters are an error), a pile's ``highest``,
        ``most_isolated`` or ``id`` (:func:`wsgrasp.perception.pile.pile_target`),
        or ``cluster``: instance ``id`` with every instance split from the same
        cluster, as one object (:func:`wsgrasp.perception.pile.cluster_members`).

    Returns
    -------
    object_points : (n, 3) float
    obstacles : list of (m_i, 3) float
        The other clusters, then the points above the table in no cluster
        (``segmentation.info["unsegmented"]``, where the segmenter gives them);
        empty when ``rule.obstacles`` is false.
    """
    clusters = list(segmentation.clusters)
    if not clusters:
        raise InputError(
            "nothing stands on the table: the segmenter found no object cluster",
            hint="check that the object is in view, or lower the segmenter's "
            "min_points / min_height",
        )
    sizes = np.array([c.shape[0] for c in clusters])
    name = rule.rule
    if name == "largest":
        # a container (a bin's walls) is no target while something lies in it
        k = int(np.argmax(np.where(containers(segmentation), -1, sizes)))
    elif name == "only":
        if len(clusters) > 1:
            raise InputError(
                f"target rule 'only' expects one object on the table, found "
                f"{_describe(clusters)}",
                hint="use target.rule largest, nearest (with point) or inside_box, "
                "or clear the table",
            )
        k = 0
    elif name == "nearest":
        q = np.asarray(rule.point, dtype=np.float64)
        dists = np.array([np.sqrt(((c - q) ** 2).sum(axis=1).min()) for c in clusters])
        k = int(np.argmin(dists))
    elif name == "cluster":
        members = cluster_members(segmentation, rule)
        if len(members) > 1:
            target = np.concatenate([clusters[i] for i in members])
            return target, _obstacles(segmentation, clusters, members, rule)
        k = members[0]
    elif name in PILE_RULES:
        k = pile_target(segmentation, rule)
    elif name == "inside_box":
        lo = np.asarray(rule.box_min, dtype=np.float64)
        hi = np.asarray(rule.box_max, dtype=np.float64)
        cents = np.stack([c.mean(axis=0) for c in clusters])  # (k, 3)
        inside = ((cents >= lo) & (cents <= hi)).all(axis=1)
        if not inside.any():
            raise InputError(
                f"no object's centroid lies inside the target box {tuple(lo)}.."
                f"{tuple(hi)}; centroids found: "
                + ", ".join(str(tuple(np.round(c, 3))) for c in cents[:6]),
                hint="move target.box_min/box_max (world frame, metres) around the "
                "object",
            )
        k = int(np.argmax(np.where(inside, sizes, -1)))
    else:
        raise InputError(
            f"unknown target rule {name!r}, expected largest, nearest, inside_box, "
            "only, highest, most_isolated, id or cluster",
            hint="set target.rule in the spec",
        )
    return clusters[k], _obstacles(segmentation, clusters, [k], rule)


def _obstacles(
    segmentation: Segmentation, clusters: list[Array], target: list[int], rule: Any
) -> list[Array]:
    """The clusters not in ``target`` (ids), then the unsegmented points; none
    when ``rule.obstacles`` is false."""
    if not getattr(rule, "obstacles", True):
        return []
    obstacles = [c for i, c in enumerate(clusters) if i not in target]
    stray = segmentation.info.get("unsegmented")
    if stray is not None and len(stray):
        obstacles.append(stray)
    return obstacles
