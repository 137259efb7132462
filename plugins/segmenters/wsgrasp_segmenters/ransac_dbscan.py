"""``ransac_dbscan``: RANSAC table plane, then DBSCAN clusters standing on it.

Nothing assumes the input frame has z up. Planes are found largest first (RANSAC on
what the previous planes left); the table is the first plane with at least one
cluster *standing* on one side of it: within ``contact_distance`` of the plane at
its lowest, or higher where no camera sees the plane under its middle, nor
anything lower under it (a top seen from straight above, not a finger held over a
box: :func:`_hidden_below`; its sides are then filled in down to
the plane under its outline, :func:`_hidden_sides`), no larger than
``max_object_extent``, with ``min_points`` points or more. The normal is turned to
the side with more standing points. Without the
cameras' poses, a cluster that hangs along the table's border (the table's own
side faces, a cloth over its edge: within ``_BORDER_BAND`` of the outline of its
inliers, or outside it) does not decide that side, and is no object on the other
one. Walls are passed over because the table (a cluster larger than
``max_object_extent``) is the only thing touching them; the floor below a table
sees only the legs, likewise too long.
When looking for what stands on one plane, the points of other wide planes with a
fair share of its inliers (a table seen from the wall beside it) are left out.
What stands under a flat surface seen above it (:func:`_under_surface`: a desk's
legs under its top) is no object where something else stands in the open; a plane
on which only such things stand is the table only where no plane after it holds
an object in the open (``info["under_surface"]`` then says so), the planes tried
then up to twice ``max_planes``.
A noisy camera's table scatters past ``min_height``: where ``noise_floor``
deviations of the points' depth noise about the plane (:func:`height_noise`)
exceed it, ``min_height`` and ``contact_distance`` rise by the difference, and the
noise is given in ``info["depth_noise"]``.
"""

from __future__ import annotations

import math
from typing import Any, ClassVar

import numpy as np
from numpy.typing import NDArray
from pydantic import BaseModel, ConfigDict, Field, model_validator
from scipy.spatial import cKDTree

from wsgrasp.errors import InputError
from wsgrasp.geometry import plane_basis
from wsgrasp.perception.cells import ROW_NEIGHBOURS as _ROW_NEIGHBOURS
from wsgrasp.perception.cells import Window as _Window
from wsgrasp.perception.cells import cells_seen as _cells_seen
from wsgrasp.perception.cells import footprint as _footprint
from wsgrasp.perception.footprint import Footprint
from wsgrasp.perception.process import cluster_labels, fit_plane_ransac
from wsgrasp.perception.types import Array, Plane, Segmentation

#: another wide plane with at least this fraction of a candidate table's inliers is
#: left out of the candidate's clusters
_OTHER_PLANE_FRACTION = 0.25


class RansacDbscanOptions(BaseModel):
    """Options of ``ransac_dbscan`` (metres)."""

    model_config = ConfigDict(extra="forbid", allow_inf_nan=False)

    plane_distance: float = Field(
        0.005, gt=0.0, le=0.1, description="RANSAC inlier distance to the plane"
    )
    ransac_iterations: int = Field(1000, ge=10, le=100000)
    min_plane_points: int = Field(
        100, ge=3, description="a plane with fewer inliers is not a table"
    )
    max_planes: int = Field(
        3,
        ge=1,
        le=10,
        description="planes tried, largest first, to find the table (twice as "
        "many where all that stands on one stands under a surface)",
    )
    cluster_eps: float = Field(
        0.01, gt=0.0, le=0.2, description="DBSCAN neighbourhood radius"
    )
    core_points: int = Field(
        4, ge=1, description="DBSCAN: neighbours within cluster_eps of a core point"
    )
    min_points: int = Field(30, ge=1, description="smallest object cluster")
    min_height: float = Field(
        0.01, ge=0.0, description="points lower than this above the table are table"
    )
    max_height: float = Field(
        1.0, gt=0.0, description="points higher than this above the table are ignored"
    )
    contact_distance: float = Field(
        0.03,
        gt=0.0,
        description="a cluster stands on the plane if its lowest point is this "
        "close, or if the plane under its middle is hidden from view",
    )
    max_object_extent: float = Field(
        0.6, gt=0.0, description="larger clusters are not objects (walls, table legs)"
    )
    noise_floor: float = Field(
        3.0,
        ge=0.0,
        le=10.0,
        description="where this many deviations of the depth noise about the "
        "table exceed min_height, min_height and contact_distance rise by the "
        "difference: a noisy table's points are not objects (0: off)",
    )

    @model_validator(mode="after")
    def _heights(self) -> RansacDbscanOptions:
        if self.min_height >= self.max_height:
            raise ValueError("min_height must be below max_height")
        return self


