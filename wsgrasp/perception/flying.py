"""Flying pixels: depth returns that hang in the air along an object's outline.

At a depth edge a time-of-flight camera mixes the near and the far return, and a
stereo matcher smears the edge: the pixels along it come back with depths
anywhere between the object and the surface behind it. Their points form a veil
along the camera's rays from the object's outline to the table; merged into the
object's cluster they make it look larger than it is and put points where there
is nothing to grasp.

A view that is still its camera's image (points in the camera frame, each on its
pixel's ray, as a depth camera's driver deprojects them) gives its pixels back:
the directions ``x / z`` and ``y / z`` of its points lie on a grid whose pitch
is one pixel (in ROS's ``camera_link`` axes, x forward, y left and z up, the
directions ``y / x`` and ``z / x``; a pitch per axis where the camera's ``fx``
and ``fy`` differ). :func:`flying_mask` rebuilds that grid and
drops the points that lie *between* their neighbours along a row or a column of
the image: one neighbour (within two pixels) nearer and the opposite one
farther, each by more than a surface steps in depth unless it is seen within
:data:`GRAZING_DEG` of its rays (such a surface's depths are no better than the
veil's), and the pixels next to them along their row and column (the rest of a
veil two pixels wide, or the outline's last pixel). A surface's own edge pixel
has a far neighbour on one side only and stays where no flying pixel lies beside
it; so do the points of a view that is no image (a registered, resampled or
shuffled cloud), which :func:`pixel_grid` does not recognise. On ``scene
synth``'s views of a box, a can and a ball (one camera of 320 x 240 at 30, 45
and 60 degrees, every edge pixel flying) it drops about 90 % of the veil
standing more than 5 mm off the object or the table, and of clean views a
handful of points on curved outlines seen edge-on (``tests/test_flying.py``). It
costs about 2 ms for a view of 50,000 points.
"""

from __future__ import annotations

import threading
from collections import OrderedDict
from dataclasses import dataclass

import numpy as np
import xxhash
from numpy.typing import NDArray
from scipy.spatial import cKDTree

from wsgrasp.perception.types import Scene

Array = NDArray[np.float64]

#: a surface seen this close to along its ray (degrees) steps in depth, pixel
#: to pixel, by less than the jump that marks a point between two surfaces
GRAZING_DEG = 7.0
#: ... and the jump is never below this (m), well above a depth camera's noise
#: at the ranges a grasp is planned at (millimetres at 0.5-1 m)
MIN_JUMP = 0.01
#: neighbours this many pixels away along a row or column are compared
REACH = 2
#: about as many points measure the pixel pitch, in the middle of the image
_PITCH_SAMPLE = 400
#: share of the points that must lie within a tenth of a pixel of the grid
_ON_GRID = 0.9
#: pixels whose two pitches differ by less than this share are square: one
#: pitch (the nearest neighbours' distance) serves both axes
_SQUARE = 1e-3
#: the largest image rebuilt (pixels), far above any depth camera's
_MAX_PIXELS = 16_000_000
#: ROS's camera_link axes (x forward, y left, z up) into the optical frame's
#: (z forward, x right, y down)
_LINK_TO_OPTICAL = np.array([[0.0, -1.0, 0.0], [0.0, 0.0, -1.0], [1.0, 0.0, 0.0]])


@dataclass(frozen=True)
class PixelGrid:
    """Each point's pixel: column ``u`` and row ``v`` (``(n,)`` int), in an
    image ``shape`` (rows, columns), the grid's ``pitch`` (radians, about), and
    each point's ``depth`` (m) along the camera's axis."""

    u: NDArray[np.int64]
    v: NDArray[np.int64]
    shape: tuple[int, int]
    pitch: float
    depth: Array


#: the last few views' grids, by their points' shape and XXH3: a plan asks for a
#: view's grid twice (its camera, :meth:`Scene.viewpoints`, and its flying
#: pixels), and building it takes 2.7 ms for a 640 x 480 view against 0.23 ms
#: to hash its points (the 2-core machine; franka_hand's plan on one such view,
#: medians of 15 alternating: 32.1 ms building it twice, 29.8 ms once)
_GRIDS: OrderedDict[tuple[tuple[int, ...], int], PixelGrid | None] = OrderedDict()
_GRIDS_KEPT = 3
_GRIDS_LOCK = threading.Lock()


