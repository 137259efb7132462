"""The finger test of the dense search as one compiled loop (optional: numba).

Per candidate and object point, the depth grid's verdict at the nearest node
(``_dense_grid.FingerDepth``) and, for a finger it leaves unsure, the sphere grid
of ``FingerSpheres`` (its cell status, then the spheres listed for a partial cell)
with the arithmetic of ``FingerSpheres.holding_coordinates``: the numpy path's
answers, without its temporary arrays. One thread: on a machine shared with
other work, numba's thread pools cost more than they gave (measured on 2 cores
under load: the dense entries 20-40 % slower with 2 threads than with 1). numba
is an optional dependency
(``pip install 'wsgrasp[fast]'``); without it :func:`available` is False and the
dense search keeps its numpy path.
``_held_loop`` is the plain Python function numba compiles, so tests hold its
logic to the numpy path with or without numba.
"""

from __future__ import annotations

import os
from collections.abc import Callable
from typing import Any

import numpy as np
from numpy.typing import NDArray

from wsgrasp.geometry._superellipsoid import _power as superellipsoid_power
from wsgrasp.planning._dense_grid import FingerDepth
from wsgrasp.planning.spheres import FingerSpheres

__all__ = [
    "held_by_fingers",
    "count_by_fingers",
    "body_hits",
    "kernel_arrays",
    "available",
]

Array = NDArray[np.float64]

try:  # pragma: no cover - depends on the environment
    if os.environ.get("WSGRASP_NUMBA", "1") == "0":
        raise ImportError("numba disabled by WSGRASP_NUMBA=0")
    import numba
except ImportError:
    numba = None  # type: ignore[assignment]  # (when numba is installed)

_FULL, _PARTIAL = 1, 2


def _held_loop(
    Q: Array,
    ol: NDArray[np.int64],
    u: Array,
    d_origin: Array,
    d_inv_cell: float,
    d_last: Array,
    d_strides: Array,
    d_codes: NDArray[np.uint8],
    origin: Array,
    inv_cell: float,
    last: Array,
    strides: Array,
    status: NDArray[np.uint8],
    cell_index: NDArray[np.int64],
    start: NDArray[np.int64],
    count: NDArray[np.int64],
    sphere: NDArray[np.int64],
    centers: Array,
    radii: Array,
    held: NDArray[np.bool_],
    dest: NDArray[np.int64],
    counts: NDArray[np.int64],
) -> None:  # pragma: no cover - run compiled, or by the tests on tiny inputs
    """``held[dest[i], j, f]``: point ``j`` of candidate ``i`` (``Q[ol[i], :, j]
    - u[i]``) strictly inside a sphere of finger ``f``; ``counts[i, f]`` their
    number. ``d_*``: the depth grid's two bits per finger at the point's nearest
    node (``_dense_grid.FingerDepth``) decide first; ``cell_index`` (nf, cells):
    compact partial-cell id per finger, -1 elsewhere; ``start``, ``count`` index
    ``sphere`` (global sphere ids into ``centers``, ``radii``) per compact id."""
    m = ol.shape[0]
    n = Q.shape[2]
    nf = status.shape[1]
    for i in range(m):
        r = ol[i]
        row = dest[i]
        for j in range(n):
            for f in range(nf):
                held[row, j, f] = False
        ux, uy, uz = u[i, 0], u[i, 1], u[i, 2]
        for j in range(n):
            x = Q[r, 0, j] - ux
            y = Q[r, 1, j] - uy
            z = Q[r, 2, j] - uz
            # the nearest node of the depth grid (clipped onto its border, whose
            # nodes are far from every sphere)
            nx = min(
                max(np.floor((x - d_origin[0]) * d_inv_cell + 0.5), 0.0), d_last[0]
            )
            ny = min(
                max(np.floor((y - d_origin[1]) * d_inv_cell + 0.5), 0.0), d_last[1]
            )
            nz = min(
                max(np.floor((z - d_origin[2]) * d_inv_cell + 0.5), 0.0), d_last[2]
            )
            code = d_codes[
                int(nx * d_strides[0] + ny * d_strides[1] + nz * d_strides[2])
            ]
            unsure = False
            for f in range(nf):
                if (code >> (2 * f)) & 1:
                    held[row, j, f] = True
                    counts[i, f] += 1
                elif (code >> (2 * f + 1)) & 1:
                    unsure = True
            if not unsure:
                continue
            # as holding_coordinates: a float sum of clipped floors × strides
            qx = min(max(np.floor((x - origin[0]) * inv_cell), 0.0), last[0])
            qy = min(max(np.floor((y - origin[1]) * inv_cell), 0.0), last[1])
            qz = min(max(np.floor((z - origin[2]) * inv_cell), 0.0), last[2])
            flat = int(((0.0 + qx * strides[0]) + qy * strides[1]) + qz * strides[2])
            for f in range(nf):
                if not (code >> (2 * f + 1)) & 1:
                    continue  # decided by the depth grid
                st = status[flat, f]
                if st == _FULL:
                    held[row, j, f] = True
                    counts[i, f] += 1
                elif st == _PARTIAL:
                    k = cell_index[f, flat]
                    for t in range(start[k], start[k] + count[k]):
                        s = sphere[t]
                        dx = x - centers[s, 0]
                        dy = y - centers[s, 1]
                        dz = z - centers[s, 2]
                        if dx * dx + dy * dy + dz * dz < radii[s] * radii[s]:
                            held[row, j, f] = True
                            counts[i, f] += 1
                            break