class RansacDbscan:
    """Table plane by a seeded RANSAC (``fit_plane_ransac``), objects by DBSCAN."""

    Options: ClassVar[type[BaseModel]] = RansacDbscanOptions

    def segment(
        self,
        points: Array,
        options: RansacDbscanOptions,
        *,
        seed: int,
        viewpoints: Array | None = None,
    ) -> Segmentation:
        """Find the table plane and the clusters standing on it.

        With ``viewpoints`` (camera centres ``(k, 3)``), only clusters on the
        cameras' side of a plane stand on it: a camera sees a table from above.
        Without them, the side with more standing points is the upper one.

        Raises
        ------
        InputError
            No plane with ``min_plane_points`` inliers, or nothing stands on any of
            the planes tried.
        """
        o = options
        p = np.asarray(points, dtype=np.float64)
        finder = _PlaneFinder(p, o, seed)
        # Planes that could matter when judging the largest one: wide ones with a
        # fair share of its points (a wall beside the table, the table beside a wall)
        while finder.worth_another(_OTHER_PLANE_FRACTION) and finder.next():
            pass
        tried: list[dict[str, Any]] = []
        # per plane tried, its largest cluster too small to be an object
        smallest: list[tuple[int, float]] = []
        # per plane tried, its largest cluster that does not touch it, with the
        # contact_distance that would take it
        apart: list[tuple[int, float]] = []
        outlines: dict[int, Footprint] = {}  # by plane
        # the first plane whose clusters all stand under a surface
        deferred: Segmentation | None = None
        k = 0
        while k < len(finder.planes) or finder.next():
            normal, offset, inliers, _ = finder.planes[k]
            if inliers.size < o.min_plane_points:
                tried.append({"inliers": int(inliers.size)})
                break
            # Wide planes other than this one are not objects standing on it
            exclude = np.zeros(p.shape[0], dtype=bool)
            for j, (_, _, other, wide) in enumerate(finder.planes):
                if (
                    j != k
                    and wide
                    and other.size >= _OTHER_PLANE_FRACTION * inliers.size
                ):
                    exclude[other] = True
            # the inliers in the plane, for this plane's outline and for what
            # reaches past a cluster's footprint: projected once
            basis = plane_basis(normal)  # (3, 2)
            # rows gathered by take here: a quarter of p[rows]'s time (12,015
            # inliers: 83 -> 21 us)
            plane_uv = p.take(inliers, axis=0) @ basis  # (m, 2)
            # without the cameras' poses, the outlines of this plane and of the
            # wide planes at least as large, along which what hangs is no object
            borders: list[Footprint] = []
            if viewpoints is None or not len(viewpoints):
                for j, (n_j, off_j, other, wide) in enumerate(finder.planes):
                    if j == k or (wide and other.size >= inliers.size):
                        if j not in outlines:
                            outlines[j] = (
                                Footprint.from_uv(n_j, off_j, basis, plane_uv)
                                if j == k
                                else Footprint.from_points(n_j, off_j, p.take(other, 0))
                            )
                        borders.append(outlines[j])
            found = self._clusters_on(
                p, normal, offset, o, exclude, viewpoints, plane_uv, borders
            )
            tried.append({"inliers": int(inliers.size), **found["why"]})
            if found.get("small") is not None:
                smallest.append(found["small"])
            if found.get("apart") is not None:
                apart.append(found["apart"])
            if found["clusters"]:
                plane = Plane(normal=found["normal"], offset=found["offset"])
                if k == 0:
                    # found among all the points, with this plane (or its exact
                    # negation): its inliers are the points within plane_distance
                    band = inliers
                else:
                    band = np.flatnonzero(
                        np.abs(plane.signed_distance(p)) <= o.plane_distance
                    )
                result = Segmentation(
                    table=plane,
                    table_points=p.take(band, axis=0),
                    clusters=found["clusters"],
                    info={
                        "planes_tried": tried,
                        "plane_rank": k,
                        "depth_noise": found["noise"],
                        **(
                            {"standing_sides": list(found["votes"])}
                            if found["votes"] is not None
                            else {}
                        ),
                    },
                )
                if not found["under"]:
                    return result
                # all it holds stands under a surface: the next planes first,
                # as many again as were to be tried (a noisy floor found as
                # slabs, three times over, left the desk over it untried)
                if deferred is None:
                    deferred = result
                    finder.limit = 2 * o.max_planes
            k += 1
        if deferred is not None:
            # no plane after it holds an object in the open: what stands under
            # the surface is the target (a shelf's board under the one above, or
            # an empty desk's legs), and the result says so
            deferred.info["under_surface"] = True
            return deferred
        if not tried or tried[0]["inliers"] < o.min_plane_points:
            best = tried[0]["inliers"] if tried else 0
            raise InputError(
                f"ransac_dbscan found no table plane: the largest plane within "
                f"{o.plane_distance:g} m has {best} of {p.shape[0]} points, expected "
                f"at least {o.min_plane_points}",
                hint="check that the table is in view and the cloud is in metres; "
                "raise plane_distance for noisy clouds, or use the given_table "
                "segmenter",
            )
        why = "; ".join(
            f"plane {i + 1} ({t['inliers']} points): "
            + (
                ", ".join(f"{v} {r}" for r, v in t.items() if r != "inliers" and v)
                or "no cluster off it"
            )
            for i, t in enumerate(tried)
        )
        hint = (
            "check that the object is in view and on the table; lower "
            "min_points or min_height, raise max_object_extent for large objects"
        )
        if smallest:
            count, across = max(smallest)
            if count >= _SMALL_HINT_POINTS:
                hint = (
                    f"the largest cluster too small to be an object has {count} "
                    f"points and is {across * 100:.1f} cm across: for an object "
                    f"that small, lower min_points to {count} or below (noise "
                    "clusters may then pass for objects); " + hint
                )
        if apart:
            count, gap = max(apart)
            if gap <= _APART_HINT_GAP:
                reach = math.ceil((gap + _APART_HINT_MARGIN) * 100.0) / 100.0
                hint = (
                    f"the largest cluster that does not touch the table has {count} "
                    f"points, its lowest {gap * 100:.1f} cm above it: if it stands "
                    "there (leaning, or its foot hidden from the cameras), raise "
                    f"contact_distance to {reach:g}; " + hint
                )
        if any(t.get(_HANGING) for t in tried):
            hint = (
                "what hangs along the table's border (its own edges, a cloth over "
                "them) is not an object; put the object on the table in view, or "
                "give the views' poses (T_world_camera) so that the cameras' side "
                "of the table is up"
            )
        raise InputError(
            f"nothing to grasp: nothing stands on the table: no cluster of at least "
            f"{o.min_points} points lies on a plane (tried {len(tried)}: "
            f"{why or 'no clusters'})",
            hint=hint,
        )

    @staticmethod
    def _clusters_on(
        p: Array,
        normal: Array,
        offset: float,
        o: RansacDbscanOptions,
        exclude: NDArray[np.bool_],
        viewpoints: Array | None = None,
        plane_uv: Array | None = None,
        borders: list[Footprint] | tuple[Footprint, ...] = (),
    ) -> dict[str, Any]:
        """Clusters standing on either side of a plane: the cameras' side when
        ``viewpoints`` are given, else the side with more points. A cluster
        stands on a plane that reaches past its footprint (``plane_uv`` ``(m,
        2)``, the inliers projected on ``plane_basis(normal)``; reordered here):
        an object's own face is no table for it. A cluster that hangs
        along one of the outlines ``borders`` (this plane's first, then those of
        wider planes) is no object: along another plane's, wherever it lies;
        along this plane's, on the side that the other clusters do not put up,
        and it does not decide that side."""
        h = p @ normal + offset  # (n,) signed heights
        ah = np.abs(h)
        # a noisy camera's table scatters past min_height (12 mm of noise: 40 %
        # of its points more than 1 cm off its plane, in clusters that stood on
        # it): the floor of what stands on it, and the reach of what touches it,
        # rise with the noise
        noise = height_noise(h, _NOISE_BAND_PLANES * o.plane_distance)
        lift = o.noise_floor * noise - o.min_height
        if not (lift > 0.0 and o.min_height + lift < o.max_height):
            lift = 0.0
        if lift:
            o = o.model_copy(
                update={
                    "min_height": o.min_height + lift,
                    "contact_distance": o.contact_distance + lift,
                }
            )
        cand = np.flatnonzero((ah > o.min_height) & (ah < o.max_height) & ~exclude)
        labels = cluster_labels(p.take(cand, axis=0), o.cluster_eps, o.core_points)
        why = {"too small": 0, "not touching": 0, "too large": 0}
        empty: dict[str, Any] = {
            "clusters": [],
            "why": why,
            "normal": normal,
            "offset": offset,
            "noise": noise,
            "small": None,
            "apart": None,
        }
        if labels.size == 0 or labels.max() < 0:
            return empty
        ok = labels >= 0
        lab, idx = labels[ok], cand[ok]
        nlab = int(lab.max()) + 1
        counts = np.bincount(lab, minlength=nlab)
        # per-cluster lowest |height|, side (sum of signs) and bounding-box size
        low = np.full(nlab, np.inf)
        np.minimum.at(low, lab, ah[idx])
        side = np.bincount(lab, weights=np.sign(h[idx]), minlength=nlab)
        lo, hi = _bounds(p.take(idx, axis=0), lab, nlab)
        extent = np.linalg.norm(hi - lo, axis=1)
        small = counts < o.min_points
        if small.any():  # the largest of them, for the error's hint
            k = int(np.flatnonzero(small)[np.argmax(counts[small])])
            largest_small: tuple[int, float] | None = (int(counts[k]), float(extent[k]))
        else:
            largest_small = None
        empty["small"] = largest_small
        far = ~small & (low > o.contact_distance)
        hidden = np.zeros(nlab, dtype=bool)
        if plane_uv is not None and far.any():
            # a gap to the plane that no camera sees is no gap: a box, a can or a
            # ball seen from straight above shows its top alone
            hidden = _hidden_below(
                plane_uv,
                normal,
                p,
                idx,
                lab,
                np.flatnonzero(far),
                o.cluster_eps,
                ah,
                low - o.contact_distance,
            )
            # ... unless a surface at its foot holds it up: a box on a desk, seen
            # from above, hides the floor under it, yet stands on the desk
            hidden &= ~_held_up(
                normal,
                p,
                idx,
                lab,
                np.flatnonzero(hidden),
                o.cluster_eps,
                ah,
                low,
                o.contact_distance,
                objects=idx[extent[lab] <= o.max_object_extent],
            )
            far &= ~hidden
        if far.any():  # the largest of them, for the error's hint
            k = int(np.flatnonzero(far)[np.argmax(counts[far])])
            # the contact_distance that takes it, before the noise's lift
            empty["apart"] = (int(counts[k]), float(low[k] - lift))
        large = ~small & ~far & (extent > o.max_object_extent)
        why.update(
            {
                "too small": int(small.sum()),
                "not touching": int(far.sum()),
                "too large": int(large.sum()),
            }
        )
        standing = ~(small | far | large)
        if plane_uv is not None and standing.any():
            beyond = _reaches_past(plane_uv, normal, p, idx, lab, nlab)
            why["on its own face"] = int((standing & ~beyond).sum())
            standing &= beyond
        # the clusters that decide which side is up
        deciding = standing
        if viewpoints is not None and len(viewpoints):
            # the cameras' side is up; what stands on the other is under the table
            camera_side = float(np.median(np.asarray(viewpoints) @ normal + offset))
            below = standing & (np.sign(side) != np.sign(camera_side))
            why["below the table"] = int(below.sum())
            standing &= ~below
            deciding = standing
        elif borders and standing.any():
            # no camera says where up is: what hangs along a border is a table's
            # own edge (or a cloth over it)
            hanging = np.zeros(nlab, dtype=bool)
            for outline in borders[1:]:
                hanging |= _along_border(outline, p, idx, lab, nlab)
            hanging &= standing
            standing &= ~hanging
            border = standing & _along_border(borders[0], p, idx, lab, nlab)
            deciding = standing & ~border
            if deciding.any():
                up = int(counts[deciding & (side > 0)].sum())
                down = int(counts[deciding & (side < 0)].sum())
                border &= np.sign(side) != (1.0 if up >= down else -1.0)
            standing &= ~border
            why[_HANGING] = int((hanging | border).sum())
        if not standing.any():
            return empty
        up = int(counts[deciding & (side > 0)].sum())
        down = int(counts[deciding & (side < 0)].sum())
        # where no camera says which side is up: the standing points on the
        # side taken and on the other
        blind = viewpoints is None or not len(viewpoints)
        votes = (max(up, down), min(up, down)) if blind else None
        if down > up:
            normal, offset, h = -normal, -offset, -h
            keep = standing & (side < 0)
        else:
            keep = standing & (side > 0)
        # what stands under a surface (a desk's legs under its top) is no
        # object where something else stands in the open; where nothing does,
        # the plane is kept for the last: the surface may be the table
        under = _under_surface(
            normal, p, h, idx, lab, np.flatnonzero(keep), o.cluster_eps
        )
        all_under = bool(under[keep].all())
        if under.any():
            why[_UNDER] = int(under.sum())
            if not all_under:
                keep &= ~under
        # give back each kept cluster's foot: points between the plane's inlier band
        # and min_height, within cluster_eps of that cluster
        lab_full = np.full(p.shape[0], -1)
        lab_full[idx[keep[lab]]] = lab[keep[lab]]
        foot = np.flatnonzero((h > o.plane_distance) & (h <= o.min_height))
        # the members that can lie within cluster_eps of a foot, whose heights
        # differ from a foot's by no more than their distance (twice cluster_eps:
        # far more than rounding adds): the same nearest member (short of two at
        # exactly the same distance, which either tree may order), from a tree of
        # box_upright's 269 lowest members instead of all 2,418 (tree and query
        # 0.6 -> 0.17 ms per plan, line timings of 40 plans)
        members = np.flatnonzero(
            (lab_full >= 0) & (h < o.min_height + 2.0 * o.cluster_eps)
        )
        if foot.size and members.size:
            d, j = cKDTree(p[members]).query(
                p[foot], distance_upper_bound=o.cluster_eps
            )
            hit = np.isfinite(d)
            lab_full[foot[hit]] = lab_full[members[j[hit]]]
        kept = np.flatnonzero(keep)
        order = kept[np.argsort(-counts[kept], kind="stable")]
        clusters = []
        for c in order:
            points = p.take(np.flatnonzero(lab_full == c), axis=0)
            if hidden[c]:
                # its sides down to the table, under its outline
                sides = _hidden_sides(
                    points, h[lab_full == c], normal, 0.5 * o.cluster_eps, o.min_height
                )
                why["sides filled in"] = why.get("sides filled in", 0) + len(sides)
                points = np.concatenate([points, sides])
            clusters.append(points)
        clusters.sort(key=lambda c: -c.shape[0])
        return {
            "clusters": clusters,
            "why": why,
            "normal": normal,
            "offset": offset,
            "noise": noise,
            "small": largest_small,
            "votes": votes,
            "under": all_under,
        }