def pixel_grid(points_camera: Array) -> PixelGrid | None:
    """The pixel of each point ``(n, 3)`` of a view in its camera frame (the
    optical frame's axes, z forward, or ROS's ``camera_link``'s, x forward), or
    None when its directions lie on no regular grid (not an image, or too few
    points). The grid's arrays are read-only: the last few are kept."""
    p = np.ascontiguousarray(points_camera, dtype=np.float64)
    # no image has points behind its camera along both axes: a merged or moved
    # cloud is told apart before anything is hashed or built
    optical = len(p) >= _PITCH_SAMPLE and _all_positive(p[:, 2])
    link = len(p) >= _PITCH_SAMPLE and _all_positive(p[:, 0])
    if not (optical or link):
        return None
    key = (p.shape, xxhash.xxh3_64_intdigest(p.reshape(-1).view(np.uint8).data))
    with _GRIDS_LOCK:
        if key in _GRIDS:
            _GRIDS.move_to_end(key)
            return _GRIDS[key]
    grid = _grid(p) if optical else None
    if grid is None and link:
        grid = _grid(p @ _LINK_TO_OPTICAL.T)
    if grid is not None:
        for a in (grid.u, grid.v, grid.depth):
            a.setflags(write=False)
    with _GRIDS_LOCK:
        _GRIDS[key] = grid
        while len(_GRIDS) > _GRIDS_KEPT:
            _GRIDS.popitem(last=False)
    return grid


def _all_positive(values: Array) -> bool:
    """Whether every one of ``values`` ``(n,)`` is above 0, from their first
    few where one of those is not: a plan asks twice of a merged cloud, whose
    points lie on both sides of every axis (box_upright's 101,213: 41 us a
    column, four columns a plan, against 2 us)."""
    if not bool((values[:_PREFIX] > 0).all()):
        return False
    return bool((values > 0).all())


#: :func:`_all_positive` looks at this many values first
_PREFIX = 64


def _grid(p: Array) -> PixelGrid | None:
    """:func:`pixel_grid` of points ``(n, 3)`` in the optical frame's axes, all
    in front of the camera."""
    z = p[:, 2]
    a, b = p[:, 0] / z, p[:, 1] / z
    # the pitch: the nearest neighbours' distance in a patch of the image, the
    # points whose directions lie nearest the mean direction (where a lens's
    # distortion bends the grid least)
    ma, mb = float(a.mean()), float(b.mean())
    spread = np.sqrt(np.ptp(a) * np.ptp(b) / len(p))  # the pitch, if dense
    half = spread * np.sqrt(_PITCH_SAMPLE) / 2
    patch = np.flatnonzero((np.abs(a - ma) < half) & (np.abs(b - mb) < half))
    if len(patch) < _PITCH_SAMPLE // 4:
        return None
    ab = np.column_stack([a[patch], b[patch]])
    dist, near = cKDTree(ab).query(ab, k=5)
    pitch = float(np.median(dist[:, 1]))
    if not pitch > 0:
        return None
    # a camera whose pixels are not square (fx and fy apart: TUM RGB-D's fr3
    # camera by 0.7 %, which put most of its 640 x 480 image off a square grid)
    # has a pitch per axis: its four nearest neighbours' steps along a row,
    # and along a column
    step = np.abs(ab[near[:, 1:]] - ab[:, None]).reshape(-1, 2)  # (4 k, 2)
    row, column = step[:, 0] > 2 * step[:, 1], step[:, 1] > 2 * step[:, 0]
    pa, pb = pitch, pitch
    if row.any() and column.any():
        pa, pb = float(np.median(step[row, 0])), float(np.median(step[column, 1]))
        if not (pa > 0 and pb > 0) or abs(pa / pb - 1.0) < _SQUARE:
            pa, pb = pitch, pitch
    # whole pixels from a point of the patch: the grid holds there
    ga, gb = (a - a[patch[0]]) / pa, (b - b[patch[0]]) / pb
    u, v = np.rint(ga).astype(np.int64), np.rint(gb).astype(np.int64)
    off = np.maximum(np.abs(ga[patch] - u[patch]), np.abs(gb[patch] - v[patch]))
    if float((off < 0.1).mean()) < _ON_GRID:
        return None
    u -= u.min()
    v -= v.min()
    shape = (int(v.max()) + 1, int(u.max()) + 1)
    if shape[0] * shape[1] > _MAX_PIXELS:
        return None
    return PixelGrid(u, v, shape, pitch, z)