def _count_loop(
    Q: Array,
    ol: NDArray[np.int64],
    u: Array,
    d_origin: Array,
    d_inv_cell: float,
    d_last: Array,
    d_strides: Array,
    d_codes: NDArray[np.uint8],
    packed: NDArray[np.int64],
    start: NDArray[np.int32],
    listed: NDArray[np.int32],
    centers: Array,
    radii: Array,
    counts: NDArray[np.int64],
) -> None:  # pragma: no cover - run compiled, or by the tests on tiny inputs
    """``counts[i, f]``: the points of candidate ``i`` (``Q[ol[i], :, j] -
    u[i]``) strictly inside a sphere of finger ``f`` (at most 4 fingers, fewer
    than 2**16 points).

    The depth grid's code at each point's nearest node decides first
    (``packed[code]``: finger ``f``'s held bit at bit ``16 f``, so one sum
    counts every finger); for a finger it leaves unsure, the spheres listed at
    that node (``FingerDepth.compact_lists``: from ``start[node]``, per unsure
    finger in order, sphere ids ending at -1) with the arithmetic of
    ``FingerSpheres.holding_coordinates``.

    Per candidate, three loops: the nearest nodes of its points, from the
    points in node units (once per row of ``Q``; ``ol`` nondecreasing reuses
    them) less the translation in node units, which rounds differently from
    ``(Q - u - origin) / cell`` by about 1e-14 of a node, far inside the grid's
    margin; their codes, noting the unsure points without a branch; then the
    unsure points' listed spheres, each list read to its end. On one
    2,500-candidate chunk of the Allegro's dense search (800 points): 60-95 ms
    with :func:`_held_loop`, 19-22 ms with a single loop over the points and
    the lists read to their first holding sphere, 12-16 ms so."""
    m = ol.shape[0]
    n = Q.shape[2]
    nf = counts.shape[1]
    Qn = np.empty((3, n))  # the row's points in node units, offset half a node
    node = np.empty(n, dtype=np.int64)
    unsure = np.empty(n, dtype=np.int64)
    prev = -1
    for i in range(m):
        r = ol[i]
        if r != prev:
            for k in range(3):
                for j in range(n):
                    Qn[k, j] = (Q[r, k, j] - d_origin[k]) * d_inv_cell + 0.5
            prev = r
        ux, uy, uz = u[i, 0], u[i, 1], u[i, 2]
        vx, vy, vz = ux * d_inv_cell, uy * d_inv_cell, uz * d_inv_cell
        for j in range(n):  # clipped onto the border, far from every sphere
            nx = min(max(np.floor(Qn[0, j] - vx), 0.0), d_last[0])
            ny = min(max(np.floor(Qn[1, j] - vy), 0.0), d_last[1])
            nz = min(max(np.floor(Qn[2, j] - vz), 0.0), d_last[2])
            node[j] = int(nx * d_strides[0] + ny * d_strides[1] + nz * d_strides[2])
        total = np.int64(0)
        nu = 0
        for j in range(n):
            code = d_codes[node[j]]
            total += packed[code]
            unsure[nu] = j
            nu += (code & 0xAA) != 0  # some finger unsure: keep the point
        for t in range(nu):
            j = unsure[t]
            code = d_codes[node[j]]
            x = Q[r, 0, j] - ux
            y = Q[r, 1, j] - uy
            z = Q[r, 2, j] - uz
            at = start[node[j]]
            for f in range(nf):
                if not (code >> (2 * f + 1)) & 1:
                    continue
                held = False
                s = listed[at]
                while s >= 0:
                    dx = x - centers[s, 0]
                    dy = y - centers[s, 1]
                    dz = z - centers[s, 2]
                    held |= dx * dx + dy * dy + dz * dz < radii[s] * radii[s]
                    at += 1
                    s = listed[at]
                at += 1  # past the terminator
                total += np.int64(held) << (16 * f)
        for f in range(nf):
            counts[i, f] = (total >> (16 * f)) & 0xFFFF


