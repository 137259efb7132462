"""What cameras that all saw one side of an object tell of the rest of it:
whether they did (:func:`one_side`), the crest that runs over its middle
(:func:`crest`), how far its middle lies behind its points
(:func:`behind_the_side`, for the scorers) and the sides they did not see
(:func:`mirror_hidden`, for the search)."""

from __future__ import annotations

import numpy as np
from numpy.typing import NDArray

from wsgrasp.perception.types import Array

__all__ = ["behind_the_side", "crest", "mirror_hidden", "one_side"]


#: cameras whose directions to an object, along the table, all lie within this
#: angle (degrees) of their mean see one side of it ...
ONE_SIDE_DEG = 60.0
#: ... when they look at it from the side: their direction along the table at
#: least this share of the whole (a camera straight above sees no one side)
FROM_THE_SIDE = 0.3


def behind_the_side(points: Array, mid: Array, n: Array, viewpoints: Array) -> Array:
    """How far ``(3,)`` the middle ``mid`` of an object seen from one side
    alone lies behind where its points ``(no, 3)`` put it, along the cameras'
    mean direction along the table (normal ``n``): to the depth of its crest
    (:func:`crest`; median), never nearer the cameras and never so deep that
    the object would be deeper than it is wide; zeros where the cameras
    ``viewpoints`` ``(k, 3)`` see several sides of it or look down on it from
    above (:func:`one_side`).

    One camera sees the near side of a ball, a can or a cup: the middle of the
    points lies between the camera and the object's middle. The top of a
    resting object, which a camera above the table sees, runs over its middle:
    a ball's or a can's crest, a box's or a cup's whole top face or rim."""
    mean = one_side(mid, n, viewpoints)
    if mean is None:
        return np.zeros(3)
    s = (points - mid) @ mean  # (no,) depth from the middle, away from the cameras
    width = float(np.ptp(points @ np.cross(n, mean)))
    depth = float(np.median(s[crest(points, n, mean)]))
    return float(np.clip(depth, 0.0, max(0.0, float(s.min()) + 0.5 * width))) * mean


def one_side(mid: Array, n: Array, viewpoints: Array) -> Array | None:
    """The cameras' mean direction ``(3,)`` along the table (normal ``n``)
    towards an object whose middle is ``mid``, where they all see one side of
    it from the side (within ``ONE_SIDE_DEG`` of that direction, none looking
    down on it from above); None otherwise."""
    d = mid - np.asarray(viewpoints, dtype=np.float64)  # (k, 3) camera to object
    side = d - np.outer(d @ n, n)  # (k, 3) along the table
    length = np.linalg.norm(side, axis=1)
    if not len(d) or np.any(length < FROM_THE_SIDE * np.linalg.norm(d, axis=1)):
        return None
    u = side / length[:, None]
    mean = u.sum(axis=0)
    norm = float(np.linalg.norm(mean))
    if norm < 1e-9:
        return None
    mean /= norm
    if np.any(u @ mean < np.cos(np.radians(ONE_SIDE_DEG))):
        return None
    return np.asarray(mean)


def crest(points: Array, n: Array, mean: Array) -> NDArray[np.bool_]:
    """Which of an object's points ``(no, 3)`` seen along ``mean`` ``(3,)`` (a
    direction along the table, normal ``n``) lie on its crest: within
    ``_CREST`` of the highest point of their slice across that direction."""
    x = points @ np.cross(n, mean)  # (no,) across
    z = points @ n  # (no,) height
    step = max(float(np.ptp(x)) / _SLICES, 1e-6)
    slice_of = np.minimum(((x - x.min()) / step).astype(np.int64), _SLICES - 1)
    top = np.full(_SLICES, -np.inf)
    np.maximum.at(top, slice_of, z)
    return z >= top[slice_of] - _CREST  # type: ignore[no-any-return]


#: slices across the cameras' direction in :func:`behind_the_side` ...
_SLICES = 16
#: ... and how far (m) below a slice's highest point its crest reaches
_CREST = 0.005


def mirror_hidden(points: Array, normal: Array, viewpoints: Array) -> Array:
    """``points`` ``(n, 3)`` and, where every camera ``viewpoints`` ``(k, 3)``
    saw one side of the object alone (:func:`one_side`), the same points
    turned half a turn about the vertical (the table's unit ``normal``
    ``(3,)``) through its middle: ``(2 n, 3)``. The middle lies halfway
    along the cameras' direction between the nearest and the farthest points
    of its crest (:func:`crest`: a box's or a can's
    top, a ball's ridge, which run over its middle) and, across that
    direction, halfway between the extremes of what they saw: where a box's,
    a can's or a ball's middle lies seen from anywhere. Halfway between the
    extremes, not at their mean: a camera samples the faces nearer it more
    densely (a box's top face's mean lay 3-4 mm nearer the camera)."""
    if not len(viewpoints) or len(points) < 4:
        return points
    n = np.asarray(normal, dtype=np.float64)
    mean = one_side(points.mean(axis=0), n, viewpoints)
    if mean is None:
        return points
    across = np.cross(n, mean)  # (3,) along the table, across the view
    s, x = points @ mean, points @ across
    top = s[crest(points, n, mean)]
    middle = (0.5 * (top.min() + top.max())) * mean + (
        0.5 * (x.min() + x.max())
    ) * across
    d = points - np.outer(points @ n, n) - middle  # (n, 3) along the table
    return np.concatenate([points, points - 2.0 * d])