def flying_mask(points_camera: Array) -> NDArray[np.bool_]:
    """Which points ``(n, 3)`` of a view in its camera frame are flying pixels
    (see the module docstring); none when the view is not an image."""
    p = np.asarray(points_camera, dtype=np.float64)
    grid = pixel_grid(p)
    if grid is None:
        return np.zeros(len(p), dtype=bool)
    h, w = grid.shape
    R = REACH
    padded = np.full((h + 2 * R, w + 2 * R), np.nan, dtype=np.float32)
    depth = padded[R : R + h, R : R + w]  # a view: nan where nothing was seen
    depth[grid.v, grid.u] = grid.depth
    flat = padded.ravel()
    # a surface at GRAZING_DEG to its rays steps this far in depth per pixel;
    # k pixels away, k times as far
    per_metre = grid.pitch / np.tan(np.radians(GRAZING_DEG))
    flying = np.zeros(grid.shape, dtype=bool)
    with np.errstate(invalid="ignore"):  # a comparison with nan is False
        for axis, step in ((1, 1), (0, w + 2 * R)):  # along a row, a column
            # a point between two others within R pixels has neighbours more
            # than MIN_JUMP apart among those R pixels on either side: only
            # the pixels near such a pair are tested
            pair = np.abs(np.diff(depth, axis=axis)) > MIN_JUMP
            pad = [(0, 0), (0, 0)]
            pad[axis] = (R, R)
            pair = np.pad(pair, pad)
            near = np.zeros(grid.shape, dtype=bool)
            for k in range(2 * R):
                near |= pair[k : k + h, :] if axis == 0 else pair[:, k : k + w]
            rows, cols = np.nonzero(near)
            at = (rows + R) * (w + 2 * R) + (cols + R)  # in the padded image
            z = flat[at]
            jump = np.maximum(MIN_JUMP, z * per_metre)
            nearer = np.zeros((2, len(at)), dtype=bool)  # before, after
            farther = np.zeros((2, len(at)), dtype=bool)
            for k in range(1, R + 1):
                for side, sign in enumerate((-1, 1)):
                    other = flat[at + sign * k * step]
                    nearer[side] |= other < z - k * jump
                    farther[side] |= other > z + k * jump
            between = (nearer[0] & farther[1]) | (farther[0] & nearer[1])
            flying[rows[between], cols[between]] = True
    # a veil two pixels wide leaves the pixel beside a flying one within a
    # jump of it, nearer the object or the table: it goes too
    out = flying.copy()
    out[:, 1:] |= flying[:, :-1]
    out[:, :-1] |= flying[:, 1:]
    out[1:, :] |= flying[:-1, :]
    out[:-1, :] |= flying[1:, :]
    return out[grid.v, grid.u]  # type: ignore[no-any-return]


def flying_points(scene: Scene) -> NDArray[np.bool_] | None:
    """Which of ``scene.points`` are flying pixels of its views
    (:func:`flying_mask` of each), or None where none is or the points are not
    the views' merge, view after view (as every loader and recording gives)."""
    sizes = [len(v.points) for v in scene.views]
    if not scene.views or sum(sizes) != len(scene.points):
        return None
    mask = np.concatenate([flying_mask(v.points) for v in scene.views])
    return mask if mask.any() else None


def without_flying(scene: Scene, drop: bool = True) -> tuple[Array, Array]:
    """``scene.points`` less its views' flying pixels (:func:`flying_points`)
    where ``drop``, and the points dropped ``(m, 3)``."""
    mask = flying_points(scene) if drop else None
    if mask is None:
        return scene.points, scene.points[:0]
    # rows by index: a boolean mask over (n, 3) rows copies 4-5 times slower
    # (204,000 points: 4.8 against 1.0 ms)
    p = scene.points
    return p.take(np.flatnonzero(~mask), axis=0), p.take(np.flatnonzero(mask), axis=0)
