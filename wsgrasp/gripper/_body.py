"""The gripper body: its point cloud and the superellipsoids that enclose it."""

from __future__ import annotations

from collections.abc import Callable, Mapping
from dataclasses import dataclass

import numpy as np
from numpy.typing import NDArray

from wsgrasp.errors import GripperError
from wsgrasp.geometry import (
    box_corner_se_factors,
    enclosing_scale,
    farthest_point_indices,
)
from wsgrasp.gripper._urdf import Kinematics, shape_mesh

Array = NDArray[np.float64]

#: dense surface samples per cloud point before farthest-point thinning
DENSE_PER_POINT = 24
#: at least this many dense samples
DENSE_MIN = 12000
#: smallest SE semi-axis (m), for flat or degenerate groups
MIN_SEMI_AXIS = 1e-3
#: SE fitting: cost of a m³ of finger workspace swallowed, relative to a m³ of air
WORKSPACE_WEIGHT = 4.0
#: SE fitting: workspace points kept for intrusion estimates
WORKSPACE_SUBSAMPLE = 5000


@dataclass
class BodySamples:
    """Dense surface samples of the gripper in the pre-grasp posture."""

    points: Array  # (N, 3) base frame
    link: NDArray[np.int64]  # (N,) index into links
    links: list[str]


def sample_body(
    kin: Kinematics,
    base_link: str,
    pregrasp: Mapping[str, float],
    count: int,
    seed: int = 0,
) -> BodySamples:
    """Sample the collision geometry of every link below ``base_link`` evenly by
    area, posed in the pre-grasp configuration, in the base frame."""
    import trimesh

    poses = kin.link_poses(base_link, pregrasp)
    meshes, owners, links = [], [], []
    for link, T in poses.items():
        shapes = kin.shapes.get(link, [])
        if not shapes:
            continue
        links.append(link)
        for shape in shapes:
            mesh = shape_mesh(shape)
            mesh.apply_transform(T)
            meshes.append(mesh)
            owners.append(len(links) - 1)
    if not meshes:
        raise GripperError(
            f"URDF {kin.path.name}: no link below {base_link!r} has collision or "
            "visual geometry",
            hint="add <collision> geometry to the gripper's links",
        )
    n = max(DENSE_MIN, DENSE_PER_POINT * count)
    combined = trimesh.util.concatenate(meshes)
    face_owner = np.repeat(owners, [len(m.faces) for m in meshes])  # (F,)
    pts, faces = trimesh.sample.sample_surface(combined, n, seed=seed)
    return BodySamples(np.asarray(pts, dtype=np.float64), face_owner[faces], links)


def thin_cloud(points: Array, count: int) -> Array:
    """Exactly ``count`` points spread evenly over ``points`` (farthest-point
    sampling from the point farthest from the centroid; deterministic)."""
    start = int(np.argmax(np.sum((points - points.mean(axis=0)) ** 2, axis=1)))
    return points[farthest_point_indices(points, count, start)]


def _box(points: Array) -> tuple[Array, Array]:
    return points.min(axis=0), points.max(axis=0)


def _volume(lo: Array, hi: Array) -> float:
    return float(np.prod(np.maximum(hi - lo, 0.0)))


def _inside_box(points: Array, lo: Array, hi: Array) -> int:
    return int(np.count_nonzero(np.all((points >= lo) & (points <= hi), axis=1)))


#: a link whose box holds finger workspace is fitted as two groups where its best
#: cut's halves cost less than this fraction of its box (box volume plus
#: swallowed workspace): an L-shaped jaw link (Baxter's electric gripper: 0.22).
#: Straight finger links, palms and rigid jaw bodies of the grippers measured
#: (the built-in and example ones, the seven vendor descriptions, SO-101, Z1,
#: PR2, TIAGo Pro) cost 0.32 or more of their box when cut, and stay whole
CONCAVE_LINK = 0.25
#: cuts tried along each axis when a group whose box swallows finger workspace
#: is split (quantiles of its points)
SPLIT_QUANTILES = np.linspace(0.1, 0.9, 17)


def _split(
    g: Array, workspace: Array, cost: Callable[[Array, Array], float]
) -> tuple[Array, Array]:
    """Two halves of a group of body points ``(n, 3)``: at the median along its
    box's longest side; or, where its box holds finger-workspace points (a
    jaw's channel, the face of a rigid jaw), at the cut (an axis and a
    quantile of the points along it) whose halves' boxes cost least, so that
    the workspace comes out between them."""
    lo, hi = _box(g)
    if not _inside_box(workspace, lo, hi):
        axis = int(np.argmax(hi - lo))
        cut = np.median(g[:, axis])
        return g[g[:, axis] <= cut], g[g[:, axis] > cut]
    best, best_cost = None, np.inf
    for axis in range(3):
        for cut in np.unique(np.quantile(g[:, axis], SPLIT_QUANTILES)):
            keep = g[:, axis] <= cut
            left, right = g[keep], g[~keep]
            if not len(left) or not len(right):
                continue
            c = cost(*_box(left)) + cost(*_box(right))
            if c < best_cost:
                best, best_cost = (left, right), c
    if best is None:
        return g, g[:0]
    return best


