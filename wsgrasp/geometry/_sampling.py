"""Point-set sampling kernels: farthest-point thinning, box grids, SE surfaces."""

from __future__ import annotations

import numpy as np
from numpy.typing import ArrayLike, NDArray

Array = NDArray[np.float64]


def farthest_point_indices(points: ArrayLike, count: int, start: int = 0) -> NDArray:
    """Indices of ``count`` points picked by farthest-point sampling.

    Deterministic: starts at ``start`` and repeatedly adds the point farthest from
    those already picked, so the result is spread evenly over the set.

    Parameters
    ----------
    points : (n, 3) float
    count
        Number to pick, ``1 <= count <= n``.
    start
        Index of the first point.

    Returns
    -------
    (count,) int
    """
    p = np.asarray(points, dtype=np.float64)
    n = p.shape[0]
    if not 1 <= count <= n:
        raise ValueError(f"count must be in [1, {n}], got {count}")
    x, y, z = (np.ascontiguousarray(p[:, k]) for k in range(3))  # 3 x (n,)
    picked = np.empty(count, dtype=np.int64)
    d2 = np.full(n, np.inf)  # squared distance to the picked set
    tmp, acc = np.empty(n), np.empty(n)
    nxt = start
    for i in range(count):
        picked[i] = nxt
        np.subtract(x, x[nxt], out=tmp)
        np.multiply(tmp, tmp, out=acc)
        np.subtract(y, y[nxt], out=tmp)
        acc += tmp * tmp
        np.subtract(z, z[nxt], out=tmp)
        acc += tmp * tmp
        np.minimum(d2, acc, out=d2)
        nxt = int(np.argmax(d2))
    return picked


def box_grid_points(center: ArrayLike, size: ArrayLike, samples: ArrayLike) -> Array:
    """Points of a regular grid filling an axis-aligned box (faces included).

    Parameters
    ----------
    center, size : (3,) float
        Box centre and full extents; an extent of 0 gives one layer.
    samples : int or (3,) int
        Points per edge.

    Returns
    -------
    (m, 3) float
        Without duplicates (an edge of zero extent contributes one layer).
    """
    c = np.asarray(center, dtype=np.float64)
    s = np.asarray(size, dtype=np.float64)
    n = np.broadcast_to(np.asarray(samples, dtype=np.int64), (3,))
    axes = [
        np.linspace(ci - si / 2, ci + si / 2, int(ni) if si > 0 else 1)
        for ci, si, ni in zip(c, s, n, strict=True)
    ]
    mesh = np.meshgrid(*axes, indexing="ij")
    return np.stack([m.reshape(-1) for m in mesh], axis=-1)  # (m, 3)


def superellipsoid_surface(
    center: ArrayLike,
    semi_axes: ArrayLike,
    exponent: float = 10.0,
    n_around: int = 24,
    n_height: int = 12,
) -> tuple[Array, Array, Array]:
    """A parametric grid on the surface of eq. (1), for drawing.

    With ``z = c s`` for ``s`` in ``[-1, 1]``, the section is
    ``|x/a|^l + |y/b|^l = 1 - s^2``, drawn with the superellipse parametrisation
    ``x = a r sgn(cos w) |cos w|^(2/l)``, ``y = b r sgn(sin w) |sin w|^(2/l)``,
    ``r = (1 - s^2)^(1/l)``.

    Returns
    -------
    X, Y, Z : (n_height, n_around) float
    """
    c = np.asarray(center, dtype=np.float64)
    a, b, cz = np.asarray(semi_axes, dtype=np.float64)
    s = np.linspace(-1.0, 1.0, n_height)[:, None]  # (h, 1)
    w = np.linspace(0.0, 2.0 * np.pi, n_around)[None, :]  # (1, w)
    r = np.clip(1.0 - s * s, 0.0, None) ** (1.0 / exponent)
    cw, sw = np.cos(w), np.sin(w)
    X = c[0] + a * r * np.sign(cw) * np.abs(cw) ** (2.0 / exponent)
    Y = c[1] + b * r * np.sign(sw) * np.abs(sw) ** (2.0 / exponent)
    Z = c[2] + cz * s * np.ones_like(w)
    return X, Y, Z