_compiled_count: Callable[..., None] | None = (
    numba.njit(cache=True, nogil=True)(_count_loop) if numba is not None else None
)


def count_by_fingers(
    depth: FingerDepth,
    Q: Array,
    ol: NDArray[np.int64],
    u: Array,
    loop: Callable[..., None] | None = None,
) -> NDArray[np.int64]:
    """Points each finger's spheres hold, per candidate (parameters as
    :func:`held_by_fingers`, fewer than 2**16 points; ``ol`` nondecreasing is
    fastest): (m, nf) int."""
    run = loop or _compiled_count
    if run is None:
        raise RuntimeError("numba is not installed: pip install 'wsgrasp[fast]'")
    _, _, centers, radii = depth.sphere_lists()
    start, listed = depth.compact_lists()
    if Q.shape[2] >= 2**16:
        raise ValueError(
            f"count_by_fingers counts below 2**16 points, got {Q.shape[2]}"
        )
    counts = np.zeros((len(ol), depth.num_fingers), dtype=np.int64)
    run(
        np.ascontiguousarray(Q, dtype=np.float64),
        np.ascontiguousarray(ol, dtype=np.int64),
        np.ascontiguousarray(u, dtype=np.float64),
        np.asarray(depth.origin, dtype=np.float64),
        float(1.0 / depth.cell),
        np.asarray(depth.shape - 1, dtype=np.float64),
        np.asarray(depth.strides, dtype=np.float64),
        depth.codes,
        depth.packed_held,
        start,
        listed,
        np.ascontiguousarray(centers, dtype=np.float64),
        np.ascontiguousarray(radii, dtype=np.float64),
        counts,
    )
    return counts


#: ``x ** exponent`` as ``wsgrasp.geometry``'s superellipsoid test computes it
#: (repeated squaring for 2, 4 and 10): the same function, on scalars here
_power = superellipsoid_power


if numba is not None:  # pragma: no cover - depends on the environment
    _power = numba.njit(inline="always")(_power)


