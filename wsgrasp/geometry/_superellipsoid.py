"""Special ellipsoids (superellipsoids) of the paper, eq. (1).

``|x-x0|^l / a^l + |y-y0|^l / b^l + (z-z0)^2 / c^2``: a value below 1 means inside.
With ``l = 10`` the shape is nearly a cuboid. Axes are those of the frame the
centres are given in (the paper's SEs are axis-aligned in the gripper or table frame).
"""

from __future__ import annotations

import numpy as np
from numpy.typing import ArrayLike, NDArray

Array = NDArray[np.float64]


def _power(x: Array, exponent: float) -> Array:
    """``x ** exponent`` for ``x >= 0``, by repeated squaring when the exponent is a
    small even integer (the common case, 10), which is several times faster."""
    if exponent == 2.0:
        return x * x
    if exponent == 10.0:
        x2 = x * x
        x4 = x2 * x2
        return x4 * x4 * x2
    if exponent == 4.0:
        x2 = x * x
        return x2 * x2
    return np.power(x, exponent)


def superellipsoid_values(
    points: ArrayLike,
    centers: ArrayLike,
    semi_axes: ArrayLike,
    exponent: float = 10.0,
) -> Array:
    """Evaluate eq. (1) of every point against every superellipsoid.

    Parameters
    ----------
    points : (..., n, 3) float
    centers : (m, 3) float
    semi_axes : (m, 3) float
        Semi-axes ``a, b, c``; all positive.
    exponent
        ``l``, applied to x and y; z uses 2 as in the paper.

    Returns
    -------
    (..., n, m) float
        Values below 1 are inside.
    """
    p = np.asarray(points, dtype=np.float64)
    c = np.asarray(centers, dtype=np.float64).reshape(-1, 3)
    ax = np.asarray(semi_axes, dtype=np.float64).reshape(-1, 3)
    # (..., n, 1, 3) - (m, 3) -> (..., n, m, 3), scaled into unit axes
    d = np.abs(p[..., :, None, :] - c) / ax
    return _power(d[..., 0], exponent) + _power(d[..., 1], exponent) + d[..., 2] ** 2


def coordinates_in_superellipsoids(
    x: ArrayLike,
    y: ArrayLike,
    z: ArrayLike,
    centers: ArrayLike,
    semi_axes: ArrayLike,
    exponent: float = 10.0,
) -> NDArray[np.bool_]:
    """Which points, given as separate coordinate arrays, lie strictly inside any
    of the superellipsoids.

    Working on contiguous per-coordinate arrays, one superellipsoid at a time, with
    a bounding-box test before eq. (1), is several times faster than a
    ``(..., n, m, 3)`` difference array.

    Parameters
    ----------
    x, y, z : (...) float
        Coordinates of the points, all of one shape.
    centers, semi_axes : (m, 3) float
    exponent
        ``l`` of eq. (1).

    Returns
    -------
    (...) bool
    """
    x = np.asarray(x, dtype=np.float64)
    y = np.asarray(y, dtype=np.float64)
    z = np.asarray(z, dtype=np.float64)
    c = np.asarray(centers, dtype=np.float64).reshape(-1, 3)
    ax = np.asarray(semi_axes, dtype=np.float64).reshape(-1, 3)
    inside = np.zeros(x.shape, dtype=bool)
    for e in range(len(c)):  # a handful of superellipsoids; points are vectorised
        dx = np.abs(x - c[e, 0])
        box = dx < ax[e, 0]
        dy = np.abs(y - c[e, 1])
        box &= dy < ax[e, 1]
        dz = np.abs(z - c[e, 2])
        box &= dz < ax[e, 2]
        box &= ~inside
        hits = np.nonzero(box)
        if hits[0].size == 0:
            continue
        value = (
            _power(dx[hits] / ax[e, 0], exponent)
            + _power(dy[hits] / ax[e, 1], exponent)
            + (dz[hits] / ax[e, 2]) ** 2
        )
        keep = value < 1.0
        inside[tuple(h[keep] for h in hits)] = True
    return inside


def points_in_superellipsoids(
    points: ArrayLike,
    centers: ArrayLike,
    semi_axes: ArrayLike,
    exponent: float = 10.0,
) -> NDArray[np.bool_]:
    """Which points lie strictly inside any of the superellipsoids.

    Parameters
    ----------
    points : (..., n, 3) float
    centers, semi_axes : (m, 3) float
    exponent
        ``l`` of eq. (1).

    Returns
    -------
    (..., n) bool
    """
    p = np.asarray(points, dtype=np.float64)
    return coordinates_in_superellipsoids(
        p[..., 0], p[..., 1], p[..., 2], centers, semi_axes, exponent
    )
