"""Target rules for piles, and the instances of a scene as a plan reports them.

An instance's id is its index in the segmenter's ``clusters`` (largest first).
The same scene planned with the same spec gives the same instances in the same
order, so an id read from one plan's ``result.info["segments"]`` names the same
object in the next plan of that scene (``target: {rule: id, id: 2}``).
"""

from __future__ import annotations

from typing import Any

import numpy as np
from scipy.spatial import cKDTree

from wsgrasp.errors import InputError
from wsgrasp.geometry import plane_basis
from wsgrasp.perception.footprint import Footprint
from wsgrasp.perception.types import Array, Plane, Segmentation

__all__ = [
    "PILE_RULES",
    "UNSEGMENTED",
    "cluster_members",
    "containers",
    "groups",
    "obstacle_names",
    "pile_target",
    "segments",
]

#: the target rules this module decides (``cluster``: :func:`cluster_members`)
PILE_RULES = ("highest", "most_isolated", "id")
#: what the points above the table that no instance holds are called
UNSEGMENTED = "unsegmented points"


def pile_target(segmentation: Segmentation, rule: Any) -> int:
    """The index of the target instance among ``segmentation.clusters`` by one of
    :data:`PILE_RULES`:

    - ``highest``: the instance whose top stands highest above the table (the one
      on top of a pile, which nothing rests on);
    - ``most_isolated``: the instance farthest from every other instance and
      from the unsegmented points (nearest point to nearest point);
    - ``id``: instance ``rule.id``.
    """
    clusters = segmentation.clusters
    name = rule.rule
    if name in ("highest", "most_isolated"):
        # a container (a bin's walls) is no target while something lies in it
        skip = np.where(containers(segmentation), -np.inf, 0.0)
        if name == "highest":
            tops = [
                float(segmentation.table.signed_distance(c).max()) for c in clusters
            ]
            return int(np.argmax(tops + skip))
        clear = _clearances(clusters, unsegmented(segmentation))
        return int(np.argmax(clear + skip))
    if name in ("id", "cluster"):
        k = int(rule.id)
        if not 0 <= k < len(clusters):
            raise InputError(
                f"target id {k} names no instance: this scene has {len(clusters)} "
                f"(ids 0 to {len(clusters) - 1})",
                hint="take an id from result.info['segments'] of a plan of this "
                "scene with this spec, or use rule highest",
            )
        return k
    raise ValueError(f"{name!r} is not a pile rule")  # the spec allows no other


#: a cluster surrounds another seen from above when its points lie in at least
#: this many of :data:`_SECTORS` equal sectors around the other's centroid (a
#: bin's four walls: all of them; an object beside another: half at most)
_SURROUNDING = 12
_SECTORS = 16
#: ... and holds it when the other's lowest point lies at least this far (m)
#: below its top (in it, not stacked on it) ...
_INSIDE_DEPTH = 0.01
#: ... and this share of the other's points lies :data:`_INSET` (m) or more
#: inside its outline seen from above: in it, clear of its walls (an object
#: stacked on a wider one surrounds the wider one's centroid; the pieces of a
#: sparse cloud's faces lie along the outline of the rest of it)
_WITHIN = 0.9
_INSET = 0.01


def containers(segmentation: Segmentation) -> np.ndarray:
    """Per cluster ``(k,)`` bool, whether it is a container with something in
    it: a bin's walls, a tray's rim, a bowl, whose points surround another
    cluster seen along the table's normal (:data:`_SURROUNDING` of
    :data:`_SECTORS` sectors around that one's centroid), whose outline holds
    :data:`_WITHIN` of that one's points :data:`_INSET` inside it and whose top
    stands :data:`_INSIDE_DEPTH` or more above that one's lowest point (an
    object stacked on another's top is not in it). None where every cluster
    would be one."""
    clusters = segmentation.clusters
    found = np.zeros(len(clusters), dtype=bool)
    if len(clusters) < 2:
        return found
    table = segmentation.table
    basis = plane_basis(table.normal)
    uv = [c @ basis for c in clusters]  # in the table's plane
    middle = np.array([u.mean(axis=0) for u in uv])  # (k, 2)
    heights = [table.signed_distance(c) for c in clusters]
    top = np.array([float(h.max()) for h in heights])
    low = np.array([float(h.min()) for h in heights])
    for i in range(len(clusters)):
        outline = None  # its outline in the table's plane, once needed
        for j in range(len(clusters)):
            if i == j or low[j] > top[i] - _INSIDE_DEPTH:
                continue
            d = uv[i] - middle[j]  # (n, 2)
            angle = np.arctan2(d[:, 1], d[:, 0])  # (-pi, pi]
            sector = np.floor((angle + np.pi) * (_SECTORS / (2 * np.pi)))
            if len(np.unique(sector.astype(np.int64) % _SECTORS)) < _SURROUNDING:
                continue
            # and the other lies within its outline (not under it, wider)
            if outline is None:
                outline = Footprint.from_uv(table.normal, table.offset, basis, uv[i])
            if np.mean(outline.depths(clusters[j]) >= _INSET) >= _WITHIN:
                found[i] = True
                break
    return np.zeros(len(clusters), dtype=bool) if found.all() else found


