"""``clutter``: object instances in a pile, where objects touch, lean or stack.

The table and the connected clusters standing on it come from ``ransac_dbscan``
(its options, inherited). Each cluster is then split into instances by geometry
alone:

1. **Concave seams.** Objects are locally convex; where two touch, their
   surfaces meet in a concave seam (a box's side above the lower box's top, the
   valley between two cylinders). Normals are estimated from ``normal_neighbours``
   neighbours and turned towards the cameras that saw the points (the camera
   whose line of sight is most nearly along the normal; without viewpoints: up,
   or away from the cluster's axis). A neighbour pair ``i, j`` closer than
   ``edge_radius`` is concave where ``(n_i - n_j) · (p_i - p_j) / |p_i - p_j|``
   is below ``-concavity``. A point with ``seam_edges`` or more concave pairs
   lies on a seam; the cluster without its seam points falls into connected
   parts, and the parts of ``min_instance_points`` points or more are instances.
   Every other point goes to the instance of its nearest point.
2. **Waists.** Two boxes flush side by side with coplanar tops make no concave
   seam; where their footprint on the table has a waist at their full height
   (``wsgrasp.perception.touching``), it is split there, up to
   ``max_waist_splits`` times per cluster.

Two boxes of the same height flush along a whole face are one box to any depth
camera: they stay one instance. A part smaller than ``min_instance_points`` or
narrower than ``min_instance_extent`` is no instance (its points join the
nearest one), so a split is made only where each side is object-sized;
otherwise the cluster stays whole, and a target that is still clearly two
objects is refused by the pipeline with its hint, as with ``ransac_dbscan``.

Points above the table that belong to no instance (too small a cluster, DBSCAN
noise) are returned in ``info["unsegmented"]`` ``(k, 3)``: the pipeline treats
them as obstacles.
"""

from __future__ import annotations

from typing import Any, ClassVar

import numpy as np
from numpy.typing import NDArray
from pydantic import BaseModel, Field
from scipy.sparse import coo_matrix
from scipy.sparse.csgraph import connected_components, dijkstra
from scipy.spatial import cKDTree

from wsgrasp.perception.touching import find_touching
from wsgrasp.perception.types import Array, Plane, Segmentation
from wsgrasp_segmenters.ransac_dbscan import RansacDbscan, RansacDbscanOptions

__all__ = ["Clutter", "ClutterOptions", "split_instances"]


class ClutterOptions(RansacDbscanOptions):
    """Options of ``clutter``: those of ``ransac_dbscan`` for the table and the
    clusters, then the split into instances (metres)."""

    normal_neighbours: int = Field(
        12, ge=4, le=64, description="neighbours per normal estimate"
    )
    edge_radius: float = Field(
        0.012,
        gt=0.0,
        le=0.1,
        description="neighbour pairs closer than this are compared for concavity",
    )
    concavity: float = Field(
        0.15,
        gt=0.0,
        le=2.0,
        description="a pair is concave where (n_i - n_j)·(p_i - p_j)/|p_i - p_j| "
        "is below minus this",
    )
    seam_edges: int = Field(
        2, ge=1, description="a point with this many concave pairs lies on a seam"
    )
    min_instance_points: int = Field(
        40, ge=1, description="a smaller part is no instance of its own"
    )
    min_instance_extent: float = Field(
        0.02, ge=0.0, description="a part narrower than this (m) is no instance"
    )
    max_waist_splits: int = Field(
        4, ge=0, le=16, description="footprint waists split per cluster, at most"
    )


