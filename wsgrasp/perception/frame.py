"""Object frame, bounding-box samples, table frame and table superellipsoid.

The object frame follows section III-A of the paper (``farthest_split``):

1. origin at the centroid of the object cloud;
2. the two farthest points of the cloud (its diameter) split it by which of the two
   is nearer; the centroids of the two halves give z, the major axis; the split is
   then repeated with the plane through the centroid perpendicular to z until z
   settles (the first split leans towards the diagonal of box-like objects, whose
   farthest points are opposite corners);
3. the cloud is projected onto the plane perpendicular to z and the same split is
   made there (two farthest projected points, nearer-of-two split): the centroids of
   the two halves, made orthogonal to z, give x;
4. y = z × x (right-handed).

The paper projects onto the camera's xy plane in step 3, which makes x depend on the
camera; splitting inside the plane perpendicular to z instead gives the same kind of
axis (the longest direction across z) in every frame. ``pca`` uses the principal
axes of the covariance instead. The sign of each axis is set by the third moment of
the cloud along it (the heavier tail is positive), so the frame moves with the
object, up to a sign flip for objects symmetric about an axis.
"""

from __future__ import annotations

import functools
from dataclasses import dataclass
from typing import Literal

import numpy as np
from numpy.typing import ArrayLike, NDArray

from wsgrasp.errors import InputError
from wsgrasp.geometry import transform_from
from wsgrasp.perception.types import Array, Plane

__all__ = [
    "MIN_OBJECT_POINTS",
    "MIN_OBJECT_THICKNESS",
    "ObjectFrame",
    "check_object",
    "estimate_normals",
    "grid_shape",
    "object_frame",
    "sample_box",
    "table_frame",
    "table_superellipsoid",
]

#: an object cloud with fewer points cannot be given a frame
MIN_OBJECT_POINTS = 10
#: an object thinner than this (m) along its thinnest principal axis is a flat sheet
MIN_OBJECT_THICKNESS = 0.002
_EPS = 1e-12
_REFINE_ITERATIONS = 25


@dataclass
class ObjectFrame:
    """The object's frame and box.

    Attributes
    ----------
    T_world_object : (4, 4) float
        Origin at the centroid, z the major axis.
    extents : (3,) float
        Box size along the object's x, y, z (m).
    box_center : (3,) float
        Box centre in the object frame.
    method : str
    """

    T_world_object: Array
    extents: Array
    box_center: Array
    method: str = "farthest_split"

    @property
    def centroid(self) -> Array:
        """Object centroid ``(3,)`` in the world frame."""
        return self.T_world_object[:3, 3]


def check_object(points: ArrayLike, name: str = "object") -> Array:
    """Return the object cloud as float64 ``(n, 3)``, or raise ``InputError`` when it
    is too small or flat to be given a frame."""
    p = np.asarray(points, dtype=np.float64)
    if p.ndim != 2 or p.shape[1] != 3:
        raise InputError(
            f"{name} cloud has shape {p.shape}, expected (n, 3)",
            hint="pass the object's points, one per row",
        )
    if p.shape[0] < MIN_OBJECT_POINTS:
        raise InputError(
            f"{name} has {p.shape[0]} points, expected at least {MIN_OBJECT_POINTS}",
            hint="use a smaller voxel_size, capture more views, or lower the "
            "segmenter's min_points",
        )
    if not np.isfinite(p).all():
        raise InputError(
            f"{name} cloud has NaN/inf points", hint="drop non-finite points first"
        )
    centred = p - p.mean(axis=0)
    # rows of vt are the principal axes, thinnest last
    _, sv, vt = np.linalg.svd(centred, full_matrices=False)
    thickness = float(np.ptp(centred @ vt[2]))
    if thickness < MIN_OBJECT_THICKNESS or sv[1] < _EPS:
        raise InputError(
            f"{name} is flat: {thickness * 1000:.2f} mm thick along its thinnest "
            f"axis, expected at least {MIN_OBJECT_THICKNESS * 1000:g} mm",
            hint="a flat sheet cannot be grasped from a single side view; check "
            "that the segmentation kept the object and not a piece of the table",
        )
    return p


def _squared_norms(diff: Array) -> Array:
    """``(diff ** 2).sum(axis=-1)`` of differences ``(..., d)`` (d < 8), bit for
    bit: numpy adds fewer than eight terms one after the other from the first, as
    here, but through its general reduction over a short axis, which took about
    twice as long (the 73 hull vertices' pairs of a bundled object: 175 against
    95 us)."""
    sq = diff * diff  # (..., d)
    out = sq[..., 0].copy()
    for k in range(1, sq.shape[-1]):
        out += sq[..., k]
    return out