def groups(segmentation: Segmentation) -> list[int]:
    """Per instance, the index of the connected cluster it was split from
    (``segmentation.info["groups"]``); each instance its own where the segmenter
    splits nothing."""
    g = segmentation.info.get("groups")
    n = len(segmentation.clusters)
    if g is None or len(g) != n:
        return list(range(n))
    return [int(x) for x in g]


def cluster_members(segmentation: Segmentation, rule: Any) -> list[int]:
    """For rule ``cluster``: instance ``rule.id`` and every instance split from
    the same connected cluster, in id order. Planned as one object, they undo a
    split at a concave seam of the object's own (a mug's handle, a bottle's
    neck, a shape made of several convex parts)."""
    k = pile_target(segmentation, rule)  # checks the id
    g = groups(segmentation)
    return [i for i in range(len(g)) if g[i] == g[k]]


def unsegmented(segmentation: Segmentation) -> Array:
    """The points above the table that the segmenter put in no instance,
    ``(k, 3)`` (none for a segmenter that does not report them)."""
    u = segmentation.info.get("unsegmented")
    if u is None:
        return np.zeros((0, 3))
    return np.asarray(u, dtype=np.float64).reshape(-1, 3)


def _clearances(clusters: list[Array], stray: Array) -> Array:
    """Per cluster ``(k,)``: the distance (m) from it to the nearest point of any
    other cluster or of ``stray``; ``inf`` for a cluster alone. Each pair of
    clouds is measured once, the smaller one's points looked up in a KD-tree
    of the larger."""
    clouds = [np.asarray(c, dtype=np.float64).reshape(-1, 3) for c in clusters]
    k = len(clouds)
    if len(stray):
        clouds.append(np.asarray(stray, dtype=np.float64).reshape(-1, 3))
    trees: dict[int, cKDTree] = {}
    gap = np.full((len(clouds), len(clouds)), np.inf)  # symmetric
    for a in range(k):
        for b in range(a + 1, len(clouds)):
            small, large = (a, b) if len(clouds[a]) <= len(clouds[b]) else (b, a)
            if not len(clouds[small]):
                continue
            if large not in trees:
                trees[large] = cKDTree(clouds[large])
            d, _ = trees[large].query(clouds[small])
            gap[a, b] = gap[b, a] = float(d.min())
    return gap[:k].min(axis=1) if len(clouds) > 1 else np.full(k, np.inf)


def segments(
    segmentation: Segmentation, target: list[int] | tuple[int, ...]
) -> list[dict[str, Any]]:
    """Each instance as a plan reports it: ``id``, ``points``, ``centroid``
    (m, world), ``top`` (height of its highest point above the table, m),
    ``clearance`` (m to the nearest other instance or unsegmented point),
    ``cluster`` (the connected cluster it was split from: :func:`groups`) and
    whether it is (part of) the ``target`` (ids)."""
    clusters = segmentation.clusters
    clear = _clearances(clusters, unsegmented(segmentation))
    table: Plane = segmentation.table
    group = groups(segmentation)
    return [
        {
            "id": k,
            "points": int(len(c)),
            "centroid": [round(float(x), 5) for x in c.mean(axis=0)],
            "top": round(float(table.signed_distance(c).max()), 5),
            "clearance": None if np.isinf(clear[k]) else round(float(clear[k]), 5),
            "cluster": group[k],
            "target": k in target,
        }
        for k, c in enumerate(clusters)
    ]


def obstacle_names(segmentation: Segmentation, obstacles: list[Array]) -> list[str]:
    """A name for each obstacle cloud: ``object <id>`` for an instance of
    ``segmentation``, :data:`UNSEGMENTED` for the points in none, ``neighbour
    <i>`` for a cloud the pipeline made (a part of a cluster it split)."""
    ids = {id(c): k for k, c in enumerate(segmentation.clusters)}
    stray = segmentation.info.get("unsegmented")
    names = []
    for i, o in enumerate(obstacles):
        if id(o) in ids:
            names.append(f"object {ids[id(o)]}")
        elif stray is not None and o is stray:
            names.append(UNSEGMENTED)
        else:
            names.append(f"neighbour {i}")
    return names