class Clutter:
    """Table and clusters by ``ransac_dbscan``, each cluster split into object
    instances at concave seams and footprint waists."""

    Options: ClassVar[type[BaseModel]] = ClutterOptions

    def segment(
        self,
        points: Array,
        options: ClutterOptions,
        *,
        seed: int,
        viewpoints: Array | None = None,
    ) -> Segmentation:
        """Find the table and every object instance standing on it.

        Returns
        -------
        Segmentation
            ``clusters`` are the instances, largest first; ``info`` has
            ``unsegmented`` (points above the table in no instance, ``(k, 3)``),
            ``splits`` (per cluster, the instances it was split into and how) and
            ``groups`` (per instance, the index of the cluster it was split from:
            instances of one group touch, and may be one object split at a
            concave seam of its own).

        Raises
        ------
        InputError
            As ``ransac_dbscan``: no table plane, or nothing stands on it.
        """
        p = np.asarray(points, dtype=np.float64)
        base = RansacDbscan().segment(p, options, seed=seed, viewpoints=viewpoints)
        table = base.table
        vp = None if viewpoints is None or not len(viewpoints) else viewpoints
        instances: list[Array] = []
        groups: list[int] = []
        splits: list[dict[str, Any]] = []
        for g, cluster in enumerate(base.clusters):
            parts, how = split_instances(cluster, table, options, vp)
            instances.extend(parts)
            groups.extend([g] * len(parts))
            splits.append({"points": int(len(cluster)), "instances": len(parts), **how})
        order = sorted(range(len(instances)), key=lambda k: -instances[k].shape[0])
        instances = [instances[k] for k in order]
        info = dict(base.info)
        info["splits"] = splits
        info["groups"] = [groups[k] for k in order]
        info["unsegmented"] = _unsegmented(p, table, base.clusters, options)
        return Segmentation(
            table=table,
            table_points=base.table_points,
            clusters=instances,
            info=info,
        )


def split_instances(
    cluster: Array,
    table: Plane,
    options: ClutterOptions,
    viewpoints: Array | None = None,
) -> tuple[list[Array], dict[str, int]]:
    """One connected cluster ``(n, 3)`` on ``table`` split into instances: at
    concave seams, then at footprint waists.

    Returns
    -------
    parts : list of (n_i, 3) float
        The instances (the cluster itself when it is one).
    how : dict
        ``seams``: instances after the seam split; ``waists``: waists split.
    """
    p = np.asarray(cluster, dtype=np.float64)
    o = options
    labels = _seam_labels(p, table, o, viewpoints)
    parts = [p[labels == k] for k in range(int(labels.max()) + 1)]
    seams = len(parts)
    waists = 0
    queue = list(parts)
    done: list[Array] = []
    while queue:
        part = queue.pop()
        # a waist splits a part only into two object-sized halves
        splittable = waists < o.max_waist_splits and (
            len(part) >= 2 * o.min_instance_points
        )
        touching = find_touching(part, table) if splittable else None
        if touching is None:
            done.append(part)
            continue
        halves = [part[touching.labels == i] for i in (0, 1)]
        if not all(_object_sized(h, o) for h in halves):
            done.append(part)
            continue
        waists += 1
        queue.extend(halves)
    done.sort(key=lambda c: -c.shape[0])
    return done, {"seams": seams, "waists": waists}