def _body_loop(
    Q: Array,
    ol: NDArray[np.int64],
    u: Array,
    centers: Array,
    semi_axes: Array,
    exponent: float,
    hit: NDArray[np.bool_],
) -> None:  # pragma: no cover - run compiled, or by the tests on tiny inputs
    """``hit[i]``: some point of candidate ``i`` (``Q[ol[i], :, j] - u[i]``)
    strictly inside some superellipsoid, with the arithmetic of
    ``coordinates_in_superellipsoids``; stops at the first such point.

    A superellipsoid whose box the candidate's object box (its row's extremes
    less ``u``) lies apart from is skipped: every point's ``|x - c| < a`` test
    along that axis fails (the rounding of ``Q - u`` and of ``- c`` keeps the
    order of the coordinates). Of the Allegro's dense candidates, those clear of
    every body are tested against the few bodies near the object only."""
    m = ol.shape[0]
    n = Q.shape[2]
    ne = centers.shape[0]
    lo = np.empty(3)  # the row's object box, gripper axes, untranslated
    hi = np.empty(3)
    near = np.empty(ne, dtype=np.int64)  # the bodies the candidate's box meets
    prev = -1
    # where the scan starts: the point that put the last candidate in a body
    # (the candidates come by orientation, a sample's neighbours next to it,
    # so the same point is often inside again: the Allegro's dense hits take
    # half the time, 0.52 -> 0.24 ms per 900-candidate chunk)
    first = 0
    for i in range(m):
        r = ol[i]
        if r != prev:
            for k in range(3):
                lo[k] = hi[k] = Q[r, k, 0] if n else 0.0
                for j in range(n):
                    lo[k] = min(lo[k], Q[r, k, j])
                    hi[k] = max(hi[k], Q[r, k, j])
            prev = r
        ux, uy, uz = u[i, 0], u[i, 1], u[i, 2]
        nn = 0
        for e in range(ne):
            apart = False
            for k in range(3):
                uk = ux if k == 0 else (uy if k == 1 else uz)
                if (lo[k] - uk) - centers[e, k] >= semi_axes[e, k]:
                    apart = True
                if centers[e, k] - (hi[k] - uk) >= semi_axes[e, k]:
                    apart = True
            if not apart:
                near[nn] = e
                nn += 1
        found = False
        if nn == 0:
            hit[i] = False
            continue
        for step in range(n):  # every point once, from the last hit's on
            j = first + step
            if j >= n:
                j -= n
            x = Q[r, 0, j] - ux
            y = Q[r, 1, j] - uy
            z = Q[r, 2, j] - uz
            for t in range(nn):
                e = near[t]
                dx = abs(x - centers[e, 0])
                if not dx < semi_axes[e, 0]:
                    continue
                dy = abs(y - centers[e, 1])
                if not dy < semi_axes[e, 1]:
                    continue
                dz = abs(z - centers[e, 2])
                if not dz < semi_axes[e, 2]:
                    continue
                c = dz / semi_axes[e, 2]
                value = (
                    _power(dx / semi_axes[e, 0], exponent)
                    + _power(dy / semi_axes[e, 1], exponent)
                    + c * c
                )
                if value < 1.0:
                    found = True
                    break
            if found:
                first = j
                break
        hit[i] = found


_compiled_body: Callable[..., None] | None = (
    numba.njit(cache=True, nogil=True)(_body_loop) if numba is not None else None
)


def body_hits(
    Q: Array,
    ol: NDArray[np.int64],
    u: Array,
    centers: Array,
    semi_axes: Array,
    exponent: float,
    loop: Callable[..., None] | None = None,
) -> NDArray[np.bool_]:
    """Whether some object point lies inside some body superellipsoid, per
    candidate (``Q``, ``ol``, ``u`` as in :func:`held_by_fingers`): (m,) bool."""
    run = loop or _compiled_body
    if run is None:
        raise RuntimeError("numba is not installed: pip install 'wsgrasp[fast]'")
    hit = np.zeros(len(ol), dtype=bool)
    run(
        np.ascontiguousarray(Q, dtype=np.float64),
        np.ascontiguousarray(ol, dtype=np.int64),
        np.ascontiguousarray(u, dtype=np.float64),
        np.ascontiguousarray(centers, dtype=np.float64),
        np.ascontiguousarray(semi_axes, dtype=np.float64),
        float(exponent),
        hit,
    )
    return hit


_compiled: Callable[..., None] | None = (
    numba.njit(cache=True, nogil=True)(_held_loop) if numba is not None else None
)


def available() -> bool:
    """Whether the compiled finger test is in use (numba importable)."""
    return _compiled is not None