def _farthest_pair(points: Array) -> tuple[int, int]:
    """Indices of the two farthest points of ``(n, d)`` points (d = 2 or 3).

    Exact on the convex hull's vertices; two farthest-point passes if the hull is
    degenerate.
    """
    from scipy.spatial import ConvexHull, QhullError

    try:
        idx = ConvexHull(points).vertices
    except (QhullError, ValueError):
        a = int(np.argmax(_squared_norms(points - points.mean(axis=0))))
        b = int(np.argmax(_squared_norms(points - points[a])))
        return a, b
    hull = points[idx]
    # (h, h) squared distances between hull vertices
    d2 = _squared_norms(hull[:, None, :] - hull[None, :, :])
    i, j = np.unravel_index(int(np.argmax(d2)), d2.shape)
    return int(idx[i]), int(idx[j])


def _split_axis(points: Array) -> Array:
    """Direction between the centroids of the halves nearer each of the two farthest
    points; ``points`` is ``(n, d)`` and centred."""
    a, b = _farthest_pair(points)
    da = _squared_norms(points - points[a])  # (n,)
    db = _squared_norms(points - points[b])
    near_b = db < da
    if near_b.all() or not near_b.any():
        axis = points[b] - points[a]
    else:
        axis = points[near_b].mean(axis=0) - points[~near_b].mean(axis=0)
    axis = axis / max(float(np.linalg.norm(axis)), _EPS)
    # Refinement: split again by the plane through the centroid perpendicular to
    # the axis until it settles. The first split is biased towards the diagonal of
    # box-like objects (their farthest points are opposite corners).
    for _ in range(_REFINE_ITERATIONS):
        side = points @ axis > 0.0
        if side.all() or not side.any():
            break
        new = points[side].mean(axis=0) - points[~side].mean(axis=0)
        new = new / max(float(np.linalg.norm(new)), _EPS)
        settled = abs(float(new @ axis)) > 1.0 - 1e-9
        axis = new
        if settled:
            break
    return np.asarray(axis)


def _orient(axis: Array, centred: Array) -> Array:
    """Flip ``axis`` so that the cloud's third moment along it is positive."""
    s = centred @ axis
    return axis if float((s**3).sum()) >= 0.0 else -axis


def object_frame(
    points: ArrayLike, method: Literal["farthest_split", "pca"] = "farthest_split"
) -> ObjectFrame:
    """The object frame and box of an object cloud.

    Parameters
    ----------
    points : (n, 3) float
        Object cloud, world frame.
    method
        ``farthest_split`` (the paper's) or ``pca``.

    Returns
    -------
    ObjectFrame
    """
    p = check_object(points)
    c = p.mean(axis=0)
    centred = p - c
    if method == "pca":
        evals, evecs = np.linalg.eigh(centred.T @ centred)
        z = evecs[:, 2]
        x = evecs[:, 1]
    elif method == "farthest_split":
        z = _split_axis(centred)
        # basis (u, v) of the plane perpendicular to z
        helper = np.eye(3)[int(np.argmin(np.abs(z)))]
        u = np.cross(z, helper)
        u /= np.linalg.norm(u)
        v = np.cross(z, u)
        planar = centred @ np.stack([u, v], axis=1)  # (n, 2) projection
        x2 = _split_axis(planar)
        x = x2[0] * u + x2[1] * v
    else:
        raise InputError(
            f"object frame method {method!r} is unknown, expected "
            "'farthest_split' or 'pca'",
            hint="set object_frame.method in the spec",
        )
    z = _orient(z / np.linalg.norm(z), centred)
    x = x - (x @ z) * z
    x = _orient(x / max(float(np.linalg.norm(x)), _EPS), centred)
    y = np.cross(z, x)
    R = np.stack([x, y, z], axis=1)  # columns are the object axes in world
    local = centred @ R  # (n, 3) in the object frame
    lo, hi = local.min(axis=0), local.max(axis=0)
    return ObjectFrame(
        T_world_object=transform_from(R, c),
        extents=hi - lo,
        box_center=(hi + lo) / 2.0,
        method=method,
    )


# --------------------------------------------------------------------------------
# box samples
# --------------------------------------------------------------------------------
_GRID_RATIO = np.array([7.0, 7.0, 3.0])  # the authors' 7 x 7 x 3 grid for ns = 147