def _seam_labels(
    p: Array, table: Plane, o: ClutterOptions, viewpoints: Array | None
) -> NDArray[np.int64]:
    """Instance label ``(n,)`` of every point of one cluster ``p`` ``(n, 3)``,
    from the connected parts it falls into without its concave-seam points."""
    n = len(p)
    if n < 2 * o.min_instance_points:
        return np.zeros(n, dtype=np.int64)
    normals = _outward_normals(p, table, o.normal_neighbours, viewpoints)
    tree = cKDTree(p)
    pairs = tree.query_pairs(o.edge_radius, output_type="ndarray")  # (e, 2)
    if not len(pairs):
        return np.zeros(n, dtype=np.int64)
    i, j = pairs[:, 0], pairs[:, 1]
    d = p[i] - p[j]  # (e, 3)
    dist = np.linalg.norm(d, axis=1)
    ok = dist > 1e-9
    if not ok.all():
        i, j, d, dist = i[ok], j[ok], d[ok], dist[ok]
    c = np.einsum("ij,ij->i", normals[i] - normals[j], d) / dist  # (e,)
    concave = c < -o.concavity
    count = np.bincount(i[concave], minlength=n) + np.bincount(j[concave], minlength=n)
    seam = count >= o.seam_edges
    keep = ~concave & ~seam[i] & ~seam[j]
    graph = coo_matrix(
        (np.ones(int(keep.sum())), (i[keep], j[keep])), shape=(n, n)
    ).tocsr()
    _, comp = connected_components(graph, directed=False)
    comp[seam] = -1
    sizes = np.bincount(comp[~seam], minlength=int(comp.max()) + 1)
    big = [
        k
        for k in np.flatnonzero(sizes >= o.min_instance_points)
        if _object_sized(p[comp == k], o)
    ]
    if len(big) < 2:
        return np.zeros(n, dtype=np.int64)
    # every other point joins the instance it reaches first along pairs that are
    # not concave; one it cannot reach, the instance of its nearest point
    seeds = np.flatnonzero(np.isin(comp, big))
    remap = np.full(int(comp.max()) + 1, -1)
    remap[big] = np.arange(len(big))
    smooth = ~concave
    graph = coo_matrix((dist[smooth], (i[smooth], j[smooth])), shape=(n, n)).tocsr()
    reach, _, source = dijkstra(
        graph, directed=False, indices=seeds, min_only=True, return_predecessors=True
    )
    cut_off = np.flatnonzero(~np.isfinite(reach))
    if len(cut_off):
        _, nearest = cKDTree(p[seeds]).query(p[cut_off])
        source[cut_off] = seeds[nearest]
    return remap[comp[source]]  # type: ignore[no-any-return]


def _object_sized(part: Array, o: ClutterOptions) -> bool:
    """Whether ``part`` ``(n, 3)`` has ``min_instance_points`` points and is at
    least ``min_instance_extent`` wide along its second principal axis (a face
    seen from one side is thin along its third)."""
    if len(part) < o.min_instance_points:
        return False
    s = np.linalg.svd(part - part.mean(axis=0), compute_uv=False)  # (3,)
    # points spread evenly over a width w deviate w / sqrt(12) from their mean
    width = np.sqrt(12.0) * float(s[1]) / np.sqrt(len(part))
    return width >= o.min_instance_extent


def _outward_normals(p: Array, table: Plane, k: int, viewpoints: Array | None) -> Array:
    """Unit normals ``(n, 3)`` of ``p`` turned out of the objects: towards the
    camera whose line of sight is most nearly along each normal; without
    viewpoints, up where the normal is steep, else away from the cluster's
    vertical axis."""
    from wsgrasp.perception.frame import estimate_normals

    normals = estimate_normals(p, k=k)  # (n, 3), oriented away from the mean
    if viewpoints is not None:
        to_cam = viewpoints[None, :, :] - p[:, None, :]  # (n, k, 3)
        to_cam /= np.linalg.norm(to_cam, axis=2, keepdims=True)
        cos = np.einsum("nkc,nc->nk", to_cam, normals)  # (n, k)
        best = cos[np.arange(len(p)), np.argmax(np.abs(cos), axis=1)]
        sign = np.where(best < 0.0, -1.0, 1.0)
    else:
        up = table.normal
        steep = np.abs(normals @ up) > 0.5
        radial = p - p.mean(axis=0)
        radial -= np.outer(radial @ up, up)
        ref = np.where(steep[:, None], up[None, :], radial)
        sign = np.where(np.einsum("ij,ij->i", normals, ref) < 0.0, -1.0, 1.0)
    return normals * sign[:, None]  # type: ignore[no-any-return]


def _unsegmented(
    p: Array, table: Plane, clusters: list[Array], o: ClutterOptions
) -> Array:
    """Points of ``p`` between ``min_height`` and ``max_height`` above the
    table that are in none of ``clusters``, ``(k, 3)``."""
    h = table.signed_distance(p)
    above = p[(h > o.min_height) & (h < o.max_height)]
    if not clusters or not len(above):
        return above
    d, _ = cKDTree(np.concatenate(clusters)).query(above, distance_upper_bound=1e-9)
    return above[~np.isfinite(d)]  # type: ignore[no-any-return]