def kernel_arrays(spheres: FingerSpheres, depth: FingerDepth) -> tuple[Any, ...]:
    """The arrays of ``depth`` and ``spheres`` the loop reads, in its argument
    order from ``d_origin`` to ``radii``; built once per index and kept."""
    got = _ARRAYS.get(id(spheres))
    if got is not None and got[0] is spheres:
        return got[1]
    fingers = spheres._fingers  # (centers, radii, _PartialCells) per finger
    nf = len(fingers)
    n_cells = len(spheres.status)
    cell_index = np.full((nf, n_cells), -1, dtype=np.int64)
    starts: list[NDArray[np.int64]] = []
    counts: list[NDArray[np.int64]] = []
    ids: list[NDArray[np.int64]] = []
    centers: list[Array] = []
    radii: list[Array] = []
    n_ids = n_spheres = n_listed = 0
    for f, (c, r, cells) in enumerate(fingers):
        has = cells.index >= 0
        cell_index[f, has] = cells.index[has] + n_ids
        starts.append(cells.start + n_listed)
        counts.append(cells.count)
        ids.append(cells.sphere + n_spheres)
        centers.append(c)
        radii.append(r)
        n_ids += len(cells.start)
        n_listed += len(cells.sphere)
        n_spheres += len(r)
    arrays = (
        np.asarray(depth.origin, dtype=np.float64),
        float(1.0 / depth.cell),
        np.asarray(depth.shape - 1, dtype=np.float64),
        np.asarray(depth.strides, dtype=np.float64),
        depth.codes,
        np.asarray(spheres.origin, dtype=np.float64),
        float(1.0 / spheres.cell),
        np.asarray(spheres._last, dtype=np.float64),
        np.asarray(spheres._strides, dtype=np.float64),
        np.ascontiguousarray(spheres.status),
        cell_index,
        np.concatenate(starts).astype(np.int64),
        np.concatenate(counts).astype(np.int64),
        np.concatenate(ids).astype(np.int64),
        np.ascontiguousarray(np.concatenate(centers), dtype=np.float64),
        np.ascontiguousarray(np.concatenate(radii), dtype=np.float64),
    )
    _ARRAYS.clear()  # one gripper at a time is the common case
    _ARRAYS[id(spheres)] = (spheres, arrays)
    return arrays


_ARRAYS: dict[int, tuple[FingerSpheres, tuple[Any, ...]]] = {}


def held_by_fingers(
    spheres: FingerSpheres,
    depth: FingerDepth,
    Q: Array,
    ol: NDArray[np.int64],
    u: Array,
    out: NDArray[np.bool_] | None = None,
    dest: NDArray[np.int64] | None = None,
    loop: Callable[..., None] | None = None,
) -> NDArray[np.int64]:
    """Which object points each finger's spheres hold, per candidate.

    Parameters
    ----------
    spheres : FingerSpheres
    depth : FingerDepth
        Of the same gripper.
    Q : (q, 3, n) float
        Object points per orientation, gripper axes, untranslated.
    ol : (m,) int
        Each candidate's row of ``Q``.
    u : (m, 3) float
        Each candidate's translation (its points are ``Q[ol] - u``).
    out : (k, n, nf) bool, optional
        Where the holdings go: candidate ``i`` to row ``dest[i]`` (by default a
        new ``(m, n, nf)`` array, row ``i``).
    dest : (m,) int, optional
    loop : callable, optional
        The loop to run: the compiled one by default, ``_held_loop`` itself in
        tests.

    Returns
    -------
    counts : (m, nf) int
        Points held per candidate and finger.
    """
    run = loop or _compiled
    if run is None:
        raise RuntimeError("numba is not installed: pip install 'wsgrasp[fast]'")
    m, n, nf = len(ol), Q.shape[2], spheres.num_fingers
    if out is None:
        out = np.empty((m, n, nf), dtype=bool)
    if dest is None:
        dest = np.arange(m, dtype=np.int64)
    counts = np.zeros((m, nf), dtype=np.int64)
    run(
        np.ascontiguousarray(Q, dtype=np.float64),
        np.ascontiguousarray(ol, dtype=np.int64),
        np.ascontiguousarray(u, dtype=np.float64),
        *kernel_arrays(spheres, depth),
        out,
        np.ascontiguousarray(dest, dtype=np.int64),
        counts,
    )
    return counts