def _next_split(
    groups: list[Array], workspace: Array, cost: Callable[[Array, Array], float]
) -> tuple[int, tuple[Array, Array]]:
    """The group to halve next, and its halves (see :func:`_split`): the one
    whose halves swallow the most less finger workspace than it does (a finger
    link tilted open, whose box holds the air it closes through); where no
    split frees workspace, the group with the largest box."""
    vols = [_volume(*_box(g)) for g in groups]
    best, best_freed = None, 0.0
    for i, g in enumerate(groups):
        lo, hi = _box(g)
        if not _inside_box(workspace, lo, hi):
            continue
        left, right = _split(g, workspace, cost)
        if not len(right):
            continue
        # swallowed workspace (in volume units, as ``cost`` weighs it)
        freed = (cost(lo, hi) - _volume(lo, hi)) - sum(
            cost(*_box(h)) - _volume(*_box(h)) for h in (left, right)
        )
        if freed > best_freed + 1e-12:
            best, best_freed = (i, (left, right)), freed
    if best is not None:
        return best
    i = int(np.argmax(vols))
    return i, _split(groups[i], workspace, cost)


def group_links(
    body: BodySamples, count: int, workspace: Array, cell_volume: float
) -> list[Array]:
    """Split the body samples into ``count`` groups, one per superellipsoid.

    Starts from one group per link and merges, greedily, the pair whose common
    bounding box adds the least volume, counting finger-workspace volume it
    swallows ``WORKSPACE_WEIGHT`` times; with fewer links than ``count``, groups
    are halved one at a time (:func:`_next_split`): first the one whose halves
    free the most finger workspace, else the one with the largest box.

    Parameters
    ----------
    workspace : (W, 3) float
        Points standing for finger-workspace voxels of volume ``cell_volume``.

    Returns
    -------
    list of (n_i, 3) float
    """
    groups = [body.points[body.link == i] for i in range(len(body.links))]
    groups = [g for g in groups if len(g)]

    def cost(lo: Array, hi: Array) -> float:
        return _volume(lo, hi) + WORKSPACE_WEIGHT * cell_volume * _inside_box(
            workspace, lo, hi
        )

    # a link shaped like an L round a finger's workspace (a jaw and the carriage
    # it stands on, in one link) starts as two groups: no merge can undo it
    links = list(groups)
    groups = []
    for g in links:
        lo, hi = _box(g)
        left, right = (
            _split(g, workspace, cost) if _inside_box(workspace, lo, hi) else (g, g[:0])
        )
        if len(right) and cost(*_box(left)) + cost(*_box(right)) < CONCAVE_LINK * cost(
            lo, hi
        ):
            groups += [left, right]
        else:
            groups.append(g)

    while len(groups) < count:
        i, (left, right) = _next_split(groups, workspace, cost)
        if not len(right):
            raise GripperError(
                f"cannot split the gripper body into {count} superellipsoids",
                hint="lower ellipsoids.count",
            )
        groups.pop(i)
        groups += [left, right]
    boxes = [_box(g) for g in groups]

    own = [cost(*b) for b in boxes]
    ids = list(range(len(groups)))  # stable ids, so pair costs can be cached
    next_id = len(groups)
    pair_cost: dict[tuple[int, int], float] = {}

    def merge_cost(i: int, j: int) -> float:
        key = (ids[i], ids[j]) if ids[i] < ids[j] else (ids[j], ids[i])
        if key not in pair_cost:
            lo = np.minimum(boxes[i][0], boxes[j][0])
            hi = np.maximum(boxes[i][1], boxes[j][1])
            pair_cost[key] = cost(lo, hi) - own[i] - own[j]
        return pair_cost[key]

    while len(groups) > count:
        n = len(groups)
        costs = [(merge_cost(i, j), i, j) for i in range(n) for j in range(i + 1, n)]
        _, i, j = min(costs)
        merged = np.concatenate([groups[i], groups[j]])
        for k in (j, i):
            groups.pop(k)
            boxes.pop(k)
            own.pop(k)
            ids.pop(k)
        groups.append(merged)
        boxes.append(_box(merged))
        own.append(cost(*boxes[-1]))
        ids.append(next_id)
        next_id += 1
    return groups


def fit_superellipsoids(groups: list[Array], exponent: float) -> tuple[Array, Array]:
    """One superellipsoid per group of points, enclosing every point.

    Centre: the group's box centre. Semi-axes: the half extents times the
    smallest-volume factors for a box's corners (:func:`box_corner_se_factors`),
    then scaled uniformly to the smallest size that still holds all the points.

    Returns
    -------
    centers, semi_axes : (ne, 3) float
    """
    factors = box_corner_se_factors(exponent)
    centers, axes = [], []
    for g in groups:
        lo, hi = _box(g)
        c = 0.5 * (lo + hi)
        semi = np.maximum(0.5 * (hi - lo), MIN_SEMI_AXIS) * factors
        semi = semi * enclosing_scale(g, c, semi, exponent, margin=1e-3)
        centers.append(c)
        axes.append(np.maximum(semi, MIN_SEMI_AXIS))
    return np.array(centers), np.array(axes)
