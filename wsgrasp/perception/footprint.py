"""The table's outline in its plane: where a cluster hangs along the table's
border, and where a gripper pose would be under the table."""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np
from numpy.typing import ArrayLike, NDArray
from scipy.spatial import ConvexHull, QhullError

from wsgrasp.geometry import plane_basis
from wsgrasp.perception.types import Array

__all__ = ["Footprint", "narrowest_across", "narrowest_width"]


@dataclass(frozen=True)
class Footprint:
    """The convex hull of a table's points, in its plane.

    Attributes
    ----------
    normal : (3,) float
        Unit normal of the plane, towards the table's upper side.
    offset : float
        ``normal · p + offset`` is a point's height above the plane.
    basis : (3, 2) float
        In-plane axes (:func:`~wsgrasp.geometry.plane_basis`).
    equations : (f, 3) float
        The hull's edges ``a · uv + b <= 0`` inside, ``(a, b)`` with ``|a| = 1``;
        no rows when the points span no area (the plane is then unbounded).
    """

    normal: Array
    offset: float
    basis: Array
    equations: Array

    @classmethod
    def from_points(
        cls, normal: ArrayLike, offset: float, points: ArrayLike
    ) -> Footprint:
        """The outline of ``points`` ``(m, 3)`` (the table's inliers) in the plane
        ``normal · p + offset = 0`` (``normal`` a unit vector)."""
        n = np.asarray(normal, dtype=np.float64).reshape(3)
        basis = plane_basis(n)
        uv = np.asarray(points, dtype=np.float64).reshape(-1, 3) @ basis  # (m, 2)
        return cls.from_uv(n, offset, basis, uv)

    @classmethod
    def from_uv(
        cls, normal: ArrayLike, offset: float, basis: Array, uv: Array
    ) -> Footprint:
        """The outline of points already projected on the plane: ``uv`` ``(m,
        2)`` is ``points @ basis``, ``basis`` ``(3, 2)`` is ``plane_basis(normal)``
        (for a caller that needs the projection too)."""
        n = np.asarray(normal, dtype=np.float64).reshape(3)
        equations = np.zeros((0, 3))
        if len(uv) >= 3:
            try:
                equations = ConvexHull(uv[_hull_candidates(uv)]).equations  # (f, 3)
            except (QhullError, ValueError):  # on a line or a point: no area
                pass
        return cls(n, float(offset), basis, equations)

    @property
    def bounded(self) -> bool:
        """Whether the outline has an area (else every point lies inside it)."""
        return len(self.equations) > 0

    def heights(self, points: ArrayLike) -> Array:
        """Heights ``(k,)`` of ``points`` ``(k, 3)`` above the plane."""
        p = np.asarray(points, dtype=np.float64).reshape(-1, 3)
        return p @ self.normal + self.offset

    def depths(self, points: ArrayLike) -> Array:
        """How far ``(k,)`` inside the outline the projections of ``points``
        ``(k, 3)`` lie (m): the distance to the nearest edge inside, negative
        outside (the distance past the farthest edge line); ``inf`` when the
        outline is unbounded."""
        p = np.asarray(points, dtype=np.float64).reshape(-1, 3)
        if not self.bounded:
            return np.full(len(p), np.inf)
        uv = p @ self.basis  # (k, 2)
        # (k, f) signed distances to the edge lines, negative inside
        signed = uv @ self.equations[:, :2].T + self.equations[:, 2]
        return -signed.max(axis=1)  # type: ignore[no-any-return]


#: eight directions (8, 2), counter-clockwise: the extreme points along them are
#: the corners of a polygon inside the convex hull
_DIRECTIONS = np.array([[np.cos(a), np.sin(a)] for a in np.arange(8) * np.pi / 4])


def _hull_candidates(uv: Array) -> NDArray[np.bool_]:
    """Which of ``uv`` ``(m, 2)`` may be vertices of their convex hull: all but
    those well inside the polygon of the extreme points along eight directions
    (Akl and Toussaint's filter; a point within ``_HULL_MARGIN`` of an edge is
    kept, whatever the rounding). qhull gives the same edges from these alone,
    the last bit of an edge's offset aside where it builds the edge from its
    other end (a square's six points: 1.4e-17 m), and takes about a quarter of
    the time on a table's 12,000 inliers, of which about 100 remain."""
    u, v = uv[:, 0], uv[:, 1]
    # (8, m): one row per direction, where the argmax along a row is fast
    corners = uv[np.argmax(_DIRECTIONS @ uv.T, axis=1)]  # (8, 2), counter-clockwise
    edges = np.roll(corners, -1, axis=0) - corners  # (8, 2)
    margin = _HULL_MARGIN * (1.0 + float(np.abs(corners).max()))
    inside = np.ones(len(uv), dtype=bool)
    for (cu, cv), (eu, ev) in zip(corners, edges, strict=True):
        if not (eu or ev):  # the same corner twice
            continue
        # left of the edge by more than the margin: eu * (v - cv) - ev * (u - cu)
        inside &= eu * v - ev * u > eu * cv - ev * cu + margin * np.hypot(eu, ev)
    return ~inside


#: points within this (m, times one plus the largest coordinate) of an edge of
#: the filter's polygon, or outside it, go to qhull
_HULL_MARGIN = 1e-9


def narrowest_width(points: ArrayLike, normal: ArrayLike) -> float:
    """How wide the points ``(n, 3)`` are at their narrowest seen along the
    unit ``normal`` (a table's): the least distance between two parallel lines
    that hold their outline in the plane, one of them along a side of their
    :class:`Footprint` (m); 0 where the outline has no area."""
    return narrowest_across(points, normal)[0]


def narrowest_across(
    points: ArrayLike, normal: ArrayLike
) -> tuple[float, Array | None]:
    """:func:`narrowest_width` and the direction it is measured along: the
    unit vector ``(3,)`` in the plane perpendicular to ``normal`` across which
    the points' outline is narrowest (the inward normal of the side that sets
    it), or None where the outline has no area."""
    p = np.asarray(points, dtype=np.float64).reshape(-1, 3)
    outline = Footprint.from_points(normal, 0.0, p)
    if not outline.bounded:
        return 0.0, None
    # (n, f) each point's distance inside each side's line; per side, the
    # farthest point is the width across it
    a, b = outline.equations[:, :2], outline.equations[:, 2]
    inside = -(p @ outline.basis @ a.T + b)
    widths = inside.max(axis=0)  # (f,)
    k = int(np.argmin(widths))
    return float(widths[k]), -(outline.basis @ a[k])
