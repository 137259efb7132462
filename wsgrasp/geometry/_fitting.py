"""Fitting superellipsoids of eq. (1) around point sets."""

from __future__ import annotations

import numpy as np
from numpy.typing import ArrayLike, NDArray

Array = NDArray[np.float64]


def box_corner_se_factors(exponent: float) -> Array:
    """Per-axis factors that turn a box's half extents into the semi-axes of the
    smallest-volume superellipsoid (eq. (1), exponent ``l`` on x and y, 2 on z)
    whose surface passes through the box corners.

    Minimising ``log a + log b + log c`` subject to
    ``(hx/a)^l + (hy/b)^l + (hz/c)^2 = 1`` gives the three terms in the ratio
    ``1/l : 1/l : 1/2``.

    Returns
    -------
    (3,) float
        Multiply the half extents by these (for ``l = 10``: about 1.215, 1.215,
        1.183).
    """
    total = 2.0 / exponent + 0.5
    u = (1.0 / exponent) / total
    w = 0.5 / total
    return np.array([u ** (-1.0 / exponent), u ** (-1.0 / exponent), w**-0.5])


def enclosing_scale(
    points: ArrayLike,
    center: ArrayLike,
    semi_axes: ArrayLike,
    exponent: float = 10.0,
    margin: float = 1e-6,
) -> float:
    """Smallest factor ``s`` such that every point is strictly inside the
    superellipsoid with semi-axes ``s * semi_axes``.

    Per point, eq. (1) at scale ``s`` is ``A s^-l + B s^-2`` with ``A`` the x and y
    terms and ``B`` the z term at scale 1; it decreases in ``s``, so the root of
    ``= 1 - margin`` is found by vectorised bisection.

    Parameters
    ----------
    points : (n, 3) float
    center, semi_axes : (3,) float
    exponent
        ``l`` of eq. (1).
    margin
        Points end with a value of at most ``1 - margin``.

    Returns
    -------
    float
        ``s > 0``; below 1 when the SE could shrink.
    """
    p = np.asarray(points, dtype=np.float64).reshape(-1, 3)
    d = np.abs(p - np.asarray(center, dtype=np.float64)) / np.asarray(
        semi_axes, dtype=np.float64
    )  # (n, 3) in units of the semi-axes
    A = d[:, 0] ** exponent + d[:, 1] ** exponent
    B = d[:, 2] ** 2
    target = 1.0 - margin
    lo = np.full(p.shape[0], 1e-6)
    hi = np.ones(p.shape[0])
    # grow hi until every point is inside at scale hi
    for _ in range(64):
        out = A * hi**-exponent + B * hi**-2 > target
        if not out.any():
            break
        hi = np.where(out, hi * 2.0, hi)
    for _ in range(60):
        mid = 0.5 * (lo + hi)
        out = A * mid**-exponent + B * mid**-2 > target
        lo = np.where(out, mid, lo)
        hi = np.where(out, hi, mid)
    return float(hi.max()) if p.shape[0] else 0.0