@functools.lru_cache(maxsize=64)
def grid_shape(points: int) -> tuple[int, int, int]:
    """Grid ``(nx, ny, nz)`` for about ``points`` samples with the authors' 7:7:3
    proportions (fewer along the major axis z); ``147`` gives exactly ``(7, 7, 3)``.

    The product equals ``points`` when a grid near those proportions has it;
    otherwise it is the nearest such product. Remembered per ``points``: a plan
    asks for the same one every time, and the search over candidate grids takes
    about 0.3 ms.
    """
    if points < 1:
        raise InputError(
            f"sampling.points is {points}, expected at least 1",
            hint="set sampling.points (ns) to e.g. 147",
        )
    k = (points / float(np.prod(_GRID_RATIO))) ** (1.0 / 3.0)
    hi = int(np.ceil(k * _GRID_RATIO.max() * 3)) + 2
    r = np.arange(1, hi + 1)
    gx, gy, gz = np.meshgrid(r, r, r, indexing="ij")  # (hi, hi, hi) candidates
    prod = gx * gy * gz
    ideal = k * _GRID_RATIO
    shape_cost = (
        np.log(gx / ideal[0]) ** 2
        + np.log(gy / ideal[1]) ** 2
        + np.log(gz / ideal[2]) ** 2
    )
    count_cost = np.abs(np.log(prod / points))
    # an exact count wins over proportions unless the grid is far off its shape
    cost = 20.0 * count_cost + shape_cost + 1e-6 * np.abs(gx - gy)
    i = np.unravel_index(int(np.argmin(cost)), cost.shape)
    return int(gx[i]), int(gy[i]), int(gz[i])


def sample_box(frame: ObjectFrame, sampling: object) -> Array:
    """Grid samples in the object's box, object frame.

    Parameters
    ----------
    frame
        From ``object_frame``.
    sampling
        The spec's ``Sampling`` (``grid`` or ``points``, and ``scale``).

    Returns
    -------
    (ns, 3) float
        Centred on ``frame.box_center``, spanning ``extents * scale`` from −d/2 to
        +d/2 inclusive along each axis; ordered x slowest, z fastest.
    """
    grid = getattr(sampling, "grid", None)
    shape = tuple(grid) if grid is not None else grid_shape(int(sampling.points))  # type: ignore[attr-defined]
    scale = np.asarray(getattr(sampling, "scale", (1.0, 1.0, 1.0)), dtype=np.float64)
    d = frame.extents * scale
    axes = [
        np.linspace(-di / 2.0, di / 2.0, int(n)) if n > 1 else np.zeros(1)
        for di, n in zip(d, shape, strict=True)
    ]
    g = np.stack(np.meshgrid(*axes, indexing="ij"), axis=-1)  # (nx, ny, nz, 3)
    return g.reshape(-1, 3) + frame.box_center  # (ns, 3)


# --------------------------------------------------------------------------------
# table
# --------------------------------------------------------------------------------
def table_frame(plane: Plane, object_centroid: ArrayLike) -> Array:
    """``T_world_table``: z the plane normal towards the object, origin the object
    centroid projected onto the plane, x the world axis least aligned with z made
    orthogonal to it.

    Returns
    -------
    (4, 4) float
    """
    c = np.asarray(object_centroid, dtype=np.float64).reshape(3)
    n = np.asarray(plane.normal, dtype=np.float64)
    norm = float(np.linalg.norm(n))
    n = n / norm
    offset = plane.offset / norm
    h = float(c @ n + offset)
    if h < 0.0:
        n, offset, h = -n, -offset, -h
    origin = c - h * n
    helper = np.eye(3)[int(np.argmin(np.abs(n)))]
    x = helper - (helper @ n) * n
    x /= np.linalg.norm(x)
    y = np.cross(n, x)
    return transform_from(np.stack([x, y, n], axis=1), origin)


def table_superellipsoid(settings: object) -> tuple[Array, Array, float]:
    """The table's special ellipsoid in the table frame.

    Parameters
    ----------
    settings
        The spec's ``TableSettings`` (``semi_axes``, ``exponent``, ``clearance``).

    Returns
    -------
    center : (3,) float
        ``semi_axes[2]`` below the surface, raised by ``clearance``.
    semi_axes : (3,) float
    exponent : float
    """
    semi = np.asarray(settings.semi_axes, dtype=np.float64)  # type: ignore[attr-defined]
    clearance = float(getattr(settings, "clearance", 0.0))
    center = np.array([0.0, 0.0, -semi[2] + clearance])
    return center, semi, float(settings.exponent)  # type: ignore[attr-defined]