#: the depth noise is measured on the points within this many plane_distance of
#: a plane (the band widened while it cuts the noise short)
_NOISE_BAND_PLANES = 3.0


def height_noise(h: Array, band: float, points: int = 4000) -> float:
    """The depth noise (m) of the points about a plane, from their signed heights
    ``h`` ``(n,)``: 1.4826 median absolute deviations of those within ``band``
    of it, at most ``points`` of them evenly spaced; the band is widened to four
    deviations while it is narrower (a band that cuts the noise short measures
    it short). Objects' feet in the band move the median little. 0 with fewer
    than 30 points."""
    x = np.asarray(h, dtype=np.float64)[:: max(1, len(h) // (4 * points))]
    sigma = 0.0
    for _ in range(4):
        near = x[np.abs(x) < band][:points]
        if len(near) < 30:
            break
        sigma = 1.4826 * float(np.median(np.abs(near - np.median(near))))
        if 4.0 * sigma <= band:
            break
        band = 4.0 * sigma
    return sigma


#: "nothing stands on the table" names the largest cluster too small to be an
#: object where it has this many points or more (a 1.2 cm cube seen by three
#: cameras, 5 mm voxels: 14 above min_height)
_SMALL_HINT_POINTS = 8
#: the error names the contact_distance that takes a cluster that does not touch
#: the table, where it hangs no higher than this (m): an object whose foot the
#: cameras do not see (a box leaning on an edge, seen from above its top face,
#: showed nothing lower than 4.5 cm)
_APART_HINT_GAP = 0.15
#: ... with this much (m) to spare
_APART_HINT_MARGIN = 0.005
#: the reason a cluster that hangs along the table's border is not an object
_HANGING = "hanging along its border"
#: ... and one that stands under a surface (:func:`_under_surface`)
_UNDER = "under a surface"
#: a cluster hangs along the table's border when this share of its points ...
_BORDER_SHARE = 0.9
#: ... lies this close (m) inside the outline of a table's inliers ...
_BORDER_BAND = 0.02
#: ... or at most this far (m) outside it
_BORDER_OUT = 0.05


def _along_border(
    footprint: Footprint,
    p: Array,
    idx: NDArray[np.int64],
    lab: NDArray[np.int64],
    nlab: int,
) -> NDArray[np.bool_]:
    """Per cluster ``(nlab,)``: whether it lies along a table's border, its
    points' projections within ``_BORDER_BAND`` inside the outline of the
    table's inliers or ``_BORDER_OUT`` outside it (``_BORDER_SHARE`` of them). A
    table's side faces and a cloth over its edge do; an object standing on the
    table, which the table surrounds, does not."""
    depth = footprint.depths(p.take(idx, axis=0))  # (k,)
    near = (depth <= _BORDER_BAND) & (depth >= -_BORDER_OUT)
    share = np.bincount(lab, weights=near, minlength=nlab) / np.maximum(
        np.bincount(lab, minlength=nlab), 1
    )
    return share >= _BORDER_SHARE  # type: ignore[no-any-return]


#: a cluster higher than ``contact_distance`` above the plane stands on it where
#: the plane's inliers, and what is seen below it, are seen in less than this
#: share of its footprint's core
_SEEN_BELOW = 0.2
#: a footprint narrower than this many cells is looked at on cells of half the
#: side
_NARROW_CELLS = 8
#: the core: the footprint's cells at least this share of its greatest depth
#: (distance to its border) inside it
_CORE_DEPTH = 0.5


def _hidden_below(
    plane_uv: Array,
    normal: Array,
    p: Array,
    idx: NDArray[np.int64],
    lab: NDArray[np.int64],
    clusters: NDArray[np.int64],
    cell: float,
    ah: Array,
    under: Array,
) -> NDArray[np.bool_]:
    """Per cluster ``(nlab,)``: whether the plane under the middle of one of
    ``clusters`` is hidden, its inliers (``plane_uv`` ``(m, 2)``, projected on
    ``plane_basis(normal)``) and the points seen below the cluster (``p``
    ``(n, 3)`` less high over the plane, ``ah`` ``(n,)``, than ``under``
    ``(nlab,)`` for that cluster) in less than ``_SEEN_BELOW`` of the core of
    its footprint: of the cells of side ``cell`` its points project into
    (holes filled), those at least ``_CORE_DEPTH`` of the deepest one's
    distance from its border.

    An object standing on the plane hides the plane under its middle, where
    it touches it, from every camera above the plane; a camera that sees it
    from straight above sees its top alone, which then seems to hang over the
    plane. A cluster that does hang over the plane shows the plane under its
    middle to a camera that looks in under it (from 45 degrees, once the gap
    is about as high as half the cluster is wide), or, over another object,
    that object's top: a robot's finger held 5 cm over a box hides the table
    from the box, not from itself. From straight above, hanging and standing
    look the same."""
    from scipy.ndimage import distance_transform_edt

    basis = plane_basis(normal)  # (3, 2)
    out = np.zeros(int(lab.max()) + 1, dtype=bool)
    inliers = _Window(plane_uv, queries=len(clusters))
    everything = _Window(p, basis, queries=len(clusters))
    for c in clusters:
        uv_c = p[idx[lab == c]] @ basis
        # a narrow footprint on cells of half the side: on 1 cm cells, a 4 cm
        # can's core was the cells round its rim, where the table seen beside
        # its foot fell (a can seen from 84-90 degrees taken for hanging)
        narrow = float(np.ptp(uv_c, axis=0).min()) < _NARROW_CELLS * cell
        side = 0.5 * cell if narrow else cell
        foot, lo, _ = _footprint(uv_c, side)
        depth = distance_transform_edt(foot)
        core = depth >= _CORE_DEPTH * depth.max()
        near = inliers.within(lo, foot.shape, side, ordered=False)
        seen = _cells_seen(plane_uv[near], lo, side, foot.shape)
        near = everything.within(lo, foot.shape, side, ordered=False)
        near = near[ah[near] < under[c]]
        seen |= _cells_seen(everything.uv[near], lo, side, foot.shape)
        out[c] = np.count_nonzero(seen & core) < _SEEN_BELOW * core.sum()
    return out


#: a cluster is held up by a surface at its foot where that surface is seen in
#: at least this share of the cells round its footprint (the side of it that
#: the cameras see: a desk round a box seen from one side, the box hiding the
#: desk behind it)
_HELD_AROUND = 0.3
#: ... the ring of cells round the footprint that is looked at, in cells
_RING_CELLS = 2


def _held_up(
    normal: Array,
    p: Array,
    idx: NDArray[np.int64],
    lab: NDArray[np.int64],
    clusters: NDArray[np.int64],
    cell: float,
    ah: Array,
    low: Array,
    reach: float,
    objects: NDArray[np.int64],
) -> NDArray[np.bool_]:
    """Per cluster ``(nlab,)``: whether one of ``clusters``, hanging over the
    plane, rests on another surface: points of no object-sized cluster (not
    ``objects``; ``p`` ``(n, 3)``,
    heights ``ah`` ``(n,)`` over the plane) within ``reach`` of its lowest
    height ``low`` ``(nlab,)`` in at least ``_HELD_AROUND`` of the ring of
    cells round its footprint (side ``cell``, ``_RING_CELLS`` wide).

    A box on a desk, seen from above with the floor in view, hides the floor
    under it as an object standing on the floor would; the desk round its
    foot, level with it, says where it stands. An object seen from straight
    above shows its top alone, and round its top nothing lies at that height."""
    from scipy.ndimage import binary_dilation

    out = np.zeros(int(lab.max()) + 1, dtype=bool)
    if not len(clusters):
        return out
    basis = plane_basis(normal)  # (3, 2)
    # a surface is no object-sized cluster's points (``objects``): a far view's
    # box falls into its top and shreds of its sides, level with the top round
    # its outline; a desk's top, too large for an object, may be one cluster
    clustered = np.zeros(p.shape[0], dtype=bool)
    clustered[objects] = True
    free = np.flatnonzero(~clustered)
    window = _Window(p[free], basis, queries=len(clusters))
    for c in clusters:
        members = idx[lab == c]
        foot, lo, _ = _footprint(p[members] @ basis, cell)
        ring = binary_dilation(foot, iterations=_RING_CELLS) & ~foot
        if not ring.any():
            continue
        near = window.within(lo, foot.shape, cell, ordered=False)
        near = near[np.abs(ah[free[near]] - low[c]) <= reach]
        seen = _cells_seen(window.uv[near], lo, cell, foot.shape)
        out[c] = np.count_nonzero(seen & ring) >= _HELD_AROUND * ring.sum()
    return out


#: a cluster stands under a surface where that surface is seen over at least
#: this share of its footprint's cells ...
_UNDER_COVER = 0.5
#: ... seen as this many points at least ...
_UNDER_FEWEST = 3
#: ... higher than the cluster's top within this many ``cluster_eps``
#: of the 90th percentile of their heights (a layer parallel to the plane: a
#: desk's top over its legs)
_UNDER_LAYER = 2.0


def _under_surface(
    normal: Array,
    p: Array,
    h: Array,
    idx: NDArray[np.int64],
    lab: NDArray[np.int64],
    clusters: NDArray[np.int64],
    cell: float,
) -> NDArray[np.bool_]:
    """Per cluster ``(nlab,)``: whether one of ``clusters`` stands under a
    surface parallel to the plane: points higher than its top, their heights
    ``h`` within ``_UNDER_LAYER`` cells of the highest layer over it, over
    ``_UNDER_COVER`` of its footprint's cells (side ``cell``; a cell counts
    where such a point lies within the points' own spacing of its centre, as
    a far view's slanted top is seen in rows several cells apart).

    A desk's legs stand on the floor under the desk's top: seen from above the
    desk, the top covers them. An object standing in the open shows its top to
    the cameras, and nothing flat lies over it."""
    from scipy.spatial import cKDTree

    out = np.zeros(int(lab.max()) + 1, dtype=bool)
    basis = plane_basis(normal)  # (3, 2)
    window = _Window(p, basis, queries=2 * len(clusters))
    for c in clusters:
        members = idx[lab == c]
        top = float(h[members].max()) + cell
        if np.count_nonzero(h > top) < _UNDER_FEWEST:
            continue  # nothing higher anywhere: a tabletop's object
        uv = p[members] @ basis
        # its outline's box, two cells wider each way (a leg seen from one
        # side is a strip a cell wide under the desk's edge)
        lo = uv.min(axis=0) - 2.0 * cell
        shape = tuple(int(n) + 4 for n in np.ceil((uv.max(axis=0) - lo) / cell))
        near = window.within(lo, shape, cell, ordered=False)
        if np.count_nonzero(h[near] > top) < _UNDER_FEWEST:
            continue  # nothing over it: in the open
        foot, lo, _ = _footprint(uv, cell)
        near = window.within(lo, foot.shape, cell, ordered=False)
        over = near[h[near] > top]
        # the highest layer over it (under it: the rest of the leg, hidden
        # between the top and the floor in shreds)
        level = np.percentile(h[over], 90.0) if over.size else 0.0
        over = over[np.abs(h[over] - level) <= _UNDER_LAYER * cell]
        if over.size < _UNDER_FEWEST:
            continue
        tree = cKDTree(window.uv[over])
        spacing = cell
        if over.size > _ROW_NEIGHBOURS:
            d, _ = tree.query(window.uv[over], k=_ROW_NEIGHBOURS + 1)
            spacing = max(cell, float(np.median(d[:, -1])))
        centres = lo + (np.argwhere(foot) + 0.5) * cell
        hit, _ = tree.query(centres, distance_upper_bound=spacing)
        out[c] = np.count_nonzero(np.isfinite(hit)) >= _UNDER_COVER * len(centres)
    return out


def _hidden_sides(
    points: Array, heights: Array, normal: Array, cell: float, floor: float
) -> Array:
    """Points ``(m, 3)`` on the sides of a cluster whose gap to the plane is
    hidden (:func:`_hidden_below`): under each cell of side ``cell`` on the
    outline of its footprint, a column from the cluster's lowest point there
    down to ``floor`` above the plane, a point every ``cell``.

    A camera straight above a box, a can or a ball sees its top, down to its
    outline; what stands under that outline is hidden from it, and a prism is
    what the camera cannot tell apart from it. Without its sides, the object
    is its top alone, its middle (which a grasp aims at) at the top."""
    from scipy.ndimage import binary_erosion

    foot, _, ij = _footprint(points @ plane_basis(normal), cell)
    i, j = ij.T
    rim = foot & ~binary_erosion(foot)
    on_rim = np.flatnonzero(rim[i, j])  # points in the outline's cells
    # the lowest of them in each cell
    cell_of = i[on_rim] * foot.shape[1] + j[on_rim]
    order = np.lexsort((heights[on_rim], cell_of))
    first = np.ones(len(order), dtype=bool)
    first[1:] = cell_of[order[1:]] != cell_of[order[:-1]]
    low = on_rim[order[first]]  # (r,) into points
    # each column's heights floor, floor + cell, ... below the point's own
    n = np.maximum(np.ceil((heights[low] - floor) / cell), 0).astype(np.int64)
    if not n.sum():
        return np.zeros((0, 3))
    k = np.arange(n.sum()) - np.repeat(np.cumsum(n) - n, n)  # (m,) 0, 1, ... per column
    column = floor + k * cell  # (m,)
    # each point lowered from its own height to its column's heights
    top = np.repeat(points[low], n, axis=0)  # (m, 3)
    return top - (np.repeat(heights[low], n) - column)[:, None] * normal


#: a table reaches at least this far (m) past a standing cluster's footprint ...
_FOOTPRINT_MARGIN = 0.02
#: ... on at least this many of the footprint's four sides
_FOOTPRINT_SIDES = 2


def _reaches_past(
    plane_uv: Array,
    normal: Array,
    p: Array,
    idx: NDArray[np.int64],
    lab: NDArray[np.int64],
    nlab: int,
) -> NDArray[np.bool_]:
    """Per cluster ``(nlab,)``: whether the plane's inliers (``plane_uv`` ``(m,
    2)``, projected on ``plane_basis(normal)``) reach past the cluster's
    footprint (its bounding box in the plane) by ``_FOOTPRINT_MARGIN`` on
    ``_FOOTPRINT_SIDES`` or more sides. A table seen around an object does; an
    object's face, which the rest of the object seems to stand on, does not."""
    basis = plane_basis(normal)  # (3, 2)
    # (2,) each; plane_uv is a temporary the partition may reorder in place
    lo_p, hi_p = np.percentile(plane_uv, [1, 99], axis=0, overwrite_input=True)
    uv = p.take(idx, axis=0) @ basis  # (k, 2)
    lo, hi = _bounds(uv, lab, nlab)
    sides = np.concatenate([lo - lo_p, hi_p - hi], axis=1)  # (nlab, 4)
    return np.count_nonzero(sides >= _FOOTPRINT_MARGIN, axis=1) >= _FOOTPRINT_SIDES


def _bounds(values: Array, lab: NDArray[np.int64], nlab: int) -> tuple[Array, Array]:
    """Per label, the least and greatest of ``values`` ``(k, d)`` over the points
    of that label ``lab`` ``(k,)``: two ``(nlab, d)`` arrays, ``inf`` and
    ``-inf`` for a label without points. One column at a time, where
    ``ufunc.at`` takes its fast one-dimensional path."""
    lo = np.full((nlab, values.shape[1]), np.inf)
    hi = np.full((nlab, values.shape[1]), -np.inf)
    for k in range(values.shape[1]):
        np.minimum.at(lo[:, k], lab, values[:, k])
        np.maximum.at(hi[:, k], lab, values[:, k])
    return lo, hi


class _PlaneFinder:
    """Planes found one at a time by RANSAC, each in what the previous ones left:
    ``planes`` holds ``(normal, offset, inliers, wide)``; ``wide`` when the
    inliers span more than half ``max_object_extent`` (not an object's face)."""

    def __init__(self, p: Array, o: RansacDbscanOptions, seed: int) -> None:
        self.p, self.o, self.seed = p, o, seed
        self.remaining = np.arange(p.shape[0])
        self.planes: list[tuple[Array, float, NDArray[np.int64], bool]] = []
        self.exhausted = False
        #: planes it may find (``max_planes``, raised where every object on
        #: those tried stands under a surface)
        self.limit = o.max_planes

    def worth_another(self, fraction: float) -> bool:
        """Whether what is left could hold a wide plane with ``fraction`` of the
        smallest plane's inliers so far."""
        if not self.planes:
            return True
        _, _, inliers, wide = self.planes[-1]
        return wide and self.remaining.size >= fraction * inliers.size

    def next(self) -> bool:
        """Find one more plane; False when no more can be found."""
        o = self.o
        k = len(self.planes)
        if k >= self.limit:
            return False
        if self.exhausted or self.remaining.size < max(o.min_plane_points, 3):
            self.exhausted = True
            return False
        # the first plane is found among all the points: no gathered copy
        everything = self.remaining.size == self.p.shape[0]
        normal, offset, inl = fit_plane_ransac(
            self.p if everything else self.p.take(self.remaining, axis=0),
            o.plane_distance,
            o.ransac_iterations,
            self.seed + k,
        )
        inliers = self.remaining[inl]
        wide = False
        if inliers.size:
            # a gathered copy, which the partition may reorder in place
            lo, hi = np.percentile(
                self.p.take(inliers, axis=0), [1, 99], axis=0, overwrite_input=True
            )
            wide = bool(np.linalg.norm(hi - lo) > o.max_object_extent / 2.0)
        self.planes.append((normal, offset, inliers, wide))
        if inliers.size < o.min_plane_points:
            self.exhausted = True
        keep = np.ones(self.p.shape[0], dtype=bool)
        keep[inliers] = False
        self.remaining = self.remaining[keep[self.remaining]]
        return True