# --------------------------------------------------------------------------------
# normals
# --------------------------------------------------------------------------------
def estimate_normals(
    points: ArrayLike,
    center: ArrayLike | None = None,
    k: int = 15,
    *,
    rows: ArrayLike | None = None,
) -> Array:
    """Surface normals from ``k`` nearest neighbours (open3d), each oriented away
    from ``center`` (the object centroid; the cloud's mean if None).

    Parameters
    ----------
    points : (n, 3) float
    center : (3,) float, optional
    k
        Neighbours per normal.
    rows : (r,) int, optional
        Only the normals of these points (their neighbours still found among all
        the points), each bit for bit the one the whole cloud's estimate gives it
        (see :func:`_normals_of_rows`).

    Returns
    -------
    (n, 3) float, or (r, 3) with ``rows``
        Unit normals.
    """
    p = np.asarray(points, dtype=np.float64)
    c = p.mean(axis=0) if center is None else np.asarray(center, dtype=np.float64)
    at = None if rows is None else np.asarray(rows, dtype=np.int64).reshape(-1)
    n = None if at is None else _normals_of_rows(p, at, int(k))
    if n is None:
        n = _open3d_normals(p, int(k))
        if at is not None:
            n = n[at]
    q = p if at is None else p[at]
    outward = ((q - c) * n).sum(axis=1) < 0.0
    n[outward] *= -1.0
    return n


def _open3d_normals(p: Array, k: int, covariances: Array | None = None) -> Array:
    """open3d's unoriented normals of the points ``p`` (n, 3) from their ``k``
    nearest neighbours, or from the given ``covariances`` (n, 3, 3)."""
    from wsgrasp._open3d import load_open3d

    o3d = load_open3d()

    pcd = o3d.geometry.PointCloud(o3d.utility.Vector3dVector(p))
    if covariances is not None:  # open3d then takes them instead of its own
        pcd.covariances = o3d.utility.Matrix3dVector(covariances)
    pcd.estimate_normals(o3d.geometry.KDTreeSearchParamKNN(knn=k))
    return np.asarray(pcd.normals, dtype=np.float64).copy()


#: neighbour distances closer than this (relative) may be ordered differently by
#: open3d's search than by scipy's; rows with such near-ties take open3d's path
_TIE_RTOL = 1e-9


def _normals_of_rows(p: Array, rows: NDArray[np.int64], k: int) -> Array | None:
    """open3d's unoriented normals of the points ``p[rows]`` within the whole
    cloud ``p``, computed for those rows only; None when this cannot promise
    open3d's bits (few points, or a near-tie among some row's ``k + 1`` nearest
    distances), so the caller takes open3d's path.

    open3d estimates a normal from its ``k`` nearest neighbours, nearest first:
    their covariance, accumulated in that order (``ComputeCovariance``: the sums
    of the coordinates and of their products, divided by ``k``, less the
    products of the means), then its eigenvector of least eigenvalue. Here the
    neighbours come from scipy's KD-tree in the same order (a near-tie could
    order them otherwise, hence the check), the covariances are accumulated in
    the same order with the same operations, and open3d computes the
    eigenvectors from them. ``tests/test_table1_fast_paths.py`` holds the result
    to open3d's whole-cloud estimate bit for bit (an open3d that accumulated
    otherwise would fail there).

    Why not open3d alone: it estimates every point's normal or none, and the
    contact-normal scorer needs those of the held points only. On
    ``box_upright.npz``'s 800 object points, all of them took 1.36 ms and 51 rows
    0.46 ms here (medians of 300, side by side, load 3.5), a quarter of the
    Franka hand's Table I search. open3d 0.20's API has no per-point estimate.
    """
    from scipy.spatial import cKDTree

    n_pts = len(p)
    if n_pts <= k or len(rows) == 0:
        return None
    # the tree's shape changes how it searches, not what it finds; unbalanced and
    # uncompacted, it builds in two thirds of the time
    tree = cKDTree(p, balanced_tree=False, compact_nodes=False)
    d, nb = tree.query(p[rows], k=k + 1)  # (r, k + 1) nearest first
    gaps = np.diff(d, axis=1)  # (r, k)
    if np.any(gaps <= _TIE_RTOL * d[:, 1:]):
        return None
    x, y, z = p[nb[:, :k].T].transpose(2, 0, 1)  # (k, r) each, nearest first
    terms = np.stack([x, y, z, x * x, x * y, x * z, y * y, y * z, z * z], axis=1)
    s = np.zeros((9, len(rows)))  # the cumulants, summed in open3d's order
    for t in range(k):
        s += terms[t]  # (9, r) every row's t-th neighbour
    s /= float(k)
    cov = np.empty((len(rows), 3, 3))
    cov[:, 0, 0] = s[3] - s[0] * s[0]
    cov[:, 1, 1] = s[6] - s[1] * s[1]
    cov[:, 2, 2] = s[8] - s[2] * s[2]
    cov[:, 0, 1] = cov[:, 1, 0] = s[4] - s[0] * s[1]
    cov[:, 0, 2] = cov[:, 2, 0] = s[5] - s[0] * s[2]
    cov[:, 1, 2] = cov[:, 2, 1] = s[7] - s[1] * s[2]
    return _open3d_normals(p[rows], k, cov)
